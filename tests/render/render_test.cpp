// Renders: analytic checks on built meshes, and goldens of the real assets compared with
// OpenImageIO's image comparison. FACESPACE_UPDATE_GOLDENS=1 rewrites the goldens (look at
// every one before committing it).
#include "facespace/offscreen/render.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <immintrin.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <thread>

#include "facespace/engine/face.h"
#include "facespace/engine/occlusion.h"
#include "facespace/engine/shape_tools.h"
#include "facespace/engine/skeleton.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace {

using picture::Image;
using picture::RenderOptions;

// One renderer for the tests, as the service keeps one for all its threads.
const offscreen::OsMesaRenderer& Gl() {
  static const offscreen::OsMesaRenderer renderer;
  return renderer;
}

// A rig from one triangle-list primitive (and its shapes).
Rig OnePrimitive(std::vector<float> positions, std::vector<uint32_t> indices,
                 std::vector<SparseTarget> targets = {}) {
  Rig rig;
  Primitive p;
  p.positions = std::move(positions);
  p.indices = std::move(indices);
  p.targets = std::move(targets);
  FinalizePrimitive(p);
  Mesh m;
  m.name = "m";
  m.primitives = {0};
  for (size_t t = 0; t < p.targets.size(); ++t) {
    m.target_shapes.push_back(static_cast<uint32_t>(t));
    rig.shapes.push_back(Shape{.name = "s" + std::to_string(t)});
  }
  rig.primitives.push_back(std::move(p));
  rig.meshes.push_back(m);
  rig.nodes.push_back(Node{.name = "n", .mesh = 0});
  rig.scene_roots = {0};
  EXPECT_TRUE(ValidateRig(rig).ok());
  return rig;
}

Rig UnitCube() {
  std::vector<float> pos;
  std::vector<uint32_t> idx;
  // Six faces with their own vertices (flat normals).
  const int faces[6][4][3] = {{{-1, -1, 1}, {1, -1, 1}, {1, 1, 1}, {-1, 1, 1}},
                              {{1, -1, -1}, {-1, -1, -1}, {-1, 1, -1}, {1, 1, -1}},
                              {{1, -1, 1}, {1, -1, -1}, {1, 1, -1}, {1, 1, 1}},
                              {{-1, -1, -1}, {-1, -1, 1}, {-1, 1, 1}, {-1, 1, -1}},
                              {{-1, 1, 1}, {1, 1, 1}, {1, 1, -1}, {-1, 1, -1}},
                              {{-1, -1, -1}, {1, -1, -1}, {1, -1, 1}, {-1, -1, 1}}};
  for (const auto& f : faces) {
    const uint32_t base = static_cast<uint32_t>(pos.size() / 3);
    for (const auto& v : f) pos.insert(pos.end(), {0.5f * v[0], 0.5f * v[1], 0.5f * v[2]});
    idx.insert(idx.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }
  return OnePrimitive(pos, idx);
}

BlendedRig Evaluate(const Rig& rig, std::vector<float> w = {}) {
  w.resize(rig.shapes.size(), 0.0f);
  BlendedRig out;
  BlendContext ctx;
  EXPECT_TRUE(EvaluateRig(rig, w, {}, out, ctx).ok());
  return out;
}

bool IsBackground(const Image& im, int x, int y, const std::array<float, 4>& bg_linear) {
  const float* p = &im.rgba[(static_cast<size_t>(y) * im.width + x) * 4];
  for (int c = 0; c < 4; ++c) {
    if (std::fabs(p[c] - bg_linear[c]) > 1e-4f) return false;
  }
  return true;
}

float Linear(float s) { return s <= 0.04045f ? s / 12.92f : std::pow((s + 0.055f) / 1.055f, 2.4f); }
float Srgb(float c) {
  c = std::clamp(c, 0.0f, 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

RenderOptions HeadOn(int size) {
  RenderOptions o;
  o.width = o.height = size;
  o.background = {0.2f, 0.4f, 0.6f, 1.0f};
  o.camera.look_at = true;
  o.camera.eye = {0, 0, 3};
  o.camera.target = {0, 0, 0};
  o.camera.fov = 30;
  return o;
}

TEST(Render, ReportsLlvmpipe) {
  const std::string info = Gl().Info();
  EXPECT_NE(info.find("llvmpipe"), std::string::npos) << info;
  EXPECT_EQ(info.find("softpipe"), std::string::npos) << info;
}

TEST(Render, EmptyBackgroundStaysBackground) {
  Rig cube = UnitCube();
  RenderOptions o = HeadOn(64);
  o.camera.target = {0, 0, 6};  // Looking away from the cube.
  Image im;
  ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), o, im).ok());
  const std::array<float, 4> bg{Linear(0.2f), Linear(0.4f), Linear(0.6f), 1.0f};
  for (int y = 0; y < im.height; ++y) {
    for (int x = 0; x < im.width; ++x) ASSERT_TRUE(IsBackground(im, x, y, bg)) << x << "," << y;
  }
  // Transparent background: alpha 0 everywhere the mesh is not.
  o.background = {1, 1, 1, 0};
  ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), o, im).ok());
  for (size_t i = 3; i < im.rgba.size(); i += 4) ASSERT_EQ(im.rgba[i], 0.0f);
}

// A draw straight into 8-bit sRGB (what the render route asks for 8-bit files) gives the float
// draw's picture: every channel of the textured FaceCap head within one 8-bit step of the float
// draw's value rounded to 8-bit sRGB, alpha exact, over an opaque and a transparent background.
// The heatmap (its legend is drawn on floats) and supersampling (box-filtered in floats) draw
// floats.
TEST(Render, EightBitDrawIsTheFloatDrawToAStep) {
  auto rig = formats::LoadRigFile(test::Bundled("facecap/facecap.glb"));
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  std::vector<float> w(rig->shapes.size(), 0.0f);
  w[static_cast<size_t>(FindShape(rig.value(), "jawOpen"))] = 0.5f;
  const BlendedRig blended = Evaluate(rig.value(), w);
  for (const float alpha : {1.0f, 0.0f}) {
    RenderOptions o;
    o.width = 200;
    o.height = 160;
    o.background[3] = alpha;
    Image floats, bytes;
    ASSERT_TRUE(Gl().Draw(rig.value(), blended, o, floats).ok());
    o.srgb8 = true;
    ASSERT_TRUE(Gl().Draw(rig.value(), blended, o, bytes).ok());
    ASSERT_TRUE(floats.srgb8.empty());
    ASSERT_TRUE(bytes.rgba.empty());
    ASSERT_EQ(bytes.srgb8.size(), floats.rgba.size());
    size_t off_by_one = 0, wrong = 0, transparent = 0;
    for (size_t i = 0; i < floats.rgba.size(); ++i) {
      const float v = std::clamp(floats.rgba[i], 0.0f, 1.0f);
      const int want = static_cast<int>(std::lround((i % 4 == 3 ? v : Srgb(v)) * 255.0f));
      const int d = std::abs(bytes.srgb8[i] - want);
      off_by_one += d == 1;
      wrong += i % 4 == 3 ? d != 0 : d > 1;
      transparent += i % 4 == 3 && bytes.srgb8[i] == 0;
    }
    EXPECT_EQ(wrong, 0u) << "alpha " << alpha;
    EXPECT_LT(off_by_one, floats.rgba.size() / 20)
        << "alpha " << alpha;  // Rounding at a step's edge, not a shift.
    if (alpha == 0.0f) {
      EXPECT_GT(transparent, floats.rgba.size() / 4 / 10);  // The background around the head.
    } else {
      EXPECT_EQ(transparent, 0u);
    }
  }
  RenderOptions o;
  o.width = o.height = 64;
  o.srgb8 = true;
  for (const bool heatmap : {true, false}) {
    o.view = heatmap ? picture::View::kHeatmap : picture::View::kShaded;
    o.supersample = heatmap ? 1 : 2;
    Image im;
    ASSERT_TRUE(Gl().Draw(rig.value(), blended, o, im).ok());
    EXPECT_TRUE(im.srgb8.empty());
    EXPECT_EQ(im.rgba.size(), 64u * 64u * 4u);
  }
}

// The heatmap's legend on images too small for it: drawn as far as it fits, never aborting the
// process (OpenImageIO asserts on text wholly above the image, which a 64-pixel legend's title
// was).
TEST(Render, HeatmapLegendOnSmallImages) {
  Rig cube = UnitCube();
  for (const int size : {1, 16, 40, 64, 100}) {
    RenderOptions o = HeadOn(size);
    o.view = picture::View::kHeatmap;
    Image im;
    ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), o, im).ok()) << size;
    EXPECT_EQ(im.rgba.size(), static_cast<size_t>(size) * size * 4);
  }
  Image im;
  im.width = im.height = 64;
  im.rgba.assign(64 * 64 * 4, 0.0f);
  EXPECT_FALSE(
      offscreen::DrawText(im, 2, -30, "displacement", 10, {1, 1, 1}));  // Wholly above: not drawn.
  EXPECT_TRUE(std::all_of(im.rgba.begin(), im.rgba.end(), [](float v) { return v == 0.0f; }));
  EXPECT_TRUE(offscreen::DrawText(im, 2, 30, "displacement", 10, {1, 1, 1}));
  EXPECT_FALSE(std::all_of(im.rgba.begin(), im.rgba.end(), [](float v) { return v == 0.0f; }));
}

