// Skeletons: skinning, sampling, blending and poses, checked analytically and against an
// independent evaluation of the real skinned assets written in this test (Eigen's own
// quaternion slerp, straight from the glTF JSON and buffers).
#include "facespace/engine/skeleton.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "facespace/engine/blend.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace skeleton_test {  // Named: core_tests is a unity build, its files share one unit.

// ---- analytic ------------------------------------------------------------------------------

// A vertical two-bone chain: joint 0 at the origin, joint 1 at y = 1 (its child). Vertices
// at y = 0.5 (bone 0 only), y = 1 (half and half) and y = 2 (bone 1 only).
Rig TwoBones() {
  Rig rig;
  rig.nodes.resize(3);
  rig.nodes[0].name = "root";
  rig.nodes[0].children = {1};
  rig.nodes[1].name = "tip";
  rig.nodes[1].parent = 0;
  rig.nodes[1].translation = {0, 1, 0};
  rig.nodes[2].name = "mesh";
  rig.nodes[2].mesh = 0;
  rig.scene_roots = {0, 2};
  Skin skin;
  skin.name = "chain";
  skin.joints = {0, 1};
  skin.inverse_bind = {
      1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0,  0, 1,   // Inverse of identity.
      1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -1, 0, 1};  // Inverse of translate(0, 1, 0).
  rig.skins.push_back(skin);
  Primitive p;
  p.mode = PrimitiveMode::kPoints;
  p.positions = {0, 0.5f, 0, 0, 1, 0, 0, 2, 0};
  p.indices = {0, 1, 2};
  p.influences = 2;
  p.joints = {0, 1, 0, 1, 0, 1};
  p.joint_weights = {1, 0, 0.5f, 0.5f, 0, 1};
  FinalizePrimitive(p);
  rig.primitives.push_back(p);
  Mesh mesh;
  mesh.name = "chain";
  mesh.primitives = {0};
  mesh.skin = 0;
  rig.meshes.push_back(mesh);
  EXPECT_TRUE(ValidateRig(rig).ok());
  return rig;
}

TEST(JobResult, TwoBoneBend) {
  Rig rig = TwoBones();
  Pose pose = RestPose(rig);
  pose.local[1].rotation = EulerToQuaternion(0, 0, 90);  // Tip bends 90 degrees about +z.
  BlendedRig out;
  BlendContext ctx;
  BlendOptions o;
  o.pose = &pose;
  ASSERT_TRUE(EvaluateRig(rig, {}, o, out, ctx).ok());
  const auto& q = out.primitives[0].positions;
  EXPECT_TRUE(out.primitives[0].skinned);
  // Bone 0 only: unmoved.
  EXPECT_NEAR(q[0], 0.0f, 1e-6f);
  EXPECT_NEAR(q[1], 0.5f, 1e-6f);
  // At the joint, both bones agree: (0, 1).
  EXPECT_NEAR(q[3], 0.0f, 1e-6f);
  EXPECT_NEAR(q[4], 1.0f, 1e-6f);
  // Bone 1 only: one unit along the bent bone, (-1, 1).
  EXPECT_NEAR(q[6], -1.0f, 1e-6f);
  EXPECT_NEAR(q[7], 1.0f, 1e-6f);
}

TEST(JobResult, RestPoseGivesTheBindMesh) {
  Rig rig = TwoBones();
  BlendedRig out;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(rig, {}, {}, out, ctx).ok());
  EXPECT_EQ(out.primitives[0].positions, rig.primitives[0].positions);
}

