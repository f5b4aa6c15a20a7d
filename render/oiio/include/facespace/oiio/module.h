// OpenImageIO, loaded on first use from its own module (libfacespace_oiio.so). Linked into the
// executable, OpenImageIO and the ~250 libraries it pulls in (GDAL, OpenCV, DCMTK, ...) cost every
// process 0.42 s at start in relocations alone (0.65 s under ASan), although only some renders use
// it: JPEG, TIFF, EXR, BMP and other formats written, textures read, and text drawn. PNG and WebP,
// the formats most renders ask for, do not need it. The interface speaks plain types only, so the
// module links nothing of ours.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace facespace::oiio {

struct EncodeArgs {
  const char* name = nullptr;  // "image.<ext>": the extension picks the writer.
  bool to_file =
      false;  // Write the file `name` itself rather than through memory (TIFF, see image.cpp).
  int width = 0, height = 0;
  int channels = 4;
  const float* linear = nullptr;         // RGBA, linear: written as half floats (EXR);
  const unsigned char* srgb8 = nullptr;  // else `channels` 8-bit sRGB values a pixel.
  int quality = 0;                       // JPEG quality, 1-100, when > 0.
  bool zip = false;                      // zip compression (TIFF, EXR).
};

struct Decoded {
  int width = 0, height = 0, channels = 0;
  std::vector<float> pixels;  // channels floats a pixel, as stored (sRGB for 8-bit formats).
};

struct Api {
  bool (*encode)(const EncodeArgs& args, std::vector<unsigned char>* out, std::string* error);
  // False with the message for the client ("image size out of range", "cannot decode the image:
  // ..."); an image with a side over `max_side` is refused before its pixels are read.
  bool (*decode)(const unsigned char* bytes, size_t size, const char* name, int max_side,
                 Decoded* out, std::string* error);
};

}  // namespace facespace::oiio

// The module's one entry point.
extern "C" const facespace::oiio::Api* facespace_oiio_api();
