// MikuMikuDance beyond the PMX basics (pmx_test.cpp): PMD expressions against the raw bytes, a
// BDEF2 vertex under a rotated bone against the skinning formula, VMD motions (counts, a Bezier key
// at mid-time against the curve computed here another way, morph keys), hostile PMD and VMD bytes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>

#include "facespace/engine/animation.h"
#include "facespace/engine/blend.h"
#include "facespace/engine/hierarchy.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace mmd_test {  // Named: core_tests is a unity build, its files share one unit.

std::string UkaDir() { return test::SharedAssets() + "/more/MMD/Uka"; }
std::string Pmd() { return test::SharedAssets() + "/more/MMD/Uka_PMD/MS_Uka.pmd"; }

// A little-endian cursor over raw bytes, for the tests' own reading of the files.
struct Raw {
  std::vector<unsigned char> b;
  size_t at = 0;
  template <typename T>
  T Get() {
    T v;
    std::memcpy(&v, &b[at], sizeof v);
    at += sizeof v;
    return v;
  }
};

float Span(const Rig& rig) {
  float lo[3] = {1e9f, 1e9f, 1e9f}, hi[3] = {-1e9f, -1e9f, -1e9f};
  for (const Primitive& p : rig.primitives) {
    for (size_t k = 0; k < p.positions.size(); ++k) {
      lo[k % 3] = std::min(lo[k % 3], p.positions[k]);
      hi[k % 3] = std::max(hi[k % 3], p.positions[k]);
    }
  }
  return std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
}

TEST(Pmd, CountsAndExpressionsAsTheRawBytesSay) {
  Raw r{test::ReadBytes(Pmd())};
  ASSERT_GT(r.b.size(), 1000u);
  ASSERT_EQ(std::memcmp(r.b.data(), "Pmd", 3), 0);
  r.at = 3 + 4 + 20 + 256;
  const uint32_t nverts = r.Get<uint32_t>();
  std::vector<std::array<float, 3>> pos(nverts);
  for (uint32_t v = 0; v < nverts; ++v) {
    for (int c = 0; c < 3; ++c) pos[v][c] = r.Get<float>();
    r.at += 38 - 12;
  }
  r.at += 2 * static_cast<size_t>(r.Get<uint32_t>());   // Faces.
  r.at += 70 * static_cast<size_t>(r.Get<uint32_t>());  // Materials.
  const uint16_t nbones = r.Get<uint16_t>();
  r.at += 39 * static_cast<size_t>(nbones);
  const uint16_t nik = r.Get<uint16_t>();
  for (int k = 0; k < nik; ++k) {
    const uint8_t chain = r.b[r.at + 4];
    r.at += 11 + 2 * static_cast<size_t>(chain);
  }
  const uint16_t nskins = r.Get<uint16_t>();
  EXPECT_EQ(nverts, 49955u);
  EXPECT_EQ(nbones, 302u);
  EXPECT_EQ(nskins, 121u);  // The base and 120 expressions.
  // The base lists model vertices; expression "あ" (Japanese "a") lists (base entry, offset).
  std::vector<uint32_t> base;
  std::map<uint32_t, std::array<double, 3>> a_offsets;
  const std::string a_sjis = "\x82\xa0";  // "あ" in Shift-JIS.
  for (int s = 0; s < nskins; ++s) {
    const std::string name(reinterpret_cast<const char*>(&r.b[r.at]),
                           strnlen(reinterpret_cast<const char*>(&r.b[r.at]), 20));
    r.at += 20;
    const uint32_t n = r.Get<uint32_t>();
    const uint8_t type = r.Get<uint8_t>();
    for (uint32_t k = 0; k < n; ++k) {
      const uint32_t idx = r.Get<uint32_t>();
      float d[3] = {r.Get<float>(), r.Get<float>(), r.Get<float>()};
      if (type == 0)
        base.push_back(idx);
      else if (name == a_sjis) {
        auto& o = a_offsets[base.at(idx)];
        for (int c = 0; c < 3; ++c) o[c] += d[c];
      }
    }
  }
  ASSERT_GT(a_offsets.size(), 20u);

  const Result<Rig> rig = formats::LoadRigFile(Pmd());
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  EXPECT_EQ(rig->vertex_count(), 49955u);
  EXPECT_EQ(rig->shapes.size(), 120u);
  EXPECT_EQ(rig->joint_count, 302u);
  const int a = FindShape(rig.value(), "あ");
  ASSERT_GE(a, 0);
  EXPECT_EQ(rig->shapes[a].group, "mouth");
  // At weight 1 the moved vertices are the listed ones, each by its offset x 0.08 with z negated:
  // compared as the count of moved vertices and the sum of their moves.
  BlendedRig b0, b1;
  ASSERT_NO_FATAL_FAILURE(test::RestAndShape(rig.value(), a, b0, b1));
  size_t moved = 0;
  double got[3] = {0, 0, 0};
  for (size_t p = 0; p < b0.primitives.size(); ++p) {
    for (size_t k = 0; k < b0.primitives[p].positions.size(); k += 3) {
      double d[3];
      for (int c = 0; c < 3; ++c)
        d[c] = b1.primitives[p].positions[k + c] - b0.primitives[p].positions[k + c];
      if (d[0] == 0 && d[1] == 0 && d[2] == 0) continue;
      ++moved;
      for (int c = 0; c < 3; ++c) got[c] += d[c];
    }
  }
  size_t want_moved = 0;
  double want[3] = {0, 0, 0};
  for (const auto& [v, o] : a_offsets) {
    if (o[0] == 0 && o[1] == 0 && o[2] == 0) continue;
    ++want_moved;
    want[0] += o[0] * 0.08, want[1] += o[1] * 0.08, want[2] -= o[2] * 0.08;
  }
  EXPECT_EQ(moved, want_moved);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-4) << c;
  // The PMX of the same model has the same vertices: the PMD is the same character.
  const Result<Rig> pmx = formats::LoadRigFile(UkaDir() + "/MS_Uka.pmx");
  ASSERT_TRUE(pmx.ok());
  EXPECT_NEAR(Span(rig.value()), Span(pmx.value()), 1e-5f);
}