TEST(JobResult, DualQuaternionKeepsVolumeOnTwist) {
  // A tube along x (rings of radius 1 at x = 0, 0.5, 1, 1.5, 2), bones at x = 0 and x = 1;
  // the ring at x = 1 follows both half and half. Twisting the tip 90 degrees about x
  // collapses that ring to cos(45) with linear blending (the candy wrapper) and keeps its
  // radius with dual quaternions.
  Rig rig = TwoBones();
  rig.nodes[1].translation = {1, 0, 0};
  rig.skins[0].inverse_bind[16 + 12] = -1.0f;  // Inverse of translate(1, 0, 0).
  rig.skins[0].inverse_bind[16 + 13] = 0.0f;
  Primitive& p = rig.primitives[0];
  p.positions.clear();
  p.joints.clear();
  p.joint_weights.clear();
  p.indices.clear();
  for (int ring = 0; ring < 5; ++ring) {
    const float x = 0.5f * ring, w1 = x < 1.0f ? 0.0f : x > 1.0f ? 1.0f : 0.5f;
    for (int k = 0; k < 8; ++k) {
      const float a = static_cast<float>(k) * static_cast<float>(M_PI) / 4.0f;
      p.positions.insert(p.positions.end(), {x, std::cos(a), std::sin(a)});
      p.joints.insert(p.joints.end(), {0, 1});
      p.joint_weights.insert(p.joint_weights.end(), {1.0f - w1, w1});
      p.indices.push_back(static_cast<uint32_t>(p.indices.size()));
    }
  }
  FinalizePrimitive(p);
  ASSERT_TRUE(ValidateRig(rig).ok());
  Pose pose = RestPose(rig);
  pose.local[1].rotation = EulerToQuaternion(90, 0, 0);
  auto middle_radius = [&](bool dq) {
    BlendedRig out;
    BlendContext ctx;
    BlendOptions o;
    o.pose = &pose;
    o.dual_quaternion = dq;
    EXPECT_TRUE(EvaluateRig(rig, {}, o, out, ctx).ok());
    const auto& q = out.primitives[0].positions;
    float r = 0;
    for (int k = 0; k < 8; ++k) r += std::hypot(q[3 * (16 + k) + 1], q[3 * (16 + k) + 2]) / 8.0f;
    return r;
  };
  EXPECT_NEAR(middle_radius(false), std::sqrt(0.5f), 1e-5f);
  EXPECT_NEAR(middle_radius(true), 1.0f, 1e-5f);
  // Both agree where a single bone rules (the tip ring turned 90 degrees: y -> z).
  BlendedRig lin, dq;
  BlendContext ctx;
  BlendOptions o;
  o.pose = &pose;
  ASSERT_TRUE(EvaluateRig(rig, {}, o, lin, ctx).ok());
  o.dual_quaternion = true;
  ASSERT_TRUE(EvaluateRig(rig, {}, o, dq, ctx).ok());
  for (int i = 3 * 32; i < 3 * 40; ++i)
    EXPECT_NEAR(lin.primitives[0].positions[i], dq.primitives[0].positions[i], 1e-5f);
  EXPECT_NEAR(lin.primitives[0].positions[3 * 32 + 2], 1.0f, 1e-5f);
}

TEST(JobValidity, SkinningJob) {
  Rig rig = TwoBones();
  const Primitive& p = rig.primitives[0];
  std::vector<float> jm(32, 0.0f), out(9, -1.0f);
  SkinningJob ok{.joint_matrices = jm,
                 .influences = 2,
                 .joints = p.joints,
                 .weights = p.joint_weights,
                 .in_positions = p.positions,
                 .out_positions = out};
  EXPECT_TRUE(ok.Validate());
  SkinningJob one_joint = ok;
  std::vector<float> jm1(16);
  one_joint.joint_matrices = jm1;  // Joint index 1 has no matrix.
  EXPECT_FALSE(one_joint.Run());
  EXPECT_EQ(out, std::vector<float>(9, -1.0f));
  SkinningJob wrong_count = ok;
  wrong_count.influences = 3;
  EXPECT_FALSE(wrong_count.Validate());
  std::vector<float> short_out(6);
  SkinningJob short_job = ok;
  short_job.out_positions = short_out;
  EXPECT_FALSE(short_job.Validate());
}

