// Shared between render's .cpp files only.
#pragma once

#include <isa-l/igzip_lib.h>

#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "facespace/offscreen/render.h"
#include "facespace/oiio/module.h"

namespace facespace::offscreen {

// An sRGB component (0..1) in linear light.
inline float SrgbToLinear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

// Draws the heatmap's colour bar with its 0 and max labels on the right of the image.
void DrawHeatLegend(picture::Image& image, float max_value);
// The left edge of the legend DrawHeatLegend draws in a width x height image: a heatmap's camera
// frames the model in the part left of it.
int HeatLegendLeft(int width, int height);

// The image as 8-bit sRGB pixels, RGBA (`alpha`) or RGB composited over white: an 8-bit draw's RGBA
// as it is, else converted into `room`; the helper threads' CPU charged to `helper_cpu`.
std::span<const unsigned char> Pixels8(const picture::Image& image, bool alpha,
                                       std::vector<unsigned char>& room, HelperCpu* helper_cpu);

// PNG's pieces: a big-endian word; a chunk (its length, type, data and CRC); the chunk begun at
// `start` (8 bytes left for its length and type, its data after them) closed with its CRC.
void PutBigEndian(std::string& out, uint32_t v);
void Chunk(std::string& out, const char* type, const std::string& data);
void CloseChunk(std::string& out, size_t start, const char* type);

// `z` made ready to deflate with the zlib wrapper by ISA-L's igzip at level 0, as every PNG and EXR
// we write (why level 0: image.cpp); the caller gives the input, output and end of stream.
void StartDeflate(isal_zstream& z);

// OpenImageIO's module (facespace/oiio/module.h), loaded once on first use (thread-safe,
// oiio_load.cpp); nullptr with the reason in `error` when it cannot be.
const oiio::Api* LoadOiio(std::string* error);

// Where LoadOiio will find the module, without loading it (OpenImageIO's start-up cost); empty when
// it is in neither place.
std::string LocateOiio();

}  // namespace facespace::offscreen
