// OBJ sequences, manifests and every export format, with round trips.
#include "facespace/formats/io.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "facespace/engine/blend.h"
#include "facespace/engine/normal_matrix.h"  // Core-internal: the per-vertex reference.
#include "facespace/engine/pose_request.h"
#include "facespace/engine/transform.h"
#include "facespace/engine/weights.h"
#include "test_util.h"

namespace facespace {
namespace io_test {  // Named: core_tests is a unity build, its files share one unit.

using test::TempDir;

std::string Quad(float lift, bool other_faces = false) {
  std::string s = "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 " + std::to_string(lift) +
                  "\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";
  s += other_faces ? "f 1/1 2/2 4/4\nf 2/2 3/3 4/4\n" : "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
  return s;
}

// A base and one shape as OBJ files {name, text} in `dir`, loaded as a sequence.
Result<Rig> LoadTwoObjs(const TempDir& dir, const std::pair<std::string, std::string>& base,
                        const std::pair<std::string, std::string>& shape) {
  test::WriteBytes(dir / base.first, base.second);
  test::WriteBytes(dir / shape.first, shape.second);
  const std::vector<std::string> paths = {dir / base.first, dir / shape.first};
  return formats::LoadObjSequence(paths);
}

TEST(ObjSequence, ShapesAreRelativeAndSparse) {
  TempDir dir;
  auto rig = LoadTwoObjs(dir, {"base.obj", Quad(0)}, {"up.obj", Quad(2)});
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

// Two quads folded along the edge v3-v4, whose corners have other UVs in each quad (a UV seam):
// v3 and v4 are split in two; "lift" raises v3 and v4 by 1 in z.
std::string Fold(float lift) {
  return "v 0 0 0\nv 1 0 0\nv 1 1 " + std::to_string(lift) + "\nv 0 1 " + std::to_string(lift) +
         "\nv 1 2 1\nv 0 2 1\n" +
         "vt 0 0\nvt 0.5 0\nvt 0.5 0.5\nvt 0 0.5\nvt 0.6 0.5\nvt 0.9 0.5\nvt 0.9 1\nvt 0.6 1\n"
         "f 1/1 2/2 3/3 4/4\nf 4/5 3/6 5/7 6/8\n";
}

TEST(ObjSeams, VerticesSplitAtUvSeamsMoveAndShadeAsOne) {
  TempDir dir;
  auto rig = LoadTwoObjs(dir, {"fold.obj", Fold(0)}, {"lift.obj", Fold(1)});
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  EXPECT_TRUE(rig->load_warnings.empty());
  const Primitive& p = rig->primitives[0];
  // v3 and v4 have two copies each, next to each other; the others one.
  EXPECT_EQ(p.source_vertices, (std::vector<uint32_t>{0, 1, 2, 2, 3, 3, 4, 5}));
  ASSERT_EQ(p.texcoords.size(), 16u);
  EXPECT_FLOAT_EQ(p.texcoords[2 * 2], 0.5f);  // v3 in the first quad: vt 3 (0.5, 0.5), v flipped.
  EXPECT_FLOAT_EQ(p.texcoords[2 * 2 + 1], 0.5f);
  EXPECT_FLOAT_EQ(p.texcoords[2 * 3], 0.9f);      // v3 in the second quad: vt 6 (0.9, 0.5).
  EXPECT_FLOAT_EQ(p.texcoords[2 * 5 + 1], 0.5f);  // v4 in the second: vt 5 (0.6, 0.5).
  // The target moves both copies.
  EXPECT_EQ(p.targets[0].indices, (std::vector<uint32_t>{2, 3, 4, 5}));
  // Copies share one normal, the fold's average (neither quad's alone): no seam in the shading.
  auto same_normal = [](std::span<const float> n, int a, int b) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(n[3 * a + c], n[3 * b + c], 1e-6f) << a << " " << b;
  };
  same_normal(p.normals, 2, 3);
  same_normal(p.normals, 4, 5);
  EXPECT_GT(std::fabs(p.normals[3 * 2 + 1]), 0.1f);  // Tilted towards -y by the second quad.
  EXPECT_LT(p.normals[3 * 2 + 2], 0.99f);
  // Blended with normals recomputed, and after a glb round trip.
  std::vector<float> w = {0.5f};
  BlendOptions options;
  options.normals = NormalMode::kRecompute;
  BlendedRig out;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(rig.value(), w, options, out, ctx).ok());
  same_normal(out.primitives[0].normals, 2, 3);
  same_normal(out.primitives[0].normals, 4, 5);
  EXPECT_FLOAT_EQ(out.primitives[0].positions[3 * 3 + 2], 0.5f);
  auto glb = ExportMesh(rig.value(), out, w, {}, formats::MeshFormat::kGlb, {.keep_targets = true});
  ASSERT_TRUE(glb.ok());
  auto back =
      formats::LoadGltfMemory(std::span<const unsigned char>(
                                  reinterpret_cast<const unsigned char*>(glb->data()), glb->size()),
                              "", {});
  ASSERT_TRUE(back.ok()) << back.status().message;
  EXPECT_EQ(back->primitives[0].source_vertices, p.source_vertices);
  BlendedRig out2;
  ASSERT_TRUE(EvaluateRig(back.value(), w, options, out2, ctx).ok());
  for (size_t k = 0; k < out.primitives[0].normals.size(); ++k)
    EXPECT_NEAR(out2.primitives[0].normals[k], out.primitives[0].normals[k], 1e-6f) << k;
  // OBJ out is welded again: the source's 6 `v`, 8 `vt`/`vn`, faces naming both.
  auto obj = ExportMesh(rig.value(), out, w, {}, formats::MeshFormat::kObj);
  ASSERT_TRUE(obj.ok());
  size_t vs = 0, vts = 0;
  std::istringstream in(obj.value());
  std::vector<std::string> faces;
  for (std::string line; std::getline(in, line);) {
    vs += line.rfind("v ", 0) == 0;
    vts += line.rfind("vt ", 0) == 0;
    if (line.rfind("f ", 0) == 0) faces.push_back(line);
  }
  EXPECT_EQ(vs, 6u);
  EXPECT_EQ(vts, 8u);
  ASSERT_EQ(faces.size(), 4u);
  EXPECT_EQ(faces[2], "f 4/6/6 3/4/4 5/7/7");  // The second quad's first triangle: v4 and v3 by
                                               // their second copies.
  // A manifest's mask names vertices as the source numbers them: vertex 3 (v4) is both copies.
  ASSERT_TRUE(
      formats::ApplyManifest(
          rig.value(), R"({"derived": {"lift_v4": {"from": "lift", "mask": {"vertices": [3]}}}})")
          .ok());
  const int derived = FindShape(rig.value(), "lift_v4");
  ASSERT_GE(derived, 0);
  EXPECT_EQ(rig->primitives[0].targets[static_cast<size_t>(derived)].indices,
            (std::vector<uint32_t>{4, 5}));
}

TEST(ObjSequence, ReportsFirstDifferingFace) {
  TempDir dir;
  test::WriteBytes(dir / "base.obj", Quad(0));
  test::WriteBytes(dir / "bad.obj", Quad(1, true));
  std::vector<std::string> paths = {dir / "base.obj", dir / "bad.obj"};
  auto rig = formats::LoadObjSequence(paths);
  ASSERT_FALSE(rig.ok());
  EXPECT_NE(rig.status().message.find("face 1 differs"), std::string::npos) << rig.status().message;
  EXPECT_NE(rig.status().message.find("bad.obj:10"), std::string::npos) << rig.status().message;
  test::WriteBytes(dir / "short.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
  paths[1] = dir / "short.obj";
  EXPECT_NE(formats::LoadObjSequence(paths).status().message.find("has 3 vertices"),
            std::string::npos);
  test::WriteBytes(dir / "broken.obj", "v 0 0 zero\n");
  paths[1] = dir / "broken.obj";
  EXPECT_NE(formats::LoadObjSequence(paths).status().message.find("broken.obj:1"),
            std::string::npos);
  test::WriteBytes(dir / "far.obj", "v 0 0 0\nf 1 2 3\n");
  EXPECT_FALSE(formats::LoadRigFile(dir / "far.obj").ok());
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
  auto neutral = std::find_if(paths.begin(), paths.end(), [](const std::string& p) {
    return p.find("neutral") != std::string::npos;
  });
  ASSERT_NE(neutral, paths.end());
  std::iter_swap(paths.begin(), neutral);
  auto rig = formats::LoadObjSequence(paths);
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  // 26,719 OBJ vertices, split where a vertex's UVs differ per face corner.
  ASSERT_EQ(rig->primitives.size(), 1u);
  const Primitive& p = rig->primitives[0];
  ASSERT_EQ(p.source_vertices.size(), p.vertex_count());
  EXPECT_EQ(std::set<uint32_t>(p.source_vertices.begin(), p.source_vertices.end()).size(), 26719u);
  EXPECT_EQ(p.texcoords.size(), 2 * p.vertex_count());
  EXPECT_EQ(rig->shapes.size(), paths.size() - 1);
  // Each frame at weight 1 is that OBJ's `v` lines, every copy of a vertex included (read here
  // independently of the importer).
  for (size_t s = 0; s < rig->shapes.size(); ++s) {
    std::ifstream f(paths[s + 1]);
    std::vector<float> want;
    for (std::string line; std::getline(f, line);) {
      if (line.rfind("v ", 0) != 0) continue;
      std::istringstream in(line.substr(2));
      float x, y, z;
      in >> x >> y >> z;
      want.insert(want.end(), {x, y, z});
    }
    ASSERT_EQ(want.size(), 3 * 26719u);
    std::vector<float> w(rig->shapes.size(), 0.0f);
    w[s] = 1.0f;
    BlendedRig out;
    BlendContext ctx;
    ASSERT_TRUE(EvaluateRig(rig.value(), w, {}, out, ctx).ok());
    for (size_t v = 0; v < p.vertex_count(); ++v) {
      for (int c = 0; c < 3; ++c)
        ASSERT_NEAR(out.primitives[0].positions[3 * v + c], want[3 * p.source_vertices[v] + c],
                    2e-6f)
            << s << " " << v;
    }
  }
  for (const Shape& s : rig->shapes) {
    EXPECT_GT(s.vertices_moved, 0u) << s.name;
    // Expressions move part of the head; the identity shape moves all of it. (These OBJs
    // are printed to 5 decimals, so many "unmoved" vertices differ by 1e-5: exact zeros
    // only are elided, and half the head counts as moved.)
    if (s.name.rfind("identity", 0) != 0) {
      EXPECT_LT(s.vertices_moved, p.vertex_count()) << s.name << " should be sparse";
    }
  }
}

TEST(Manifest, AppliesAndRejects) {
  auto rig = formats::LoadGltfFile(test::RealAsset("MorphStressTest/MorphStressTest.gltf"),
                                   {.read_manifest = false});
  ASSERT_TRUE(rig.ok());
  const std::string good = R"({"name": "Stress", "groups": {"identity": ["Key 1", "Key 2"]},
    "shapes": {"Key 3": {"group": "expression", "min": -1, "max": 2, "default": 0.5, "aliases": ["k3"], "partner": "Key 4"},
               "Nope": {"group": "x"}}})";
  ASSERT_TRUE(formats::ApplyManifest(rig.value(), good).ok());
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
  auto bad = formats::ApplyManifest(rig.value(), R"({"shapes": {"Key 1": {"min": "low"}}})");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.fields[0].pointer, "/shapes/Key 1/min");
  EXPECT_FALSE(formats::ApplyManifest(rig.value(), "{").ok());
  EXPECT_FALSE(
      formats::ApplyManifest(rig.value(), R"({"shapes": {"Key 1": {"min": 2, "max": 1}}})").ok());
}