TEST(Sampling, StepLinearCubic) {
  Rig rig = TwoBones();
  AnimationInfo clip;
  clip.name = "move";
  AnimationSampler lin;
  lin.times = {0, 1, 3};
  lin.values = {0, 0, 0, 2, 0, 0, 2, 4, 0};
  lin.components = 3;
  AnimationSampler step = lin;
  step.interpolation = Interpolation::kStep;
  AnimationSampler cubic;
  cubic.interpolation = Interpolation::kCubicSpline;
  cubic.times = {0, 2};
  // (in-tangent, value, out-tangent) per key: value 0 -> 1 with zero tangents (smoothstep).
  cubic.values = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 0, 0, 0};
  cubic.components = 3;
  clip.sampler_data = {lin, step, cubic};
  clip.channel_data = {{0, 0, ChannelPath::kTranslation},
                       {1, 1, ChannelPath::kTranslation},
                       {2, 2, ChannelPath::kScale}};
  clip.duration = 3;
  rig.animations.push_back(clip);
  auto sample = [&](float t, ClipWrap wrap) {
    Pose pose = RestPose(rig);
    std::vector<float> w;
    std::vector<uint8_t> set;
    EXPECT_TRUE(SampleClip(rig, 0, t, wrap, pose, w, set).ok());
    return pose;
  };
  Pose p = sample(0.5f, ClipWrap::kClamp);
  EXPECT_FLOAT_EQ(p.local[0].translation[0], 1.0f);  // Linear: halfway to 2.
  EXPECT_FLOAT_EQ(p.local[1].translation[0], 0.0f);  // Step: holds the first key.
  EXPECT_FLOAT_EQ(p.local[2].scale[0], 0.15625f);    // Hermite at u = 0.25: 3u^2 - 2u^3.
  p = sample(2.0f, ClipWrap::kClamp);
  EXPECT_FLOAT_EQ(p.local[0].translation[1], 2.0f);  // Between keys 1 and 3.
  EXPECT_FLOAT_EQ(p.local[1].translation[0], 2.0f);
  p = sample(7.0f, ClipWrap::kClamp);
  EXPECT_FLOAT_EQ(p.local[0].translation[1], 4.0f);  // Clamped at the end.
  p = sample(3.5f, ClipWrap::kLoop);
  EXPECT_FLOAT_EQ(p.local[0].translation[0], 1.0f);  // 3.5 loops to 0.5.
  p = sample(-1.0f, ClipWrap::kClamp);
  EXPECT_FLOAT_EQ(p.local[0].translation[0], 0.0f);
}

TEST(Sampling, SlerpTakesTheShortPath) {
  const std::array<float, 4> a{0, 0, 0, 1};
  const std::array<float, 4> b = EulerToQuaternion(0, 0, 170);
  std::array<float, 4> nb;
  for (int i = 0; i < 4; ++i) nb[i] = -b[i];  // The same rotation, other hemisphere.
  const auto m1 = Slerp(a, b, 0.5f), m2 = Slerp(a, nb, 0.5f);
  const auto want = EulerToQuaternion(0, 0, 85);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(m1[i], want[i], 1e-5f);
    EXPECT_NEAR(m2[i], want[i], 1e-5f);
  }
}

TEST(Pose, RequestsAndErrors) {
  Rig rig = TwoBones();
  PoseRequest req;
  JointOverride j;
  j.joint = "tip";
  j.pointer = "/pose/tip";
  j.has_rotation = true;
  j.rotation = {0, 0, 2, 2};  // 90 degrees about z, length 2*sqrt(2).
  req.joints.push_back(j);
  Pose pose;
  std::vector<float> w;
  std::vector<uint8_t> set;
  std::vector<Warning> warnings;
  ASSERT_TRUE(BuildPose(rig, req, pose, w, set, warnings).ok());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].code, "quaternion_normalised");
  EXPECT_NEAR(pose.local[1].rotation[2], std::sqrt(0.5f), 1e-6f);
  EXPECT_EQ(pose.local[1].translation, (std::array<float, 3>{0, 1, 0}))
      << "translation kept from rest";

  req.joints[0].rotation = {0, 0, 0, 0};
  auto bad = BuildPose(rig, req, pose, w, set, warnings);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.fields[0].pointer, "/pose/tip/rotation");
  req.joints[0].rotation = {NAN, 0, 0, 1};
  EXPECT_FALSE(BuildPose(rig, req, pose, w, set, warnings).ok());
  req.joints[0].joint = "nose";
  EXPECT_NE(BuildPose(rig, req, pose, w, set, warnings).message.find("unknown joint 'nose'"),
            std::string::npos);
  PoseRequest clip;
  clip.clips.push_back(ClipRequest{.name = "dance", .pointer = "/animation"});
  EXPECT_NE(BuildPose(rig, clip, pose, w, set, warnings).message.find("unknown animation 'dance'"),
            std::string::npos);
}

