// Retarget (core/retarget.h) a solve at a time, as a point request or a live message pays it
// (issue 63's bar: 0.2 ms a solve): MMD's vowels and blink onto FaceCap; ARKit's 52 at once onto
// the derived MakeHuman (352 shapes, 286 of them placed nowhere) and onto Uka (MMD's morphs and
// ARKit's names both, where the damping decides).
#include <benchmark/benchmark.h>

#include <map>
#include <random>
#include <string>

#include "facespace/engine/face.h"
#include "facespace/engine/retarget.h"
#include "facespace/formats/io.h"

namespace {

using namespace facespace;

const Rig& Load(const char* rel) {
  static std::map<std::string, Rig> rigs;
  auto it = rigs.find(rel);
  if (it == rigs.end())
    it = rigs.emplace(
                 rel,
                 formats::LoadRigFile(std::string(FACESPACE_SOURCE_DIR) + "/assets/" + rel).value())
             .first;
  return it->second;
}

std::vector<WeightEntry> AllArkit() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<WeightEntry> entries;
  for (std::string_view n : kArkitNames)
    entries.push_back({std::string(n), -1, u(rng), "/weights"});
  return entries;
}

void Run(benchmark::State& state, const Rig& rig, Vocabulary v, std::vector<WeightEntry> entries) {
  Retargeted out;
  std::vector<Warning> warnings;
  for (auto _ : state) {
    warnings.clear();
    benchmark::DoNotOptimize(Retarget(rig, {v, nullptr, "bench"}, entries, out, warnings));
  }
  state.counters["shapes out"] = static_cast<double>(out.weights.size() + out.expressions.size());
}

void BM_MmdOntoFaceCap(benchmark::State& state) {
  Run(state, Load("facecap/facecap.glb"), Vocabulary::kMmd,
      {{"あ", -1, 0.7, "/weights"}, {"う", -1, 0.2, "/weights"}, {"まばたき", -1, 1, "/weights"}});
}
void BM_ArkitOntoMakeHuman(benchmark::State& state) {
  Run(state, Load("makehuman/makehuman.glb"), Vocabulary::kArkit, AllArkit());
}
void BM_ArkitOntoUka(benchmark::State& state) {
  Run(state, Load("uka/MS_Uka.pmx"), Vocabulary::kArkit, AllArkit());
}

}  // namespace

BENCHMARK(BM_MmdOntoFaceCap)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ArkitOntoMakeHuman)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ArkitOntoUka)->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
