// FBX (../shared/assets/more/FBX): the files' animations at the frames their authors exported as
// OBJ (Maya and Blender evaluated them, not us), ASCII and binary versions of a file giving the
// same rig, curve values from ufbx's own test expectations, raw shape deltas read from the file
// text, then hostile files built here byte by byte.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "facespace/engine/animation.h"
#include "facespace/engine/blend.h"
#include "facespace/formats/io.h"
#include "test_util.h"
#include "world.h"

namespace facespace {
namespace fbx_test {  // Named: core_tests is a unity build, its files share one unit.

std::string Fbx(const std::string& rel) { return test::SharedAssets() + "/more/FBX/" + rel; }

using Points = std::vector<std::array<double, 3>>;

// OBJ `v` lines by object: a `g` line names the vertices listed since the last one (Maya writes
// the vertices of a group before its `g`), Blender's single `g` names all.
std::map<std::string, Points> ObjVertices(const std::string& path) {
  std::map<std::string, Points> out;
  std::ifstream f(path);
  Points pending;
  std::string last = "?";
  for (std::string line; std::getline(f, line);) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "v") {
      std::array<double, 3> p;
      s >> p[0] >> p[1] >> p[2];
      pending.push_back(p);
    } else if (tag == "g") {
      std::string name;
      while (s >> name) last = name;  // "g ArrowZ ArrowY": the last name is the group's own.
      if (pending.empty()) continue;  // "g default" before any vertex.
      out[last].insert(out[last].end(), pending.begin(), pending.end());
      pending.clear();
    }
  }
  if (!pending.empty()) out[last].insert(out[last].end(), pending.begin(), pending.end());
  return out;
}

double Diagonal(const std::map<std::string, Points>& objects) {
  std::array<double, 3> lo{1e30, 1e30, 1e30}, hi{-1e30, -1e30, -1e30};
  for (const auto& [name, points] : objects) {
    for (const auto& p : points) {
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::min(lo[c], p[c]);
        hi[c] = std::max(hi[c], p[c]);
      }
    }
  }
  return std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                   (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

// Largest distance from a point of `a` to the nearest of `b`, both ways (our vertices are split
// per face corner, the OBJ's are not: as point sets they must coincide).
double Hausdorff(const Points& a, const Points& b) {
  auto one_way = [](const Points& x, const Points& y) {
    double worst = 0;
    for (const auto& p : x) {
      double best = 1e30;
      for (const auto& q : y)
        best = std::min(best, std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]));
      worst = std::max(worst, best);
    }
    return worst;
  };
  return std::max(one_way(a, b), one_way(b, a));
}

// World-space vertices of each mesh of the rig, with clip 0 sampled at `time` (none: rest).
std::map<std::string, Points> Evaluate(const Rig& rig, double time,
                                       const std::vector<float>* weights = nullptr) {
  Pose pose = RestPose(rig);
  std::vector<float> w(rig.shapes.size(), 0.0f);
  for (size_t s = 0; s < rig.shapes.size(); ++s)
    w[s] = rig.shapes[s].driven ? 0.0f : rig.shapes[s].default_weight;
  if (weights) w = *weights;
  if (time >= 0) {
    std::vector<uint8_t> set;
    std::vector<float> sampled;
    EXPECT_TRUE(
        SampleClip(rig, 0, static_cast<float>(time), ClipWrap::kClamp, pose, sampled, set).ok());
    for (size_t s = 0; s < set.size() && s < w.size(); ++s) {
      if (set[s]) w[s] = sampled[s];
    }
  }
  const std::vector<float> world = test::WorldOf(rig, w, &pose);
  std::map<std::string, Points> out;
  size_t at = 0;
  for (const Primitive& p : rig.primitives) {
    Points& points = out[rig.meshes[p.mesh].name];
    for (size_t v = 0; v < p.vertex_count(); ++v, at += 3)
      points.push_back({world[at], world[at + 1], world[at + 2]});
  }
  return out;
}

Rig Load(const std::string& path) {
  Result<Rig> rig = formats::LoadRigFile(path);
  EXPECT_TRUE(rig.ok()) << path << ": " << rig.status().message;
  return rig.ok() ? std::move(rig.value()) : Rig{};
}

// ---- the OBJ frames ----

