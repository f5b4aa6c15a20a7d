// Shared by core's .cpp files only.
#pragma once

#include <cmath>
#include <cstddef>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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
  // Apply to `count` xyz normals from `n` into `out` (not overlapping): four at a time in SSE
  // registers where there are some, with the same operations in the same order as Apply, so the
  // same bits (IEEE division and square root are exact in either form; no fused multiply-add).
  void ApplyMany(const float* n, size_t count, float* out) const {
    size_t v = 0;
#if defined(__SSE2__)
    const __m128 s = _mm_set1_ps(sgn), zero = _mm_setzero_ps();
    for (; v + 4 <= count; v += 4, n += 12, out += 12) {
      alignas(16) float in[3][4], res[3][4];
      for (int k = 0; k < 4; ++k) {
        for (int r = 0; r < 3; ++r) in[r][k] = n[3 * k + r];
      }
      const __m128 x = _mm_load_ps(in[0]), y = _mm_load_ps(in[1]), z = _mm_load_ps(in[2]);
      __m128 o[3];
      for (int r = 0; r < 3; ++r) {
        const __m128 dot = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_set1_ps(cof[3 * r]), x), _mm_mul_ps(_mm_set1_ps(cof[3 * r + 1]), y)),
                                      _mm_mul_ps(_mm_set1_ps(cof[3 * r + 2]), z));
        o[r] = _mm_mul_ps(s, dot);
      }
      const __m128 len = _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(o[0], o[0]), _mm_mul_ps(o[1], o[1])), _mm_mul_ps(o[2], o[2])));
      const __m128 positive = _mm_cmpgt_ps(len, zero);  // False for 0 and NaN, as in Apply.
      const __m128 kept[3] = {x, y, z};
      for (int r = 0; r < 3; ++r) {
        _mm_store_ps(res[r], _mm_or_ps(_mm_and_ps(positive, _mm_div_ps(o[r], len)), _mm_andnot_ps(positive, kept[r])));
      }
      for (int k = 0; k < 4; ++k) {
        for (int r = 0; r < 3; ++r) out[3 * k + r] = res[r][k];
      }
    }
#endif
    for (; v < count; ++v, n += 3, out += 3) Apply(n, out);
  }
};

// A blended normal (or tangent) scaled to unit length in place, as EvaluateRig leaves a moved
// vertex's: kept when its length is 1e-30 or less. F32Blender repeats the blend with it, bit for bit.
inline void Normalize3(float* v) {
  const float len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (len > 1e-30f) {
    const float inv = 1.0f / len;
    v[0] *= inv;
    v[1] *= inv;
    v[2] *= inv;
  }
}

inline void TransformNormal(const float* m, int stride, const float* n, float* out) { NormalMatrix(m, stride).Apply(n, out); }

}  // namespace facespace
