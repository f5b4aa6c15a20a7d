// Landmarks to weights a frame (core/derive/capture.h), as the live socket's {"landmarks"} and
// POST /capture pay it (issue 64's bar: 1 ms a frame): FaceCap's own landmarks (MediaPipe's
// canonical face registered onto it), its jaw opening and closing, one FaceTracker::Step a frame.
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

#include "facespace/derive/capture.h"
#include "facespace/engine/rig.h"
#include "facespace/formats/io.h"

namespace {

using namespace facespace;
using namespace facespace::derive;

const LandmarkRig& FaceCapMap() {
  static const LandmarkRig map = [] {
    const std::string assets = std::string(FACESPACE_SOURCE_DIR) + "/assets/";
    const Rig rig = formats::LoadRigFile(assets + "facecap/facecap.glb").value();
    const Rig canonical =
        formats::LoadRigFile(assets + "trackers/mediapipe/canonical_face_model.obj").value();
    return MapLandmarks(rig, canonical, {}).value();
  }();
  return map;
}

// The rig's landmarks with the first shape (of those placed) at `w`, as pixels of a 640x480 image.
std::vector<float> Frame(const LandmarkRig& m, float w) {
  const double scale = 300 / m.diag;
  std::vector<float> out(3 * kMediaPipeFace);
  for (size_t i = 0; i < kMediaPipeFace; ++i) {
    double p[3];
    for (int k = 0; k < 3; ++k) p[k] = m.rest[3 * i + k] + w * m.moves[3 * i + k];
    out[3 * i] = static_cast<float>(320 + scale * p[0]);
    out[3 * i + 1] = static_cast<float>(240 - scale * p[1]);
    out[3 * i + 2] = static_cast<float>(-scale * p[2]);
  }
  return out;
}

void BM_TrackFrameFaceCap(benchmark::State& state) {
  const LandmarkRig& m = FaceCapMap();
  FaceTracker tracker(m, {});
  if (!tracker.SetNeutral(Frame(m, 0), 0).ok()) state.SkipWithError("no neutral");
  std::vector<std::vector<float>> frames;
  for (int i = 0; i < 60; ++i) frames.push_back(Frame(m, 0.5f + 0.5f * std::sin(i * 0.1f)));
  FaceTracker::Frame out;
  size_t i = 0;
  for (auto _ : state) {
    if (!tracker.Step(frames[i % frames.size()], i, out).ok()) state.SkipWithError("step");
    ++i;
    benchmark::DoNotOptimize(out.weights.data());
  }
  state.counters["shapes"] = static_cast<double>(m.shapes.size());
}
BENCHMARK(BM_TrackFrameFaceCap)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
