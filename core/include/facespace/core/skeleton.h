// Skeletons: poses (local TRS per node), world matrices, linear blend skinning, animation
// sampling and pose blending. Morph first, then skin (glTF's order).
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include "facespace/core/rig.h"
#include "facespace/core/status.h"
#include "facespace/core/weights.h"

namespace facespace {

struct Transform {
  std::array<float, 3> translation{0, 0, 0};
  std::array<float, 4> rotation{0, 0, 0, 1};  // x, y, z, w (glTF order), unit length.
  std::array<float, 3> scale{1, 1, 1};
};

// A local transform per node. Nodes given by a matrix in the source keep it (glTF forbids
// animating them) unless a pose replaces them.
struct Pose {
  std::vector<Transform> local;
  std::vector<uint8_t> from_matrix;  // 1: use Node::matrix.
};

// The rest pose: every node's own TRS or matrix.
Pose RestPose(const Rig& rig);

// Column-major world matrices of every node under `pose`, parents before children.
std::vector<std::array<float, 16>> WorldMatrices(const Rig& rig, const Pose& pose);

// Joint matrices of a skin: world(joint) * inverseBind(joint), 16 floats each.
void JointMatrices(const Rig& rig, int skin, std::span<const std::array<float, 16>> world,
                   std::vector<float>& out);

// Linear blend skinning: p' = sum_k w_k M_k p, normals with the inverse-transpose of the
// blended matrix, tangents (xyz) with the blended matrix. Owns nothing, never allocates.
struct SkinningJob {
  bool Validate() const;  // False on short spans, a joint index beyond the matrices, or a
                          // weight count that is not vertex_count * influences.
  bool Run() const;       // Calls Validate(); on false, the outputs are left untouched.

  std::span<const float> joint_matrices;  // 16 floats per joint, column-major.
  size_t influences = 4;                  // Per vertex (4 per JOINTS_n/WEIGHTS_n set).
  std::span<const uint16_t> joints;       // influences per vertex.
  std::span<const float> weights;         // influences per vertex, summing to 1.
  std::span<const float> in_positions;    // xyz per vertex.
  std::span<const float> in_normals;      // xyz per vertex, or empty.
  std::span<const float> in_tangents;     // xyzw per vertex, or empty.
  std::span<float> out_positions;         // Same sizes as the inputs; must not alias them.
  std::span<float> out_normals;
  std::span<float> out_tangents;
  // Dual-quaternion skinning instead of linear: 8 floats per joint (real xyzw, dual xyzw)
  // from DualQuaternions(); keeps volume on twisted joints. Scale in the joints is ignored.
  std::span<const float> joint_dual_quaternions;
};

// The rigid part of each joint matrix as a unit dual quaternion (8 floats per joint).
void DualQuaternions(std::span<const float> joint_matrices, std::vector<float>& out);

enum class ClipWrap { kClamp, kLoop };

// Samples clip `clip` at `time` seconds into `pose` (TRS channels) and `shape_weights`
// (morph weight channels; `shape_set` marks the shapes the clip drives). Time outside the
// clip clamps or loops.
Status SampleClip(const Rig& rig, int clip, float time, ClipWrap wrap, Pose& pose, std::vector<float>& shape_weights,
                  std::vector<uint8_t>& shape_set);

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

// What a request asks of the skeleton, as plain data (api/ parses it from JSON).
struct JointOverride {
  std::string joint;                      // Node name.
  std::string pointer;                    // Where it came from, for errors.
  bool has_rotation = false, has_euler = false, has_translation = false, has_scale = false;
  std::array<float, 4> rotation{0, 0, 0, 1};  // x, y, z, w.
  std::array<float, 3> euler{0, 0, 0};        // Degrees, R = Rz * Ry * Rx.
  std::array<float, 3> translation{0, 0, 0};
  std::array<float, 3> scale{1, 1, 1};
};

struct ClipRequest {
  std::string name;        // Clip name, or empty to use `index`.
  long long index = -1;
  float time = 0.0f;
  float weight = 1.0f;
  bool loop = false;
  std::vector<std::string> mask;  // Joint names whose subtrees the clip affects.
  std::string pointer;
};

struct PoseRequest {
  std::vector<ClipRequest> clips;          // One (animation + time) or several (blend).
  std::vector<JointOverride> joints;       // Explicit pose, applied after the clips.
  bool empty() const { return clips.empty() && joints.empty(); }
};

// Builds the pose: rest, then the clips (their weight channels fill `animated_weights` and
// `animated_set`), then the explicit joints (each given property replaces the joint's local
// value). Unknown joints or clips and invalid quaternions are errors naming their pointer;
// non-unit quaternions are normalised with a `quaternion_normalised` warning.
Status BuildPose(const Rig& rig, const PoseRequest& request, Pose& pose, std::vector<float>& animated_weights,
                 std::vector<uint8_t>& animated_set, std::vector<Warning>& warnings);

// A request's weights and pose together, in glTF's order of application: rest pose, then the
// clips (their weight channels set shape weights), then the explicit joints, then the
// explicit weights, which override animated ones. `posed` is false when the request asks
// nothing of the skeleton (the rest pose applies).
Status ResolvePoseAndWeights(const Rig& rig, std::span<const WeightEntry> entries, const PoseRequest& request,
                             std::vector<float>& weights, Pose& pose, bool& posed, std::vector<Warning>& warnings);

// Quaternion helpers (x, y, z, w).
std::array<float, 4> Slerp(const std::array<float, 4>& a, const std::array<float, 4>& b, float t);
std::array<float, 4> EulerToQuaternion(float x_deg, float y_deg, float z_deg);  // R = Rz * Ry * Rx.

// Index of the node called `name`, or -1.
int FindNode(const Rig& rig, const std::string& name);

}  // namespace facespace