TEST(Pmx, ABdef2VertexUnderARotatedBoneLandsWhereTheFormulaPutsIt) {
  // The first BDEF2 vertex with a real blend, read from the raw bytes with its two bones; the bone
  // positions from the bone section. Bone b0 turns 40 degrees about Z (glTF axes) at its own
  // origin.
  Raw r{test::ReadBytes(UkaDir() + "/MS_Uka.pmx")};
  r.at = 8;
  const int globals = r.b[r.at++];
  const int extra_uv = r.b[r.at + 1], vsize = r.b[r.at + 2], tsize = r.b[r.at + 3],
            bsize = r.b[r.at + 5];
  ASSERT_EQ(bsize, 2);
  r.at += static_cast<size_t>(globals);
  auto text = [&] { r.at += static_cast<size_t>(r.Get<int32_t>()); };
  for (int k = 0; k < 4; ++k) text();
  const int32_t nverts = r.Get<int32_t>();
  float vpos[3] = {0, 0, 0}, w0 = 0;
  int bone[2] = {-1, -1};
  for (int32_t v = 0; v < nverts; ++v) {
    float p[3] = {r.Get<float>(), r.Get<float>(), r.Get<float>()};
    r.at += 4 * (3 + 2 + 4 * static_cast<size_t>(extra_uv));
    const int kind = r.b[r.at++];
    if (kind == 1 && bone[0] < 0) {
      const int b0 = r.Get<int16_t>(), b1 = r.Get<int16_t>();
      const float w = r.Get<float>();
      if (w > 0.3f && w < 0.7f && b0 != b1) {
        std::copy(p, p + 3, vpos);
        bone[0] = b0, bone[1] = b1, w0 = w;
      }
    } else {
      r.at += kind == 0 ? 2 : kind == 1 ? 8 : kind == 2 ? 24 : kind == 3 ? 44 : 24;
    }
    r.at += 4;
  }
  ASSERT_GE(bone[0], 0);
  r.at += static_cast<size_t>(vsize) * static_cast<size_t>(r.Get<int32_t>());  // Faces.
  const int32_t ntex = r.Get<int32_t>();
  for (int k = 0; k < ntex; ++k) text();
  const int32_t nmats = r.Get<int32_t>();
  for (int k = 0; k < nmats; ++k) {
    text(), text();
    r.at += 4 * 11 + 1 + 4 * 5 + 2 * static_cast<size_t>(tsize) + 1;
    const int shared = r.b[r.at++];
    r.at += shared ? 1 : static_cast<size_t>(tsize);
    text();
    r.at += 4;
  }
  const int32_t nbones = r.Get<int32_t>();
  ASSERT_GT(nbones, std::max(bone[0], bone[1]));
  std::vector<std::array<float, 3>> bpos(static_cast<size_t>(nbones));
  for (int32_t b = 0; b < nbones; ++b) {
    text(), text();
    for (int c = 0; c < 3; ++c) bpos[b][c] = r.Get<float>();
    r.at += 2 + 4;
    const uint16_t flags = r.Get<uint16_t>();
    r.at += (flags & 1) ? 2 : 12;
    if (flags & 0x0300) r.at += 2 + 4;
    if (flags & 0x0400) r.at += 12;
    if (flags & 0x0800) r.at += 24;
    if (flags & 0x2000) r.at += 4;
    if (flags & 0x0020) {
      r.at += 2 + 4 + 4;
      const int32_t links = r.Get<int32_t>();
      for (int l = 0; l < links; ++l) {
        r.at += 2;
        if (r.b[r.at++]) r.at += 24;
      }
    }
  }

  const Result<Rig> rig = formats::LoadRigFile(UkaDir() + "/MS_Uka.pmx");
  ASSERT_TRUE(rig.ok());
  // The skin's joint k is bone k: its node. The bone turned is b0, or b1 when b1 hangs under b0, so
  // that the other bone stays where it was (one is never under the other both ways).
  const int n0 = rig->skins[0].joints[bone[0]], n1 = rig->skins[0].joints[bone[1]];
  bool b1_under_b0 = false;
  for (int n = n1; n >= 0; n = rig->nodes[n].parent) b1_under_b0 |= n == n0;
  const int turned = b1_under_b0 ? bone[1] : bone[0];
  const double w = b1_under_b0 ? 1 - w0 : w0;
  const double th = 40.0 * M_PI / 180.0;
  Pose pose = RestPose(rig.value());
  pose.local[rig->skins[0].joints[turned]].rotation = {0, 0, static_cast<float>(std::sin(th / 2)),
                                                       static_cast<float>(std::cos(th / 2))};
  BlendOptions options;
  options.pose = &pose;
  BlendedRig out;
  BlendContext ctx;
  ASSERT_TRUE(
      EvaluateRig(rig.value(), std::vector<float>(rig->shapes.size(), 0.0f), options, out, ctx)
          .ok());
  // p' = w Mt p + (1 - w) p, Mt = T(c) Rz T(-c) about the turned bone's rest place c; in glTF axes
  // (x, y, -z) x 0.08.
  const double p[3] = {vpos[0] * 0.08, vpos[1] * 0.08, -vpos[2] * 0.08};
  const double c[3] = {bpos[turned][0] * 0.08, bpos[turned][1] * 0.08, -bpos[turned][2] * 0.08};
  const double q[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]};
  const double mt[3] = {c[0] + std::cos(th) * q[0] - std::sin(th) * q[1],
                        c[1] + std::sin(th) * q[0] + std::cos(th) * q[1], p[2]};
  double want[3];
  for (int k = 0; k < 3; ++k) want[k] = w * mt[k] + (1 - w) * p[k];
  // Find the vertex by its rest position, then compare where it went.
  bool found = false;
  for (size_t pi = 0; pi < rig->primitives.size() && !found; ++pi) {
    const Primitive& prim = rig->primitives[pi];
    for (size_t k = 0; k < prim.vertex_count() && !found; ++k) {
      if (std::fabs(prim.positions[3 * k] - p[0]) > 1e-6 ||
          std::fabs(prim.positions[3 * k + 1] - p[1]) > 1e-6 ||
          std::fabs(prim.positions[3 * k + 2] - p[2]) > 1e-6)
        continue;
      found = true;
      for (int a = 0; a < 3; ++a)
        EXPECT_NEAR(out.primitives[pi].positions[3 * k + a], want[a], 2e-6) << a;
      EXPECT_GT(std::hypot(want[0] - p[0], want[1] - p[1]), 1e-3);  // It did move.
    }
  }
  EXPECT_TRUE(found);
}

