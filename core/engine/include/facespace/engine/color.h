// Colour encodings shared by what draws and what writes files.
#pragma once

#include <algorithm>
#include <cmath>

namespace facespace {
inline namespace engine {

// sRGB's encoding of a linear value, clamped to [0, 1] first.
inline double SrgbEncode(double linear) {
  const double c = std::clamp(linear, 0.0, 1.0);
  return c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
}

// The linear value an sRGB encoding stands for.
inline double SrgbDecode(double encoded) {
  return encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4);
}

}  // namespace engine
}  // namespace facespace