TEST(Pose, BlendOfClipsWithMask) {
  Rig rig = TwoBones();
  for (float x : {0.0f, 10.0f}) {
    AnimationInfo clip;
    clip.name = x == 0 ? "a" : "b";
    AnimationSampler s;
    s.times = {0};
    s.values = {x, 0, 0};
    s.components = 3;
    clip.sampler_data = {s};
    clip.channel_data = {{0, 0, ChannelPath::kTranslation}, {0, 1, ChannelPath::kTranslation}};
    rig.animations.push_back(clip);
  }
  std::vector<ClipLayer> layers = {{.clip = 0, .weight = 0.7f}, {.clip = 1, .weight = 0.3f}};
  Pose pose = RestPose(rig);
  std::vector<float> w;
  std::vector<uint8_t> set;
  ASSERT_TRUE(BlendClips(rig, layers, pose, w, set).ok());
  EXPECT_FLOAT_EQ(pose.local[0].translation[0], 3.0f);
  EXPECT_FLOAT_EQ(pose.local[1].translation[0], 3.0f);
  // Clip b limited to the tip's subtree: the root follows clip a alone.
  layers[1].mask = {1};
  pose = RestPose(rig);
  ASSERT_TRUE(BlendClips(rig, layers, pose, w, set).ok());
  EXPECT_FLOAT_EQ(pose.local[0].translation[0], 0.0f);
  EXPECT_FLOAT_EQ(pose.local[1].translation[0], 3.0f);
}

TEST(Pose, AnimatedWeightsYieldToExplicitOnes) {
  auto rig = formats::LoadGltfFile(test::RealAsset("AnimatedMorphCube/AnimatedMorphCube.gltf"));
  ASSERT_TRUE(rig.ok());
  PoseRequest req;
  req.clips.push_back(ClipRequest{.index = 0, .time = 1.0f, .pointer = "/animation"});
  std::vector<float> weights;
  Pose pose;
  bool posed = false;
  std::vector<Warning> warnings;
  std::vector<WeightEntry> none;
  ASSERT_TRUE(ResolvePoseAndWeights(rig.value(), none, req, weights, pose, posed, warnings).ok());
  EXPECT_TRUE(posed);
  // The clip drives both shapes (raw values at t = 1: see the asset's output accessor).
  test::RawGltf raw(test::RealAsset("AnimatedMorphCube/AnimatedMorphCube.gltf"));
  const auto& sampler = raw.json["animations"][0]["samplers"][0];
  const auto times = raw.Floats(sampler["input"]);
  const auto values = raw.Floats(sampler["output"]);
  const size_t k = std::upper_bound(times.begin(), times.end(), 1.0f) - times.begin();
  const float u = (1.0f - times[k - 1]) / (times[k] - times[k - 1]);
  for (int s = 0; s < 2; ++s) {
    EXPECT_NEAR(weights[s],
                values[2 * (k - 1) + s] + u * (values[2 * k + s] - values[2 * (k - 1) + s]), 1e-6f);
  }
  std::vector<WeightEntry> one = {{.name = rig->shapes[0].name, .value = 0.25}};
  ASSERT_TRUE(ResolvePoseAndWeights(rig.value(), one, req, weights, pose, posed, warnings).ok());
  EXPECT_FLOAT_EQ(weights[0], 0.25f);
}

// ---- real assets against an independent evaluation -----------------------------------------

Eigen::Matrix4f NodeLocal(const nlohmann::json& n) {
  if (n.contains("matrix")) {
    Eigen::Matrix4f m;
    for (int i = 0; i < 16; ++i) m.data()[i] = n["matrix"][i].get<float>();
    return m;
  }
  Eigen::Vector3f t(0, 0, 0), s(1, 1, 1);
  Eigen::Quaternionf r(1, 0, 0, 0);
  if (n.contains("translation"))
    t = Eigen::Vector3f(n["translation"][0], n["translation"][1], n["translation"][2]);
  if (n.contains("scale")) s = Eigen::Vector3f(n["scale"][0], n["scale"][1], n["scale"][2]);
  if (n.contains("rotation"))
    r = Eigen::Quaternionf(n["rotation"][3], n["rotation"][0], n["rotation"][1], n["rotation"][2]);
  return (Eigen::Translation3f(t) * r.normalized() * Eigen::Scaling(s)).matrix();
}

