// Occlusion baked from depth maps (occlusion.h): per direction, the mesh rasterised
// orthographically keeping the nearest depth toward the sky, then each vertex looked up.
#include "facespace/engine/occlusion.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "facespace/engine/blend.h"
#include "facespace/engine/normal_matrix.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/transform.h"

namespace facespace {
inline namespace engine {

namespace {

float Dot(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Direction k of `count` spread evenly over the sphere (a Fibonacci lattice).
void SphereDirection(int k, int count, float d[3]) {
  const float z = 1.0f - (2.0f * static_cast<float>(k) + 1.0f) / static_cast<float>(count);
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  const float phi = 2.39996323f * static_cast<float>(k);  // The golden angle.
  d[0] = r * std::cos(phi);
  d[1] = r * std::sin(phi);
  d[2] = z;
}

// One direction's depth map: per pixel the largest depth along the direction (what the sky meets
// first), -inf where nothing is.
struct DepthMap {
  int size = 0;
  float x0 = 0, y0 = 0, scale = 1;  // Pixel = (coordinate - origin) * scale.
  std::vector<float> depth;
};

// The mesh's vertices in the frame (u, v, d) of one direction, as pixel x, pixel y and depth.
void Project(std::span<const float> positions, const float u[3], const float v[3], const float d[3],
             const DepthMap& map, std::span<float> projected) {
  for (size_t i = 0; i < positions.size() / 3; ++i) {
    const float* p = &positions[3 * i];
    projected[3 * i] = (Dot(p, u) - map.x0) * map.scale;
    projected[3 * i + 1] = (Dot(p, v) - map.y0) * map.scale;
    projected[3 * i + 2] = Dot(p, d);
  }
}

// One triangle into the map: pixel centres inside it (either winding) keep the larger depth.
void RasterizeTriangle(const float* a, const float* b, const float* c, DepthMap& map) {
  const float area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
  if (!(std::abs(area) > 1e-12f)) return;
  const float n = static_cast<float>(map.size - 1);
  const int x_lo =
      static_cast<int>(std::clamp(std::ceil(std::min({a[0], b[0], c[0]}) - 0.5f), 0.0f, n));
  const int x_hi =
      static_cast<int>(std::clamp(std::floor(std::max({a[0], b[0], c[0]}) - 0.5f), -1.0f, n));
  const int y_lo =
      static_cast<int>(std::clamp(std::ceil(std::min({a[1], b[1], c[1]}) - 0.5f), 0.0f, n));
  const int y_hi =
      static_cast<int>(std::clamp(std::floor(std::max({a[1], b[1], c[1]}) - 0.5f), -1.0f, n));
  const float inv = 1.0f / area;
  for (int y = y_lo; y <= y_hi; ++y) {
    for (int x = x_lo; x <= x_hi; ++x) {
      const float px = static_cast<float>(x) + 0.5f, py = static_cast<float>(y) + 0.5f;
      const float wa = ((b[0] - px) * (c[1] - py) - (b[1] - py) * (c[0] - px)) * inv;
      const float wb = ((c[0] - px) * (a[1] - py) - (c[1] - py) * (a[0] - px)) * inv;
      const float wc = 1.0f - wa - wb;
      if (wa < 0 || wb < 0 || wc < 0) continue;
      float& z = map.depth[static_cast<size_t>(y) * static_cast<size_t>(map.size) +
                           static_cast<size_t>(x)];
      z = std::max(z, wa * a[2] + wb * b[2] + wc * c[2]);
    }
  }
}

// Whether a point at pixel (x, y) and depth z sees the sky: the share of the four pixels around it
// with nothing more than `bias` nearer the sky (a soft edge rather than a pixel's staircase).
float Visible(const DepthMap& map, float x, float y, float z, float bias) {
  const int x0 = static_cast<int>(std::floor(x - 0.5f)),
            y0 = static_cast<int>(std::floor(y - 0.5f));
  float seen = 0;
  for (int j = y0; j <= y0 + 1; ++j) {
    for (int i = x0; i <= x0 + 1; ++i) {
      const bool outside = i < 0 || j < 0 || i >= map.size || j >= map.size;
      seen += outside || z >= map.depth[static_cast<size_t>(j) * static_cast<size_t>(map.size) +
                                        static_cast<size_t>(i)] -
                                  bias
                  ? 0.25f
                  : 0.0f;
    }
  }
  return seen;
}

}  // namespace

void OcclusionFrame(const float n[3], float t[3], float s[3]) {
  const float sign = std::copysign(1.0f, n[2]);
  const float a = -1.0f / (sign + n[2]);
  const float b = n[0] * n[1] * a;
  t[0] = 1.0f + sign * n[0] * n[0] * a;
  t[1] = sign * b;
  t[2] = -sign * n[0];
  s[0] = b;
  s[1] = sign + n[1] * n[1] * a;
  s[2] = -n[1];
}

float LightVisibility(float ao, const float b[3], const float n[3], const float l[3]) {
  const float open = 0.5f + 0.75f * std::max(Dot(n, l), 0.0f);
  return std::clamp((0.5f * ao + 0.75f * Dot(b, l)) / open, 0.0f, 1.0f);
}

namespace {

// Per vertex: the cosine-weighted visible and total shares of the hemisphere, and the visible
// directions' sum (world space): kSums floats.
constexpr size_t kSums = 5;

// One direction's looks: each vertex facing it, pushed 1.5 pixels out along its normal (so its own
// surface does not hide it), is looked up in the map.
void Accumulate(const DepthMap& map, std::span<const float> projected,
                std::span<const float> normals, const float u[3], const float v[3],
                const float d[3], std::span<float> sums) {
  const float pixel = 1.0f / map.scale;
  for (size_t i = 0; i < projected.size() / 3; ++i) {
    const float* n = &normals[3 * i];
    const float cos = Dot(n, d);
    if (!(cos > 0.0f)) continue;
    const float seen =
        Visible(map, projected[3 * i] + 1.5f * Dot(n, u), projected[3 * i + 1] + 1.5f * Dot(n, v),
                projected[3 * i + 2] + 1.5f * pixel * cos, pixel);
    float* s = &sums[kSums * i];
    s[0] += seen * cos;
    s[1] += cos;
    for (int c = 0; c < 3; ++c) s[2 + c] += seen * d[c];
  }
}

// The sums into kOcclusionFloats per vertex: ao, and b in the normal's frame.
void Finish(std::span<const float> sums, std::span<const float> normals, int directions,
            std::span<float> out) {
  for (size_t i = 0; i < sums.size() / kSums; ++i) {
    const float* s = &sums[kSums * i];
    const float* n = &normals[3 * i];
    float* o = &out[kOcclusionFloats * i];
    if (!(s[1] > 0.0f)) continue;  // No direction faced it (no usable normal): left open.
    float t[3], bt[3], b[3];
    OcclusionFrame(n, t, bt);
    for (int c = 0; c < 3; ++c) b[c] = 4.0f * s[2 + c] / static_cast<float>(directions);
    o[0] = s[0] / s[1];
    o[1] = Dot(b, t);
    o[2] = Dot(b, bt);
    o[3] = Dot(b, n);
  }
}

// The centre and radius of a sphere around every position.
void Bounds(std::span<const float> positions, float center[3], float& radius) {
  float lo[3], hi[3];
  for (int c = 0; c < 3; ++c)
    lo[c] = std::numeric_limits<float>::max(), hi[c] = std::numeric_limits<float>::lowest();
  for (size_t i = 0; i < positions.size(); ++i) {
    lo[i % 3] = std::min(lo[i % 3], positions[i]);
    hi[i % 3] = std::max(hi[i % 3], positions[i]);
  }
  float r2 = 0;
  for (int c = 0; c < 3; ++c) {
    center[c] = 0.5f * (lo[c] + hi[c]);
    r2 += 0.25f * (hi[c] - lo[c]) * (hi[c] - lo[c]);
  }
  radius = std::max(std::sqrt(r2) * 1.01f, 1e-6f);
}

}  // namespace

void BakeOcclusion(std::span<const float> positions, std::span<const float> normals,
                   std::span<const uint32_t> triangles, const OcclusionSettings& settings,
                   std::span<float> out) {
  const size_t count = positions.size() / 3;
  for (size_t i = 0; i < count; ++i)
    std::copy(kOpenOcclusion.begin(), kOpenOcclusion.end(),
              out.begin() + static_cast<long>(kOcclusionFloats * i));
  if (triangles.size() < 3 || count == 0 || normals.size() < positions.size()) return;
  float center[3], radius;
  Bounds(positions, center, radius);
  DepthMap map;
  map.size = std::clamp(settings.resolution, 16, 1024);
  map.scale = static_cast<float>(map.size) / (2.0f * radius);
  map.depth.resize(static_cast<size_t>(map.size) * static_cast<size_t>(map.size));
  std::vector<float> projected(3 * count), sums(kSums * count, 0.0f);
  const int directions = std::clamp(settings.directions, 8, 1024);
  for (int k = 0; k < directions; ++k) {
    float d[3], u[3], v[3];
    SphereDirection(k, directions, d);
    OcclusionFrame(d, u, v);
    map.x0 = Dot(center, u) - radius;
    map.y0 = Dot(center, v) - radius;
    std::fill(map.depth.begin(), map.depth.end(), -std::numeric_limits<float>::infinity());
    Project(positions, u, v, d, map, projected);
    for (size_t t = 0; t + 2 < triangles.size(); t += 3) {
      if (triangles[t] >= count || triangles[t + 1] >= count || triangles[t + 2] >= count) continue;
      RasterizeTriangle(&projected[3 * triangles[t]], &projected[3 * triangles[t + 1]],
                        &projected[3 * triangles[t + 2]], map);
    }
    Accumulate(map, projected, normals, u, v, d, sums);
  }
  Finish(sums, normals, directions, out);
}

namespace {

// One primitive's vertices and normals in scene space appended to `positions` and `normals`.
void AppendScene(const Primitive& p, const BlendedPrimitive& b, std::vector<float>& positions,
                 std::vector<float>& normals) {
  for (size_t v = 0;
       v < p.vertex_count() && 3 * v + 2 < b.positions.size() && 3 * v + 2 < b.normals.size();
       ++v) {
    float q[3], n[3];
    TransformPoint(b.world, &b.positions[3 * v], q);
    TransformPoint(b.world, &b.normals[3 * v], n,
                   0.0f);  // Uniform scale: the normal's direction stays.
    Normalize3(n);
    positions.insert(positions.end(), q, q + 3);
    normals.insert(normals.end(), n, n + 3);
  }
}

}  // namespace

RigOcclusion BakeRigOcclusion(const Rig& rig, const BlendedRig& rest,
                              const OcclusionSettings& settings) {
  std::vector<float> positions, normals;
  std::vector<uint32_t> triangles;
  std::vector<size_t> first(rig.primitives.size() + 1, 0);
  for (size_t i = 0; i < rig.primitives.size() && i < rest.primitives.size(); ++i) {
    const Primitive& p = rig.primitives[i];
    const uint32_t base = static_cast<uint32_t>(positions.size() / 3);
    AppendScene(p, rest.primitives[i], positions, normals);
    first[i + 1] = positions.size() / 3;
    const bool overlay = p.material >= 0 &&
                         static_cast<size_t>(p.material) < rig.materials.size() &&
                         rig.materials[static_cast<size_t>(p.material)].alpha_mode == "BLEND";
    if (p.mode != PrimitiveMode::kTriangles || overlay) continue;
    const uint32_t count = static_cast<uint32_t>(first[i + 1] - first[i]);
    for (uint32_t index : p.indices)
      triangles.push_back(index < count ? base + index : UINT32_MAX);  // The bake skips these.
  }
  for (size_t i = rest.primitives.size(); i < rig.primitives.size(); ++i) first[i + 1] = first[i];
  std::vector<float> baked(kOcclusionFloats * (positions.size() / 3));
  BakeOcclusion(positions, normals, triangles, settings, baked);
  RigOcclusion out(rig.primitives.size());
  for (size_t i = 0; i < rig.primitives.size(); ++i) {
    if (rig.primitives[i].mode != PrimitiveMode::kTriangles) continue;
    out[i].assign(baked.begin() + static_cast<long>(kOcclusionFloats * first[i]),
                  baked.begin() + static_cast<long>(kOcclusionFloats * first[i + 1]));
  }
  return out;
}

}  // namespace engine
}  // namespace facespace