TEST(JsonPointer, KeysAreEscapedAsOneReferenceToken) {
  EXPECT_EQ(JsonPointerEscape("jawOpen"), "jawOpen");
  EXPECT_EQ(JsonPointerEscape("nose/nose-trans-down|up"), "nose~1nose-trans-down|up");
  EXPECT_EQ(JsonPointerEscape("~/"), "~0~1");  // "~" first, so "/" never turns into "~01".
  EXPECT_EQ(JsonPointerEscape(""), "");
}

// A rig written back as glb (sparse targets kept) and compressed with EXT_meshopt_compression:
// smaller, the extension required, and the same rig to the bit once read (the codecs are lossless).
TEST(MeshoptOut, CompressedGlbIsSmallerAndTheSameRig) {
  auto rig = formats::LoadRigFile(test::Bundled("facecap/facecap.glb"));
  ASSERT_TRUE(rig.ok());
  std::vector<float> w(rig->shapes.size(), 0.0f);
  BlendedRig out;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(rig.value(), w, {}, out, ctx).ok());
  auto plain =
      ExportMesh(rig.value(), out, w, {}, formats::MeshFormat::kGlb, {.keep_targets = true});
  ASSERT_TRUE(plain.ok());
  const auto bytes = [](const std::string& s) {
    return std::span<const unsigned char>(reinterpret_cast<const unsigned char*>(s.data()),
                                          s.size());
  };
  auto packed = formats::EncodeMeshoptGlb(bytes(plain.value()));
  ASSERT_TRUE(packed.ok()) << packed.status().message;
  EXPECT_LT(packed->size(), plain->size() * 2 / 3) << plain->size();
  const std::string packed_text(packed->begin(), packed->end());
  EXPECT_NE(packed_text.find("\"extensionsRequired\":[\"EXT_meshopt_compression\"]"),
            std::string::npos);
  auto a = formats::LoadGltfMemory(bytes(plain.value()), "", {});
  auto b = formats::LoadGltfMemory(packed.value(), "", {});
  ASSERT_TRUE(a.ok() && b.ok()) << b.status().message;
  ASSERT_EQ(a->primitives.size(), b->primitives.size());
  for (size_t p = 0; p < a->primitives.size(); ++p) {
    EXPECT_EQ(a->primitives[p].positions, b->primitives[p].positions) << p;
    EXPECT_EQ(a->primitives[p].indices, b->primitives[p].indices) << p;
    ASSERT_EQ(a->primitives[p].targets.size(), b->primitives[p].targets.size());
    for (size_t k = 0; k < a->primitives[p].targets.size(); ++k) {
      EXPECT_EQ(a->primitives[p].targets[k].indices, b->primitives[p].targets[k].indices)
          << p << " " << k;
      EXPECT_EQ(a->primitives[p].targets[k].position_deltas,
                b->primitives[p].targets[k].position_deltas)
          << p << " " << k;
    }
  }
  // Compressing again changes nothing (the extension is there already).
  auto again = formats::EncodeMeshoptGlb(packed.value());
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again.value(), packed.value());
}

