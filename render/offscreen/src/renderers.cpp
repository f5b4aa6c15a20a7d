// The renderers that draw nothing of their own: EncodingRenderer's encoders (every renderer's), and
// NullRenderer's background-only pictures.
#include "facespace/offscreen/render.h"
#include "internal.h"

namespace facespace::offscreen {

Result<std::string> EncodingRenderer::Encode(const picture::Image& image,
                                             picture::ImageFormat format, int quality,
                                             HelperCpu* helper_cpu) const {
  return offscreen::Encode(image, format, quality, helper_cpu);
}

picture::Image EncodingRenderer::Sheet(std::span<const picture::Image> cells,
                                       std::span<const std::string> labels, int columns,
                                       std::array<float, 4> background) const {
  return ContactSheet(cells, labels, columns, background);
}

bool EncodingRenderer::CanDrawText(const std::string& text) const {
  return offscreen::CanDrawText(text);
}

Result<std::string> EncodingRenderer::EncodeData(std::span<const float> values, int width,
                                                 int height, int channels,
                                                 picture::DataPrecision precision) const {
  return EncodeDataExr(values, width, height, channels, precision);
}

Result<std::string> EncodingRenderer::EncodeIds(std::span<const uint16_t> ids, int width,
                                                int height) const {
  return EncodeIdPng(ids, width, height);
}

Result<picture::Image> EncodingRenderer::DecodePicture(std::span<const unsigned char> bytes,
                                                       const std::string& mime_type) const {
  return Decode(bytes, mime_type);
}

Status NullRenderer::Draw(const Rig& rig, const BlendedRig& blended,
                          const picture::RenderOptions& o, picture::Image& out) const {
  if (Status s = CheckDrawInputs(rig, blended, o); !s.ok()) return s;
  out.width = o.width;
  out.height = o.height;
  out.srgb8.clear();
  out.rgba.resize(static_cast<size_t>(o.width) * o.height * 4);
  for (size_t i = 0; i < out.rgba.size(); i += 4) {
    for (int c = 0; c < 3; ++c) out.rgba[i + c] = SrgbToLinear(o.background[c]);
    out.rgba[i + 3] = o.background[3];
  }
  const size_t n =
      o.labels ? static_cast<size_t>(o.width) * o.height : 0;  // Nothing drawn: nothing labelled.
  out.labels.distance.assign(n, 0.0f), out.labels.normal.assign(3 * n, 0.0f),
      out.labels.segment.assign(n, 0);
  return Status::Ok();
}

}  // namespace facespace::offscreen
