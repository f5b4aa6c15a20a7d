// Landmarks to weights (core/derive/capture.h): a performer who is not the rig, ICT-FaceKit's head
// with its own authored shapes (another artist's), tracked as MediaPipe would see it (its
// landmarks' places on ICT, posed, turned and put in an image's pixels), drives FaceCap; and ICT
// itself. Hostile frames are named.
#include "facespace/derive/capture.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>

#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace::derive {
namespace {

std::string Ict(const std::string& f) {
  return test::SharedAssets() + "/more/OBJ/ICT-FaceKit_subset/" + f;
}

const Rig& Canonical() {
  static const Rig rig =
      formats::LoadRigFile(test::Bundled("trackers/mediapipe/canonical_face_model.obj")).value();
  return rig;
}

struct Performer {
  Rig rig;
  LandmarkRig map;
};

const Performer& IctPerformer() {
  static const Performer p = [] {
    Performer out;
    out.rig = formats::LoadObjSequence(
                  std::vector<std::string>{Ict("generic_neutral_mesh.obj"), Ict("jawOpen.obj"),
                                           Ict("eyeBlink_L.obj"), Ict("mouthSmile_L.obj")})
                  .value();
    auto map = MapLandmarks(out.rig, Canonical(), {});
    EXPECT_TRUE(map.ok()) << map.status().message;
    out.map = std::move(map.value());
    return out;
  }();
  return p;
}

// The performer's landmarks at `weights` (ICT's shapes by index in map.shapes' order), the head
// turned `yaw` degrees, as pixels of a 640x480 image (x right, y down, z smaller nearer).
std::vector<float> Track(const LandmarkRig& m, std::vector<float> weights, double yaw) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(yaw * M_PI / 180, Eigen::Vector3d::UnitY()).matrix();
  const double scale = 300 / m.diag;
  std::vector<float> out(3 * kMediaPipeFace, 0.0f);
  const size_t n = kMediaPipeFace;
  for (size_t i = 0; i < n; ++i) {
    Eigen::Vector3d p(m.rest[3 * i], m.rest[3 * i + 1], m.rest[3 * i + 2]);
    for (size_t k = 0; k < weights.size(); ++k)
      p += weights[k] * Eigen::Map<const Eigen::Vector3d>(&m.moves[(k * n + i) * 3]);
    const Eigen::Vector3d q = scale * (r * p);
    out[3 * i] = static_cast<float>(320 + q.x());
    out[3 * i + 1] = static_cast<float>(240 - q.y());
    out[3 * i + 2] = static_cast<float>(-q.z());
  }
  return out;
}

size_t IndexOf(const LandmarkRig& m, const Rig& rig, const char* name) {
  for (size_t k = 0; k < m.shapes.size(); ++k)
    if (rig.shapes[m.shapes[k]].name == name) return k;
  ADD_FAILURE() << name;
  return 0;
}

// Twenty frames each (2/3 s at 30 a second): rest, jaw open, left blink, left smile, rest with the
// head turned 20 degrees.
std::vector<std::vector<float>> Performance(const Performer& p) {
  const LandmarkRig& m = p.map;
  std::vector<std::vector<float>> frames;
  auto hold = [&](const char* shape, double yaw) {
    std::vector<float> w(m.shapes.size(), 0.0f);
    if (shape) w[IndexOf(m, p.rig, shape)] = 1.0f;
    for (int i = 0; i < 20; ++i) frames.push_back(Track(m, w, yaw));
  };
  hold(nullptr, 0);
  hold("jawOpen", 0);
  hold("eyeBlink_L", 0);
  hold("mouthSmile_L", 0);
  hold(nullptr, 20);
  return frames;
}

float W(const Rig& rig, const Captured& c, size_t frame, const char* name) {
  const int s = FindShape(rig, name);
  EXPECT_GE(s, 0) << name;
  return c.weights[frame][s];
}

