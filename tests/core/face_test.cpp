// The face by name (core/face.h): expressions equal their mapped weights, VRM's override rules,
// gaze through range maps (FaceCap's eye shapes) and eye bones (Uka), natural blinks' statistics.
#include "facespace/engine/face.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <numeric>

#include "facespace/engine/blend.h"
#include "facespace/engine/pose_request.h"
#include "facespace/engine/sequence.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace face_test {  // Named: core_tests is a unity build, its files share one unit.

const Rig& FaceCap() {
  static const Rig rig = formats::LoadRigFile(test::Bundled("facecap/facecap.glb")).value();
  return rig;
}
const Rig& Uka() {
  static const Rig rig = formats::LoadRigFile(test::Bundled("uka/MS_Uka.pmx")).value();
  return rig;
}

int ShapeOf(const Rig& rig, const char* name) {
  const int s = FindShape(rig, name);
  EXPECT_GE(s, 0) << name;
  return s;
}

struct Point {
  std::vector<float> weights;
  Pose pose;
  bool posed = false;
  std::vector<Warning> warnings;
};

Point Resolve(const Rig& rig, std::vector<WeightEntry> weights, PoseRequest request) {
  Point p;
  EXPECT_TRUE(
      ResolvePoseAndWeights(rig, weights, request, p.weights, p.pose, p.posed, p.warnings).ok());
  return p;
}

std::vector<float> Positions(const Rig& rig, const Point& p) {
  BlendedRig out;
  BlendContext context;
  BlendOptions options;
  options.pose = p.posed ? &p.pose : nullptr;
  EXPECT_TRUE(EvaluateRig(rig, p.weights, options, out, context).ok());
  std::vector<float> all;
  for (const BlendedPrimitive& prim : out.primitives)
    all.insert(all.end(), prim.positions.begin(), prim.positions.end());
  return all;
}

PoseRequest WithExpressions(std::vector<WeightEntry> e) {
  PoseRequest r;
  r.expressions = std::move(e);
  return r;
}

// `expressions: {"happy": 1}` is the same mesh as the weights the rig maps it to, on an ARKit rig
// (derived) and on an MMD rig (her manifest's group morph, with bones and materials).
TEST(Face, AnExpressionIsTheSameMeshAsItsMappedWeights) {
  for (const Rig* rig : {&FaceCap(), &Uka()}) {
    const int happy = FindExpression(*rig, "happy");
    ASSERT_GE(happy, 0) << rig->name;
    const Expression& e = rig->expressions[happy];
    ASSERT_FALSE(e.binds.empty());
    std::vector<WeightEntry> mapped;
    for (const auto& [s, w] : e.binds) mapped.push_back({rig->shapes[s].name, -1, w, ""});
    const Point by_name =
        Resolve(*rig, {}, WithExpressions({{"happy", -1, 1.0, "/expressions/happy"}}));
    const Point by_weights = Resolve(*rig, mapped, {});
    EXPECT_EQ(by_name.weights, by_weights.weights) << rig->name;
    const std::vector<float> a = Positions(*rig, by_name), b = Positions(*rig, by_weights);
    ASSERT_EQ(a.size(), b.size());
    float moved = 0.0f;
    const std::vector<float> rest = Positions(*rig, Resolve(*rig, {}, {}));
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i], b[i]) << rig->name << " at " << i;
      moved = std::max(moved, std::fabs(a[i] - rest[i]));
    }
    EXPECT_GT(moved, 1e-4f) << rig->name << ": happy moves nothing";
  }
  // FaceCap's happy is derived from its ARKit names; Uka's is her manifest's.
  EXPECT_TRUE(FaceCap().expressions[FindExpression(FaceCap(), "happy")].derived);
  const Expression& uka_happy = Uka().expressions[FindExpression(Uka(), "happy")];
  EXPECT_FALSE(uka_happy.derived);
  ASSERT_EQ(uka_happy.binds.size(), 1u);
  EXPECT_EQ(Uka().shapes[uka_happy.binds[0].first].name, "笑顔総");
}

