// Secondary motion. A pendulum checked against its own mechanics; Uka's rigid bodies and joints as
// the PMX and PMD bytes say them; her happy motion with physics: hair and skirt swing, nothing
// flies off, and the same request gives the same bytes.
#include "facespace/physics/physics.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "facespace/evaluator/evaluator.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace {

// A pivot bone at (0, 1, 0) holding, through a joint free to turn, an arm whose body (a sphere of
// radius 5 cm, 1 kg) sits 0.5 m along +x; a tip bone 1 m along the arm. Released horizontal.
Rig Pendulum() {
  Rig rig;
  rig.nodes.resize(4);
  rig.nodes[0] = {.name = "root", .children = {1}};
  rig.nodes[1] = {.name = "pivot", .parent = 0, .children = {2}, .translation = {0, 1, 0}};
  rig.nodes[2] = {.name = "arm", .parent = 1, .children = {3}};
  rig.nodes[3] = {.name = "tip", .parent = 2, .translation = {1, 0, 0}};
  rig.scene_roots = {0};
  RigidBody pivot{.name = "pivot", .node = 1, .size = {0.05f, 0, 0}, .position = {0, 1, 0}};
  RigidBody arm{.name = "arm",
                .node = 2,
                .size = {0.05f, 0, 0},
                .position = {0.5f, 1, 0},
                .mass = 1.0f,
                .mode = RigidBody::Mode::kPhysics};
  pivot.collides_with = arm.collides_with = 0;  // Only the ground.
  PhysicsJoint hinge{.name = "hinge",
                     .a = 0,
                     .b = 1,
                     .position = {0, 1, 0},
                     .angular_lower = {1, 1, 1},
                     .angular_upper = {-1, -1, -1}};  // lower > upper: free.
  rig.physics.bodies = {pivot, arm};
  rig.physics.joints = {hinge};
  return rig;
}

std::array<float, 3> At(const Rig& rig, const Pose& pose, int node) {
  const auto world = WorldMatrices(rig, pose);
  return {world[node][12], world[node][13], world[node][14]};
}

TEST(Physics, APendulumReleasedHorizontalSwingsDownInAQuarterOfItsPeriod) {
  const Rig rig = Pendulum();
  const Pose rest = RestPose(rig);
  auto sim = physics::Simulation::Create(rig, rest);
  ASSERT_NE(sim, nullptr);
  // A rigid pendulum from 90 degrees: T/4 = K(sin 45 deg) sqrt(I / (m g L)), with I = m L^2 + 2/5 m
  // r^2 about the pivot (a sphere of radius r at L = 0.5 m): K(1/sqrt 2) = 1.854075, so 0.4196 s.
  const double L = 0.5, r = 0.05, g = 9.8;
  const double quarter = 1.854075 * std::sqrt((L * L + 0.4 * r * r) / (g * L));
  float lowest_y = 2.0f, lowest_t = 0.0f;
  for (int step = 1; step <= 48; ++step) {  // 0.8 s at 60 a second.
    sim->Step(rest, 1.0f / 60.0f);
    Pose pose = rest;
    sim->Apply(pose);
    const auto tip = At(rig, pose, 3);
    const auto pivot = At(rig, pose, 1);
    const float length = std::hypot(tip[0] - pivot[0], tip[1] - pivot[1], tip[2] - pivot[2]);
    // Bullet's joints are soft (an error corrected a fraction a step): at the bottom, swinging at
    // 3 m/s, the body pulls away from the pivot by a few centimetres, as in every MMD player.
    EXPECT_NEAR(length, 1.0f, 0.05f) << "the arm keeps its length at step " << step;
    EXPECT_NEAR(tip[2], 0.0f, 1e-3f) << "it swings in its plane";
    if (tip[1] < lowest_y) lowest_y = tip[1], lowest_t = static_cast<float>(step) / 60.0f;
  }
  EXPECT_NEAR(lowest_y, 0.0f, 0.02f) << "at the bottom the arm hangs straight down";
  EXPECT_NEAR(lowest_t, quarter, 0.035) << "the bottom is reached a quarter period after release";
}

