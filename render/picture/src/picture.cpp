// The names of views and image formats, and the inputs every renderer refuses.
#include "facespace/picture/picture.h"

#include "facespace/engine/enum_table.h"

namespace facespace::picture {

namespace {

constexpr EnumName<View> kViews[] = {{View::kShaded, "shaded"},
                                     {View::kWireframe, "wireframe"},
                                     {View::kHeatmap, "heatmap"},
                                     {View::kNormals, "normals"},
                                     {View::kClay, "clay"}};

constexpr EnumName<ImageFormat> kImageFormats[] = {
    {ImageFormat::kPng, "png", nullptr, "image/png", "png"},
    {ImageFormat::kJpeg, "jpeg", "jpg", "image/jpeg", "jpg"},
    {ImageFormat::kExr, "exr", nullptr, "image/x-exr", "exr"},
    {ImageFormat::kTiff, "tiff", "tif", "image/tiff", "tif"},
    {ImageFormat::kWebp, "webp", nullptr, "image/webp", "webp"}};

}  // namespace

bool ParseView(const std::string& name, View* view) { return ParseEnum(kViews, name, view); }
const char* ViewName(View view) { return EnumEntry(kViews, view).name; }

bool ParseImageFormat(const std::string& name, ImageFormat* format) {
  return ParseEnum(kImageFormats, name, format);
}
const char* ImageFormatMimeType(ImageFormat format) {
  return EnumEntry(kImageFormats, format).media_type;
}
const char* ImageFormatExtension(ImageFormat format) {
  return EnumEntry(kImageFormats, format).extension;
}

Status CheckDrawInputs(const Rig& rig, const BlendedRig& blended, const RenderOptions& o) {
  if (o.width < 1 || o.height < 1 || o.width > 8192 || o.height > 8192)
    return InvalidArgument("image size out of range");
  if (o.supersample < 1 || o.supersample > 4) return InvalidArgument("supersample must be 1..4");
  if (blended.primitives.size() != rig.primitives.size())
    return InvalidArgument("blended rig does not match the rig");
  return Status::Ok();
}

}  // namespace facespace::picture