TEST(Face, EveryPresetOfAnArkitRigIsDerived) {
  for (std::string_view name : kExpressionPresets)
    EXPECT_GE(FindExpression(FaceCap(), name), 0) << name;
  const Expression& left = FaceCap().expressions[FindExpression(FaceCap(), "lookLeft")];
  std::vector<std::string> names;
  for (const auto& [s, w] : left.binds) names.push_back(FaceCap().shapes[s].name);
  EXPECT_EQ(names, (std::vector<std::string>{"eyeLookOut_L", "eyeLookIn_R"}));
}

// VRM 1.0: an expression overriding blink with "block" hides the blink while it shows at all;
// "blend" scales the blink by 1 - its value.
TEST(Face, OverridesBlockOrBlendTheBlink) {
  const Rig& uka = Uka();
  const int blink_shape = ShapeOf(uka, "まばたき");
  auto blink_with = [&](const char* other, double value) {
    return Resolve(uka, {}, WithExpressions({{"blink", -1, 1.0, ""}, {other, -1, value, ""}}))
        .weights[blink_shape];
  };
  EXPECT_FLOAT_EQ(blink_with("aa", 1.0), 1.0f);     // A mouth shape overrides nothing.
  EXPECT_FLOAT_EQ(blink_with("happy", 0.2), 0.0f);  // Block: hidden as soon as happy shows.
  EXPECT_FLOAT_EQ(blink_with("sad", 0.25), 0.75f);  // Blend: 1 - 0.25.
  // Uka's surprised blends the mouth: aa at 1 under surprised 0.6 shows at 0.4.
  const int a = ShapeOf(uka, "あ");
  EXPECT_FLOAT_EQ(
      Resolve(uka, {}, WithExpressions({{"aa", -1, 1.0, ""}, {"surprised", -1, 0.6, ""}}))
          .weights[a],
      0.4f);
}

TEST(Face, UnknownExpressionsAreErrorsAndUnmappedPresetsWarn) {
  std::vector<float> values;
  std::vector<Warning> warnings;
  const Status bad = ResolveExpressions(
      FaceCap(), std::vector<WeightEntry>{{"hapy", -1, 1.0, "/expressions/hapy"}}, values,
      warnings);
  ASSERT_FALSE(bad.ok());
  ASSERT_EQ(bad.fields.size(), 1u);
  EXPECT_EQ(bad.fields[0].pointer, "/expressions/hapy");
  EXPECT_NE(bad.fields[0].message.find("did you mean 'happy'"), std::string::npos)
      << bad.fields[0].message;
  EXPECT_FALSE(ResolveExpressions(FaceCap(),
                                  std::vector<WeightEntry>{{"aa", -1, NAN, "/expressions/aa"}},
                                  values, warnings)
                   .ok());
  // MakeHuman's expressions, derived from FaceCap's, carry VRM's presets as FaceCap's do: happy
  // smiles with its mouthSmile shapes.
  const Rig mh = formats::LoadRigFile(test::Bundled("makehuman/makehuman.glb")).value();
  std::vector<float> happy, smile(mh.shapes.size(), 0.0f);
  warnings.clear();
  ASSERT_TRUE(ResolveExpressions(mh,
                                 std::vector<WeightEntry>{{"happy", -1, 1.0, "/expressions/happy"}},
                                 happy, warnings)
                  .ok());
  EXPECT_TRUE(warnings.empty());
  AddExpressionWeights(mh, happy, ExpressionMultipliers{}, smile);
  EXPECT_GT(smile[static_cast<size_t>(FindShape(mh, "mouthSmile_L"))], 0.5f);
  EXPECT_GT(smile[static_cast<size_t>(FindShape(mh, "mouthSmile_R"))], 0.5f);
  // A cube has none of VRM's presets: "ou" is one it does not map, said, not refused.
  const Rig cube =
      formats::LoadRigFile(test::RealAsset("AnimatedMorphCube/AnimatedMorphCube.gltf")).value();
  EXPECT_LT(FindExpression(cube, "ou"), 0);
  EXPECT_TRUE(ResolveExpressions(cube, std::vector<WeightEntry>{{"ou", -1, 1.0, "/expressions/ou"}},
                                 values, warnings)
                  .ok());
  ASSERT_FALSE(warnings.empty());
  EXPECT_EQ(warnings.back().code, "expression_unmapped");
}

