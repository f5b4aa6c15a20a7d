// Images: encoding and decoding (OpenImageIO, through facespace/oiio/module.h), text, legends and
// contact sheets.
#include <isa-l/igzip_lib.h>
#include <unistd.h>
#include <webp/encode.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <mutex>
#include <span>
#include <thread>

#include "facespace/engine/color.h"
#include "facespace/engine/cpu.h"
#include "facespace/offscreen/render.h"
#include "facespace/oiio/module.h"
#include "internal.h"
#include "text.h"

namespace facespace::offscreen {

namespace {

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

void FillRect(picture::Image& im, int x0, int y0, int x1, int y1, std::array<float, 4> linear) {
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
Result<std::string> EncodeWebp(std::span<const unsigned char> rgba, int width, int height,
                               int quality) {
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
  const bool ok =
      WebPPictureImportRGBA(&picture, rgba.data(), width * 4) && WebPEncode(&config, &picture);
  std::string bytes =
      ok ? std::string(reinterpret_cast<const char*>(writer.mem), writer.size) : std::string();
  const int error = picture.error_code;
  WebPPictureFree(&picture);
  WebPMemoryWriterClear(&writer);
  if (!ok) return Internal("WebP encoding failed (libwebp error " + std::to_string(error) + ")");
  return bytes;
}

// 8-bit sRGB of linear values, exactly: the nearest 8-bit step of the sRGB curve worked out in
// double precision (a pow per channel would cost more than the render). By the value's float bits:
// the exponent and the top 8 bits of the mantissa pick one of 3,328 buckets over [2^-13, 1) (below
// 2^-13 every value rounds to 0); a bucket keeps the step of its first value, and the low mantissa
// bits where the next step begins inside it, if one does (no bucket holds two: the steps are at
// least 0.0003 apart in linear light, the buckets at most 0.002 wide near 1 where the steps are
// 0.009 apart). 10 KB that stay in L1, where the 64 KB table of 65,536 steps it replaced missed L1
// on most lookups: the PNG of the 512x512 FaceCap float image 3.3 -> 2.2 ms (render_bench).
class SrgbEncoder {
 public:
  static const SrgbEncoder& Get() {
    static const SrgbEncoder encoder;
    return encoder;
  }
  unsigned char operator()(float v) const {
    if (!(v >= kLow)) return 0;  // And NaN.
    if (v >= 1.0f) return 255;
    uint32_t bits;
    std::memcpy(&bits, &v, 4);
    const uint32_t b = (bits >> 15) - kFirst;
    return static_cast<unsigned char>(base_[b] + ((bits & 0x7FFF) >= step_[b] ? 1 : 0));
  }

 private:
  static unsigned char Exact(float v) {
    return static_cast<unsigned char>(std::lround(SrgbEncode(v) * 255.0));
  }

  static constexpr float kLow = 1.0f / 8192.0f;                         // 2^-13.
  static constexpr uint32_t kFirst = (uint32_t{127 - 13} << 23) >> 15;  // Its bits' bucket.
  static constexpr uint32_t kBuckets = 13 * 256;
  SrgbEncoder() {
    auto at = [](uint32_t bits) {
      float v;
      std::memcpy(&v, &bits, 4);
      return Exact(v);
    };
    for (uint32_t b = 0; b < kBuckets; ++b) {
      const uint32_t first = (kFirst + b) << 15;
      base_[b] = at(first);
      uint32_t lo = 0,
               hi =
                   0x8000;  // The first low-bits value whose step is above the base (0x8000: none).
      while (lo < hi) {
        const uint32_t mid = (lo + hi) / 2;
        if (at(first | mid) > base_[b])
          hi = mid;
        else
          lo = mid + 1;
      }
      step_[b] = static_cast<uint16_t>(lo);
    }
  }
  unsigned char base_[kBuckets];
  uint16_t step_[kBuckets];
};

// Linear values of the 256 8-bit sRGB steps.
const float* LinearOf8() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i)
      t[static_cast<size_t>(i)] = SrgbToLinear(static_cast<float>(i) / 255.0f);
    return t;
  }();
  return table.data();
}

