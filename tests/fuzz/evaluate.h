// What every reader's fuzz target does with a rig that loaded: evaluate it at rest with every
// shape at `weight` (in-betweens and correctives derive theirs), then posed by clip 0 at a time.
#pragma once

#include <vector>

#include "facespace/core/animation.h"
#include "facespace/core/blend.h"
#include "facespace/core/skeleton.h"

inline void EvaluateLoadedRig(const facespace::Rig& rig, float weight) {
  facespace::BlendedRig blended;
  facespace::BlendContext context;
  const std::vector<float> weights(rig.shapes.size(), weight);
  facespace::EvaluateRig(rig, weights, {}, blended, context);
  if (rig.animations.empty()) return;
  facespace::Pose pose = facespace::RestPose(rig);
  std::vector<float> w;
  std::vector<uint8_t> set;
  if (!facespace::SampleClip(rig, 0, 0.37f, facespace::ClipWrap::kLoop, pose, w, set).ok()) return;
  facespace::BlendOptions options;
  options.pose = &pose;
  facespace::EvaluateRig(rig, weights, options, blended, context);
}