TEST(Manifest, BundledFaceCap) {
  auto rig = formats::LoadRigFile(test::Bundled("facecap/facecap.glb"));
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  EXPECT_EQ(rig->shapes[FindShape(rig.value(), "jawOpen")].group,
            "jaw");  // Grouped by face region.
  EXPECT_EQ(rig->shapes[FindShape(rig.value(), "browInnerUp")].group, "brow");
  EXPECT_NE(rig->credit.find("Face Cap model by Bannaflak"), std::string::npos);
  EXPECT_EQ(FindShape(rig.value(), "mouthSmileLeft"), FindShape(rig.value(), "mouthSmile_L"));
  EXPECT_GE(FindShape(rig.value(), "mouthSmileLeft"), 0);
}

struct Evaluated {
  Rig rig;
  std::vector<float> weights;
  BlendedRig blended;
};

Evaluated Evaluate(const std::string& path, std::vector<float> w) {
  Evaluated e{formats::LoadRigFile(path).value(), std::move(w), {}};
  BlendContext ctx;
  EXPECT_TRUE(EvaluateRig(e.rig, e.weights, {}, e.blended, ctx).ok());
  return e;
}

TEST(Export, JsonShapeAndDeterminism) {
  auto e = Evaluate(test::RealAsset("MorphStressTest/MorphStressTest.gltf"),
                    {0.5f, 0, 0, 0, 0, 0, 0, 0.25f});
  std::vector<Warning> warn = {{"extrapolation", "x", "", 1.5, true}};
  auto a = ExportMesh(e.rig, e.blended, e.weights, warn, formats::MeshFormat::kJson);
  auto b = ExportMesh(e.rig, e.blended, e.weights, warn, formats::MeshFormat::kJson);
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
    EXPECT_EQ(j["primitives"][0]["positions"][i].get<float>(),
              e.blended.primitives[0].positions[i]);
  }
}