// Labels in any script: Uka's Japanese shape names draw as their glyphs on a contact sheet
// (FreeType with fonts-noto-cjk), where OpenImageIO 2.4's text drew ま as '>' and others as empty
// boxes.
TEST(Render, JapaneseLabelsDrawAsGlyphs) {
  ASSERT_TRUE(offscreen::CanDrawText("まばたき (blink)"))
      << "fonts-noto-cjk is in .ci/dev's packages";
  EXPECT_FALSE(offscreen::CanDrawText("\xF0\x9F\x98")) << "a malformed sequence";
  auto ink = [](const std::string& text) {
    Image im;
    im.width = 48;
    im.height = 40;
    im.rgba.assign(static_cast<size_t>(im.width) * im.height * 4, 0.0f);
    EXPECT_TRUE(offscreen::DrawText(im, 4, 30, text, 28, {1, 1, 1})) << text;
    return im.rgba;
  };
  const auto ma = ink("ま"), ba = ink("ば"), gt = ink(">"), a = ink("あ");
  EXPECT_NE(ma, ba);
  EXPECT_NE(ma, gt);
  EXPECT_NE(ma, a);
  // A glyph, not a box: あ's ink is not a rectangle's outline (a box's pixels sit on 4 lines).
  size_t inked = 0;
  for (size_t i = 0; i < a.size(); i += 4) inked += a[i] > 0.5f;
  EXPECT_GT(inked, 60u);
}

// The heatmap's legend takes the right of the image: the orbit camera frames the model in the part
// left of it, centred there, so no part of the model runs under the legend (FaceCap's ear did).
TEST(Render, HeatmapFramesTheModelLeftOfItsLegend) {
  Rig cube = UnitCube();
  RenderOptions o;
  o.width = o.height = 256;
  o.background = {0.2f, 0.4f, 0.6f, 1.0f};
  o.view = picture::View::kHeatmap;
  Image im;
  ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), o, im).ok());
  const std::array<float, 4> bg{Linear(0.2f), Linear(0.4f), Linear(0.6f), 1.0f};
  int model_lo = o.width, model_hi = -1, legend_lo = o.width;
  for (int y = 0; y < o.height * 2 / 3;
       ++y) {  // Above the legend's swatch (nothing moved: one purple square at its foot).
    for (int x = 0; x < o.width; ++x) {
      if (IsBackground(im, x, y, bg)) continue;
      const float* p = &im.rgba[(static_cast<size_t>(y) * o.width + x) * 4];
      if (p[2] > 2.0f * p[1] + 0.02f)
        model_lo = std::min(model_lo, x), model_hi = std::max(model_hi, x);  // Viridis' purple.
      else if (p[0] + p[1] + p[2] > 2.0f)
        legend_lo = std::min(legend_lo, x);  // The legend's veil.
    }
  }
  ASSERT_GE(model_hi, 0);
  ASSERT_LT(legend_lo, o.width);
  EXPECT_LT(model_hi, legend_lo);
  EXPECT_NEAR(0.5 * (model_lo + model_hi), 0.5 * legend_lo, 2.0) << "centred left of the legend";
}

TEST(Render, UnitCubeHeadOnCoversExpectedArea) {
  Rig cube = UnitCube();
  const int size = 256;
  Image im;
  ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), HeadOn(size), im).ok());
  const std::array<float, 4> bg{Linear(0.2f), Linear(0.4f), Linear(0.6f), 1.0f};
  int covered = 0, min_x = size, max_x = -1;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      if (!IsBackground(im, x, y, bg)) {
        ++covered;
        min_x = std::min(min_x, x);
        max_x = std::max(max_x, x);
      }
    }
  }
  // The front face (z = 0.5) seen from 2.5 away with a 30 degree field of view.
  const double side = 0.5 / 2.5 / std::tan(15.0 * M_PI / 180.0) * size;
  EXPECT_NEAR(covered, side * side, 0.02 * side * side);
  EXPECT_NEAR(max_x - min_x + 1, side, 2.0);
  EXPECT_NEAR(0.5 * (min_x + max_x), 0.5 * (size - 1), 1.0) << "centred";
}

// What other threads spend for a picture is charged to the meter handed down with it (never found
// through the thread): llvmpipe's rasteriser for a draw, the conversion helpers for a big PNG.
TEST(Render, HelperThreadsChargeTheMeterHandedDown) {
  if (std::thread::hardware_concurrency() < 2) GTEST_SKIP() << "one core: no helper threads";
  Rig cube = UnitCube();
  HelperCpu drawn;
  RenderOptions o = HeadOn(1024);
  o.supersample = 2;
  o.helper_cpu = &drawn;
  Image im;
  ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), o, im).ok());
  EXPECT_GT(drawn.Seconds(), 0.0) << "the rasteriser's CPU for this draw";
  o.helper_cpu = nullptr;  // Charged nowhere, and nothing else is charged.
  const double before = drawn.Seconds();
  ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), o, im).ok());
  EXPECT_EQ(drawn.Seconds(), before);
  HelperCpu encoded;
  ASSERT_FALSE(im.rgba.empty()) << "a float image: converted to 8 bits in parts";
  ASSERT_TRUE(offscreen::Encode(im, picture::ImageFormat::kPng, 0, &encoded).ok());
  EXPECT_GT(encoded.Seconds(), 0.0) << "the conversion helpers' CPU";
  EXPECT_GT(encoded.Take(), 0.0);
  EXPECT_EQ(encoded.Seconds(), 0.0) << "Take empties the meter";
}

TEST(Render, WeightChangesExactlyThePixelsWhereTheVerticesAre) {
  // A 20x20 grid in z = 0 spanning [-1, 1]^2; the shape pushes the vertices with x > 0.5
  // towards the camera.
  const int g = 21;
  std::vector<float> pos;
  std::vector<uint32_t> idx;
  for (int y = 0; y < g; ++y) {
    for (int x = 0; x < g; ++x)
      pos.insert(pos.end(), {-1.0f + 2.0f * x / (g - 1), -1.0f + 2.0f * y / (g - 1), 0.0f});
  }
  for (int y = 0; y + 1 < g; ++y) {
    for (int x = 0; x + 1 < g; ++x) {
      const uint32_t a = y * g + x;
      idx.insert(idx.end(), {a, a + 1, a + g + 1, a, a + g + 1, a + g});
    }
  }
  SparseTarget push;
  for (uint32_t v = 0; v < static_cast<uint32_t>(g * g); ++v) {
    if (pos[3 * v] > 0.5f) {
      push.indices.push_back(v);
      push.position_deltas.insert(push.position_deltas.end(),
                                  {0.0f, 0.0f, 0.3f * (pos[3 * v] - 0.5f)});
    }
  }
  Rig rig = OnePrimitive(pos, idx, {push});
  RenderOptions o = HeadOn(200);
  o.camera.eye = {0, 0, 5};
  Image base, moved;
  ASSERT_TRUE(Gl().Draw(rig, Evaluate(rig, {0.0f}), o, base).ok());
  ASSERT_TRUE(Gl().Draw(rig, Evaluate(rig, {1.0f}), o, moved).ok());
  // Faces touching a moved vertex span x >= 0.4 (the grid step is 0.1); with the camera 5
  // away (4.85 for the raised ones) and tan(15 deg), x = 0.4 is column 100 + 0.4 / (4.85 * 0.2679)
  // * 100.
  const int first_col =
      static_cast<int>(std::floor(100.0 + 0.4 / (4.85 * std::tan(15.0 * M_PI / 180.0)) * 100.0)) -
      1;
  int changed = 0;
  for (int y = 0; y < 200; ++y) {
    for (int x = 0; x < 200; ++x) {
      const size_t i = (static_cast<size_t>(y) * 200 + x) * 4;
      bool differs = false;
      for (int c = 0; c < 3; ++c)
        differs |= std::fabs(base.rgba[i + c] - moved.rgba[i + c]) > 1e-5f;
      if (differs) {
        ++changed;
        EXPECT_GE(x, first_col) << "pixel (" << x << "," << y
                                << ") changed left of the moved region";
      }
    }
  }
  EXPECT_GT(changed, 1000) << "the shape changes the picture";
}

TEST(Render, ThreadsShareABoundedSetOfContexts) {
  // Renders from several threads, more than the contexts allowed, at two sizes (a shared
  // context resizes its framebuffer) give exactly the pictures rendered one at a time.
  Rig cube = UnitCube();
  RenderOptions small = HeadOn(48), large = HeadOn(96);
  large.camera.yaw = 30;
  Image want_small, want_large;
  ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), small, want_small).ok());
  ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), large, want_large).ok());
  offscreen::OsMesaRenderer one(1);
  EXPECT_EQ(one.Concurrency(), 1);
  const BlendedRig blended = Evaluate(cube);
  std::vector<int> mismatches(6, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 6; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < 8; ++i) {
        const bool big = (t + i) % 2 == 1;
        Image im;
        if (!one.Draw(cube, blended, big ? large : small, im).ok() ||
            im.rgba != (big ? want_large : want_small).rgba) {
          ++mismatches[t];
        }
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < 6; ++t) EXPECT_EQ(mismatches[t], 0) << "thread " << t;
  one.SetMaxContexts(0);
  EXPECT_EQ(one.Concurrency(), std::max(1, static_cast<int>(std::thread::hardware_concurrency())));
  EXPECT_NE(one.Info().find("llvmpipe"), std::string::npos);
}