// Node locals of `raw` with animation `anim` applied at `t` (LINEAR samplers only).
std::vector<nlohmann::json> AnimatedNodes(const test::RawGltf& raw, int anim, float t) {
  std::vector<nlohmann::json> nodes(raw.json["nodes"].begin(), raw.json["nodes"].end());
  const auto& a = raw.json["animations"][anim];
  for (const auto& ch : a["channels"]) {
    const auto& smp = a["samplers"][ch["sampler"].get<int>()];
    EXPECT_EQ(smp.value("interpolation", std::string("LINEAR")), "LINEAR");
    const auto times = raw.Floats(smp["input"]);
    const auto values = raw.Floats(smp["output"]);
    const std::string path = ch["target"]["path"];
    const int comps = path == "rotation" ? 4 : 3;
    size_t k0 = 0, k1 = 0;
    float u = 0;
    if (t >= times.back()) {
      k0 = k1 = times.size() - 1;
    } else if (t > times.front()) {
      k1 = std::upper_bound(times.begin(), times.end(), t) - times.begin();
      k0 = k1 - 1;
      u = (t - times[k0]) / (times[k1] - times[k0]);
    }
    auto& node = nodes[ch["target"]["node"].get<int>()];
    if (path == "rotation") {
      const Eigen::Quaternionf q0(values[4 * k0 + 3], values[4 * k0], values[4 * k0 + 1],
                                  values[4 * k0 + 2]);
      const Eigen::Quaternionf q1(values[4 * k1 + 3], values[4 * k1], values[4 * k1 + 1],
                                  values[4 * k1 + 2]);
      const Eigen::Quaternionf q = q0.slerp(u, q1).normalized();
      node["rotation"] = {q.x(), q.y(), q.z(), q.w()};
    } else {
      std::vector<float> v(comps);
      for (int c = 0; c < comps; ++c)
        v[c] = values[comps * k0 + c] + u * (values[comps * k1 + c] - values[comps * k0 + c]);
      node[path] = v;
    }
  }
  return nodes;
}

struct SkinCase {
  const char* path;
  int animation;
  float time;
};

void PrintTo(const SkinCase& c, std::ostream* os) { *os << c.path << " @" << c.time; }

class SkinnedAssets : public ::testing::TestWithParam<SkinCase> {};