TEST(Fbx, MayaInBetweensMatchMayasFramesEverywhereOnTheCurve) {
  for (const char* file : {"ufbx_maya_blend_inbetween/maya_blend_inbetween_7500_ascii.fbx",
                           "ufbx_maya_blend_inbetween/maya_blend_inbetween_7500_binary.fbx"}) {
    const Rig rig = Load(Fbx(file));
    ASSERT_EQ(rig.inbetweens.size(), 2u);
    for (int frame : {1, 30, 60, 65, 71, 80, 89, 120}) {
      const auto want =
          ObjVertices(test::SharedAssets() +
                      "/more/OBJ/ufbx_maya_blend_inbetween_frames/maya_blend_inbetween_" +
                      std::to_string(frame) + ".obj");
      const auto got = Evaluate(rig, frame / 24.0);
      ASSERT_EQ(want.size(), 1u);
      const double err = Hausdorff(got.at("pCube1"), want.begin()->second);
      EXPECT_LT(err, 1e-4 * Diagonal(want)) << file << " frame " << frame << ": " << err;
    }
  }
}

TEST(Fbx, BlenderShapeKeysWithVertexGroupWeightsMatchBlendersFrames) {
  const Rig rig =
      Load(Fbx("ufbx_blender440_shape_weight_anim/blender440_shape_weight_anim_7400_binary.fbx"));
  ASSERT_EQ(rig.shapes.size(), 2u);
  EXPECT_TRUE(rig.inbetweens
                  .empty());  // Blender's FullWeights here are per-vertex weights, not in-betweens.
  for (int frame : {5, 15, 25}) {
    const auto want =
        ObjVertices(Fbx("ufbx_blender440_shape_weight_anim/blender440_shape_weight_anim_" +
                        std::to_string(frame) + ".obj"));
    const auto got = Evaluate(rig, frame / 24.0);
    const double err = Hausdorff(got.at("Cube"), want.at("Cube"));
    EXPECT_LT(err, 1e-4 * Diagonal(want)) << "frame " << frame << ": " << err;
  }
}

TEST(Fbx, MayaNodeAnimationPreRotationBlendShapeAndSkinMatchMayasFrames) {
  const Rig rig = Load(Fbx("ufbx_maya_axes_anim/maya_axes_anim_7700_ascii.fbx"));
  ASSERT_EQ(rig.skins.size(), 1u);
  EXPECT_EQ(rig.skins[0].joints.size(), 4u);
  // Y is driven by a Maya point cache the FBX does not carry: reported, and left out here.
  bool cache_reported = false;
  for (const Warning& w : rig.load_warnings)
    cache_reported |= w.code == "deformer_skipped" && w.shape == "Y";
  EXPECT_TRUE(cache_reported);
  for (int frame : {0, 5, 8}) {
    const auto want =
        ObjVertices(Fbx("ufbx_maya_axes_anim/maya_axes_anim_" + std::to_string(frame) + ".obj"));
    const auto got = Evaluate(rig, frame / 24.0);
    const double diag = Diagonal(want);
    for (const char* mesh : {"X", "ArrowX", "ArrowY", "ArrowZ"}) {
      const double err = Hausdorff(got.at(mesh), want.at(mesh));
      EXPECT_LT(err, 1e-4 * diag) << mesh << " frame " << frame << ": " << err;
    }
    // The skinned Z: exact at the bind frame; at 5 and 8 within 4e-4 of the scene (see
    // core/README.md).
    const double err = Hausdorff(got.at("Z"), want.at("Z"));
    EXPECT_LT(err, (frame == 0 ? 1e-4 : 4e-4) * diag) << "Z frame " << frame << ": " << err;
  }
}

// ---- ASCII and binary give the same rig ----