TEST(Render, FramingOnTheShapesUsesAGivenFocusBox) {
  // A cube whose shape pushes out one face's corner: framing on the shapes looks at that corner.
  Rig cube = UnitCube();
  SparseTarget push;
  push.indices = {2};  // (0.5, 0.5, 0.5) of the front face.
  push.position_deltas = {0.1f, 0.1f, 0.1f};
  cube.primitives[0].targets = {push};
  cube.meshes[0].target_shapes = {0};
  cube.shapes = {Shape{.name = "corner"}};
  FinalizePrimitive(cube.primitives[0]);
  ASSERT_TRUE(ValidateRig(cube).ok());
  RenderOptions o;
  o.width = o.height = 64;
  o.camera.frame = picture::Framing::kShapes;
  const BlendedRig blended = Evaluate(cube, {1.0f});
  Image computed, given, elsewhere;
  ASSERT_TRUE(Gl().Draw(cube, blended, o, computed).ok());
  std::array<float, 3> lo, hi;
  ASSERT_TRUE(ShapeFocusBox(cube, lo, hi));
  o.camera.has_focus = true;
  o.camera.focus_min = lo;
  o.camera.focus_max = hi;
  ASSERT_TRUE(Gl().Draw(cube, blended, o, given).ok());
  EXPECT_EQ(given.rgba, computed.rgba)
      << "the box the caller keeps is the one a render would compute";
  o.camera.focus_min = {-0.5f, -0.5f, -0.5f};
  o.camera.focus_max = {-0.4f, -0.4f, -0.4f};
  ASSERT_TRUE(Gl().Draw(cube, blended, o, elsewhere).ok());
  EXPECT_NE(elsewhere.rgba, computed.rgba) << "a given box is honoured";
}

// Rows holding anything but the background (transparent here): how tall the subject stands.
int CoveredRows(const Image& im) {
  int rows = 0;
  for (int y = 0; y < im.height; ++y) {
    for (int x = 0; x < im.width; ++x) {
      if (im.rgba[(static_cast<size_t>(y) * im.width + x) * 4 + 3] > 0.5f) {
        ++rows;
        break;
      }
    }
  }
  return rows;
}

// MakeHuman's shapes act on the face of a whole body: by default a render frames the face (as
// "shapes" does), where "all" shows a body with a head a tenth of the image tall. FaceCap (shapes
// all over the head) keeps the whole mesh; Uka (a face on a skinned body) frames her head joint
// (below).
TEST(Render, ShapesOnASmallPartAreFramedByDefault) {
  auto human = formats::LoadRigFile(test::Bundled("makehuman/makehuman.glb"));
  auto face = formats::LoadRigFile(test::Bundled("facecap/facecap.glb"));
  auto uka = formats::LoadRigFile(test::Bundled("uka/MS_Uka.pmx"));
  ASSERT_TRUE(human.ok() && face.ok() && uka.ok());
  std::array<float, 3> lo, hi;
  ASSERT_TRUE(ShapeFocusBox(human.value(), lo, hi));
  EXPECT_TRUE(FrameShapesByDefault(human.value(), lo, hi));
  ASSERT_TRUE(ShapeFocusBox(face.value(), lo, hi));
  EXPECT_FALSE(FrameShapesByDefault(face.value(), lo, hi));
  EXPECT_EQ(ShapeFocusJoint(face.value()), -1);  // No skin: framed by the box.
  ASSERT_TRUE(ShapeFocusBox(uka.value(), lo, hi));
  EXPECT_TRUE(FrameShapesByDefault(uka.value(), lo, hi));

  RenderOptions o;
  o.width = o.height = 128;
  o.background = {1, 1, 1, 0};
  const BlendedRig blended =
      Evaluate(human.value(), std::vector<float>(human->shapes.size(), 0.0f));
  Image by_default, shapes, all;
  ASSERT_TRUE(Gl().Draw(human.value(), blended, o, by_default).ok());
  o.camera.frame = picture::Framing::kShapes;
  ASSERT_TRUE(Gl().Draw(human.value(), blended, o, shapes).ok());
  o.camera.frame = picture::Framing::kAll;
  ASSERT_TRUE(Gl().Draw(human.value(), blended, o, all).ok());
  EXPECT_NE(by_default.rgba,
            shapes.rgba);  // The shapes' box grown by 40%: a margin around the face.
  EXPECT_GT(CoveredRows(by_default), 100);  // The head fills the frame...
  EXPECT_GT(CoveredRows(all), 100);         // ...where "all" shows the whole body, as tall,
  EXPECT_NE(by_default.rgba, all.rgba);     // and so a different picture.
}

// Uka's shapes are her face on a skinned body: by default a render frames her face (the box of what
// her expressions move, with a margin) carried by the joint that carries them (頭, her head) to
// where a pose takes it; frame=joint:頭 frames all that joint carries (her ears and hair too),
// "all" her whole, small.
TEST(Render, AFaceOnASkinnedBodyFollowsItsHeadJointByDefault) {
  auto loaded = formats::LoadRigFile(test::Bundled("uka/MS_Uka.pmx"));
  ASSERT_TRUE(loaded.ok());
  const Rig& uka = loaded.value();
  const int head = ShapeFocusJoint(uka);
  ASSERT_GE(head, 0);
  EXPECT_EQ(uka.nodes[static_cast<size_t>(head)].name, "頭");

  RenderOptions o;
  o.width = o.height = 96;
  o.background = {1, 1, 1, 0};
  for (const bool posed : {false, true}) {
    BlendedRig blended = Evaluate(uka, std::vector<float>(uka.shapes.size(), 0.0f));
    if (posed) {  // Her whole body 30 cm to her left and turned: the head with it.
      Pose pose = RestPose(uka);
      const int centre = FindNode(uka, "センター");
      ASSERT_GE(centre, 0);
      pose.local[static_cast<size_t>(centre)].translation[0] += 3.75f;
      pose.local[static_cast<size_t>(centre)].rotation = EulerToQuaternion(0, 40, 0);
      pose.from_matrix[static_cast<size_t>(centre)] = 0;
      BlendContext ctx;
      BlendOptions bo;
      bo.pose = &pose;
      const std::vector<float> w(uka.shapes.size(), 0.0f);
      ASSERT_TRUE(EvaluateRig(uka, w, bo, blended, ctx).ok());
    }
    Image by_default, joint, all;
    o.camera.frame = picture::Framing::kAuto;
    ASSERT_TRUE(Gl().Draw(uka, blended, o, by_default).ok());
    o.camera.frame = picture::Framing::kJoint;
    o.camera.frame_joint = "頭";
    ASSERT_TRUE(Gl().Draw(uka, blended, o, joint).ok());
    o.camera.frame = picture::Framing::kAll;
    ASSERT_TRUE(Gl().Draw(uka, blended, o, all).ok());
    EXPECT_NE(by_default.rgba, joint.rgba) << (posed ? "posed" : "at rest");
    EXPECT_EQ(CoveredRows(by_default), 96)
        << (posed ? "posed" : "at rest");  // The face fills the frame,
    EXPECT_GT(CoveredRows(joint), 80) << (posed ? "posed" : "at rest");
    EXPECT_LT(CoveredRows(all), 80) << (posed ? "posed" : "at rest");  // a whole body is thin.
  }
}

// A nose 4 mm lower on MakeHuman (the bundled rig is in metres: nose-trans-down, whose largest move
// is 3.7 mm at 1, scaled so that it is 0.004) shows at 512 x 512 with the default framing and
// light: a share of the face's pixels (those not background) changes by more than 2/255 in sRGB.
TEST(Render, AFourMillimetreNoseChangeShowsOnMakeHuman) {
  auto human = formats::LoadRigFile(test::Bundled("makehuman/makehuman.glb"));
  ASSERT_TRUE(human.ok());
  const Rig& rig = human.value();
  const auto shape = std::find_if(rig.shapes.begin(), rig.shapes.end(),
                                  [](const Shape& s) { return s.name == "nose-trans-down"; });
  ASSERT_NE(shape, rig.shapes.end());
  const size_t index = static_cast<size_t>(shape - rig.shapes.begin());
  float largest = 0;  // The shape's largest vertex move at weight 1.
  std::vector<float> w(rig.shapes.size(), 0.0f);
  const BlendedRig neutral = Evaluate(rig, w);
  w[index] = 1.0f;
  const BlendedRig full = Evaluate(rig, w);
  for (size_t v = 0; v < rig.primitives[0].vertex_count(); ++v) {
    float d2 = 0;
    for (int c = 0; c < 3; ++c)
      d2 += std::pow(
          full.primitives[0].positions[3 * v + c] - neutral.primitives[0].positions[3 * v + c],
          2.0f);
    largest = std::max(largest, std::sqrt(d2));
  }
  ASSERT_GT(largest, 0.001f);
  w[index] = 0.004f / largest;
  const BlendedRig moved = Evaluate(rig, w);

  RenderOptions o;  // 512 x 512, shaded, framing auto (the face).
  o.background = {1, 1, 1, 0};
  Image before, after;
  ASSERT_TRUE(Gl().Draw(rig, neutral, o, before).ok());
  ASSERT_TRUE(Gl().Draw(rig, moved, o, after).ok());
  size_t face = 0, changed = 0;
  for (size_t i = 0; i < before.rgba.size(); i += 4) {
    if (before.rgba[i + 3] == 0.0f && after.rgba[i + 3] == 0.0f) continue;
    ++face;
    for (int c = 0; c < 3; ++c) {
      if (std::fabs(Srgb(before.rgba[i + c]) - Srgb(after.rgba[i + c])) > 2.0f / 255.0f) {
        ++changed;
        break;
      }
    }
  }
  ASSERT_GT(face, 512u * 512u / 4) << "the face fills the frame";
  const double share = static_cast<double>(changed) / static_cast<double>(face);
  std::printf("nose 4 mm lower: %zu of %zu face pixels changed (%.2f%%)\n", changed, face,
              100.0 * share);
  EXPECT_GT(share, 0.03);  // 3.9% measured (llvmpipe).
}