// A VMD written here: bone "頭" keyed at frames 0 and 10 (rotation 0 -> 90 degrees about MMD's Y,
// x 0 -> 10 units) with a slow-in curve on both; morph "あ" keyed 0 -> 1 over frames 0 and 20.
std::vector<unsigned char> TestVmd(uint8_t x1, uint8_t y1, uint8_t x2, uint8_t y2) {
  const std::string header = "Vocaloid Motion Data 0002";
  std::vector<unsigned char> b(header.begin(), header.end());
  b.resize(50, 0);  // The rest of the 30-byte header and the 20-byte model name.
  auto put = [&](const void* p, size_t n) {
    const size_t at = b.size();
    b.resize(at + n);
    std::memcpy(b.data() + at, p, n);
  };
  auto u32 = [&](uint32_t v) { put(&v, 4); };
  auto name = [&](const char* sjis) {
    char n[15] = {};
    std::memcpy(n, sjis, std::strlen(sjis));
    put(n, 15);
  };
  u32(2);
  const float s = std::sin(M_PI / 4), c = std::cos(M_PI / 4);
  for (int k = 0; k < 2; ++k) {
    name("\x93\xaa");  // "頭" in Shift-JIS.
    u32(k ? 10 : 0);
    const float f[7] = {k ? 10.0f : 0.0f, 0, 0, 0, k ? s : 0.0f, 0, k ? c : 1.0f};
    put(f, sizeof f);
    uint8_t curve[64] = {};
    for (int ch = 0; ch < 4; ++ch)
      curve[ch] = x1, curve[ch + 4] = y1, curve[ch + 8] = x2, curve[ch + 12] = y2;
    put(curve, 64);
  }
  u32(2);
  for (int k = 0; k < 2; ++k) {
    name("\x82\xa0");  // "あ".
    u32(k ? 20 : 0);
    const float w = k ? 1.0f : 0.0f;
    put(&w, 4);
  }
  return b;
}

