// Render latency: the bundled FaceCap head (8k triangles) and a 100k-triangle mesh, at
// 512x512 and 1024x1024, with and without PNG encoding. One draw at a time, llvmpipe
// rasterising on one thread per core as the service runs it (LP_NUM_THREADS=0 in the
// environment measures drawing on the calling thread, as before).
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>

#include "facespace/engine/shape_tools.h"
#include "facespace/formats/io.h"
#include "facespace/offscreen/render.h"

namespace {

using namespace facespace;

// A 224x224-vertex wavy sheet: 2 * 223 * 223 = 99,458 triangles.
Rig BigMesh() {
  Rig rig;
  Primitive p;
  const int n = 224;
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const float u = static_cast<float>(x) / (n - 1) * 2 - 1,
                  v = static_cast<float>(y) / (n - 1) * 2 - 1;
      p.positions.insert(p.positions.end(), {u, v, 0.1f * std::sin(6 * u) * std::cos(5 * v)});
    }
  }
  for (uint32_t y = 0; y + 1 < n; ++y) {
    for (uint32_t x = 0; x + 1 < n; ++x) {
      const uint32_t a = y * n + x;
      p.indices.insert(p.indices.end(), {a, a + 1, a + n + 1, a, a + n + 1, a + n});
    }
  }
  FinalizePrimitive(p);
  rig.primitives.push_back(std::move(p));
  rig.meshes.push_back(Mesh{.name = "sheet", .primitives = {0}, .target_shapes = {}});
  rig.nodes.push_back(Node{.name = "sheet", .mesh = 0});
  rig.scene_roots = {0};
  return rig;
}

const Rig& Case(int which) {
  static const Rig face =
      formats::LoadRigFile(FACESPACE_SOURCE_DIR "/assets/facecap/facecap.glb").value();
  static const Rig big = BigMesh();
  if (which == 2) {
    static const Rig uka =
        formats::LoadRigFile(FACESPACE_SOURCE_DIR "/assets/uka/MS_Uka.pmx").value();
    return uka;
  }
  return which == 0 ? face : big;
}

const char* CaseName(int which) {
  return which == 0 ? "facecap 8k tris" : which == 1 ? "sheet 100k tris" : "uka 78k tris";
}

// The rig's occlusion baked at its neutral weights, as the service bakes it once per rig and level.
std::shared_ptr<const RigOcclusion> Baked(const Rig& rig) {
  BlendedRig rest;
  BlendContext ctx;
  EvaluateRig(rig, std::vector<float>(rig.shapes.size(), 0.0f), {}, rest, ctx);
  return std::make_shared<const RigOcclusion>(BakeRigOcclusion(rig, rest, OcclusionSettings{}));
}