void ExpectSameRig(const Rig& a, const Rig& b) {
  ASSERT_EQ(a.primitives.size(), b.primitives.size());
  ASSERT_EQ(a.shapes.size(), b.shapes.size());
  for (size_t s = 0; s < a.shapes.size(); ++s) {
    EXPECT_EQ(a.shapes[s].name, b.shapes[s].name);
    EXPECT_EQ(a.shapes[s].default_weight, b.shapes[s].default_weight);
  }
  for (size_t p = 0; p < a.primitives.size(); ++p) {
    const Primitive &pa = a.primitives[p], &pb = b.primitives[p];
    EXPECT_LT(test::MaxAbsDiff(pa.positions, pb.positions), 1e-6f);
    EXPECT_LT(test::MaxAbsDiff(pa.normals, pb.normals), 1e-6f);
    EXPECT_LT(test::MaxAbsDiff(pa.texcoords, pb.texcoords), 1e-6f);
    EXPECT_EQ(pa.indices, pb.indices);
    ASSERT_EQ(pa.targets.size(), pb.targets.size());
    for (size_t t = 0; t < pa.targets.size(); ++t) {
      EXPECT_EQ(pa.targets[t].indices, pb.targets[t].indices);
      EXPECT_LT(test::MaxAbsDiff(pa.targets[t].position_deltas, pb.targets[t].position_deltas),
                1e-6f);
    }
  }
  ASSERT_EQ(a.animations.size(), b.animations.size());
  for (size_t c = 0; c < a.animations.size(); ++c) {
    ASSERT_EQ(a.animations[c].sampler_data.size(), b.animations[c].sampler_data.size());
    for (size_t s = 0; s < a.animations[c].sampler_data.size(); ++s) {
      EXPECT_LT(test::MaxAbsDiff(a.animations[c].sampler_data[s].values,
                                 b.animations[c].sampler_data[s].values),
                1e-5f);
    }
  }
}

TEST(Fbx, AsciiAndBinaryVersionsGiveTheSameRig) {
  ExpectSameRig(Load(Fbx("ufbx_maya_blend_inbetween/maya_blend_inbetween_7500_ascii.fbx")),
                Load(Fbx("ufbx_maya_blend_inbetween/maya_blend_inbetween_7500_binary.fbx")));
  ExpectSameRig(Load(Fbx("ufbx_maya_blend_shape_cube/maya_blend_shape_cube_7700_ascii.fbx")),
                Load(Fbx("ufbx_maya_blend_shape_cube/maya_blend_shape_cube_7700_binary.fbx")));
}

// ---- weights, shapes and in-betweens as the files say ----

TEST(Fbx, DeformPercentCurvesGiveUfbxsExpectedWeights) {
  // ufbx's test of this file expects these weights (its curve evaluation, not ours).
  const Rig rig = Load(Fbx("ufbx_maya_blend_shape_cube/maya_blend_shape_cube_7700_binary.fbx"));
  ASSERT_EQ(rig.shapes.size(), 2u);
  EXPECT_EQ(rig.shapes[0].name, "TopH");
  EXPECT_EQ(rig.shapes[0].aliases, std::vector<std::string>{"Squish.TopH"});
  const struct {
    double time, top_h, top_v;
  } keys[] = {
      {1.0 / 24, 1, 1}, {16.0 / 24, 0.279, 0.670}, {53.0 / 24, 0.901, 0.168}, {120.0 / 24, 1, 1}};
  for (const auto& k : keys) {
    Pose pose = RestPose(rig);
    std::vector<float> w;
    std::vector<uint8_t> set;
    ASSERT_TRUE(
        SampleClip(rig, 0, static_cast<float>(k.time), ClipWrap::kClamp, pose, w, set).ok());
    EXPECT_NEAR(w[0], k.top_h, 1e-3) << k.time;
    EXPECT_NEAR(w[1], k.top_v, 1e-3) << k.time;
  }
}

TEST(Fbx, ShapesWithoutNormalsMoveTheControlPointsTheFileNames) {
  // From the file text: TopH moves control points 2, 3, 4, 5 by +-0.3169564 in x; the cube's
  // control points are its +-0.5 corners (3 and 5 at 0.49999997 and 0.50000006).
  const Rig rig = Load(Fbx("ufbx_maya_blend_shape_cube/maya_blend_shape_cube_7700_ascii.fbx"));
  const double raw[8][3] = {{-0.5, -0.5, 0.5},  {0.5, -0.5, 0.5},
                            {-0.5, 0.5, 0.5},   {0.499999970197678, 0.5, 0.5},
                            {-0.5, 0.5, -0.5},  {0.500000059604645, 0.5, -0.5},
                            {-0.5, -0.5, -0.5}, {0.5, -0.5, -0.5}};
  const double dx[8] = {
      0, 0, 0.316956400871277, -0.316956371068954, 0.316956400871277, -0.316956400871277, 0, 0};
  Points want;
  for (int k = 0; k < 8; ++k) want.push_back({raw[k][0] + dx[k], raw[k][1], raw[k][2]});
  std::vector<float> w = {1.0f, 0.0f};
  const auto got = Evaluate(rig, -1, &w);
  EXPECT_LT(Hausdorff(got.at("pCube1"), want), 1e-6);
  // No normals in the shapes: the blend recomputes them (the top face tilts; unit length).
  EXPECT_TRUE(rig.primitives[0].targets[0].normal_deltas.empty());
}