TEST(Export, GlbRoundTripKeepsBlendHierarchyAndMaterials) {
  auto e = Evaluate(test::RealAsset("FaceCap/facecap.glb"), std::vector<float>(52, 0.0f));
  e.weights[24] = 0.9f;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(e.rig, e.weights, {}, e.blended, ctx).ok());
  auto glb = ExportMesh(e.rig, e.blended, e.weights, {}, formats::MeshFormat::kGlb);
  ASSERT_TRUE(glb.ok());
  std::vector<unsigned char> bytes(glb->begin(), glb->end());
  auto back = formats::LoadGltfMemory(bytes, "", {.allow_external_files = false});
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
  auto e = Evaluate(test::RealAsset("MorphStressTest/MorphStressTest.gltf"),
                    std::vector<float>(8, 0.0f));
  ASSERT_FALSE(e.rig.materials.empty());
  Material& m = e.rig.materials[0];
  // Its occlusion map is on TEXCOORD_1, which is not kept: said, not silent.
  EXPECT_EQ(m.occlusion_image, -1);
  const auto dropped =
      std::find_if(e.rig.load_warnings.begin(), e.rig.load_warnings.end(),
                   [](const Warning& w) { return w.code == "material_map_dropped"; });
  ASSERT_NE(dropped, e.rig.load_warnings.end());
  EXPECT_NE(dropped->message.find("occlusion map is on TEXCOORD_1"), std::string::npos)
      << dropped->message;
  ASSERT_GE(m.base_color_image, 0);
  m.normal_image = m.metallic_roughness_image = m.emissive_image = m.occlusion_image =
      m.base_color_image;
  m.normal_scale = 0.75f;
  m.occlusion_strength = 0.5f;
  m.emissive_factor = {0.25f, 0.5f, 1.0f};
  auto glb = ExportMesh(e.rig, e.blended, e.weights, {}, formats::MeshFormat::kGlb);
  ASSERT_TRUE(glb.ok()) << glb.status().message;
  std::vector<unsigned char> bytes(glb->begin(), glb->end());
  auto back = formats::LoadGltfMemory(bytes, "", {.allow_external_files = false});
  ASSERT_TRUE(back.ok()) << back.status().message;
  const Material& b = back->materials[0];
  ASSERT_GE(b.normal_image, 0);
  EXPECT_EQ(back->images[static_cast<size_t>(b.normal_image)].bytes,
            e.rig.images[static_cast<size_t>(m.normal_image)].bytes);
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
  auto e = Evaluate(test::RealAsset("MorphStressTest/MorphStressTest.gltf"),
                    {0.5f, 0, 0.3f, 0, 0, 0, 0, 0.25f});
  auto glb = ExportMesh(e.rig, e.blended, e.weights, {}, formats::MeshFormat::kGlb,
                        {.keep_targets = true});
  ASSERT_TRUE(glb.ok());
  std::vector<unsigned char> bytes(glb->begin(), glb->end());
  auto back = formats::LoadGltfMemory(bytes, "", {.allow_external_files = false});
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
    EXPECT_EQ(back->primitives[p].targets[0].indices, e.rig.primitives[p].targets[0].indices)
        << "sparse kept sparse";
  }
}

