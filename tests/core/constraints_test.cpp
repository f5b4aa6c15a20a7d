// MMD's bone constraints (core/constraints.h): grants and IK on small skeletons whose answers
// follow from geometry, then on Uka (shared/assets/more/MMD) with the motions she is played with.
#include "facespace/engine/constraints.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "facespace/engine/animation.h"
#include "facespace/engine/blend.h"
#include "facespace/engine/pose_request.h"
#include "facespace/formats/io.h"
#include "test_util.h"
#include "world.h"

namespace facespace {
namespace constraints_test {  // Named: core_tests is a unity build, its files share one unit.

constexpr float kPi = 3.14159265358979f;

// A chain of nodes along +y from the origin, one unit apart: node 0 the root, then 1..n.
Rig Chain(int n) {
  Rig rig;
  for (int i = 0; i <= n; ++i) {
    Node node;
    node.name = "b" + std::to_string(i);
    node.parent = i - 1;
    if (i > 0) {
      node.translation = {0, 1, 0};
      rig.nodes[i - 1].children.push_back(i);
    }
    rig.nodes.push_back(node);
  }
  rig.scene_roots = {0};
  return rig;
}

Eigen::Vector3f NodePosition(const Rig& rig, const Pose& pose, int node) {
  const auto world = WorldMatrices(rig, pose);
  return {world[node][12], world[node][13], world[node][14]};
}

std::array<float, 4> AxisAngle(float x, float y, float z, float angle) {
  const Eigen::Quaternionf q(Eigen::AngleAxisf(angle, Eigen::Vector3f(x, y, z).normalized()));
  return {q.x(), q.y(), q.z(), q.w()};
}

// A two-bone arm (shoulder 1, elbow 2, hand 3) and an IK bone 4 under the root where the hand is
// to be: any point closer to the shoulder than the arm's length is reached.
Rig Arm(bool knee) {
  Rig rig = Chain(3);
  Node ik;
  ik.name = "ik";
  ik.parent = 0;
  ik.translation = {0, 3, 0};  // The hand's rest position.
  rig.nodes[0].children.push_back(4);
  rig.nodes.push_back(ik);
  IkChain c;
  c.node = 4;
  c.effector = 3;
  c.loops = 40;
  c.max_angle = 2.0f;
  IkLink elbow{2, knee, {0, 0, 0}, {0, 0, 0}};
  if (knee)
    elbow.lower[0] = 0.5f * kPi / 180, elbow.upper[0] = kPi;  // Bends one way only, about x.
  c.links = {elbow, IkLink{1}};
  rig.constraints.chains = {c};
  rig.constraints.order = {4};
  return rig;
}

TEST(Ik, TheEffectorReachesAReachableGoal) {
  const Rig rig = Arm(false);
  for (const Eigen::Vector3f& goal :
       {Eigen::Vector3f(1.0f, 2.0f, 0.3f), Eigen::Vector3f(0.0f, 1.2f, 1.0f),
        Eigen::Vector3f(-1.5f, 1.0f, -0.2f)}) {
    Pose pose = RestPose(rig);
    pose.local[4].translation = {goal.x(), goal.y(), goal.z()};
    SolveBoneConstraints(rig, pose);
    EXPECT_LT((NodePosition(rig, pose, 3) - goal).norm(), 1e-3f) << goal.transpose();
    // The bones keep their lengths: rotations only.
    EXPECT_NEAR((NodePosition(rig, pose, 2) - NodePosition(rig, pose, 1)).norm(), 1.0f, 1e-5f);
  }
}

TEST(Ik, AGoalOutOfReachStretchesTheArmTowardsIt) {
  const Rig rig = Arm(false);
  Pose pose = RestPose(rig);
  pose.local[4].translation = {5, 1, 0};
  SolveBoneConstraints(rig, pose);
  // Shoulder at (0, 1, 0), the arm 2 long: the hand lands on the line to the goal, 2 away.
  const Eigen::Vector3f want = Eigen::Vector3f(0, 1, 0) + 2 * Eigen::Vector3f(5, 0, 0).normalized();
  EXPECT_LT((NodePosition(rig, pose, 3) - want).norm(), 0.05f);
}

TEST(Ik, AKneeBendsOneWayAboutItsAxisWithinItsLimits) {
  const Rig rig = Arm(true);
  // A goal in the y-z plane, 1.2 from the shoulder: the knee must bend (about x) by the angle the
  // triangle of sides 1, 1, 1.2 gives, and only the way its limits allow.
  Pose pose = RestPose(rig);
  pose.local[4].translation = {0, 1.0f + 0.6f, 1.2f * std::sqrt(1 - 0.25f)};
  SolveBoneConstraints(rig, pose);
  const Eigen::Quaternionf knee(pose.local[2].rotation[3], pose.local[2].rotation[0],
                                pose.local[2].rotation[1], pose.local[2].rotation[2]);
  const Eigen::AngleAxisf aa(knee);
  EXPECT_NEAR(std::fabs(aa.axis().x()), 1.0f, 1e-4f);  // About x alone.
  const float bend = aa.axis().x() > 0 ? aa.angle() : -aa.angle();
  EXPECT_GT(bend, 0.5f * kPi / 180 - 1e-6f);
  EXPECT_NEAR(bend, kPi - 2 * std::asin(0.6f), 2e-3f);  // The angle at the knee: pi - 2 asin(0.6).
  EXPECT_LT((NodePosition(rig, pose, 3) - Eigen::Vector3f(0, 1.6f, 1.2f * std::sqrt(0.75f))).norm(),
            2e-3f);
}

TEST(Grant, ABoneInheritsAShareOfAnothersRotationAndTranslation) {
  Rig rig = Chain(3);
  // b3 takes half of b1's rotation and translation (b1's animated values, not what b1 inherits).
  rig.constraints.grants = {Grant{3, 1, 0.5f, true, true, false}};
  rig.constraints.order = {3};
  Pose pose = RestPose(rig);
  pose.local[1].rotation = AxisAngle(0, 0, 1, 1.0f);
  pose.local[1].translation = {0.4f, 1.0f, 0.0f};  // Moved 0.4 along x from its rest.
  pose.local[3].rotation =
      AxisAngle(1, 0, 0, 0.3f);  // b3's own animation stays, the share after it.
  SolveBoneConstraints(rig, pose);
  const Eigen::Quaternionf want =
      Eigen::Quaternionf(Eigen::AngleAxisf(0.3f, Eigen::Vector3f::UnitX())) *
      Eigen::Quaternionf(Eigen::AngleAxisf(0.5f, Eigen::Vector3f::UnitZ()));
  const Eigen::Quaternionf got(pose.local[3].rotation[3], pose.local[3].rotation[0],
                               pose.local[3].rotation[1], pose.local[3].rotation[2]);
  EXPECT_NEAR(std::fabs(got.dot(want)), 1.0f, 1e-6f);
  EXPECT_NEAR(pose.local[3].translation[0], 0.2f, 1e-6f);
  EXPECT_NEAR(pose.local[3].translation[1], 1.0f, 1e-6f);
}

// ---- motion layers ----

// A turn about z as a sampler's four values.
std::vector<float> TurnZ(float angle) {
  const std::array<float, 4> q = AxisAngle(0, 0, 1, angle);
  return {q.begin(), q.end()};
}

// A sampler of one key.
AnimationSampler Key(std::vector<float> values, size_t components) {
  AnimationSampler s;
  s.times = {0.0f, 2.0f};
  s.values = values;
  s.values.insert(s.values.end(), values.begin(), values.end());
  s.components = components;
  return s;
}

// Nodes b1, b2 under b0 and a mesh of two shapes; clip 0 (the base) turns b1 by 1 rad and b2 by 0.5
// about z and sets shape 0 to 0.2; clip 1 keys b1 at rest, turns b2 by 1.0, keys shape 0 at 0 and
// shape 1 at 1.
Rig Layered() {
  Rig rig = Chain(2);
  rig.shapes.resize(2);
  rig.shapes[0].name = "s0";
  rig.shapes[1].name = "s1";
  Mesh mesh;
  mesh.target_shapes = {0, 1};
  rig.meshes.push_back(mesh);
  rig.nodes[0].mesh = 0;
  AnimationInfo base, over;
  base.name = "base";
  over.name = "over";
  base.duration = over.duration = 2.0f;
  base.sampler_data = {Key(TurnZ(1.0f), 4), Key(TurnZ(0.5f), 4), Key({0.2f, 0.0f}, 2)};
  base.channel_data = {{0, 1, ChannelPath::kRotation},
                       {1, 2, ChannelPath::kRotation},
                       {2, 0, ChannelPath::kWeights}};
  over.sampler_data = {Key({0, 0, 0, 1}, 4), Key(TurnZ(1.0f), 4), Key({0.0f, 1.0f}, 2)};
  over.channel_data = {{0, 1, ChannelPath::kRotation},
                       {1, 2, ChannelPath::kRotation},
                       {2, 0, ChannelPath::kWeights}};
  rig.animations = {base, over};
  return rig;
}

float AngleZ(const Transform& t) { return 2.0f * std::atan2(t.rotation[2], t.rotation[3]); }

TEST(Layers, AnOverlayReplacesOnlyWhatItMovesByItsWeight) {
  const Rig rig = Layered();
  Pose pose = RestPose(rig);
  std::vector<float> w;
  std::vector<uint8_t> set;
  std::vector<ClipLayer> layers(2);
  layers[0].clip = 0;
  layers[1].clip = 1;
  layers[1].overlay = true;
  layers[1].weight = 0.5f;
  layers[0].time = layers[1].time = 1.0f;
  ASSERT_TRUE(BlendClips(rig, layers, pose, w, set).ok());
  EXPECT_NEAR(AngleZ(pose.local[1]), 1.0f, 1e-5f);   // Keyed at rest by the overlay: the base's.
  EXPECT_NEAR(AngleZ(pose.local[2]), 0.75f, 1e-5f);  // Halfway from 0.5 to 1.0.
  EXPECT_NEAR(w[0], 0.2f, 1e-6f);                    // Keyed 0 by the overlay: the base's.
  EXPECT_NEAR(w[1], 0.5f, 1e-6f);
  // Fades: a quarter into a 1 s fade-in, and 0.5 s before the end of a 2 s fade-out.
  layers[1].weight = 1.0f;
  layers[1].fade_in = 1.0f;
  layers[1].time = 0.25f;
  ASSERT_TRUE(BlendClips(rig, layers, pose = RestPose(rig), w, set).ok());
  EXPECT_NEAR(w[1], 0.25f, 1e-6f);
  layers[1].fade_in = 0.0f;
  layers[1].fade_out = 2.0f;
  layers[1].time = 1.5f;
  ASSERT_TRUE(BlendClips(rig, layers, pose = RestPose(rig), w, set).ok());
  EXPECT_NEAR(w[1], 0.25f, 1e-6f);
  // Not started (before its time 0) or over (past a fade-out): the base alone.
  for (float t : {-0.5f, 2.5f}) {
    layers[1].time = t;
    ASSERT_TRUE(BlendClips(rig, layers, pose = RestPose(rig), w, set).ok());
    EXPECT_NEAR(AngleZ(pose.local[2]), 0.5f, 1e-5f) << t;
  }
}

// ---- Uka, standing ----

struct Uka {
  Rig rig;
  int stand = -1;
};

Uka LoadUka() {
  Uka u;
  Result<Rig> rig = formats::LoadRigFile(test::SharedAssets() + "/more/MMD/Uka/MS_Uka.pmx");
  EXPECT_TRUE(rig.ok());
  if (!rig.ok()) return u;
  u.rig = std::move(rig.value());
  const auto bytes =
      test::ReadBytes(test::SharedAssets() + "/more/MMD/Uka_upstream/motion/stand.vmd");
  std::vector<Warning> warnings;
  Result<AnimationInfo> stand = formats::LoadVmdMemory(bytes, u.rig, "stand", &warnings);
  EXPECT_TRUE(stand.ok());
  if (!stand.ok()) return u;
  u.rig.animations.push_back(std::move(stand.value()));
  u.stand = static_cast<int>(u.rig.animations.size()) - 1;
  return u;
}

// Width (x) over height (y) of the posed mesh.
float Aspect(const Rig& rig, const Pose& pose) {
  const std::vector<float> p =
      test::WorldOf(rig, std::vector<float>(rig.shapes.size(), 0.0f), &pose);
  float lo[3] = {1e9f, 1e9f, 1e9f}, hi[3] = {-1e9f, -1e9f, -1e9f};
  for (size_t k = 0; k < p.size(); ++k) {
    lo[k % 3] = std::min(lo[k % 3], p[k]);
    hi[k % 3] = std::max(hi[k % 3], p[k]);
  }
  return (hi[0] - lo[0]) / (hi[1] - lo[1]);
}

// The pose (and the animated weights) a request gives.
Pose Posed(const Rig& rig, const PoseRequest& request, std::vector<float>* weights = nullptr) {
  Pose pose;
  std::vector<float> w;
  std::vector<uint8_t> set;
  std::vector<Warning> warnings;
  EXPECT_TRUE(BuildPose(rig, request, pose, w, set, warnings).ok());
  if (weights) *weights = std::move(w);
  return pose;
}

TEST(UkaConstraints, HerIkAndGrantBonesAreRead) {
  const Uka u = LoadUka();
  EXPECT_EQ(u.rig.constraints.chains.size(), 10u);
  EXPECT_EQ(u.rig.constraints.grants.size(), 2u);
  for (const Warning& w : u.rig.load_warnings)
    EXPECT_NE(w.code, "bone_constraints_skipped") << w.message;
}

TEST(UkaConstraints, ThePmdsIkListIsReadWithItsKneesLimited) {
  const Result<Rig> rig =
      formats::LoadRigFile(test::SharedAssets() + "/more/MMD/Uka_PMD/MS_Uka.pmd");
  ASSERT_TRUE(rig.ok());
  EXPECT_GE(rig->constraints.chains.size(), 4u);  // Legs and toes at least.
  size_t knees = 0;
  for (const IkChain& c : rig->constraints.chains) {
    EXPECT_GT(c.loops, 0);
    EXPECT_GT(c.max_angle, 0.0f);
    for (const IkLink& l : c.links) {
      if (rig->nodes[l.node].name.find("ひざ") == std::string::npos) continue;
      ++knees;
      EXPECT_TRUE(l.limited);
      // MMD's x range [-180, -0.5] degrees, mirrored into our axes: [0.5, 180].
      EXPECT_NEAR(l.lower[0], 0.5f * kPi / 180, 1e-6f);
      EXPECT_NEAR(l.upper[0], kPi, 1e-6f);
    }
  }
  EXPECT_EQ(knees, 2u);
}

TEST(UkaMorphs, ABoneMorphTurnsHerEarsByItsRotationScaledByItsWeight) {
  // 耳驚き (ears, surprised) is a PMX bone morph (type 2): 8 entries, each turning one ear bone by
  // about 10 degrees about MMD's x (quaternion (-0.0872, 0, 0, 0.9962) in the file for 左耳1_1,
  // which our axes read (0.0872, 0, 0, 0.9962)). At weight w a bone turns by w times that angle.
  const Uka u = LoadUka();
  const int shape = FindShape(u.rig, "耳驚き");
  ASSERT_GE(shape, 0);
  const std::vector<BoneMorph>& morphs = u.rig.shapes[shape].bone_morphs;
  ASSERT_EQ(morphs.size(), 8u);
  EXPECT_EQ(u.rig.nodes[morphs[0].node].name, "左耳1_1");
  EXPECT_NEAR(morphs[0].rotation[0], 0.0872f, 2e-4f);
  EXPECT_NEAR(morphs[0].rotation[3], 0.9962f, 2e-4f);
  const float angle = 2 * std::acos(morphs[0].rotation[3]);
  for (float w : {1.0f, 0.5f}) {
    std::vector<float> weights;
    Pose pose;
    bool posed = false;
    std::vector<Warning> warnings;
    const WeightEntry entry{.name = "耳驚き", .value = w};
    ASSERT_TRUE(ResolvePoseAndWeights(u.rig, std::span(&entry, 1), PoseRequest{}, weights, pose,
                                      posed, warnings)
                    .ok());
    ASSERT_TRUE(posed) << "weights alone move bones when a bone morph has a weight";
    const auto& q = pose.local[morphs[0].node].rotation;
    EXPECT_NEAR(2 * std::acos(std::min(1.0f, q[3])), w * angle, 1e-4f) << "w=" << w;
    EXPECT_NEAR(q[1], 0.0f, 1e-6f);
    // Her left ear's vertices move; her face does not (the shape has no vertex offsets of its own).
    const std::vector<float> rest =
        test::WorldOf(u.rig, std::vector<float>(u.rig.shapes.size(), 0.0f), nullptr);
    const std::vector<float> moved = test::WorldOf(u.rig, weights, &pose);
    float most = 0.0f;
    for (size_t i = 0; i < rest.size(); ++i) most = std::max(most, std::abs(rest[i] - moved[i]));
    EXPECT_GT(most, 0.005f * w) << "the ears move";
  }
}

TEST(UkaConstraints, ThePmdsRotationFollowingEyesAreTheGrantsHerPmxGives) {
  // PMD bones 34 左目 and 36 右目 are type 9 (回転連動): tail 32 (両目), IK field 7, a ratio of
  // 7/100.
  const Result<Rig> pmd =
      formats::LoadRigFile(test::SharedAssets() + "/more/MMD/Uka_PMD/MS_Uka.pmd");
  const Uka u = LoadUka();
  ASSERT_TRUE(pmd.ok());
  ASSERT_EQ(pmd->constraints.grants.size(), 2u);
  ASSERT_EQ(u.rig.constraints.grants.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const Grant &d = pmd->constraints.grants[i], &x = u.rig.constraints.grants[i];
    EXPECT_EQ(pmd->nodes[d.node].name, u.rig.nodes[x.node].name);
    EXPECT_EQ(pmd->nodes[d.source].name, "両目");
    EXPECT_EQ(u.rig.nodes[x.source].name, "両目");
    EXPECT_FLOAT_EQ(d.ratio, 0.07f);
    EXPECT_FLOAT_EQ(x.ratio, d.ratio);
    EXPECT_TRUE(d.rotation && !d.translation && !d.local);
  }
  for (const Warning& w : pmd->load_warnings)
    EXPECT_NE(w.code, "bone_constraints_skipped") << w.message;
}

TEST(UkaConstraints, StandingHerSleevesFollowHerArms) {
  const Uka u = LoadUka();
  ASSERT_GE(u.stand, 0);
  PoseRequest request;
  ClipRequest clip;
  clip.index = u.stand;
  clip.time = 1.0f;
  request.clips.push_back(clip);
  // Hands in front, sleeves around the arms: the mesh is narrow (T-pose 0.70, stand.vmd without IK
  // 0.55).
  EXPECT_LE(Aspect(u.rig, Posed(u.rig, request)), 0.5f);
  Rig unconstrained = u.rig;
  unconstrained.constraints = {};
  EXPECT_GT(Aspect(unconstrained, Posed(unconstrained, request)), 0.52f);
  EXPECT_GT(Aspect(u.rig, RestPose(u.rig)), 0.65f);
}

TEST(UkaConstraints, AMotionAloneStandsOnTheManifestsBaseMotion) {
  Uka u = LoadUka();
  ASSERT_GE(u.stand, 0);
  u.rig.base_motion = "stand";
  PoseRequest request;
  ClipRequest happy;
  happy.name = "01_happy";
  happy.time = 5.0f;
  happy.over_base = true;
  request.clips.push_back(happy);
  std::vector<float> w;
  EXPECT_LE(Aspect(u.rig, Posed(u.rig, request, &w)), 0.5f);  // Standing, not in the bind T-pose.
  ASSERT_EQ(w.size(), u.rig.shapes.size());
  EXPECT_FLOAT_EQ(w[FindShape(u.rig, "笑い")],
                  1.0f);               // And smiling: 笑い is 1 from frame 15 to 285.
  request.clips[0].over_base = false;  // Alone: the T-pose.
  EXPECT_GT(Aspect(u.rig, Posed(u.rig, request)), 0.65f);
}

}  // namespace constraints_test
}  // namespace facespace
