// OBJ sequences, manifests and every export format, with round trips.
#include <gtest/gtest.h>

#include <cstring>

#include "facespace/core/blend.h"
#include "facespace/core/io.h"
#include "facespace/core/pose_request.h"
#include "facespace/core/weights.h"
#include "test_util.h"

namespace facespace {
namespace {

using test::TempDir;

std::string Quad(float lift, bool other_faces = false) {
  std::string s = "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 " + std::to_string(lift) + "\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";
  s += other_faces ? "f 1/1 2/2 4/4\nf 2/2 3/3 4/4\n" : "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
  return s;
}

TEST(ObjSequence, ShapesAreRelativeAndSparse) {
  TempDir dir;
  test::WriteBytes(dir / "base.obj", Quad(0));
  test::WriteBytes(dir / "up.obj", Quad(2));
  std::vector<std::string> paths = {dir / "base.obj", dir / "up.obj"};
  auto rig = LoadObjSequence(paths);
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  ASSERT_EQ(rig->shapes.size(), 1u);
  EXPECT_EQ(rig->shapes[0].name, "up");
  EXPECT_EQ(rig->primitives[0].targets[0].indices, (std::vector<uint32_t>{2}));
  EXPECT_EQ(rig->primitives[0].targets[0].position_deltas, (std::vector<float>{0, 0, 2}));
  EXPECT_EQ(rig->primitives[0].texcoords.size(), 8u);
  std::vector<float> w = {0.5f};
  BlendedRig out;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(rig.value(), w, {}, out, ctx).ok());
  EXPECT_EQ(out.primitives[0].positions[8], 1.0f);
}

TEST(ObjSequence, ReportsFirstDifferingFace) {
  TempDir dir;
  test::WriteBytes(dir / "base.obj", Quad(0));
  test::WriteBytes(dir / "bad.obj", Quad(1, true));
  std::vector<std::string> paths = {dir / "base.obj", dir / "bad.obj"};
  auto rig = LoadObjSequence(paths);
  ASSERT_FALSE(rig.ok());
  EXPECT_NE(rig.status().message.find("face 1 differs"), std::string::npos) << rig.status().message;
  EXPECT_NE(rig.status().message.find("bad.obj:10"), std::string::npos) << rig.status().message;
  test::WriteBytes(dir / "short.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
  paths[1] = dir / "short.obj";
  EXPECT_NE(LoadObjSequence(paths).status().message.find("has 3 vertices"), std::string::npos);
  test::WriteBytes(dir / "broken.obj", "v 0 0 zero\n");
  paths[1] = dir / "broken.obj";
  EXPECT_NE(LoadObjSequence(paths).status().message.find("broken.obj:1"), std::string::npos);
  test::WriteBytes(dir / "far.obj", "v 0 0 0\nf 1 2 3\n");
  EXPECT_FALSE(LoadRigFile(dir / "far.obj").ok());
}

TEST(ObjSequence, IctFaceKitFrames) {
  // Real OBJ frames with identical connectivity (26,719 vertices).
  const std::string d = test::SharedAssets() + "/more/OBJ/ICT-FaceKit_subset/";
  std::vector<std::string> paths;
  for (const auto& e : std::filesystem::directory_iterator(d)) {
    if (e.path().extension() == ".obj") paths.push_back(e.path().string());
  }
  std::sort(paths.begin(), paths.end());
  ASSERT_GE(paths.size(), 3u);
  auto neutral = std::find_if(paths.begin(), paths.end(), [](const std::string& p) { return p.find("neutral") != std::string::npos; });
  ASSERT_NE(neutral, paths.end());
  std::iter_swap(paths.begin(), neutral);
  auto rig = LoadObjSequence(paths);
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  EXPECT_EQ(rig->vertex_count(), 26719u);
  EXPECT_EQ(rig->shapes.size(), paths.size() - 1);
  for (const Shape& s : rig->shapes) {
    EXPECT_GT(s.vertices_moved, 0u) << s.name;
    // Expressions move part of the head; the identity shape moves all of it. (These OBJs
    // are printed to 5 decimals, so many "unmoved" vertices differ by 1e-5: exact zeros
    // only are elided, and half the head counts as moved.)
    if (s.name.rfind("identity", 0) != 0) {
      EXPECT_LT(s.vertices_moved, 26719u) << s.name << " should be sparse";
    }
  }
}

TEST(Manifest, AppliesAndRejects) {
  auto rig = LoadGltfFile(test::RealAsset("MorphStressTest/MorphStressTest.gltf"), {.read_manifest = false});
  ASSERT_TRUE(rig.ok());
  const std::string good = R"({"name": "Stress", "groups": {"identity": ["Key 1", "Key 2"]},
    "shapes": {"Key 3": {"group": "expression", "min": -1, "max": 2, "default": 0.5, "aliases": ["k3"], "partner": "Key 4"},
               "Nope": {"group": "x"}}})";
  ASSERT_TRUE(ApplyManifest(rig.value(), good).ok());
  EXPECT_EQ(rig->name, "Stress");
  EXPECT_EQ(rig->shapes[0].group, "identity");
  EXPECT_EQ(rig->shapes[2].group, "expression");
  EXPECT_EQ(rig->shapes[2].min, -1.0f);
  EXPECT_EQ(rig->shapes[2].max, 2.0f);
  EXPECT_EQ(rig->shapes[2].default_weight, 0.5f);
  EXPECT_EQ(FindShape(rig.value(), "k3"), 2);
  EXPECT_EQ(rig->shapes[3].partner, 2);
  ASSERT_FALSE(rig->load_warnings.empty());
  EXPECT_EQ(rig->load_warnings.back().code, "manifest_unknown_shape");
  auto bad = ApplyManifest(rig.value(), R"({"shapes": {"Key 1": {"min": "low"}}})");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.fields[0].pointer, "/shapes/Key 1/min");
  EXPECT_FALSE(ApplyManifest(rig.value(), "{").ok());
  EXPECT_FALSE(ApplyManifest(rig.value(), R"({"shapes": {"Key 1": {"min": 2, "max": 1}}})").ok());
}

