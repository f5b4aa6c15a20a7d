// COLLADA (../shared/assets/more/Collada): the conformance files' morphs give the shapes the
// spec's formulas give from the raw numbers (copied here from the file text), the skins sit at
// their bind shape at rest, the animated weight passes through its keys; then hostile files.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "facespace/engine/animation.h"
#include "facespace/engine/blend.h"
#include "facespace/formats/io.h"
#include "test_util.h"
#include "world.h"

namespace facespace {
namespace collada_test {  // Named: core_tests is a unity build, its files share one unit.

std::string Dae(const std::string& rel) { return test::SharedAssets() + "/more/Collada/" + rel; }

std::string Text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// The numbers of the element with id="`id`" in the file text.
std::vector<double> ArrayById(const std::string& text, const std::string& id) {
  const size_t at = text.find("id=\"" + id + "\"");
  const size_t open = text.find('>', at) + 1, close = text.find('<', open);
  std::istringstream s(text.substr(open, close - open));
  std::vector<double> out;
  for (double v; s >> v;) out.push_back(v);
  return out;
}

Rig Load(const std::string& path) {
  Result<Rig> rig = formats::LoadRigFile(path);
  EXPECT_TRUE(rig.ok()) << path << ": " << rig.status().message;
  return rig.ok() ? std::move(rig.value()) : Rig{};
}

// World positions of every vertex, weights as given (default: the rig's defaults).
std::vector<float> World(const Rig& rig, std::vector<float> w = {}, const Pose* pose = nullptr) {
  if (w.empty()) {
    for (const Shape& s : rig.shapes) w.push_back(s.default_weight);
  }
  return test::WorldOf(rig, w, pose);
}

// True when every point of `want` is within `tol` of a vertex of `got` (vertices split per corner).
bool Covers(const std::vector<float>& got, const std::vector<std::array<double, 3>>& want,
            double tol) {
  for (const auto& p : want) {
    double best = 1e30;
    for (size_t v = 0; v + 2 < got.size(); v += 3)
      best = std::min(best, std::hypot(got[v] - p[0], got[v + 1] - p[1], got[v + 2] - p[2]));
    if (best > tol) return false;
  }
  return true;
}

// The Khronos test's two-target morph of one file: the rig, and the base's and targets' positions
// as the file writes them; its shapes' default weights are the file's.
struct TwoTargets {
  Rig rig;
  std::vector<double> base, t1, t2;
};
TwoTargets LoadTwoTargets(const std::string& file, float w1, float w2) {
  const std::string path = Dae("CTS_morph_two_targets/" + file);
  TwoTargets m{Load(path), {}, {}, {}};
  EXPECT_EQ(m.rig.shapes.size(), 2u);
  if (m.rig.shapes.size() == 2) {
    EXPECT_FLOAT_EQ(m.rig.shapes[0].default_weight, w1);
    EXPECT_FLOAT_EQ(m.rig.shapes[1].default_weight, w2);
  }
  const std::string text = Text(path);
  m.base = ArrayById(text, "pCubeShape3-positions-array");
  m.t1 = ArrayById(text, "pCubeShape1-positions-array");
  m.t2 = ArrayById(text, "pCubeShape2-positions-array");
  return m;
}

TEST(Collada, NormalizedMorphIsTheWeightedSumOfTargetsAndBase) {
  const auto [rig, base, t1, t2] = LoadTwoTargets("morph_two_targets.dae", 0.5f, 1.0f);
  ASSERT_EQ(base.size(), 15u);
  // (1 - 0.5 - 1) base + 0.5 t1 + 1 t2, then the node: translate (0, -50, 0), scale 3.
  std::vector<std::array<double, 3>> want;
  for (size_t v = 0; v < 5; ++v) {
    std::array<double, 3> p;
    for (int c = 0; c < 3; ++c)
      p[c] =
          3 * (-0.5 * base[3 * v + c] + 0.5 * t1[3 * v + c] + t2[3 * v + c]) + (c == 1 ? -50 : 0);
    want.push_back(p);
  }
  EXPECT_TRUE(Covers(World(rig), want, 1e-3));
  EXPECT_NEAR(want[4][1], 100.0, 1e-9);  // The apex: 0.5 x -100 + 100, scaled by 3, moved down 50.
}

TEST(Collada, RelativeMorphAddsTheWeightedTargetsAsGiven) {
  const auto [rig, base, t1, t2] = LoadTwoTargets("morph_two_targets_relative.dae", 0.5f, 0.25f);
  ASSERT_EQ(base.size(), 15u);
  // COLLADA 1.4.1: RELATIVE is base + w1 t1 + w2 t2 (the targets as given); then the node's
  // translate (0, 20, 0) and scale 2. At the file's weights the square grows by 1 + 0.5 + 0.25.
  for (const std::array<float, 2> w :
       {std::array<float, 2>{0.5f, 0.25f}, {1.0f, 0.0f}, {0.0f, 1.0f}}) {
    std::vector<std::array<double, 3>> want;
    for (size_t v = 0; v < 5; ++v) {
      std::array<double, 3> p;
      for (int c = 0; c < 3; ++c)
        p[c] =
            2 * (base[3 * v + c] + w[0] * t1[3 * v + c] + w[1] * t2[3 * v + c]) + (c == 1 ? 20 : 0);
      want.push_back(p);
    }
    EXPECT_TRUE(Covers(World(rig, {w[0], w[1]}), want, 1e-3)) << w[0] << " " << w[1];
  }
  // A corner of the square: (-25, 0, 25) x 1.75, scaled 2, moved up 20.
  EXPECT_TRUE(Covers(World(rig), {{2 * -25 * 1.75, 20, 2 * 25 * 1.75}}, 1e-3));
}

TEST(Collada, SkinOverMorphBlendsThenSkins) {
  const std::string path = Dae("CTS_skin_on_morph/skin_on_morph.dae");
  const Rig rig = Load(path);
  ASSERT_EQ(rig.shapes.size(), 1u);
  ASSERT_EQ(rig.skins.size(), 1u);
  EXPECT_EQ(rig.skins[0].joints.size(), 2u);
  const std::string text = Text(path);
  const auto g0 = ArrayById(text, "geometries_0-Pos-array"),
             g1 = ArrayById(text, "geometries_1-Pos-array");
  ASSERT_EQ(g0.size(), 18u);
  // From the file: bind shape matrix identity; joint "null" rests where its inverse bind binds it
  // (z = -4), "null1" sits 4 further along x than its bind (world (4, 0, 4), bound at (0, 0, 4)),
  // so each vertex moves by its null1 weight x (4, 0, 0). Weights of null1 per vertex, from <v>:
  const double null1[6] = {0.003448, 0, 0.996552, 0.003448, 0, 0.996552};
  for (float w : {0.0f, 0.5f, 1.0f}) {
    std::vector<std::array<double, 3>> want;
    for (size_t v = 0; v < 6; ++v) {
      std::array<double, 3> p;
      for (int c = 0; c < 3; ++c)
        p[c] = (1 - w) * g0[3 * v + c] + w * g1[3 * v + c] + (c == 0 ? 4 * null1[v] : 0.0);
      want.push_back(p);
    }
    EXPECT_TRUE(Covers(World(rig, {w}), want, 1e-4)) << w;
  }
}

TEST(Collada, FourInfluenceSkinKeepsEveryInfluence) {
  const std::string path = Dae("CTS_skin_4_influence/skin_4_influence.dae");
  const Rig rig = Load(path);
  ASSERT_EQ(rig.skins.size(), 1u);
  EXPECT_EQ(rig.skins[0].joints.size(), 4u);
  ASSERT_EQ(rig.primitives.size(), 1u);
  const Primitive& p = rig.primitives[0];
  EXPECT_EQ(p.influences, 4u);
  // Every vertex has 4 influences (<vcount> is all 4s) whose weights sum to 1.
  size_t full = 0;
  for (size_t v = 0; v < p.vertex_count(); ++v) {
    float sum = 0;
    int nonzero = 0;
    for (size_t k = 0; k < 4; ++k) {
      sum += p.joint_weights[4 * v + k];
      nonzero += p.joint_weights[4 * v + k] > 0;
    }
    EXPECT_NEAR(sum, 1.0f, 1e-5);
    full += nonzero == 4;
  }
  EXPECT_GT(full, p.vertex_count() / 2);
  // The rest pose evaluates to finite positions.
  for (float v : World(rig)) ASSERT_TRUE(std::isfinite(v));
}

// The weight curve of SCEA_animation_morph, evaluated here from the file's numbers: per segment the
// cubic Bezier through (t_k, v_k), the key's out-tangent, the next key's in-tangent, (t_k+1,
// v_k+1), time as the curve's x (its parameter found by bisection), then y.
double FileCurve(double x) {
  const double t[] = {0.041666, 0.416667, 0.833333}, v[] = {0, 1, -0.5};
  const double in[] = {-0.291667, -0.888889, 0.291667, 1.07895, 0.694444, 0};
  const double out[] = {0.166667, 0.333333, 0.555556, 0.912281, 1.16667, -1.7};
  if (x <= t[0]) return v[0];
  if (x >= t[2]) return v[2];
  const int k = x < t[1] ? 0 : 1;
  const auto at = [](double a, double b, double c, double d, double s) {
    return (1 - s) * (1 - s) * (1 - s) * a + 3 * (1 - s) * (1 - s) * s * b +
           3 * (1 - s) * s * s * c + s * s * s * d;
  };
  double lo = 0, hi = 1;
  for (int i = 0; i < 80; ++i) {
    const double s = (lo + hi) / 2;
    (at(t[k], out[2 * k], in[2 * k + 2], t[k + 1], s) < x ? lo : hi) = s;
  }
  return at(v[k], out[2 * k + 1], in[2 * k + 3], v[k + 1], (lo + hi) / 2);
}

TEST(Collada, AnimatedMorphWeightFollowsItsBezierCurve) {
  const Rig rig = Load(Dae("SCEA_animation_morph/animation_morph.dae"));
  ASSERT_EQ(rig.animations.size(), 1u);
  ASSERT_EQ(rig.shapes.size(),
            1u);  // The IDREF array names a second, missing target: the accessor says 1.
  const auto weight = [&](double time) {
    Pose pose = RestPose(rig);
    std::vector<float> w;
    std::vector<uint8_t> set;
    EXPECT_TRUE(SampleClip(rig, 0, static_cast<float>(time), ClipWrap::kClamp, pose, w, set).ok());
    return w.empty() ? NAN : w[0];
  };
  // At its keys, its values; between them, the curve (every 1/240 s, and mid-segment).
  EXPECT_NEAR(weight(0.416667), 1.0, 1e-6);
  EXPECT_NEAR(weight(0.041666), 0.0, 1e-6);
  EXPECT_NEAR(weight(0.833333), -0.5, 1e-6);
  double worst = 0;
  for (double x = 0.0; x <= 0.9; x += 1.0 / 240)
    worst = std::max(worst, std::fabs(weight(x) - FileCurve(x)));
  EXPECT_LT(worst, 1e-5);
  EXPECT_NEAR(weight(0.229166), FileCurve(0.229166), 1e-5);
  EXPECT_GT(FileCurve(0.4),
            1.0);  // The curve overshoots its key, which no straight line between keys does.
  EXPECT_NEAR(weight(0.4), FileCurve(0.4), 1e-5);
}

// ---- hostile ----

std::string Doc(const std::string& geometry_body, const std::string& extra = "",
                const std::string& scene = "") {
  return "<?xml version=\"1.0\"?><COLLADA version=\"1.4.1\"><library_geometries><geometry "
         "id=\"g\"><mesh>"
         "<source id=\"p\"><float_array id=\"pa\" count=\"9\">0 0 0 1 0 0 0 1 0</float_array>"
         "<technique_common><accessor source=\"#pa\" count=\"3\" "
         "stride=\"3\"/></technique_common></source>"
         "<vertices id=\"v\"><input semantic=\"POSITION\" source=\"#p\"/></vertices>" +
         geometry_body + "</mesh></geometry></library_geometries>" + extra +
         "<library_visual_scenes><visual_scene id=\"s\"><node id=\"n\"><instance_geometry "
         "url=\"#g\"/></node>" +
         scene +
         "</visual_scene></library_visual_scenes><scene><instance_visual_scene "
         "url=\"#s\"/></scene></COLLADA>";
}

Result<Rig> LoadText(const std::string& text) {
  return formats::LoadColladaMemory(
      std::span<const unsigned char>(reinterpret_cast<const unsigned char*>(text.data()),
                                     text.size()),
      "t");
}

void ExpectError(const std::string& text, const std::string& needle) {
  const Result<Rig> rig = LoadText(text);
  ASSERT_FALSE(rig.ok()) << needle;
  EXPECT_NE(rig.status().message.find(needle), std::string::npos) << rig.status().message;
}

TEST(ColladaHostile, AWellFormedTriangleLoads) {
  const Result<Rig> rig =
      LoadText(Doc("<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" "
                   "offset=\"0\"/><p>0 1 2</p></triangles>"));
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  EXPECT_EQ(rig->triangle_count(), 1u);
}

TEST(ColladaHostile, BrokenFilesNameWhatIsWrong) {
  ExpectError("<COLLADA><library_geometries>", "not well-formed XML");
  ExpectError(Doc("<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" "
                  "offset=\"0\"/><p>0 1 99</p></triangles>"),
              "<geometry id=\"g\">: corner 2 uses vertex 99 of 3");
  ExpectError(Doc("<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" "
                  "offset=\"0\"/><p>0 1</p></triangles>"),
              "the polygons need");
  ExpectError(Doc("<polylist count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" "
                  "offset=\"0\"/><vcount>5</vcount><p>0 1 2</p></polylist>"),
              "<p> holds 3 indices, the polygons need 5");
  ExpectError(Doc("<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" "
                  "offset=\"0\"/><p>0 1 nan</p></triangles>"),
              "not a number");
  std::string lying =
      Doc("<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><p>0 1 "
          "2</p></triangles>");
  lying.replace(lying.find("count=\"3\""), 9, "count=\"30\"");
  ExpectError(lying, "its accessor reads 30 x 3 values of 9");
}

TEST(ColladaHostile, InstanceNodeCyclesAndBadSkinsAreRefused) {
  const std::string tri =
      "<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><p>0 1 "
      "2</p></triangles>";
  ExpectError(Doc(tri,
                  "<library_nodes><node id=\"a\"><instance_node url=\"#b\"/></node><node "
                  "id=\"b\"><instance_node url=\"#a\"/></node></library_nodes>",
                  "<node id=\"c\"><instance_node url=\"#a\"/></node>"),
              "nested deeper than 128");
  const std::string skin =
      "<library_controllers><controller id=\"k\"><skin source=\"#g\">"
      "<source id=\"j\"><Name_array id=\"ja\" "
      "count=\"1\">n</Name_array><technique_common><accessor source=\"#ja\" "
      "count=\"1\"/></technique_common></source>"
      "<source id=\"m\"><float_array id=\"ma\" count=\"16\">1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 "
      "1</float_array><technique_common><accessor source=\"#ma\" count=\"1\" "
      "stride=\"16\"/></technique_common></source>"
      "<source id=\"w\"><float_array id=\"wa\" "
      "count=\"1\">1</float_array><technique_common><accessor source=\"#wa\" "
      "count=\"1\"/></technique_common></source>"
      "<joints><input semantic=\"JOINT\" source=\"#j\"/><input semantic=\"INV_BIND_MATRIX\" "
      "source=\"#m\"/></joints>"
      "<vertex_weights count=\"3\"><input semantic=\"JOINT\" source=\"#j\" offset=\"0\"/><input "
      "semantic=\"WEIGHT\" source=\"#w\" offset=\"1\"/>"
      "<vcount>1 1 1</vcount><v>0 0 0 0 "
      "JOINT</v></vertex_weights></skin></controller></library_controllers>";
  std::string doc = Doc(tri, skin);
  doc.replace(doc.find("<instance_geometry url=\"#g\"/>"), 29, "<instance_controller url=\"#k\"/>");
  std::string fixed = doc;
  fixed.replace(fixed.find("JOINT</v>"), 9, "5 0</v>");
  ExpectError(fixed, "names joint 5 of 1");
  // Numbers too large for any integer are named as written, not cast (UBSan, found by fuzz_dae).
  fixed = doc;
  fixed.replace(fixed.find("JOINT</v>"), 9, "7.77778e+65 0</v>");
  ExpectError(fixed, "names joint 7.77778e+65 of 1");
  fixed = doc;
  fixed.replace(fixed.find("JOINT</v>"), 9, "0 0</v>");
  fixed.replace(fixed.find("<vcount>1 1 1</vcount>"), 22, "<vcount>1 1e30 1</vcount>");
  ExpectError(fixed, "vertex 1 has 1e+30 influences");
  fixed = doc;
  fixed.replace(fixed.find("JOINT</v>"), 9, "0 0</v>");
  fixed.replace(fixed.find(">n</Name_array>"), 15, ">q</Name_array>");
  ExpectError(fixed, "joint 'q' is no node of the scene");
  fixed.replace(fixed.find("<node id=\"n\">"), 13, "<node id=\"n\" sid=\"q\">");
  const Result<Rig> rig = LoadText(fixed);
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  EXPECT_EQ(rig->skins.size(), 1u);
}

TEST(ColladaHostile, NamesThatAreNotUtf8AreRepairedAndExportable) {
  // A node and a geometry named with stray bytes (Latin-1, a cut sequence): the glb writer's JSON
  // took them as they were and threw (found by fuzz_dae).
  std::string doc =
      Doc("<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><p>0 1 "
          "2</p></triangles>");
  doc.replace(doc.find("<node id=\"n\">"), 13, "<node id=\"n\" name=\"caf\xE9 \xE2\x82\">");
  doc.replace(doc.find("<geometry id=\"g\">"), 17, "<geometry id=\"g\" name=\"\xFFhead\">");
  const Result<Rig> rig = LoadText(doc);
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  bool warned = false;
  for (const Warning& w : rig->load_warnings) warned |= w.code == "names_repaired";
  EXPECT_TRUE(warned);
  for (const Node& node : rig->nodes) {
    std::string copy = node.name;
    EXPECT_FALSE(RepairUtf8(copy)) << node.name;
  }
  for (const Mesh& mesh : rig->meshes) {
    std::string copy = mesh.name;
    EXPECT_FALSE(RepairUtf8(copy)) << mesh.name;
  }
  BlendedRig blended;
  BlendContext context;
  ASSERT_TRUE(EvaluateRig(rig.value(), {}, {}, blended, context).ok());
  const auto glb = ExportMesh(rig.value(), blended, {}, {}, formats::MeshFormat::kGlb);
  ASSERT_TRUE(glb.ok()) << glb.status().message;
  EXPECT_NE(glb->find("\xEF\xBF\xBD"), std::string::npos);  // U+FFFD where the stray bytes were.
}

TEST(Utf8, RepairReplacesWhatIsNotUtf8AndKeepsWhatIs) {
  auto repaired = [](std::string s) {
    RepairUtf8(s);
    return s;
  };
  std::string ok = "abc \xC3\xA9 \xE3\x81\x82 \xF0\x9F\x98\x80";  // a, é, あ, an emoji
  EXPECT_FALSE(RepairUtf8(ok));
  EXPECT_EQ(repaired("caf\xE9"), "caf\xEF\xBF\xBD");            // Latin-1
  EXPECT_EQ(repaired("\xE3\x81"), "\xEF\xBF\xBD\xEF\xBF\xBD");  // cut short
  EXPECT_EQ(repaired("\xC0\xAF"), "\xEF\xBF\xBD\xEF\xBF\xBD");  // overlong '/'
  EXPECT_EQ(repaired("\xED\xA0\x80x"),
            "\xEF\xBF\xBD\xEF\xBF\xBD\xEF\xBF\xBDx");  // a UTF-16 surrogate
  EXPECT_EQ(
      repaired("\xF4\x90\x80\x80"),
      std::string(4 * 3, ' ')
          .replace(0, 12, "\xEF\xBF\xBD\xEF\xBF\xBD\xEF\xBF\xBD\xEF\xBF\xBD"));  // past U+10FFFF
}

// A triangle with UVs and a textured material, its image given three ways (COLLADA 1.4's sampler
// and surface params; 1.5's instance_image; an absolute path on the author's disk), read from the
// model's folder; a path out of the folder is not read.
std::string TexturedDoc(const std::string& image_uri, bool v15) {
  const std::string sampler =
      v15 ? "<newparam sid=\"smp\"><sampler2D><instance_image url=\"#img\"/></sampler2D></newparam>"
          : "<newparam sid=\"srf\"><surface "
            "type=\"2D\"><init_from>img</init_from></surface></newparam>"
            "<newparam sid=\"smp\"><sampler2D><source>srf</source></sampler2D></newparam>";
  const std::string extra = "<library_images><image id=\"img\"><init_from>" +
                            std::string(v15 ? "<ref>" : "") + image_uri + (v15 ? "</ref>" : "") +
                            "</init_from></image></library_images>"
                            "<library_effects><effect id=\"fx\"><profile_COMMON>" +
                            sampler +
                            "<technique sid=\"t\"><lambert><diffuse><texture texture=\"smp\" "
                            "texcoord=\"UV0\"/></diffuse></lambert></technique>"
                            "</profile_COMMON></effect></library_effects>"
                            "<library_materials><material id=\"mat\"><instance_effect "
                            "url=\"#fx\"/></material></library_materials>";
  std::string doc =
      Doc("<source id=\"t\"><float_array id=\"ta\" count=\"6\">0 0 1 0 0 1</float_array>"
          "<technique_common><accessor source=\"#ta\" count=\"3\" "
          "stride=\"2\"/></technique_common></source>"
          "<triangles count=\"1\" material=\"m\"><input semantic=\"VERTEX\" source=\"#v\" "
          "offset=\"0\"/>"
          "<input semantic=\"TEXCOORD\" source=\"#t\" offset=\"0\"/><p>0 1 2</p></triangles>",
          extra);
  const std::string plain = "<instance_geometry url=\"#g\"/>";
  doc.replace(doc.find(plain), plain.size(),
              "<instance_geometry url=\"#g\"><bind_material><technique_common><instance_material "
              "symbol=\"m\" target=\"#mat\"/>"
              "</technique_common></bind_material></instance_geometry>");
  return doc;
}

TEST(Collada, DiffuseTexturesAreReadFromTheModelsFolder) {
  test::TempDir dir;
  std::filesystem::create_directories(dir.path / "model" / "tex");
  const std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + std::string(32, 'x');
  test::WriteBytes(dir / "model/tex/Checker.png", png);
  test::WriteBytes(dir / "secret.png", png);
  struct Case {
    std::string uri;
    bool v15;
    bool read;
  };
  for (const Case& c :
       {Case{"tex/Checker.png", false, true}, Case{"./tex/checker.PNG", true, true},
        Case{"tex/Checker%2Epng", false, true},
        Case{"file:///C:/Users/someone/art/Checker.png", false,
             false},  // Its file name, not beside the model.
        Case{"file:///home/someone/tex/Checker.png", true, false},
        Case{"../secret.png", false, false}, Case{"tex/../../secret.png", true, false}}) {
    test::WriteBytes(dir / "model/m.dae", TexturedDoc(c.uri, c.v15));
    const Result<Rig> rig = formats::LoadRigFile(dir / "model/m.dae");
    ASSERT_TRUE(rig.ok()) << c.uri << ": " << rig.status().message;
    ASSERT_EQ(rig->materials.size(), 1u) << c.uri;
    ASSERT_EQ(rig->materials[0].base_color_image, 0) << c.uri;
    EXPECT_EQ(rig->primitives[0].texcoords.size(), 6u);
    const bool read = !rig->images[0].bytes.empty();
    EXPECT_EQ(read, c.read) << c.uri;
    if (read) {
      EXPECT_EQ(rig->images[0].mime_type, "image/png");
      EXPECT_TRUE(rig->load_warnings.empty()) << rig->load_warnings[0].message;
    } else {
      ASSERT_FALSE(rig->load_warnings.empty()) << c.uri;
      EXPECT_EQ(rig->load_warnings[0].code, "texture_not_loaded");
      EXPECT_NE(rig->load_warnings[0].message.find("no such file in the model's folder"),
                std::string::npos)
          << rig->load_warnings[0].message;
    }
  }
  // An absolute path on the author's disk: its file name, found beside the model.
  test::WriteBytes(dir / "model/Checker.png", png);
  test::WriteBytes(dir / "model/m.dae",
                   TexturedDoc("file:///C:/Users/someone/art/Checker.png", false));
  const Result<Rig> beside = formats::LoadRigFile(dir / "model/m.dae");
  ASSERT_TRUE(beside.ok());
  EXPECT_FALSE(beside->images[0].bytes.empty());
  // From bytes (an upload) there is no folder: said so.
  const Result<Rig> bytes = LoadText(TexturedDoc("tex/Checker.png", false));
  ASSERT_TRUE(bytes.ok());
  ASSERT_FALSE(bytes->load_warnings.empty());
  EXPECT_NE(bytes->load_warnings[0].message.find("has no folder"), std::string::npos);
}

}  // namespace collada_test
}  // namespace facespace
