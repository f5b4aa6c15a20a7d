// MikuMikuDance PMX (../shared/assets/more/MMD/Uka): counts as the file says, vertices and a vertex
// morph read here from the raw bytes with our own small reader (and converted to right-handed
// metres by hand), then hostile files.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "facespace/core/blend.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace {

std::string Uka() { return test::SharedAssets() + "/more/MMD/Uka/MS_Uka.pmx"; }

// An independent walk over the start of the file: the header, the texts, the vertices.
struct Raw {
  std::vector<unsigned char> b;
  size_t at = 0;
  int32_t I32() { int32_t v; std::memcpy(&v, &b[at], 4); at += 4; return v; }
  float F32() { float v; std::memcpy(&v, &b[at], 4); at += 4; return v; }
  void Text() { at += static_cast<size_t>(I32()); }
};

TEST(Pmx, CountsAsTheFileSays) {
  const Result<Rig> rig = LoadRigFile(Uka());
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  EXPECT_EQ(rig->vertex_count(), 49955u);
  EXPECT_EQ(rig->triangle_count(), 77909u);
  EXPECT_EQ(rig->primitives.size(), 12u);  // One per material.
  ASSERT_EQ(rig->skins.size(), 1u);
  EXPECT_EQ(rig->skins[0].joints.size(), 302u);
  // 213 morphs: 183 vertex + 19 group + 7 bone + 4 material, every one a shape; none skipped.
  EXPECT_EQ(rig->shapes.size(), 213u);
  size_t bones = 0;
  for (const Shape& s : rig->shapes) bones += !s.bone_morphs.empty();
  EXPECT_EQ(bones, 7u + 17u);  // The 7 bone morphs, and 17 groups that name them.
  for (const Warning& w : rig->load_warnings) EXPECT_NE(w.code, "morphs_skipped") << w.message;
  // Japanese names, panel groups; English names as aliases where the file has them.
  const int a = FindShape(rig.value(), "あ");
  ASSERT_GE(a, 0);
  EXPECT_EQ(rig->shapes[a].group, "mouth");
  EXPECT_GE(FindShape(rig.value(), "まばたき"), 0);
  EXPECT_EQ(rig->shapes[FindShape(rig.value(), "まばたき")].group, "eye");
}

TEST(Pmx, VerticesAreTheFilesInRightHandedMetres) {
  Raw r{test::ReadBytes(Uka())};
  ASSERT_GT(r.b.size(), 1000u);
  ASSERT_EQ(std::memcmp(r.b.data(), "PMX ", 4), 0);
  r.at = 8;
  const int globals = r.b[r.at++];
  const int extra_uv = r.b[r.at + 1], bone_size = r.b[r.at + 5];
  r.at += static_cast<size_t>(globals);
  for (int k = 0; k < 4; ++k) r.Text();
  const int32_t count = r.I32();
  ASSERT_EQ(count, 49955);
  const Result<Rig> rig = LoadRigFile(Uka());
  ASSERT_TRUE(rig.ok());
  // Every vertex of the first 200: (x, y, -z) x 0.08 is somewhere in the rig's primitives.
  for (int v = 0; v < 200; ++v) {
    const float x = r.F32(), y = r.F32(), z = r.F32();
    r.at += 4 * (3 + 2 + 4 * static_cast<size_t>(extra_uv));
    const int kind = r.b[r.at++];
    r.at += kind == 0 ? bone_size : kind == 1 ? 2 * bone_size + 4 : kind == 2 ? 4 * bone_size + 16 : kind == 3 ? 2 * bone_size + 40 : 4 * bone_size + 16;
    r.at += 4;  // Edge scale.
    const float want[3] = {x * 0.08f, y * 0.08f, -z * 0.08f};
    bool found = false;
    for (const Primitive& p : rig->primitives) {
      for (size_t k = 0; k < p.vertex_count() && !found; ++k) {
        found = std::fabs(p.positions[3 * k] - want[0]) < 1e-6f && std::fabs(p.positions[3 * k + 1] - want[1]) < 1e-6f &&
                std::fabs(p.positions[3 * k + 2] - want[2]) < 1e-6f;
      }
      if (found) break;
    }
    EXPECT_TRUE(found) << "vertex " << v;
  }
}

TEST(Pmx, AVertexMorphMovesExactlyItsVerticesByItsOffsets) {
  const Result<Rig> rig = LoadRigFile(Uka());
  ASSERT_TRUE(rig.ok());
  const int a = FindShape(rig.value(), "あ");
  ASSERT_GE(a, 0);
  std::vector<float> zero(rig->shapes.size(), 0.0f), one = zero;
  one[a] = 1.0f;
  BlendedRig b0, b1;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(rig.value(), zero, {}, b0, ctx).ok());
  ASSERT_TRUE(EvaluateRig(rig.value(), one, {}, b1, ctx).ok());
  // The vertices that move are the shape's own, by its deltas (which are the file's offsets x 0.08, z negated:
  // checked on the moved count and on the largest move, a few centimetres for an open mouth).
  size_t moved = 0;
  float largest = 0;
  for (size_t p = 0; p < b0.primitives.size(); ++p) {
    for (size_t k = 0; k < b0.primitives[p].positions.size(); k += 3) {
      const float d = std::hypot(b1.primitives[p].positions[k] - b0.primitives[p].positions[k], b1.primitives[p].positions[k + 1] - b0.primitives[p].positions[k + 1],
                                 b1.primitives[p].positions[k + 2] - b0.primitives[p].positions[k + 2]);
      moved += d > 0;
      largest = std::max(largest, d);
    }
  }
  EXPECT_EQ(moved, rig->shapes[a].vertices_moved);
  EXPECT_GT(moved, 20u);
  EXPECT_GT(largest, 0.002f);
  EXPECT_LT(largest, 0.1f);
}