TEST(JsonPointer, KeysAreEscapedAsOneReferenceToken) {
  EXPECT_EQ(JsonPointerEscape("jawOpen"), "jawOpen");
  EXPECT_EQ(JsonPointerEscape("nose/nose-trans-down|up"), "nose~1nose-trans-down|up");
  EXPECT_EQ(JsonPointerEscape("~/"), "~0~1");  // "~" first, so "/" never turns into "~01".
  EXPECT_EQ(JsonPointerEscape(""), "");
}

TEST(Manifest, BundledFaceCap) {
  auto rig = LoadRigFile(test::Bundled("facecap/facecap.glb"));
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  EXPECT_EQ(rig->shapes[FindShape(rig.value(), "jawOpen")].group, "expression");
  EXPECT_EQ(FindShape(rig.value(), "mouthSmileLeft"), FindShape(rig.value(), "mouthSmile_L"));
  EXPECT_GE(FindShape(rig.value(), "mouthSmileLeft"), 0);
}

struct Evaluated {
  Rig rig;
  std::vector<float> weights;
  BlendedRig blended;
};

Evaluated Evaluate(const std::string& path, std::vector<float> w) {
  Evaluated e{LoadRigFile(path).value(), std::move(w), {}};
  BlendContext ctx;
  EXPECT_TRUE(EvaluateRig(e.rig, e.weights, {}, e.blended, ctx).ok());
  return e;
}

