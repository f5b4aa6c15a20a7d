// The node hierarchy under a pose: local transforms per node, world matrices, joint matrices.
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/transform.h"

namespace facespace {
inline namespace engine {

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

// The same into `world` (resized to the node count), under `pose` or, when null, the nodes' own
// transforms (the rest pose). `order` is scratch: nothing allocates once both have grown.
void WorldMatricesInto(const Rig& rig, const Pose* pose, std::vector<std::array<float, 16>>& world,
                       std::vector<int>& order);

// Joint matrices of a skin: world(joint) * inverseBind(joint), 16 floats each.
void JointMatrices(const Rig& rig, int skin, std::span<const std::array<float, 16>> world,
                   std::vector<float>& out);

// Index of the node called `name`, or -1.
int FindNode(const Rig& rig, const std::string& name);

}  // namespace engine
}  // namespace facespace
