// Shared by core's .cpp files only.
#pragma once

#include <cmath>

namespace facespace {

// n' = normalize(inverse-transpose(A) n) for the upper 3x3 A of a column-major matrix with
// column stride `stride` (4 for a 4x4, 3 for a 3x4). Uses the cofactor matrix (the
// determinant's scale drops out on normalising; its sign keeps normals outward under
// mirroring), made once per matrix for a loop over vertices. Apply returns n unchanged when A
// is singular.
struct NormalMatrix {
  float cof[9];
  float sgn;
  NormalMatrix(const float* m, int stride) {
    const float a = m[0], b = m[stride], c = m[2 * stride], d = m[1], e = m[stride + 1], f = m[2 * stride + 1], g = m[2],
                h = m[stride + 2], i = m[2 * stride + 2];
    const float k[9] = {e * i - f * h, -(d * i - f * g), d * h - e * g, -(b * i - c * h), a * i - c * g,
                        -(a * h - b * g), b * f - c * e, -(a * f - c * d), a * e - b * d};
    for (int j = 0; j < 9; ++j) cof[j] = k[j];
    sgn = a * cof[0] + b * cof[1] + c * cof[2] < 0.0f ? -1.0f : 1.0f;
  }
  void Apply(const float* n, float* out) const {
    float o[3];
    for (int r = 0; r < 3; ++r) o[r] = sgn * (cof[3 * r] * n[0] + cof[3 * r + 1] * n[1] + cof[3 * r + 2] * n[2]);
    const float len = std::sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
    for (int r = 0; r < 3; ++r) out[r] = len > 0.0f ? o[r] / len : n[r];
  }
};

inline void TransformNormal(const float* m, int stride, const float* n, float* out) { NormalMatrix(m, stride).Apply(n, out); }

}  // namespace facespace