TEST(Render, TheCameraStaysStillWhileWeightsChange) {
  // FaceCap frames every vertex; the jaw opening lowers the chin. The camera orbits the rest
  // shape, so the forehead and eyes stay where they were (frames of a sequence line up).
  auto face = formats::LoadRigFile(test::Bundled("facecap/facecap.glb"));
  ASSERT_TRUE(face.ok());
  const int jaw = FindShape(face.value(), "jawOpen");
  ASSERT_GE(jaw, 0);
  std::vector<float> open(face->shapes.size(), 0.0f);
  open[static_cast<size_t>(jaw)] = 1.0f;
  RenderOptions o;
  o.width = o.height = 128;
  o.background = {1, 1, 1, 0};
  Image rest, opened;
  ASSERT_TRUE(Gl().Draw(face.value(), Evaluate(face.value()), o, rest).ok());
  ASSERT_TRUE(Gl().Draw(face.value(), Evaluate(face.value(), open), o, opened).ok());
  size_t top_changed = 0, changed = 0;
  const size_t top = static_cast<size_t>(0.4 * o.height) * o.width * 4;
  for (size_t i = 0; i < rest.rgba.size(); ++i) {
    const bool differs = std::fabs(rest.rgba[i] - opened.rgba[i]) > 1e-3f;
    changed += differs;
    if (i < top) top_changed += differs;
  }
  EXPECT_GT(changed, 200u);    // The jaw moved...
  EXPECT_EQ(top_changed, 0u);  // ...and nothing above the eyes did.
}

TEST(Render, FramesAJointByName) {
  auto fox = formats::LoadRigFile(test::RealAsset("Fox/Fox.glb"));
  ASSERT_TRUE(fox.ok());
  RenderOptions o;
  o.width = o.height = 128;
  o.background = {1, 1, 1, 0};
  o.camera.yaw = 90;  // From the side: the fox is long, its head small.
  const BlendedRig blended = Evaluate(fox.value());
  Image all, head;
  o.camera.frame = picture::Framing::kAll;
  ASSERT_TRUE(Gl().Draw(fox.value(), blended, o, all).ok());
  o.camera.frame = picture::Framing::kJoint;
  o.camera.frame_joint = "b_Head_05";
  ASSERT_TRUE(Gl().Draw(fox.value(), blended, o, head).ok());
  auto covered = [](const Image& im) {
    size_t n = 0;
    for (size_t i = 3; i < im.rgba.size(); i += 4) n += im.rgba[i] > 0.5f;
    return n;
  };
  EXPECT_GT(CoveredRows(head), 100);           // The head fills the frame (its neck leaves it),
  EXPECT_GT(covered(head), 2 * covered(all));  // where the whole fox, side on, covers a fraction.
  o.camera.frame_joint = "b_head_5";
  const Status unknown = Gl().Draw(fox.value(), blended, o, head);
  EXPECT_FALSE(unknown.ok());
  EXPECT_NE(unknown.message.find("did you mean 'b_Head_05'"), std::string::npos) << unknown.message;
  auto face = formats::LoadRigFile(test::Bundled("facecap/facecap.glb"));
  ASSERT_TRUE(face.ok());
  const Status boneless = Gl().Draw(face.value(), Evaluate(face.value()), o, head);
  EXPECT_NE(boneless.message.find("has no skeleton"), std::string::npos) << boneless.message;
}

// ---- Materials: a quad facing the camera (UVs as glTF's: v down the image), one material.

// PNG bytes of a w x h image, every pixel these 8-bit values (as a map's file holds them).
std::vector<unsigned char> FlatPng(std::array<int, 4> bytes, int w = 4, int h = 4) {
  Image im;
  im.width = w;
  im.height = h;
  for (int i = 0; i < w * h; ++i) {
    for (int c = 0; c < 4; ++c)
      im.rgba.push_back(c == 3 ? bytes[3] / 255.0f : Linear(bytes[c] / 255.0f));
  }
  auto png = offscreen::Encode(im, picture::ImageFormat::kPng);
  EXPECT_TRUE(png.ok());
  return {png->begin(), png->end()};
}

Rig Quad(const Material& material, std::vector<std::vector<unsigned char>> images = {}) {
  Rig rig = OnePrimitive({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3});
  rig.primitives[0].texcoords = {0, 1, 1, 1, 1, 0, 0, 0};
  rig.primitives[0].material = 0;
  rig.materials = {material};
  for (auto& bytes : images) rig.images.push_back({"map", "image/png", std::move(bytes)});
  EXPECT_TRUE(ValidateRig(rig).ok());
  return rig;
}

// The mean linear colour of the middle 16 x 16 pixels of a 64 x 64 render.
std::array<float, 3> Middle(const Rig& rig, RenderOptions o = HeadOn(64)) {
  Image im;
  EXPECT_TRUE(Gl().Draw(rig, Evaluate(rig), o, im).ok());
  std::array<float, 3> sum{0, 0, 0};
  for (int y = 24; y < 40; ++y) {
    for (int x = 24; x < 40; ++x) {
      for (int c = 0; c < 3; ++c)
        sum[c] += im.rgba[(static_cast<size_t>(y) * 64 + x) * 4 + c] / 256.0f;
    }
  }
  return sum;
}

float Luma(std::array<float, 3> c) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; }

Material Dielectric(std::array<float, 4> base = {0.8f, 0.8f, 0.8f, 1.0f}) {
  Material m;
  m.base_color_factor = base;
  m.metallic_factor = 0.0f;
  m.roughness_factor = 0.6f;
  return m;
}

// The key light is high on the left, the fill low on the right: a normal map tilting the surface
// up brightens it, down or right darkens it, left outshines right; a flat map (128, 128, 255)
// changes nothing. Green up = toward v = 0.
TEST(Materials, NormalMapTurnsTheSurfaceInTheMapsFrame) {
  Material m = Dielectric();
  const float plain = Luma(Middle(Quad(m)));
  m.normal_image = 0;
  auto lit = [&](std::array<int, 4> n) { return Luma(Middle(Quad(m, {FlatPng(n)}))); };
  EXPECT_NEAR(lit({128, 128, 255, 255}), plain, 0.01f);
  const float left = lit({51, 128, 230, 255}), right = lit({204, 128, 230, 255});
  const float up = lit({128, 204, 230, 255}), down = lit({128, 51, 230, 255});
  EXPECT_GT(left, right + 0.1f);  // Left: more key light, less fill; right: the reverse.
  EXPECT_LT(right, plain - 0.03f);
  EXPECT_GT(up, plain + 0.03f);
  EXPECT_LT(down, plain - 0.03f);
  m.normal_scale = 0.0f;  // Scale 0: the map's tilt is gone.
  EXPECT_NEAR(Luma(Middle(Quad(m, {FlatPng({51, 128, 230, 255})}))), plain, 0.01f);
}

// A UV morph (MMD's, glTF's TEXCOORD_0 targets) moves where the texture is read: a map red on its
// left half and blue on its right, the quad's UVs on the left half; a shape moving every u by 0.5
// shows blue.
TEST(Materials, AUvMorphMovesWhereTheMapIsRead) {
  Image map;
  map.width = 4;
  map.height = 1;
  map.rgba = {1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 1};
  auto png = offscreen::Encode(map, picture::ImageFormat::kPng);
  ASSERT_TRUE(png.ok());
  Material m = Dielectric({1, 1, 1, 1});
  m.base_color_image = 0;
  Rig rig = Quad(m, {{png->begin(), png->end()}});
  for (size_t v = 0; v < 4; ++v)
    rig.primitives[0].texcoords[2 * v] =
        0.125f + 0.25f * rig.primitives[0].texcoords[2 * v];  // u in [1/8, 3/8]: red texels alone.
  SparseTarget shift;
  shift.texcoord_indices = {0, 1, 2, 3};
  shift.texcoord_deltas = {0.5f, 0, 0.5f, 0, 0.5f, 0, 0.5f, 0};  // u in [5/8, 7/8]: blue.
  rig.primitives[0].targets = {shift};
  rig.meshes[0].target_shapes = {0};
  rig.shapes = {Shape{.name = "uv"}};
  ASSERT_TRUE(ValidateRig(rig).ok());
  auto colour = [&](float w) {
    Image im;
    EXPECT_TRUE(Gl().Draw(rig, Evaluate(rig, {w}), HeadOn(64), im).ok());
    std::array<float, 3> sum{0, 0, 0};
    for (int y = 24; y < 40; ++y) {
      for (int x = 24; x < 40; ++x) {
        for (int c = 0; c < 3; ++c)
          sum[c] += im.rgba[(static_cast<size_t>(y) * 64 + x) * 4 + c] / 256.0f;
      }
    }
    return sum;
  };
  const auto rest = colour(0.0f), moved = colour(1.0f);
  EXPECT_GT(rest[0], 5 * rest[2]);    // Red.
  EXPECT_GT(moved[2], 5 * moved[0]);  // Blue.
  const BlendedRig half = Evaluate(rig, {0.5f});
  ASSERT_EQ(half.primitives[0].texcoords.size(), 8u);
  EXPECT_FLOAT_EQ(half.primitives[0].texcoords[2], 0.375f + 0.25f);  // Vertex 1: u 3/8 + 0.5 x 0.5.
  EXPECT_TRUE(
      Evaluate(rig, {0.0f}).primitives[0].texcoords.empty());  // At rest the primitive's own hold.
}

// The map multiplies the factors: roughness from green, metallic from blue.
TEST(Materials, MetallicRoughnessMapMultipliesTheFactors) {
  Material m = Dielectric({0.9f, 0.1f, 0.1f, 1.0f});
  m.metallic_factor = 1.0f;
  m.roughness_factor = 0.6f;
  const auto metal = Middle(Quad(m));
  m.metallic_factor = 0.0f;
  const auto plastic = Middle(Quad(m));
  EXPECT_GT(std::fabs(Luma(metal) - Luma(plastic)), 0.05f);
  m.metallic_factor = 1.0f;
  m.metallic_roughness_image = 0;
  const auto mapped_plastic = Middle(Quad(m, {FlatPng({0, 255, 0, 255})}));  // Metallic 1 x 0.
  const auto mapped_metal = Middle(Quad(m, {FlatPng({0, 255, 255, 255})}));  // Metallic 1 x 1.
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(mapped_plastic[c], plastic[c], 2e-3f) << c;
    EXPECT_NEAR(mapped_metal[c], metal[c], 2e-3f) << c;
  }
  // Roughness 0.6 x 0.1: a sharper, dimmer-away-from-the-highlight surface than 0.6.
  const auto glossy = Middle(Quad(m, {FlatPng({0, 26, 255, 255})}));
  EXPECT_GT(std::fabs(Luma(glossy) - Luma(metal)), 0.01f);
}

