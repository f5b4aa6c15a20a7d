// Bullet's rigid-body world for a rig's Physics: bodies, spring joints, a ground plane; the bones
// they follow or move. The bodies live at the rig's authored scale (units_per_metre), where their
// masses, springs and dampings hold; poses and bones stay in the rig's metres.
#include "facespace/physics/physics.h"

#include <btBulletDynamicsCommon.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

#include "facespace/engine/transform.h"

namespace facespace::physics {

namespace {

constexpr float kStep = 1.0f / 120.0f;  // MMD players' fixed step.

using Affine = Eigen::Affine3f;

Affine FromColumnMajor(const std::array<float, 16>& m) {
  Affine a;
  a.matrix() = Eigen::Map<const Eigen::Matrix4f>(m.data());
  return a;
}

Affine FromPlacement(const std::array<float, 3>& t, const std::array<float, 4>& q) {
  Affine a = Affine::Identity();
  a.translate(Eigen::Vector3f(t[0], t[1], t[2]));
  a.rotate(Eigen::Quaternionf(q[3], q[0], q[1], q[2]).normalized());
  return a;
}

// Rigid transforms between the rig's metres and the simulation's units.
btTransform ToBullet(const Affine& a, float scale) {
  const Eigen::Quaternionf q(a.linear());
  const Eigen::Vector3f t = a.translation() * scale;
  return btTransform(btQuaternion(q.x(), q.y(), q.z(), q.w()).normalized(),
                     btVector3(t.x(), t.y(), t.z()));
}

Affine FromBullet(const btTransform& b, float scale) {
  const btQuaternion q = b.getRotation();
  const btVector3& t = b.getOrigin();
  Affine a = Affine::Identity();
  a.translate(Eigen::Vector3f(t.x(), t.y(), t.z()) / scale);
  a.rotate(Eigen::Quaternionf(q.w(), q.x(), q.y(), q.z()).normalized());
  return a;
}

std::unique_ptr<btCollisionShape> MakeShape(const RigidBody& b, float scale) {
  const btVector3 s(b.size[0] * scale, b.size[1] * scale, b.size[2] * scale);
  switch (b.shape) {
    case RigidBody::Shape::kBox: return std::make_unique<btBoxShape>(s);
    case RigidBody::Shape::kCapsule: return std::make_unique<btCapsuleShape>(s.x(), s.y());
    case RigidBody::Shape::kSphere: break;
  }
  return std::make_unique<btSphereShape>(s.x());
}

bool Simulated(const RigidBody& b) {
  return b.mode != RigidBody::Mode::kFollowBone && b.mass > 0.0f;
}

}  // namespace

struct Simulation::World {
  const Rig& rig;
  const float scale;
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  btStaticPlaneShape ground_shape{btVector3(0, 1, 0), 0};
  std::unique_ptr<btRigidBody> ground;
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btDefaultMotionState>> states;  // Followed bodies only.
  std::vector<std::unique_ptr<btRigidBody>> bodies;
  std::vector<std::unique_ptr<btGeneric6DofSpringConstraint>> joints;
  std::vector<Affine> offset, inverse_offset;  // Each body in its bone's frame (rest pose).
  std::vector<Affine> last;    // Followed bodies: where the last pose put them (metres).
  std::vector<Affine> target;  // Step's scratch: where this pose puts them.
  std::vector<int> driver;     // Per node: the simulated body that moves it, or -1.
  mutable std::vector<std::array<float, 16>> world_m, moved;
  mutable std::vector<int> order;

  explicit World(const Rig& r) : rig(r), scale(r.physics.units_per_metre) {}
  ~World() {
    for (auto& j : joints) world.removeConstraint(j.get());
    for (auto& b : bodies) world.removeRigidBody(b.get());
    if (ground) world.removeRigidBody(ground.get());
  }

