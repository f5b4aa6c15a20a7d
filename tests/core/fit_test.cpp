#include "facespace/engine/fit.h"

#include <gtest/gtest.h>

#include <random>

#include "facespace/engine/blend.h"
#include "facespace/engine/transform.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace fit_test {  // Named: core_tests is a unity build, its files share one unit.

std::vector<std::vector<float>> Blend(const Rig& rig, const std::vector<float>& w) {
  BlendedRig out;
  BlendContext ctx;
  EXPECT_TRUE(EvaluateRig(rig, w, {}, out, ctx).ok());
  std::vector<std::vector<float>> t;
  for (const auto& p : out.primitives) t.push_back(p.positions);
  return t;
}

// The service's own neutral mesh (world space, float32, as the JSON and OBJ exports write it) fits
// back to zero weights with a residual of float round-off in the scene's units (micrometres), not
// FaceCap's mesh units (1.95 mm each, where it read 0.00078 as if in metres).
TEST(Fit, TheNeutralMeshInWorldSpaceFitsToZeroWithRoundOffAlone) {
  auto rig = formats::LoadRigFile(test::Bundled("facecap/facecap.glb"));
  ASSERT_TRUE(rig.ok());
  std::vector<std::vector<float>> target =
      Blend(rig.value(), std::vector<float>(rig->shapes.size(), 0.0f));
  const auto world = PrimitiveWorldMatrices(rig.value());
  for (size_t p = 0; p < target.size(); ++p) {
    for (size_t v = 0; v + 2 < target[p].size(); v += 3) {
      float q[3];
      TransformPoint(world[p], &target[p][v], q);
      std::copy(q, q + 3, &target[p][v]);
    }
  }
  WorldToMeshSpace(rig.value(), target);
  auto fit = FitWeights(rig.value(), target, {});
  ASSERT_TRUE(fit.ok()) << fit.status().message;
  for (float w : fit->weights) EXPECT_EQ(w, 0.0f);
  EXPECT_LT(fit->rms_error,
            1e-5);  // Metres: float32 at 11 m from the origin rounds to about 1 micrometre.
  EXPECT_LT(fit->max_error, 1e-5);
}

TEST(Fit, RecoversKnownWeightsOnFaceCap) {
  auto rig = formats::LoadRigFile(test::Bundled("facecap/facecap.glb"));
  ASSERT_TRUE(rig.ok());
  std::vector<float> w(rig->shapes.size(), 0.0f);
  w[FindShape(rig.value(), "jawOpen")] = 0.6f;
  w[FindShape(rig.value(), "mouthSmile_L")] = 0.3f;
  w[FindShape(rig.value(), "eyeBlink_R")] = 0.8f;
  auto fit = FitWeights(rig.value(), Blend(rig.value(), w), {});
  ASSERT_TRUE(fit.ok()) << fit.status().message;
  for (size_t s = 0; s < w.size(); ++s) {
    if (rig->shapes[s].vertices_moved == 0) continue;  // tongueOut moves nothing: unobservable.
    EXPECT_NEAR(fit->weights[s], w[s], 2e-3f) << rig->shapes[s].name;
  }
  EXPECT_LT(fit->max_error, 1e-2);
  // An exact round trip is inside the authored space: round-off (weights like -4.6e-08 for the
  // shapes at 0) is no warning.
  for (const Warning& warning : fit->warnings)
    EXPECT_EQ(warning.code, "extrapolation") << warning.message;  // The sum 1.7 is, rightly.
  for (size_t s = 0; s < w.size(); ++s)
    EXPECT_GE(fit->weights[s], rig->shapes[s].min) << rig->shapes[s].name;
  // And the shapes at 0 come back as 0, not as 1e-7 noise: the answer lists what acts.
  size_t noise = 0;
  for (size_t s = 0; s < w.size(); ++s)
    noise += w[s] == 0.0f && fit->weights[s] != 0.0f && rig->shapes[s].vertices_moved > 0;
  EXPECT_LE(noise, 3u);  // At most a few with a real (if small) share of the answer.
  for (size_t s = 0; s < w.size(); ++s) {
    if (fit->weights[s] != 0.0f) {
      EXPECT_GE(std::fabs(fit->weights[s]), 1e-5f) << rig->shapes[s].name;
    }
  }
}