// The curve's y where its x is u, found another way: dense sampling of the parameter.
double CurveY(double x1, double y1, double x2, double y2, double u) {
  double best = 1e9, y = 0;
  for (int i = 0; i <= 200000; ++i) {
    const double s = i / 200000.0, t = 1 - s;
    const double x = 3 * t * t * s * x1 + 3 * t * s * s * x2 + s * s * s;
    if (std::fabs(x - u) < best)
      best = std::fabs(x - u), y = 3 * t * t * s * y1 + 3 * t * s * s * y2 + s * s * s;
  }
  return y;
}

const AnimationSampler* ChannelOf(const AnimationInfo& clip, int node, ChannelPath path) {
  for (const AnimationChannel& ch : clip.channel_data) {
    if (ch.node == node && ch.path == path) return &clip.sampler_data[ch.sampler];
  }
  return nullptr;
}

TEST(Vmd, ABezierKeyAtMidTimeGivesTheCurvesValue) {
  const Result<Rig> rig = formats::LoadRigFile(UkaDir() + "/MS_Uka.pmx");
  ASSERT_TRUE(rig.ok());
  const uint8_t x1 = 100, y1 = 10, x2 = 120, y2 = 40;  // Slow in.
  std::vector<Warning> warnings;
  const Result<AnimationInfo> clip =
      formats::LoadVmdMemory(TestVmd(x1, y1, x2, y2), rig.value(), "test", &warnings);
  ASSERT_TRUE(clip.ok()) << clip.status().message;
  EXPECT_TRUE(warnings.empty());
  const int head = FindNode(rig.value(), "頭");
  ASSERT_GE(head, 0);
  const AnimationSampler* rot = ChannelOf(clip.value(), head, ChannelPath::kRotation);
  const AnimationSampler* tr = ChannelOf(clip.value(), head, ChannelPath::kTranslation);
  ASSERT_TRUE(rot && tr);
  // Frame 5 of 0..10 is mid-time: sample 10 at 60 a second.
  ASSERT_EQ(rot->times.size(), 21u);
  EXPECT_FLOAT_EQ(rot->times[10], 5.0f / 30.0f);
  const double y = CurveY(x1 / 127.0, y1 / 127.0, x2 / 127.0, y2 / 127.0, 0.5);
  EXPECT_LT(y, 0.3);  // Far from linear's 0.5: the curve is what moves it.
  // Rotation: slerp from identity by y of 90 degrees about Y; MMD's Y stays glTF's Y, the angle
  // flips sign.
  const double half = -0.5 * y * M_PI / 2;
  EXPECT_NEAR(rot->values[4 * 10 + 1], std::sin(half), 1e-5);
  EXPECT_NEAR(rot->values[4 * 10 + 3], std::cos(half), 1e-5);
  // Translation: the rest offset plus y of 10 units along x, in metres.
  const Node& n = rig->nodes[head];
  EXPECT_NEAR(tr->values[3 * 10], n.translation[0] + y * 10 * 0.08, 1e-5);
  EXPECT_NEAR(tr->values[3 * 10 + 1], n.translation[1], 1e-6);
  // The morph: linear, 0 at frame 0, 1 at frame 20, one weights channel over its two key times.
  int mesh_node = -1;
  for (size_t k = 0; k < rig->nodes.size(); ++k) {
    if (rig->nodes[k].mesh == 0) mesh_node = static_cast<int>(k);
  }
  const AnimationSampler* w = ChannelOf(clip.value(), mesh_node, ChannelPath::kWeights);
  ASSERT_TRUE(w);
  ASSERT_EQ(w->times.size(), 2u);
  EXPECT_FLOAT_EQ(w->times[1], 20.0f / 30.0f);
  const int a = FindShape(rig.value(), "あ");
  size_t t = 0;
  while (rig->meshes[0].target_shapes[t] != static_cast<uint32_t>(a)) ++t;
  EXPECT_EQ(w->values[t], 0.0f);
  EXPECT_EQ(w->values[w->components + t], 1.0f);
  EXPECT_NEAR(clip->duration, 20.0f / 30.0f, 1e-6f);
}

TEST(Vmd, AStraightSegmentKeepsItsTwoKeys) {
  // MMD's default curve (20, 20, 107, 107) is the diagonal: linear, so the keys alone are exact.
  const Result<Rig> rig = formats::LoadRigFile(UkaDir() + "/MS_Uka.pmx");
  ASSERT_TRUE(rig.ok());
  const Result<AnimationInfo> clip =
      formats::LoadVmdMemory(TestVmd(20, 20, 107, 107), rig.value(), "straight", nullptr);
  ASSERT_TRUE(clip.ok()) << clip.status().message;
  const AnimationSampler* rot =
      ChannelOf(clip.value(), FindNode(rig.value(), "頭"), ChannelPath::kRotation);
  ASSERT_TRUE(rot);
  ASSERT_EQ(rot->times.size(), 2u);
  EXPECT_FLOAT_EQ(rot->times[1], 10.0f / 30.0f);
  EXPECT_NEAR(rot->values[4 + 1], -std::sin(M_PI / 4), 1e-6);  // 90 degrees about Y, mirrored.
}