// Row y of the image as 8-bit sRGB RGBA (`alpha`) or RGB composited over white in linear light
// (JPEG), from the image's floats, or (RGB only: Pixels8 takes 8-bit RGBA as it is) from its 8-bit
// pixels when it has no floats.
void Row8(const picture::Image& image, int y, bool alpha, unsigned char* out) {
  const size_t width = static_cast<size_t>(image.width), at = static_cast<size_t>(y) * width * 4;
  const SrgbEncoder& srgb = SrgbEncoder::Get();
  if (!image.rgba.empty()) {
    const float* linear = &image.rgba[at];
    if (alpha) {
      for (size_t x = 0; x < width; ++x, linear += 4, out += 4) {
        out[0] = srgb(linear[0]);
        out[1] = srgb(linear[1]);
        out[2] = srgb(linear[2]);
        out[3] = static_cast<unsigned char>(std::clamp(linear[3], 0.0f, 1.0f) * 255.0f + 0.5f);
      }
      return;
    }
    for (size_t x = 0; x < width; ++x, linear += 4, out += 3) {
      for (int c = 0; c < 3; ++c) out[c] = srgb(linear[c] * linear[3] + (1.0f - linear[3]));
    }
    return;
  }
  const unsigned char* in = &image.srgb8[at];
  const float* linear_of = LinearOf8();
  for (size_t x = 0; x < width; ++x, in += 4, out += 3) {
    const float a = static_cast<float>(in[3]) / 255.0f;
    for (int c = 0; c < 3; ++c)
      out[c] = in[3] == 255 ? in[c] : srgb(linear_of[in[c]] * a + (1.0f - a));
  }
}

// The image's linear floats: its own, or made from its 8-bit pixels.
std::vector<float> LinearPixels(const picture::Image& image) {
  if (!image.rgba.empty()) return image.rgba;
  std::vector<float> out(image.srgb8.size());
  const float* linear_of = LinearOf8();
  for (size_t i = 0; i < out.size(); ++i)
    out[i] = i % 4 == 3 ? static_cast<float>(image.srgb8[i]) / 255.0f : linear_of[image.srgb8[i]];
  return out;
}

// True when every alpha byte of the 8-bit RGBA pixels is 255: the PNG can then be RGB (a quarter
// fewer bytes to filter and deflate, and a smaller file).
bool Opaque(std::span<const unsigned char> rgba8) {
  for (size_t i = 3; i < rgba8.size(); i += 4) {
    if (rgba8[i] != 255) return false;
  }
  return true;
}

// An encoder's buffers: a float image converted to 8 bits, the filtered rows of a batch, and a row
// of zeros (above the first).
struct Deflater {
  std::vector<unsigned char> converted, lines, zeros;
};

// Deflaters reused across threads, most recently used first (its pages warm in cache), a few
// kept: per-thread ones would grow with every connection thread that ever encoded a PNG.
class DeflaterPool {
 public:
  struct Return {
    void operator()(Deflater* d) const { Give(std::unique_ptr<Deflater>(d)); }
  };
  using Lease = std::unique_ptr<Deflater, Return>;
  static Lease Take() {
    {
      std::lock_guard lock(mu_);
      if (!idle_.empty()) {
        Lease d(idle_.back().release());
        idle_.pop_back();
        return d;
      }
    }
    return Lease(new Deflater);
  }

 private:
  static void Give(std::unique_ptr<Deflater> d) {
    std::lock_guard lock(mu_);
    if (idle_.size() < 8) idle_.push_back(std::move(d));
  }
  static inline std::mutex mu_;
  static inline std::vector<std::unique_ptr<Deflater>> idle_;
};

}  // namespace

// (internal.h)
void PutBigEndian(std::string& out, uint32_t v) {
  const char b[4] = {static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                     static_cast<char>(v >> 8), static_cast<char>(v)};
  out.append(b, 4);
}

