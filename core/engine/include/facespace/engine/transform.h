// Transforms: TRS (glTF order), quaternions (x, y, z, w), column-major 4x4 matrices.
#pragma once

#include <array>
#include <span>

namespace facespace {
inline namespace engine {

struct Transform {
  std::array<float, 3> translation{0, 0, 0};
  std::array<float, 4> rotation{0, 0, 0, 1};  // x, y, z, w (glTF order), unit length.
  std::array<float, 3> scale{1, 1, 1};
};

// Quaternion helpers (x, y, z, w).
std::array<float, 4> Slerp(const std::array<float, 4>& a, const std::array<float, 4>& b, float t);
std::array<float, 4> EulerToQuaternion(float x_deg, float y_deg, float z_deg);  // R = Rz * Ry * Rx.

// The unit quaternion of q; the identity for a zero or non-finite one.
std::array<float, 4> NormalizedQuaternion(std::array<float, 4> q);

// Column-major 4x4 matrix of a TRS: T * R * S.
std::array<float, 16> ComposeTrs(const Transform& t);

// Column-major 4x4 `m` applied to (p, w): a point for w = 1, a direction for w = 0. out may not
// alias p.
inline void TransformPoint(std::span<const float, 16> m, const float* p, float* out,
                           float w = 1.0f) {
  for (int r = 0; r < 3; ++r)
    out[r] = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r] * w;
}

}  // namespace engine
}  // namespace facespace
