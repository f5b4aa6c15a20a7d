// What every reader's fuzz target does with a rig that loaded: evaluate it at rest with every
// shape at `weight` (in-betweens and correctives derive theirs), then posed by clip 0 at a time;
// each blend is written as glb by the batch's GlbVariantWriter, which must give ExportMesh's
// bytes (the second write patches the first's template), else the target traps.
#pragma once

#include <string>
#include <vector>

#include "facespace/engine/animation.h"
#include "facespace/engine/blend.h"
#include "facespace/engine/skeleton.h"
#include "facespace/formats/io.h"

inline void CheckGlbWriter(facespace::formats::GlbVariantWriter& writer, const facespace::Rig& rig,
                           const facespace::BlendedRig& blended,
                           const std::vector<float>& weights) {
  auto expected = facespace::formats::ExportMesh(rig, blended, weights, {},
                                                 facespace::formats::MeshFormat::kGlb);
  auto pieces = writer.Write(rig, blended, weights, {});
  if (expected.ok() != pieces.ok()) __builtin_trap();
  if (expected.ok() && expected.value() != std::string(pieces->head) + std::string(pieces->bin))
    __builtin_trap();
}

inline void EvaluateLoadedRig(const facespace::Rig& rig, float weight) {
  facespace::BlendedRig blended;
  facespace::BlendContext context;
  facespace::formats::GlbVariantWriter writer;
  const std::vector<float> weights(rig.shapes.size(), weight);
  if (facespace::EvaluateRig(rig, weights, {}, blended, context).ok()) {
    CheckGlbWriter(writer, rig, blended, weights);
    CheckGlbWriter(writer, rig, blended, std::vector<float>(rig.shapes.size(), 0.5f * weight));
  }
  if (rig.animations.empty()) return;
  facespace::Pose pose = facespace::RestPose(rig);
  std::vector<float> w;
  std::vector<uint8_t> set;
  if (!facespace::SampleClip(rig, 0, 0.37f, facespace::ClipWrap::kLoop, pose, w, set).ok()) return;
  facespace::BlendOptions options;
  options.pose = &pose;
  if (facespace::EvaluateRig(rig, weights, options, blended, context).ok())
    CheckGlbWriter(writer, rig, blended, weights);
}
