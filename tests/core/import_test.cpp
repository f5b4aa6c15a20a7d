// Import of every real asset, checked against the test's own raw reader.
#include <gtest/gtest.h>

#include "facespace/engine/blend.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace import_test {  // Named: core_tests is a unity build, its files share one unit.

using test::RawGltf;
using test::RealAsset;

struct AssetCase {
  const char* path;
  size_t vertices, primitives, shapes, skins;
};

const AssetCase kAssets[] = {
    {"AnimatedMorphCube/AnimatedMorphCube.gltf", 24, 1, 2, 0},
    {"AnimatedMorphSphere/AnimatedMorphSphere.gltf", 1876, 1, 2, 0},
    {"SimpleMorph/SimpleMorph.gltf", 3, 1, 2, 0},
    {"MorphPrimitivesTest/MorphPrimitivesTest.gltf", 30, 2, 1, 0},
    {"MorphStressTest/MorphStressTest.gltf", 1528, 2, 8, 0},
    {"FaceCap/facecap.glb", 4368, 4, 52, 0},
    {"FaceCap/facecap_decoded.glb", 4368, 4, 52, 0},
    {"Fox/Fox.glb", 1728, 1, 0, 1},
    {"CesiumMan/CesiumMan.gltf", 3273, 1, 0, 1},
    {"RiggedSimple/RiggedSimple.gltf", 160, 1, 0, 1},
    {"SimpleSkin/SimpleSkin.gltf", 10, 1, 0, 1},
    {"SimpleSparseAccessor/SimpleSparseAccessor.gltf", 14, 1, 0, 0},
    {"SparseMorphCube_tinygltf/singleBlendshapeCube_sparse.glb", 24, 1, 1, 0},
};

void PrintTo(const AssetCase& c, std::ostream* os) { *os << c.path; }

class RealAssets : public ::testing::TestWithParam<AssetCase> {};

TEST_P(RealAssets, CountsMatch) {
  const AssetCase& c = GetParam();
  auto rig = formats::LoadGltfFile(RealAsset(c.path));
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  EXPECT_EQ(rig->vertex_count(), c.vertices);
  EXPECT_EQ(rig->primitives.size(), c.primitives);
  EXPECT_EQ(rig->shapes.size(), c.shapes);
  EXPECT_EQ(rig->skin_count, c.skins);
  EXPECT_TRUE(ValidateRig(rig.value()).ok());
}

// Positions at sample weights equal base + sum w_j * target_j read by the raw reader.
TEST_P(RealAssets, BlendMatchesRawAccessors) {
  const AssetCase& c = GetParam();
  // facecap.glb is quantized and meshopt-compressed, beyond the raw reader: it is checked
  // against its decoded copy in FaceCapMatchesDecodedCopy instead.
  if (std::string(c.path) == "FaceCap/facecap.glb") return;
  auto rig = formats::LoadGltfFile(RealAsset(c.path));
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  RawGltf raw(RealAsset(c.path));
  std::vector<float> w(rig->shapes.size());
  for (size_t j = 0; j < w.size(); ++j)
    w[j] = 0.3f + 0.1f * static_cast<float>(j % 7) - (j % 5 == 4 ? 0.6f : 0.0f);
  BlendedRig out;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(rig.value(), w, {}, out, ctx).ok());
  size_t prim = 0;
  for (size_t m = 0; m < raw.json["meshes"].size(); ++m) {
    const auto& mesh = raw.json["meshes"][m];
    for (const auto& p : mesh["primitives"]) {
      std::vector<float> expected = raw.Floats(p["attributes"]["POSITION"]);
      float extent = 0.0f;
      for (float f : expected) extent = std::max(extent, std::fabs(f));
      const auto& targets = p.value("targets", nlohmann::json::array());
      for (size_t t = 0; t < targets.size(); ++t) {
        const uint32_t shape = rig->meshes[m].target_shapes[t];
        const std::vector<float> d = raw.Floats(targets[t]["POSITION"]);
        for (size_t i = 0; i < expected.size(); ++i) expected[i] += w[shape] * d[i];
      }
      ASSERT_LT(prim, out.primitives.size());
      if (out.primitives[prim].skinned) {  // Scene space after skinning: see skeleton_test.
        ++prim;
        continue;
      }
      EXPECT_LE(test::MaxAbsDiff(out.primitives[prim].positions, expected),
                test::kPositionTol * std::max(extent, 1.0f))
          << "mesh " << m;
      ++prim;
    }
  }
  EXPECT_EQ(prim, out.primitives.size());
}