// Ends the PNG chunk begun at `start`: 8 bytes left there for its length and type, its data after
// them up to the end of `out`; then its CRC.
void CloseChunk(std::string& out, size_t start, const char* type) {
  const size_t length = out.size() - start - 8;
  for (int i = 0; i < 4; ++i) out[start + i] = static_cast<char>(length >> (24 - 8 * i));
  std::memcpy(&out[start + 4], type, 4);
  const auto* bytes = reinterpret_cast<const Bytef*>(out.data() + start + 4);
  PutBigEndian(out, static_cast<uint32_t>(
                        crc32(crc32(0, nullptr, 0), bytes, static_cast<uInt>(length + 4))));
}

void Chunk(std::string& out, const char* type, const std::string& data) {
  const size_t start = out.size();
  out.append(8, '\0');
  out += data;
  CloseChunk(out, start, type);
}

// (internal.h) igzip deflates our filtered rows many times faster than zlib level 1 (level 1: 0.45
// against 3.05 ms on the 512x512 FaceCap render, tests/bench/README.md), so one thread deflates
// what two parts on two threads did with zlib. Level 0, not 1: on this machine level 1's output for
// the same bytes changed about once in a thousand images (and one label EXR in a few hundred
// samples), only inside a busy process (never in a harness, the same rows deflated 100,000 times),
// which broke the dataset's same seed, same bytes; level 0 never did in the same stress, is faster,
// and makes files about a seventh larger (67.4 against 76.6 KB). Every field is set (hist_bits
// among them), not only those isal_deflate_init sets.
void StartDeflate(isal_zstream& z) {
  z = isal_zstream{};
  isal_deflate_init(&z);
  z.level = 0;
  z.gzip_flag = IGZIP_ZLIB;
  z.flush = NO_FLUSH;
}

// (internal.h) The image as 8-bit sRGB pixels, RGBA (`alpha`) or RGB composited over white (JPEG):
// an 8-bit draw's RGBA as it is, else converted into `room`, a large image (256K pixels or more) in
// parts on up to one thread per core (4 at most), as the conversion costs more than igzip's deflate
// (512x512 from floats: about 1.5 ms on one thread).
std::span<const unsigned char> Pixels8(const picture::Image& image, bool alpha,
                                       std::vector<unsigned char>& room, HelperCpu* helper_cpu) {
  if (alpha && image.rgba.empty()) return image.srgb8;
  static const int cores =
      static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1u, 4u));
  const size_t row = static_cast<size_t>(image.width) * (alpha ? 4 : 3);
  room.resize(row * image.height);
  const int parts = static_cast<int>(std::clamp<long long>(
      static_cast<long long>(image.width) * image.height / (128 * 1024), 1, cores));
  auto run = [&](int k) {
    const int first = static_cast<int>(static_cast<long long>(image.height) * k / parts);
    const int end = static_cast<int>(static_cast<long long>(image.height) * (k + 1) / parts);
    for (int y = first; y < end; ++y) Row8(image, y, alpha, &room[static_cast<size_t>(y) * row]);
  };
  std::vector<std::thread> helpers;
  std::vector<double> spent(static_cast<size_t>(parts),
                            0.0);  // Each helper's CPU, charged to the caller's work.
  for (int k = 1; k < parts; ++k) {
    helpers.emplace_back([&run, &spent, k] {
      run(k);
      spent[static_cast<size_t>(k)] = ThreadCpuSeconds();
    });
  }
  run(0);
  for (std::thread& t : helpers) t.join();
  for (double s : spent) ChargeHelperCpu(helper_cpu, s);
  return room;
}