TEST(Physics, TheSameStepsGiveTheSameBonesAndTheFirstPoseIsAsGiven) {
  const Rig rig = Pendulum();
  const Pose rest = RestPose(rig);
  Pose a = rest, b = rest, untouched = rest;
  auto one = physics::Simulation::Create(rig, rest);
  auto two = physics::Simulation::Create(rig, rest);
  one->Apply(untouched);
  EXPECT_NEAR(At(rig, untouched, 3)[0], 1.0f, 1e-5f)
      << "before any step the bones are where the pose put them";
  EXPECT_NEAR(At(rig, untouched, 3)[1], 1.0f, 1e-5f);
  for (int i = 0; i < 30; ++i) one->Step(rest, 1.0f / 60.0f), two->Step(rest, 1.0f / 60.0f);
  one->Apply(a);
  two->Apply(b);
  EXPECT_EQ(std::memcmp(a.local[2].rotation.data(), b.local[2].rotation.data(), sizeof(float) * 4),
            0);
}

TEST(Physics, ARigWithNothingSimulatedOnABoneHasNoSimulation) {
  Rig rig = Pendulum();
  rig.physics.bodies[1].mode = RigidBody::Mode::kFollowBone;
  EXPECT_EQ(physics::Simulation::Create(rig, RestPose(rig)), nullptr);
}

// ---- Uka ----

size_t Simulated(const Rig& rig) {
  return static_cast<size_t>(
      std::count_if(rig.physics.bodies.begin(), rig.physics.bodies.end(),
                    [](const RigidBody& b) { return b.mode != RigidBody::Mode::kFollowBone; }));
}

TEST(UkaPhysics, HerBodiesAndJointsAreReadAsTheFilesSay) {
  // PMX: 164 rigid bodies (137 simulated: hair, ears, skirt), 151 joints. The PMD the same model.
  const Result<Rig> pmx = formats::LoadRigFile(test::SharedAssets() + "/more/MMD/Uka/MS_Uka.pmx");
  ASSERT_TRUE(pmx.ok()) << pmx.status().message;
  EXPECT_EQ(pmx->physics.bodies.size(), 164u);
  EXPECT_EQ(Simulated(pmx.value()), 137u);
  EXPECT_EQ(pmx->physics.joints.size(), 151u);
  EXPECT_FLOAT_EQ(pmx->physics.units_per_metre, 12.5f);
  const Result<Rig> pmd =
      formats::LoadRigFile(test::SharedAssets() + "/more/MMD/Uka_PMD/MS_Uka.pmd");
  ASSERT_TRUE(pmd.ok()) << pmd.status().message;
  EXPECT_EQ(pmd->physics.bodies.size(), pmx->physics.bodies.size());
  EXPECT_EQ(pmd->physics.joints.size(), pmx->physics.joints.size());
  // Each body where its file puts it: the PMX's absolute, the PMD's from its bone.
  for (size_t i = 0; i < pmx->physics.bodies.size(); ++i) {
    const RigidBody &x = pmx->physics.bodies[i], &d = pmd->physics.bodies[i];
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(x.position[a], d.position[a], 1e-3f) << x.name << " axis " << a;
  }
}

struct Played {
  std::vector<std::vector<float>> frames;  // World positions at each time.
};

