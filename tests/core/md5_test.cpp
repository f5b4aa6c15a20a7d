// MD5 (Bob, ../shared/assets/more/MD5): counts, and vertices at rest and at animation frames
// computed here from the raw file text with our own small reader and quaternion math, against
// what the importer and the evaluation give. Then hostile files.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "facespace/engine/blend.h"
#include "facespace/engine/skeleton.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace md5_test {  // Named: core_tests is a unity build, its files share one unit.

std::string BobDir() { return test::SharedAssets() + "/more/MD5/Bob/"; }

std::string Text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// ---- an independent reading of the files: tokens without comments, parentheses dropped ----

std::vector<std::string> Tokens(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    line = line.substr(0, line.find("//"));
    for (char& c : line) {
      if (c == '(' || c == ')' || c == '{' || c == '}') c = ' ';
    }
    std::istringstream words(line);
    for (std::string w; words >> w;) out.push_back(w);
  }
  return out;
}

struct Q {  // w, x, y, z
  double w, x, y, z;
};
Q Mul(Q a, Q b) {
  return {
      a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
      a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}
std::array<double, 3> Rotate(Q q, std::array<double, 3> v) {
  const Q p = Mul(Mul(q, {0, v[0], v[1], v[2]}), {q.w, -q.x, -q.y, -q.z});
  return {p.x, p.y, p.z};
}
Q FromXyz(double x, double y, double z) {
  const double t = 1 - x * x - y * y - z * z;
  return {t < 0 ? 0 : -std::sqrt(t), x, y, z};
}

struct RawJoint {
  std::string name;
  int parent;
  std::array<double, 3> pos;
  Q q;
};
struct RawWeight {
  int joint;
  double bias;
  std::array<double, 3> pos;
};
// Moves `i` past the next token `w` of `t` (to the end when there is none).
void SkipPast(const std::vector<std::string>& t, const std::string& w, size_t& i) {
  while (i < t.size() && t[i] != w) ++i;
  ++i;
}

struct RawMesh {
  std::vector<std::pair<int, int>> verts;  // first weight, count
  std::vector<RawWeight> weights;
  size_t tris = 0;
};

void ReadRawMesh(std::vector<RawJoint>& joints, std::vector<RawMesh>& meshes) {
  const std::vector<std::string> t = Tokens(Text(BobDir() + "Bob.md5mesh"));
  size_t i = 0;
  auto find = [&](const std::string& w) { SkipPast(t, w, i); };
  find("numJoints");
  joints.resize(std::stoi(t[i]));
  find("joints");
  for (RawJoint& j : joints) {
    j.name = t[i].substr(1, t[i].size() - 2);
    j.parent = std::stoi(t[i + 1]);
    j.pos = {std::stod(t[i + 2]), std::stod(t[i + 3]), std::stod(t[i + 4])};
    j.q = FromXyz(std::stod(t[i + 5]), std::stod(t[i + 6]), std::stod(t[i + 7]));
    i += 8;
  }
  while (i < t.size()) {
    find("numverts");
    if (i >= t.size()) break;
    RawMesh m;
    m.verts.resize(std::stoi(t[i]));
    for (auto& v : m.verts) {
      find("vert");
      v = {std::stoi(t[i + 3]), std::stoi(t[i + 4])};
    }
    find("numtris");
    m.tris = std::stoul(t[i]);
    find("numweights");
    m.weights.resize(std::stoi(t[i]));
    for (RawWeight& w : m.weights) {
      find("weight");
      w = {std::stoi(t[i + 1]),
           std::stod(t[i + 2]),
           {std::stod(t[i + 3]), std::stod(t[i + 4]), std::stod(t[i + 5])}};
    }
    meshes.push_back(std::move(m));
  }
}

// The object-space joints of the clip's frame `f`: base frame, flagged components replaced, then
// the hierarchy (a child's position and orientation are its parent's space).
std::vector<RawJoint> RawFrame(const std::vector<RawJoint>& bind, int f) {
  const std::vector<std::string> t = Tokens(Text(BobDir() + "Bob.md5anim"));
  size_t i = 0;
  auto find = [&](const std::string& w) { SkipPast(t, w, i); };
  find("hierarchy");
  std::vector<std::array<int, 2>> flags(bind.size());
  for (auto& fl : flags) {
    fl = {std::stoi(t[i + 2]), std::stoi(t[i + 3])};
    i += 4;
  }
  find("baseframe");
  std::vector<std::array<double, 6>> base(bind.size());
  for (auto& b : base) {
    for (double& x : b) x = std::stod(t[i++]);
  }
  for (;;) {
    find("frame");
    if (std::stoi(t[i]) == f) break;
  }
  ++i;
  std::vector<RawJoint> out = bind;
  for (size_t j = 0; j < bind.size(); ++j) {
    std::array<double, 6> v = base[j];
    int at = flags[j][1];
    for (int b = 0; b < 6; ++b) {
      if (flags[j][0] & (1 << b)) v[b] = std::stod(t[i + at++]);
    }
    Q q = FromXyz(v[3], v[4], v[5]);
    std::array<double, 3> p = {v[0], v[1], v[2]};
    if (bind[j].parent >= 0) {
      const RawJoint& parent = out[bind[j].parent];
      const auto r = Rotate(parent.q, p);
      p = {r[0] + parent.pos[0], r[1] + parent.pos[1], r[2] + parent.pos[2]};
      q = Mul(parent.q, q);
    }
    const double n = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
    out[j].pos = p;
    out[j].q = {q.w / n, q.x / n, q.y / n, q.z / n};
  }
  return out;
}

// Vertex v of mesh m under `joints`, turned Z-up to Y-up: (x, y, z) -> (x, z, -y).
std::array<double, 3> RawVertex(const std::vector<RawJoint>& joints, const RawMesh& m, size_t v) {
  std::array<double, 3> p{0, 0, 0};
  double total = 0;
  for (int k = 0; k < m.verts[v].second; ++k) {
    const RawWeight& w = m.weights[m.verts[v].first + k];
    const auto r = Rotate(joints[w.joint].q, w.pos);
    for (int c = 0; c < 3; ++c) p[c] += w.bias * (r[c] + joints[w.joint].pos[c]);
    total += w.bias;
  }
  return {p[0] / total, p[2] / total, -p[1] / total};
}

class Md5 : public ::testing::Test {
 protected:
  void SetUp() override {
    auto loaded = formats::LoadRigFile(BobDir() + "Bob.md5mesh");
    ASSERT_TRUE(loaded.ok()) << loaded.status().message;
    rig_ = std::move(loaded.value());
    ReadRawMesh(joints_, meshes_);
  }
  // Largest distance between our evaluation under `pose` and the raw computation, over every
  // vertex.
  double MaxError(const Pose* pose, const std::vector<RawJoint>& joints, double* extent) {
    BlendedRig blended;
    BlendContext context;
    BlendOptions options;
    options.pose = pose;
    EXPECT_TRUE(EvaluateRig(rig_, {}, options, blended, context).ok());
    double worst = 0, lo = 1e30, hi = -1e30;
    for (size_t m = 0; m < meshes_.size(); ++m) {
      const BlendedPrimitive& b = blended.primitives[m];
      EXPECT_TRUE(b.skinned);
      for (size_t v = 0; v < meshes_[m].verts.size(); ++v) {
        const auto want = RawVertex(joints, meshes_[m], v);
        for (int c = 0; c < 3; ++c) {
          worst = std::max(worst, std::abs(want[c] - b.positions[3 * v + c]));
          lo = std::min(lo, want[c]);
          hi = std::max(hi, want[c]);
        }
      }
    }
    *extent = hi - lo;
    return worst;
  }
  Rig rig_;
  std::vector<RawJoint> joints_;
  std::vector<RawMesh> meshes_;
};

TEST_F(Md5, CountsAsTheFilesSay) {
  EXPECT_EQ(rig_.joint_count, 33u);
  EXPECT_EQ(joints_.size(), 33u);
  ASSERT_EQ(rig_.primitives.size(), 6u);
  ASSERT_EQ(meshes_.size(), 6u);
  for (size_t m = 0; m < 6; ++m) {
    EXPECT_EQ(rig_.primitives[m].vertex_count(), meshes_[m].verts.size());
    EXPECT_EQ(rig_.primitives[m].triangle_count(), meshes_[m].tris);
  }
  EXPECT_EQ(rig_.triangle_count(), 1027u);
  ASSERT_EQ(rig_.animations.size(), 1u);
  EXPECT_EQ(rig_.animations[0].name, "Bob");
  EXPECT_FLOAT_EQ(rig_.animations[0].duration, 139.0f / 24.0f);  // 140 frames at 24 fps.
  EXPECT_EQ(FindNode(rig_, "head"), 1 + 7);
}

TEST_F(Md5, BindPoseVerticesAreTheWeightedJointSpacePositions) {
  double extent = 0;
  const double err = MaxError(nullptr, joints_, &extent);
  EXPECT_GT(extent, 50);  // Bob is about 70 units tall.
  EXPECT_LT(err, 1e-4 * extent) << err;
}

TEST_F(Md5, AnimationFramesPoseTheSkinAsTheFileSays) {
  for (int frame : {0, 30, 97, 139}) {
    Pose pose = RestPose(rig_);
    std::vector<float> w;
    std::vector<uint8_t> set;
    ASSERT_TRUE(
        SampleClip(rig_, 0, static_cast<float>(frame) / 24.0f, ClipWrap::kClamp, pose, w, set)
            .ok());
    double extent = 0;
    const double err = MaxError(&pose, RawFrame(joints_, frame), &extent);
    EXPECT_LT(err, 1e-4 * extent) << "frame " << frame << ": " << err;
  }
}

TEST_F(Md5, BetweenFramesTranslationsInterpolateLinearly) {
  const int head = FindNode(rig_, "head");
  auto at = [&](float t) {
    Pose pose = RestPose(rig_);
    std::vector<float> w;
    std::vector<uint8_t> set;
    EXPECT_TRUE(SampleClip(rig_, 0, t, ClipWrap::kClamp, pose, w, set).ok());
    return pose.local[head];
  };
  const Transform a = at(30.0f / 24), b = at(31.0f / 24), mid = at(30.5f / 24);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(mid.translation[c], 0.5f * (a.translation[c] + b.translation[c]), 1e-4);
}

TEST_F(Md5, TrianglesFaceOutwards) {
  // Counter-clockwise seen from outside: the signed volume the triangles enclose is positive
  // (divergence theorem), for every mesh.
  for (const Primitive& p : rig_.primitives) {
    double volume = 0;
    for (size_t t = 0; t < p.indices.size(); t += 3) {
      const float* a = &p.positions[3 * p.indices[t]];
      const float* b = &p.positions[3 * p.indices[t + 1]];
      const float* c = &p.positions[3 * p.indices[t + 2]];
      volume += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                a[2] * (b[0] * c[1] - b[1] * c[0]);
    }
    EXPECT_GT(volume, 0) << rig_.meshes[p.mesh].name;
  }
}

Status Load(const std::string& mesh, const std::string& anim = "") {
  std::vector<std::pair<std::string, std::string>> anims;
  if (!anim.empty()) anims.emplace_back("a", anim);
  auto r = formats::LoadMd5Memory(mesh, "t.md5mesh", anims);
  if (!r.ok()) return r.status();
  for (const Warning& w : r->load_warnings) {
    if (w.code == "animation_skipped") return InvalidArgument(w.code + ": " + w.message);
  }
  return Status::Ok();
}

TEST(Md5Hostile, ClearErrorsNamingTheLine) {
  const std::string bob = Text(BobDir() + "Bob.md5mesh");
  const std::string head =
      "MD5Version 10\ncommandline \"\"\nnumJoints 1\nnumMeshes 1\njoints {\n\"root\" -1 ( 0 0 0 ) "
      "( 0 0 0 )\n}\n";
  struct Case {
    std::string text, needle;
  };
  const Case cases[] = {
      {bob.substr(0, bob.size() / 2), "t.md5mesh:"},  // Truncated.
      {"MD5Version 11\ncommandline \"\"", "only 10"},
      {head + "mesh {\nshader \"s\"\nnumverts 999999999\n",
       "numverts 999999999 is outside"},  // A lying count.
      {head + "mesh {\nshader \"s\"\nnumverts 2\nvert 0 ( 0 0 ) 0 1\n}",
       "t.md5mesh:12: expected 'vert', got '}'"},
      {head + "mesh {\nshader \"s\"\nnumverts 1\nvert 0 ( 0 0 ) 5 1\nnumtris 0\nnumweights "
              "1\nweight 0 0 1 ( 0 0 0 )\n}",
       "uses weights 5..5 of 1"},
      {head + "mesh {\nshader \"s\"\nnumverts 1\nvert 0 ( 0 0 ) 0 1\nnumtris 1\ntri 0 0 0 7\n",
       "vertex 7 is outside"},
      {head + "mesh {\nshader \"s\"\nnumverts 1\nvert 0 ( 0 0 ) 0 1\nnumtris 0\nnumweights "
              "1\nweight 0 3 1 ( 0 0 0 )\n}",
       "joint 3 is outside"},
      {"MD5Version 10\ncommandline \"\"\nnumJoints 2\nnumMeshes 0\njoints {\n\"a\" 1 ( 0 0 0 ) ( 0 "
       "0 0 )\n",
       "parent"},  // A cycle.
      {head + "mesh {\nshader \"s\"\nnumverts 1\nvert 0 ( 0 nan ) 0 1\n", "not a finite number"},
      {"MD5Version 10\ncommandline \"unterminated", "unterminated string"},
      {head + "mesh {\nshader \"s\"\nnumverts 2\nvert 1 ( 0 0 ) 0 1\n",
       "the vertex index 1 where 0 was due"},  // Out of order.
  };
  for (const Case& c : cases) {
    const Status s = Load(c.text);
    EXPECT_FALSE(s.ok()) << c.needle;
    EXPECT_NE(s.message.find(c.needle), std::string::npos)
        << "want '" << c.needle << "' in: " << s.message;
  }
  // A clip whose joints are not the mesh's is skipped with a warning naming the difference.
  const Status s = Load(bob,
                        "MD5Version 10\ncommandline \"\"\nnumFrames 1\nnumJoints 2\nframeRate "
                        "24\nnumAnimatedComponents 0\n");
  EXPECT_NE(s.message.find("animation_skipped"), std::string::npos) << s.message;
  EXPECT_NE(s.message.find("2 joints, the mesh has 33"), std::string::npos) << s.message;
}

}  // namespace md5_test
}  // namespace facespace
