// The occlusion bake (core/occlusion.h) on shapes whose answer is known: an open floor sees the
// whole sky, the inside of a closed box none of it, and a floor beside a wall is shaded from the
// wall's side.
#include "facespace/engine/occlusion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace facespace {
namespace occlusion_test {  // Named: core_tests is a unity build, its files share one unit.

struct Soup {
  std::vector<float> positions, normals;
  std::vector<uint32_t> triangles;
  // An n x n grid of quads from `origin` along `a` and `b` (unit-length steps of 1/n), normal
  // `normal`.
  void Grid(const float origin[3], const float a[3], const float b[3], const float normal[3],
            int n) {
    const uint32_t first = static_cast<uint32_t>(positions.size() / 3);
    for (int j = 0; j <= n; ++j) {
      for (int i = 0; i <= n; ++i) {
        for (int c = 0; c < 3; ++c)
          positions.push_back(origin[c] +
                              (a[c] * static_cast<float>(i) + b[c] * static_cast<float>(j)) /
                                  static_cast<float>(n));
        normals.insert(normals.end(), normal, normal + 3);
      }
    }
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        const uint32_t v = first + static_cast<uint32_t>(j * (n + 1) + i),
                       w = static_cast<uint32_t>(n + 1);
        triangles.insert(triangles.end(), {v, v + 1, v + w + 1, v, v + w + 1, v + w});
      }
    }
  }
  std::vector<float> Bake() const {
    std::vector<float> out(kOcclusionFloats * (positions.size() / 3));
    BakeOcclusion(positions, normals, triangles, OcclusionSettings{}, out);
    return out;
  }
  // The vertex nearest p.
  size_t Nearest(float x, float y, float z) const {
    size_t best = 0;
    float best_d = INFINITY;
    for (size_t i = 0; i < positions.size() / 3; ++i) {
      const float d =
          std::hypot(positions[3 * i] - x, positions[3 * i + 1] - y, positions[3 * i + 2] - z);
      if (d < best_d) best = i, best_d = d;
    }
    return best;
  }
};

// The light visibility of vertex v (unit normal n) toward l, from the baked values.
float Light(const std::vector<float>& baked, size_t v, const float n[3], std::array<float, 3> l) {
  const float len = std::hypot(l[0], l[1], l[2]);
  for (float& c : l) c /= len;
  float t[3], s[3], b[3];
  OcclusionFrame(n, t, s);
  const float* o = &baked[kOcclusionFloats * v];
  for (int c = 0; c < 3; ++c) b[c] = o[1] * t[c] + o[2] * s[c] + o[3] * n[c];
  return LightVisibility(o[0], b, n, l.data());
}

const float kX[3] = {1, 0, 0}, kY[3] = {0, 1, 0}, kZ[3] = {0, 0, 1};

TEST(Occlusion, AnOpenFloorSeesTheWholeSky) {
  Soup floor;
  const float origin[3] = {-0.5f, -0.5f, 0};
  floor.Grid(origin, kX, kY, kZ, 8);
  const std::vector<float> baked = floor.Bake();
  for (size_t v = 0; v < floor.positions.size() / 3; ++v) {
    EXPECT_NEAR(baked[4 * v], 1.0f, 1e-5f) << "vertex " << v;
    EXPECT_NEAR(baked[4 * v + 1], 0.0f, 0.02f);
    EXPECT_NEAR(baked[4 * v + 2], 0.0f, 0.02f);
    EXPECT_NEAR(baked[4 * v + 3], 1.0f,
                0.02f);  // 4 x the mean visible direction: the normal, for an open vertex.
  }
  EXPECT_NEAR(Light(baked, 0, kZ, {1, 0, 1}), 1.0f, 0.03f);
}

TEST(Occlusion, TheInsideOfAClosedBoxSeesNothing) {
  Soup box;  // A unit cube's six faces, normals inward.
  const float o0[3] = {0, 0, 0}, o1[3] = {1, 1, 1};
  const float nx[3] = {1, 0, 0}, ny[3] = {0, 1, 0}, nz[3] = {0, 0, 1}, mx[3] = {-1, 0, 0},
              my[3] = {0, -1, 0}, mz[3] = {0, 0, -1};
  const float mkX[3] = {-1, 0, 0}, mkY[3] = {0, -1, 0}, mkZ[3] = {0, 0, -1};
  box.Grid(o0, kY, kZ, nx, 4);
  box.Grid(o0, kX, kZ, ny, 4);
  box.Grid(o0, kX, kY, nz, 4);
  box.Grid(o1, mkY, mkZ, mx, 4);
  box.Grid(o1, mkX, mkZ, my, 4);
  box.Grid(o1, mkX, mkY, mz, 4);
  const std::vector<float> baked = box.Bake();
  const size_t centre =
      box.Nearest(0.5f, 0.5f, 0.0f);  // The middle of the floor, facing up into the box.
  EXPECT_LT(baked[4 * centre], 0.02f);
  EXPECT_LT(Light(baked, centre, kZ, {0, 0, 1}), 0.05f);
}

TEST(Occlusion, AFloorBesideAWallIsShadedFromTheWallsSide) {
  Soup scene;
  const float floor_origin[3] = {-1, 0, 0}, wall_origin[3] = {0.5f, 0, 0},
              wall_normal[3] = {-1, 0, 0};
  const float two_x[3] = {1.5f, 0, 0};
  scene.Grid(floor_origin, two_x, kY, kZ, 24);       // Floor x in [-1, 0.5], y in [0, 1].
  scene.Grid(wall_origin, kY, kZ, wall_normal, 12);  // Wall at x = 0.5, 1 high, facing -x.
  const std::vector<float> baked = scene.Bake();
  const size_t corner = scene.Nearest(0.4375f, 0.5f, 0), open = scene.Nearest(-0.9375f, 0.5f, 0);
  EXPECT_GT(baked[4 * open], 0.85f);
  EXPECT_LT(baked[4 * corner], 0.75f);
  EXPECT_GT(baked[4 * corner], 0.3f);  // Half the sky is still there.
  // A light from over the wall (from +x, 45 degrees up) is blocked at its foot; from the open side
  // it is not. (The linear estimate is soft: 0.28 against 0.79 here.)
  EXPECT_LT(Light(baked, corner, kZ, {1, 0, 1}), 0.4f);
  EXPECT_GT(Light(baked, corner, kZ, {-1, 0, 1}), 0.7f);
  EXPECT_GT(Light(baked, open, kZ, {1, 0, 1}), 0.8f);
}

TEST(Occlusion, NothingToBakeLeavesEveryVertexOpen) {
  const std::vector<float> positions{0, 0, 0, 1, 0, 0}, normals{0, 0, 1, 0, 0, 0};
  std::vector<float> out(8, -1.0f);
  BakeOcclusion(positions, normals, {}, OcclusionSettings{}, out);
  for (size_t i = 0; i < out.size(); ++i) EXPECT_EQ(out[i], kOpenOcclusion[i % 4]);
  const std::vector<uint32_t> hostile{0, 1,
                                      7};  // An index past the vertices: that triangle is skipped.
  BakeOcclusion(positions, normals, hostile, OcclusionSettings{}, out);
  EXPECT_NEAR(out[0], 1.0f, 1e-6f);
}

}  // namespace occlusion_test
}  // namespace facespace