Played PlayHappy(const std::shared_ptr<const evaluator::StoredRig>& stored, bool physics,
                 const std::vector<float>& times) {
  const Rig& rig = stored->rig;
  ClipRequest named{.name = "01_happy"};
  auto seq = SequenceOfClip(rig, FindClip(rig, named));
  EXPECT_TRUE(seq.ok());
  seq->physics = physics;
  const evaluator::Evaluator evaluator;
  evaluator::Workspace ws;
  evaluator::SequencePhysics simulation(rig, seq.value());
  EXPECT_EQ(simulation.active(), physics);
  Played run;
  evaluator::ResolvedPoint point;
  for (float t : times) {
    evaluator::SequencePoint(rig, seq.value(), t, BlendMode::kRelative, point, &simulation);
    auto bytes =
        evaluator.Run(stored, point, evaluator::OutputSpec::Frame(BlendOptions{}, true), ws);
    EXPECT_TRUE(bytes.ok());
    std::vector<float> xyz((bytes->bytes.size() - 4) / 4);
    std::memcpy(xyz.data(), bytes->bytes.data() + 4, xyz.size() * 4);
    run.frames.push_back(std::move(xyz));
  }
  return run;
}

TEST(UkaPhysics, HappyForFiveSecondsSwingsHairAndSkirtAndNothingFliesOff) {
  Result<Rig> rig = formats::LoadRigFile(test::Bundled("uka/MS_Uka.pmx"));
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  const auto stored = evaluator::Unstored(std::move(rig.value()));
  const std::vector<float> times = {0.0f, 1.0f, 2.5f, 5.0f};
  const Played with = PlayHappy(stored, true, times), without = PlayHappy(stored, false, times),
               again = PlayHappy(stored, true, times);
  // The rest pose's bounding box, grown 1.5 times about its centre.
  std::vector<float> rest = without.frames[0];
  std::array<float, 3> lo{1e9f, 1e9f, 1e9f}, hi{-1e9f, -1e9f, -1e9f};
  for (size_t v = 0; v < rest.size(); v += 3) {
    for (int a = 0; a < 3; ++a)
      lo[a] = std::min(lo[a], rest[v + a]), hi[a] = std::max(hi[a], rest[v + a]);
  }
  for (size_t f = 0; f < times.size(); ++f) {
    ASSERT_EQ(with.frames[f].size(), without.frames[f].size());
    size_t moved = 0, outside = 0;
    float most = 0.0f;
    for (size_t v = 0; v < with.frames[f].size(); v += 3) {
      float d = 0.0f;
      for (int a = 0; a < 3; ++a) {
        const float c = (lo[a] + hi[a]) / 2, h = 0.75f * (hi[a] - lo[a]);
        outside += std::abs(with.frames[f][v + a] - c) > h;
        d = std::max(d, std::abs(with.frames[f][v + a] - without.frames[f][v + a]));
      }
      moved += d > 0.005f;
      most = std::max(most, d);
    }
    EXPECT_EQ(outside, 0u) << "t=" << times[f] << ": vertices outside 1.5x the rest box";
    if (f == 0) {
      EXPECT_EQ(most, 0.0f) << "the first frame is the pose as it is";
    } else {
      EXPECT_GT(moved, 300u) << "t=" << times[f] << ": hair and skirt move (largest " << most
                             << " m)";
      EXPECT_LT(most, 0.5f) << "t=" << times[f];
    }
    EXPECT_EQ(std::memcmp(with.frames[f].data(), again.frames[f].data(), with.frames[f].size() * 4),
              0)
        << "t=" << times[f] << ": two runs, the same bytes";
  }
}

TEST(UkaPhysics, SampledTimesInAnyOrderGiveTheStreamsFrames) {
  Result<Rig> rig = formats::LoadRigFile(test::Bundled("uka/MS_Uka.pmx"));
  ASSERT_TRUE(rig.ok());
  const auto stored = evaluator::Unstored(std::move(rig.value()));
  const Played forward = PlayHappy(stored, true, {0.5f, 1.0f}),
               backward = PlayHappy(stored, true, {1.0f, 0.5f});
  EXPECT_EQ(std::memcmp(forward.frames[0].data(), backward.frames[1].data(),
                        forward.frames[0].size() * 4),
            0);
  EXPECT_EQ(std::memcmp(forward.frames[1].data(), backward.frames[0].data(),
                        forward.frames[1].size() * 4),
            0);
}

}  // namespace
}  // namespace facespace