// FaceCap looking at a point to its left: eyeLookOut_L and eyeLookIn_R follow the range map (30
// degrees to full weight), the other look shapes stay 0; past 30 degrees they hold 1.
TEST(Face, FaceCapsEyeShapesFollowTheRangeMap) {
  const Rig& rig = FaceCap();
  ASSERT_EQ(rig.gaze.kind, GazeSetup::Kind::kShapes);
  const auto& o = rig.gaze.origin;
  for (float degrees : {0.0f, 6.0f, 15.0f, 24.0f, 45.0f}) {
    const float rad = degrees * static_cast<float>(M_PI / 180.0);
    PoseRequest r;
    r.gaze = Gaze{true, {o[0] + std::sin(rad), o[1], o[2] + std::cos(rad)}};
    const Point p = Resolve(rig, {}, r);
    const float expected = std::min(degrees / 30.0f, 1.0f);
    EXPECT_NEAR(p.weights[ShapeOf(rig, "eyeLookOut_L")], expected, 1e-4f) << degrees;
    EXPECT_NEAR(p.weights[ShapeOf(rig, "eyeLookIn_R")], expected, 1e-4f) << degrees;
    for (const char* other : {"eyeLookIn_L", "eyeLookOut_R", "eyeLookUp_L", "eyeLookUp_R",
                              "eyeLookDown_L", "eyeLookDown_R"}) {
      EXPECT_NEAR(p.weights[ShapeOf(rig, other)], 0.0f, 1e-4f) << degrees << " " << other;
    }
  }
  // Up and to the right by angles: eyeLookOut_R and eyeLookIn_L at 10/30, eyeLookUp at 5/25.
  PoseRequest r;
  r.gaze = Gaze{false, {}, -10.0f, 5.0f};
  const Point p = Resolve(rig, {}, r);
  EXPECT_NEAR(p.weights[ShapeOf(rig, "eyeLookOut_R")], 1.0f / 3.0f, 1e-5f);
  EXPECT_NEAR(p.weights[ShapeOf(rig, "eyeLookIn_L")], 1.0f / 3.0f, 1e-5f);
  EXPECT_NEAR(p.weights[ShapeOf(rig, "eyeLookUp_L")], 0.2f, 1e-5f);
  EXPECT_FALSE(p.posed);
}

// The local rotation's angle (degrees) and axis.
float TurnDegrees(const Transform& t) {
  return 2.0f * std::acos(std::min(1.0f, std::fabs(t.rotation[3]))) *
         static_cast<float>(180.0 / M_PI);
}

