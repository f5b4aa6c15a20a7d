// Images: encoding and decoding (OpenImageIO), text, legends and contact sheets.
#include <OpenImageIO/filesystem.h>
#include "facespace/core/enum_table.h"
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <webp/encode.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <unistd.h>
#include <memory>
#include <thread>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "facespace/render/render.h"
#include "internal.h"

namespace facespace::render {

namespace {

float LinearToSrgb(float c) {
  c = std::clamp(c, 0.0f, 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}
float SrgbToLinear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }

// Same polynomial as the heatmap shader (viridis), sRGB.
std::array<float, 3> Viridis(float t) {
  static const float c[7][3] = {{0.2777273272234177f, 0.005407344544966578f, 0.3340998053353061f},
                                {0.1050930431085774f, 1.404613529898575f, 1.384590162594685f},
                                {-0.3308618287255563f, 0.214847559468213f, 0.09509516302823659f},
                                {-4.634230498983486f, -5.799100973351585f, -19.33244095627987f},
                                {6.228269936347081f, 14.17993336680509f, 56.69055260068105f},
                                {4.776384997670288f, -13.74514537774601f, -65.35303263337234f},
                                {-5.435455855934631f, 4.645852612178535f, 26.3124352495832f}};
  t = std::clamp(t, 0.0f, 1.0f);
  std::array<float, 3> out{};
  for (int ch = 0; ch < 3; ++ch) {
    float v = c[6][ch];
    for (int k = 5; k >= 0; --k) v = c[k][ch] + t * v;
    out[ch] = v;
  }
  return out;
}

std::string FontPath() {
  for (const char* p : {"/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "/usr/share/fonts/TTF/DejaVuSans.ttf"}) {
    if (std::filesystem::exists(p)) return p;
  }
  return "";
}

void FillRect(Image& im, int x0, int y0, int x1, int y1, std::array<float, 4> linear) {
  for (int y = std::max(0, y0); y < std::min(im.height, y1); ++y) {
    for (int x = std::max(0, x0); x < std::min(im.width, x1); ++x) {
      std::memcpy(&im.rgba[(static_cast<size_t>(y) * im.width + x) * 4], linear.data(), 16);
    }
  }
}

// WebP through libwebp itself: OpenImageIO 2.4 always asks for its slowest method (6). Lossy
// with method 0 at `quality` (alpha kept, lossless), or lossless at quality 100. Measured on the
// 512x512 FaceCap render: quality 90 4.7 ms for 5.8 KB (PNG: 4.0 ms for 36 KB); lossless 9.6 ms
// for 33 KB (OpenImageIO's: 349 ms for 15 KB).
Result<std::string> EncodeWebp(const std::vector<unsigned char>& rgba, int width, int height, int quality) {
  WebPConfig config;
  if (!WebPConfigInit(&config)) return Internal("libwebp: bad version");
  config.method = 0;
  config.lossless = quality >= 100;
  config.quality = config.lossless ? 0.0f : static_cast<float>(std::clamp(quality, 1, 99));
  WebPPicture picture;
  if (!WebPPictureInit(&picture)) return Internal("libwebp: bad version");
  picture.width = width;
  picture.height = height;
  picture.use_argb = config.lossless;
  WebPMemoryWriter writer;
  WebPMemoryWriterInit(&writer);
  picture.writer = WebPMemoryWrite;
  picture.custom_ptr = &writer;
  const bool ok = WebPPictureImportRGBA(&picture, rgba.data(), width * 4) && WebPEncode(&config, &picture);
  std::string bytes = ok ? std::string(reinterpret_cast<const char*>(writer.mem), writer.size) : std::string();
  const int error = picture.error_code;
  WebPPictureFree(&picture);
  WebPMemoryWriterClear(&writer);
  if (!ok) return Internal("WebP encoding failed (libwebp error " + std::to_string(error) + ")");
  return bytes;
}

// 8-bit sRGB of linear values through a table (a pow per channel would cost more than the
// render). The table is fine enough that the result matches the exact curve to the nearest 8-bit step.
constexpr int kSrgbSteps = 1 << 16;
const unsigned char* SrgbTable() {
  static const std::vector<unsigned char> table = [] {
    std::vector<unsigned char> t(kSrgbSteps + 1);
    for (int i = 0; i <= kSrgbSteps; ++i) t[i] = static_cast<unsigned char>(std::lround(LinearToSrgb(static_cast<float>(i) / kSrgbSteps) * 255.0f));
    return t;
  }();
  return table.data();
}

// One row of the image as 8-bit sRGB RGBA (`alpha`) or RGB composited over white (JPEG).
void RowToSrgb8(const float* linear, int width, bool alpha, unsigned char* out) {
  const unsigned char* table = SrgbTable();
  auto srgb = [table](float v) { return table[static_cast<size_t>(std::clamp(v, 0.0f, 1.0f) * kSrgbSteps + 0.5f)]; };
  if (alpha) {
    for (int x = 0; x < width; ++x, linear += 4, out += 4) {
      out[0] = srgb(linear[0]);
      out[1] = srgb(linear[1]);
      out[2] = srgb(linear[2]);
      out[3] = static_cast<unsigned char>(std::clamp(linear[3], 0.0f, 1.0f) * 255.0f + 0.5f);
    }
    return;
  }
  for (int x = 0; x < width; ++x, linear += 4, out += 3) {
    for (int c = 0; c < 3; ++c) out[c] = srgb(linear[c] * linear[3] + (1.0f - linear[3]));
  }
}

void PutBigEndian(std::string& out, uint32_t v) {
  const char b[4] = {static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8), static_cast<char>(v)};
  out.append(b, 4);
}

// Ends the PNG chunk begun at `start`: 8 bytes left there for its length and type, its data after
// them up to the end of `out`; then its CRC.
void CloseChunk(std::string& out, size_t start, const char* type) {
  const size_t length = out.size() - start - 8;
  for (int i = 0; i < 4; ++i) out[start + i] = static_cast<char>(length >> (24 - 8 * i));
  std::memcpy(&out[start + 4], type, 4);
  const auto* bytes = reinterpret_cast<const Bytef*>(out.data() + start + 4);
  PutBigEndian(out, static_cast<uint32_t>(crc32(crc32(0, nullptr, 0), bytes, static_cast<uInt>(length + 4))));
}

void Chunk(std::string& out, const char* type, const std::string& data) {
  const size_t start = out.size();
  out.append(8, '\0');
  out += data;
  CloseChunk(out, start, type);
}

// Rows [first, first + count) of the image as PNG scanlines (8-bit sRGB RGBA, each UP-filtered:
// every byte minus the byte above it), deflated raw at zlib level 1 into `out`: byte-aligned and
// not final (Z_FULL_FLUSH) unless `last`, so parts deflated apart join into one stream (as pigz
// does). `adler` gets the Adler-32 of the scanlines. The deflate state is kept per thread (its
// 256 KB are not allocated and faulted in again per image).
bool DeflateRows(const Image& image, int first, int count, bool last, std::string& out, uLong& adler) {
  struct Deflater {
    z_stream z{};
    bool ready = deflateInit2(&z, 1, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) == Z_OK;
    ~Deflater() {
      if (ready) deflateEnd(&z);
    }
  };
  thread_local Deflater deflater;
  if (!deflater.ready || deflateReset(&deflater.z) != Z_OK) return false;
  z_stream& z = deflater.z;
  const size_t row_bytes = static_cast<size_t>(image.width) * 4;
  out.resize(deflateBound(&z, static_cast<uLong>((row_bytes + 1) * static_cast<size_t>(count))) + 16);
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  adler = adler32(0, nullptr, 0);
  // This row and the one above in 8 bits (a part's first row is filtered against the row before
  // the part), and the filtered scanline with its filter byte.
  std::vector<unsigned char> rows(2 * row_bytes, 0), line(row_bytes + 1);
  line[0] = 2;  // UP.
  if (first > 0) RowToSrgb8(&image.rgba[static_cast<size_t>(first - 1) * row_bytes], image.width, true, &rows[((first - 1) & 1) * row_bytes]);
  for (int y = first; y < first + count; ++y) {
    unsigned char* cur = &rows[(y & 1) * row_bytes];
    const unsigned char* above = &rows[((y + 1) & 1) * row_bytes];
    RowToSrgb8(&image.rgba[static_cast<size_t>(y) * row_bytes], image.width, true, cur);
    for (size_t i = 0; i < row_bytes; ++i) line[i + 1] = static_cast<unsigned char>(cur[i] - (y > 0 ? above[i] : 0));
    adler = adler32(adler, line.data(), static_cast<uInt>(line.size()));
    z.next_in = line.data();
    z.avail_in = static_cast<uInt>(line.size());
    const bool end = y + 1 == first + count;
    const int rc = deflate(&z, !end ? Z_NO_FLUSH : last ? Z_FINISH : Z_FULL_FLUSH);
    if (rc != (end && last ? Z_STREAM_END : Z_OK) || z.avail_in != 0) return false;
  }
  out.resize(out.size() - z.avail_out);
  return true;
}

// PNG, 8-bit sRGB RGBA, written here rather than through OpenImageIO: rows converted from linear
// floats, UP-filtered and deflated at zlib level 1 in one pass, a 512 x 512 image in two parts on
// two threads where there are two cores, into one IDAT. Measured on the 512x512 FaceCap render
// (render_bench): OpenImageIO's writer at zlib 1 with the UP filter (chosen by BM_Encode: libpng's
// own filter choice cost 2.5x, level 6 4x) plus our float-to-8-bit pass cost 6.3 ms; this 4.3 ms
// on one thread, 2.7 ms on two (the same bytes but for the join).
Result<std::string> EncodePng(const Image& image) {
  static const int cores = static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1u, 4u));
  const int parts = static_cast<int>(std::clamp<long long>(static_cast<long long>(image.width) * image.height / (128 * 1024), 1, cores));
  std::vector<std::string> deflated(static_cast<size_t>(parts));
  std::vector<uLong> adlers(static_cast<size_t>(parts));
  std::vector<int> firsts(static_cast<size_t>(parts) + 1);
  for (int k = 0; k <= parts; ++k) firsts[static_cast<size_t>(k)] = static_cast<int>(static_cast<long long>(image.height) * k / parts);
  std::vector<char> ok(static_cast<size_t>(parts), 0);
  auto run = [&](int k) {
    const size_t i = static_cast<size_t>(k);
    ok[i] = DeflateRows(image, firsts[i], firsts[i + 1] - firsts[i], k + 1 == parts, deflated[i], adlers[i]);
  };
  std::vector<std::thread> helpers;
  for (int k = 1; k < parts; ++k) helpers.emplace_back(run, k);
  run(0);
  for (std::thread& t : helpers) t.join();
  if (std::find(ok.begin(), ok.end(), 0) != ok.end()) return Internal("zlib: deflate failed");

