// Render latency: the bundled FaceCap head (8k triangles) and a 100k-triangle mesh, at
// 512x512 and 1024x1024, with and without PNG encoding. One thread (llvmpipe in the
// calling thread, as the service runs it).
#include <benchmark/benchmark.h>

#include <cmath>

#include "facespace/core/io.h"
#include "facespace/render/render.h"

namespace {

using namespace facespace;

// A 224x224-vertex wavy sheet: 2 * 223 * 223 = 99,458 triangles.
Rig BigMesh() {
  Rig rig;
  Primitive p;
  const int n = 224;
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const float u = static_cast<float>(x) / (n - 1) * 2 - 1, v = static_cast<float>(y) / (n - 1) * 2 - 1;
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
  static const Rig face = LoadRigFile(FACESPACE_SOURCE_DIR "/assets/facecap/facecap.glb").value();
  static const Rig big = BigMesh();
  return which == 0 ? face : big;
}

void BM_Render(benchmark::State& state) {
  const Rig& rig = Case(static_cast<int>(state.range(0)));
  const int size = static_cast<int>(state.range(1));
  const bool png = state.range(2) != 0;
  std::vector<float> w(rig.shapes.size(), 0.0f);
  if (!w.empty()) w[24] = 0.5f;  // jawOpen on FaceCap.
  BlendedRig blended;
  BlendContext ctx;
  EvaluateRig(rig, w, {}, blended, ctx);
  render::RenderOptions o;
  o.width = o.height = size;
  render::Image image;
  static const render::OsMesaRenderer renderer;
  size_t bytes = 0;
  for (auto _ : state) {
    if (!renderer.Draw(rig, blended, o, image).ok()) state.SkipWithError("render failed");
    if (png) bytes = render::Encode(image, render::ImageFormat::kPng).value().size();
    benchmark::DoNotOptimize(image.rgba.data());
  }
  state.SetLabel(std::string(state.range(0) == 0 ? "facecap 8k tris" : "sheet 100k tris") + (png ? " + PNG" : ""));
  state.counters["triangles"] = static_cast<double>(rig.triangle_count());
  if (png) state.counters["png_KB"] = bytes / 1024.0;
}

BENCHMARK(BM_Render)
    ->ArgsProduct({{0, 1}, {512, 1024}, {0, 1}})
    ->ArgNames({"mesh", "size", "png"})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0);

}  // namespace

BENCHMARK_MAIN();
