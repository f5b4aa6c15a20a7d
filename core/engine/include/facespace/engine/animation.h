// Animation clips: sampling a clip at a time, and blending several clips over the rest pose.
#pragma once

#include <span>
#include <vector>

#include "facespace/engine/hierarchy.h"
#include "facespace/engine/status.h"

namespace facespace {
inline namespace engine {

enum class ClipWrap { kClamp, kLoop };

// Samples clip `clip` at `time` seconds into `pose` (TRS channels) and `shape_weights`
// (morph weight channels; `shape_set` marks the shapes the clip drives). Time outside the
// clip clamps or loops.
Status SampleClip(const Rig& rig, int clip, float time, ClipWrap wrap, Pose& pose,
                  std::vector<float>& shape_weights, std::vector<uint8_t>& shape_set);

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
  // An overlay (MMD players' partial motion) goes over the layers before it and replaces only what
  // its clip moves: the joints and shapes whose tracks are not all at rest (a track keyed once at
  // the rest pose, as an expression motion keys the body, is left to the layers below). Its weight
  // ramps up over `fade_in` seconds from its start and, when it does not loop, down over the last
  // `fade_out` seconds of its clip (after which it is gone; without a fade-out it holds its end).
  bool overlay = false;
  float fade_in = 0.0f, fade_out = 0.0f;
};

// True when some TRS channel of the clip leaves its node's rest value (an MMD expression motion
// keys the body at rest: false).
bool ClipMovesJoints(const Rig& rig, int clip);

// The weight an overlay has at its time: `weight` with its fades.
float LayerWeight(const Rig& rig, const ClipLayer& layer);

// Blends layers over the rest pose: the layers that are not overlays first, per node
// translations and scales as weighted averages and rotations as a weighted, sign-aligned,
// normalised quaternion sum (nlerp); nodes none of them reaches keep their rest transform; morph
// weights the same way. Then each overlay in order: what it moves is interpolated from what lies
// below towards it by its weight (lerp, rotations slerp).
Status BlendClips(const Rig& rig, std::span<const ClipLayer> layers, Pose& pose,
                  std::vector<float>& shape_weights, std::vector<uint8_t>& shape_set);

}  // namespace engine
}  // namespace facespace
