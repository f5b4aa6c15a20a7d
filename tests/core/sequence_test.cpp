#include "facespace/engine/sequence.h"

#include <gtest/gtest.h>

#include <random>

#include "facespace/engine/blend.h"
#include "facespace/engine/skeleton.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace sequence_test {  // Named: core_tests is a unity build, its files share one unit.

Transition T(const char* name) {
  Transition t;
  EXPECT_TRUE(ParseTransition(name, &t)) << name;
  return t;
}

TEST(Transitions, ExactValues) {
  EXPECT_EQ(ApplyTransition(T("step"), 0.99f), 0.0f);
  EXPECT_EQ(ApplyTransition(T("step"), 1.0f), 1.0f);
  EXPECT_EQ(ApplyTransition(T("linear"), 0.3f), 0.3f);
  EXPECT_FLOAT_EQ(ApplyTransition(T("smoothstep"), 0.25f), 0.15625f);        // 3u^2 - 2u^3
  EXPECT_FLOAT_EQ(ApplyTransition(T("smootherstep"), 0.25f), 0.103515625f);  // 6u^5 - 15u^4 + 10u^3
  EXPECT_FLOAT_EQ(ApplyTransition(T("ease-in"), 0.5f), 0.125f);
  EXPECT_FLOAT_EQ(ApplyTransition(T("ease-out"), 0.5f), 0.875f);
  EXPECT_FLOAT_EQ(ApplyTransition(T("ease-in-out"), 0.25f), 0.0625f);
  EXPECT_FLOAT_EQ(ApplyTransition(T("ease-in-out"), 0.75f), 0.9375f);
  for (const char* n :
       {"linear", "smoothstep", "smootherstep", "ease-in", "ease-out", "ease-in-out"}) {
    EXPECT_FLOAT_EQ(ApplyTransition(T(n), 0.0f), 0.0f) << n;
    EXPECT_FLOAT_EQ(ApplyTransition(T(n), 1.0f), 1.0f) << n;
  }
  for (const char* n :
       {"linear", "smoothstep", "smootherstep", "ease-in-out"}) {  // Point-symmetric ones.
    EXPECT_FLOAT_EQ(ApplyTransition(T(n), 0.5f), 0.5f) << n;
  }
  // CSS's "ease" is cubic-bezier(0.25, 0.1, 0.25, 1); its value at x = 0.5 is 0.8024033877.
  EXPECT_NEAR(ApplyTransition(T("cubic-bezier(0.25, 0.1, 0.25, 1)"), 0.5f), 0.8024034f, 1e-5f);
  // cubic-bezier(x1, y1, x2, y2) with x = y control points is the identity.
  EXPECT_NEAR(ApplyTransition(T("cubic-bezier(0.3,0.3,0.7,0.7)"), 0.42f), 0.42f, 1e-5f);
  // y outside [0, 1] overshoots: extrapolation.
  EXPECT_LT(ApplyTransition(T("cubic-bezier(0.3,-0.5,0.7,1.5)"), 0.1f), 0.0f);
  EXPECT_GT(ApplyTransition(T("cubic-bezier(0.3,-0.5,0.7,1.5)"), 0.9f), 1.0f);
  Transition bad;
  EXPECT_FALSE(ParseTransition("bounce", &bad));
  EXPECT_FALSE(ParseTransition("cubic-bezier(1.5, 0, 0, 1)", &bad)) << "x must stay in [0, 1]";
  EXPECT_FALSE(ParseTransition("cubic-bezier(0.1, 0, 0.2)", &bad));
  EXPECT_EQ(TransitionName(T("cubic-bezier(0.25, 0.1, 0.25, 1)")),
            "cubic-bezier(0.25, 0.1, 0.25, 1)");
}

Sequence ThreeKeys(const char* transition) {
  Sequence s;
  s.transition = T(transition);
  s.keys = {{0.0f, {0, 0}, {}}, {1.0f, {1, 0}, {}}, {3.0f, {0, 2}, {}}};
  return s;
}

TEST(Sequences, InBetweenFormula) {
  Sequence s = ThreeKeys("smoothstep");
  std::vector<float> w(2);
  float f = 0;
  SampleSequence(s, 2.5f, w, &f);
  // B = key 1 (t=1), C = key 2 (t=3): u = 0.75, f = smoothstep(0.75) = 0.84375.
  EXPECT_FLOAT_EQ(f, 0.84375f);
  EXPECT_FLOAT_EQ(w[0], 1.0f - 0.84375f);
  EXPECT_FLOAT_EQ(w[1], 2.0f * 0.84375f);
  SampleSequence(s, -5.0f, w);
  EXPECT_EQ(w, (std::vector<float>{0, 0})) << "clamped before the first key";
  SampleSequence(s, 9.0f, w);
  EXPECT_EQ(w, (std::vector<float>{0, 2})) << "clamped after the last key";
  // A key's own transition wins for the span after it.
  s.keys[1].transition = T("step");
  SampleSequence(s, 2.9f, w);
  EXPECT_EQ(w, (std::vector<float>{1, 0}));
}

TEST(Sequences, CatmullRomPassesThroughKeys) {
  Sequence s = ThreeKeys("linear");
  s.smooth = true;
  std::vector<float> w(2);
  for (const Keyframe& k : s.keys) {
    SampleSequence(s, k.time, w);
    EXPECT_NEAR(w[0], k.weights[0], 1e-6f);
    EXPECT_NEAR(w[1], k.weights[1], 1e-6f);
  }
  SampleSequence(s, 0.5f, w);
  EXPECT_NE(w[1], 0.0f) << "a spline looks ahead: the next key's shape starts early";
}

