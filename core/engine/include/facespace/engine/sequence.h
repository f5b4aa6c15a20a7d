// Shapes over time: keyframe sequences of weight vectors, in-betweened by a transition
// function, with baking and keyframe reduction.
#pragma once

#include <optional>
#include <span>
#include <stop_token>
#include <string>
#include <vector>

#include "facespace/engine/blend.h"
#include "facespace/engine/face.h"
#include "facespace/engine/pose_request.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace {
inline namespace engine {

enum class TransitionKind {
  kStep,
  kLinear,
  kSmoothstep,
  kSmootherstep,
  kEaseIn,
  kEaseOut,
  kEaseInOut,
  kBezier
};

// f: [0, 1] -> R with f(0) = 0 and f(1) = 1 (except step, which holds until 1). A cubic
// Bezier is CSS's cubic-bezier(x1, y1, x2, y2): x1, x2 in [0, 1], y free, so it may leave
// [0, 1] and extrapolate.
struct Transition {
  TransitionKind kind = TransitionKind::kLinear;
  float x1 = 0.0f, y1 = 0.0f, x2 = 1.0f, y2 = 1.0f;  // kBezier only.
};

// "step", "linear", "smoothstep", "smootherstep", "ease-in", "ease-out", "ease-in-out",
// "cubic-bezier(x1, y1, x2, y2)". False when unknown or out of range.
bool ParseTransition(const std::string& text, Transition* out);
std::string TransitionName(const Transition& t);

// f(u) for u in [0, 1].
float ApplyTransition(const Transition& t, float u);

struct Keyframe {
  float time = 0.0f;                     // Seconds; any spacing.
  std::vector<float> weights;            // One per shape (a shape key is a one-hot vector).
  std::optional<Transition> transition;  // Towards the next key; else the sequence's.
  std::vector<float> expressions;        // One value per rig expression (face.h), or empty: none.
};

// A gaze at a time: a sequence's gaze track is linear between its keys (targets, or angles) and
// held past its ends.
struct GazeKey {
  float time = 0.0f;
  Gaze gaze;
};

struct Sequence {
  std::vector<Keyframe> keys;  // Strictly increasing times.
  Transition transition;
  bool smooth = false;  // Catmull-Rom through the weight vectors instead.
  int clip = -1;        // Played from this animation (a VMD motion...): its pose at each time too.
  std::vector<ClipRequest>
      layers;           // Or motions layered (pose_request.h), each starting at its `time`.
  bool physics = true;  // A posed sequence simulates the rig's physics (rig.h), if it has any.
  // The face over time (face.h): the keys' expressions, a gaze track, natural blinks.
  std::vector<GazeKey> gaze;
  std::vector<Blink> blinks;
  std::vector<Warning>
      warnings;  // About the whole sequence (a face the rig cannot show), said once.
};

// Times finite and strictly increasing, every key with one weight per shape, finite.
Status ValidateSequence(const Sequence& sequence, size_t shape_count);

// Weights at time t (clamped to the first and last key): keys B, C around t,
// w_C = f((t - t_B) / (t_C - t_B)), w_B = 1 - w_C. `f_out` receives f (for warnings).
void SampleSequence(const Sequence& sequence, float t, std::span<float> out,
                    float* f_out = nullptr);

// The face at time t: the keys' expressions (sampled as the weights are), the gaze track, the
// blinks. False when the sequence asks nothing of the face.
bool SampleFace(const Sequence& sequence, float t, FaceState& face);

// The sequence with a key baked at t (the sampled weights, keeping the transition); a key
// already at t is replaced by its own value (no change).
Sequence BakeKey(const Sequence& sequence, float t);

struct ReduceResult {
  Sequence sequence;
  double max_error = 0.0;  // Largest vertex distance between the two, over the check times (a
                           // bound: never below it, above it by at most 5% of the tolerance).
  size_t removed = 0;
};

// Removes keys (never the first or last) while the largest vertex distance between the
// original and the reduced sequence, over every original key time and the quarter points
// between them, stays at most `tolerance` (mesh units). O(K log K) samples of the sequence for K
// keys, each one blend of the shapes that differ; Cancelled when `stop` fires.
Result<ReduceResult> ReduceSequence(const Rig& rig, const Sequence& sequence, float tolerance,
                                    const std::stop_token& stop = {});

// A sequence from a glTF animation's morph-weight channel (its first one): keys at the
// sampler's times; STEP and LINEAR map to step and linear, CUBICSPLINE to smooth.
Result<Sequence> SequenceFromAnimation(const Rig& rig, int animation);

// A clip played as a sequence: its pose and weights at each time (`clip` set), its weight channel's
// keys (or the rest weights when it has none) spanning the whole clip, from 0 to its duration.
Result<Sequence> SequenceOfClip(const Rig& rig, int clip);

}  // namespace engine
}  // namespace facespace
