// Text on images (FreeType; text.cpp says why not OpenImageIO's).
#pragma once

#include <string>

namespace facespace::offscreen {

// The advance of UTF-8 `text` at `size` pixels (the pen's move), -1 without a font.
int TextAdvance(const std::string& text, int size);

// Draws UTF-8 `text` at `size` pixels, the baseline's left end at (x, y), into linear RGBA
// (`width` x `height`, top row first) in `linear` colour, clipped to the image. True when any
// pixel was inked.
bool DrawGlyphs(float* rgba, int width, int height, int x, int y, const std::string& text, int size,
                const float linear[3]);

}  // namespace facespace::offscreen