INSTANTIATE_TEST_SUITE_P(Import, RealAssets, ::testing::ValuesIn(kAssets),
                         [](const auto& param_info) {
                           std::string n = param_info.param.path;
                           n = n.substr(n.find('/') + 1);
                           for (char& ch : n)
                             if (!isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n;
                         });

TEST(Import, FaceCapMatchesDecodedCopy) {
  // facecap.glb (meshopt + int16 quantization, decoded by us) against facecap_decoded.glb
  // (decoded and dequantized by glTF-Transform): the same geometry and the same shapes.
  auto packed = formats::LoadGltfFile(RealAsset("FaceCap/facecap.glb"));
  auto plain = formats::LoadGltfFile(RealAsset("FaceCap/facecap_decoded.glb"));
  ASSERT_TRUE(packed.ok()) << packed.status().message;
  ASSERT_TRUE(plain.ok()) << plain.status().message;
  ASSERT_EQ(packed->shapes.size(), plain->shapes.size());
  for (size_t s = 0; s < packed->shapes.size(); ++s)
    EXPECT_EQ(packed->shapes[s].name, plain->shapes[s].name);
  EXPECT_EQ(packed->shapes[24].name, "jawOpen");
  ASSERT_EQ(packed->load_warnings.size(), 1u);
  EXPECT_EQ(packed->load_warnings[0].code, "texture_dropped");
  std::vector<float> w(52, 0.0f);
  w[24] = 0.8f;  // jawOpen
  w[37] = 0.5f;  // mouthSmile_L
  BlendedRig a, b;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(packed.value(), w, {}, a, ctx).ok());
  ASSERT_TRUE(EvaluateRig(plain.value(), w, {}, b, ctx).ok());
  for (size_t p = 0; p < a.primitives.size(); ++p) {
    EXPECT_EQ(packed->primitives[p].indices, plain->primitives[p].indices);
    EXPECT_LE(test::MaxAbsDiff(a.primitives[p].positions, b.primitives[p].positions),
              1e-3f);  // Units of 2^-16.
    EXPECT_LE(test::MaxAbsDiff(a.primitives[p].normals, b.primitives[p].normals),
              2e-2f);  // int8 normals.
  }
  // jawOpen moves the head; the eyes do not have it.
  EXPECT_GT(packed->shapes[24].vertices_moved, 1000u);
  EXPECT_EQ(packed->meshes[2].name, "head");
}

TEST(Import, SparseBaseAccessor) {
  // SimpleSparseAccessor: the base POSITION is sparse over a bufferView.
  auto rig = formats::LoadGltfFile(RealAsset("SimpleSparseAccessor/SimpleSparseAccessor.gltf"));
  ASSERT_TRUE(rig.ok());
  RawGltf raw(RealAsset("SimpleSparseAccessor/SimpleSparseAccessor.gltf"));
  const auto expected =
      raw.Floats(raw.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"]);
  EXPECT_EQ(rig->primitives[0].positions, expected);
  // The sparse substitution did change the data of the bufferView underneath.
  RawGltf plain(RealAsset("SimpleSparseAccessor/SimpleSparseAccessor.gltf"));
  const int acc = raw.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"];
  plain.json["accessors"][acc].erase("sparse");
  EXPECT_NE(plain.Floats(acc), expected);
}

TEST(Import, TargetNamesAndDefaults) {
  auto rig = formats::LoadGltfFile(RealAsset("MorphStressTest/MorphStressTest.gltf"));
  ASSERT_TRUE(rig.ok());
  EXPECT_EQ(rig->shapes[0].name, "Key 1");
  EXPECT_EQ(rig->shapes[7].name, "Key 8");
  // Both primitives' targets map to the same 8 shapes.
  EXPECT_EQ(rig->meshes[0].target_shapes, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5, 6, 7}));
  auto prims = formats::LoadGltfFile(RealAsset("MorphPrimitivesTest/MorphPrimitivesTest.gltf"));
  ASSERT_TRUE(prims.ok());
  EXPECT_EQ(prims->shapes[0].default_weight, 0.5f) << "mesh.weights";
  EXPECT_EQ(prims->images.size(), 1u) << "the JPEG texture is kept";
  EXPECT_EQ(prims->images[0].mime_type, "image/jpeg");
}

