// Shared between render's .cpp files only.
#pragma once

#include "facespace/render/render.h"

namespace facespace::render {

// Draws the heatmap's colour bar with its 0 and max labels on the right of the image.
void DrawHeatLegend(Image& image, float max_value);

}  // namespace facespace::render