namespace {

// PNG, 8-bit sRGB (RGB when opaque, else RGBA), written here rather than through OpenImageIO: the
// 8-bit pixels (the draw's own, or a float image converted) UP-filtered in batches, each batch
// deflated as it is made (StartDeflate) into one IDAT. The buffers come from a pool (not allocated
// and faulted in again per image).
Result<std::string> EncodePng(const picture::Image& image, HelperCpu* helper_cpu) {
  const DeflaterPool::Lease lease = DeflaterPool::Take();
  Deflater& d = *lease;
  const size_t width = static_cast<size_t>(image.width), stride = width * 4;
  const std::span<const unsigned char> px = Pixels8(image, true, d.converted, helper_cpu);
  const bool opaque = Opaque(px);
  const size_t row_bytes = width * (opaque ? 3 : 4), line_bytes = row_bytes + 1;
  const size_t batch = std::max<size_t>(1, (64 * 1024) / line_bytes);  // Rows deflated per call.
  d.lines.resize(batch * line_bytes);
  d.zeros.assign(stride, 0);

  isal_zstream z;
  StartDeflate(z);

  std::string out("\x89PNG\r\n\x1a\n", 8);
  std::string header;
  PutBigEndian(header, static_cast<uint32_t>(image.width));
  PutBigEndian(header, static_cast<uint32_t>(image.height));
  header += std::string(opaque ? "\x08\x02\x00\x00\x00" : "\x08\x06\x00\x00\x00",
                        5);  // 8 bits, RGB or RGBA, deflate, filters, no interlace.
  Chunk(out, "IHDR", header);
  Chunk(out, "sRGB",
        std::string(1, '\0'));  // Perceptual; with gAMA and cHRM as the PNG spec recommends.
  std::string gama;
  PutBigEndian(gama, 45455);
  Chunk(out, "gAMA", gama);
  std::string chrm;
  for (uint32_t v : {31270u, 32900u, 64000u, 33000u, 30000u, 60000u, 15000u, 6000u})
    PutBigEndian(chrm, v);
  Chunk(out, "cHRM", chrm);
  const size_t idat = out.size();
  out.append(8, '\0');
  size_t written = out.size();  // The end of the deflated bytes so far.
  // Room for a quarter of the scanlines (renders deflate to a tenth or less), grown when short.
  out.resize(written + line_bytes * static_cast<size_t>(image.height) / 4 + 65536);

  for (int first = 0; first < image.height; first += static_cast<int>(batch)) {
    const int count = std::min(static_cast<int>(batch), image.height - first);
    for (int k = 0; k < count; ++k) {
      const int y = first + k;
      const unsigned char* cur = px.data() + static_cast<size_t>(y) * stride;
      const unsigned char* above = y > 0 ? cur - stride : d.zeros.data();
      unsigned char* line = &d.lines[static_cast<size_t>(k) * line_bytes];
      line[0] = 2;  // UP: every byte minus the byte above it.
      if (opaque) {
        for (size_t x = 0; x < width; ++x) {
          for (int c = 0; c < 3; ++c)
            line[1 + 3 * x + c] = static_cast<unsigned char>(cur[4 * x + c] - above[4 * x + c]);
        }
      } else {
        for (size_t i = 0; i < stride; ++i)
          line[1 + i] = static_cast<unsigned char>(cur[i] - above[i]);
      }
    }
    z.next_in = d.lines.data();
    z.avail_in = static_cast<uint32_t>(static_cast<size_t>(count) * line_bytes);
    z.end_of_stream = first + count == image.height;
    while (true) {
      const uint32_t in_before = z.avail_in;
      const size_t written_before = written;
      z.next_out = reinterpret_cast<uint8_t*>(out.data() + written);
      z.avail_out = static_cast<uint32_t>(out.size() - written);
      if (isal_deflate(&z) != COMP_OK) return Internal("igzip: deflate failed");
      written = out.size() - z.avail_out;
      if (z.avail_in == 0 && (!z.end_of_stream || z.internal_state.state == ZSTATE_END)) break;
      if (z.avail_out == 0)
        out.resize(out.size() + out.size() / 2);
      else if (z.avail_in == in_before && written == written_before)
        return Internal("igzip: deflate made no progress");
    }
  }
  out.resize(written);
  CloseChunk(out, idat, "IDAT");
  Chunk(out, "IEND", "");
  out.shrink_to_fit();  // The response cache counts size(), not the room left over.
  return out;
}

}  // namespace