TEST(Sequences, BakeRoundTrip) {
  for (const char* tr : {"linear", "smoothstep"}) {
    Sequence s = ThreeKeys(tr);
    Sequence baked = BakeKey(s, 2.0f);
    ASSERT_EQ(baked.keys.size(), 4u);
    EXPECT_EQ(baked.keys[2].time, 2.0f);
    std::vector<float> a(2), b(2);
    SampleSequence(s, 2.0f, a);
    EXPECT_EQ(baked.keys[2].weights, a) << tr;
    SampleSequence(baked, 2.0f, b);
    EXPECT_EQ(a, b) << tr;
    if (std::string(tr) == "linear") {  // A linear sequence is unchanged everywhere.
      for (float t = 0; t <= 3.0f; t += 0.125f) {
        SampleSequence(s, t, a);
        SampleSequence(baked, t, b);
        EXPECT_NEAR(a[0], b[0], 1e-6f) << t;
        EXPECT_NEAR(a[1], b[1], 1e-6f) << t;
      }
    }
  }
  Sequence s = ThreeKeys("linear");
  EXPECT_EQ(BakeKey(s, 1.0f).keys.size(), 3u) << "a key already there";
}

TEST(Sequences, Validation) {
  Sequence s = ThreeKeys("linear");
  EXPECT_TRUE(ValidateSequence(s, 2).ok());
  EXPECT_FALSE(ValidateSequence(s, 3).ok());
  s.keys[2].time = 1.0f;
  auto st = ValidateSequence(s, 2);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.fields[0].pointer, "/keys/2/time");
  s.keys[2].time = NAN;
  EXPECT_FALSE(ValidateSequence(s, 2).ok());
  EXPECT_FALSE(ValidateSequence(Sequence{}, 2).ok());
}

// Largest vertex distance between two weight vectors, evaluated independently with EvaluateRig.
double Distance(const Rig& rig, const std::vector<float>& a, const std::vector<float>& b) {
  BlendedRig x, y;
  BlendContext ctx;
  EXPECT_TRUE(EvaluateRig(rig, a, {}, x, ctx).ok());
  EXPECT_TRUE(EvaluateRig(rig, b, {}, y, ctx).ok());
  return test::MaxDistance(x, y);
}

class Reduction : public ::testing::TestWithParam<std::pair<const char*, float>> {};

TEST_P(Reduction, ToleranceRespectedOnRealAnimation) {
  const auto [path, tolerance] = GetParam();
  auto rig = formats::LoadGltfFile(test::RealAsset(path));
  ASSERT_TRUE(rig.ok());
  auto seq = SequenceFromAnimation(rig.value(), 0);
  ASSERT_TRUE(seq.ok()) << seq.status().message;
  // The sequence agrees with sampling the glTF clip directly.
  std::vector<float> w(rig->shapes.size());
  for (float t : {0.1f, 0.77f, 1.5f}) {
    Pose pose = RestPose(rig.value());
    std::vector<float> clip_w;
    std::vector<uint8_t> set;
    ASSERT_TRUE(SampleClip(rig.value(), 0, t, ClipWrap::kClamp, pose, clip_w, set).ok());
    SampleSequence(seq.value(), t, w);
    for (size_t s = 0; s < w.size(); ++s) EXPECT_NEAR(w[s], clip_w[s], 1e-6f);
  }
  auto r = ReduceSequence(rig.value(), seq.value(), tolerance);
  ASSERT_TRUE(r.ok());
  EXPECT_LT(r->sequence.keys.size(), seq->keys.size() / 4) << "a real reduction";
  EXPECT_EQ(r->removed, seq->keys.size() - r->sequence.keys.size());
  EXPECT_LE(r->max_error, tolerance);
  EXPECT_EQ(r->sequence.keys.front().time, seq->keys.front().time);
  EXPECT_EQ(r->sequence.keys.back().time, seq->keys.back().time);
  // Checked independently at 300 random times over the clip (linear keys: the error is
  // largest at key times, so the bound holds everywhere).
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(seq->keys.front().time, seq->keys.back().time);
  std::vector<float> a(w.size()), b(w.size());
  double worst = 0;
  for (int i = 0; i < 300; ++i) {
    const float t = u(rng);
    SampleSequence(seq.value(), t, a);
    SampleSequence(r->sequence, t, b);
    worst = std::max(worst, Distance(rig.value(), a, b));
  }
  EXPECT_LE(worst, tolerance * 1.0001 + 1e-7);
  // Zero tolerance keeps what matters: exact reproduction at every key.
  auto exact = ReduceSequence(rig.value(), seq.value(), 0.0f);
  ASSERT_TRUE(exact.ok());
  EXPECT_EQ(exact->max_error, 0.0);
}

INSTANTIATE_TEST_SUITE_P(
    Real, Reduction,
    ::testing::Values(std::make_pair("AnimatedMorphCube/AnimatedMorphCube.gltf", 0.001f),
                      std::make_pair("AnimatedMorphSphere/AnimatedMorphSphere.gltf", 0.01f)),
    [](const auto& param_info) {
      return std::string(param_info.param.first)
          .substr(0, std::string(param_info.param.first).find('/'));
    });

}  // namespace sequence_test
}  // namespace facespace
