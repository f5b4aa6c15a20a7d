// Skinning throughput: 50,000 vertices, 4 influences each, 64 joints, with normals.
#include <benchmark/benchmark.h>

#include <random>

#include "facespace/engine/skeleton.h"

namespace {

using namespace facespace;

struct Data {
  std::vector<float> matrices, dq, positions, normals, out_p, out_n, weights;
  std::vector<uint16_t> joints;
};

const Data& Get() {
  static const Data data = [] {
    Data d;
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-1, 1);
    const size_t n = 50000, joints = 64;
    for (size_t j = 0; j < joints; ++j) {
      const auto q = EulerToQuaternion(20 * u(rng), 20 * u(rng), 20 * u(rng));
      const float x = q[0], y = q[1], z = q[2], w = q[3];
      const float m[16] = {1 - 2 * (y * y + z * z),
                           2 * (x * y + z * w),
                           2 * (x * z - y * w),
                           0,
                           2 * (x * y - z * w),
                           1 - 2 * (x * x + z * z),
                           2 * (y * z + x * w),
                           0,
                           2 * (x * z + y * w),
                           2 * (y * z - x * w),
                           1 - 2 * (x * x + y * y),
                           0,
                           u(rng),
                           u(rng),
                           u(rng),
                           1};
      d.matrices.insert(d.matrices.end(), m, m + 16);
    }
    DualQuaternions(d.matrices, d.dq);
    for (size_t v = 0; v < n; ++v) {
      d.positions.insert(d.positions.end(), {u(rng), u(rng), u(rng)});
      d.normals.insert(d.normals.end(), {0, 0, 1});
      float ws[4], sum = 0;
      for (float& w : ws) sum += (w = u(rng) + 1.0f);
      for (int k = 0; k < 4; ++k) {
        d.joints.push_back(static_cast<uint16_t>(rng() % joints));
        d.weights.push_back(ws[k] / sum);
      }
    }
    d.out_p.resize(d.positions.size());
    d.out_n.resize(d.normals.size());
    return d;
  }();
  return data;
}

void BM_Skin(benchmark::State& state) {
  Data& d = const_cast<Data&>(Get());
  SkinningJob job{.joint_matrices = d.matrices,
                  .influences = 4,
                  .joints = d.joints,
                  .weights = d.weights,
                  .in_positions = d.positions,
                  .in_normals = d.normals,
                  .out_positions = d.out_p,
                  .out_normals = d.out_n};
  if (state.range(0)) job.joint_dual_quaternions = d.dq;
  for (auto _ : state) {
    if (!job.Run()) state.SkipWithError("skinning failed");
    benchmark::DoNotOptimize(d.out_p.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * 50000);
  state.SetLabel(state.range(0) ? "dual quaternion, 50k vertices x 4 influences"
                                : "linear, 50k vertices x 4 influences");
}

BENCHMARK(BM_Skin)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