  std::string out("\x89PNG\r\n\x1a\n", 8);
  std::string header;
  PutBigEndian(header, static_cast<uint32_t>(image.width));
  PutBigEndian(header, static_cast<uint32_t>(image.height));
  header += std::string("\x08\x06\x00\x00\x00", 5);  // 8 bits, RGBA, deflate, filters, no interlace.
  Chunk(out, "IHDR", header);
  Chunk(out, "sRGB", std::string(1, '\0'));  // Perceptual; with gAMA and cHRM as the PNG spec recommends.
  std::string gama;
  PutBigEndian(gama, 45455);
  Chunk(out, "gAMA", gama);
  std::string chrm;
  for (uint32_t v : {31270u, 32900u, 64000u, 33000u, 30000u, 60000u, 15000u, 6000u}) PutBigEndian(chrm, v);
  Chunk(out, "cHRM", chrm);
  // IDAT: the zlib stream, its header (deflate, 32 KB window, fastest) and the Adler-32 of every part.
  const size_t idat = out.size();
  out.append(8, '\0');
  out += std::string("\x78\x01", 2);
  uLong adler = adlers[0];
  for (int k = 0; k < parts; ++k) {
    const size_t i = static_cast<size_t>(k);
    out += deflated[i];
    if (k > 0) adler = adler32_combine(adler, adlers[i], static_cast<z_off_t>((firsts[i + 1] - firsts[i]) * (static_cast<size_t>(image.width) * 4 + 1)));
  }
  PutBigEndian(out, static_cast<uint32_t>(adler));
  CloseChunk(out, idat, "IDAT");
  Chunk(out, "IEND", "");
  return out;
}

}  // namespace