Result<std::string> Encode(const picture::Image& image, picture::ImageFormat format, int quality,
                           HelperCpu* helper_cpu) {
  const size_t values =
      image.width < 1 || image.height < 1 ? 0 : static_cast<size_t>(image.width) * image.height * 4;
  if (values == 0 ||
      (image.rgba.size() != values && !(image.rgba.empty() && image.srgb8.size() == values))) {
    return InvalidArgument("empty image");
  }
  if (format == picture::ImageFormat::kPng) return EncodePng(image, helper_cpu);
  std::vector<unsigned char> room;
  const bool alpha = format != picture::ImageFormat::kJpeg;
  if (format == picture::ImageFormat::kWebp) {
    const std::span<const unsigned char> px = Pixels8(image, alpha, room, helper_cpu);
    return EncodeWebp(px, image.width, image.height, quality);
  }
  std::string error;
  const oiio::Api* api = LoadOiio(&error);
  if (!api) return Internal(error);
  oiio::EncodeArgs args;
  std::string name = std::string("image.") + ImageFormatExtension(format);
  // OIIO 2.4's TIFF writer produces a broken file through an IOProxy (its directory is not
  // written back): TIFF goes through a private temporary file instead.
  args.to_file = format == picture::ImageFormat::kTiff;
  if (args.to_file) {
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
  } unlink_tmp{name, args.to_file};
  args.name = name.c_str();
  args.width = image.width;
  args.height = image.height;
  args.zip = format == picture::ImageFormat::kTiff || format == picture::ImageFormat::kExr;
  std::vector<float> linear;
  if (format == picture::ImageFormat::kExr) {
    linear = LinearPixels(image);
    args.linear = linear.data();
  } else {
    args.channels = alpha ? 4 : 3;
    args.srgb8 = Pixels8(image, alpha, room, helper_cpu)
                     .data();  // JPEG has no alpha: composited over white.
    if (format == picture::ImageFormat::kJpeg) args.quality = std::clamp(quality, 1, 100);
  }
  std::vector<unsigned char> bytes;
  if (!api->encode(args, &bytes, &error)) {
    return Internal(std::string(format == picture::ImageFormat::kExr ? "EXR" : "image") +
                    " encoding failed: " + error);
  }
  if (args.to_file) {
    std::ifstream f(name, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  }
  return std::string(bytes.begin(), bytes.end());
}

std::string ImageModuleProblem() {
  return LocateOiio().empty() ? "the image module libfacespace_oiio.so is neither beside the "
                                "executable nor in the build"
                              : "";
}

std::string OpenImageModule() {
  std::string error;
  return LoadOiio(&error) ? "" : error;
}

Result<picture::Image> Decode(std::span<const unsigned char> bytes, const std::string& mime_type) {
  const char* name = nullptr;
  if (bytes.size() > 8 && bytes[0] == 0x89 && bytes[1] == 'P')
    name = "image.png";
  else if (bytes.size() > 3 && bytes[0] == 0xFF && bytes[1] == 0xD8)
    name = "image.jpg";
  else if (bytes.size() > 4 && bytes[0] == 0x76 && bytes[1] == 0x2f && bytes[2] == 0x31 &&
           bytes[3] == 0x01)
    name = "image.exr";
  else if (bytes.size() > 4 &&
           ((bytes[0] == 'I' && bytes[1] == 'I') || (bytes[0] == 'M' && bytes[1] == 'M')))
    name = "image.tif";
  else if (bytes.size() > 26 && bytes[0] == 'B' && bytes[1] == 'M')
    name = "image.bmp";
  else if (bytes.size() > 12 && std::memcmp(bytes.data(), "RIFF", 4) == 0 &&
           std::memcmp(bytes.data() + 8, "WEBP", 4) == 0)
    name = "image.webp";
  else if (bytes.size() > 18 && mime_type == "image/x-tga")
    name = "image.tga";  // TGA has no magic.
  if (!name) return InvalidArgument("not a PNG, JPEG, EXR, TIFF, WebP, BMP or TGA image");
  std::string error;
  const oiio::Api* api = LoadOiio(&error);
  if (!api) return Internal(error);
  oiio::Decoded decoded;
  if (!api->decode(bytes.data(), bytes.size(), name, 16384, &decoded, &error)) {
    return InvalidArgument(error);
  }
  const std::vector<float>& px = decoded.pixels;
  const bool linear = std::strcmp(name, "image.exr") == 0;
  picture::Image im;
  im.width = decoded.width;
  im.height = decoded.height;
  im.rgba.resize(static_cast<size_t>(im.width) * im.height * 4);
  const int nc = decoded.channels;
  for (size_t i = 0, n = static_cast<size_t>(im.width) * im.height; i < n; ++i) {
    const float* s = &px[i * nc];
    float rgba[4] = {s[0], nc >= 3 ? s[1] : s[0], nc >= 3 ? s[2] : s[0],
                     nc == 4   ? s[3]
                     : nc == 2 ? s[1]
                               : 1.0f};
    for (int c = 0; c < 3; ++c) im.rgba[4 * i + c] = linear ? rgba[c] : SrgbToLinear(rgba[c]);
    im.rgba[4 * i + 3] = rgba[3];
  }
  return im;
}

bool DrawText(picture::Image& image, int x, int y, const std::string& text, int size,
              std::array<float, 3> srgb) {
  const float color[3] = {SrgbToLinear(srgb[0]), SrgbToLinear(srgb[1]), SrgbToLinear(srgb[2])};
  return DrawGlyphs(image.rgba.data(), image.width, image.height, x, y, text, size, color);
}

namespace {

// The width `text` takes at `size` pixels, or an estimate without the font.
int TextWidth(const std::string& text, int size) {
  if (text.empty()) return 0;
  const int advance = TextAdvance(text, size);
  return advance >= 0 ? advance : size * static_cast<int>(text.size()) * 6 / 10;
}

// `text` cut to fit `width` pixels, ending in "..." when cut (whole UTF-8 characters only).
std::string FitText(const std::string& text, int size, int width) {
  if (TextWidth(text, size) <= width) return text;
  std::string cut = text;
  while (!cut.empty()) {
    while (!cut.empty() && (static_cast<unsigned char>(cut.back()) & 0xC0) == 0x80)
      cut.pop_back();                  // Continuation bytes,
    if (!cut.empty()) cut.pop_back();  // then the lead byte (or an ASCII character).
    if (TextWidth(cut + "...", size) <= width) return cut + "...";
  }
  return "";
}

// Lightens the rectangle towards white (linear `amount` of white): a backdrop that keeps text
// readable over the mesh.
void Veil(picture::Image& im, int x0, int y0, int x1, int y1, float amount) {
  for (int y = std::max(0, y0); y < std::min(im.height, y1); ++y) {
    for (int x = std::max(0, x0); x < std::min(im.width, x1); ++x) {
      float* px = &im.rgba[(static_cast<size_t>(y) * im.width + x) * 4];
      for (int c = 0; c < 3; ++c) px[c] = px[c] * (1.0f - amount) + amount;
      px[3] = std::max(px[3], amount);
    }
  }
}

struct LegendLayout {
  int bar_w, bar_h, x0, y0, font, title_x;
};

// Where the legend goes in a width x height image: the bar at the right, its title over it.
LegendLayout HeatLegendLayout(int width, int height) {
  LegendLayout l;
  l.bar_w = std::max(8, width / 40);
  l.bar_h = height * 3 / 5;
  l.x0 = width - l.bar_w - std::max(40, width / 8);
  l.y0 = (height - l.bar_h) / 2;
  l.font = std::max(10, height / 36);
  l.title_x = std::max(2, std::min(l.x0, width -
                                             std::max(TextWidth("displacement", l.font),
                                                      TextWidth("(rig units)", l.font)) -
                                             6));
  return l;
}

}  // namespace

int HeatLegendLeft(int width, int height) {
  return std::max(0, HeatLegendLayout(width, height).title_x - 3);
}

void DrawHeatLegend(picture::Image& im, float max_value) {
  const LegendLayout l = HeatLegendLayout(im.width, im.height);
  const int font = l.font;
  // The title says what the colours measure and in which units: the distance each vertex moved,
  // in the rig's own units (metres for most glTF rigs).
  const std::string title = "displacement", units = "(rig units)";
  Veil(im, l.title_x - 3, l.y0 - 3 * font, im.width, l.y0 + l.bar_h + font, 0.75f);
  const std::array<float, 3> ink{0.1f, 0.1f, 0.1f};
  DrawText(im, l.title_x, l.y0 - 2 * font + font / 3, title, font,
           ink);  // Both end at the image's right margin.
  DrawText(im, l.title_x, l.y0 - font / 2, units, font, ink);
  if (!(max_value > 0.0f)) {  // Nothing moved: one swatch, said in words (not a scale from 0 to 0).
    const auto c = Viridis(0.0f);
    FillRect(im, l.x0, l.y0 + l.bar_h - l.bar_w, l.x0 + l.bar_w, l.y0 + l.bar_h,
             {SrgbToLinear(c[0]), SrgbToLinear(c[1]), SrgbToLinear(c[2]), 1.0f});
    DrawText(im, l.x0 + l.bar_w + 4, l.y0 + l.bar_h, "0", font, ink);
    DrawText(im, l.title_x, l.y0 + l.bar_h / 2, "none moved", font, ink);
    return;
  }
  for (int y = 0; y < l.bar_h; ++y) {
    const auto c =
        Viridis(1.0f - static_cast<float>(y) / static_cast<float>(std::max(1, l.bar_h - 1)));
    FillRect(im, l.x0, l.y0 + y, l.x0 + l.bar_w, l.y0 + y + 1,
             {SrgbToLinear(c[0]), SrgbToLinear(c[1]), SrgbToLinear(c[2]), 1.0f});
  }
  char top[32];
  std::snprintf(top, sizeof top, "%.3g", static_cast<double>(max_value));
  DrawText(im, l.x0 + l.bar_w + 4, l.y0 + font / 2, top, font, ink);
  DrawText(im, l.x0 + l.bar_w + 4, l.y0 + l.bar_h, "0", font, ink);
}

picture::Image ContactSheet(std::span<const picture::Image> cells,
                            std::span<const std::string> labels, int columns,
                            std::array<float, 4> background) {
  picture::Image sheet;
  if (cells.empty()) return sheet;
  columns = std::clamp(columns, 1, static_cast<int>(cells.size()));
  int cw = 0, ch = 0;
  for (const picture::Image& c : cells) {
    cw = std::max(cw, c.width);
    ch = std::max(ch, c.height);
  }
  const int label_h = std::max(18, ch / 12), pad = 4;
  const int rows = (static_cast<int>(cells.size()) + columns - 1) / columns;
  sheet.width = columns * (cw + pad) + pad;
  sheet.height = rows * (ch + label_h + pad) + pad;
  const std::array<float, 4> bg{SrgbToLinear(background[0]), SrgbToLinear(background[1]),
                                SrgbToLinear(background[2]), background[3]};
  sheet.rgba.resize(static_cast<size_t>(sheet.width) * sheet.height * 4);
  FillRect(sheet, 0, 0, sheet.width, sheet.height, bg);
  for (size_t i = 0; i < cells.size(); ++i) {
    const picture::Image& c = cells[i];
    const int x0 = pad + static_cast<int>(i % columns) * (cw + pad),
              y0 = pad + static_cast<int>(i / columns) * (ch + label_h + pad);
    for (int y = 0; y < c.height; ++y) {
      std::memcpy(&sheet.rgba[(static_cast<size_t>(y0 + y) * sheet.width + x0) * 4],
                  &c.rgba[static_cast<size_t>(y) * c.width * 4], static_cast<size_t>(c.width) * 16);
    }
    if (i <
        labels.size()) {  // Cut to the cell's width: a long label never runs into the next cell.
      const int size = label_h * 2 / 3;
      DrawText(sheet, x0 + 4, y0 + ch + label_h * 3 / 4, FitText(labels[i], size, cw - 8), size,
               {0.1f, 0.1f, 0.1f});
    }
  }
  return sheet;
}

}  // namespace facespace::offscreen
