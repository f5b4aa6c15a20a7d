// MikuMikuDance PMX (../shared/assets/more/MMD/Uka): counts as the file says, vertices and a vertex
// morph read here from the raw bytes with our own small reader (and converted to right-handed
// metres by hand), then hostile files.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "facespace/engine/blend.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace pmx_test {  // Named: core_tests is a unity build, its files share one unit.

std::string Uka() { return test::SharedAssets() + "/more/MMD/Uka/MS_Uka.pmx"; }

// An independent walk over the start of the file: the header, the texts, the vertices.
struct Raw {
  std::vector<unsigned char> b;
  size_t at = 0;
  int32_t I32() {
    int32_t v;
    std::memcpy(&v, &b[at], 4);
    at += 4;
    return v;
  }
  float F32() {
    float v;
    std::memcpy(&v, &b[at], 4);
    at += 4;
    return v;
  }
  void Text() { at += static_cast<size_t>(I32()); }
};

TEST(Pmx, CountsAsTheFileSays) {
  const Result<Rig> rig = formats::LoadRigFile(Uka());
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
  const Result<Rig> rig = formats::LoadRigFile(Uka());
  ASSERT_TRUE(rig.ok());
  // Every vertex of the first 200: (x, y, -z) x 0.08 is somewhere in the rig's primitives.
  for (int v = 0; v < 200; ++v) {
    const float x = r.F32(), y = r.F32(), z = r.F32();
    r.at += 4 * (3 + 2 + 4 * static_cast<size_t>(extra_uv));
    const int kind = r.b[r.at++];
    r.at += kind == 0   ? bone_size
            : kind == 1 ? 2 * bone_size + 4
            : kind == 2 ? 4 * bone_size + 16
            : kind == 3 ? 2 * bone_size + 40
                        : 4 * bone_size + 16;
    r.at += 4;  // Edge scale.
    const float want[3] = {x * 0.08f, y * 0.08f, -z * 0.08f};
    bool found = false;
    for (const Primitive& p : rig->primitives) {
      for (size_t k = 0; k < p.vertex_count() && !found; ++k) {
        found = std::fabs(p.positions[3 * k] - want[0]) < 1e-6f &&
                std::fabs(p.positions[3 * k + 1] - want[1]) < 1e-6f &&
                std::fabs(p.positions[3 * k + 2] - want[2]) < 1e-6f;
      }
      if (found) break;
    }
    EXPECT_TRUE(found) << "vertex " << v;
  }
}