TEST(Export, ObjAndF32InWorldSpace) {
  auto e = Evaluate(test::RealAsset("FaceCap/facecap_decoded.glb"), std::vector<float>(52, 0.0f));
  auto obj = ExportMesh(e.rig, e.blended, e.weights, {}, formats::MeshFormat::kObj);
  auto f32 = ExportMesh(e.rig, e.blended, e.weights, {}, formats::MeshFormat::kF32);
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
  for (size_t at = obj->find("\nf "); at != std::string::npos; at = obj->find("\nf ", at + 1))
    ++faces;
  EXPECT_EQ(faces, e.rig.triangle_count());
  // OBJ round trip through our own reader: same vertex count and triangles.
  TempDir dir;
  test::WriteBytes(dir / "out.obj", obj.value());
  auto back = formats::LoadRigFile(dir / "out.obj");
  ASSERT_TRUE(back.ok()) << back.status().message;
  EXPECT_EQ(back->vertex_count(), e.rig.vertex_count());
  EXPECT_EQ(back->triangle_count(), e.rig.triangle_count());
}

// f32 is written in blocks (positions and normals a block at a time, normals four at a time):
// bit for bit the per-vertex TransformPoint and NormalMatrix::Apply, under a mirroring, rotating,
// scaling, moving node, for counts that are no multiple of 4 or 64, a zero normal kept as it is.
TEST(Export, F32BlocksGiveTheVertexByVertexBits) {
  for (size_t count : {1u, 5u, 67u, 130u}) {
    Rig rig;
    rig.primitives.resize(1);
    BlendedRig blended;
    blended.primitives.resize(1);
    BlendedPrimitive& b = blended.primitives[0];
    b.world = {0.0f, -2.5f, 0.0f,  0, 0.3f, 0.0f,  0.1f, 0,
               0.0f, 0.2f,  -1.7f, 0, 4.0f, -5.0f, 6.5f, 1};
    uint32_t state = 7;
    auto next = [&state] {
      state = state * 1664525u + 1013904223u;
      return static_cast<float>(state >> 8) / 8388608.0f - 1.0f;
    };
    for (size_t i = 0; i < 3 * count; ++i) {
      b.positions.push_back(100.0f * next());
      b.normals.push_back(next());
    }
    if (count > 3) std::fill(b.normals.begin() + 9, b.normals.begin() + 12, 0.0f);
    auto f32 = ExportMesh(rig, blended, {}, {}, formats::MeshFormat::kF32);
    ASSERT_TRUE(f32.ok());
    ASSERT_EQ(f32->size(), count * 24);
    std::vector<float> expected(6 * count);
    const NormalMatrix nm(b.world.data(), 4);
    for (size_t v = 0; v < count; ++v) {
      TransformPoint(b.world, &b.positions[3 * v], &expected[3 * v]);
      nm.Apply(&b.normals[3 * v], &expected[3 * (count + v)]);
    }
    EXPECT_EQ(std::memcmp(f32->data(), expected.data(), f32->size()), 0) << count << " vertices";
    if (count > 3) {
      EXPECT_EQ(expected[3 * count + 9], 0.0f) << "a zero normal stays zero";
    }
  }
}

