// Images of data rather than light, for labelled datasets: planes of floats as EXR (depth, normals)
// and ids as grey PNG (segmentation), written as they are: no colour space, no tone.
#include <zlib.h>

#include <algorithm>

#include "facespace/render/render.h"
#include "internal.h"
#include "oiio_module.h"

namespace facespace::render {

Result<std::string> EncodeDataExr(std::span<const float> values, int width, int height, int channels, bool full_float) {
  if (width < 1 || height < 1 || (channels != 1 && channels != 3) ||
      values.size() != static_cast<size_t>(width) * static_cast<size_t>(height) * static_cast<size_t>(channels)) {
    return InvalidArgument("a data image of " + std::to_string(values.size()) + " values is not " + std::to_string(width) + " x " +
                           std::to_string(height) + " x " + std::to_string(channels));
  }
  std::string error;
  const oiio::Api* api = oiio::Load(&error);
  if (!api) return Internal(error);
  oiio::EncodeArgs args;
  args.name = "data.exr";
  args.width = width;
  args.height = height;
  args.channels = channels;
  args.planes = values.data();
  args.full_float = full_float;
  args.zip = true;
  std::vector<unsigned char> bytes;
  if (!api->encode(args, &bytes, &error)) return Internal("EXR encoding failed: " + error);
  return std::string(bytes.begin(), bytes.end());
}

Result<std::string> EncodeIdPng(std::span<const uint16_t> ids, int width, int height) {
  const size_t w = static_cast<size_t>(std::max(width, 0)), h = static_cast<size_t>(std::max(height, 0));
  if (w == 0 || h == 0 || ids.size() != w * h) return InvalidArgument("an id image of " + std::to_string(ids.size()) + " values is not its size");
  const bool wide = *std::max_element(ids.begin(), ids.end()) > 255;
  const size_t line = 1 + w * (wide ? 2 : 1);
  std::string raw(line * h, '\0');  // Filter 0 (none) on every row: ids are flat areas, deflate does the rest.
  for (size_t y = 0; y < h; ++y) {
    unsigned char* row = reinterpret_cast<unsigned char*>(&raw[y * line + 1]);
    for (size_t x = 0; x < w; ++x) {
      const uint16_t id = ids[y * w + x];
      if (wide) row[2 * x] = static_cast<unsigned char>(id >> 8), row[2 * x + 1] = static_cast<unsigned char>(id);
      else row[x] = static_cast<unsigned char>(id);
    }
  }
  // Run-length deflate (Z_RLE): ids are long runs, and zlib's default match search took a fifth of a
  // labelled sample's time on them.
  z_stream z{};
  if (deflateInit2(&z, 6, Z_DEFLATED, 15, 8, Z_RLE) != Z_OK) return Internal("zlib: deflateInit2 failed");
  std::string deflated(deflateBound(&z, static_cast<uLong>(raw.size())), '\0');
  z.next_in = reinterpret_cast<Bytef*>(raw.data());
  z.avail_in = static_cast<uInt>(raw.size());
  z.next_out = reinterpret_cast<Bytef*>(deflated.data());
  z.avail_out = static_cast<uInt>(deflated.size());
  const int done = deflate(&z, Z_FINISH);
  deflated.resize(z.total_out);
  deflateEnd(&z);
  if (done != Z_STREAM_END) return Internal("zlib: deflate failed");
  std::string out("\x89PNG\r\n\x1a\n", 8), header;
  PutBigEndian(header, static_cast<uint32_t>(w));
  PutBigEndian(header, static_cast<uint32_t>(h));
  header += std::string(wide ? "\x10\x00\x00\x00\x00" : "\x08\x00\x00\x00\x00", 5);  // 16 or 8 bits, grey, deflate, filters, no interlace.
  Chunk(out, "IHDR", header);
  Chunk(out, "IDAT", deflated);
  Chunk(out, "IEND", "");
  return out;
}

}  // namespace facespace::render
