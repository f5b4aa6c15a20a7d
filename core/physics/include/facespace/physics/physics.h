// Secondary motion (the lecture's "secondary, physically generated"): a rig's rigid bodies and
// joints (rig.h's Physics) simulated over time with Bullet, as MMD players do. Bodies that follow
// their bones are moved by the animated pose; the others fall, swing and collide, held by their
// joints, and turn (or move) their bones.
#pragma once

#include <memory>

#include "facespace/engine/hierarchy.h"
#include "facespace/engine/rig.h"

namespace facespace::physics {

// Fixed steps of 1/120 s at the rig's authored scale (MMD's 12.5 units a metre), gravity down -y, a
// ground plane at y = 0. Deterministic: the same poses and steps give the same bytes.
class Simulation {
 public:
  // The rig's bodies placed where `pose` puts their bones, at rest (no velocity); null when the rig
  // has no body that would move a bone.
  static std::unique_ptr<Simulation> Create(const Rig& rig, const Pose& pose);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // Moves the bodies that follow their bones from the last pose to `pose` over `seconds` (in steps
  // of at most 1/120 s, the followed bodies interpolated between the two), simulating the others.
  void Step(const Pose& pose, float seconds);

  // The simulated bones into `pose` (the animated pose of the same time): each body that moves
  // its bone sets the bone's rotation, and its place unless it keeps its position on its parent;
  // bones under them follow. Parents before children; the last body on a bone wins, as in MMD.
  void Apply(Pose& pose) const;

 private:
  struct World;
  explicit Simulation(std::unique_ptr<World> world);
  std::unique_ptr<World> w_;
};

}  // namespace facespace::physics