// ApplyMany with unit_first (F32Writer's pass: a moved vertex's blended normal scaled to unit
// length, then placed): bit for bit Normalize3 then Apply for the marked normals and Apply alone
// for the rest, four at a time and in the tail, with zero, tiny, huge and NaN normals among them.
TEST(Export, UnitFirstNormalsAreNormalize3ThenApply) {
  const float m[16] = {0.0f, -2.5f, 0.0f,  0, 0.3f, 0.0f,  0.1f, 0,
                       0.0f, 0.2f,  -1.7f, 0, 4.0f, -5.0f, 6.5f, 1};
  const NormalMatrix nm(m, 4);
  uint32_t state = 3;
  auto next = [&state] {
    state = state * 1664525u + 1013904223u;
    return state;
  };
  for (size_t count : {1u, 7u, 61u, 64u}) {
    std::vector<float> n(3 * count);
    for (float& f : n)
      f = static_cast<float>(next() >> 8) / 4194304.0f - 2.0f;  // [-2, 2): rarely unit length.
    if (count > 4) {
      std::fill(n.begin() + 3, n.begin() + 6, 0.0f);     // zero: kept
      std::fill(n.begin() + 6, n.begin() + 9, 1e-31f);   // length under 1e-30: kept
      n[9] = std::numeric_limits<float>::quiet_NaN();    // NaN: kept by both
      std::fill(n.begin() + 12, n.begin() + 15, 3e18f);  // huge
    }
    const uint64_t bits =
        (uint64_t{next()} << 32 | next()) | 0x1e;  // The odd normals are all marked.
    std::vector<float> got(3 * count), want(3 * count);
    nm.ApplyMany(n.data(), count, got.data(), bits);
    int unit = 0;
    for (size_t v = 0; v < count; ++v) {
      float t[3] = {n[3 * v], n[3 * v + 1], n[3 * v + 2]};
      if (bits >> v & 1) {
        Normalize3(t);
        ++unit;
      }
      nm.Apply(t, &want[3 * v]);
    }
    EXPECT_EQ(std::memcmp(got.data(), want.data(), got.size() * 4), 0)
        << count << " normals, " << unit << " marked";
    // And the marks matter: without them the bits differ wherever a marked normal is not unit
    // length.
    std::vector<float> plain(3 * count);
    nm.ApplyMany(n.data(), count, plain.data());
    if (count > 4) {
      EXPECT_NE(std::memcmp(plain.data(), want.data(), plain.size() * 4), 0) << count;
    }
  }
}

