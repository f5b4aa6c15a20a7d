// Shared between render's .cpp files only.
#pragma once

#include "facespace/render/render.h"

namespace facespace::render {

// Draws the heatmap's colour bar with its 0 and max labels on the right of the image.
void DrawHeatLegend(Image& image, float max_value);
// The left edge of the legend DrawHeatLegend draws in a width x height image: a heatmap's camera
// frames the model in the part left of it.
int HeatLegendLeft(int width, int height);

}  // namespace facespace::render
