// A dataset's background pictures (dataset.h, LoadBackgroundImages): what the sample's compositing
// shares. Private to api/batch.
#pragma once

#include "facespace/batch/plan.h"

namespace facespace::batch {

// `bg` (the render's size) behind what `image` drew over a transparent background, in linear light:
// 8-bit sRGB or float images alike; the result is opaque.
void BlendOver(picture::Image& image, const BatchPlan::Background& bg);

}  // namespace facespace::batch