// Uka: the head and neck take 30% and 20% of the angle, the eye bones turn by the coefficient (0.3)
// times the rest, up to the limits (12 degrees sideways, 8 up or down).
TEST(Face, UkasEyeBonesTurnByTheCoefficientWithinLimits) {
  const Rig& rig = Uka();
  ASSERT_EQ(rig.gaze.kind, GazeSetup::Kind::kBones);
  const int left = FindNode(rig, "左目"), right = FindNode(rig, "右目"), head = FindNode(rig, "頭"),
            neck = FindNode(rig, "首");
  const Pose rest = RestPose(rig);
  for (float yaw : {10.0f, 20.0f, 60.0f, -20.0f}) {
    PoseRequest r;
    r.gaze = Gaze{false, {}, yaw, 0.0f};
    Pose pose = rest;
    bool posed = false;
    std::vector<Warning> warnings;
    std::vector<float> weights(rig.shapes.size(), 0.0f);
    ApplyGaze(rig, *r.gaze, 1.0f, weights, pose, posed,
              warnings);  // Before MMD's constraints: the bones' own turns.
    ASSERT_TRUE(posed);
    const float eye = std::min(std::fabs(yaw) * 0.5f * 0.3f, 12.0f);
    EXPECT_NEAR(TurnDegrees(pose.local[left]), eye, 1e-3f) << yaw;
    EXPECT_NEAR(TurnDegrees(pose.local[right]), eye, 1e-3f) << yaw;
    EXPECT_NEAR(TurnDegrees(pose.local[head]), std::fabs(yaw) * 0.3f, 1e-3f) << yaw;
    EXPECT_NEAR(TurnDegrees(pose.local[neck]), std::fabs(yaw) * 0.2f, 1e-3f) << yaw;
    // About the vertical, to her left (+x) for a positive yaw: the eye's forward (+z) turns towards
    // +x.
    const float sign = yaw > 0 ? 1.0f : -1.0f;
    EXPECT_GT(sign * pose.local[left].rotation[1], 0.0f) << yaw;
  }
}

// A target: the angles are measured from between her eyes, in her head's frame.
TEST(Face, AGazeTargetStraightAheadTurnsNothing) {
  const Rig& rig = Uka();
  const auto& o = rig.gaze.origin;
  PoseRequest r;
  r.gaze = Gaze{true, {o[0], o[1], o[2] + 2.0f}};
  const Point p = Resolve(rig, {}, r);
  for (const char* bone : {"左目", "右目", "頭", "首"})
    EXPECT_NEAR(TurnDegrees(p.pose.local[FindNode(rig, bone)]), 0.0f, 0.05f) << bone;
}

TEST(Face, ARigWithoutEyesWarnsAndIgnoresTheGaze) {
  Rig rig;
  rig.name = "box";
  Pose pose;
  bool posed = false;
  std::vector<Warning> warnings;
  ApplyGaze(rig, Gaze{false, {}, 10.0f, 0.0f}, 1.0f, {}, pose, posed, warnings);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].code, "gaze_unsupported");
  EXPECT_FALSE(posed);
}

// 60 s at 15 a minute: 15 blinks for every seed, none overlapping the next (0.3 s apart at least),
// each closing faster than it opens, the intervals irregular; the same seed the same blinks.
TEST(Face, NaturalBlinksMatchTheRequestedRate) {
  for (uint64_t seed = 1; seed <= 50; ++seed) {
    const std::vector<Blink> blinks = NaturalBlinks(0.0f, 60.0f, 15.0f, seed);
    ASSERT_GE(blinks.size(), 12u) << seed;  // The issue's bound: the rate within 20%.
    ASSERT_LE(blinks.size(), 18u) << seed;
    std::vector<double> intervals;
    for (size_t k = 0; k < blinks.size(); ++k) {
      const Blink& b = blinks[k];
      EXPECT_LT(b.start, b.closed);
      EXPECT_LE(b.closed, b.opens);
      EXPECT_LT(b.opens, b.end);
      EXPECT_LT(b.closed - b.start, b.end - b.opens) << "closes faster than it opens";
      EXPECT_GE(b.start, 0.0f);
      EXPECT_LE(b.end, 60.0f);
      if (k > 0) {
        EXPECT_GE(b.start - blinks[k - 1].end, kMinBlinkGap - 1e-4f) << seed << " " << k;
        intervals.push_back(b.start - blinks[k - 1].start);
      }
    }
    const double mean = std::accumulate(intervals.begin(), intervals.end(), 0.0) /
                        static_cast<double>(intervals.size());
    double var = 0;
    for (double x : intervals) var += (x - mean) * (x - mean);
    EXPECT_NEAR(mean, 4.0, 0.8) << seed;
    EXPECT_GT(std::sqrt(var / static_cast<double>(intervals.size())), 0.5)
        << "irregular, not a metronome: seed " << seed;
  }
  const auto a = NaturalBlinks(0.0f, 60.0f, 15.0f, 7), b = NaturalBlinks(0.0f, 60.0f, 15.0f, 7),
             c = NaturalBlinks(0.0f, 60.0f, 15.0f, 8);
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k) EXPECT_EQ(a[k].start, b[k].start);
  EXPECT_NE(a.front().start, c.front().start);
  // Closed in the middle, open between.
  EXPECT_FLOAT_EQ(BlinkValue(a, 0.5f * (a[0].closed + a[0].opens)), 1.0f);
  EXPECT_FLOAT_EQ(BlinkValue(a, a[0].end + 0.01f), 0.0f);
  EXPECT_GT(BlinkValue(a, 0.5f * (a[0].start + a[0].closed)), 0.0f);
}

