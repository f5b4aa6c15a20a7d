// Secondary motion and constraints for a VRM: MMD's rigid bodies and joints as spring chains and
// colliders, MMD's rotation grants as node constraints. MMD simulates bodies in Bullet; VRM swings
// each bone towards its rest direction (stiffness) against drag and gravity. The mapping (ours,
// chosen to keep the authors' feel):
//   stiffness = 0.4 / (the joint's mean angular range, radians) + (its mean angular spring) / 100,
//   in [0.25, 4] drag      = 0.1 + half the body's angular damping;  gravity = 0.2 down;  hit
//   radius = the body's radius.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "export/vrm_parts.h"

namespace facespace::formats::writers {

namespace {

ordered_json Vec(const std::array<float, 3>& v) { return {Num(v[0]), Num(v[1]), Num(v[2])}; }

bool Dynamic(const RigidBody& b) { return b.node >= 0 && b.mode != RigidBody::Mode::kFollowBone; }

// The joint holding body `b` to another, or nullptr.
const PhysicsJoint* JointOf(const Physics& p, int b) {
  for (const PhysicsJoint& j : p.joints) {
    if (j.b == b) return &j;
  }
  for (const PhysicsJoint& j : p.joints) {
    if (j.a == b) return &j;
  }
  return nullptr;
}

SpringJoint JointSettings(const Rig& rig, int node, int body) {
  const RigidBody& b = rig.physics.bodies[body];
  SpringJoint s;
  s.node = node;
  s.hit_radius =
      b.shape == RigidBody::Shape::kBox ? std::min({b.size[0], b.size[1], b.size[2]}) : b.size[0];
  s.drag = std::clamp(0.1f + 0.5f * b.angular_damping, 0.0f, 1.0f);
  s.gravity = 0.2f;
  float range = 0.0f, spring = 0.0f;
  if (const PhysicsJoint* j = JointOf(rig.physics, body)) {
    for (int k = 0; k < 3; ++k) {
      const float r = j->angular_upper[k] - j->angular_lower[k];
      range += (r < 0 ? static_cast<float>(M_PI) : r) / 3.0f;  // lower > upper: free.
      spring += j->angular_stiffness[k] / 3.0f;
    }
  } else {
    range = static_cast<float>(M_PI);
  }
  s.stiffness = std::clamp(0.4f / std::max(range, 0.05f) + spring / 100.0f, 0.25f, 4.0f);
  return s;
}

// A point of the rig's space in node `n`'s space at rest.
std::array<float, 3> InNode(const std::array<float, 16>& world, const Eigen::Vector3f& p) {
  const Eigen::Vector3f q =
      Eigen::Map<const Eigen::Matrix4f>(world.data()).inverse().eval().topLeftCorner<3, 4>() *
      p.homogeneous();
  return {q.x(), q.y(), q.z()};
}

// A body that follows its bone as a collider: a sphere, or a capsule along its axis (a box's
// longest).
Collider ColliderOf(const RigidBody& b, const std::array<float, 16>& world) {
  Collider c;
  c.node = b.node;
  c.group = b.group;
  const Eigen::Quaternionf q(b.rotation[3], b.rotation[0], b.rotation[1], b.rotation[2]);
  const Eigen::Vector3f centre(b.position[0], b.position[1], b.position[2]);
  Eigen::Vector3f axis(0, 1, 0);
  float half = 0.0f;
  c.radius = b.size[0];
  if (b.shape == RigidBody::Shape::kCapsule) {
    half = 0.5f * b.size[1];
  } else if (b.shape == RigidBody::Shape::kBox) {
    const int longest =
        static_cast<int>(std::max_element(b.size.begin(), b.size.end()) - b.size.begin());
    axis = Eigen::Vector3f::Unit(longest);
    c.radius = std::max(b.size[(longest + 1) % 3], b.size[(longest + 2) % 3]);
    half = std::max(0.0f, b.size[longest] - c.radius);
  }
  const Eigen::Vector3f along = q.normalized() * axis * half;
  c.capsule = half > 0.0f;
  c.offset = InNode(world, centre - along);
  c.tail = InNode(world, centre + along);
  return c;
}

}  // namespace

SpringSetup SpringsOf(const Rig& rig) {
  SpringSetup out;
  const Physics& p = rig.physics;
  std::vector<int> body_of(rig.nodes.size(), -1);  // A node's dynamic body.
  for (size_t b = 0; b < p.bodies.size(); ++b) {
    if (Dynamic(p.bodies[b]) && static_cast<size_t>(p.bodies[b].node) < rig.nodes.size() &&
        body_of[p.bodies[b].node] < 0)
      body_of[p.bodies[b].node] = static_cast<int>(b);
  }
  const auto world = NodeWorldMatrices(rig);
  for (const RigidBody& b : p.bodies) {
    if (!Dynamic(b) && b.node >= 0 && static_cast<size_t>(b.node) < rig.nodes.size())
      out.colliders.push_back(ColliderOf(b, world[b.node]));
  }
  // Roots: dynamic bones under a bone that is not; each chain follows its first dynamic child, and
  // the others start chains of their own.
  std::vector<int> roots;
  for (size_t n = 0; n < rig.nodes.size(); ++n) {
    const int parent = rig.nodes[n].parent;
    if (body_of[n] >= 0 && (parent < 0 || body_of[parent] < 0))
      roots.push_back(static_cast<int>(n));
  }
  const size_t first_roots = roots.size();
  for (size_t r = 0; r < roots.size(); ++r) {
    Spring s;
    s.branch = r >= first_roots;
    s.name = rig.nodes[roots[r]].name;
    s.collides_with = p.bodies[body_of[roots[r]]].collides_with;
    for (int n = roots[r]; n >= 0;) {
      s.joints.push_back(JointSettings(rig, n, body_of[n]));
      int next = -1;
      for (int c : rig.nodes[n].children) {
        if (body_of[c] < 0) continue;
        if (next < 0)
          next = c;
        else
          roots.push_back(c);
      }
      if (next < 0 && !rig.nodes[n].children.empty())
        s.joints.push_back({rig.nodes[n].children[0], s.joints.back().hit_radius});  // The tail.
      n = next;
    }
    if (s.joints.size() >= 2) out.springs.push_back(std::move(s));
  }
  return out;
}

ordered_json SpringBone1(const SpringSetup& s) {
  ordered_json colliders = ordered_json::array(), groups = ordered_json::array(),
               springs = ordered_json::array();
  std::array<int, 16> group_at;
  group_at.fill(-1);
  for (size_t i = 0; i < s.colliders.size(); ++i) {
    const Collider& c = s.colliders[i];
    colliders.push_back(
        {{"node", c.node},
         {"shape",
          c.capsule
              ? ordered_json{{"capsule",
                              {{"offset", Vec(c.offset)},
                               {"radius", Num(c.radius)},
                               {"tail", Vec(c.tail)}}}}
              : ordered_json{{"sphere", {{"offset", Vec(c.offset)}, {"radius", Num(c.radius)}}}}}});
    const int g = c.group & 15;
    if (group_at[g] < 0) {
      group_at[g] = static_cast<int>(groups.size());
      groups.push_back({{"name", "PMX collision group " + std::to_string(g)},
                        {"colliders", ordered_json::array()}});
    }
    groups[group_at[g]]["colliders"].push_back(i);
  }
  for (const Spring& spring : s.springs) {
    ordered_json joints = ordered_json::array(), with = ordered_json::array();
    for (const SpringJoint& j : spring.joints) {
      joints.push_back({{"node", j.node},
                        {"hitRadius", Num(j.hit_radius)},
                        {"stiffness", Num(j.stiffness)},
                        {"gravityPower", Num(j.gravity)},
                        {"gravityDir", {0, -1, 0}},
                        {"dragForce", Num(j.drag)}});
    }
    for (int g = 0; g < 16; ++g) {
      if (group_at[g] >= 0 && (spring.collides_with >> g & 1)) with.push_back(group_at[g]);
    }
    ordered_json o = {{"name", spring.name}, {"joints", joints}};
    if (!with.empty()) o["colliderGroups"] = with;
    springs.push_back(std::move(o));
  }
  ordered_json out = {{"specVersion", "1.0"}};
  if (!colliders.empty()) out["colliders"] = colliders, out["colliderGroups"] = groups;
  out["springs"] = springs;
  return out;
}

// 0.x: a bone group per chain (its root bone; UniVRM follows the children), spheres only.
ordered_json SecondaryAnimation0(const SpringSetup& s) {
  ordered_json groups = ordered_json::array(), bone_groups = ordered_json::array();
  std::array<std::vector<int>, 16>
      of_group;  // Collider groups (one per node and PMX group) in each PMX group.
  for (const Collider& c : s.colliders) {
    ordered_json spheres = ordered_json::array();
    const int n = c.capsule ? 4 : 1;
    for (int k = 0; k < n; ++k) {
      const float t = n == 1 ? 0.0f : static_cast<float>(k) / (n - 1);
      std::array<float, 3> at;
      for (int d = 0; d < 3; ++d) at[d] = c.offset[d] + t * (c.tail[d] - c.offset[d]);
      spheres.push_back({{"offset", {{"x", Num(at[0])}, {"y", Num(at[1])}, {"z", Num(at[2])}}},
                         {"radius", Num(c.radius)}});
    }
    of_group[c.group & 15].push_back(static_cast<int>(groups.size()));
    groups.push_back({{"node", c.node}, {"colliders", spheres}});
  }
  for (const Spring& spring : s.springs) {
    if (spring.branch) continue;
    const SpringJoint& j = spring.joints.front();
    ordered_json with = ordered_json::array();
    for (int g = 0; g < 16; ++g) {
      if (spring.collides_with >> g & 1) {
        for (int c : of_group[g]) with.push_back(c);
      }
    }
    bone_groups.push_back({{"comment", spring.name},
                           {"stiffiness", Num(j.stiffness)},
                           {"gravityPower", Num(j.gravity)},
                           {"gravityDir", {{"x", 0}, {"y", -1}, {"z", 0}}},
                           {"dragForce", Num(j.drag)},
                           {"center", -1},
                           {"hitRadius", Num(j.hit_radius)},
                           {"bones", {j.node}},
                           {"colliderGroups", with}});
  }
  return {{"boneGroups", bone_groups}, {"colliderGroups", groups}};
}

namespace {

// A node inserted under `bone` at its place (identity transform), taking its children and its place
// in every skin: what the bone carried now turns with the bone and then with what the new node
// adds.
int InsertUnder(Rig& rig, int bone) {
  const int added = static_cast<int>(rig.nodes.size());
  Node n;
  n.name = rig.nodes[bone].name + "+grant";
  n.parent = bone;
  n.children = std::move(rig.nodes[bone].children);
  rig.nodes.push_back(std::move(n));
  rig.nodes[bone].children = {added};
  for (int c : rig.nodes[added].children) rig.nodes[c].parent = added;
  for (Skin& skin : rig.skins) std::replace(skin.joints.begin(), skin.joints.end(), bone, added);
  return added;
}

}  // namespace

Constrained WithNodeConstraints(const Rig& rig, std::span<const int> humanoid,
                                const SpringSetup& springs) {
  Constrained out{rig, {}, 0};
  auto in = [](int n, std::span<const int> list) {
    return std::find(list.begin(), list.end(), n) != list.end();
  };
  std::vector<int> swinging;
  for (const Spring& s : springs.springs) {
    for (const SpringJoint& j : s.joints) swinging.push_back(j.node);
  }
  for (const Grant& g : rig.constraints.grants) {
    const bool fits = g.rotation && !g.translation && g.ratio >= 0.0f && g.ratio <= 1.0f &&
                      g.node != g.source && g.node >= 0 && g.source >= 0 && !in(g.node, swinging);
    if (!fits) {
      ++out.dropped;
      continue;
    }
    const int node = in(g.node, humanoid) ? InsertUnder(out.rig, g.node) : g.node;
    out.constraints.emplace_back(
        node, ordered_json{{"specVersion", "1.0"},
                           {"constraint",
                            {{"rotation", {{"source", g.source}, {"weight", Num(g.ratio)}}}}}});
  }
  return out;
}

}  // namespace facespace::formats::writers