// Occlusion darkens the ambient light only, by its strength.
TEST(Materials, OcclusionDarkensByItsStrength) {
  Material m = Dielectric();
  const float plain = Luma(Middle(Quad(m)));
  m.occlusion_image = 0;
  const float dark = Luma(Middle(Quad(m, {FlatPng({0, 0, 0, 255})})));
  EXPECT_LT(dark, plain - 0.02f);
  EXPECT_GT(dark, 0.3f * plain) << "the direct light stays";
  m.occlusion_strength = 0.0f;
  EXPECT_NEAR(Luma(Middle(Quad(m, {FlatPng({0, 0, 0, 255})}))), plain, 1e-3f);
}

// Emission adds its colour whatever the light: a black surface glows red, then green from the map.
TEST(Materials, EmissiveGlowsInItsColour) {
  Material m = Dielectric({0, 0, 0, 1});
  const auto black = Middle(Quad(m));
  EXPECT_LT(Luma(black), 0.05f);
  m.emissive_factor = {0.6f, 0.0f, 0.0f};
  const auto red = Middle(Quad(m));
  EXPECT_GT(red[0], black[0] + 0.4f);
  EXPECT_NEAR(red[1], black[1], 0.02f);
  m.emissive_factor = {1, 1, 1};
  m.emissive_image = 0;
  const auto green = Middle(Quad(m, {FlatPng({0, 160, 0, 255})}));
  EXPECT_GT(green[1], black[1] + 0.2f);
  EXPECT_LT(green[0], 0.05f);
}

// MASK cuts out below the cutoff; OPAQUE ignores alpha (opaque even on a transparent background).
TEST(Materials, AlphaModes) {
  RenderOptions o = HeadOn(64);
  o.background = {1, 1, 1, 0};
  Material m = Dielectric({0.8f, 0.8f, 0.8f, 0.3f});
  Image im;
  auto middle_alpha = [&](const Material& mat) {
    const Rig quad = Quad(mat);
    EXPECT_TRUE(Gl().Draw(quad, Evaluate(quad), o, im).ok());
    return im.rgba[(static_cast<size_t>(32) * 64 + 32) * 4 + 3];
  };
  EXPECT_EQ(middle_alpha(m), 1.0f);
  m.alpha_mode = "MASK";
  m.alpha_cutoff = 0.5f;
  EXPECT_EQ(middle_alpha(m), 0.0f) << "0.3 < 0.5: cut out";
  m.alpha_cutoff = 0.2f;
  EXPECT_EQ(middle_alpha(m), 1.0f);
  m.alpha_mode = "BLEND";
  EXPECT_NEAR(middle_alpha(m), 0.3f, 1e-3f);
}

// Clay: one grey material whatever the rig's; exposure: stops of light before tone mapping.
TEST(Render, ClayIgnoresTheMaterialAndExposureScalesTheLight) {
  Material red = Dielectric({1, 0, 0, 1});
  red.base_color_image = 0;
  const Rig textured = Quad(red, {FlatPng({255, 255, 0, 255})});
  RenderOptions o = HeadOn(64);
  o.view = picture::View::kClay;
  const auto clay = Middle(textured, o);
  EXPECT_NEAR(clay[0], clay[1], 0.02f);
  EXPECT_NEAR(clay[1], clay[2], 0.02f);
  const auto plain = Middle(Quad(Dielectric({0, 0, 1, 1})), o);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(clay[c], plain[c], 1e-4f);
  const auto shaded = Middle(textured);
  EXPECT_GT(shaded[0], 5 * shaded[2]) << "shaded keeps the red texture";
  o.view = picture::View::kShaded;
  const float at0 = Luma(Middle(textured, o));
  o.exposure = 1.0f;
  const float brighter = Luma(Middle(textured, o));
  o.exposure = -1.0f;
  const float darker = Luma(Middle(textured, o));
  EXPECT_GT(brighter, at0 * 1.3f);
  EXPECT_LT(darker, at0 * 0.7f);
}

TEST(Render, SupersamplingSmoothsEdges) {
  Rig cube = UnitCube();
  RenderOptions o = HeadOn(64);
  o.camera.yaw = 0;
  o.camera.eye = {1.2f, 0.9f, 2.5f};
  Image hard, soft;
  ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), o, hard).ok());
  o.supersample = 4;
  ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), o, soft).ok());
  // Count partially covered pixels: values strictly between background and surface.
  auto partial = [](const Image& im) {
    int n = 0;
    for (size_t i = 0; i < im.rgba.size(); i += 4) {
      const float b = im.rgba[i + 2];
      if (b > 0.02f && std::fabs(b - Linear(0.6f)) > 0.02f &&
          std::fabs(im.rgba[i] - im.rgba[i + 2]) > 0.01f)
        ++n;
    }
    return n;
  };
  EXPECT_EQ(soft.width, 64);
  EXPECT_GT(partial(soft), partial(hard));
}

TEST(Render, EncodeDecodeRoundTrip) {
  Rig cube = UnitCube();
  Image im;
  ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), HeadOn(32), im).ok());
  for (auto f :
       {picture::ImageFormat::kPng, picture::ImageFormat::kTiff, picture::ImageFormat::kExr,
        picture::ImageFormat::kJpeg, picture::ImageFormat::kWebp}) {
    // WebP at 100 is lossless (8-bit exact, as PNG); JPEG at 95 is lossy.
    auto bytes = offscreen::Encode(im, f, f == picture::ImageFormat::kWebp ? 100 : 95);
    ASSERT_TRUE(bytes.ok()) << picture::ImageFormatExtension(f);
    std::vector<unsigned char> b(bytes->begin(), bytes->end());
    auto back = offscreen::Decode(b);
    ASSERT_TRUE(back.ok()) << picture::ImageFormatExtension(f) << ": " << back.status().message;
    EXPECT_EQ(back->width, 32);
    // Errors in sRGB units: 8-bit formats round to 1/255; JPEG is lossy; EXR keeps halfs.
    // JPEG is lossy: its mean error is bounded, not its max.
    const bool jpeg = f == picture::ImageFormat::kJpeg;
    const float tol = f == picture::ImageFormat::kExr ? 2e-3f : jpeg ? 0.015f : 0.6f / 255.0f;
    float max_err = 0, sum_err = 0;
    for (size_t i = 0; i < im.rgba.size(); i += 4) {
      for (int c = 0; c < 3; ++c) {
        const float e = std::fabs(Srgb(back->rgba[i + c]) - Srgb(im.rgba[i + c]));
        max_err = std::max(max_err, e);
        sum_err += e;
      }
    }
    EXPECT_LT(jpeg ? sum_err / (im.rgba.size() / 4 * 3) : max_err, tol)
        << picture::ImageFormatExtension(f);
  }
  EXPECT_FALSE(offscreen::Decode(std::vector<unsigned char>{1, 2, 3, 4, 5, 6, 7, 8, 9}).ok());
}

// Our PNG writer (igzip, batches of rows): images come back from libpng byte for byte, every colour
// channel to the nearest 8-bit sRGB step and alpha exactly, the rows in order. An image whose alpha
// is all 1 is written as RGB (3 channels), any other as RGBA. Noise in every byte (nothing to
// compress: the output buffer has to grow), noise beside gradients, and the smallest image.
TEST(Render, PngDecodesExactlyAsRgbWhenOpaqueElseRgba) {
  struct Case {
    int w, h;
    bool opaque, all_noise;
  };
  for (const Case c :
       {Case{523, 777, false, false}, Case{523, 777, true, false}, Case{1500, 1100, true, true},
        Case{700, 300, false, true}, Case{1, 1, false, false}, Case{1, 1, true, false}}) {
    Image im;
    im.width = c.w;
    im.height = c.h;
    im.rgba.resize(static_cast<size_t>(c.w) * c.h * 4);
    uint32_t state = 12345;
    for (size_t i = 0; i < im.rgba.size(); ++i) {
      state = state * 1664525u +
              1013904223u;  // Noise in half the channels (or all), gradients in the rest.
      const size_t px = i / 4;
      im.rgba[i] = (i % 2 || c.all_noise)
                       ? static_cast<float>(state >> 8) / 16777216.0f
                       : static_cast<float>((px % c.w + px / c.w) % 256) / 255.0f;
      if (c.opaque && i % 4 == 3) im.rgba[i] = 1.0f;
    }
    auto png = offscreen::Encode(im, picture::ImageFormat::kPng);
    ASSERT_TRUE(png.ok());
    // No room left over from the writer's buffer: the response cache counts a body by its size.
    EXPECT_LE(png->capacity(), png->size() + 64) << c.w << "x" << c.h;
    OIIO::Filesystem::IOMemReader proxy(png->data(), png->size());
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);  // The file's values: no premultiplying on read.
    auto in = OIIO::ImageInput::create("image.png", true, &config, &proxy);
    ASSERT_TRUE(in) << OIIO::geterror();
    ASSERT_EQ(in->spec().width, c.w);
    ASSERT_EQ(in->spec().height, c.h);
    const int channels = c.opaque ? 3 : 4;
    ASSERT_EQ(in->spec().nchannels, channels);
    std::vector<unsigned char> px(static_cast<size_t>(c.w) * c.h * channels);
    ASSERT_TRUE(in->read_image(0, 0, 0, channels, OIIO::TypeDesc::UINT8, px.data()))
        << in->geterror();
    size_t wrong = 0;
    for (size_t p = 0; p < static_cast<size_t>(c.w) * c.h; ++p) {
      for (int ch = 0; ch < channels; ++ch) {
        const float v = std::clamp(im.rgba[4 * p + ch], 0.0f, 1.0f);
        const int expected = static_cast<int>(std::lround((ch == 3 ? v : Srgb(v)) * 255.0f));
        wrong += std::abs(px[p * channels + ch] - expected) >
                 (ch == 3 ? 0 : 1);  // The sRGB table may round the other way at a step's edge.
      }
    }
    EXPECT_EQ(wrong, 0u) << c.w << "x" << c.h;
  }
}