// In a sequence: the blink shows through the rig's blink expression; a sequence's gaze track is
// linear between its keys.
TEST(Face, SequencesBlinkAndFollowTheirGazeTrack) {
  const Rig& rig = FaceCap();
  Sequence s;
  s.keys.push_back({0.0f, std::vector<float>(rig.shapes.size(), 0.0f), std::nullopt, {}});
  s.keys.push_back({10.0f, std::vector<float>(rig.shapes.size(), 0.0f), std::nullopt, {}});
  s.blinks = NaturalBlinks(0.0f, 10.0f, 20.0f, 3);
  s.gaze = {{0.0f, Gaze{false, {}, 30.0f, 0.0f}}, {10.0f, Gaze{false, {}, -30.0f, 0.0f}}};
  ASSERT_FALSE(s.blinks.empty());
  FaceState face;
  const float t = 0.5f * (s.blinks[0].closed + s.blinks[0].opens);
  ASSERT_TRUE(SampleFace(s, t, face));
  EXPECT_FLOAT_EQ(face.blink, 1.0f);
  EXPECT_NEAR(face.gaze->yaw, 30.0f - 6.0f * t, 1e-3f);
  std::vector<float> weights(rig.shapes.size(), 0.0f);
  Pose pose;
  bool posed = false;
  std::vector<Warning> warnings;
  ApplyFace(rig, face, weights, pose, posed, warnings);
  EXPECT_FLOAT_EQ(weights[ShapeOf(rig, "eyeBlink_L")], 1.0f);
  EXPECT_FLOAT_EQ(weights[ShapeOf(rig, "eyeBlink_R")], 1.0f);
  EXPECT_NEAR(weights[ShapeOf(rig, "eyeLookOut_L")], std::min(1.0f, (30.0f - 6.0f * t) / 30.0f),
              1e-4f);
  EXPECT_TRUE(warnings.empty());
}

// A gaze track of targets: the eyes follow a point moving from the character's left to her right,
// 1 m in front of her eyes: eyeLookOut_L falls as the point passes, eyeLookOut_R rises, each
// frame's weights those of the point's own angle.
TEST(Face, AGazeTrackFollowsAMovingPoint) {
  const Rig& rig = FaceCap();
  const auto& o = rig.gaze.origin;
  Sequence s;
  s.keys.push_back({0.0f, std::vector<float>(rig.shapes.size(), 0.0f), std::nullopt, {}});
  s.keys.push_back({4.0f, std::vector<float>(rig.shapes.size(), 0.0f), std::nullopt, {}});
  s.gaze = {{0.0f, Gaze{true, {o[0] + 0.4f, o[1], o[2] + 1.0f}}},
            {4.0f, Gaze{true, {o[0] - 0.4f, o[1], o[2] + 1.0f}}}};
  float last_out_l = 2.0f;
  for (float t = 0.0f; t <= 4.0f; t += 0.5f) {
    FaceState face;
    ASSERT_TRUE(SampleFace(s, t, face));
    std::vector<float> weights(rig.shapes.size(), 0.0f);
    Pose pose;
    bool posed = false;
    std::vector<Warning> warnings;
    ApplyFace(rig, face, weights, pose, posed, warnings);
    const float x = 0.4f - 0.2f * t;  // The point's offset to her left.
    const float degrees = std::atan2(x, 1.0f) * static_cast<float>(180.0 / M_PI);
    const float expected = std::min(std::fabs(degrees) / 30.0f, 1.0f);
    EXPECT_NEAR(weights[ShapeOf(rig, x >= 0 ? "eyeLookOut_L" : "eyeLookOut_R")], expected, 1e-4f)
        << t;
    EXPECT_NEAR(weights[ShapeOf(rig, x >= 0 ? "eyeLookIn_R" : "eyeLookIn_L")], expected, 1e-4f)
        << t;
    if (x >= 0) {
      EXPECT_LT(weights[ShapeOf(rig, "eyeLookOut_L")], last_out_l) << t;
      last_out_l = weights[ShapeOf(rig, "eyeLookOut_L")];
    }
  }
}

}  // namespace face_test
}  // namespace facespace