TEST(Vmd, TheMotionsBesideTheModelAreClipsWithTheirKeyCounts) {
  Raw r{test::ReadBytes(UkaDir() + "/motion/01_happy.vmd")};
  r.at = 50;
  const uint32_t bone_keys = r.Get<uint32_t>();
  r.at += 111 * static_cast<size_t>(bone_keys);
  const uint32_t morph_keys = r.Get<uint32_t>();
  EXPECT_EQ(bone_keys, 224u);
  EXPECT_EQ(morph_keys, 345u);
  const Result<Rig> rig = formats::LoadRigFile(UkaDir() + "/MS_Uka.pmx");
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig->animations.size(), 4u);
  EXPECT_EQ(rig->animations[1].name, "01_happy");
  EXPECT_NEAR(rig->animations[1].duration, 10.0f, 1e-6f);  // Frame 300 at 30 a second.
  // The motions were written for another model: the names Uka lacks are reported, by motion.
  size_t unmatched = 0;
  for (const Warning& w : rig->load_warnings) {
    if (w.code == "motion_names_unmatched" && w.shape == "01_happy")
      unmatched = static_cast<size_t>(w.value);
  }
  EXPECT_GT(unmatched, 100u);
  EXPECT_LT(unmatched, 200u);
  // "笑い" (a smile of the eyes) is 1 from frame 15 to 285 in 01_happy: at 5 s, fully on.
  const int smile = FindShape(rig.value(), "笑い");
  ASSERT_GE(smile, 0);
  const AnimationInfo& happy = rig->animations[1];
  const AnimationSampler* w = nullptr;
  for (const AnimationChannel& ch : happy.channel_data) {
    if (ch.path == ChannelPath::kWeights) w = &happy.sampler_data[ch.sampler];
  }
  ASSERT_TRUE(w);
  size_t t = 0;
  while (rig->meshes[0].target_shapes[t] != static_cast<uint32_t>(smile)) ++t;
  size_t k = 0;
  while (k + 1 < w->times.size() && w->times[k + 1] <= 5.0f) ++k;
  EXPECT_EQ(w->values[k * w->components + t], 1.0f);
}

// MMD matches a motion's morph tracks to the model's morphs by their names, and every morph is its
// own morph: 瞳小 and pupil_decrease_geo_ hold the same 834 offsets, and 08_surprise keys them
// apart.
TEST(Vmd, EveryMorphIsItsOwnShapeAndATrackDrivesTheMorphOfItsName) {
  // From the file: 瞳小's keys (Shift-JIS 93 B5 8F AC), frame -> weight.
  Raw r{test::ReadBytes(UkaDir() + "/motion/08_surprise.vmd")};
  r.at = 50;
  r.at += 111 * static_cast<size_t>(r.Get<uint32_t>());
  const uint32_t morph_keys = r.Get<uint32_t>();
  std::map<uint32_t, float> pupil;
  for (uint32_t k = 0; k < morph_keys; ++k) {
    const std::string name(reinterpret_cast<const char*>(&r.b[r.at]), 4);
    const bool ours = name == "\x93\xb5\x8f\xac" && r.b[r.at + 4] == 0;
    r.at += 15;
    const uint32_t frame = r.Get<uint32_t>();
    const float weight = r.Get<float>();
    if (ours) pupil[frame] = weight;
  }
  ASSERT_EQ(pupil.count(15), 1u);
  EXPECT_FLOAT_EQ(pupil[15], 0.4f);

  const Result<Rig> rig = formats::LoadRigFile(UkaDir() + "/MS_Uka.pmx");
  ASSERT_TRUE(rig.ok());
  const int small = FindShape(rig.value(), "瞳小"),
            geo = FindShape(rig.value(), "pupil_decrease_geo_");
  ASSERT_GE(small, 0);
  ASSERT_GE(geo, 0);
  EXPECT_NE(small, geo);
  EXPECT_EQ(rig->shapes[geo].name, "pupil_decrease_geo_");  // Its own name, not an alias of 瞳小.
  int clip = -1;
  for (size_t a = 0; a < rig->animations.size(); ++a) {
    if (rig->animations[a].name == "08_surprise") clip = static_cast<int>(a);
  }
  ASSERT_GE(clip, 0);
  for (const auto& [frame, weight] : pupil) {
    Pose pose = RestPose(rig.value());
    std::vector<float> w;
    std::vector<uint8_t> set;
    ASSERT_TRUE(SampleClip(rig.value(), clip, static_cast<float>(frame) / 30.0f, ClipWrap::kClamp,
                           pose, w, set)
                    .ok());
    EXPECT_FLOAT_EQ(w[small], weight) << "frame " << frame;
    EXPECT_FLOAT_EQ(w[geo], 0.0f) << "frame " << frame;  // Its own track: keyed 0.
  }
}

