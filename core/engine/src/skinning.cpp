// Skinning jobs: linear blend and dual quaternions.
#include "facespace/engine/skinning.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "facespace/engine/normal_matrix.h"

namespace facespace {
inline namespace engine {

bool SkinningJob::Validate() const {
  const size_t n = in_positions.size() / 3;
  if (in_positions.size() % 3 || out_positions.size() != in_positions.size()) return false;
  if (influences == 0 || joints.size() != n * influences || weights.size() != n * influences)
    return false;
  if (joint_matrices.size() % 16) return false;
  if (!in_normals.empty() &&
      (in_normals.size() != 3 * n || out_normals.size() != in_normals.size()))
    return false;
  if (!in_tangents.empty() &&
      (in_tangents.size() != 4 * n || out_tangents.size() != in_tangents.size()))
    return false;
  const size_t joint_count = joint_matrices.size() / 16;
  if (!joint_dual_quaternions.empty() && joint_dual_quaternions.size() != 8 * joint_count)
    return false;
  for (uint16_t j : joints) {
    if (j >= joint_count) return false;
  }
  return true;
}

void DualQuaternions(std::span<const float> joint_matrices, std::vector<float>& out) {
  const size_t joints = joint_matrices.size() / 16;
  out.resize(8 * joints);
  for (size_t j = 0; j < joints; ++j) {
    const Eigen::Map<const Eigen::Matrix4f> m(&joint_matrices[16 * j]);
    Eigen::Matrix3f rot, scale;
    Eigen::Affine3f(m).computeRotationScaling(&rot, &scale);
    const Eigen::Quaternionf r(rot);
    const Eigen::Vector3f t = m.block<3, 1>(0, 3);
    // Dual part: 0.5 * (t, 0) * r.
    const Eigen::Quaternionf tq(0.0f, t.x(), t.y(), t.z());
    const Eigen::Quaternionf d = tq * r;
    float* o = &out[8 * j];
    o[0] = r.x();
    o[1] = r.y();
    o[2] = r.z();
    o[3] = r.w();
    o[4] = 0.5f * d.x();
    o[5] = 0.5f * d.y();
    o[6] = 0.5f * d.z();
    o[7] = 0.5f * d.w();
  }
}

namespace {

// Dual-quaternion skinning of one vertex.
void SkinVertexDq(const SkinningJob& job, size_t v) {
  const size_t K = job.influences;
  float real[4] = {0, 0, 0, 0}, dual[4] = {0, 0, 0, 0};
  const float* first = nullptr;
  for (size_t k = 0; k < K; ++k) {
    const float w = job.weights[v * K + k];
    if (w == 0.0f) continue;
    const float* q = &job.joint_dual_quaternions[8 * static_cast<size_t>(job.joints[v * K + k])];
    if (!first) first = q;
    // Blend in the hemisphere of the first influence (antipodality).
    const float sign =
        (q[0] * first[0] + q[1] * first[1] + q[2] * first[2] + q[3] * first[3]) < 0.0f ? -w : w;
    for (int i = 0; i < 4; ++i) {
      real[i] += sign * q[i];
      dual[i] += sign * q[4 + i];
    }
  }
  const float len =
      std::sqrt(real[0] * real[0] + real[1] * real[1] + real[2] * real[2] + real[3] * real[3]);
  if (!(len > 0.0f)) {
    real[3] = 1.0f;
  } else {
    for (int i = 0; i < 4; ++i) {
      real[i] /= len;
      dual[i] /= len;
    }
  }
  const Eigen::Quaternionf r(real[3], real[0], real[1], real[2]);
  const Eigen::Quaternionf d(dual[3], dual[0], dual[1], dual[2]);
  const Eigen::Quaternionf tq = d * r.conjugate();  // t = 2 * d * conj(r).
  const Eigen::Vector3f t = 2.0f * tq.vec();
  const float* p = &job.in_positions[3 * v];
  const Eigen::Vector3f q = r * Eigen::Vector3f(p[0], p[1], p[2]) + t;
  for (int i = 0; i < 3; ++i) job.out_positions[3 * v + i] = q[i];
  if (!job.in_normals.empty()) {
    const float* nn = &job.in_normals[3 * v];
    const Eigen::Vector3f n = r * Eigen::Vector3f(nn[0], nn[1], nn[2]);
    for (int i = 0; i < 3; ++i) job.out_normals[3 * v + i] = n[i];
  }
  if (!job.in_tangents.empty()) {
    const float* tt = &job.in_tangents[4 * v];
    const Eigen::Vector3f tv = r * Eigen::Vector3f(tt[0], tt[1], tt[2]);
    for (int i = 0; i < 3; ++i) job.out_tangents[4 * v + i] = tv[i];
    job.out_tangents[4 * v + 3] = tt[3];
  }
}

}  // namespace

bool SkinningJob::Run() const {
  if (!Validate()) return false;
  const size_t n = in_positions.size() / 3;
  if (!joint_dual_quaternions.empty()) {
    for (size_t v = 0; v < n; ++v) SkinVertexDq(*this, v);
    return true;
  }
  for (size_t v = 0; v < n; ++v) {
    // Blended matrix (upper 3x4, column-major).
    float m[12] = {0};
    for (size_t k = 0; k < influences; ++k) {
      const float w = weights[v * influences + k];
      if (w == 0.0f) continue;
      const float* jm = &joint_matrices[16 * static_cast<size_t>(joints[v * influences + k])];
      for (int c = 0; c < 4; ++c) {
        m[3 * c] += w * jm[4 * c];
        m[3 * c + 1] += w * jm[4 * c + 1];
        m[3 * c + 2] += w * jm[4 * c + 2];
      }
    }
    const float* p = &in_positions[3 * v];
    for (int r = 0; r < 3; ++r)
      out_positions[3 * v + r] = m[r] * p[0] + m[3 + r] * p[1] + m[6 + r] * p[2] + m[9 + r];
    if (!in_normals.empty()) TransformNormal(m, 3, &in_normals[3 * v], &out_normals[3 * v]);
    if (!in_tangents.empty()) {
      const float* t = &in_tangents[4 * v];
      float o[3];
      for (int r = 0; r < 3; ++r) o[r] = m[r] * t[0] + m[3 + r] * t[1] + m[6 + r] * t[2];
      const float len = std::sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
      for (int r = 0; r < 3; ++r) out_tangents[4 * v + r] = len > 0.0f ? o[r] / len : t[r];
      out_tangents[4 * v + 3] = t[3];
    }
  }
  return true;
}

}  // namespace engine
}  // namespace facespace
