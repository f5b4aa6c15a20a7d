// Frames a network carries (facespace/formats/frames.h): FaceCap's jaw dragged at 60 Hz as delta
// frames, decoded as a client decodes them, stays within the grid's bound of the float32 face at
// every frame, and is a small part of the float32 frame's bytes.
#include "facespace/formats/frames.h"

#include <gtest/gtest.h>

#include <cmath>

#include "facespace/engine/blend.h"
#include "facespace/engine/rig.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace frames_test {  // Named: core_tests is a unity build.

// Every primitive's world-space positions at `weights`, as the f32 frame lays them out.
std::vector<float> Positions(const Rig& rig, std::span<const float> weights, BlendContext& ctx) {
  BlendedRig out;
  EXPECT_TRUE(EvaluateRig(rig, weights, {}, out, ctx).ok());
  std::vector<float> p;
  for (const BlendedPrimitive& b : out.primitives) {
    for (size_t v = 0; v + 2 < b.positions.size(); v += 3) {
      const float* m = b.world.data();
      const float x = b.positions[v], y = b.positions[v + 1], z = b.positions[v + 2];
      for (int k = 0; k < 3; ++k) p.push_back(m[k] * x + m[4 + k] * y + m[8 + k] * z + m[12 + k]);
    }
  }
  return p;
}

float Diagonal(std::span<const float> p) {
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (size_t v = 0; v < p.size(); v += 3) {
    for (int k = 0; k < 3; ++k)
      lo[k] = std::min(lo[k], p[v + k]), hi[k] = std::max(hi[k], p[v + k]);
  }
  return std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                   (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

TEST(Frames, AJawDragDecodesWithinItsBoundAndPacksSmall) {
  const Rig rig = formats::LoadRigFile(test::Bundled("facecap/facecap.glb")).value();
  const int jaw = FindShape(rig, "jawOpen");
  ASSERT_GE(jaw, 0);
  std::vector<float> w(rig.shapes.size(), 0.0f);
  BlendContext ctx;
  formats::DeltaFrames frames(1e-4f);
  std::vector<int16_t> held;
  std::vector<float> decoded;
  size_t bytes = 0, keys = 0, f32 = 0;
  float diagonal = 0, worst = 0;
  for (int i = 0; i <= 60; ++i) {  // A second of dragging, 0 to 1.
    w[jaw] = i / 60.0f;
    const std::vector<float> p = Positions(rig, w, ctx);
    if (i == 0) diagonal = Diagonal(p);
    std::string frame;
    const bool key = frames.Encode(p, frame);
    keys += key;
    if (i > 0) bytes += frame.size();
    f32 += 2 * p.size() * 4;  // Positions and normals.
    ASSERT_TRUE(formats::ApplyFrame(frame, key, held, decoded).ok()) << i;
    ASSERT_EQ(decoded.size(), p.size());
    for (size_t k = 0; k < p.size(); k += 3) {
      const float dx = decoded[k] - p[k], dy = decoded[k + 1] - p[k + 1],
                  dz = decoded[k + 2] - p[k + 2];
      worst = std::max(worst, std::sqrt(dx * dx + dy * dy + dz * dz));
    }
  }
  EXPECT_EQ(keys, 1u);  // The first: the rest are deltas.
  const float bound = frames.grid().step * std::sqrt(3.0f) / 2;
  EXPECT_LE(worst, bound * 1.0001f);
  EXPECT_LE(worst / diagonal, 1e-4f) << "worst " << worst << " of a diagonal of " << diagonal;
  const double mbit = bytes * 8.0 / 1e6;  // 60 frames: a second.
  EXPECT_LT(mbit, 2.0) << bytes << " bytes a second of deltas against " << f32 << " as float32";
  std::printf(
      "jaw drag: %zu bytes/s of deltas (%.2f Mbit/s), float32 %zu (%.1f Mbit/s); worst %.2e "
      "of the diagonal\n",
      bytes, mbit, f32, f32 * 8.0 / 1e6, worst / diagonal);

  // Still: a delta of nothing moving costs a few bytes a vertex at most.
  std::string still;
  EXPECT_FALSE(frames.Encode(Positions(rig, w, ctx), still));
  EXPECT_LT(still.size(), decoded.size() / 3 / 4 + 64);
  // A keyframe asked for; a jump past what int16 holds is a keyframe on a new grid.
  frames.Keyframe();
  std::string key;
  EXPECT_TRUE(frames.Encode(Positions(rig, w, ctx), key));
  std::vector<float> far = Positions(rig, w, ctx);
  for (float& c : far) c += 100.0f * diagonal;
  std::string jump;
  EXPECT_TRUE(frames.Encode(far, jump));
  ASSERT_TRUE(formats::ApplyFrame(jump, true, held, decoded).ok());
  EXPECT_NEAR(decoded[0], far[0], frames.grid().step);
}

TEST(Frames, RefusesBytesThatDoNotFit) {
  std::vector<int16_t> held;
  std::vector<float> p;
  EXPECT_FALSE(formats::ApplyFrame("short", true, held, p).ok());
  std::string block(24, '\0');
  block[0] = 3;  // Three vertices, raw, but no bytes for them.
  EXPECT_FALSE(formats::ApplyFrame(block, true, held, p).ok());
  EXPECT_FALSE(formats::ApplyFrame(block + std::string(24, '\0'), false, held, p).ok());  // No key.
  EXPECT_TRUE(formats::ApplyFrame(block + std::string(24, '\0'), true, held, p).ok());
  block[4] = 1;  // meshopt: garbage.
  EXPECT_FALSE(formats::ApplyFrame(block + std::string(7, '\x55'), true, held, p).ok());
  block[4] = 9;
  EXPECT_FALSE(formats::ApplyFrame(block + std::string(24, '\0'), true, held, p).ok());
}

}  // namespace frames_test
}  // namespace facespace
