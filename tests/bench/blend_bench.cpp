// Blend layouts compared on synthetic rigs (README "Blend layout"):
//   ByShapeRuns    production BlendShapeJob: per shape, runs of consecutive moved vertices
//   ByShapeIndices per shape, one index per moved vertex (a plain scatter loop)
//   ByVertexCsr    per vertex, the (shape, delta) pairs that move it (GPU-morphing style)
//   DenseEigen     a dense 3N x S matrix times the weight vector
//   Memcpy         a plain copy of as many bytes as the sparse blend touches
// Cases: 50,000 vertices, 100 shapes, 10% moved each, 20% of weights non-zero; and a
// MetaHuman-sized head: 24,000 vertices, 669 shapes, 5% moved each, 60 active.
// Moved vertices are either clustered (contiguous patches, as face regions are in real
// meshes) or scattered (uniformly random: the worst case for runs).
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cstring>
#include <random>

#include "facespace/engine/blend.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/formats/io.h"

namespace {

using facespace::SparseTarget;

struct Synthetic {
  size_t vertices = 0;
  std::vector<float> base;
  std::vector<SparseTarget> targets;
  std::vector<float> weights;
  size_t active_entries = 0;  // Moved vertices summed over active shapes.
  size_t active_runs = 0;
};

Synthetic Make(size_t n, size_t shapes, double moved, size_t active, bool clustered,
               uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Synthetic s;
  s.vertices = n;
  s.base.resize(3 * n);
  for (float& f : s.base) f = u(rng);
  const size_t k = static_cast<size_t>(n * moved);
  for (size_t j = 0; j < shapes; ++j) {
    SparseTarget t;
    if (clustered) {
      // A few patches of 40..400 consecutive vertices, like a region of a face.
      std::vector<uint8_t> mark(n, 0);
      size_t count = 0;
      std::uniform_int_distribution<size_t> start(0, n - 1), len(40, 400);
      while (count < k) {
        const size_t a = start(rng), l = std::min(len(rng), k - count);
        for (size_t v = a; v < std::min(n, a + l); ++v) count += !mark[v], mark[v] = 1;
      }
      for (size_t v = 0; v < n; ++v)
        if (mark[v]) t.indices.push_back(static_cast<uint32_t>(v));
    } else {
      std::vector<uint32_t> all(n);
      for (size_t v = 0; v < n; ++v) all[v] = static_cast<uint32_t>(v);
      std::shuffle(all.begin(), all.end(), rng);
      t.indices.assign(all.begin(), all.begin() + k);
      std::sort(t.indices.begin(), t.indices.end());
    }
    t.position_deltas.resize(3 * t.indices.size());
    for (float& f : t.position_deltas) f = 0.1f * u(rng);
    facespace::FinalizeTarget(t);
    s.targets.push_back(std::move(t));
  }
  s.weights.assign(shapes, 0.0f);
  std::vector<size_t> order(shapes);
  for (size_t j = 0; j < shapes; ++j) order[j] = j;
  std::shuffle(order.begin(), order.end(), rng);
  for (size_t j = 0; j < active; ++j) {
    s.weights[order[j]] = 0.05f + 0.9f * (u(rng) * 0.5f + 0.5f);
    s.active_entries += s.targets[order[j]].indices.size();
    s.active_runs += s.targets[order[j]].runs.size() / 2;
  }
  return s;
}

const Synthetic& Case(int which) {
  static const Synthetic cases[4] = {
      Make(50000, 100, 0.10, 20, true, 1), Make(50000, 100, 0.10, 20, false, 2),
      Make(24000, 669, 0.05, 60, true, 3), Make(24000, 669, 0.05, 60, false, 4)};
  return cases[which];
}

const char* kCaseNames[4] = {"50k_100shapes_clustered", "50k_100shapes_scattered",
                             "metahuman_clustered", "metahuman_scattered"};

// Bytes a sparse blend must touch: read base, write out, read each active delta + index,
// and read-modify-write the vertex it moves.
double SparseBytes(const Synthetic& s) {
  return 24.0 * s.vertices + s.active_entries * (12.0 + 4.0 + 24.0);
}

void Report(benchmark::State& state, double bytes) {
  state.SetBytesProcessed(static_cast<int64_t>(bytes) * state.iterations());
  state.counters["touched_MB"] = bytes / 1e6;
}

void BM_ByShapeRuns(benchmark::State& state) {
  const Synthetic& s = Case(static_cast<int>(state.range(0)));
  std::vector<float> out(s.base.size());
  facespace::BlendShapeJob job{.base = s.base,
                               .weights = s.weights,
                               .targets = s.targets,
                               .channel = facespace::TargetChannel::kPosition,
                               .stride = 3,
                               .out = out};
  for (auto _ : state) {
    if (!job.Run()) state.SkipWithError("job failed");
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  Report(state, SparseBytes(s));
  state.SetLabel(kCaseNames[state.range(0)]);
  state.counters["runs"] = static_cast<double>(s.active_runs);
}

void BM_ByShapeIndices(benchmark::State& state) {
  const Synthetic& s = Case(static_cast<int>(state.range(0)));
  std::vector<float> out(s.base.size());
  for (auto _ : state) {
    std::memcpy(out.data(), s.base.data(), s.base.size() * 4);
    for (size_t t = 0; t < s.targets.size(); ++t) {
      const float w = s.weights[t];
      if (w == 0.0f) continue;
      const SparseTarget& st = s.targets[t];
      const float* d = st.position_deltas.data();
      for (uint32_t v : st.indices) {
        float* o = &out[3 * static_cast<size_t>(v)];
        o[0] += w * d[0];
        o[1] += w * d[1];
        o[2] += w * d[2];
        d += 3;
      }
    }
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  Report(state, SparseBytes(s));
  state.SetLabel(kCaseNames[state.range(0)]);
}

// Candidate: entries interleaved as {index, dx, dy, dz} (one 16-byte stream per shape).
void BM_ByShapeInterleaved(benchmark::State& state) {
  const Synthetic& s = Case(static_cast<int>(state.range(0)));
  struct Entry {
    uint32_t v;
    float d[3];
  };
  std::vector<std::vector<Entry>> packed(s.targets.size());
  for (size_t t = 0; t < s.targets.size(); ++t) {
    for (size_t k = 0; k < s.targets[t].indices.size(); ++k) {
      const float* d = &s.targets[t].position_deltas[3 * k];
      packed[t].push_back({s.targets[t].indices[k], {d[0], d[1], d[2]}});
    }
  }
  std::vector<float> out(s.base.size());
  for (auto _ : state) {
    std::memcpy(out.data(), s.base.data(), s.base.size() * 4);
    for (size_t t = 0; t < packed.size(); ++t) {
      const float w = s.weights[t];
      if (w == 0.0f) continue;
      for (const Entry& e : packed[t]) {
        float* o = &out[3 * static_cast<size_t>(e.v)];
        o[0] += w * e.d[0];
        o[1] += w * e.d[1];
        o[2] += w * e.d[2];
      }
    }
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  Report(state, SparseBytes(s));
  state.SetLabel(kCaseNames[state.range(0)]);
}

// Candidate: accumulate into a 16-byte-aligned xyz_ buffer with SSE, then compact to xyz.
void BM_ByShapePadded(benchmark::State& state) {
  const Synthetic& s = Case(static_cast<int>(state.range(0)));
  std::vector<std::vector<float>> d4(s.targets.size());
  for (size_t t = 0; t < s.targets.size(); ++t) {
    for (size_t k = 0; k < s.targets[t].indices.size(); ++k) {
      const float* d = &s.targets[t].position_deltas[3 * k];
      d4[t].insert(d4[t].end(), {d[0], d[1], d[2], 0.0f});
    }
  }
  std::vector<float> base4(4 * s.vertices, 0.0f);
  for (size_t v = 0; v < s.vertices; ++v) std::memcpy(&base4[4 * v], &s.base[3 * v], 12);
  std::vector<float> acc(4 * s.vertices), out(s.base.size());
  for (auto _ : state) {
    std::memcpy(acc.data(), base4.data(), acc.size() * 4);
    for (size_t t = 0; t < d4.size(); ++t) {
      const float w = s.weights[t];
      if (w == 0.0f) continue;
      const uint32_t* idx = s.targets[t].indices.data();
      const float* d = d4[t].data();
      const size_t n = s.targets[t].indices.size();
      for (size_t k = 0; k < n; ++k) {
        float* o = &acc[4 * static_cast<size_t>(idx[k])];
        for (int c = 0; c < 4; ++c) o[c] += w * d[4 * k + c];
      }
    }
    for (size_t v = 0; v < s.vertices; ++v) std::memcpy(&out[3 * v], &acc[4 * v], 12);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  Report(state, SparseBytes(s));
  state.SetLabel(kCaseNames[state.range(0)]);
}

void BM_ByVertexCsr(benchmark::State& state) {
  const Synthetic& s = Case(static_cast<int>(state.range(0)));
  // Build the CSR once: for each vertex, (shape, delta) entries.
  std::vector<uint32_t> offsets(s.vertices + 1, 0), shape_of;
  std::vector<float> deltas;
  for (const SparseTarget& t : s.targets)
    for (uint32_t v : t.indices) offsets[v + 1]++;
  for (size_t v = 0; v < s.vertices; ++v) offsets[v + 1] += offsets[v];
  shape_of.resize(offsets.back());
  deltas.resize(3 * offsets.back());
  std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
  for (size_t j = 0; j < s.targets.size(); ++j) {
    const SparseTarget& t = s.targets[j];
    for (size_t k = 0; k < t.indices.size(); ++k) {
      const uint32_t slot = fill[t.indices[k]]++;
      shape_of[slot] = static_cast<uint32_t>(j);
      std::memcpy(&deltas[3 * slot], &t.position_deltas[3 * k], 12);
    }
  }
  std::vector<float> out(s.base.size());
  for (auto _ : state) {
    for (size_t v = 0; v < s.vertices; ++v) {
      float x = s.base[3 * v], y = s.base[3 * v + 1], z = s.base[3 * v + 2];
      for (uint32_t e = offsets[v]; e < offsets[v + 1]; ++e) {
        const float w = s.weights[shape_of[e]];
        x += w * deltas[3 * e];
        y += w * deltas[3 * e + 1];
        z += w * deltas[3 * e + 2];
      }
      out[3 * v] = x;
      out[3 * v + 1] = y;
      out[3 * v + 2] = z;
    }
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  Report(state, 24.0 * s.vertices + 20.0 * offsets.back());
  state.SetLabel(kCaseNames[state.range(0)]);
}

void BM_DenseEigen(benchmark::State& state) {
  const Synthetic& s = Case(static_cast<int>(state.range(0)));
  Eigen::MatrixXf d = Eigen::MatrixXf::Zero(3 * s.vertices, s.targets.size());
  for (size_t j = 0; j < s.targets.size(); ++j) {
    const SparseTarget& t = s.targets[j];
    for (size_t k = 0; k < t.indices.size(); ++k) {
      for (int c = 0; c < 3; ++c) d(3 * t.indices[k] + c, j) = t.position_deltas[3 * k + c];
    }
  }
  Eigen::Map<const Eigen::VectorXf> base(s.base.data(), s.base.size());
  Eigen::Map<const Eigen::VectorXf> w(s.weights.data(), s.weights.size());
  Eigen::VectorXf out(s.base.size());
  for (auto _ : state) {
    out.noalias() = base + d * w;
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  Report(state, 4.0 * d.size() + 24.0 * s.vertices);
  state.SetLabel(kCaseNames[state.range(0)]);
}

void BM_Memcpy(benchmark::State& state) {
  const Synthetic& s = Case(static_cast<int>(state.range(0)));
  const size_t bytes = static_cast<size_t>(SparseBytes(s)) / 2;  // Read + write = touched.
  std::vector<char> a(bytes, 1), b(bytes);
  for (auto _ : state) {
    std::memcpy(b.data(), a.data(), bytes);
    benchmark::DoNotOptimize(b.data());
    benchmark::ClobberMemory();
  }
  Report(state, 2.0 * bytes);
  state.SetLabel(kCaseNames[state.range(0)]);
}

// The bundled MakeHuman face (13,380 vertices, 286 sparse targets): the kernel alone (positions),
// and the whole evaluation (positions, normals kept fresh), with 20 or all 286 shapes active.
using facespace::BlendContext;
using facespace::BlendedRig;
using facespace::Primitive;
using facespace::Rig;

const Rig& MakeHuman() {
  static const Rig rig = [] {
    auto r = facespace::formats::LoadRigFile(std::string(FACESPACE_SOURCE_DIR) +
                                             "/assets/makehuman/makehuman.glb");
    if (!r.ok()) std::abort();
    return std::move(r.value());
  }();
  return rig;
}

std::vector<float> MakeHumanWeights(size_t active) {
  const Rig& rig = MakeHuman();
  std::vector<float> w(rig.shapes.size(), 0.0f);
  for (size_t k = 0; k < active; ++k)
    w[(k * 7919) % w.size()] = 0.3f + 0.001f * static_cast<float>(k);
  return w;
}

void BM_MakeHumanKernel(benchmark::State& state) {
  const Rig& rig = MakeHuman();
  const Primitive& p = rig.primitives[0];
  const std::vector<float> w = MakeHumanWeights(static_cast<size_t>(state.range(0)));
  std::vector<float> out(p.positions.size());
  facespace::BlendShapeJob job;
  job.base = p.positions;
  job.weights = w;  // One mesh: target t drives shape t.
  job.targets = p.targets;
  job.out = out;
  for (auto _ : state) {
    job.Run();
    benchmark::DoNotOptimize(out.data());
  }
  state.SetLabel(std::to_string(state.range(0)) + " of 286 shapes active");
}

void BM_MakeHumanEvaluate(benchmark::State& state) {
  const Rig& rig = MakeHuman();
  const std::vector<float> w = MakeHumanWeights(static_cast<size_t>(state.range(0)));
  BlendedRig out;
  BlendContext ctx;
  for (auto _ : state) {
    facespace::EvaluateRig(rig, w, {}, out, ctx);
    benchmark::DoNotOptimize(out.primitives[0].positions.data());
  }
  state.SetLabel(std::to_string(state.range(0)) + " of 286 shapes active, with normals");
}

// The mesh route's work in process, FaceCap with 4 shapes at 0.2: the blend, then the f32 body
// (arg 0), the glb through ExportMesh (1), the glb through the batch's GlbVariantWriter (2), or
// nothing (3); or the f32 body through F32Writer, the route's way (4: only the primitives the point
// moves blended, written over the last body).
void BM_FaceCapMeshEncode(benchmark::State& state) {
  static const Rig rig =
      facespace::formats::LoadRigFile(FACESPACE_SOURCE_DIR "/assets/facecap/facecap.glb").value();
  std::vector<float> w(rig.shapes.size(), 0.0f);
  for (size_t k : {24, 37, 38, 9}) w[k] = 0.2f;
  BlendedRig out;
  BlendContext ctx;
  facespace::formats::GlbVariantWriter writer;
  const facespace::formats::F32Writer blender(rig, false);
  facespace::formats::F32Writer::Scratch scratch;
  std::string body;
  const int encode = static_cast<int>(state.range(0));
  size_t bytes = 0;
  for (auto _ : state) {
    w[24] += 1e-6f;  // A new point each time, as the route sees.
    if (encode == 4) {
      if (!blender.Write(rig, w, scratch, body)) state.SkipWithError("F32Writer declined");
      bytes = body.size();
      benchmark::DoNotOptimize(bytes);
      continue;
    }
    facespace::EvaluateRig(rig, w, {}, out, ctx);
    if (encode == 3) {
      bytes = out.primitives[0].positions.size() * 4;
    } else if (encode == 2) {
      bytes = writer.Write(rig, out, w, {}).value().bin.size();
    } else {
      bytes = facespace::formats::ExportMesh(rig, out, w, {},
                                             encode == 0 ? facespace::formats::MeshFormat::kF32
                                                         : facespace::formats::MeshFormat::kGlb)
                  .value()
                  .size();
    }
    benchmark::DoNotOptimize(bytes);
  }
  state.SetLabel(encode == 4   ? "f32 (F32Writer)"
                 : encode == 0 ? "blend + f32"
                 : encode == 1 ? "blend + glb (ExportMesh)"
                 : encode == 2 ? "blend + glb (GlbVariantWriter)"
                               : "blend");
  state.counters["KB"] = bytes / 1024.0;
}

// The mesh route's f32 through the evaluator, as the route calls it: Evaluator::Run alone (arg 0),
// or with the request's first step and the cache key before it (1: ResolvePoint, CacheKey, Run).
// Against BM_FaceCapMeshEncode/4 (the F32Writer alone), what the evaluator's layer adds.
void BM_FaceCapEvaluatorF32(benchmark::State& state) {
  static const auto rig = facespace::evaluator::Unstored(
      facespace::formats::LoadRigFile(FACESPACE_SOURCE_DIR "/assets/facecap/facecap.glb").value(),
      "1");
  const facespace::evaluator::Evaluator evaluator;
  facespace::evaluator::Workspace ws;
  facespace::evaluator::MeshRequest request;
  for (const char* name : {"jawOpen", "mouthSmile_L", "mouthSmile_R", "cheekPuff"})
    request.weights.push_back({name, -1, 0.2, ""});
  const facespace::evaluator::OutputSpec spec =
      facespace::evaluator::OutputSpec::Mesh(request, facespace::formats::MeshFormat::kF32);
  facespace::evaluator::ResolvedPoint point;
  facespace::evaluator::ResolvePoint(rig->rig, request, point);
  const bool resolve = state.range(0) == 1;
  size_t bytes = 0;
  for (auto _ : state) {
    request.weights[0].value += 1e-6;  // A new point each time, as the route sees.
    if (resolve) {
      facespace::evaluator::ResolvePoint(rig->rig, request, point);
      benchmark::DoNotOptimize(facespace::evaluator::CacheKey(*rig, {&point, 1}, spec).size());
    } else {
      point.weights[0] += 1e-6f;
    }
    auto out = evaluator.Run(rig, point, spec, ws);
    bytes = out->bytes.size();
    ws.body = std::move(out->bytes);  // Handed back, as a sent response's body is.
    benchmark::DoNotOptimize(bytes);
  }
  state.SetLabel(resolve ? "ResolvePoint + CacheKey + Run" : "Evaluator::Run");
  state.counters["KB"] = bytes / 1024.0;
}

BENCHMARK(BM_FaceCapMeshEncode)->DenseRange(0, 4)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FaceCapEvaluatorF32)->DenseRange(0, 1)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_MakeHumanKernel)->Arg(20)->Arg(286)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_MakeHumanEvaluate)->Arg(20)->Arg(286)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ByShapeRuns)->DenseRange(0, 3)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ByShapeIndices)->DenseRange(0, 3)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ByShapeInterleaved)->DenseRange(0, 3)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ByShapePadded)->DenseRange(0, 3)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ByVertexCsr)->DenseRange(0, 3)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DenseEigen)->DenseRange(0, 1)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Memcpy)->DenseRange(0, 3)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
