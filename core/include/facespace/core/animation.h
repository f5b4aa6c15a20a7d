// Animation clips: sampling a clip at a time, and blending several clips over the rest pose.
#pragma once

#include <span>
#include <vector>
#include "facespace/core/hierarchy.h"
#include "facespace/core/status.h"

namespace facespace {

enum class ClipWrap { kClamp, kLoop };

// Samples clip `clip` at `time` seconds into `pose` (TRS channels) and `shape_weights`
// (morph weight channels; `shape_set` marks the shapes the clip drives). Time outside the
// clip clamps or loops.
Status SampleClip(const Rig& rig, int clip, float time, ClipWrap wrap, Pose& pose, std::vector<float>& shape_weights,
                  std::vector<uint8_t>& shape_set);

// A kBezier sampler as LINEAR keys for formats that cannot say it (glTF): every key, and between
// keys `per_second` samples a second. Any other sampler is returned as it is.
AnimationSampler LinearSampler(const AnimationSampler& sampler, float per_second);

// One clip of a blend: sampled at `time`, weighted by `weight`, limited to the subtrees of
// the joints named in `mask` (all nodes when empty).
struct ClipLayer {
  int clip = -1;
  float time = 0.0f;
  float weight = 1.0f;
  ClipWrap wrap = ClipWrap::kClamp;
  std::vector<int> mask;  // Node indices whose subtrees the layer affects.
};

// Blends layers over the rest pose: per node, translations and scales are weighted averages
// and rotations a weighted, sign-aligned, normalised quaternion sum (nlerp). Nodes no layer
// reaches keep their rest transform. Morph weights blend the same way.
Status BlendClips(const Rig& rig, std::span<const ClipLayer> layers, Pose& pose, std::vector<float>& shape_weights,
                  std::vector<uint8_t>& shape_set);

}  // namespace facespace