TEST(Fbx, InBetweensSitAtTheirFullWeightsOnOneSlider) {
  const Rig rig = Load(Fbx("ufbx_maya_blend_inbetween/maya_blend_inbetween_7500_ascii.fbx"));
  // LiftTop: FullWeights 50, 100; MoveToSide: -49.9, -24.9, 100 (file text).
  ASSERT_EQ(rig.inbetweens.size(), 2u);
  const InBetweens& lift = rig.inbetweens[0];
  EXPECT_EQ(rig.shapes[lift.slider].name, "LiftTop");
  EXPECT_FLOAT_EQ(lift.full, 1.0f);
  ASSERT_EQ(lift.keys.size(), 1u);
  EXPECT_FLOAT_EQ(lift.keys[0].first, 0.5f);
  const InBetweens& side = rig.inbetweens[1];
  ASSERT_EQ(side.keys.size(), 2u);
  EXPECT_FLOAT_EQ(side.keys[0].first, -0.499f);
  EXPECT_FLOAT_EQ(side.keys[1].first, -0.249f);
  // At a key's weight the mesh is that key's shape alone; halfway to the next, half of each.
  std::vector<float> given(rig.shapes.size(), 0.0f), eff(rig.shapes.size());
  given[lift.slider] = 0.5f;
  EffectiveWeights(rig, given, eff);
  EXPECT_FLOAT_EQ(eff[lift.keys[0].second], 1.0f);
  EXPECT_FLOAT_EQ(eff[lift.slider], 0.0f);
  given[lift.slider] = 0.75f;
  EffectiveWeights(rig, given, eff);
  EXPECT_FLOAT_EQ(eff[lift.keys[0].second], 0.5f);
  EXPECT_FLOAT_EQ(eff[lift.slider], 0.5f);
  given[lift.slider] = 0.0f;
  given[side.slider] = -0.1245f;  // Halfway between the base (0) and the key at -0.249.
  EffectiveWeights(rig, given, eff);
  EXPECT_NEAR(eff[side.keys[1].second], 0.5f, 1e-6);
  EXPECT_NEAR(eff[side.slider], 0.0f, 1e-6);
  // Below the lowest key the end segment extrapolates.
  given[side.slider] = -0.749f;
  EffectiveWeights(rig, given, eff);
  EXPECT_NEAR(eff[side.keys[0].second], 2.0f, 1e-5);
  EXPECT_NEAR(eff[side.keys[1].second], -1.0f, 1e-5);
}

// ---- hostile files ----

// A binary FBX 7.5 written here: nodes with scalar and array properties.
struct BNode {
  std::string name;
  std::string props;
  uint32_t count = 0;
  std::vector<BNode> kids;

