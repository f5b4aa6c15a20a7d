// What a request asks of the skeleton, as plain data (api/ parses it from JSON), and the pose
// and weights it comes to.
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include "facespace/engine/animation.h"
#include "facespace/engine/face.h"
#include "facespace/engine/hierarchy.h"
#include "facespace/engine/status.h"
#include "facespace/engine/weights.h"

namespace facespace {
inline namespace engine {

struct JointOverride {
  std::string joint;    // Node name.
  std::string pointer;  // Where it came from, for errors.
  bool has_rotation = false, has_euler = false, has_translation = false, has_scale = false;
  std::array<float, 4> rotation{0, 0, 0, 1};  // x, y, z, w.
  std::array<float, 3> euler{0, 0, 0};        // Degrees, R = Rz * Ry * Rx.
  std::array<float, 3> translation{0, 0, 0};
  std::array<float, 3> scale{1, 1, 1};
};

struct ClipRequest {
  std::string name;  // Clip name, or empty to use `index`.
  long long index = -1;
  float time = 0.0f;
  bool timed = false;  // A time was given (as seconds or frames).
  float weight = 1.0f;
  bool loop = false;
  std::vector<std::string> mask;  // Joint names whose subtrees the clip affects.
  bool overlay = false;           // A layer over the clips before it (ClipLayer::overlay).
  bool over_base = false;  // A single motion asked for: played over the rig's base_motion, if any.
  float fade_in = 0.0f, fade_out = 0.0f;
  std::string pointer;
};

struct PoseRequest {
  std::vector<ClipRequest> clips;     // One (animation + time) or several (blend).
  std::vector<JointOverride> joints;  // Explicit pose, applied after the clips.
  // The face by name (core/face.h): expressions added to the weights, then the gaze (eye bones
  // after the joints, before MMD's constraints; or eye shapes, set).
  std::vector<WeightEntry> expressions;
  std::optional<Gaze> gaze;
  // Whether it asks anything of the skeleton (a gaze may, on a rig with eye bones).
  bool empty() const { return clips.empty() && joints.empty(); }
  bool has_face() const { return !expressions.empty() || gaze.has_value(); }
};

// The rig's animation a clip names (by name, else by index), or -1.
int FindClip(const Rig& rig, const ClipRequest& clip);
// "unknown animation 'X' (did you mean 'Y'?); animations: ..." for a clip FindClip did not find.
std::string UnknownClipMessage(const Rig& rig, const ClipRequest& clip);

// Builds the pose: rest, then the clips (their weight channels fill `animated_weights` and
// `animated_set`), then the explicit joints (each given property replaces the joint's local
// value). Unknown joints or clips and invalid quaternions are errors naming their pointer;
// non-unit quaternions are normalised with a `quaternion_normalised` warning.
// MMD's bone constraints (constraints.h) are solved at the end unless `solve` is false (a caller
// that applies bone morphs first, then solves).
Status BuildPose(const Rig& rig, const PoseRequest& request, Pose& pose,
                 std::vector<float>& animated_weights, std::vector<uint8_t>& animated_set,
                 std::vector<Warning>& warnings, bool solve = true);

// MMD's bone morphs (Shape::bone_morphs) at `weights` onto `pose`: each entry moves its bone by
// weight x its translation and turns it by its rotation slerped from none by the weight, after what
// the clips animate (animated x morph). False, and `pose` untouched, when no shape with bone morphs
// has a weight.
bool ApplyBoneMorphs(const Rig& rig, std::span<const float> weights, Pose& pose);
// Whether ApplyBoneMorphs would move a bone.
bool BoneMorphsActive(const Rig& rig, std::span<const float> weights);

// A pose's last steps, after its clips and joint overrides: the bone morphs of `weights`, then
// MMD's bone constraints.
void FinishPose(const Rig& rig, std::span<const float> weights, Pose& pose);

// Weights with no clip or joint: false, and `pose` untouched, unless a bone morph of `weights`
// moves a bone; then the rest pose, finished with them.
bool PoseOfWeightsAlone(const Rig& rig, std::span<const float> weights, Pose& pose);

// No clip or joint, with a face: the face (face.h) onto the weights, and onto the rest pose when
// its gaze turns bones; then, as PoseOfWeightsAlone, false and `pose` untouched unless a bone
// moved.
bool PoseOfFaceAndWeights(const Rig& rig, const FaceState& face, std::span<float> weights,
                          Pose& pose, std::vector<Warning>& warnings);

// A request's weights and pose together, in glTF's order of application: rest pose, then the
// clips (their weight channels set shape weights), then the explicit joints, then the
// explicit weights, which override animated ones, then the face (expressions and gaze, face.h),
// then the bone morphs and MMD's constraints. `posed` is false when nothing moves a bone (the rest
// pose applies).
Status ResolvePoseAndWeights(const Rig& rig, std::span<const WeightEntry> entries,
                             const PoseRequest& request, std::vector<float>& weights, Pose& pose,
                             bool& posed, std::vector<Warning>& warnings);

}  // namespace engine
}  // namespace facespace