TEST(Pmx, AVertexMorphMovesExactlyItsVerticesByItsOffsets) {
  const Result<Rig> rig = formats::LoadRigFile(Uka());
  ASSERT_TRUE(rig.ok());
  const int a = FindShape(rig.value(), "あ");
  ASSERT_GE(a, 0);
  BlendedRig b0, b1;
  ASSERT_NO_FATAL_FAILURE(test::RestAndShape(rig.value(), a, b0, b1));
  // The vertices that move are the shape's own, by its deltas (which are the file's offsets x 0.08,
  // z negated: checked on the moved count and on the largest move, a few centimetres for an open
  // mouth).
  size_t moved = 0;
  float largest = 0;
  for (size_t p = 0; p < b0.primitives.size(); ++p) {
    for (size_t k = 0; k < b0.primitives[p].positions.size(); k += 3) {
      const float d =
          std::hypot(b1.primitives[p].positions[k] - b0.primitives[p].positions[k],
                     b1.primitives[p].positions[k + 1] - b0.primitives[p].positions[k + 1],
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
  for (size_t n = 0; n < whole.size() / 2;
       n += n < 2000 ? 7 : 199999) {  // The first half: before the morphs end.
    const Result<Rig> rig =
        formats::LoadPmxMemory(std::span<const unsigned char>(whole.data(), n), "cut");
    EXPECT_FALSE(rig.ok()) << n;
  }
  std::vector<unsigned char> bad = whole;
  bad[4 + 4 + 1 + 2] = 3;  // Vertex index size 3.
  Result<Rig> rig = formats::LoadPmxMemory(bad, "bad");
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
  rig = formats::LoadPmxMemory(bad, "lying");
  ASSERT_FALSE(rig.ok());
  EXPECT_NE(rig.status().message.find("more than the file holds"), std::string::npos)
      << rig.status().message;
}

// A PMX file's bytes as a test writes them: raw bytes, little-endian int32s and floats, bytes, and
// UTF-8 text with its length.
struct PmxBytes {
  std::vector<unsigned char> b;
  void bytes(const void* p, size_t n) {
    b.insert(b.end(), static_cast<const unsigned char*>(p),
             static_cast<const unsigned char*>(p) + n);
  }
  void i32(int32_t v) { bytes(&v, 4); }
  void f32(std::initializer_list<float> fs) {
    for (float f : fs) bytes(&f, 4);
  }
  void u8(int v) { b.push_back(static_cast<unsigned char>(v)); }
  void text(const std::string& t) {
    i32(static_cast<int32_t>(t.size()));
    bytes(t.data(), t.size());
  }
};

// A small PMX written here: one bone, one triangle over vertex 0, a vertex morph moving vertex 0 by
// (1, 2, 3) units, and a group morph of `entries` entries alternating between that morph (factor
// 0.25) and itself. Index sizes are 1 byte.
std::vector<unsigned char> GroupFanOut(int entries) {
  PmxBytes w;
  w.bytes("PMX ", 4);
  w.f32({2.0f});
  for (int g : {8, 1, 0, 1, 1, 1, 1, 1, 1})
    w.u8(g);                             // 8 globals: UTF-8, no extra UV, 1-byte indices.
  for (int t = 0; t < 4; ++t) w.i32(0);  // Model names and comments.
  w.i32(1);                              // One vertex: position, normal, UV, BDEF1 on bone 0, edge.
  w.f32({0, 0, 0, 0, 0, -1, 0, 0});
  w.u8(0);
  w.u8(0);
  w.f32({1});
  w.i32(3);  // One (degenerate) triangle.
  w.u8(0), w.u8(0), w.u8(0);
  w.i32(0);  // No textures.
  w.i32(1);  // One material over the 3 indices.
  w.i32(0), w.i32(0);
  w.f32({1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0});
  w.u8(0);
  w.f32({0, 0, 0, 1, 1});
  w.u8(0xff), w.u8(0xff), w.u8(0), w.u8(1), w.u8(0);
  w.i32(0), w.i32(3);
  w.i32(1);  // One bone at the origin, no parent.
  w.i32(0), w.i32(0);
  w.f32({0, 0, 0});
  w.u8(0xff);
  w.i32(0);
  w.u8(0), w.u8(0);
  w.f32({0, 1, 0});
  w.i32(2);  // Two morphs.
  w.i32(0), w.i32(0), w.u8(3), w.u8(1), w.i32(1), w.u8(0);
  w.f32({1, 2, 3});
  w.i32(0), w.i32(0), w.u8(3), w.u8(0), w.i32(entries);
  for (int k = 0; k < entries; ++k) {
    w.u8(k % 2);
    w.f32({k % 2 ? 1.0f : 0.25f});
  }
  return w.b;
}

TEST(PmxHostile, AGroupNamingItselfIsNotFollowed) {
  // Before, groups were followed to a depth of 8: 2000 entries naming the group itself were 1000^8
  // paths (the fuzzer's out-of-memory). PMX 2.0 does not nest groups: only the vertex morphs count.
  const std::vector<unsigned char> pmx = GroupFanOut(2000);
  const Result<Rig> rig = formats::LoadPmxMemory(pmx, "fanout");
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  ASSERT_EQ(rig->shapes.size(), 2u);
  const SparseTarget& t = rig->primitives[0].targets[1];
  ASSERT_EQ(t.indices.size(), 1u);
  // 1000 entries x 0.25 x (1, 2, 3) units x 0.08 m, z negated.
  EXPECT_NEAR(t.position_deltas[0], 250 * 1 * 0.08f, 1e-3f);
  EXPECT_NEAR(t.position_deltas[1], 250 * 2 * 0.08f, 1e-3f);
  EXPECT_NEAR(t.position_deltas[2], -250 * 3 * 0.08f, 1e-3f);
  bool reported = false;
  for (const auto& w : rig->load_warnings)
    reported |= w.code == "morphs_skipped" &&
                w.message.find("1000 group-morph entries naming group morphs") != std::string::npos;
  EXPECT_TRUE(reported);
}

// A small PMX written here with every other morph kind: three vertices (UVs (0,0), (1,0), (0,1)) on
// one triangle, and the morphs
//   0 "v"   vertex: vertex 1 by (0, 0, 1) units
//   1 "uv"  UV: vertex 1's UV by (0.25, -0.5) (z and w, for effect shaders, 7 and 9)
//   2 "g"   group: "uv" x 0.5, "v" x 1
//   3 "f"   flip (PMX 2.1): entries "uv" at 1, "v" at 0.5
//   4 "uv1" additional UV 1, 5 "imp" impulse (rigid body 0): read, not made shapes.
std::vector<unsigned char> EveryMorphKind() {
  PmxBytes w;
  w.bytes("PMX ", 4);
  w.f32({2.1f});
  for (int g : {8, 1, 0, 1, 1, 1, 1, 1, 1})
    w.u8(g);  // UTF-8, no additional UV sets, 1-byte indices.
  for (int t = 0; t < 4; ++t) w.i32(0);
  w.i32(3);
  const float uvs[3][2] = {{0, 0}, {1, 0}, {0, 1}};
  for (int v = 0; v < 3; ++v) {
    w.f32({static_cast<float>(v == 1), static_cast<float>(v == 2), 0, 0, 0, -1, uvs[v][0],
           uvs[v][1]});
    w.u8(0), w.u8(0), w.f32({1});  // BDEF1 on bone 0, edge scale.
  }
  w.i32(3), w.u8(0), w.u8(1), w.u8(2);
  w.i32(0);  // No textures.
  w.i32(1), w.i32(0), w.i32(0);
  w.f32({1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0});
  w.u8(0);
  w.f32({0, 0, 0, 1, 1});
  w.u8(0xff), w.u8(0xff), w.u8(0), w.u8(1), w.u8(0);
  w.i32(0), w.i32(3);
  w.i32(1), w.i32(0), w.i32(0);  // One bone.
  w.f32({0, 0, 0});
  w.u8(0xff), w.i32(0), w.u8(0), w.u8(0);
  w.f32({0, 1, 0});
  w.i32(6);
  w.text("v"), w.i32(0), w.u8(4), w.u8(1), w.i32(1), w.u8(1), w.f32({0, 0, 1});
  w.text("uv"), w.i32(0), w.u8(4), w.u8(3), w.i32(1), w.u8(1), w.f32({0.25f, -0.5f, 7, 9});
  w.text("g"), w.i32(0), w.u8(4), w.u8(0), w.i32(2), w.u8(1), w.f32({0.5f}), w.u8(0), w.f32({1});
  w.text("f"), w.i32(0), w.u8(4), w.u8(9), w.i32(2), w.u8(1), w.f32({1}), w.u8(0), w.f32({0.5f});
  w.text("uv1"), w.i32(0), w.u8(4), w.u8(4), w.i32(1), w.u8(2), w.f32({1, 1, 1, 1});
  w.text("imp"), w.i32(0), w.u8(4), w.u8(10), w.i32(1), w.u8(0), w.u8(0), w.f32({0, 1, 0, 0, 0, 0});
  return w.b;
}

struct Evaluated {
  std::array<float, 2> uv1;  // Vertex 1's UV.
  float z1;                  // Vertex 1's z (metres).
};

Evaluated At(const Rig& rig, std::vector<std::pair<std::string, float>> named) {
  std::vector<float> w(rig.shapes.size(), 0.0f);
  for (const auto& [name, value] : named) w[FindShape(rig, name)] = value;
  BlendedRig out;
  BlendContext ctx;
  EXPECT_TRUE(EvaluateRig(rig, w, {}, out, ctx).ok());
  const std::span<const float> uv = TexcoordsOf(rig.primitives[0], out.primitives[0]);
  // Skinned at rest: the morphed positions are the skinned ones.
  return {{uv[2], uv[3]}, out.primitives[0].positions[5]};
}

TEST(PmxMorphs, UvGroupAndFlipMorphsActAsPmxDefinesThem) {
  // The same bytes are tests/data/every_morph_kind.pmx, which the CLI suite exports and validates.
  EXPECT_EQ(test::ReadBytes(std::string(FACESPACE_SOURCE_DIR) + "/tests/data/every_morph_kind.pmx"),
            EveryMorphKind());
  const Result<Rig> loaded = formats::LoadPmxMemory(EveryMorphKind(), "kinds");
  ASSERT_TRUE(loaded.ok()) << loaded.status().message;
  const Rig& rig = loaded.value();
  ASSERT_EQ(rig.shapes.size(), 4u);  // v, uv, g, f: additional-UV and impulse morphs are reported.
  EXPECT_EQ(rig.shapes[FindShape(rig, "uv")].vertices_moved, 1u);
  bool reported = false;
  for (const auto& w : rig.load_warnings) {
    reported |= w.code == "morphs_skipped" &&
                w.message.find("1 additional-UV-1 morph") != std::string::npos &&
                w.message.find("1 impulse morph") != std::string::npos;
  }
  EXPECT_TRUE(reported);
  // A UV morph adds its offset's x and y to the UV, by its weight; positions stay.
  Evaluated e = At(rig, {{"uv", 1.0f}});
  EXPECT_FLOAT_EQ(e.uv1[0], 1.25f);
  EXPECT_FLOAT_EQ(e.uv1[1], -0.5f);
  EXPECT_FLOAT_EQ(e.z1, 0.0f);
  e = At(rig, {{"uv", 0.5f}});
  EXPECT_FLOAT_EQ(e.uv1[0], 1.125f);
  // A group: its entries at their factors times its weight, UV and vertex alike.
  e = At(rig, {{"g", 1.0f}});
  EXPECT_FLOAT_EQ(e.uv1[0], 1.125f);
  EXPECT_FLOAT_EQ(e.uv1[1], -0.25f);
  EXPECT_NEAR(e.z1, -0.08f, 1e-7f);  // 1 unit x 0.08 m, z negated.
  // A flip of 2 entries: weight w picks entry floor(3w) - 1 at the entry's own weight, not w's.
  e = At(rig, {{"f", 0.2f}});
  EXPECT_FLOAT_EQ(e.uv1[0], 1.0f);
  EXPECT_FLOAT_EQ(e.z1, 0.0f);
  e = At(rig, {{"f", 0.4f}});
  EXPECT_FLOAT_EQ(e.uv1[0], 1.25f);  // "uv" at 1.
  EXPECT_FLOAT_EQ(e.z1, 0.0f);
  for (float w : {0.7f, 1.0f}) {
    e = At(rig, {{"f", w}});
    EXPECT_FLOAT_EQ(e.uv1[0], 1.0f);
    EXPECT_NEAR(e.z1, -0.04f, 1e-7f) << w;  // "v" at 0.5.
  }
}

// UV morphs leave as glTF TEXCOORD_0 targets (the rig) or as the blended UVs (a point), and come
// back.
TEST(PmxMorphs, UvMorphsSurviveGlbOneWayAndTheOther) {
  const Result<Rig> loaded = formats::LoadPmxMemory(EveryMorphKind(), "kinds");
  ASSERT_TRUE(loaded.ok()) << loaded.status().message;
  const Rig* rig = &loaded.value();
  std::vector<float> w(rig->shapes.size(), 0.0f);
  w[FindShape(*rig, "uv")] = 1.0f;
  BlendedRig blended;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(*rig, w, {}, blended, ctx).ok());
  for (bool keep : {true, false}) {
    auto glb = ExportMesh(*rig, blended, w, {}, formats::MeshFormat::kGlb, {.keep_targets = keep});
    ASSERT_TRUE(glb.ok()) << glb.status().message;
    const std::vector<unsigned char> bytes(glb->begin(), glb->end());
    const Result<Rig> reloaded = formats::LoadGltfMemory(bytes, "", {});
    ASSERT_TRUE(reloaded.ok()) << reloaded.status().message;
    const Rig* back = &reloaded.value();
    if (keep) {
      const SparseTarget& t =
          back->primitives[0].targets[static_cast<size_t>(FindShape(*back, "uv"))];
      ASSERT_EQ(t.texcoord_indices, std::vector<uint32_t>{1});
      EXPECT_EQ(t.texcoord_deltas, (std::vector<float>{0.25f, -0.5f}));
      EXPECT_FLOAT_EQ(At(*back, {{"uv", 1.0f}}).uv1[0], 1.25f);
    } else {
      EXPECT_FLOAT_EQ(back->primitives[0].texcoords[2], 1.25f);
      EXPECT_FLOAT_EQ(back->primitives[0].texcoords[3], -0.5f);
    }
  }
  // The variant writer patches the UVs of later variants: the same bytes as a whole export.
  formats::GlbVariantWriter writer;
  BlendedRig rest;
  ASSERT_TRUE(EvaluateRig(*rig, std::vector<float>(w.size(), 0.0f), {}, rest, ctx).ok());
  ASSERT_TRUE(writer.Write(*rig, rest, std::vector<float>(w.size(), 0.0f), {}).ok());
  auto pieces = writer.Write(*rig, blended, w, {});
  ASSERT_TRUE(pieces.ok());
  auto whole = ExportMesh(*rig, blended, w, {}, formats::MeshFormat::kGlb);
  ASSERT_TRUE(whole.ok());
  EXPECT_EQ(std::string(pieces->head) + std::string(pieces->bin), whole.value());
  // OBJ: vt is (u, 1 - v).
  auto obj = ExportMesh(*rig, blended, w, {}, formats::MeshFormat::kObj);
  ASSERT_TRUE(obj.ok());
  EXPECT_NE(obj->find("vt 1.25 1.5\n"), std::string::npos) << obj.value();
}

}  // namespace pmx_test
}  // namespace facespace