TEST(Export, JsonShapeAndDeterminism) {
  auto e = Evaluate(test::RealAsset("MorphStressTest/MorphStressTest.gltf"), {0.5f, 0, 0, 0, 0, 0, 0, 0.25f});
  std::vector<Warning> warn = {{"extrapolation", "x", "", 1.5, true}};
  auto a = ExportMesh(e.rig, e.blended, e.weights, warn, MeshFormat::kJson);
  auto b = ExportMesh(e.rig, e.blended, e.weights, warn, MeshFormat::kJson);
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(a.value(), b.value()) << "byte-identical for the same input";
  auto j = nlohmann::json::parse(a.value());
  ASSERT_EQ(j["primitives"].size(), 2u);
  EXPECT_EQ(j["primitives"][1]["mesh"], 0);
  EXPECT_EQ(j["primitives"][1]["primitive"], 1);
  EXPECT_EQ(j["primitives"][1]["name"], "Cube");
  EXPECT_EQ(j["primitives"][1]["positions"].size(), 3u * 1504);
  EXPECT_EQ(j["warnings"][0]["code"], "extrapolation");
  EXPECT_EQ(j["warnings"][0]["value"], 1.5);
  // Floats survive the text exactly.
  for (size_t i = 0; i < 30; ++i) {
    EXPECT_EQ(j["primitives"][0]["positions"][i].get<float>(), e.blended.primitives[0].positions[i]);
  }
}

TEST(Export, GlbRoundTripKeepsBlendHierarchyAndMaterials) {
  auto e = Evaluate(test::RealAsset("FaceCap/facecap.glb"), std::vector<float>(52, 0.0f));
  e.weights[24] = 0.9f;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(e.rig, e.weights, {}, e.blended, ctx).ok());
  auto glb = ExportMesh(e.rig, e.blended, e.weights, {}, MeshFormat::kGlb);
  ASSERT_TRUE(glb.ok());
  std::vector<unsigned char> bytes(glb->begin(), glb->end());
  auto back = LoadGltfMemory(bytes, "", {.allow_external_files = false});
  ASSERT_TRUE(back.ok()) << back.status().message;
  EXPECT_EQ(back->nodes.size(), e.rig.nodes.size());
  EXPECT_EQ(back->nodes[5].name, "grp_eyeLeft");
  EXPECT_EQ(back->materials.size(), 1u);
  EXPECT_TRUE(back->shapes.empty()) << "the blended mesh has no targets";
  for (size_t p = 0; p < e.rig.primitives.size(); ++p) {
    EXPECT_EQ(back->primitives[p].positions, e.blended.primitives[p].positions);
    EXPECT_EQ(back->primitives[p].indices, e.rig.primitives[p].indices);
  }
  EXPECT_EQ(NodeWorldMatrices(back.value()), NodeWorldMatrices(e.rig));
}

// Every map of a metallic-roughness material is read and written back (MorphStressTest's
// material with each map pointed at its base colour image).
TEST(Export, GlbKeepsEveryMaterialMap) {
  auto e = Evaluate(test::RealAsset("MorphStressTest/MorphStressTest.gltf"), std::vector<float>(8, 0.0f));
  ASSERT_FALSE(e.rig.materials.empty());
  Material& m = e.rig.materials[0];
  // Its occlusion map is on TEXCOORD_1, which is not kept: said, not silent.
  EXPECT_EQ(m.occlusion_image, -1);
  const auto dropped = std::find_if(e.rig.load_warnings.begin(), e.rig.load_warnings.end(),
                                    [](const Warning& w) { return w.code == "material_map_dropped"; });
  ASSERT_NE(dropped, e.rig.load_warnings.end());
  EXPECT_NE(dropped->message.find("occlusion map is on TEXCOORD_1"), std::string::npos) << dropped->message;
  ASSERT_GE(m.base_color_image, 0);
  m.normal_image = m.metallic_roughness_image = m.emissive_image = m.occlusion_image = m.base_color_image;
  m.normal_scale = 0.75f;
  m.occlusion_strength = 0.5f;
  m.emissive_factor = {0.25f, 0.5f, 1.0f};
  auto glb = ExportMesh(e.rig, e.blended, e.weights, {}, MeshFormat::kGlb);
  ASSERT_TRUE(glb.ok()) << glb.status().message;
  std::vector<unsigned char> bytes(glb->begin(), glb->end());
  auto back = LoadGltfMemory(bytes, "", {.allow_external_files = false});
  ASSERT_TRUE(back.ok()) << back.status().message;
  const Material& b = back->materials[0];
  ASSERT_GE(b.normal_image, 0);
  EXPECT_EQ(back->images[static_cast<size_t>(b.normal_image)].bytes, e.rig.images[static_cast<size_t>(m.normal_image)].bytes);
  EXPECT_EQ(b.metallic_roughness_image, b.normal_image);
  EXPECT_EQ(b.emissive_image, b.normal_image);
  EXPECT_EQ(b.occlusion_image, b.normal_image);
  EXPECT_EQ(b.normal_scale, 0.75f);
  EXPECT_EQ(b.occlusion_strength, 0.5f);
  EXPECT_EQ(b.emissive_factor, m.emissive_factor);
  EXPECT_EQ(b.base_color_image >= 0, m.base_color_image >= 0);
  // A map naming an image that is not there is refused, as the base colour's is.
  m.normal_image = static_cast<int>(e.rig.images.size());
  EXPECT_FALSE(ValidateRig(e.rig).ok());
}