TEST(MmdHostile, TruncatedAndLyingPmdAndVmdAreErrors) {
  const std::vector<unsigned char> pmd = test::ReadBytes(Pmd());
  for (size_t n = 0; n < pmd.size() * 9 / 10; n += n < 3000 ? 13 : 299999) {
    EXPECT_FALSE(formats::LoadPmdMemory(std::span<const unsigned char>(pmd.data(), n), "cut").ok())
        << n;
  }
  std::vector<unsigned char> lying = pmd;
  const uint32_t lie = 0x7fffffff;
  std::memcpy(&lying[3 + 4 + 20 + 256], &lie, 4);
  const Result<Rig> bad = formats::LoadPmdMemory(lying, "lying");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message.find("more than the file holds"), std::string::npos)
      << bad.status().message;

  const Result<Rig> rig = formats::LoadRigFile(UkaDir() + "/MS_Uka.pmx");
  ASSERT_TRUE(rig.ok());
  const std::vector<unsigned char> vmd = test::ReadBytes(UkaDir() + "/motion/01_happy.vmd");
  for (size_t n = 0; n < vmd.size() - 200; n += 997) {
    EXPECT_FALSE(formats::LoadVmdMemory(std::span<const unsigned char>(vmd.data(), n), rig.value(),
                                        "cut", nullptr)
                     .ok())
        << n;
  }
  std::vector<unsigned char> far = TestVmd(20, 20, 107, 107);
  const uint32_t frame = 0xffffffffu;
  std::memcpy(&far[54 + 15], &frame, 4);
  const Result<AnimationInfo> clip = formats::LoadVmdMemory(far, rig.value(), "far", nullptr);
  ASSERT_FALSE(clip.ok());
  EXPECT_NE(clip.status().message.find("beyond an hour"), std::string::npos)
      << clip.status().message;
  EXPECT_FALSE(
      formats::LoadVmdMemory(std::vector<unsigned char>(60, 'x'), rig.value(), "junk", nullptr)
          .ok());
}

// Found by fuzz_vmd: finite keys whose interpolation overflows a float (a morph from -3e38 to 3e38
// is infinite half-way) are refused, naming the key; so are offsets no bone has. A rotation whose
// components square past a float's range is still a rotation (normalised in double).
TEST(MmdHostile, VmdValuesWhoseInterpolationWouldOverflowAreRefused) {
  const Result<Rig> rig = formats::LoadRigFile(UkaDir() + "/MS_Uka.pmx");
  ASSERT_TRUE(rig.ok());
  const size_t morphs = 54 + 2 * 111 + 4;  // Header, bone keys, morph count.
  std::vector<unsigned char> vmd = TestVmd(20, 20, 107, 107);
  const float low = -3e38f, high = 3e38f;
  std::memcpy(&vmd[morphs + 19], &low, 4);
  std::memcpy(&vmd[morphs + 23 + 19], &high, 4);
  const Result<AnimationInfo> morph = formats::LoadVmdMemory(vmd, rig.value(), "wide", nullptr);
  ASSERT_FALSE(morph.ok());
  EXPECT_NE(morph.status().message.find("morph key 0 has weight"), std::string::npos)
      << morph.status().message;

  vmd = TestVmd(20, 20, 107, 107);
  const float far = 2e6f;
  std::memcpy(&vmd[54 + 111 + 19], &far, 4);  // Bone key 1's x.
  const Result<AnimationInfo> bone = formats::LoadVmdMemory(vmd, rig.value(), "far", nullptr);
  ASSERT_FALSE(bone.ok());
  EXPECT_NE(bone.status().message.find("bone key 1 moves its bone beyond"), std::string::npos)
      << bone.status().message;

  vmd = TestVmd(20, 20, 107, 107);
  const float big[4] = {0, 2e38f, 0, 2e38f};  // 90 degrees about y, scaled.
  std::memcpy(&vmd[54 + 111 + 19 + 12], big, 16);
  const Result<AnimationInfo> scaled = formats::LoadVmdMemory(vmd, rig.value(), "scaled", nullptr);
  ASSERT_TRUE(scaled.ok()) << scaled.status().message;
  const Result<AnimationInfo> plain =
      formats::LoadVmdMemory(TestVmd(20, 20, 107, 107), rig.value(), "plain", nullptr);
  ASSERT_TRUE(plain.ok());
  ASSERT_EQ(scaled->sampler_data.size(), plain->sampler_data.size());
  for (size_t s = 0; s < plain->sampler_data.size(); ++s) {
    ASSERT_EQ(scaled->sampler_data[s].values.size(), plain->sampler_data[s].values.size());
    for (size_t i = 0; i < plain->sampler_data[s].values.size(); ++i) {
      EXPECT_NEAR(scaled->sampler_data[s].values[i], plain->sampler_data[s].values[i], 1e-6)
          << s << " " << i;
    }
  }
}