// ---- hostile and broken files -------------------------------------------------------------

std::vector<unsigned char> Bytes(const std::string& s) { return {s.begin(), s.end()}; }

Result<Rig> LoadText(const std::string& gltf) {
  return formats::LoadGltfMemory(Bytes(gltf), "",
                                 {.allow_external_files = false, .read_manifest = false});
}

// A one-triangle glTF with an embedded buffer; `patch` edits its JSON first.
std::string Triangle(const std::function<void(nlohmann::json&)>& patch) {
  // 3 positions (36 bytes) + 3 uint16 indices (6 bytes, padded to 8) + one target (36 bytes).
  std::vector<float> pos = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  std::vector<uint16_t> idx = {0, 1, 2, 0};
  std::vector<float> delta = {0, 0, 1, 0, 0, 0, 0, 0, 0};
  std::string bin(reinterpret_cast<char*>(pos.data()), 36);
  bin.append(reinterpret_cast<char*>(idx.data()), 8);
  bin.append(reinterpret_cast<char*>(delta.data()), 36);
  static const char* b64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string enc;
  for (size_t i = 0; i < bin.size(); i += 3) {
    uint32_t v = static_cast<unsigned char>(bin[i]) << 16;
    if (i + 1 < bin.size()) v |= static_cast<unsigned char>(bin[i + 1]) << 8;
    if (i + 2 < bin.size()) v |= static_cast<unsigned char>(bin[i + 2]);
    enc += b64[(v >> 18) & 63];
    enc += b64[(v >> 12) & 63];
    enc += i + 1 < bin.size() ? b64[(v >> 6) & 63] : '=';
    enc += i + 2 < bin.size() ? b64[v & 63] : '=';
  }
  nlohmann::json j = {
      {"asset", {{"version", "2.0"}}},
      {"buffers",
       {{{"byteLength", bin.size()}, {"uri", "data:application/octet-stream;base64," + enc}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 36}},
        {{"buffer", 0}, {"byteOffset", 36}, {"byteLength", 6}},
        {{"buffer", 0}, {"byteOffset", 44}, {"byteLength", 36}}}},
      {"accessors",
       {{{"bufferView", 0},
         {"componentType", 5126},
         {"count", 3},
         {"type", "VEC3"},
         {"min", {0, 0, 0}},
         {"max", {1, 1, 0}}},
        {{"bufferView", 1}, {"componentType", 5123}, {"count", 3}, {"type", "SCALAR"}},
        {{"bufferView", 2},
         {"componentType", 5126},
         {"count", 3},
         {"type", "VEC3"},
         {"min", {0, 0, 0}},
         {"max", {0, 0, 1}}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}}}, {"indices", 1}, {"targets", {{{"POSITION", 2}}}}}}},
         {"extras", {{"targetNames", {"up"}}}}}}},
      {"nodes", {{{"mesh", 0}}}},
      {"scenes", {{{"nodes", {0}}}}}};
  patch(j);
  return j.dump();
}

TEST(ImportHostile, BuiltTriangleLoads) {
  auto rig = LoadText(Triangle([](nlohmann::json&) {}));
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  EXPECT_EQ(rig->shapes[0].name, "up");
  EXPECT_EQ(rig->primitives[0].targets[0].indices, (std::vector<uint32_t>{0}));
}