namespace {
constexpr EnumName<ImageFormat> kImageFormats[] = {
    {ImageFormat::kPng, "png", nullptr, "image/png", "png"},
    {ImageFormat::kJpeg, "jpeg", "jpg", "image/jpeg", "jpg"},
    {ImageFormat::kExr, "exr", nullptr, "image/x-exr", "exr"},
    {ImageFormat::kTiff, "tiff", "tif", "image/tiff", "tif"},
    {ImageFormat::kWebp, "webp", nullptr, "image/webp", "webp"}};
}  // namespace

bool ParseImageFormat(const std::string& name, ImageFormat* format) { return ParseEnum(kImageFormats, name, format); }
const char* ImageFormatMimeType(ImageFormat format) { return EnumEntry(kImageFormats, format).media_type; }
const char* ImageFormatExtension(ImageFormat format) { return EnumEntry(kImageFormats, format).extension; }

Result<std::string> Encode(const Image& image, ImageFormat format, int quality) {
  if (image.width < 1 || image.height < 1 || image.rgba.size() != static_cast<size_t>(image.width) * image.height * 4) {
    return InvalidArgument("empty image");
  }
  if (format == ImageFormat::kPng) return EncodePng(image);
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  std::string name = std::string("image.") + ImageFormatExtension(format);
  // OIIO 2.4's TIFF writer produces a broken file through an IOProxy (its directory is not
  // written back): TIFF goes through a private temporary file instead.
  const bool via_file = format == ImageFormat::kTiff;
  if (via_file) {
    char tmpl[] = "/tmp/facespace_XXXXXX.tif";
    const int fd = mkstemps(tmpl, 4);
    if (fd < 0) return Internal("cannot create a temporary file for TIFF");
    close(fd);
    name = tmpl;
  }
  struct Unlink {
    const std::string& path;
    bool on;
    ~Unlink() {
      if (on) std::remove(path.c_str());
    }
  } unlink_tmp{name, via_file};
  std::unique_ptr<OIIO::ImageOutput> out;
  if (format != ImageFormat::kWebp) {
    out = OIIO::ImageOutput::create(name, via_file ? nullptr : &proxy);
    if (!out) return Internal("no OpenImageIO writer for " + name);
  }
  const bool alpha = format != ImageFormat::kJpeg;
  const int channels = alpha ? 4 : 3;
  if (format == ImageFormat::kExr) {
    OIIO::ImageSpec spec(image.width, image.height, 4, OIIO::TypeDesc::HALF);
    spec.attribute("compression", "zip");
    if (!out->open(name, spec) || !out->write_image(OIIO::TypeDesc::FLOAT, image.rgba.data()) || !out->close()) {
      return Internal("EXR encoding failed: " + out->geterror());
    }
    return std::string(bytes.begin(), bytes.end());
  }
  // JPEG has no alpha: composite over white.
  std::vector<unsigned char> px(static_cast<size_t>(image.width) * image.height * channels);
  for (int y = 0; y < image.height; ++y) {
    RowToSrgb8(&image.rgba[static_cast<size_t>(y) * image.width * 4], image.width, alpha, &px[static_cast<size_t>(y) * image.width * channels]);
  }
  if (format == ImageFormat::kWebp) return EncodeWebp(px, image.width, image.height, quality);
  OIIO::ImageSpec spec(image.width, image.height, channels, OIIO::TypeDesc::UINT8);
  spec.attribute("oiio:ColorSpace", "sRGB");
  if (format == ImageFormat::kJpeg) spec.attribute("CompressionQuality", std::clamp(quality, 1, 100));
  if (format == ImageFormat::kTiff) spec.attribute("compression", "zip");
  if (!out->open(name, spec) || !out->write_image(OIIO::TypeDesc::UINT8, px.data()) || !out->close()) {
    return Internal("image encoding failed: " + out->geterror());
  }
  if (via_file) {
    std::ifstream f(name, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  }
  return std::string(bytes.begin(), bytes.end());
}

Result<Image> Decode(std::span<const unsigned char> bytes, const std::string& mime_type) {
  const char* name = nullptr;
  if (bytes.size() > 8 && bytes[0] == 0x89 && bytes[1] == 'P') name = "image.png";
  else if (bytes.size() > 3 && bytes[0] == 0xFF && bytes[1] == 0xD8) name = "image.jpg";
  else if (bytes.size() > 4 && bytes[0] == 0x76 && bytes[1] == 0x2f && bytes[2] == 0x31 && bytes[3] == 0x01) name = "image.exr";
  else if (bytes.size() > 4 && ((bytes[0] == 'I' && bytes[1] == 'I') || (bytes[0] == 'M' && bytes[1] == 'M'))) name = "image.tif";
  else if (bytes.size() > 26 && bytes[0] == 'B' && bytes[1] == 'M') name = "image.bmp";
  else if (bytes.size() > 12 && std::memcmp(bytes.data(), "RIFF", 4) == 0 && std::memcmp(bytes.data() + 8, "WEBP", 4) == 0) name = "image.webp";
  else if (bytes.size() > 18 && mime_type == "image/x-tga") name = "image.tga";  // TGA has no magic.
  if (!name) return InvalidArgument("not a PNG, JPEG, EXR, TIFF, WebP, BMP or TGA image");
  OIIO::Filesystem::IOMemReader proxy(bytes.data(), bytes.size());
  auto in = OIIO::ImageInput::open(name, nullptr, &proxy);
  if (!in) return InvalidArgument(std::string("cannot decode the image: ") + OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width < 1 || spec.height < 1 || spec.width > 16384 || spec.height > 16384 || spec.nchannels < 1) {
    return InvalidArgument("image size out of range");
  }
  std::vector<float> px(static_cast<size_t>(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, px.data())) {
    return InvalidArgument("cannot decode the image: " + in->geterror());
  }
  const bool linear = std::strcmp(name, "image.exr") == 0;
  Image im;
  im.width = spec.width;
  im.height = spec.height;
  im.rgba.resize(static_cast<size_t>(im.width) * im.height * 4);
  const int nc = spec.nchannels;
  for (size_t i = 0, n = static_cast<size_t>(im.width) * im.height; i < n; ++i) {
    const float* s = &px[i * nc];
    float rgba[4] = {s[0], nc >= 3 ? s[1] : s[0], nc >= 3 ? s[2] : s[0], nc == 4 ? s[3] : nc == 2 ? s[1] : 1.0f};
    for (int c = 0; c < 3; ++c) im.rgba[4 * i + c] = linear ? rgba[c] : SrgbToLinear(rgba[c]);
    im.rgba[4 * i + 3] = rgba[3];
  }
  return im;
}

bool DrawText(Image& image, int x, int y, const std::string& text, int size, std::array<float, 3> srgb) {
  static const std::string font = FontPath();
  if (font.empty() || text.empty()) return false;
  OIIO::ImageSpec spec(image.width, image.height, 4, OIIO::TypeDesc::FLOAT);
  OIIO::ImageBuf buf(spec, image.rgba.data());
  const float color[4] = {SrgbToLinear(srgb[0]), SrgbToLinear(srgb[1]), SrgbToLinear(srgb[2]), 1.0f};
  return OIIO::ImageBufAlgo::render_text(buf, x, y, text, size, font, OIIO::cspan<float>(color, 4));
}

namespace {

// The width `text` takes at `size` pixels, or an estimate without the font.
int TextWidth(const std::string& text, int size) {
  static const std::string font_path = FontPath();
  if (text.empty()) return 0;
  const OIIO::ROI roi = font_path.empty() ? OIIO::ROI() : OIIO::ImageBufAlgo::text_size(text, size, font_path);
  if (!roi.defined()) return size * static_cast<int>(text.size()) * 6 / 10;
  // Text with no ink (spaces only) comes back as an inverted box (xbegin INT_MAX, xend INT_MIN):
  // width 0, computed without the overflow roi.width() would do.
  const long long width = static_cast<long long>(roi.xend) - roi.xbegin;
  return width > 0 ? static_cast<int>(width) : 0;
}

// `text` cut to fit `width` pixels, ending in "..." when cut (whole UTF-8 characters only).
std::string FitText(const std::string& text, int size, int width) {
  if (TextWidth(text, size) <= width) return text;
  std::string cut = text;
  while (!cut.empty()) {
    while (!cut.empty() && (static_cast<unsigned char>(cut.back()) & 0xC0) == 0x80) cut.pop_back();  // Continuation bytes,
    if (!cut.empty()) cut.pop_back();  // then the lead byte (or an ASCII character).
    if (TextWidth(cut + "...", size) <= width) return cut + "...";
  }
  return "";
}

// Lightens the rectangle towards white (linear `amount` of white): a backdrop that keeps text
// readable over the mesh.
void Veil(Image& im, int x0, int y0, int x1, int y1, float amount) {
  for (int y = std::max(0, y0); y < std::min(im.height, y1); ++y) {
    for (int x = std::max(0, x0); x < std::min(im.width, x1); ++x) {
      float* px = &im.rgba[(static_cast<size_t>(y) * im.width + x) * 4];
      for (int c = 0; c < 3; ++c) px[c] = px[c] * (1.0f - amount) + amount;
      px[3] = std::max(px[3], amount);
    }
  }
}

}  // namespace

void DrawHeatLegend(Image& im, float max_value) {
  const int bar_w = std::max(8, im.width / 40), bar_h = im.height * 3 / 5;
  const int x0 = im.width - bar_w - std::max(40, im.width / 8), y0 = (im.height - bar_h) / 2;
  const int font = std::max(10, im.height / 36);
  // The title says what the colours measure and in which units: the distance each vertex moved,
  // in the rig's own units (metres for most glTF rigs).
  const std::string title = "displacement", units = "(rig units)";
  const int title_x = std::max(2, std::min(x0, im.width - std::max(TextWidth(title, font), TextWidth(units, font)) - 6));
  Veil(im, title_x - 3, y0 - 3 * font, im.width, y0 + bar_h + font, 0.75f);
  for (int y = 0; y < bar_h; ++y) {
    const auto c = Viridis(1.0f - static_cast<float>(y) / static_cast<float>(std::max(1, bar_h - 1)));
    FillRect(im, x0, y0 + y, x0 + bar_w, y0 + y + 1, {SrgbToLinear(c[0]), SrgbToLinear(c[1]), SrgbToLinear(c[2]), 1.0f});
  }
  char top[32];
  std::snprintf(top, sizeof top, "%.3g", static_cast<double>(max_value));
  const std::array<float, 3> ink{0.1f, 0.1f, 0.1f};
  DrawText(im, x0 + bar_w + 4, y0 + font / 2, top, font, ink);
  DrawText(im, x0 + bar_w + 4, y0 + bar_h, "0", font, ink);
  DrawText(im, title_x, y0 - 2 * font + font / 3, title, font, ink);  // Both end at the image's right margin.
  DrawText(im, title_x, y0 - font / 2, units, font, ink);
}

Image ContactSheet(std::span<const Image> cells, std::span<const std::string> labels, int columns,
                   std::array<float, 4> background) {
  Image sheet;
  if (cells.empty()) return sheet;
  columns = std::clamp(columns, 1, static_cast<int>(cells.size()));
  int cw = 0, ch = 0;
  for (const Image& c : cells) {
    cw = std::max(cw, c.width);
    ch = std::max(ch, c.height);
  }
  const int label_h = std::max(18, ch / 12), pad = 4;
  const int rows = (static_cast<int>(cells.size()) + columns - 1) / columns;
  sheet.width = columns * (cw + pad) + pad;
  sheet.height = rows * (ch + label_h + pad) + pad;
  const std::array<float, 4> bg{SrgbToLinear(background[0]), SrgbToLinear(background[1]), SrgbToLinear(background[2]), background[3]};
  sheet.rgba.resize(static_cast<size_t>(sheet.width) * sheet.height * 4);
  FillRect(sheet, 0, 0, sheet.width, sheet.height, bg);
  for (size_t i = 0; i < cells.size(); ++i) {
    const Image& c = cells[i];
    const int x0 = pad + static_cast<int>(i % columns) * (cw + pad), y0 = pad + static_cast<int>(i / columns) * (ch + label_h + pad);
    for (int y = 0; y < c.height; ++y) {
      std::memcpy(&sheet.rgba[(static_cast<size_t>(y0 + y) * sheet.width + x0) * 4], &c.rgba[static_cast<size_t>(y) * c.width * 4],
                  static_cast<size_t>(c.width) * 16);
    }
    if (i < labels.size()) {  // Cut to the cell's width: a long label never runs into the next cell.
      const int size = label_h * 2 / 3;
      DrawText(sheet, x0 + 4, y0 + ch + label_h * 3 / 4, FitText(labels[i], size, cw - 8), size, {0.1f, 0.1f, 0.1f});
    }
  }
  return sheet;
}

}  // namespace facespace::render
