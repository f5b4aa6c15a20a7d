// libFuzzer: the VMD motion reader (the bytes are a .vmd file) against the bundled Uka model, then
// the clip sampled mid-way (BuildPose: every channel) and the posed, morphed rig evaluated there.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "facespace/engine/blend.h"
#include "facespace/engine/pose_request.h"
#include "facespace/formats/io.h"

namespace {

const facespace::Rig& Uka() {
  static const facespace::Rig rig = [] {
    auto r = facespace::formats::LoadRigFile(FACESPACE_SOURCE_DIR "/assets/uka/MS_Uka.pmx");
    if (!r.ok()) std::abort();
    r->animations.clear();
    return std::move(r.value());
  }();
  return rig;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace facespace;
  static Rig rig = Uka();
  std::vector<Warning> warnings;
  auto clip = facespace::formats::LoadVmdMemory(std::span<const unsigned char>(data, size), rig,
                                                "fuzz", &warnings);
  if (!clip.ok()) return 0;
  rig.animations = {std::move(clip.value())};
  for (float f : {0.5f}) {
    PoseRequest request;
    ClipRequest c;
    c.index = 0;
    c.time = f * rig.animations[0].duration;
    request.clips.push_back(c);
    Pose pose;
    std::vector<float> weights(rig.shapes.size(), 0.0f);
    std::vector<uint8_t> set;
    std::vector<Warning> w;
    if (!BuildPose(rig, request, pose, weights, set, w).ok()) std::abort();
    BlendOptions options;
    options.pose = &pose;
    BlendedRig out;
    BlendContext ctx;
    if (!EvaluateRig(rig, weights, options, out, ctx).ok()) std::abort();
  }
  return 0;
}