// The mesh route's f32 writer gives EvaluateRig + ExportMesh(kF32)'s bytes exactly: FaceCap
// (one morphed primitive of four, a moved and scaled node) and the morph test assets, at rest,
// at random points of several shapes, with extrapolated and negative weights, in world and mesh
// space; then what it must decline (a point whose shape has no normal deltas, a skinned rig).
TEST(F32Writer, WritesExportMeshBytes) {
  uint32_t state = 11;
  auto next = [&state] {
    state = state * 1664525u + 1013904223u;
    return static_cast<float>(state >> 8) / 8388608.0f;  // [0, 2)
  };
  int points = 0, written = 0;
  for (const char* asset : {"FaceCap/facecap_decoded.glb", "MorphStressTest/MorphStressTest.gltf",
                            "MorphPrimitivesTest/MorphPrimitivesTest.gltf",
                            "AnimatedMorphSphere/AnimatedMorphSphere.gltf"}) {
    auto rig = formats::LoadRigFile(test::RealAsset(asset));
    ASSERT_TRUE(rig.ok()) << asset << ": " << rig.status().message;
    ASSERT_TRUE(SparseBlend::Serves(rig.value(), {})) << asset;
    for (bool mesh_space : {false, true}) {
      const formats::F32Writer writer(rig.value(), mesh_space);
      formats::F32Writer::Scratch scratch;
      BlendedRig blended;
      BlendContext ctx;
      std::string body;
      std::vector<float> w(rig->shapes.size(), 0.0f);
      for (int point = 0; point < 12; ++point) {
        if (point > 0) {
          std::fill(w.begin(), w.end(), 0.0f);
          for (int k = 0; k < 1 + point % 5; ++k)
            w[static_cast<size_t>(next() * 1000) % w.size()] =
                point % 4 == 3 ? 1.0f - 2.0f * next() : 0.5f * next();
        }
        ASSERT_TRUE(EvaluateRig(rig.value(), w, {}, blended, ctx).ok());
        auto want = ExportMesh(rig.value(), blended, w, {}, formats::MeshFormat::kF32,
                               {.mesh_space = mesh_space});
        ASSERT_TRUE(want.ok());
        // Served unless an active target has no normal deltas (MorphPrimitivesTest's have none).
        bool recomputed = false;
        for (const Mesh& m : rig->meshes) {
          for (int pi : m.primitives) {
            const Primitive& p = rig->primitives[pi];
            for (size_t t = 0; t < p.targets.size(); ++t) {
              recomputed |= w[m.target_shapes[t]] != 0.0f &&
                            p.targets[t].normal_deltas.size() != 3 * p.targets[t].indices.size();
            }
          }
        }
        ++points;
        if (!writer.Write(rig.value(), w, scratch, body)) {
          EXPECT_TRUE(recomputed) << asset << " point " << point << " declined";
          continue;
        }
        EXPECT_FALSE(recomputed) << asset << " point " << point;
        ++written;
        ASSERT_EQ(body.size(), want->size());
        EXPECT_EQ(std::memcmp(body.data(), want->data(), body.size()), 0)
            << asset << " point " << point << (mesh_space ? " mesh" : " world");
      }
      // The body is written over whole: the rest again, into the last point's body, is the rest's
      // bytes.
      const std::vector<float> zero(w.size(), 0.0f);
      ASSERT_TRUE(EvaluateRig(rig.value(), zero, {}, blended, ctx).ok());
      auto rest = ExportMesh(rig.value(), blended, zero, {}, formats::MeshFormat::kF32,
                             {.mesh_space = mesh_space});
      ASSERT_TRUE(rest.ok());
      ASSERT_TRUE(writer.Write(rig.value(), zero, scratch, body));
      EXPECT_TRUE(body == rest.value()) << asset << " at rest after a point";
      EXPECT_FALSE(writer.Write(rig.value(), std::vector<float>(w.size() + 1, 0.0f), scratch, body))
          << "weights of another rig";
      std::vector<float> nan(w.size(), 0.0f);
      nan[0] = std::nanf("");
      EXPECT_FALSE(writer.Write(rig.value(), nan, scratch, body));
    }
  }
  EXPECT_GT(written, points / 2) << written << " of " << points << " points written";
  // A target without normal deltas: the blend recomputes normals there, so the writer declines
  // when (only when) that target is active.
  auto face = formats::LoadRigFile(test::RealAsset("FaceCap/facecap_decoded.glb"));
  ASSERT_TRUE(face.ok());
  Rig rig = face.value();
  size_t shape = SIZE_MAX;
  for (Primitive& p : rig.primitives) {
    for (size_t t = 0; t < p.targets.size() && shape == SIZE_MAX; ++t) {
      p.targets[t].normal_deltas.clear();
      for (const Mesh& m : rig.meshes) {
        if (!m.target_shapes.empty() && &rig.primitives[m.primitives[0]] == &p)
          shape = m.target_shapes[t];
      }
    }
  }
  ASSERT_NE(shape, SIZE_MAX);
  const formats::F32Writer writer(rig, false);
  formats::F32Writer::Scratch scratch;
  std::string body;
  std::vector<float> w(rig.shapes.size(), 0.0f);
  w[(shape + 1) % w.size()] = 0.5f;
  EXPECT_TRUE(writer.Write(rig, w, scratch, body));
  w[shape] = 0.5f;
  EXPECT_FALSE(writer.Write(rig, w, scratch, body));
  // Skinned, posed, recomputed normals: not served.
  auto skinned = formats::LoadRigFile(test::RealAsset("CesiumMan/CesiumMan.gltf"));
  ASSERT_TRUE(skinned.ok());
  EXPECT_FALSE(SparseBlend::Serves(skinned.value(), {}));
  EXPECT_FALSE(
      formats::F32Writer(skinned.value(), false)
          .Write(skinned.value(), std::vector<float>(skinned->shapes.size(), 0.0f), scratch, body));
  Pose pose;
  EXPECT_FALSE(SparseBlend::Serves(face.value(), {.pose = &pose}));
  EXPECT_FALSE(SparseBlend::Serves(face.value(), {.normals = NormalMode::kRecompute}));
}