TEST(ImportHostile, ClearErrors) {
  struct Case {
    const char* name;
    std::function<void(nlohmann::json&)> patch;
    const char* needle;
  };
  const Case cases[] = {
      {"accessor beyond its view", [](auto& j) { j["accessors"][0]["count"] = 4; },
       "beyond its bufferView"},
      {"view beyond its buffer", [](auto& j) { j["bufferViews"][0]["byteLength"] = 400; }, ""},
      {"byteOffset overflow",
       [](auto& j) { j["accessors"][0]["byteOffset"] = 0x7ffffffffffffff0ll; }, ""},
      {"index beyond vertex count",
       [](auto& j) {
         j["accessors"][0]["count"] = 2;
         j["accessors"][2]["count"] = 2;
       },
       "beyond vertex count"},
      {"target with another vertex count", [](auto& j) { j["accessors"][2]["count"] = 2; },
       "the base has 3"},
      {"missing accessor",
       [](auto& j) { j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 9; }, ""},
      {"missing bufferView", [](auto& j) { j["accessors"][0]["bufferView"] = 7; }, ""},
      {"child cycle",
       [](auto& j) {
         j["nodes"] = {{{"mesh", 0}, {"children", {1}}}, {{"children", {0}}}};
       },
       ""},
      {"unsupported required extension",
       [](auto& j) {
         j["extensionsRequired"] = {"KHR_draco_mesh_compression"};
         j["extensionsUsed"] = {"KHR_draco_mesh_compression"};
       },
       "KHR_draco_mesh_compression"},
      {"POSITION as VEC2", [](auto& j) { j["accessors"][0]["type"] = "VEC2"; }, ""},
      {"NaN in data URI count", [](auto& j) { j["accessors"][1]["componentType"] = 5126; },
       "unsigned integer"},
  };
  for (const Case& c : cases) {
    auto rig = LoadText(Triangle(c.patch));
    EXPECT_FALSE(rig.ok()) << c.name;
    if (!rig.ok()) {
      EXPECT_FALSE(rig.status().message.empty()) << c.name;
      EXPECT_NE(rig.status().message.find(c.needle), std::string::npos)
          << c.name << ": " << rig.status().message;
    }
  }
}

TEST(ImportHostile, TruncatedGlbAtEveryRegion) {
  const auto bytes = test::ReadBytes(RealAsset("FaceCap/facecap.glb"));
  for (size_t cut : {size_t{0}, size_t{3}, size_t{12}, size_t{19}, size_t{20}, size_t{100},
                     size_t{5000}, bytes.size() / 2, bytes.size() - 100, bytes.size() - 1}) {
    std::vector<unsigned char> part(bytes.begin(), bytes.begin() + cut);
    auto rig = formats::LoadGltfMemory(part, "", {.allow_external_files = false});
    EXPECT_FALSE(rig.ok()) << "cut at " << cut;
  }
  // Flipped bytes inside the compressed data: an error or a valid rig, never a crash.
  for (size_t at = 80000; at < bytes.size(); at += 20011) {
    std::vector<unsigned char> bad = bytes;
    bad[at] ^= 0x5A;
    auto rig = formats::LoadGltfMemory(bad, "", {.allow_external_files = false});
    if (rig.ok()) {
      EXPECT_TRUE(ValidateRig(rig.value()).ok());
    }
  }
}

TEST(ImportHostile, UploadsCannotReadOurDisk) {
  auto rig = LoadText(Triangle([](auto& j) { j["buffers"][0]["uri"] = "../../../../etc/passwd"; }));
  ASSERT_FALSE(rig.ok());
  EXPECT_NE(rig.status().message.find("refused"), std::string::npos) << rig.status().message;
}

TEST(ImportHostile, GarbageIsNotGltf) {
  EXPECT_FALSE(LoadText("").ok());
  EXPECT_FALSE(LoadText("{").ok());
  EXPECT_FALSE(LoadText("[1,2,3]").ok());
  EXPECT_FALSE(LoadText("glTF\x02").ok());
  EXPECT_EQ(formats::LoadGltfFile("/nonexistent/rig.glb").status().code, StatusCode::kNotFound);
}

}  // namespace import_test
}  // namespace facespace