  template <typename T>
  void Raw(char type, T v) {
    props += type;
    props.append(reinterpret_cast<const char*>(&v), sizeof v);
    ++count;
  }
  BNode& L(int64_t v) {
    Raw('L', v);
    return *this;
  }
  BNode& S(const std::string& s) {
    props += 'S';
    const uint32_t n = static_cast<uint32_t>(s.size());
    props.append(reinterpret_cast<const char*>(&n), 4);
    props += s;
    ++count;
    return *this;
  }
  // An array: `declared` elements, `data` as stored (raw or deflated per `encoding`).
  BNode& Array(char type, uint32_t declared, uint32_t encoding, const std::string& data) {
    props += type;
    const uint32_t head[3] = {declared, encoding, static_cast<uint32_t>(data.size())};
    props.append(reinterpret_cast<const char*>(head), 12);
    props += data;
    ++count;
    return *this;
  }
  template <typename T>
  BNode& Values(char type, const std::vector<T>& v, bool compress = false) {
    std::string raw(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
    return compress ? Array(type, static_cast<uint32_t>(v.size()), 1, Deflate(raw))
                    : Array(type, static_cast<uint32_t>(v.size()), 0, raw);
  }
  static std::string Deflate(const std::string& raw) {
    uLongf n = compressBound(raw.size());
    std::string out(n, '\0');
    compress(reinterpret_cast<Bytef*>(out.data()), &n, reinterpret_cast<const Bytef*>(raw.data()),
             raw.size());
    out.resize(n);
    return out;
  }
  BNode& Kid(BNode k) {
    kids.push_back(std::move(k));
    return *this;
  }

  void Write(std::string& out) const {
    const size_t start = out.size();
    out.append(25, '\0');
    out.back() = static_cast<char>(name.size());
    out += name;
    out += props;
    for (const BNode& k : kids) k.Write(out);
    if (!kids.empty()) out.append(25, '\0');
    const uint64_t head[3] = {out.size(), count, props.size()};
    std::memcpy(&out[start], head, 24);
  }
};

BNode N(const std::string& name) { return BNode{name, {}, 0, {}}; }

std::string File(const std::vector<BNode>& roots) {
  std::string out("Kaydara FBX Binary  \0\x1a\0", 23);
  const uint32_t version = 7500;
  out.append(reinterpret_cast<const char*>(&version), 4);
  for (const BNode& n : roots) n.Write(out);
  out.append(25, '\0');
  return out;
}

// A one-quad mesh under one model, with `polygon` as its PolygonVertexIndex.
std::vector<BNode> Quad(const std::vector<int32_t>& polygon, bool compress) {
  BNode geometry = N("Geometry").L(10).S(std::string("quad\0\1Geometry", 14)).S("Mesh");
  geometry.Kid(
      N("Vertices").Values('d', std::vector<double>{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, compress));
  geometry.Kid(N("PolygonVertexIndex").Values('i', polygon, compress));
  BNode model = N("Model").L(20).S(std::string("quad\0\1Model", 11)).S("Mesh");
  BNode objects = N("Objects").Kid(geometry).Kid(model);
  BNode conns = N("Connections").Kid(N("C").S("OO").L(10).L(20)).Kid(N("C").S("OO").L(20).L(0));
  return {objects, conns};
}

Result<Rig> LoadBytes(const std::string& bytes) {
  return formats::LoadFbxMemory(
      std::span<const unsigned char>(reinterpret_cast<const unsigned char*>(bytes.data()),
                                     bytes.size()),
      "t");
}

void ExpectError(const std::string& bytes, const std::string& needle) {
  const Result<Rig> rig = LoadBytes(bytes);
  ASSERT_FALSE(rig.ok()) << needle;
  EXPECT_EQ(rig.status().code, StatusCode::kInvalidArgument);
  EXPECT_NE(rig.status().message.find(needle), std::string::npos) << rig.status().message;
}

TEST(FbxHostile, AWellFormedBinaryQuadLoadsRawAndCompressed) {
  for (bool compress : {false, true}) {
    const Result<Rig> rig = LoadBytes(File(Quad({0, 1, 2, ~3}, compress)));
    ASSERT_TRUE(rig.ok()) << rig.status().message;
    EXPECT_EQ(rig->triangle_count(), 2u);
    EXPECT_EQ(rig->vertex_count(), 4u);
  }
}

TEST(FbxHostile, EveryTruncationIsAnErrorNotACrash) {
  const std::string whole = File(Quad({0, 1, 2, ~3}, true));
  for (size_t n = 0; n + 26 < whole.size();
       ++n) {  // The last 25 bytes are the closing null record.
    const Result<Rig> rig = LoadBytes(whole.substr(0, n));
    EXPECT_FALSE(rig.ok()) << n;
  }
  const std::vector<unsigned char> real =
      test::ReadBytes(Fbx("ufbx_maya_blend_shape_cube/maya_blend_shape_cube_7700_binary.fbx"));
  for (size_t n = 0; n < real.size(); n += 97) {
    (void)formats::LoadFbxMemory(std::span<const unsigned char>(real.data(), n),
                                 "cut");  // Must not crash; may load (a tail cut off).
  }
}

TEST(FbxHostile, LyingArrayLengthsAreRefused) {
  std::vector<BNode> f = Quad({0, 1, 2, ~3}, false);
  // 4 indices declared as 400, raw: the stored byte count does not match.
  f[0].kids[0].kids[1] = N("PolygonVertexIndex").Array('i', 400, 0, std::string(16, '\0'));
  ExpectError(File(f), "array of 400 stored in 16 bytes");
  // An array claiming 2^30 doubles (8 GiB) is refused before any allocation.
  f[0].kids[0].kids[1] = N("PolygonVertexIndex").Array('d', 1u << 30, 1, BNode::Deflate("x"));
  ExpectError(File(f), "MiB");
}

TEST(FbxHostile, AZlibBombIsRefused) {
  // 64 MiB of zeros deflate to ~64 KiB; the array says it holds 4 ints.
  const std::string bomb = BNode::Deflate(std::string(64u << 20, '\0'));
  std::vector<BNode> f = Quad({0, 1, 2, ~3}, false);
  f[0].kids[0].kids[1] = N("PolygonVertexIndex").Array('i', 4, 1, bomb);
  ExpectError(File(f), "does not inflate to exactly 4 elements");
}

TEST(FbxHostile, IndicesBeyondArraysNameTheObject) {
  ExpectError(File(Quad({0, 1, 2, ~99}, true)),
              "Geometry 'quad' (Mesh): polygon 0 uses control point 99 of 4");
  ExpectError(File(Quad({0, 1, 2, 3}, true)), "does not end a polygon");
  // A shape whose Indexes reach past the mesh.
  std::vector<BNode> f = Quad({0, 1, 2, ~3}, false);
  f[0].Kid(N("Geometry")
               .L(30)
               .S(std::string("bad\0\1Geometry", 13))
               .S("Shape")
               .Kid(N("Indexes").Values('i', std::vector<int32_t>{7}))
               .Kid(N("Vertices").Values('d', std::vector<double>{1, 0, 0})));
  f[0].Kid(N("Deformer").L(40).S(std::string("bs\0\1Deformer", 12)).S("BlendShape"));
  f[0].Kid(N("Deformer").L(50).S(std::string("ch\0\1SubDeformer", 15)).S("BlendShapeChannel"));
  f[1].Kid(N("C").S("OO").L(40).L(10))
      .Kid(N("C").S("OO").L(50).L(40))
      .Kid(N("C").S("OO").L(30).L(50));
  ExpectError(File(f), "Geometry 'bad' (Shape): Indexes[0] = 7 is beyond the 4 control points");
}

TEST(FbxHostile, NodeRecordsOutsideTheFileAreRefused) {
  std::string bytes = File(Quad({0, 1, 2, ~3}, false));
  const uint64_t far = 1u << 30;
  std::memcpy(&bytes[27], &far, 8);  // The first node's end offset.
  ExpectError(bytes, "outside the file");
}

TEST(FbxHostile, ACycleInTheNodeGraphIsNamed) {
  const std::string text =
      "; FBX 7.4.0 project file\n"
      "Objects:  {\n"
      "  Geometry: 10, \"Geometry::g\", \"Mesh\" {\n"
      "    Vertices: *9 {\n      a: 0,0,0,1,0,0,0,1,0\n    }\n"
      "    PolygonVertexIndex: *3 {\n      a: 0,1,-3\n    }\n"
      "  }\n"
      "  Model: 20, \"Model::A\", \"Mesh\" {\n  }\n"
      "  Model: 30, \"Model::B\", \"Null\" {\n  }\n"
      "}\n"
      "Connections:  {\n  C: \"OO\",10,20\n  C: \"OO\",20,30\n  C: \"OO\",30,20\n}\n";
  ExpectError(text, "cycle through Model 'A'");
  // Without the cycle it loads: the triangle.
  std::string fine = text;
  fine.replace(fine.find("C: \"OO\",30,20"), 13, "C: \"OO\",30,0 ");
  const Result<Rig> rig = LoadBytes(fine);
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  EXPECT_EQ(rig->triangle_count(), 1u);
}

TEST(FbxHostile, DeepNestingAndBadAsciiAreRefused) {
  std::string deep = "; FBX 7.4.0 project file\n";
  for (int k = 0; k < 200; ++k) deep += "A: {\n";
  ExpectError(deep, "nested deeper than 64");
  ExpectError(
      "; FBX 7.4.0 project file\nObjects: {\n  Geometry: 1, \"Geometry::g\", \"Mesh\" {\n    "
      "Vertices: *9 {\n      a: 1,2\n    }\n",
      "2 values, declared 9");
  ExpectError("; FBX 7.4.0 project file\nObjects: {\n", "missing '}'");
}

}  // namespace fbx_test
}  // namespace facespace
