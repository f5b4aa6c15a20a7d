// Offscreen rendering of a blended rig (OSMesa, llvmpipe) and image encoding (OpenImageIO).
// GL and OIIO types stay inside render/offscreen/src.
#pragma once

#include <array>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "facespace/engine/blend.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"
#include "facespace/picture/picture.h"

namespace facespace::offscreen {

// A renderer with this module's encoders (Encode, ContactSheet below): what the renderers here
// derive from.
class EncodingRenderer : public picture::Renderer {
 public:
  Result<std::string> Encode(const picture::Image& image, picture::ImageFormat format, int quality,
                             HelperCpu* helper_cpu) const override;
  picture::Image Sheet(std::span<const picture::Image> cells, std::span<const std::string> labels,
                       int columns, std::array<float, 4> background) const override;
  bool CanDrawText(const std::string& text) const override;
  Result<std::string> EncodeData(std::span<const float> values, int width, int height, int channels,
                                 picture::DataPrecision precision) const override;
  Result<std::string> EncodeIds(std::span<const uint16_t> ids, int width,
                                int height) const override;
  Result<picture::Image> DecodePicture(std::span<const unsigned char> bytes,
                                       const std::string& mime_type) const override;
};

// OSMesa (llvmpipe, rasterising on one thread per core): draws with a GL context leased from a
// bounded pool this object owns, so draws run in parallel up to that many and wait beyond it (first
// come, first served). Each context holds its framebuffer: about 20 MB at 1024 x 1024 samples.
class OsMesaRenderer final : public EncodingRenderer {
 public:
  explicit OsMesaRenderer(int max_contexts = 0);  // 0: one per core.
  ~OsMesaRenderer() override;
  OsMesaRenderer(const OsMesaRenderer&) = delete;
  OsMesaRenderer& operator=(const OsMesaRenderer&) = delete;

  Status Draw(const Rig& rig, const BlendedRig& blended, const picture::RenderOptions& options,
              picture::Image& out) const override;
  std::string Info() const override;
  int Concurrency() const override;
  void SetMaxContexts(
      int n);  // 0: one per core. Contexts beyond the new limit are freed when idle.

  class ContextPool;

 private:
  std::unique_ptr<ContextPool> pool_;
};

// Draws no geometry: checks its inputs as every renderer does and fills the image with the
// background. For tests of the layers above render (tests/api) without GL.
class NullRenderer final : public EncodingRenderer {
 public:
  Status Draw(const Rig& rig, const BlendedRig& blended, const picture::RenderOptions& options,
              picture::Image& out) const override;
  std::string Info() const override { return "null renderer (no GL)"; }
  int Concurrency() const override { return 1 << 20; }
};

// Encodes to file bytes: PNG/JPEG/TIFF/WebP as 8-bit sRGB (alpha kept where the format has it),
// EXR as linear half floats. `quality` is JPEG's and WebP's 1..100 (WebP: 100 is lossless).
Result<std::string> Encode(const picture::Image& image, picture::ImageFormat format,
                           int quality = 90, HelperCpu* helper_cpu = nullptr);

// Data as images, written as they are (no colour space): `channels` (1 or 3) floats a pixel, top
// row first, as a ZIP-compressed EXR of 32-bit floats or 16-bit halves (rounded to nearest, ties to
// even), one channel "Y" or R, G, B (depth, normals); and ids as a grey PNG, 8 bits when every id
// is below 256, else 16 (segmentation).
Result<std::string> EncodeDataExr(
    std::span<const float> values, int width, int height, int channels,
    picture::DataPrecision precision = picture::DataPrecision::kFloat);
// IEEE 754 half of `f`, rounded to nearest, ties to even (as F16C's conversion), for EncodeDataExr.
uint16_t HalfOf(float f);
Result<std::string> EncodeIdPng(std::span<const uint16_t> ids, int width, int height);

// Decodes PNG/JPEG/EXR/TIFF/BMP bytes (TGA, which has no magic, when mime_type is "image/x-tga") to
// linear RGBA (for tests and textures).
Result<picture::Image> Decode(std::span<const unsigned char> bytes,
                              const std::string& mime_type = "");

// Empty when the image module (OpenImageIO: formats other than PNG and WebP, textures) is where
// it is looked for, else what is missing. A server asks at start, so a missing module is said at
// once; it is opened on first use.
std::string ImageModuleProblem();

// Opens the image module now rather than at the first texture decode: a process that starts worker
// threads should open it before them. (Opened on the main thread after workers had run,
// LeakSanitizer's exit scan met a garbage dynamic-TLS entry and crashed: batch --jobs 2 with a
// contact sheet under ASan.) Empty on success, else why it cannot be opened.
std::string OpenImageModule();

// Draws UTF-8 text (DejaVu Sans; Noto Sans CJK for what DejaVu lacks; FreeType) in an sRGB colour
// at pixel (x, y) = baseline start. False if no font, or nothing of it lands in the image.
bool DrawText(picture::Image& image, int x, int y, const std::string& text, int size,
              std::array<float, 3> srgb);

// Whether every character of UTF-8 `text` has a glyph in the fonts DrawText uses (Japanese needs
// fonts-noto-cjk): a label that cannot draw is better said another way than as boxes.
bool CanDrawText(const std::string& text);

// A grid of cells, `columns` wide, each labelled under its picture.
picture::Image ContactSheet(std::span<const picture::Image> cells,
                            std::span<const std::string> labels, int columns,
                            std::array<float, 4> background);

}  // namespace facespace::offscreen
