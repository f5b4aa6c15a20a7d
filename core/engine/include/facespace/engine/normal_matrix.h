// Shared by core's .cpp files only.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace facespace {
inline namespace engine {

#if defined(__SSE2__)
// Four xyz triples (12 floats at `p`) as x, y and z lanes, and back: shuffles in registers.
inline void LoadXyz4(const float* p, __m128& x, __m128& y, __m128& z) {
  const __m128 a = _mm_loadu_ps(p), b = _mm_loadu_ps(p + 4),
               c = _mm_loadu_ps(p + 8);  // x0y0z0x1 y1z1x2y2 z2x3y3z3
  x = _mm_shuffle_ps(_mm_shuffle_ps(a, a, _MM_SHUFFLE(3, 3, 0, 0)),
                     _mm_shuffle_ps(b, c, _MM_SHUFFLE(1, 1, 2, 2)), _MM_SHUFFLE(2, 0, 2, 0));
  y = _mm_shuffle_ps(_mm_shuffle_ps(a, b, _MM_SHUFFLE(0, 0, 1, 1)),
                     _mm_shuffle_ps(b, c, _MM_SHUFFLE(2, 2, 3, 3)), _MM_SHUFFLE(2, 0, 2, 0));
  z = _mm_shuffle_ps(_mm_shuffle_ps(a, b, _MM_SHUFFLE(1, 1, 2, 2)),
                     _mm_shuffle_ps(c, c, _MM_SHUFFLE(3, 3, 0, 0)), _MM_SHUFFLE(2, 0, 2, 0));
}

inline void StoreXyz4(__m128 x, __m128 y, __m128 z, float* p) {
  _mm_storeu_ps(
      p, _mm_shuffle_ps(_mm_shuffle_ps(x, y, _MM_SHUFFLE(0, 0, 0, 0)),
                        _mm_shuffle_ps(z, x, _MM_SHUFFLE(1, 1, 0, 0)), _MM_SHUFFLE(2, 0, 2, 0)));
  _mm_storeu_ps(p + 4, _mm_shuffle_ps(_mm_shuffle_ps(y, z, _MM_SHUFFLE(1, 1, 1, 1)),
                                      _mm_shuffle_ps(x, y, _MM_SHUFFLE(2, 2, 2, 2)),
                                      _MM_SHUFFLE(2, 0, 2, 0)));
  _mm_storeu_ps(p + 8, _mm_shuffle_ps(_mm_shuffle_ps(z, x, _MM_SHUFFLE(3, 3, 2, 2)),
                                      _mm_shuffle_ps(y, z, _MM_SHUFFLE(3, 3, 3, 3)),
                                      _MM_SHUFFLE(2, 0, 2, 0)));
}
#endif

// A blended normal (or tangent) scaled to unit length in place, as EvaluateRig leaves a moved
// vertex's: kept when its length is 1e-30 or less. F32Blender repeats the blend with it, bit for
// bit.
inline void Normalize3(float* v) {
  const float len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (len > 1e-30f) {
    const float inv = 1.0f / len;
    v[0] *= inv;
    v[1] *= inv;
    v[2] *= inv;
  }
}

// n' = normalize(inverse-transpose(A) n) for the upper 3x3 A of a column-major matrix with
// column stride `stride` (4 for a 4x4, 3 for a 3x4). Uses the cofactor matrix (the
// determinant's scale drops out on normalising; its sign keeps normals outward under
// mirroring), made once per matrix for a loop over vertices. Apply returns n unchanged when A
// is singular.
struct NormalMatrix {
  float cof[9];
  float sgn;
  NormalMatrix(const float* m, int stride) {
    const float a = m[0], b = m[stride], c = m[2 * stride], d = m[1], e = m[stride + 1],
                f = m[2 * stride + 1], g = m[2], h = m[stride + 2], i = m[2 * stride + 2];
    const float k[9] = {e * i - f * h,    -(d * i - f * g), d * h - e * g,
                        -(b * i - c * h), a * i - c * g,    -(a * h - b * g),
                        b * f - c * e,    -(a * f - c * d), a * e - b * d};
    for (int j = 0; j < 9; ++j) cof[j] = k[j];
    sgn = a * cof[0] + b * cof[1] + c * cof[2] < 0.0f ? -1.0f : 1.0f;
  }
  void Apply(const float* n, float* out) const {
    float o[3];
    for (int r = 0; r < 3; ++r)
      o[r] = sgn * (cof[3 * r] * n[0] + cof[3 * r + 1] * n[1] + cof[3 * r + 2] * n[2]);
    const float len = std::sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
    for (int r = 0; r < 3; ++r) out[r] = len > 0.0f ? o[r] / len : n[r];
  }
  // Apply to `count` xyz normals from `n` into `out` (not overlapping): four at a time in SSE
  // registers where there are some, with the same operations in the same order as Apply, so the
  // same bits (IEEE division and square root are exact in either form; no fused multiply-add).
  // Bit k of `unit_first` (count <= 64 when any is set) scales normal k to unit length first, as
  // Normalize3 does: a blended normal, normalised and placed in one pass.
  void ApplyMany(const float* n, size_t count, float* out, uint64_t unit_first = 0) const {
    size_t v = 0;
#if defined(__SSE2__)
    const __m128 s = _mm_set1_ps(sgn), zero = _mm_setzero_ps(), tiny = _mm_set1_ps(1e-30f),
                 one = _mm_set1_ps(1.0f);
    for (; v + 4 <= count; v += 4, n += 12, out += 12) {
      __m128 x, y, z;
      LoadXyz4(n, x, y, z);
      if (const uint64_t bits = unit_first != 0 ? unit_first >> v & 15 : 0; bits != 0) {
        const __m128i lane =
            _mm_set_epi32(-static_cast<int>(bits >> 3 & 1), -static_cast<int>(bits >> 2 & 1),
                          -static_cast<int>(bits >> 1 & 1), -static_cast<int>(bits & 1));
        const __m128 len = _mm_sqrt_ps(
            _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)), _mm_mul_ps(z, z)));
        const __m128 scaled = _mm_and_ps(_mm_castsi128_ps(lane),
                                         _mm_cmpgt_ps(len, tiny));  // False for NaN, as Normalize3.
        const __m128 inv = _mm_div_ps(one, len);
        x = _mm_or_ps(_mm_and_ps(scaled, _mm_mul_ps(x, inv)), _mm_andnot_ps(scaled, x));
        y = _mm_or_ps(_mm_and_ps(scaled, _mm_mul_ps(y, inv)), _mm_andnot_ps(scaled, y));
        z = _mm_or_ps(_mm_and_ps(scaled, _mm_mul_ps(z, inv)), _mm_andnot_ps(scaled, z));
      }
      __m128 o[3];
      for (int r = 0; r < 3; ++r) {
        const __m128 dot = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_set1_ps(cof[3 * r]), x),
                                                 _mm_mul_ps(_mm_set1_ps(cof[3 * r + 1]), y)),
                                      _mm_mul_ps(_mm_set1_ps(cof[3 * r + 2]), z));
        o[r] = _mm_mul_ps(s, dot);
      }
      const __m128 len = _mm_sqrt_ps(_mm_add_ps(
          _mm_add_ps(_mm_mul_ps(o[0], o[0]), _mm_mul_ps(o[1], o[1])), _mm_mul_ps(o[2], o[2])));
      const __m128 positive = _mm_cmpgt_ps(len, zero);  // False for 0 and NaN, as in Apply.
      const __m128 kept[3] = {x, y, z};
      __m128 res[3];
      for (int r = 0; r < 3; ++r)
        res[r] = _mm_or_ps(_mm_and_ps(positive, _mm_div_ps(o[r], len)),
                           _mm_andnot_ps(positive, kept[r]));
      StoreXyz4(res[0], res[1], res[2], out);
    }
#endif
    for (; v < count; ++v, n += 3, out += 3) {
      float t[3] = {n[0], n[1], n[2]};
      if (unit_first != 0 && (unit_first >> v & 1)) Normalize3(t);
      Apply(t, out);
    }
  }
};

inline void TransformNormal(const float* m, int stride, const float* n, float* out) {
  NormalMatrix(m, stride).Apply(n, out);
}

}  // namespace engine
}  // namespace facespace