// MMD's material morph formula: per material the product of lerp(1, m, w) over the multiplies, then
// the sum of w * a over the adds, on the diffuse colour, times the texture tint (same rules).
TEST(MaterialMorphs, MultipliesThenAddsByWeight) {
  Rig rig;
  rig.materials.resize(2);
  rig.materials[0].base_color_factor = {0.5f, 0.5f, 0.5f, 1.0f};
  rig.materials[1].base_color_factor = {1.0f, 1.0f, 1.0f, 0.0f};
  rig.shapes.resize(3);
  MaterialMorph darker;  // Every material's diffuse x (0.2, 1, 1, 1).
  darker.diffuse = {0.2f, 1, 1, 1};
  rig.shapes[0].material_morphs = {darker};
  MaterialMorph show;  // Material 1: alpha + 1, red + 0.5 (the texture tint adds nothing).
  show.material = 1;
  show.add = true;
  show.diffuse = {0.5f, 0, 0, 1};
  show.texture_tint = {0, 0, 0, 0};
  rig.shapes[1].material_morphs = {show};
  std::vector<std::array<float, 4>> colors;
  MorphedMaterialColors(rig, std::vector<float>{0, 0, 0.7f}, colors);
  EXPECT_TRUE(colors.empty());  // No shape with material morphs has a weight.
  MorphedMaterialColors(rig, std::vector<float>{0.5f, 0.4f, 0}, colors);
  ASSERT_EQ(colors.size(), 2u);
  EXPECT_NEAR(colors[0][0], 0.5f * (1 + 0.5f * (0.2f - 1)),
              1e-6f);  // 0.5 x lerp(1, 0.2, 0.5) = 0.3.
  EXPECT_NEAR(colors[0][1], 0.5f, 1e-6f);
  EXPECT_NEAR(colors[1][0], std::min(1.0f, 1.0f * 0.6f + 0.4f * 0.5f), 1e-6f);  // x 0.6, + 0.2.
  EXPECT_NEAR(colors[1][3], 0.4f, 1e-6f);                                       // Alpha 0 + 0.4.
}

// Uka's blush (赤み), pallor (青ざめ) and gloom (どんより) are material morphs: shapes a motion
// drives.
TEST(MaterialMorphs, UkasBlushIsAShapeThatColoursHerMaterials) {
  const Result<Rig> rig = formats::LoadRigFile(UkaDir() + "/MS_Uka.pmx");
  ASSERT_TRUE(rig.ok());
  for (const char* name : {"赤み", "青ざめ", "どんより"}) {
    const int s = FindShape(rig.value(), name);
    ASSERT_GE(s, 0) << name;
    EXPECT_FALSE(rig->shapes[s].material_morphs.empty()) << name;
    std::vector<float> w(rig->shapes.size(), 0.0f);
    w[s] = 1.0f;
    std::vector<std::array<float, 4>> colors;
    MorphedMaterialColors(rig.value(), w, colors);
    ASSERT_EQ(colors.size(), rig->materials.size());
    bool changed = false;
    for (size_t m = 0; m < colors.size(); ++m) {
      for (int c = 0; c < 4; ++c)
        changed |= std::fabs(colors[m][c] - rig->materials[m].base_color_factor[c]) > 1e-3f;
    }
    EXPECT_TRUE(changed) << name;
  }
  // The motions name them: no longer "matching nothing".
  for (const Warning& warning : rig->load_warnings) {
    if (warning.code == "motion_names_unmatched") {
      EXPECT_EQ(warning.message.find("赤み"), std::string::npos) << warning.message;
    }
  }
}

// A glb of Uka carries the materials' colours at its weights; the batch's template writer gives the
// same bytes as a whole export for every variant (colours change from one to the next).
TEST(MaterialMorphs, EveryGlbVariantCarriesItsColours) {
  const Result<Rig> rig = formats::LoadRigFile(UkaDir() + "/MS_Uka.pmx");
  ASSERT_TRUE(rig.ok());
  formats::GlbVariantWriter writer;
  BlendedRig blended;
  BlendContext context;
  for (float w : {0.0f, 0.7f, 0.35f}) {
    std::vector<float> weights(rig->shapes.size(), 0.0f);
    weights[FindShape(rig.value(), "赤み")] = w;
    ASSERT_TRUE(EvaluateRig(rig.value(), weights, {}, blended, context).ok());
    auto whole = ExportMesh(rig.value(), blended, weights, {}, formats::MeshFormat::kGlb);
    auto pieces = writer.Write(rig.value(), blended, weights, {});
    ASSERT_TRUE(whole.ok() && pieces.ok());
    EXPECT_EQ(whole.value(), std::string(pieces->head) + std::string(pieces->bin)) << w;
    EXPECT_EQ(blended.material_colors.empty(), w == 0.0f);
  }
}

