// What the FBX and COLLADA readers share: their files index attributes per polygon corner, so a
// mesh is split into vertices that each remember the control point ("position index") they came
// from; shapes and skin weights, given per control point, follow through that map. And both give
// node transforms as matrices, made TRS where they can be.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "facespace/engine/rig.h"

namespace facespace::formats {

// One joint influence: (joint index in the skin, weight).
using Influences = std::vector<std::pair<uint32_t, float>>;

// Sets `prim`'s skinning from per-control-point influences: as many slots per vertex as the most
// any point has, weights normalised to sum 1. Every point must have at least one influence.
inline void SetInfluences(Primitive& prim, const std::vector<uint32_t>& point_of_vertex,
                          const std::vector<Influences>& per_point) {
  size_t most = 1;
  for (const Influences& inf : per_point) most = std::max(most, inf.size());
  prim.influences = most;
  prim.joints.assign(point_of_vertex.size() * most, 0);
  prim.joint_weights.assign(point_of_vertex.size() * most, 0.0f);
  for (size_t v = 0; v < point_of_vertex.size(); ++v) {
    const Influences& inf = per_point[point_of_vertex[v]];
    float total = 0.0f;
    for (const auto& [j, w] : inf) total += w;
    for (size_t i = 0; i < inf.size(); ++i) {
      prim.joints[v * most + i] = static_cast<uint16_t>(inf[i].first);
      prim.joint_weights[v * most + i] = inf[i].second / total;
    }
  }
}

// TRS of a matrix; false when it shears (no TRS gives it).
inline bool DecomposeTrs(const Eigen::Matrix4d& m, std::array<float, 3>& t, std::array<float, 4>& q,
                         std::array<float, 3>& s) {
  Eigen::Matrix3d a = m.block<3, 3>(0, 0);
  Eigen::Vector3d scale(a.col(0).norm(), a.col(1).norm(), a.col(2).norm());
  if (a.determinant() < 0) scale.x() = -scale.x();
  for (int c = 0; c < 3; ++c) {
    if (!(std::fabs(scale[c]) > 1e-12)) return false;
    a.col(c) /= scale[c];
  }
  const bool orthonormal =
      (a.transpose() * a - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-5;
  Eigen::Quaterniond r(a);
  r.normalize();
  for (int c = 0; c < 3; ++c) {
    t[c] = static_cast<float>(m(c, 3));
    s[c] = static_cast<float>(scale[c]);
  }
  q = {static_cast<float>(r.x()), static_cast<float>(r.y()), static_cast<float>(r.z()),
       static_cast<float>(r.w())};
  return orthonormal;
}

// A node's local transform from a matrix: TRS when it has one, else the matrix itself.
inline void SetNodeLocal(Node& node, const Eigen::Matrix4d& m) {
  if (!DecomposeTrs(m, node.translation, node.rotation, node.scale)) {
    node.has_matrix = true;
    for (int k = 0; k < 16; ++k) node.matrix[k] = static_cast<float>(m(k % 4, k / 4));
  }
}

}  // namespace facespace::formats