  // Where `world_m` (a pose's world matrices) puts body `i`, in metres.
  Affine Target(size_t i) const {
    const int node = rig.physics.bodies[i].node;
    return FromColumnMajor(world_m[node >= 0 ? node : 0]) * offset[i];
  }
};

Simulation::Simulation(std::unique_ptr<World> world) : w_(std::move(world)) {}
Simulation::~Simulation() = default;

std::unique_ptr<Simulation> Simulation::Create(const Rig& rig, const Pose& pose) {
  const Physics& ph = rig.physics;
  const bool moves_a_bone = std::any_of(ph.bodies.begin(), ph.bodies.end(), [](const RigidBody& b) {
    return b.node >= 0 && Simulated(b);
  });
  if (!moves_a_bone || rig.nodes.empty()) return nullptr;
  auto w = std::make_unique<World>(rig);
  const float scale = w->scale;
  w->world.setGravity(btVector3(0, -ph.gravity * scale, 0));
  // The ground collides with every group.
  btRigidBody::btRigidBodyConstructionInfo ground_info(0, nullptr, &w->ground_shape);
  w->ground = std::make_unique<btRigidBody>(ground_info);
  w->world.addRigidBody(w->ground.get(), -1, -1);

  // Rest placements give the offsets and the joints' frames; the pose places the bodies.
  std::vector<int> order;
  std::vector<std::array<float, 16>> rest;
  WorldMatricesInto(rig, nullptr, rest, order);
  WorldMatricesInto(rig, &pose, w->world_m, w->order);
  const size_t n = ph.bodies.size();
  std::vector<Affine> rest_body(n);
  w->offset.resize(n);
  w->inverse_offset.resize(n);
  w->last.resize(n);
  w->driver.assign(rig.nodes.size(), -1);
  for (size_t i = 0; i < n; ++i) {
    const RigidBody& b = ph.bodies[i];
    rest_body[i] = FromPlacement(b.position, b.rotation);
    const Affine bone = FromColumnMajor(rest[b.node >= 0 ? b.node : 0]);
    w->offset[i] = bone.inverse() * rest_body[i];
    w->inverse_offset[i] = w->offset[i].inverse();
    w->last[i] = w->Target(i);
    const bool simulated = Simulated(b);
    if (simulated && b.node >= 0) w->driver[b.node] = static_cast<int>(i);

    w->shapes.push_back(MakeShape(b, scale));
    btCollisionShape* shape = w->shapes.back().get();
    btVector3 inertia(0, 0, 0);
    if (simulated) shape->calculateLocalInertia(b.mass, inertia);
    btMotionState* state = nullptr;
    if (!simulated) {
      w->states.push_back(std::make_unique<btDefaultMotionState>(ToBullet(w->last[i], scale)));
      state = w->states.back().get();
    }
    btRigidBody::btRigidBodyConstructionInfo info(simulated ? b.mass : 0.0f, state, shape, inertia);
    info.m_startWorldTransform = ToBullet(w->last[i], scale);
    info.m_linearDamping = b.linear_damping;
    info.m_angularDamping = b.angular_damping;
    info.m_restitution = b.restitution;
    info.m_friction = b.friction;
    info.m_additionalDamping = true;
    auto body = std::make_unique<btRigidBody>(info);
    body->setSleepingThresholds(0.01f, 0.0017453f);  // 0.1 degrees.
    body->setActivationState(DISABLE_DEACTIVATION);
    if (!simulated)
      body->setCollisionFlags(body->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
    w->world.addRigidBody(body.get(), 1 << b.group, b.collides_with);
    w->bodies.push_back(std::move(body));
  }
  for (const PhysicsJoint& j : ph.joints) {
    const Affine frame = FromPlacement(j.position, j.rotation);
    const btTransform in_a = ToBullet(rest_body[j.a].inverse() * frame, scale);
    const btTransform in_b = ToBullet(rest_body[j.b].inverse() * frame, scale);
    auto c = std::make_unique<btGeneric6DofSpringConstraint>(*w->bodies[j.a], *w->bodies[j.b], in_a,
                                                             in_b, true);
    c->setLinearLowerLimit(btVector3(j.linear_lower[0], j.linear_lower[1], j.linear_lower[2]) *
                           scale);
    c->setLinearUpperLimit(btVector3(j.linear_upper[0], j.linear_upper[1], j.linear_upper[2]) *
                           scale);
    c->setAngularLowerLimit(btVector3(j.angular_lower[0], j.angular_lower[1], j.angular_lower[2]));
    c->setAngularUpperLimit(btVector3(j.angular_upper[0], j.angular_upper[1], j.angular_upper[2]));
    for (int a = 0; a < 3; ++a) {
      if (j.linear_stiffness[a] != 0.0f) {
        c->enableSpring(a, true);
        c->setStiffness(a, j.linear_stiffness[a]);
      }
      if (j.angular_stiffness[a] != 0.0f) {
        c->enableSpring(a + 3, true);
        c->setStiffness(a + 3, j.angular_stiffness[a]);
      }
    }
    w->world.addConstraint(c.get());
    w->joints.push_back(std::move(c));
  }
  return std::unique_ptr<Simulation>(new Simulation(std::move(w)));
}

void Simulation::Step(const Pose& pose, float seconds) {
  World& w = *w_;
  if (!(seconds > 0.0f)) return;
  WorldMatricesInto(w.rig, &pose, w.world_m, w.order);
  const std::vector<RigidBody>& bodies = w.rig.physics.bodies;
  std::vector<Affine>& target = w.target;
  target.resize(bodies.size());
  for (size_t i = 0; i < bodies.size(); ++i) {
    if (!Simulated(bodies[i])) target[i] = w.Target(i);
  }
  const int steps = std::max(1, static_cast<int>(std::ceil(seconds / kStep - 1e-3f)));
  const float dt = seconds / static_cast<float>(steps);
  for (int s = 1; s <= steps; ++s) {
    const float u = static_cast<float>(s) / static_cast<float>(steps);
    size_t state = 0;
    for (size_t i = 0; i < bodies.size(); ++i) {
      if (Simulated(bodies[i])) continue;
      const Eigen::Quaternionf q0(w.last[i].linear()), q1(target[i].linear());
      Affine a = Affine::Identity();
      a.translate(w.last[i].translation() +
                  u * (target[i].translation() - w.last[i].translation()));
      a.rotate(q0.slerp(u, q1));
      w.states[state++]->setWorldTransform(ToBullet(a, w.scale));
    }
    w.world.stepSimulation(dt, 0, dt);
  }
  for (size_t i = 0; i < bodies.size(); ++i) {
    if (!Simulated(bodies[i])) w.last[i] = target[i];
  }
}

void Simulation::Apply(Pose& pose) const {
  const World& w = *w_;
  const Rig& rig = w.rig;
  WorldMatricesInto(rig, &pose, w.world_m, w.order);
  w.moved = w.world_m;
  for (int n : w.order) {
    const int parent = rig.nodes[n].parent;
    const Affine old_parent = parent >= 0 ? FromColumnMajor(w.world_m[parent]) : Affine::Identity();
    const Affine new_parent = parent >= 0 ? FromColumnMajor(w.moved[parent]) : Affine::Identity();
    const Affine local = old_parent.inverse() * FromColumnMajor(w.world_m[n]);
    Affine world = new_parent * local;
    const int b = w.driver[n];
    if (b >= 0) {
      const Affine placed =
          FromBullet(w.bodies[b]->getWorldTransform(), w.scale) * w.inverse_offset[b];
      const Eigen::Vector3f keep = world.translation();
      world = placed;
      if (rig.physics.bodies[b].mode == RigidBody::Mode::kPhysicsKeepPosition)
        world.translation() = keep;
      const Affine moved_local = new_parent.inverse() * world;
      const Eigen::Quaternionf q = Eigen::Quaternionf(moved_local.linear()).normalized();
      Transform& t = pose.local[n];
      t.translation = {moved_local.translation().x(), moved_local.translation().y(),
                       moved_local.translation().z()};
      t.rotation = {q.x(), q.y(), q.z(), q.w()};
      pose.from_matrix[n] = 0;
    }
    Eigen::Map<Eigen::Matrix4f>(w.moved[n].data()) = world.matrix();
  }
}

}  // namespace facespace::physics