// The batch's glb writer gives ExportMesh's bytes exactly, variant after variant: FaceCap with
// and without warnings (extrapolation), CesiumMan posed by its clip at several times (skinned
// positions, every node's matrix), then the same CesiumMan at rest (another shape: the template
// is made again), and a rig's export with keep_targets.
TEST(GlbVariantWriter, WritesExportMeshBytes) {
  auto joined = [](const formats::GlbVariantWriter::Pieces& p) {
    return std::string(p.head) + std::string(p.bin);
  };
  formats::GlbVariantWriter writer;
  auto face = formats::LoadRigFile(test::RealAsset("FaceCap/facecap_decoded.glb"));
  ASSERT_TRUE(face.ok());
  BlendedRig out;
  BlendContext ctx;
  size_t patched = 0;
  for (int i = 0; i < 6; ++i) {
    std::vector<float> w(face->shapes.size(), 0.0f);
    for (size_t k = static_cast<size_t>(i); k < w.size(); k += 7)
      w[k] = 0.1f * static_cast<float>(i + k % 5);
    const WeightReport report = CheckWeights(face.value(), w, BlendMode::kRelative);
    ASSERT_TRUE(EvaluateRig(face.value(), w, {}, out, ctx).ok());
    auto expected = ExportMesh(face.value(), out, w, report.warnings, formats::MeshFormat::kGlb);
    auto pieces = writer.Write(face.value(), out, w, report.warnings);
    ASSERT_TRUE(expected.ok() && pieces.ok());
    ASSERT_EQ(joined(pieces.value()), expected.value())
        << "variant " << i << ", " << report.warnings.size() << " warnings";
    patched += !pieces->bin.empty();
  }
  EXPECT_EQ(patched, 5u) << "the first variant makes the template, the others patch it";

  auto man = formats::LoadGltfFile(test::RealAsset("CesiumMan/CesiumMan.gltf"));
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
    auto expected = ExportMesh(man.value(), out, none, {}, formats::MeshFormat::kGlb);
    auto pieces = writer.Write(man.value(), out, none, {});
    ASSERT_TRUE(expected.ok() && pieces.ok());
    ASSERT_EQ(joined(pieces.value()), expected.value()) << "CesiumMan at " << time;
  }
  auto rig_itself = writer.Write(man.value(), out, none, {}, {.keep_targets = true});
  ASSERT_TRUE(rig_itself.ok());
  EXPECT_EQ(
      joined(rig_itself.value()),
      ExportMesh(man.value(), out, none, {}, formats::MeshFormat::kGlb, {.keep_targets = true})
          .value());
}

}  // namespace io_test
}  // namespace facespace