TEST(Export, GlbWithTargetsReblendsTheSame) {
  auto e = Evaluate(test::RealAsset("MorphStressTest/MorphStressTest.gltf"), {0.5f, 0, 0.3f, 0, 0, 0, 0, 0.25f});
  auto glb = ExportMesh(e.rig, e.blended, e.weights, {}, MeshFormat::kGlb, {.keep_targets = true});
  ASSERT_TRUE(glb.ok());
  std::vector<unsigned char> bytes(glb->begin(), glb->end());
  auto back = LoadGltfMemory(bytes, "", {.allow_external_files = false});
  ASSERT_TRUE(back.ok()) << back.status().message;
  ASSERT_EQ(back->shapes.size(), 8u);
  EXPECT_EQ(back->shapes[7].name, "Key 8");
  EXPECT_EQ(back->shapes[7].default_weight, 0.25f) << "chosen weights become mesh.weights";
  EXPECT_EQ(back->images.size(), e.rig.images.size());
  BlendedRig again;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(back.value(), e.weights, {}, again, ctx).ok());
  for (size_t p = 0; p < again.primitives.size(); ++p) {
    EXPECT_EQ(again.primitives[p].positions, e.blended.primitives[p].positions);
    EXPECT_EQ(back->primitives[p].targets[0].indices, e.rig.primitives[p].targets[0].indices) << "sparse kept sparse";
  }
}

TEST(Export, ObjAndF32InWorldSpace) {
  auto e = Evaluate(test::RealAsset("FaceCap/facecap_decoded.glb"), std::vector<float>(52, 0.0f));
  auto obj = ExportMesh(e.rig, e.blended, e.weights, {}, MeshFormat::kObj);
  auto f32 = ExportMesh(e.rig, e.blended, e.weights, {}, MeshFormat::kF32);
  ASSERT_TRUE(obj.ok() && f32.ok());
  EXPECT_EQ(f32->size(), e.rig.vertex_count() * 6 * 4);
  // The first OBJ vertex equals the first f32 position; both are world space (the nodes
  // scale the int16 range of this file down to about 0.2 units).
  float first[3];
  std::memcpy(first, f32->data(), 12);
  const size_t v = obj->find("\nv ");
  ASSERT_NE(v, std::string::npos);
  float x, y, z;
  ASSERT_EQ(std::sscanf(obj->c_str() + v + 3, "%f %f %f", &x, &y, &z), 3);
  EXPECT_FLOAT_EQ(x, first[0]);
  EXPECT_FLOAT_EQ(y, first[1]);
  EXPECT_FLOAT_EQ(z, first[2]);
  EXPECT_LT(std::fabs(first[0]) + std::fabs(first[1]) + std::fabs(first[2]), 100.0f);
  size_t faces = 0;
  for (size_t at = obj->find("\nf "); at != std::string::npos; at = obj->find("\nf ", at + 1)) ++faces;
  EXPECT_EQ(faces, e.rig.triangle_count());
  // OBJ round trip through our own reader: same vertex count and triangles.
  TempDir dir;
  test::WriteBytes(dir / "out.obj", obj.value());
  auto back = LoadRigFile(dir / "out.obj");
  ASSERT_TRUE(back.ok()) << back.status().message;
  EXPECT_EQ(back->vertex_count(), e.rig.vertex_count());
  EXPECT_EQ(back->triangle_count(), e.rig.triangle_count());
}

