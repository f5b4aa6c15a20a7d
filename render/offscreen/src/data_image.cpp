// Images of data rather than light, for labelled datasets: planes of floats as EXR (depth, normals)
// and ids as grey PNG (segmentation), written as they are: no colour space, no tone.
#include <immintrin.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <vector>

#include "facespace/offscreen/render.h"
#include "internal.h"

namespace facespace::offscreen {

namespace {

void PutLE(std::string& out, uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
}

// One EXR header attribute: name, type, size, value.
void Attribute(std::string& out, const char* name, const char* type, const std::string& value) {
  out.append(name).push_back('\0');
  out.append(type).push_back('\0');
  PutLE(out, value.size(), 4);
  out += value;
}

// `raw` deflated in one call (StartDeflate), or "" when that fails.
std::string Deflated(std::string_view raw) {
  std::string out(raw.size() + raw.size() / 8 + 1024, '\0');
  isal_zstream z;
  StartDeflate(z);
  z.end_of_stream = 1;
  z.next_in = reinterpret_cast<uint8_t*>(const_cast<char*>(raw.data()));
  z.avail_in = static_cast<uint32_t>(raw.size());
  z.next_out = reinterpret_cast<uint8_t*>(out.data());
  z.avail_out = static_cast<uint32_t>(out.size());
  if (isal_deflate(&z) != COMP_OK || z.avail_in != 0 || z.internal_state.state != ZSTATE_END)
    return {};
  out.resize(z.total_out);
  return out;
}

// OpenEXR's ZIP block: bytes split into even and odd halves, each byte the difference from the one
// before
// (+128), deflated (Deflated). Left raw when that is no smaller, as readers expect. Plain byte
// loops the compiler vectorises: this was a tenth of a labelled sample's time as one loop indexing
// a string.
std::string ZipBlock(std::string_view raw, std::vector<uint8_t>& split, std::string& predicted) {
  const size_t n = raw.size(), half = (n + 1) / 2;
  const auto* in = reinterpret_cast<const uint8_t*>(raw.data());
  split.resize(n);
  predicted.resize(n);
  uint8_t* even = split.data();
  uint8_t* odd = split.data() + half;
  for (size_t j = 0; j < n / 2; ++j) even[j] = in[2 * j], odd[j] = in[2 * j + 1];
  if (n % 2) even[half - 1] = in[n - 1];
  auto* to = reinterpret_cast<uint8_t*>(predicted.data());
  if (n) to[0] = split[0];
  for (size_t i = 1; i < n; ++i) to[i] = static_cast<uint8_t>(split[i] - split[i - 1] + 128);
  std::string out = Deflated(predicted);
  return out.empty() || out.size() >= n ? std::string(raw) : out;
}

// `in` as halves into `out` (n each): eight at a time by F16C where the CPU has it, the rest by
// HalfOf, which rounds the same way.
__attribute__((target("avx,f16c"))) void HalvesF16c(const float* in, uint16_t* out, size_t n) {
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + i),
                     _mm256_cvtps_ph(_mm256_loadu_ps(in + i), _MM_FROUND_TO_NEAREST_INT));
  }
  for (; i < n; ++i) out[i] = HalfOf(in[i]);
}

void Halves(const float* in, uint16_t* out, size_t n) {
  static const bool f16c = __builtin_cpu_supports(
      "avx2");  // Every CPU with AVX2 has F16C (clang's builtin does not name it).
  if (f16c) return HalvesF16c(in, out, n);
  for (size_t i = 0; i < n; ++i) out[i] = HalfOf(in[i]);
}

}  // namespace

uint16_t HalfOf(float f) {
  uint32_t x = 0;
  std::memcpy(&x, &f, 4);
  const uint32_t sign = (x >> 16) & 0x8000u, abs = x & 0x7fffffffu;
  if (abs >= 0x7f800000u)
    return static_cast<uint16_t>(
        sign | 0x7c00u | (abs > 0x7f800000u ? 0x200u | ((abs >> 13) & 0x3ffu) : 0u));  // inf, NaN
  if (abs >= 0x477ff000u)
    return static_cast<uint16_t>(sign | 0x7c00u);  // 65520 and over: infinity.
  uint32_t h, rest, halfway;
  if (abs >= 0x38800000u) {  // A normal half: the exponent rebased, 13 bits rounded off.
    h = (abs - 0x38000000u) >> 13, rest = abs & 0x1fffu, halfway = 0x1000u;
  } else if (abs >= 0x33000000u) {  // A subnormal half (from 2^-25): the mantissa with its leading
                                    // 1, shifted.
    const uint32_t shift = 126 - (abs >> 23), m = (abs & 0x7fffffu) | 0x800000u;
    h = m >> shift, rest = m & ((1u << shift) - 1), halfway = 1u << (shift - 1);
  } else {
    return static_cast<uint16_t>(sign);
  }
  if (rest > halfway || (rest == halfway && (h & 1u)))
    ++h;  // A carry into the exponent is the next half up.
  return static_cast<uint16_t>(sign | h);
}

