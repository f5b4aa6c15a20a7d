// The node hierarchy: rest pose, world matrices, joint matrices.
#include "facespace/engine/hierarchy.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace facespace {
inline namespace engine {

int FindNode(const Rig& rig, const std::string& name) {
  for (size_t i = 0; i < rig.nodes.size(); ++i) {
    if (rig.nodes[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

Pose RestPose(const Rig& rig) {
  Pose p;
  p.local.resize(rig.nodes.size());
  p.from_matrix.resize(rig.nodes.size(), 0);
  for (size_t i = 0; i < rig.nodes.size(); ++i) {
    const Node& n = rig.nodes[i];
    p.local[i] = {n.translation, NormalizedQuaternion(n.rotation), n.scale};
    p.from_matrix[i] = n.has_matrix ? 1 : 0;
  }
  return p;
}

void WorldMatricesInto(const Rig& rig, const Pose* pose, std::vector<std::array<float, 16>>& world,
                       std::vector<int>& order) {
  const size_t n = rig.nodes.size();
  world.resize(n);
  order.clear();
  for (size_t i = 0; i < n; ++i) {
    if (rig.nodes[i].parent < 0) order.push_back(static_cast<int>(i));
  }
  for (size_t q = 0; q < order.size(); ++q) {  // Breadth first: parents before children.
    const int i = order[q];
    const Node& node = rig.nodes[i];
    std::array<float, 16> local;
    if (pose ? pose->from_matrix[i] != 0 : node.has_matrix) {
      local = node.matrix;
    } else {
      local = ComposeTrs(
          pose ? pose->local[i]
               : Transform{node.translation, NormalizedQuaternion(node.rotation), node.scale});
    }
    if (node.parent < 0) {
      world[i] = local;
    } else {
      Eigen::Map<Eigen::Matrix4f>(world[i].data()) =
          Eigen::Map<const Eigen::Matrix4f>(world[node.parent].data()) *
          Eigen::Map<const Eigen::Matrix4f>(local.data());
    }
    for (int c : node.children) order.push_back(c);
  }
}

std::vector<std::array<float, 16>> WorldMatrices(const Rig& rig, const Pose& pose) {
  std::vector<std::array<float, 16>> world;
  std::vector<int> order;
  WorldMatricesInto(rig, &pose, world, order);
  return world;
}

void JointMatrices(const Rig& rig, int skin, std::span<const std::array<float, 16>> world,
                   std::vector<float>& out) {
  const Skin& s = rig.skins[skin];
  out.resize(16 * s.joints.size());
  for (size_t j = 0; j < s.joints.size(); ++j) {
    const Eigen::Map<const Eigen::Matrix4f> w(world[s.joints[j]].data());
    const Eigen::Map<const Eigen::Matrix4f> ibm(&s.inverse_bind[16 * j]);
    Eigen::Map<Eigen::Matrix4f> joint(&out[16 * j]);
    joint = w * ibm;
  }
}

}  // namespace engine
}  // namespace facespace