// The batch's glb writer gives ExportMesh's bytes exactly, variant after variant: FaceCap with
// and without warnings (extrapolation), CesiumMan posed by its clip at several times (skinned
// positions, every node's matrix), then the same CesiumMan at rest (another shape: the template
// is made again), and a rig's export with keep_targets.
TEST(GlbVariantWriter, WritesExportMeshBytes) {
  auto joined = [](const GlbVariantWriter::Pieces& p) { return std::string(p.head) + std::string(p.bin); };
  GlbVariantWriter writer;
  auto face = LoadRigFile(test::RealAsset("FaceCap/facecap_decoded.glb"));
  ASSERT_TRUE(face.ok());
  BlendedRig out;
  BlendContext ctx;
  size_t patched = 0;
  for (int i = 0; i < 6; ++i) {
    std::vector<float> w(face->shapes.size(), 0.0f);
    for (size_t k = static_cast<size_t>(i); k < w.size(); k += 7) w[k] = 0.1f * static_cast<float>(i + k % 5);
    const WeightReport report = CheckWeights(face.value(), w, BlendMode::kRelative);
    ASSERT_TRUE(EvaluateRig(face.value(), w, {}, out, ctx).ok());
    auto expected = ExportMesh(face.value(), out, w, report.warnings, MeshFormat::kGlb);
    auto pieces = writer.Write(face.value(), out, w, report.warnings);
    ASSERT_TRUE(expected.ok() && pieces.ok());
    ASSERT_EQ(joined(pieces.value()), expected.value()) << "variant " << i << ", " << report.warnings.size() << " warnings";
    patched += !pieces->bin.empty();
  }
  EXPECT_EQ(patched, 5u) << "the first variant makes the template, the others patch it";

  auto man = LoadGltfFile(test::RealAsset("CesiumMan/CesiumMan.gltf"));
  ASSERT_TRUE(man.ok());
  std::vector<float> none;
  for (float time : {0.0f, 0.8f, 1.7f, -1.0f}) {
    Pose pose;
    BlendOptions o;
    if (time >= 0) {
      PoseRequest req;
      req.clips.push_back(ClipRequest{.index = 0, .time = time, .pointer = "/animation"});
      std::vector<float> w;
      bool posed = false;
      std::vector<Warning> warnings;
      std::vector<WeightEntry> entries;
      ASSERT_TRUE(ResolvePoseAndWeights(man.value(), entries, req, w, pose, posed, warnings).ok());
      o.pose = &pose;
    }
    ASSERT_TRUE(EvaluateRig(man.value(), none, o, out, ctx).ok());
    auto expected = ExportMesh(man.value(), out, none, {}, MeshFormat::kGlb);
    auto pieces = writer.Write(man.value(), out, none, {});
    ASSERT_TRUE(expected.ok() && pieces.ok());
    ASSERT_EQ(joined(pieces.value()), expected.value()) << "CesiumMan at " << time;
  }
  auto rig_itself = writer.Write(man.value(), out, none, {}, {.keep_targets = true});
  ASSERT_TRUE(rig_itself.ok());
  EXPECT_EQ(joined(rig_itself.value()), ExportMesh(man.value(), out, none, {}, MeshFormat::kGlb, {.keep_targets = true}).value());
}

}  // namespace
}  // namespace facespace
