// UTF-8, one code point at a time: what RepairUtf8 keeps and what text on images draws.
#pragma once

#include <cstddef>
#include <string_view>

namespace facespace {
inline namespace engine {

// The length (1-4) of the well-formed UTF-8 sequence at `s[i]`, with its code point in `cp`; 0 when
// the bytes there are not one (a stray continuation byte, an overlong form, a surrogate, past
// U+10FFFF, cut short).
inline size_t DecodeUtf8(std::string_view s, size_t i, char32_t& cp) {
  const auto* p = reinterpret_cast<const unsigned char*>(s.data());
  const unsigned char c = p[i];
  if (c < 0x80) return cp = c, 1;
  size_t len = 0;
  if (c >= 0xC2 && c <= 0xDF)
    len = 2, cp = c & 0x1F;
  else if (c >= 0xE0 && c <= 0xEF)
    len = 3, cp = c & 0x0F;
  else if (c >= 0xF0 && c <= 0xF4)
    len = 4, cp = c & 0x07;
  else
    return 0;
  if (i + len > s.size()) return 0;
  for (size_t k = 1; k < len; ++k) {
    if ((p[i + k] & 0xC0) != 0x80) return 0;
    cp = (cp << 6) | (p[i + k] & 0x3F);
  }
  if ((len == 3 && (cp < 0x800 || (cp >= 0xD800 && cp <= 0xDFFF))) ||
      (len == 4 && (cp < 0x10000 || cp > 0x10FFFF)))
    return 0;
  return len;
}

}  // namespace engine
}  // namespace facespace