// Floats to 8-bit sRGB in the PNG writer are exact: the nearest step of the sRGB curve worked out
// in double precision, for values a few ulps either side of each of the 255 points where the step
// changes, every 65,536th of the range, random values, and out of range (negative, above 1, NaN).
TEST(Render, PngSrgbStepsAreExact) {
  auto exact = [](float v) {
    const double c = std::isnan(v) ? 0.0 : std::clamp(static_cast<double>(v), 0.0, 1.0);
    return static_cast<int>(
        std::lround((c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055) * 255.0));
  };
  std::vector<float> values = {
      -1.0f,  -0.0f,         0.0f, 1.0f, 2.0f, 1e30f, std::numeric_limits<float>::quiet_NaN(),
      1e-30f, 1.0f / 8192.0f};
  for (int k = 1; k < 256; ++k) {
    const double s = (k - 0.5) / 255.0;  // Where the step k begins, in sRGB; then in linear light.
    float t = static_cast<float>(s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4));
    for (int i = 0; i < 3; ++i) t = std::nextafter(t, 0.0f);
    for (int i = 0; i < 7; ++i, t = std::nextafter(t, 1.0f)) values.push_back(t);
  }
  for (int i = 0; i <= 65536; ++i) values.push_back(static_cast<float>(i) / 65536.0f);
  uint32_t state = 99;
  for (int i = 0; i < 100000; ++i) {
    state = state * 1664525u + 1013904223u;
    values.push_back(static_cast<float>(state >> 8) / 16777216.0f);
  }
  Image im;
  im.width = 1024;
  im.height = static_cast<int>((values.size() + im.width - 1) / im.width);
  im.rgba.assign(static_cast<size_t>(im.width) * im.height * 4, 1.0f);  // Opaque: an RGB file.
  for (size_t i = 0; i < values.size(); ++i) im.rgba[4 * i] = values[i];
  auto png = offscreen::Encode(im, picture::ImageFormat::kPng);
  ASSERT_TRUE(png.ok());
  OIIO::Filesystem::IOMemReader proxy(png->data(), png->size());
  auto in = OIIO::ImageInput::open("image.png", nullptr, &proxy);
  ASSERT_TRUE(in) << OIIO::geterror();
  ASSERT_EQ(in->spec().nchannels, 3);
  std::vector<unsigned char> px(static_cast<size_t>(im.width) * im.height * 3);
  ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, px.data()));
  size_t wrong = 0;
  for (size_t i = 0; i < values.size(); ++i) {
    if (px[3 * i] != exact(values[i]) && wrong++ < 5)
      ADD_FAILURE() << values[i] << ": " << int(px[3 * i]) << " not " << exact(values[i]);
  }
  EXPECT_EQ(wrong, 0u) << "of " << values.size();
}

// MMD textures come as BMP and TGA too: a 2x1 image (a red then a blue pixel) in each, written here
// byte by byte, decodes to those colours (TGA only when told so: it has no magic).
// Lossy WebP (what a web page asks for): the picture within a small mean error, its alpha kept
// (transparent background stays transparent), and a fraction of the PNG's bytes.
TEST(Render, WebpIsLossySmallAndKeepsAlpha) {
  Rig cube = UnitCube();
  RenderOptions o = HeadOn(128);
  o.background = {0, 0, 0, 0};
  Image im;
  ASSERT_TRUE(Gl().Draw(cube, Evaluate(cube), o, im).ok());
  auto webp = offscreen::Encode(im, picture::ImageFormat::kWebp, 90);
  auto png = offscreen::Encode(im, picture::ImageFormat::kPng);
  ASSERT_TRUE(webp.ok() && png.ok());
  EXPECT_EQ(webp->substr(0, 4), "RIFF");
  EXPECT_LT(webp->size() * 2, png->size());
  auto back = offscreen::Decode(std::vector<unsigned char>(webp->begin(), webp->end()));
  ASSERT_TRUE(back.ok()) << back.status().message;
  ASSERT_EQ(back->rgba.size(), im.rgba.size());
  double sum_err = 0;
  float alpha_err = 0;
  for (size_t i = 0; i < im.rgba.size(); i += 4) {
    for (int c = 0; c < 3; ++c)
      sum_err += std::fabs(Srgb(back->rgba[i + c] * back->rgba[i + 3]) -
                           Srgb(im.rgba[i + c] * im.rgba[i + 3]));
    alpha_err = std::max(alpha_err, std::fabs(back->rgba[i + 3] - im.rgba[i + 3]));
  }
  EXPECT_LT(sum_err / (im.rgba.size() / 4 * 3), 0.02);
  EXPECT_LT(alpha_err, 1.5f / 255.0f);
  EXPECT_EQ(back->rgba[3], 0.0f);  // The corner: background, transparent.
}

// A label longer than its cell is cut to the cell (with "..."): no ink beyond the cell's right
// edge in the label strip (it used to run into the next cell).
TEST(Image, SheetLabelsStayInTheirCell) {
  Image white;
  white.width = white.height = 64;
  white.rgba.assign(64 * 64 * 4, 1.0f);
  const std::vector<Image> cells = {white, white};
  const std::vector<std::string> labels = {"a-very-long-label-that-would-cross-into-the-next-cell",
                                           "b"};
  const Image sheet = offscreen::ContactSheet(cells, labels, 2, {1, 1, 1, 1});
  ASSERT_GT(sheet.width, 128);
  const int pad = 4, label_h = 18, x_edge = pad + 64;  // Cell 0 spans [pad, pad + 64).
  size_t ink_in_cell = 0, ink_beyond = 0;
  for (int y = pad + 64; y < pad + 64 + label_h; ++y) {
    for (int x = pad; x < sheet.width; ++x) {
      const float v = sheet.rgba[(static_cast<size_t>(y) * sheet.width + x) * 4];
      const bool ink = v < 0.5f;
      if (x < x_edge)
        ink_in_cell += ink;
      else if (x < x_edge + pad + 4)
        ink_beyond += ink;  // The gap and the next cell's first pixels.
    }
  }
  EXPECT_GT(ink_in_cell, 20u);  // The label is drawn (its cut start).
  EXPECT_EQ(ink_beyond, 0u);
}

// Cells narrower than "..." and labels with no ink (empty, spaces) draw no label and never
// overflow (the font's box for blank text is inverted: checked under UBSan in CI).
TEST(Image, SheetTakesTinyCellsAndBlankLabels) {
  Image grey;
  grey.width = grey.height = 16;
  grey.rgba.assign(16 * 16 * 4, 0.5f);
  const std::vector<Image> cells = {grey, grey, grey};
  const std::vector<std::string> labels = {"open", "", "   "};
  const Image sheet = offscreen::ContactSheet(cells, labels, 3, {1, 1, 1, 1});
  ASSERT_EQ(sheet.height > 16, true);
  ASSERT_GE(sheet.width, 3 * 16);
  size_t ink = 0;  // Label strip of the blank cells: background only.
  for (int y = 4 + 16; y < sheet.height; ++y) {
    for (int x = sheet.width / 3; x < sheet.width; ++x)
      ink += sheet.rgba[(static_cast<size_t>(y) * sheet.width + x) * 4] < 0.5f;
  }
  EXPECT_EQ(ink, 0u);
}

TEST(Image, DecodesBmpAndTgaTextures) {
  std::vector<unsigned char> bmp = {
      'B', 'M', 62,  0,   0, 0, 0, 0, 0, 0, 54, 0, 0, 0,  // File header.
      40,  0,   0,   0,   2, 0, 0, 0, 1, 0, 0,  0, 1, 0, 24, 0, 0, 0, 0, 0,
      8,   0,   0,   0,   0, 0, 0, 0, 0, 0, 0,  0, 0, 0, 0,  0, 0, 0, 0, 0,  // Info header.
      0,   0,   255, 255, 0, 0, 0, 0};  // BGR red, BGR blue, padding.
  std::vector<unsigned char> tga = {0, 0, 2,   0,   0, 0, 0, 0,  0,
                                    0, 0, 0,   2,   0, 1, 0, 24, 0,  // Uncompressed true colour.
                                    0, 0, 255, 255, 0, 0};
  for (const auto& [bytes, mime] :
       {std::pair{bmp, std::string("image/bmp")}, std::pair{tga, std::string("image/x-tga")}}) {
    auto im = offscreen::Decode(bytes, mime);
    ASSERT_TRUE(im.ok()) << mime << ": " << im.status().message;
    ASSERT_EQ(im->width, 2);
    ASSERT_EQ(im->height, 1);
    EXPECT_NEAR(im->rgba[0], 1.0f, 1e-3f) << mime;  // Red.
    EXPECT_NEAR(im->rgba[2], 0.0f, 1e-3f) << mime;
    EXPECT_NEAR(im->rgba[4], 0.0f, 1e-3f) << mime;  // Blue.
    EXPECT_NEAR(im->rgba[6], 1.0f, 1e-3f) << mime;
  }
  EXPECT_FALSE(offscreen::Decode(tga).ok());  // Without the hint: no magic.
}