TEST(Capture, IctsFaceDrivesFaceCap) {
  const Rig facecap = formats::LoadRigFile(test::Bundled("facecap/facecap.glb")).value();
  auto map = MapLandmarks(facecap, Canonical(), {});
  ASSERT_TRUE(map.ok()) << map.status().message;
  EXPECT_GE(map->shapes.size(), 50u);  // tongueOut moves no landmark.
  const auto frames = Performance(IctPerformer());
  auto solved = SolveFrames(map.value(), frames, {});
  ASSERT_TRUE(solved.ok()) << solved.status().message;
  const Captured* c = &solved.value();
  std::printf("%zu landmarks placed; solve %.3f ms a frame\n",
              size_t(std::count(map->found.begin(), map->found.end(), 1)),
              1e3 * c->solve_seconds / double(frames.size()));
  for (size_t f : {19, 39, 59, 79, 99})
    std::printf(
        "frame %2zu: jawOpen %.2f eyeBlink_L %.2f eyeBlink_R %.2f mouthSmile_L %.2f "
        "mouthSmile_R %.2f residual %.4f\n",
        f, W(facecap, *c, f, "jawOpen"), W(facecap, *c, f, "eyeBlink_L"),
        W(facecap, *c, f, "eyeBlink_R"), W(facecap, *c, f, "mouthSmile_L"),
        W(facecap, *c, f, "mouthSmile_R"), c->residual[f]);
  EXPECT_LT(W(facecap, *c, 19, "jawOpen"), 0.1);
  EXPECT_GT(W(facecap, *c, 39, "jawOpen"), 0.5);
  EXPECT_GT(W(facecap, *c, 59, "eyeBlink_L"), 0.5);
  EXPECT_LT(W(facecap, *c, 59, "eyeBlink_R"), 0.3);
  EXPECT_GT(W(facecap, *c, 79, "mouthSmile_L"), 0.3);
  EXPECT_GT(W(facecap, *c, 79, "mouthSmile_L"), W(facecap, *c, 79, "mouthSmile_R"));
  // The turned head at rest: no expression, and the turn found (20 degrees about y).
  for (float w : c->weights[99]) EXPECT_LT(w, 0.15f);
  const auto& q = c->head[99];
  EXPECT_NEAR(2 * std::asin(std::abs(q[1])) * 180 / M_PI, 20.0, 1.0);
}

TEST(Capture, IctsFaceDrivesIctItself) {
  const Performer& p = IctPerformer();
  auto solved = SolveFrames(p.map, Performance(p), {});
  ASSERT_TRUE(solved.ok()) << solved.status().message;
  const Captured* c = &solved.value();
  EXPECT_NEAR(W(p.rig, *c, 39, "jawOpen"), 1.0, 0.05);
  EXPECT_NEAR(W(p.rig, *c, 59, "eyeBlink_L"), 1.0, 0.05);
  EXPECT_NEAR(W(p.rig, *c, 79, "mouthSmile_L"), 1.0, 0.05);
  EXPECT_LT(c->residual[39], 2e-3);
}

TEST(Capture, HostileFramesAreNamed) {
  const Performer& p = IctPerformer();
  std::vector<std::vector<float>> frames = {Track(p.map, {}, 0), std::vector<float>(30, 1.0f)};
  auto short_frame = SolveFrames(p.map, frames, {});
  ASSERT_FALSE(short_frame.ok());
  EXPECT_EQ(short_frame.status().fields[0].pointer, "/frames/1");
  frames[1] = Track(p.map, {}, 0);
  frames[1][3 * 7 + 1] = NAN;
  auto nan = SolveFrames(p.map, frames, {});
  ASSERT_FALSE(nan.ok());
  EXPECT_EQ(nan.status().fields[0].pointer, "/frames/1/7");
  CaptureOptions o;
  o.neutral = 5;
  EXPECT_EQ(SolveFrames(p.map, frames, o).status().fields[0].pointer, "/neutral");
  EXPECT_EQ(SolveFrames(p.map, {}, {}).status().fields[0].pointer, "/frames");
}

}  // namespace
}  // namespace facespace::derive
