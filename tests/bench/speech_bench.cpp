// Lip sync's figures (issue 38; tests/bench/README.md): on one core (run under `taskset -c 0`), a
// 10 s line from text to JSON keys, 10 s of speech to visemes, and 10 s of 512x512 30 fps WebM.
#include <benchmark/benchmark.h>

#include "facespace/evaluator/evaluator.h"
#include "facespace/formats/io.h"
#include "facespace/lipsync/lipsync.h"
#include "facespace/offscreen/render.h"

namespace {

using namespace facespace;

// About 10 s at espeak-ng's default 175 words a minute.
constexpr char kLine[] =
    "Good morning everyone. Today I would like to tell you a short story about a fox who lived in "
    "a forest near a small village, "
    "and who loved to watch the people at the market.";

const std::shared_ptr<const evaluator::StoredRig>& FaceCap() {
  static const auto rig = evaluator::Unstored(
      formats::LoadRigFile(std::string(FACESPACE_SOURCE_DIR) + "/assets/facecap/facecap.glb")
          .value());
  return rig;
}

void BM_TextToJsonKeys(benchmark::State& state) {
  evaluator::SpeechRequest r;
  r.text = kLine;
  float seconds = 0;
  for (auto _ : state) {
    auto plan = lipsync::PlanSpeech(FaceCap()->rig, r);
    benchmark::DoNotOptimize(lipsync::SpeechJson(FaceCap()->rig, plan.value(), 30));
    seconds = plan->audio.seconds();
  }
  state.counters["audio_s"] = seconds;
}
BENCHMARK(BM_TextToJsonKeys)->Unit(benchmark::kMillisecond);

void BM_SpeechToVisemes(benchmark::State& state) {
  const auto spoken = speech::Synthesize(kLine, {});
  const std::string wav = speech::WriteWav(spoken->audio);
  evaluator::SpeechRequest r;
  r.audio = wav;
  r.has_audio = true;
  r.transcript = state.range(0) ? kLine : "";
  for (auto _ : state) benchmark::DoNotOptimize(lipsync::PlanSpeech(FaceCap()->rig, r));
  state.counters["audio_s"] = spoken->audio.seconds();
  state.SetLabel(state.range(0) ? "aligned to the transcript" : "recognized");
}
BENCHMARK(BM_SpeechToVisemes)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_Webm512At30(benchmark::State& state) {
  evaluator::SpeechRequest r;
  r.text = kLine;
  r.render.render.width = r.render.render.height = 512;
  auto plan = lipsync::PlanSpeech(FaceCap()->rig, r);
  offscreen::OsMesaRenderer renderer(1);
  evaluator::Evaluator evaluator(renderer);
  evaluator::Workspace ws;
  size_t bytes = 0;
  for (auto _ : state)
    bytes = lipsync::SpeechVideo(evaluator, FaceCap(), plan.value(), r, ws)->size();
  state.counters["audio_s"] = plan->audio.seconds();
  state.counters["frames"] = static_cast<double>(evaluator::FrameCount(plan->sequence, 30));
  state.counters["KB"] = bytes / 1024.0;
}
BENCHMARK(BM_Webm512At30)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
