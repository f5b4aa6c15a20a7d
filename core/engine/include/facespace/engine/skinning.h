// Skinning jobs: linear blend and dual-quaternion skinning over spans of plain data.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace facespace {
inline namespace engine {

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

}  // namespace engine
}  // namespace facespace