// The bake itself: what a rig's first shaded render waits for.
void BM_BakeOcclusion(benchmark::State& state) {
  const Rig& rig = Case(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(Baked(rig));
  state.SetLabel(CaseName(static_cast<int>(state.range(0))));
  state.counters["vertices"] = static_cast<double>(rig.vertex_count());
}
BENCHMARK(BM_BakeOcclusion)
    ->ArgName("mesh")
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(0.5);

// One renderer for every benchmark: its GL contexts are made once.
const offscreen::OsMesaRenderer& Renderer() {
  static const offscreen::OsMesaRenderer renderer;
  return renderer;
}

// The 512x512 FaceCap render (jawOpen at 0.5) the encoder benchmarks encode, drawn once as floats
// and once straight into 8-bit sRGB (RenderOptions::srgb8, what the render route draws for 8-bit
// files). FaceCap blended with jawOpen at 0.5, once.
const BlendedRig& FaceCapJawHalfOpen() {
  static const BlendedRig blended = [] {
    const Rig& rig = Case(0);
    std::vector<float> w(rig.shapes.size(), 0.0f);
    w[24] = 0.5f;  // jawOpen
    BlendedRig b;
    BlendContext ctx;
    EvaluateRig(rig, w, {}, b, ctx);
    return b;
  }();
  return blended;
}

picture::Image Draw512(bool srgb8) {
  const Rig& rig = Case(0);
  const BlendedRig& blended = FaceCapJawHalfOpen();
  picture::RenderOptions o;
  o.width = o.height = 512;
  o.srgb8 = srgb8;
  picture::Image drawn;
  (void)Renderer().Draw(rig, blended, o, drawn);
  return drawn;
}

const picture::Image& FaceCapImage(bool srgb8 = false) {
  static const picture::Image floats = Draw512(false), bytes = Draw512(true);
  return srgb8 ? bytes : floats;
}

void BM_Render(benchmark::State& state) {
  const Rig& rig = Case(static_cast<int>(state.range(0)));
  const int size = static_cast<int>(state.range(1));
  const bool png = state.range(2) != 0;
  const bool srgb8 = state.range(3) != 0;
  std::vector<float> w(rig.shapes.size(), 0.0f);
  if (!w.empty()) w[24] = 0.5f;  // jawOpen on FaceCap.
  BlendedRig blended;
  BlendContext ctx;
  EvaluateRig(rig, w, {}, blended, ctx);
  picture::RenderOptions o;
  o.width = o.height = size;
  o.srgb8 = srgb8;
  o.occlusion = Baked(rig);
  // The framing box of the shapes, found once per rig as the service keeps it (api's DerivedRig).
  o.camera.has_focus = ShapeFocusBox(rig, o.camera.focus_min, o.camera.focus_max);
  o.camera.focus_small =
      o.camera.has_focus && FrameShapesByDefault(rig, o.camera.focus_min, o.camera.focus_max);
  o.camera.focus_joint = o.camera.focus_small ? ShapeFocusJoint(rig) : -1;
  picture::Image image;
  size_t bytes = 0;
  for (auto _ : state) {
    if (!Renderer().Draw(rig, blended, o, image).ok()) state.SkipWithError("render failed");
    if (png) bytes = offscreen::Encode(image, picture::ImageFormat::kPng).value().size();
    benchmark::DoNotOptimize(image.rgba.data());
  }
  state.SetLabel(std::string(CaseName(static_cast<int>(state.range(0)))) +
                 (srgb8 ? ", 8-bit sRGB" : ", float") + (png ? " + PNG" : ""));
  state.counters["triangles"] = static_cast<double>(rig.triangle_count());
  if (png) state.counters["png_KB"] = bytes / 1024.0;
}

BENCHMARK(BM_Render)
    ->ArgsProduct({{0, 1}, {512, 1024}, {0, 1}, {0, 1}})
    ->ArgNames({"mesh", "size", "png", "srgb8"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()  // llvmpipe's threads do the drawing: the wall clock is what a client waits.
    ->MinTime(1.0);

// A labelled sample's draw (api/batch/dataset.h): FaceCap at 256 x 256 and 512 x 512 in 8-bit sRGB,
// with the label planes (distance, normal, segment) or without, one draw at a time.
void BM_RenderLabels(benchmark::State& state) {
  const Rig& rig = Case(0);
  const BlendedRig& blended = FaceCapJawHalfOpen();
  picture::RenderOptions o;
  o.width = o.height = static_cast<int>(state.range(0));
  o.srgb8 = true;
  o.labels = state.range(1) != 0;
  o.occlusion = Baked(rig);
  picture::Image image;
  for (auto _ : state) {
    if (!Renderer().Draw(rig, blended, o, image).ok()) state.SkipWithError("render failed");
    benchmark::DoNotOptimize(image.srgb8.data());
  }
  state.SetLabel(o.labels ? "with labels" : "picture only");
}
BENCHMARK(BM_RenderLabels)
    ->ArgsProduct({{256, 512}, {0, 1}})
    ->ArgNames({"size", "labels"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(0.5);

// The encoder settings, measured on the 512x512 FaceCap render (8-bit sRGB RGBA, as Encode
// hands it to OpenImageIO): PNG zlib levels and row filters, WebP lossless and lossy.
// kind: 0 PNG (arg = zlib level, filter = libpng's filter mask, 0 = libpng's choice), 1 WebP (arg =
// quality, 100 = lossless).
void BM_Encode(benchmark::State& state) {
  static const std::vector<unsigned char> px = [] {
    const picture::Image& image = FaceCapImage();
    std::vector<unsigned char> out(image.rgba.size());
    for (size_t i = 0; i < out.size(); ++i) {
      const float c = std::clamp(image.rgba[i], 0.0f, 1.0f);
      out[i] = static_cast<unsigned char>(
          std::lround((i % 4 == 3 ? c : std::pow(c, 1.0f / 2.2f)) * 255.0f));
    }
    return out;
  }();
  const bool png = state.range(0) == 0;
  const int arg = static_cast<int>(state.range(1)), filter = static_cast<int>(state.range(2));
  size_t bytes = 0;
  for (auto _ : state) {
    std::vector<unsigned char> out;
    OIIO::Filesystem::IOVecOutput proxy(out);
    const std::string name = png ? "image.png" : "image.webp";
    auto writer = OIIO::ImageOutput::create(name, &proxy);
    OIIO::ImageSpec spec(512, 512, 4, OIIO::TypeDesc::UINT8);
    if (png) {
      spec.attribute("png:compressionLevel", arg);
      if (filter) spec.attribute("png:filter", filter);
    } else {
      spec.attribute("compression", arg >= 100 ? "lossless" : "webp:" + std::to_string(arg));
    }
    if (!writer || !writer->open(name, spec) ||
        !writer->write_image(OIIO::TypeDesc::UINT8, px.data()) || !writer->close()) {
      state.SkipWithError("encoding failed");
    }
    bytes = out.size();
  }
  state.SetLabel(png ? "png level " + std::to_string(arg) +
                           (filter ? " filter " + std::to_string(filter) : " filter libpng's")
                 : arg >= 100 ? "webp lossless"
                              : "webp quality " + std::to_string(arg));
  state.counters["KB"] = bytes / 1024.0;
}

// Our PNG writer (offscreen::Encode) on the same 512x512 FaceCap render, from the float image (the
// sRGB conversion, UP filter and igzip level 0 in one pass) or from the 8-bit draw (UP and igzip).
void BM_EncodeOurs(benchmark::State& state) {
  const picture::Image& image = FaceCapImage(state.range(0) != 0);
  if (image.rgba.empty() && image.srgb8.empty()) state.SkipWithError("render failed");
  size_t bytes = 0;
  for (auto _ : state) {
    bytes = offscreen::Encode(image, picture::ImageFormat::kPng).value().size();
  }
  state.SetLabel(state.range(0) ? "png ours (8-bit sRGB in, igzip level 0, UP)"
                                : "png ours (float in, igzip level 0, UP)");
  state.counters["KB"] = bytes / 1024.0;
}
BENCHMARK(BM_EncodeOurs)
    ->ArgName("srgb8")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(0.5);

// {webp, level, filter}: PNG at deflate levels and filters (PNG_FILTER_NONE 0x08, SUB 0x10, UP
// 0x20, PAETH 0x80), then WebP at qualities.
void EncodeCases(benchmark::internal::Benchmark* b) {
  const std::array<int64_t, 3> cases[] = {{0, 6, 0},    {0, 1, 0},    {0, 1, 0x08}, {0, 1, 0x10},
                                          {0, 1, 0x20}, {0, 1, 0x80}, {0, 2, 0x10}, {0, 3, 0x20},
                                          {0, 6, 0x20}, {1, 100, 0},  {1, 90, 0},   {1, 75, 0}};
  for (const auto& c : cases) b->Args({c[0], c[1], c[2]});
}
BENCHMARK(BM_Encode)
    ->Apply(EncodeCases)
    ->ArgNames({"webp", "level", "filter"})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5);

}  // namespace

BENCHMARK_MAIN();