// The manifest may colour a material (a model whose textures are not at hand) and name the base
// motion.
TEST(MaterialMorphs, TheManifestColoursMaterialsAndNamesTheBaseMotion) {
  Result<Rig> rig = formats::LoadRigFile(UkaDir() + "/MS_Uka.pmx");
  ASSERT_TRUE(rig.ok());
  ASSERT_TRUE(
      formats::ApplyManifest(
          rig.value(),
          R"({"materials": {"頬照り2": {"base_color": [0.9, 0.5, 0.5, 0]}}, "base_motion": "01_happy"})")
          .ok());
  const auto it = std::find_if(rig->materials.begin(), rig->materials.end(),
                               [](const Material& m) { return m.name == "頬照り2"; });
  ASSERT_NE(it, rig->materials.end());
  EXPECT_FLOAT_EQ(it->base_color_factor[0], 0.9f);
  EXPECT_FLOAT_EQ(it->base_color_factor[3], 0.0f);
  EXPECT_EQ(rig->base_motion, "01_happy");
  // The blush adds 1 to that material's alpha: at 1 it shows in the manifest's colour.
  std::vector<float> w(rig->shapes.size(), 0.0f);
  w[FindShape(rig.value(), "赤み")] = 1.0f;
  std::vector<std::array<float, 4>> colors;
  MorphedMaterialColors(rig.value(), w, colors);
  const size_t m = static_cast<size_t>(it - rig->materials.begin());
  EXPECT_FLOAT_EQ(colors[m][0], 0.9f);
  EXPECT_FLOAT_EQ(colors[m][3], 1.0f);
  // Names that are not there are load warnings (a model copied without its motions still loads); a
  // colour out of range is refused, naming the member.
  rig->load_warnings.clear();
  ASSERT_TRUE(
      formats::ApplyManifest(
          rig.value(),
          R"({"materials": {"nope": {"base_color": [1, 1, 1, 1]}}, "base_motion": "01_hapy"})")
          .ok());
  ASSERT_EQ(rig->load_warnings.size(), 2u);
  EXPECT_EQ(rig->load_warnings[0].code, "manifest_unknown_motion");
  EXPECT_NE(rig->load_warnings[0].message.find("did you mean '01_happy'"), std::string::npos)
      << rig->load_warnings[0].message;
  EXPECT_EQ(rig->load_warnings[1].code, "manifest_unknown_material");
  EXPECT_EQ(rig->base_motion, "01_happy");  // Unchanged.
  const Status bad = formats::ApplyManifest(
      rig.value(), R"({"materials": {"頬照り2": {"base_color": [2, 1, 1, 1]}}})");
  EXPECT_EQ(bad.fields.at(0).pointer, "/materials/頬照り2");
}

TEST(MmdTextures, ImagesAreReadFromTheModelsFolderOnly) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("facespace_tex_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "model" / "Tex");
  const std::string png = std::string("\x89PNG\r\n\x1a\n") + std::string(20, 'x');
  test::WriteBytes((dir / "model" / "Tex" / "Face.PNG").string(), png);
  test::WriteBytes((dir / "model" / "hair.tga").string(), std::string(30, 'x'));
  test::WriteBytes((dir / "model" / "notes.txt").string(), "hello");
  test::WriteBytes((dir / "secret.png").string(), png);
  Rig rig;
  for (const char* name : {"tex/face.png", "hair.tga", "../secret.png", "/etc/passwd", "C:/x.png",
                           "tex/../../secret.png", "notes.txt", "missing.bmp"}) {
    rig.images.push_back({name, "", {}});
    rig.load_warnings.push_back({"texture_not_loaded", "not read", name, 0.0, false});
  }
  formats::LoadImagesBeside(rig, (dir / "model" / "m.pmx").string());
  // Read: the PNG (its letter case forgiven) and the TGA (by extension); nothing outside the
  // folder.
  EXPECT_EQ(rig.images[0].mime_type, "image/png");
  EXPECT_EQ(rig.images[0].bytes.size(), png.size());
  EXPECT_EQ(rig.images[1].mime_type, "image/x-tga");
  for (size_t k = 2; k < rig.images.size(); ++k)
    EXPECT_TRUE(rig.images[k].bytes.empty()) << rig.images[k].name;
  // The warnings left are the images not read, each saying why.
  ASSERT_EQ(rig.load_warnings.size(), 6u);
  EXPECT_EQ(rig.load_warnings[0].shape, "../secret.png");
  EXPECT_NE(rig.load_warnings[0].message.find("no such file in the model's folder"),
            std::string::npos);
  EXPECT_NE(rig.load_warnings[4].message.find("not a PNG, JPEG, BMP or TGA image"),
            std::string::npos)
      << rig.load_warnings[4].message;
  fs::remove_all(dir);
}

}  // namespace mmd_test
}  // namespace facespace