namespace facespace {
namespace face_test {

std::pair<nlohmann::json, std::string> SplitGlbForTest(const std::string& glb) {
  uint32_t json_len = 0;
  std::memcpy(&json_len, glb.data() + 12, 4);
  const std::string bin = glb.substr(20 + json_len + 8);
  return {nlohmann::json::parse(glb.substr(20, json_len)), bin};
}

std::string JoinGlbForTest(const nlohmann::json& j, const std::string& bin) {
  std::string text = j.dump();
  while (text.size() % 4) text += ' ';
  std::string out(12, '\0');
  auto u32 = [](std::string& s, uint32_t v) { s.append(reinterpret_cast<const char*>(&v), 4); };
  u32(out, static_cast<uint32_t>(text.size()));
  out.resize(12);
  std::string body;
  u32(body, static_cast<uint32_t>(text.size()));
  u32(body, 0x4E4F534Au);
  body += text;
  u32(body, static_cast<uint32_t>(bin.size()));
  u32(body, 0x004E4942u);
  body += bin;
  std::string head;
  u32(head, 0x46546C67u);
  u32(head, 2);
  u32(head, static_cast<uint32_t>(12 + body.size()));
  return head + body;
}

// VRM in: Uka's VRM 1.0 read back has her expressions and eye bones; the same file rewritten as VRM
// 0.x (blendShapeMaster, weights 0-100, preset names joy/sorrow/a/blink_l, firstPerson) reads as
// the same.
TEST(Face, VrmExpressionsAndLookAtAreReadBack) {
  const Rig& uka = Uka();
  BlendedRig blended;
  BlendContext context;
  const std::vector<float> zero(uka.shapes.size(), 0.0f);
  ASSERT_TRUE(EvaluateRig(uka, zero, {}, blended, context).ok());
  auto vrm = ExportMesh(uka, blended, zero, {}, formats::MeshFormat::kVrm);
  ASSERT_TRUE(vrm.ok()) << vrm.status().message;
  auto check = [&](const Rig& back, const char* what) {
    for (const char* name : {"happy", "sad", "aa", "blinkLeft", "surprised"}) {
      const int a = FindExpression(uka, name), b = FindExpression(back, name);
      ASSERT_GE(b, 0) << what << " " << name;
      ASSERT_EQ(back.expressions[b].binds.size(), uka.expressions[a].binds.size())
          << what << " " << name;
      for (size_t k = 0; k < back.expressions[b].binds.size(); ++k) {
        EXPECT_EQ(back.shapes[back.expressions[b].binds[k].first].name,
                  uka.shapes[uka.expressions[a].binds[k].first].name)
            << what;
        EXPECT_NEAR(back.expressions[b].binds[k].second, uka.expressions[a].binds[k].second, 1e-6f)
            << what;
      }
      EXPECT_FALSE(back.expressions[b].derived);
    }
    EXPECT_EQ(back.gaze.kind, GazeSetup::Kind::kBones) << what;
    EXPECT_EQ(back.nodes[back.gaze.eyes[0]].name, "左目") << what;
    EXPECT_EQ(back.license_url, "https://creativecommons.org/licenses/by/4.0/") << what;
  };
  const std::span<const unsigned char> bytes(reinterpret_cast<const unsigned char*>(vrm->data()),
                                             vrm->size());
  auto one = LoadRigMemory(bytes, formats::RigFormat::kGltf, "uka_vrm1");
  ASSERT_TRUE(one.ok()) << one.status().message;
  check(one.value(), "VRM 1.0");
  EXPECT_EQ(one->expressions[FindExpression(one.value(), "happy")].blink,
            ExpressionOverride::kBlock);
  EXPECT_FALSE(one->gaze.faces_minus_z);
  // The same as VRM 0.x.
  auto [j, bin] = SplitGlbForTest(vrm.value());
  const nlohmann::json v1 = j["extensions"]["VRMC_vrm"];
  nlohmann::json groups = nlohmann::json::array();
  // clang-format off
  const std::map<std::string, std::string> preset0 = {
      {"happy", "joy"}, {"sad", "sorrow"}, {"relaxed", "fun"}, {"aa", "a"}, {"ih", "i"},
      {"ou", "u"}, {"ee", "e"}, {"oh", "o"}, {"blinkLeft", "blink_l"}, {"blinkRight", "blink_r"}};
  // clang-format on
  for (auto it = v1["expressions"]["preset"].begin(); it != v1["expressions"]["preset"].end();
       ++it) {
    nlohmann::json binds = nlohmann::json::array();
    for (const auto& b : it.value()["morphTargetBinds"]) {
      binds.push_back({{"mesh", j["nodes"][b["node"].get<int>()]["mesh"]},
                       {"index", b["index"]},
                       {"weight", b["weight"].get<double>() * 100}});
    }
    const std::string name = it.key();
    groups.push_back({{"name", name},
                      {"presetName", preset0.count(name) ? preset0.at(name) : name},
                      {"binds", binds}});
  }
  nlohmann::json bones = nlohmann::json::array();
  for (auto it = v1["humanoid"]["humanBones"].begin(); it != v1["humanoid"]["humanBones"].end();
       ++it)
    bones.push_back({{"bone", it.key()}, {"node", it.value()["node"]}});
  j["extensions"].erase("VRMC_vrm");
  j["extensionsUsed"] = nlohmann::json::array({"VRM"});
  j["extensions"]["VRM"] = {{"meta",
                             {{"title", "Uka 0.x"},
                              {"author", "test"},
                              {"otherLicenseUrl", "https://creativecommons.org/licenses/by/4.0/"}}},
                            {"humanoid", {{"humanBones", bones}}},
                            {"blendShapeMaster", {{"blendShapeGroups", groups}}},
                            {"firstPerson",
                             {{"lookAtTypeName", "Bone"},
                              {"firstPersonBone", v1["humanoid"]["humanBones"]["head"]["node"]},
                              {"lookAtHorizontalOuter", {{"xRange", 60}, {"yRange", 10}}}}}};
  const std::string v0 = JoinGlbForTest(j, bin);
  auto zero_x = LoadRigMemory(
      std::span<const unsigned char>(reinterpret_cast<const unsigned char*>(v0.data()), v0.size()),
      formats::RigFormat::kGltf, "uka_vrm0");
  ASSERT_TRUE(zero_x.ok()) << zero_x.status().message;
  check(zero_x.value(), "VRM 0.x");
  EXPECT_EQ(zero_x->name,
            "uka_vrm0");  // The id names a rig loaded from memory; the file's title does not.
  EXPECT_TRUE(zero_x->gaze.faces_minus_z);
  EXPECT_FLOAT_EQ(zero_x->gaze.horizontal_outer.input_max, 60.0f);
  EXPECT_FLOAT_EQ(zero_x->gaze.horizontal_outer.output_scale, 10.0f);
}

// Terms: the manifest's, refused when malformed; Uka's survive a VRM's round trip, 1.0 and 0.x
// (whose meta says fewer of them: the rest fall back to VRM's most restrictive); her blush, a
// material morph, comes back as a material colour bind on a shape of its own, and the 0.x file is
// turned half round.
TEST(Face, VrmTermsAndColourBindsSurviveARoundTrip) {
  Rig rig;
  auto bad = [&](const char* text) { return formats::ApplyManifest(rig, text); };
  EXPECT_EQ(bad(R"({"terms": {"allowExcessivelyViolentUsage": false}})").fields.at(0).pointer,
            "/terms/source");
  EXPECT_EQ(bad(R"({"terms": {"source": "x", "allowExcessivelySexualUsage": "no"}})")
                .fields.at(0)
                .pointer,
            "/terms/allowExcessivelySexualUsage");
  EXPECT_EQ(
      bad(R"({"terms": {"source": "x", "avatarPermission": "Everyone"}})").fields.at(0).pointer,
      "/terms/avatarPermission");
  EXPECT_NE(bad(R"({"terms": {"source": "x", "allowRedistributon": true}})")
                .message.find("did you mean 'allowRedistribution'"),
            std::string::npos);
  const Rig& uka = Uka();
  EXPECT_FALSE(uka.terms.violent);
  EXPECT_EQ(uka.terms.avatar, UsageTerms::Avatar::kEveryone);
  BlendedRig blended;
  BlendContext context;
  const std::vector<float> zero(uka.shapes.size(), 0.0f);
  ASSERT_TRUE(EvaluateRig(uka, zero, {}, blended, context).ok());
  for (formats::MeshFormat format : {formats::MeshFormat::kVrm, formats::MeshFormat::kVrm0}) {
    auto vrm = ExportMesh(uka, blended, zero, {}, format);
    ASSERT_TRUE(vrm.ok()) << vrm.status().message;
    auto back = LoadRigMemory(std::span<const unsigned char>(
                                  reinterpret_cast<const unsigned char*>(vrm->data()), vrm->size()),
                              formats::RigFormat::kGltf, "back");
    ASSERT_TRUE(back.ok()) << back.status().message;
    const bool one = format == formats::MeshFormat::kVrm;
    EXPECT_EQ(back->terms.source, "the VRM's meta");
    EXPECT_FALSE(back->terms.violent || back->terms.sexual || back->terms.antisocial_or_hate ||
                 back->terms.political_or_religious);
    EXPECT_EQ(back->terms.avatar, UsageTerms::Avatar::kEveryone);
    EXPECT_EQ(back->terms.commercial, UsageTerms::Commercial::kCorporation);
    EXPECT_EQ(back->terms.modification,
              one ? UsageTerms::Modification::kAllowModificationRedistribution
                  : UsageTerms::Modification::kProhibited);
    const int blush = FindExpression(back.value(), "blush");
    ASSERT_GE(blush, 0);
    std::vector<float> w(back->shapes.size(), 0.0f);
    for (const auto& [shape, weight] : back->expressions[blush].binds) w[shape] = weight;
    std::vector<std::array<float, 4>> colours;
    MorphedMaterialColors(back.value(), w, colours);
    const int cheeks = 10;  // 頬照り2, transparent until blushing.
    ASSERT_EQ(back->materials[cheeks].name, "頬照り2");
    ASSERT_EQ(colours.size(), back->materials.size());
    EXPECT_NEAR(colours[cheeks][3], 1.0f, 1e-6f) << (one ? "1.0" : "0.x");
    EXPECT_NEAR(back->primitives[0].positions[0],
                (one ? 1.0f : -1.0f) * uka.primitives[0].positions[0], 1e-6f);
    EXPECT_NEAR(back->primitives[0].positions[2],
                (one ? 1.0f : -1.0f) * uka.primitives[0].positions[2], 1e-6f);
  }
}

}  // namespace face_test
}  // namespace facespace