// ---- occlusion -----------------------------------------------------------------------------

// The rig's occlusion baked at its neutral weights, as the service bakes it (api's DerivedRigs).
std::shared_ptr<const RigOcclusion> Baked(const Rig& rig) {
  return std::make_shared<const RigOcclusion>(
      BakeRigOcclusion(rig, Evaluate(rig), OcclusionSettings{}));
}

// The mean luminance of the (2r+1)^2 pixels around (x, y) of a linear-light image.
float PatchLuma(const Image& im, int x, int y, int r = 2) {
  float sum = 0;
  int n = 0;
  for (int j = y - r; j <= y + r; ++j) {
    for (int i = x - r; i <= x + r; ++i) {
      const float* px = &im.rgba[4 * (static_cast<size_t>(j) * static_cast<size_t>(im.width) +
                                      static_cast<size_t>(i))];
      sum += Luma({px[0], px[1], px[2]});
      ++n;
    }
  }
  return sum / static_cast<float>(n);
}

// The rig drawn at 256 x 256 (from 20 degrees below: under the chin shows) without and with its
// baked occlusion, both written beside the test (NAME_off/on.actual.png) for a person to look at.
std::pair<Image, Image> WithoutAndWith(const std::string& name, const Rig& rig,
                                       const std::vector<float>& w) {
  const BlendedRig blended = Evaluate(rig, w);
  RenderOptions o;
  o.width = o.height = 256;
  o.camera.pitch = -20;
  std::pair<Image, Image> drawn;
  EXPECT_TRUE(Gl().Draw(rig, blended, o, drawn.first).ok());
  o.occlusion = Baked(rig);
  EXPECT_TRUE(Gl().Draw(rig, blended, o, drawn.second).ok());
  test::WriteBytes(name + "_off.actual.png",
                   offscreen::Encode(drawn.first, picture::ImageFormat::kPng).value());
  test::WriteBytes(name + "_on.actual.png",
                   offscreen::Encode(drawn.second, picture::ImageFormat::kPng).value());
  return drawn;
}

struct Place {
  const char* name;
  int x, y;
};

// With over without occlusion, in linear light, around each place.
void ExpectRatios(const std::pair<Image, Image>& drawn, std::initializer_list<Place> creases,
                  std::initializer_list<Place> open) {
  for (const Place& p : creases)
    EXPECT_LT(PatchLuma(drawn.second, p.x, p.y) / PatchLuma(drawn.first, p.x, p.y), 0.75f)
        << p.name;
  for (const Place& p : open)
    EXPECT_GT(PatchLuma(drawn.second, p.x, p.y) / PatchLuma(drawn.first, p.x, p.y), 0.9f) << p.name;
}

// Baked occlusion darkens the creases against the same render without it (FaceCap's nostrils and
// open mouth, MakeHuman's fold under the chin) and leaves open skin (forehead, cheeks) nearly as it
// was. The places were picked on the renders the test writes.
TEST(Occlusion, DarkensCreasesAndLeavesOpenSkin) {
  auto facecap = formats::LoadRigFile(test::Bundled("facecap/facecap.glb"));
  ASSERT_TRUE(facecap.ok());
  std::vector<float> w(facecap->shapes.size(), 0.0f);
  w[static_cast<size_t>(FindShape(facecap.value(), "jawOpen"))] = 1.0f;
  ExpectRatios(WithoutAndWith("occlusion_facecap", facecap.value(), w),
               {{"a nostril", 134, 125}, {"the open mouth", 127, 165}},
               {{"forehead", 128, 75}, {"right cheek", 95, 135}, {"left cheek", 160, 135}});
  auto makehuman = formats::LoadRigFile(test::Bundled("makehuman/makehuman.glb"));
  ASSERT_TRUE(makehuman.ok());
  ExpectRatios(WithoutAndWith("occlusion_makehuman", makehuman.value(), {}),
               {{"under the chin", 124, 191}}, {{"forehead", 128, 70}, {"cheek", 100, 132}});
}

// ---- goldens of real assets ---------------------------------------------------------------

struct GoldenCase {
  const char* name;
  const char* asset;
  std::vector<std::pair<std::string, float>> weights;
  picture::View view;
  float yaw, pitch;
  const char* animation = nullptr;  // Skinned assets: a clip and a time.
  float time = 0.0f;
  bool checker = false;  // Every material's base colour: a checker over the UVs (shows UV seams).
  const char* expression = nullptr;  // An expression at 1 (core/face.h), over the weights.
};

// A 512 x 512 checker of 16 x 16 squares, two colours, with a red cell at the atlas's (0, 0) corner
// and a blue one at (1, 1) so an upside-down map shows.
std::vector<unsigned char> CheckerPng() {
  Image im;
  im.width = im.height = 512;
  for (int y = 0; y < 512; ++y) {
    for (int x = 0; x < 512; ++x) {
      const bool odd = ((x / 32) + (y / 32)) % 2;
      std::array<float, 3> c = odd ? std::array<float, 3>{0.9f, 0.85f, 0.75f}
                                   : std::array<float, 3>{0.15f, 0.25f, 0.35f};
      if (x < 32 && y < 32) c = {0.9f, 0.05f, 0.05f};
      if (x >= 480 && y >= 480) c = {0.05f, 0.1f, 0.9f};
      im.rgba.insert(im.rgba.end(), {c[0], c[1], c[2], 1.0f});
    }
  }
  auto png = offscreen::Encode(im, picture::ImageFormat::kPng);
  EXPECT_TRUE(png.ok());
  return {png->begin(), png->end()};
}

void PrintTo(const GoldenCase& c, std::ostream* os) { *os << c.name; }

class Golden : public ::testing::TestWithParam<GoldenCase> {};

// The image as RGBA: an opaque render's PNG is RGB (alpha 1 added here), so it compares with
// goldens written as RGBA. Uninitialized when the file cannot be read.
OIIO::ImageBuf ReadWithAlpha(const std::string& path) {
  OIIO::ImageBuf in(path);
  if (!in.read()) return {};
  if (in.nchannels() == 4) return in;
  const int order[4] = {0, 1, 2, -1};
  const float fill[4] = {0, 0, 0, 1};
  return OIIO::ImageBufAlgo::channels(in, 4, order, fill);
}

TEST_P(Golden, MatchesCommittedImage) {
  const GoldenCase& c = GetParam();
  // '@': bundled in assets/; '+': the shared more/ data (FBX, COLLADA, MD5); else the shared real/
  // glTFs.
  auto rig =
      formats::LoadRigFile(c.asset[0] == '@'   ? test::Bundled(c.asset + 1)
                           : c.asset[0] == '+' ? test::SharedAssets() + "/more/" + (c.asset + 1)
                                               : test::RealAsset(c.asset));
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  if (c.checker) {
    rig->images.push_back({"checker", "image/png", CheckerPng()});
    if (rig->materials.empty()) rig->materials.emplace_back();
    for (Material& m : rig->materials)
      m.base_color_image = static_cast<int>(rig->images.size() - 1),
      m.base_color_factor = {1, 1, 1, 1};
    for (Primitive& p : rig->primitives) p.material = p.material < 0 ? 0 : p.material;
    ASSERT_TRUE(ValidateRig(rig.value()).ok());
  }
  std::vector<float> w(rig->shapes.size(), 0.0f);
  for (const auto& [name, value] : c.weights) {
    const int s = FindShape(rig.value(), name);
    ASSERT_GE(s, 0) << name;
    w[s] = value;
  }
  if (c.expression) {
    const int e = FindExpression(rig.value(), c.expression);
    ASSERT_GE(e, 0) << c.expression;
    std::vector<float> values(rig->expressions.size(), 0.0f);
    values[static_cast<size_t>(e)] = 1.0f;
    AddExpressionWeights(rig.value(), values, ExpressionMultipliers{}, w);
  }
  BlendedRig blended = Evaluate(rig.value(), w);
  if (c.animation) {
    PoseRequest req;
    req.clips.push_back(ClipRequest{.name = c.animation, .time = c.time, .pointer = "/animation"});
    Pose pose;
    bool posed = false;
    std::vector<Warning> warnings;
    std::vector<WeightEntry> none;
    ASSERT_TRUE(ResolvePoseAndWeights(rig.value(), none, req, w, pose, posed, warnings).ok());
    BlendContext ctx;
    BlendOptions bo;
    bo.pose = &pose;
    ASSERT_TRUE(EvaluateRig(rig.value(), w, bo, blended, ctx).ok());
  }
  RenderOptions o;
  o.width = o.height = 256;
  o.view = c.view;
  o.camera.yaw = c.yaw;
  o.camera.pitch = c.pitch;
  o.supersample = 2;
  if (c.view != picture::View::kHeatmap && c.view != picture::View::kNormals)
    o.occlusion = Baked(rig.value());
  Image im;
  ASSERT_TRUE(Gl().Draw(rig.value(), blended, o, im).ok());
  auto png = offscreen::Encode(im, picture::ImageFormat::kPng);
  ASSERT_TRUE(png.ok());
  const std::string golden =
      std::string(FACESPACE_SOURCE_DIR) + "/tests/render/golden/" + c.name + ".png";
  const char* update = std::getenv("FACESPACE_UPDATE_GOLDENS");
  if (update && *update == '1') {
    test::WriteBytes(golden, png.value());
    GTEST_SKIP() << "golden rewritten: look at " << golden;
  }
  // Keep what we rendered beside the build for a person to look at when this fails.
  test::WriteBytes(std::string(c.name) + ".actual.png", png.value());
  OIIO::ImageBuf expected = ReadWithAlpha(golden);
  ASSERT_TRUE(expected.initialized()) << "missing golden " << golden;
  OIIO::ImageBuf actual = ReadWithAlpha(std::string(c.name) + ".actual.png");
  ASSERT_TRUE(actual.initialized());
  // OIIO's comparison: a pixel fails when a channel differs by more than 6/255; allow 0.5%
  // of the pixels to (rasterisation on another CPU may move an edge by a pixel).
  const auto cmp = OIIO::ImageBufAlgo::compare(actual, expected, 6.0f / 255.0f, 2.0f / 255.0f);
  const double npix = 256.0 * 256.0;
  EXPECT_LE(static_cast<double>(cmp.nfail), 0.005 * npix)
      << "mean " << cmp.meanerror << " max " << cmp.maxerror;
  EXPECT_LT(cmp.meanerror, 1.0 / 255.0);
}