// A scanline EXR of 32-bit float or 16-bit half channels, ZIP-compressed in blocks of 16 lines,
// written here rather than through OpenImageIO: a 256² depth plane took 1.4-2.2 ms there (its I/O
// proxy and OpenEXR's zlib at any level, and "none" was slower still), a fifth of a labelled
// sample's time. OpenImageIO reads them back in the tests. Channels are stored by name,
// alphabetically: "Y", or B, G, R.
Result<std::string> EncodeDataExr(std::span<const float> values, int width, int height,
                                  int channels, picture::DataPrecision precision) {
  if (width < 1 || height < 1 || (channels != 1 && channels != 3) ||
      values.size() != static_cast<size_t>(width) * static_cast<size_t>(height) *
                           static_cast<size_t>(channels)) {
    return InvalidArgument("a data image of " + std::to_string(values.size()) + " values is not " +
                           std::to_string(width) + " x " + std::to_string(height) + " x " +
                           std::to_string(channels));
  }
  const size_t w = static_cast<size_t>(width), h = static_cast<size_t>(height),
               c = static_cast<size_t>(channels);
  const bool half = precision == picture::DataPrecision::kHalf;
  const char* const names[3] = {"B", "G",
                                "R"};  // Stored in this order: value index 2, 1, 0 of a pixel.
  std::string chlist;
  for (size_t k = 0; k < c; ++k) {
    chlist.append(c == 1 ? "Y" : names[k]).push_back('\0');
    PutLE(chlist, half ? 1 : 2, 4);  // HALF or FLOAT
    PutLE(chlist, 0, 4);             // pLinear and reserved
    PutLE(chlist, 1, 4);             // xSampling
    PutLE(chlist, 1, 4);             // ySampling
  }
  chlist.push_back('\0');
  std::string box;
  for (uint64_t v : {uint64_t{0}, uint64_t{0}, uint64_t{w - 1}, uint64_t{h - 1}}) PutLE(box, v, 4);
  std::string one, zero8;
  const float unit = 1.0f;
  one.assign(reinterpret_cast<const char*>(&unit), 4);
  zero8.assign(8, '\0');
  std::string out("\x76\x2f\x31\x01\x02\x00\x00\x00", 8);
  Attribute(out, "channels", "chlist", chlist);
  Attribute(out, "compression", "compression", std::string(1, '\x03'));  // ZIP, 16 lines a block.
  Attribute(out, "dataWindow", "box2i", box);
  Attribute(out, "displayWindow", "box2i", box);
  Attribute(out, "lineOrder", "lineOrder", std::string(1, '\0'));
  Attribute(out, "pixelAspectRatio", "float", one);
  Attribute(out, "screenWindowCenter", "v2f", zero8);
  Attribute(out, "screenWindowWidth", "float", one);
  out.push_back('\0');
  const size_t blocks = (h + 15) / 16, table = out.size();
  out.append(8 * blocks, '\0');
  std::string raw, halves, predicted;
  std::vector<uint8_t> split;
  for (size_t b = 0; b < blocks; ++b) {
    const size_t first = 16 * b, lines = std::min(h, first + 16) - first;
    raw.resize(lines * w * c * 4);
    float* to = reinterpret_cast<float*>(raw.data());  // Each line's channels one after the other.
    for (size_t y = first; y < first + lines; ++y) {
      for (size_t k = 0; k < c; ++k) {
        const float* from = &values[y * w * c + (c == 1 ? 0 : 2 - k)];
        for (size_t x = 0; x < w; ++x) *to++ = from[x * c];
      }
    }
    for (int i = 0; i < 8; ++i)
      out[table + 8 * b + static_cast<size_t>(i)] =
          static_cast<char>(static_cast<uint64_t>(out.size()) >> (8 * i));
    if (half) {
      halves.resize(raw.size() / 2);
      Halves(reinterpret_cast<const float*>(raw.data()), reinterpret_cast<uint16_t*>(halves.data()),
             raw.size() / 4);
    }
    const std::string block = ZipBlock(half ? halves : raw, split, predicted);
    PutLE(out, 16 * b, 4);
    PutLE(out, block.size(), 4);
    out += block;
  }
  return out;
}

Result<std::string> EncodeIdPng(std::span<const uint16_t> ids, int width, int height) {
  const size_t w = static_cast<size_t>(std::max(width, 0)),
               h = static_cast<size_t>(std::max(height, 0));
  if (w == 0 || h == 0 || ids.size() != w * h)
    return InvalidArgument("an id image of " + std::to_string(ids.size()) +
                           " values is not its size");
  const bool wide = *std::max_element(ids.begin(), ids.end()) > 255;
  const size_t line = 1 + w * (wide ? 2 : 1);
  std::string raw(
      line * h, '\0');  // Filter 0 (none) on every row: ids are flat areas, deflate does the rest.
  for (size_t y = 0; y < h; ++y) {
    unsigned char* row = reinterpret_cast<unsigned char*>(&raw[y * line + 1]);
    for (size_t x = 0; x < w; ++x) {
      const uint16_t id = ids[y * w + x];
      if (wide)
        row[2 * x] = static_cast<unsigned char>(id >> 8),
                row[2 * x + 1] = static_cast<unsigned char>(id);
      else
        row[x] = static_cast<unsigned char>(id);
    }
  }
  const std::string deflated = Deflated(raw);
  if (deflated.empty()) return Internal("igzip: deflate failed");
  std::string out("\x89PNG\r\n\x1a\n", 8), header;
  PutBigEndian(header, static_cast<uint32_t>(w));
  PutBigEndian(header, static_cast<uint32_t>(h));
  header += std::string(wide ? "\x10\x00\x00\x00\x00" : "\x08\x00\x00\x00\x00",
                        5);  // 16 or 8 bits, grey, deflate, filters, no interlace.
  Chunk(out, "IHDR", header);
  Chunk(out, "IDAT", deflated);
  Chunk(out, "IEND", "");
  return out;
}

}  // namespace facespace::offscreen