TEST_P(SkinnedAssets, MatchIndependentEvaluation) {
  const SkinCase& c = GetParam();
  auto rig = formats::LoadGltfFile(test::RealAsset(c.path));
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  test::RawGltf raw(test::RealAsset(c.path));
  // Reference: world matrices by recursion, joint matrices, LBS with normalised weights.
  const auto nodes = AnimatedNodes(raw, c.animation, c.time);
  std::vector<int> parent(nodes.size(), -1);
  for (size_t i = 0; i < nodes.size(); ++i) {
    for (const auto& ch : nodes[i].value("children", nlohmann::json::array()))
      parent[ch.get<int>()] = static_cast<int>(i);
  }
  std::function<Eigen::Matrix4f(int)> world = [&](int i) -> Eigen::Matrix4f {
    return parent[i] < 0 ? NodeLocal(nodes[i])
                         : Eigen::Matrix4f(world(parent[i]) * NodeLocal(nodes[i]));
  };
  const auto& skin = raw.json["skins"][0];
  const auto ibm = raw.Floats(skin["inverseBindMatrices"]);
  std::vector<Eigen::Matrix4f> jm;
  for (size_t j = 0; j < skin["joints"].size(); ++j) {
    jm.push_back(world(skin["joints"][j].get<int>()) *
                 Eigen::Map<const Eigen::Matrix4f>(&ibm[16 * j]));
  }
  const auto& prim = raw.json["meshes"][0]["primitives"][0];
  const auto pos = raw.Floats(prim["attributes"]["POSITION"]);
  const auto joints = raw.U16(prim["attributes"]["JOINTS_0"]);
  const auto weights = raw.Floats(prim["attributes"]["WEIGHTS_0"]);
  std::vector<float> expected(pos.size());
  float extent = 0;
  for (size_t v = 0; v < pos.size() / 3; ++v) {
    float sum = 0;
    for (int k = 0; k < 4; ++k) sum += weights[4 * v + k];
    Eigen::Vector4f p(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2], 1), q = Eigen::Vector4f::Zero();
    for (int k = 0; k < 4; ++k) q += weights[4 * v + k] / sum * (jm[joints[4 * v + k]] * p);
    for (int i = 0; i < 3; ++i) {
      expected[3 * v + i] = q[i];
      extent = std::max(extent, std::fabs(q[i]));
    }
  }
  // Ours: the clip through the request path.
  PoseRequest req;
  req.clips.push_back(ClipRequest{.index = c.animation, .time = c.time, .pointer = "/animation"});
  std::vector<float> w;
  Pose pose;
  bool posed = false;
  std::vector<Warning> warnings;
  std::vector<WeightEntry> none;
  ASSERT_TRUE(ResolvePoseAndWeights(rig.value(), none, req, w, pose, posed, warnings).ok());
  BlendedRig out;
  BlendContext ctx;
  BlendOptions o;
  o.pose = &pose;
  ASSERT_TRUE(EvaluateRig(rig.value(), w, o, out, ctx).ok());
  ASSERT_TRUE(out.primitives[0].skinned);
  EXPECT_LE(test::MaxAbsDiff(out.primitives[0].positions, expected),
            2e-5f * std::max(extent, 1.0f));
  // Normals stay unit length after skinning.
  const auto& n = out.primitives[0].normals;
  for (size_t v = 0; v < n.size(); v += 3) {
    ASSERT_NEAR(n[v] * n[v] + n[v + 1] * n[v + 1] + n[v + 2] * n[v + 2], 1.0f, 1e-4f);
  }
}

INSTANTIATE_TEST_SUITE_P(Skins, SkinnedAssets,
                         ::testing::Values(SkinCase{"SimpleSkin/SimpleSkin.gltf", 0, 0.0f},
                                           SkinCase{"SimpleSkin/SimpleSkin.gltf", 0, 2.25f},
                                           SkinCase{"SimpleSkin/SimpleSkin.gltf", 0, 4.9f},
                                           SkinCase{"RiggedSimple/RiggedSimple.gltf", 0, 0.37f},
                                           SkinCase{"RiggedSimple/RiggedSimple.gltf", 0, 1.5f},
                                           SkinCase{"CesiumMan/CesiumMan.gltf", 0, 0.0f},
                                           SkinCase{"CesiumMan/CesiumMan.gltf", 0, 0.8f},
                                           SkinCase{"CesiumMan/CesiumMan.gltf", 0, 1.7f},
                                           SkinCase{"Fox/Fox.glb", 0, 1.2f},
                                           SkinCase{"Fox/Fox.glb", 1, 0.3f},
                                           SkinCase{"Fox/Fox.glb", 2, 0.77f}),
                         [](const auto& param_info) {
                           std::string n =
                               std::string(param_info.param.path) + "_a" +
                               std::to_string(param_info.param.animation) + "_t" +
                               std::to_string(static_cast<int>(param_info.param.time * 100));
                           n = n.substr(n.find('/') + 1);
                           for (char& ch : n)
                             if (!isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n;
                         });

TEST(Skins, CesiumManWeightsAreNormalisedWithAWarning) {
  auto rig = formats::LoadGltfFile(test::RealAsset("CesiumMan/CesiumMan.gltf"));
  ASSERT_TRUE(rig.ok());
  bool warned = false;
  for (const Warning& w : rig->load_warnings)
    warned |= w.code == "weights_normalised" && w.value == 210;
  EXPECT_TRUE(warned) << "210 of 3273 vertices do not sum to 1 in this sample";
  const Primitive& p = rig->primitives[0];
  for (size_t v = 0; v < p.vertex_count(); ++v) {
    float sum = 0;
    for (size_t k = 0; k < p.influences; ++k) sum += p.joint_weights[v * p.influences + k];
    ASSERT_NEAR(sum, 1.0f, 1e-5f);
  }
}

}  // namespace skeleton_test
}  // namespace facespace