INSTANTIATE_TEST_SUITE_P(
    RealAssets, Golden,
    // One case a line (or two), as a table reads:
    // clang-format off
    ::testing::Values(
        GoldenCase{"facecap_neutral", "@facecap/facecap.glb", {}, picture::View::kShaded, 0, 0},
        GoldenCase{"facecap_jaw_open", "@facecap/facecap.glb", {{"jawOpen", 1.0f}},
                   picture::View::kShaded, 0, 0},
        GoldenCase{"uka_neutral", "@uka/MS_Uka.pmx", {}, picture::View::kShaded, 0, 0},
        GoldenCase{"uka_happy_still", "@uka/MS_Uka.pmx", {},
                   picture::View::kShaded, 0, 0, nullptr, 0.0f, false, "happy"},
        GoldenCase{"uka_blush", "@uka/MS_Uka.pmx", {{"照れ", 1.0f}, {"赤み", 1.0f}},
                   picture::View::kShaded, 0, 0},
        GoldenCase{"makehuman_neutral", "@makehuman/makehuman.glb", {},
                   picture::View::kShaded, 0, 0},
        GoldenCase{"makehuman_happy", "@makehuman/makehuman.glb", {},
                   picture::View::kShaded, 0, 0, nullptr, 0.0f, false, "happy"},
        GoldenCase{"facecap_jaw_smile", "@facecap/facecap.glb",
                   {{"jawOpen", 0.6f}, {"mouthSmile_L", 0.8f}, {"mouthSmile_R", 0.8f}},
                   picture::View::kShaded, 25, 10},
        GoldenCase{"facecap_heatmap", "@facecap/facecap.glb",
                   {{"jawOpen", 0.6f}, {"eyeBlink_L", 1.0f}}, picture::View::kHeatmap, 0, 0},
        GoldenCase{"facecap_wireframe", "@facecap/facecap.glb", {{"browInnerUp", 1.0f}},
                   picture::View::kWireframe, -30, 0},
        GoldenCase{"stress_textured", "MorphStressTest/MorphStressTest.gltf",
                   {{"Key 3", 1.0f}, {"Key 6", 0.5f}}, picture::View::kShaded, 30, 20},
        GoldenCase{"sphere_normals", "AnimatedMorphSphere/AnimatedMorphSphere.gltf",
                   {{"Blob", 0.8f}}, picture::View::kNormals, 0, 0},
        GoldenCase{"primitives_jpeg_texture", "MorphPrimitivesTest/MorphPrimitivesTest.gltf",
                   {{"target_0", 1.0f}}, picture::View::kShaded, 20, 30},
        GoldenCase{"fox_run", "Fox/Fox.glb", {}, picture::View::kShaded, 90, 10, "Run", 0.4f},
        GoldenCase{"cesium_man_walk", "CesiumMan/CesiumMan.gltf", {},
                   picture::View::kShaded, 60, 0, "animation_0", 0.9f},
        GoldenCase{"makehuman_skin", "@makehuman/makehuman.glb",
                   {{"nose-trans-down", 1.0f}, {"mouth-scale-horiz-incr", 0.6f}},
                   picture::View::kShaded, 0, 0},
        GoldenCase{"makehuman_uv_checker", "@makehuman/makehuman.glb", {},
                   picture::View::kShaded, 35, 5, nullptr, 0.0f, true},
        GoldenCase{"uka_happy", "@uka/MS_Uka.pmx", {},
                   picture::View::kShaded, 15, 0, "01_happy", 1.5f},
        GoldenCase{"fbx_inbetween",
                   "+FBX/ufbx_maya_blend_inbetween/maya_blend_inbetween_7500_binary.fbx",
                   {{"LiftTop", 0.5f}, {"MoveToSide", 1.0f}}, picture::View::kShaded, 30, 20},
        GoldenCase{"collada_skin_on_morph", "+Collada/CTS_skin_on_morph/skin_on_morph.dae", {},
                   picture::View::kShaded, 30, 15},
        GoldenCase{"md5_bob", "+MD5/Bob/Bob.md5mesh", {}, picture::View::kShaded, 20, 5},
        GoldenCase{"rigged_simple_bend", "RiggedSimple/RiggedSimple.gltf", {},
                   picture::View::kWireframe, 0, 0, "animation_0", 0.6f}),
    // clang-format on
    [](const auto& param_info) { return std::string(param_info.param.name); });

}  // namespace
}  // namespace facespace

namespace facespace {
namespace {

TEST(NullRenderer, FillsTheBackgroundAndChecksItsInputsAsGlDoes) {
  const Rig cube = UnitCube();
  const offscreen::NullRenderer null;
  RenderOptions o = HeadOn(8);
  o.background = {1.0f, 0.5f, 0.0f, 1.0f};
  Image im;
  ASSERT_TRUE(null.Draw(cube, Evaluate(cube), o, im).ok());
  ASSERT_EQ(im.width, 8);
  ASSERT_EQ(im.rgba.size(), 8u * 8u * 4u);
  EXPECT_FLOAT_EQ(im.rgba[0], 1.0f);
  EXPECT_NEAR(im.rgba[1], 0.2140f, 1e-4);  // sRGB 0.5 in linear light.
  EXPECT_FLOAT_EQ(im.rgba[2], 0.0f);
  o.supersample = 5;
  EXPECT_EQ(null.Draw(cube, Evaluate(cube), o, im).code, StatusCode::kInvalidArgument);
  EXPECT_EQ(Gl().Draw(cube, Evaluate(cube), o, im).code, StatusCode::kInvalidArgument);
}

// Halves as IEEE rounds them (nearest, ties to even), the same as F16C's on a million floats of
// every kind, and a half EXR of normals read back by OpenImageIO as those halves.
__attribute__((target("avx,f16c"))) uint16_t F16cHalf(float f) {
  return static_cast<uint16_t>(_cvtss_sh(f, _MM_FROUND_TO_NEAREST_INT));
}

TEST(DataExr, HalvesRoundToNearestEvenAsF16cDoes) {
  EXPECT_EQ(offscreen::HalfOf(1.0f), 0x3c00);
  EXPECT_EQ(offscreen::HalfOf(-2.0f), 0xc000);
  EXPECT_EQ(offscreen::HalfOf(65504.0f), 0x7bff);
  EXPECT_EQ(offscreen::HalfOf(65520.0f), 0x7c00);  // Rounds up past the largest: infinity.
  EXPECT_EQ(offscreen::HalfOf(std::ldexp(1.0f, -24)), 0x0001);  // The smallest subnormal.
  EXPECT_EQ(offscreen::HalfOf(std::ldexp(1.0f, -25)),
            0x0000);  // Half of it: a tie, to even (zero).
  EXPECT_EQ(offscreen::HalfOf(std::ldexp(1.5f, -25)), 0x0001);
  EXPECT_EQ(offscreen::HalfOf(1.0f + std::ldexp(1.0f, -11)),
            0x3c00);  // A tie between 1 and the next: even.
  EXPECT_EQ(offscreen::HalfOf(1.0f + std::ldexp(3.0f, -11)),
            0x3c02);  // A tie the other way: even again.
  EXPECT_EQ(offscreen::HalfOf(-0.0f), 0x8000);
  if (!__builtin_cpu_supports("avx2")) GTEST_SKIP() << "no F16C (AVX2) to compare with";
  uint32_t state = 12345, differing = 0;
  for (int i = 0; i < 1000000; ++i) {
    state = state * 1664525u + 1013904223u;
    uint32_t bits = state;
    if (i % 2)
      bits = (bits & 0x8fffffffu) |
             0x30000000u;  // Half of them near the half range (subnormals to 2^2).
    float f;
    std::memcpy(&f, &bits, 4);
    if (std::isnan(f)) continue;
    differing += offscreen::HalfOf(f) != F16cHalf(f);
  }
  EXPECT_EQ(differing, 0u);
}

TEST(DataExr, HalfNormalsReadBackAsTheirHalves) {
  const int w = 5, h = 37;  // Blocks of 16 lines and a short last one.
  std::vector<float> normals(static_cast<size_t>(w) * h * 3);
  for (size_t i = 0; i < normals.size(); ++i) normals[i] = std::sin(0.37f * static_cast<float>(i));
  auto exr = offscreen::EncodeDataExr(normals, w, h, 3, picture::DataPrecision::kHalf);
  ASSERT_TRUE(exr.ok());
  OIIO::Filesystem::IOMemReader proxy(exr->data(), exr->size());
  auto in = OIIO::ImageInput::open("n.exr", nullptr, &proxy);
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().format, OIIO::TypeDesc::HALF);
  std::vector<uint16_t> back(normals.size());
  ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::HALF, back.data()));
  for (size_t i = 0; i < normals.size(); ++i)
    ASSERT_EQ(back[i], offscreen::HalfOf(normals[i])) << i;
}

}  // namespace
}  // namespace facespace