TEST(Fit, NoiseAndBounds) {
  auto rig = formats::LoadRigFile(test::RealAsset("MorphStressTest/MorphStressTest.gltf"));
  ASSERT_TRUE(rig.ok());
  std::vector<float> w = {0.5f, 0, 0.25f, 0, 0, 0.75f, 0, 0};
  auto target = Blend(rig.value(), w);
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.0f, 1e-3f);
  for (auto& p : target)
    for (float& f : p) f += noise(rng);
  auto fit = FitWeights(rig.value(), target, {});
  ASSERT_TRUE(fit.ok());
  for (size_t s = 0; s < w.size(); ++s) EXPECT_NEAR(fit->weights[s], w[s], 0.02f) << s;
  EXPECT_GT(fit->rms_error, 5e-4);  // The noise is left in the residual.
  EXPECT_LT(fit->rms_error, 3e-3);

  // Beyond the range: unbounded fits 1.6; bounded stops at the range's end.
  std::vector<float> over = {1.6f, 0, 0, 0, 0, 0, 0, 0};
  auto free_fit = FitWeights(rig.value(), Blend(rig.value(), over), {});
  auto bounded = FitWeights(rig.value(), Blend(rig.value(), over), {.bounded = true});
  ASSERT_TRUE(free_fit.ok() && bounded.ok());
  EXPECT_NEAR(free_fit->weights[0], 1.6f, 1e-3f);
  EXPECT_EQ(free_fit->warnings[0].code, "extrapolation");
  EXPECT_NEAR(bounded->weights[0], 1.0f, 1e-4f);
  EXPECT_GT(bounded->max_error, free_fit->max_error);
  // Sum at most one: two shapes at 0.8 each come back summing to 1.
  std::vector<float> two = {0.8f, 0.8f, 0, 0, 0, 0, 0, 0};
  auto capped =
      FitWeights(rig.value(), Blend(rig.value(), two), {.bounded = true, .sum_at_most_one = true});
  ASSERT_TRUE(capped.ok());
  float sum = 0;
  for (float f : capped->weights) sum += f;
  EXPECT_NEAR(sum, 1.0f, 1e-4f);
  for (float f : capped->weights) EXPECT_GE(f, -1e-6f);
  EXPECT_TRUE(capped->warnings.empty());
}

TEST(Fit, RigidAlignmentFirst) {
  auto rig = formats::LoadRigFile(test::RealAsset("MorphStressTest/MorphStressTest.gltf"));
  ASSERT_TRUE(rig.ok());
  std::vector<float> w = {0, 0.4f, 0, 0, 0.7f, 0, 0, 0};
  auto target = Blend(rig.value(), w);
  // Rotate the target 30 degrees about y and move it.
  const float c = std::cos(0.5236f), s = std::sin(0.5236f);
  for (auto& p : target) {
    for (size_t v = 0; v < p.size(); v += 3) {
      const float x = p[v], z = p[v + 2];
      p[v] = c * x + s * z + 2.0f;
      p[v + 2] = -s * x + c * z - 1.0f;
    }
  }
  auto plain = FitWeights(rig.value(), target, {});
  auto aligned = FitWeights(rig.value(), target, {.rigid_align = true});
  ASSERT_TRUE(plain.ok() && aligned.ok());
  for (size_t k = 0; k < w.size(); ++k) EXPECT_NEAR(aligned->weights[k], w[k], 0.02f) << k;
  EXPECT_LT(aligned->rms_error, plain->rms_error / 10);
}

TEST(Fit, Errors) {
  auto rig = formats::LoadRigFile(test::RealAsset("MorphStressTest/MorphStressTest.gltf"));
  ASSERT_TRUE(rig.ok());
  std::vector<std::vector<float>> one = {std::vector<float>(9, 0.0f)};
  EXPECT_FALSE(FitWeights(rig.value(), one, {}).ok());
  auto target = Blend(rig.value(), std::vector<float>(8, 0.0f));
  target[1].pop_back();
  EXPECT_FALSE(FitWeights(rig.value(), target, {}).ok());
  target = Blend(rig.value(), std::vector<float>(8, 0.0f));
  target[0][0] = NAN;
  EXPECT_FALSE(FitWeights(rig.value(), target, {}).ok());
}

}  // namespace fit_test
}  // namespace facespace
