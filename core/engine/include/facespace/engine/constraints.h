// MMD's bone constraints over a pose: grants (a bone inherits a share of another's rotation or
// translation) and IK chains (cyclic coordinate descent with per-step and per-axis limits), solved
// as MMD solves them, in its deform order.
#pragma once

#include "facespace/engine/animation.h"
#include "facespace/engine/hierarchy.h"
#include "facespace/engine/rig.h"

namespace facespace {
inline namespace engine {

// Rewrites the local transforms of `pose` (its clips and joint overrides applied: MMD's animated
// values) into the solved ones, for the rig's grants and IK chains, in `rig.constraints.order`:
// per bone its grant, then its IK chain. A bone's rotation becomes ik * animated * granted, its
// translation animated + granted. Nothing happens for a rig without constraints.
void SolveBoneConstraints(const Rig& rig, Pose& pose);

// Clip `clip` with the constraints solved into it, for formats that cannot say them (glTF): the
// rotations and translations of the bones the constraints move, sampled `per_second` times a
// second (and at its end) from the solved pose, replace the clip's own channels for those bones.
// A rig without constraints, or a clip that moves no joint, gets the clip as it is.
AnimationInfo ClipWithConstraintsSolved(const Rig& rig, int clip, float per_second);

}  // namespace engine
}  // namespace facespace