TEST(PmxHostile, TruncationsAndBadHeadersAreErrors) {
  const std::vector<unsigned char> whole = test::ReadBytes(Uka());
  for (size_t n = 0; n < whole.size() / 2; n += n < 2000 ? 7 : 199999) {  // The first half: before the morphs end.
    const Result<Rig> rig = LoadPmxMemory(std::span<const unsigned char>(whole.data(), n), "cut");
    EXPECT_FALSE(rig.ok()) << n;
  }
  std::vector<unsigned char> bad = whole;
  bad[4 + 4 + 1 + 2] = 3;  // Vertex index size 3.
  Result<Rig> rig = LoadPmxMemory(bad, "bad");
  ASSERT_FALSE(rig.ok());
  EXPECT_NE(rig.status().message.find("index size 3"), std::string::npos) << rig.status().message;
  bad = whole;
  const int32_t lie = 0x7fffffff;
  // The vertex count sits after the header and the four texts: find it by the known count.
  const int32_t real = 49955;
  for (size_t k = 0; k + 4 < 2000; ++k) {
    if (std::memcmp(&bad[k], &real, 4) == 0) {
      std::memcpy(&bad[k], &lie, 4);
      break;
    }
  }
  rig = LoadPmxMemory(bad, "lying");
  ASSERT_FALSE(rig.ok());
  EXPECT_NE(rig.status().message.find("more than the file holds"), std::string::npos) << rig.status().message;
}

// A small PMX written here: one bone, one triangle over vertex 0, a vertex morph moving vertex 0 by
// (1, 2, 3) units, and a group morph of `entries` entries alternating between that morph (factor 0.25)
// and itself. Index sizes are 1 byte.
std::vector<unsigned char> GroupFanOut(int entries) {
  std::vector<unsigned char> b;
  auto bytes = [&](const void* p, size_t n) { b.insert(b.end(), static_cast<const unsigned char*>(p), static_cast<const unsigned char*>(p) + n); };
  auto i32 = [&](int32_t v) { bytes(&v, 4); };
  auto f32 = [&](std::initializer_list<float> fs) { for (float f : fs) bytes(&f, 4); };
  auto u8 = [&](int v) { b.push_back(static_cast<unsigned char>(v)); };
  bytes("PMX ", 4);
  f32({2.0f});
  for (int g : {8, 1, 0, 1, 1, 1, 1, 1, 1}) u8(g);  // 8 globals: UTF-8, no extra UV, 1-byte indices.
  for (int t = 0; t < 4; ++t) i32(0);                // Model names and comments.
  i32(1);                                             // One vertex: position, normal, UV, BDEF1 on bone 0, edge.
  f32({0, 0, 0, 0, 0, -1, 0, 0});
  u8(0);
  u8(0);
  f32({1});
  i32(3);  // One (degenerate) triangle.
  u8(0), u8(0), u8(0);
  i32(0);  // No textures.
  i32(1);  // One material over the 3 indices.
  i32(0), i32(0);
  f32({1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0});
  u8(0);
  f32({0, 0, 0, 1, 1});
  u8(0xff), u8(0xff), u8(0), u8(1), u8(0);
  i32(0), i32(3);
  i32(1);  // One bone at the origin, no parent.
  i32(0), i32(0);
  f32({0, 0, 0});
  u8(0xff);
  i32(0);
  u8(0), u8(0);
  f32({0, 1, 0});
  i32(2);  // Two morphs.
  i32(0), i32(0), u8(3), u8(1), i32(1), u8(0);
  f32({1, 2, 3});
  i32(0), i32(0), u8(3), u8(0), i32(entries);
  for (int k = 0; k < entries; ++k) {
    u8(k % 2);
    f32({k % 2 ? 1.0f : 0.25f});
  }
  return b;
}

TEST(PmxHostile, AGroupNamingItselfIsNotFollowed) {
  // Before, groups were followed to a depth of 8: 2000 entries naming the group itself were 1000^8
  // paths (the fuzzer's out-of-memory). PMX 2.0 does not nest groups: only the vertex morphs count.
  const std::vector<unsigned char> pmx = GroupFanOut(2000);
  const Result<Rig> rig = LoadPmxMemory(pmx, "fanout");
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  ASSERT_EQ(rig->shapes.size(), 2u);
  const SparseTarget& t = rig->primitives[0].targets[1];
  ASSERT_EQ(t.indices.size(), 1u);
  // 1000 entries x 0.25 x (1, 2, 3) units x 0.08 m, z negated.
  EXPECT_NEAR(t.position_deltas[0], 250 * 1 * 0.08f, 1e-3f);
  EXPECT_NEAR(t.position_deltas[1], 250 * 2 * 0.08f, 1e-3f);
  EXPECT_NEAR(t.position_deltas[2], -250 * 3 * 0.08f, 1e-3f);
  bool reported = false;
  for (const auto& w : rig->load_warnings) reported |= w.code == "morphs_skipped" && w.message.find("1000 group-morph entries naming group morphs") != std::string::npos;
  EXPECT_TRUE(reported);
}

}  // namespace
}  // namespace facespace
