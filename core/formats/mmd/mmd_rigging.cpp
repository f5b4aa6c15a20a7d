// An MMD model's bones and rigid bodies as the rig's constraints (grants, IK) and physics (mmd.h).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "facespace/engine/rig.h"
#include "facespace/engine/transform.h"
#include "mmd/mmd.h"

namespace facespace::formats::mmd {

// The bones' grants and IK chains as the rig's constraints, in MMD's deform order (after-physics
// bones last, then by layer, then by index). Limits turn with the axes: MMD's z is our -z, so
// rotations about x and y change sign (their ranges swap ends) and about z keep it. What names no
// bone (or itself) is dropped and counted in `dropped`.
void ReadConstraints(const std::vector<Bone>& bones, const std::vector<int>& node_of, Rig& rig,
                     size_t& dropped) {
  const int64_t n = static_cast<int64_t>(bones.size());
  const auto bone = [&](int64_t b) { return b >= 0 && b < n; };
  constexpr int32_t kMaxLoops =
      256;  // MMD models use 40 at most; a hostile count is cut (the work per pose is capped).
  std::vector<int> by_order(bones.size());
  for (size_t b = 0; b < bones.size(); ++b) by_order[b] = static_cast<int>(b);
  std::stable_sort(by_order.begin(), by_order.end(), [&](int a, int b) {
    return std::pair(bones[a].after_physics, bones[a].layer) <
           std::pair(bones[b].after_physics, bones[b].layer);
  });
  // The work a pose costs is capped: per chain, loops x the nodes its links move (each link's
  // subtree); chains past kMaxIkWork in all are dropped (a hostile file, not a model: Uka's ten
  // need about 3,000).
  constexpr size_t kMaxIkWork = 1'000'000;
  std::vector<size_t> subtree(rig.nodes.size(), 1);
  for (size_t i = rig.nodes.size(); i-- > 1;) {
    if (rig.nodes[i].parent >= 0) subtree[rig.nodes[i].parent] += subtree[i];
  }
  size_t work = 0;
  BoneConstraints& c = rig.constraints;
  for (int b : by_order) {
    const Bone& x = bones[b];
    const bool granted = x.grant_rotation || x.grant_translation;
    if (granted && (!bone(x.grant) || x.grant == b || !std::isfinite(x.grant_ratio)))
      ++dropped;
    else if (granted)
      c.grants.push_back({node_of[b], node_of[x.grant], x.grant_ratio, x.grant_rotation,
                          x.grant_translation, x.grant_local});
    if (x.ik) {
      IkChain chain{node_of[b],
                    bone(x.ik_effector) ? node_of[x.ik_effector] : -1,
                    std::clamp(x.ik_loops, 0, kMaxLoops),
                    std::isfinite(x.ik_angle) ? std::max(x.ik_angle, 0.0f) : 0.0f,
                    {}};
      bool ok = chain.effector >= 0 && x.ik_effector != b;
      for (const IkLinkData& l : x.ik_links) {
        ok &= bone(l.bone) && l.bone != b;
        if (!ok) break;
        IkLink link{node_of[l.bone],
                    l.limited,
                    {-l.upper[0], -l.upper[1], l.lower[2]},
                    {-l.lower[0], -l.lower[1], l.upper[2]}};
        for (int a = 0; a < 3; ++a)
          ok &= std::isfinite(link.lower[a]) && std::isfinite(link.upper[a]);
        chain.links.push_back(link);
      }
      size_t cost = 0;
      for (const IkLink& l : chain.links)
        cost += static_cast<size_t>(chain.loops) * subtree[l.node];
      if (ok && work + cost <= kMaxIkWork) {
        work += cost;
        c.chains.push_back(std::move(chain));
      } else {
        ++dropped;
      }
    }
    if (granted || x.ik) c.order.push_back(node_of[b]);
  }
  if (c.empty()) c.order.clear();
}

namespace {

// MMD's Euler angles applied in `order` (axes 0-2, first applied first), turned into the rig's axes
// as positions are: (x, y, z, w) becomes (-x, -y, z, w).
std::array<float, 4> EulerToRig(const float* angles, std::array<int, 3> order) {
  Eigen::Quaternionf q = Eigen::Quaternionf::Identity();
  for (int axis : order) q = Eigen::AngleAxisf(angles[axis], Eigen::Vector3f::Unit(axis)) * q;
  return {-q.x(), -q.y(), q.z(), q.w()};
}

}  // namespace

// The rigid bodies and joints as the rig's physics (rig.h), in its axes and metres; the masses,
// springs and dampings hold at MMD's scale, where it is simulated. Bodies and joints that name
// nothing, or of an unknown shape or mode, are dropped and counted.
void ReadPhysics(const Model& in, const std::vector<int>& node_of, Rig& rig, size_t& dropped) {
  constexpr size_t kMaxBodies = 1024,
                   kMaxJoints = 2048;  // A model has hundreds; each costs every step.
  Physics& ph = rig.physics;
  ph.units_per_metre = 1.0f / kMetresPerUnit;
  ph.gravity = 9.8f * 10.0f * kMetresPerUnit;  // MMD's 9.8 x 10 units a second squared.
  const int64_t nbones = static_cast<int64_t>(in.bones.size());
  std::vector<int> body_of(in.bodies.size(), -1);
  for (size_t i = 0; i < in.bodies.size(); ++i) {
    const RigidBodyData& b = in.bodies[i];
    if (b.shape > 2 || b.mode > 2 || b.bone >= nbones || b.bone < -1 || b.group > 15 ||
        ph.bodies.size() >= kMaxBodies) {
      ++dropped;
      continue;
    }
    RigidBody body;
    body.name = b.name;
    body.node = b.bone >= 0 ? node_of[b.bone] : -1;
    body.shape = static_cast<RigidBody::Shape>(b.shape);
    body.mode = static_cast<RigidBody::Mode>(b.mode);
    for (int a = 0; a < 3; ++a) body.size[a] = std::clamp(b.size[a], 1e-3f, 1e4f) * kMetresPerUnit;
    float pos[3] = {b.pos[0], b.pos[1], b.pos[2]};
    if (in.body_positions_from_bone && nbones > 0) {  // PMD: from its bone (or the first bone).
      const float* from = in.bones[b.bone >= 0 ? b.bone : 0].pos;
      for (int a = 0; a < 3; ++a) pos[a] += from[a];
    }
    body.position = ToGltf(pos);
    body.rotation = EulerToRig(b.rot, {2, 0, 1});  // R = Ry Rx Rz.
    body.mass = std::clamp(b.mass, 0.0f, 1e6f);
    body.linear_damping = std::clamp(b.linear_damping, 0.0f, 1.0f);
    body.angular_damping = std::clamp(b.angular_damping, 0.0f, 1.0f);
    body.restitution = std::clamp(b.restitution, 0.0f, 1.0f);
    body.friction = std::clamp(b.friction, 0.0f, 1e3f);
    body.group = b.group;
    body.collides_with = b.mask;
    body_of[i] = static_cast<int>(ph.bodies.size());
    ph.bodies.push_back(std::move(body));
  }
  const int64_t nbodies = static_cast<int64_t>(in.bodies.size());
  for (const JointData& j : in.joints) {
    if (j.type != 0 || j.a < 0 || j.b < 0 || j.a >= nbodies || j.b >= nbodies || body_of[j.a] < 0 ||
        body_of[j.b] < 0 || j.a == j.b || ph.joints.size() >= kMaxJoints) {
      ++dropped;
      continue;
    }
    PhysicsJoint joint;
    joint.name = j.name;
    joint.a = body_of[j.a];
    joint.b = body_of[j.b];
    joint.position = ToGltf(j.pos);
    joint.rotation = EulerToRig(j.rot, {0, 1, 2});  // R = Rz Ry Rx.
    for (int a = 0; a < 3; ++a) {
      // The z axis turns over: translations along it and rotations about x and y change sign.
      const bool flip_linear = a == 2, flip_angular = a != 2;
      joint.linear_lower[a] =
          (flip_linear ? -j.linear_upper[a] : j.linear_lower[a]) * kMetresPerUnit;
      joint.linear_upper[a] =
          (flip_linear ? -j.linear_lower[a] : j.linear_upper[a]) * kMetresPerUnit;
      joint.angular_lower[a] = flip_angular ? -j.angular_upper[a] : j.angular_lower[a];
      joint.angular_upper[a] = flip_angular ? -j.angular_lower[a] : j.angular_upper[a];
      joint.linear_stiffness[a] = std::clamp(j.linear_spring[a], 0.0f, 1e6f);
      joint.angular_stiffness[a] = std::clamp(j.angular_spring[a], 0.0f, 1e6f);
    }
    ph.joints.push_back(std::move(joint));
  }
  if (ph.bodies.empty()) ph = Physics{};
}

}  // namespace facespace::formats::mmd
