// New shapes from existing ones: the mirror image of a shape on a symmetric rig, and a
// shape limited to a region (mask). Both add a shape to the rig, sparse like the others.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace {
inline namespace engine {

struct ShapeMask {
  int side = 0;  // +1: keep where coordinate `axis` > center; -1: where < center; 0: no side limit.
  int axis = 0;  // 0 x, 1 y, 2 z (mesh space).
  bool auto_center = true;  // center = the middle of the mesh's bounding box along `axis`,
  float center = 0.0f;      // or as given.
  float falloff = 0.0f;     // Width (mesh units) of a smooth ramp across the plane; 0 = hard cut.
  std::vector<uint32_t>
      vertices;  // Keep only these (indices over the rig's primitives in order); empty = all.
};

struct DeriveOptions {
  bool mirror = false;  // Reflect across the plane coordinate `axis` = center.
  int axis = 0;
  bool auto_center = true;  // center = the middle of the bounding box of the shape's
  float center = 0.0f;      // primitives along `axis` (mesh space), or as given.
  float tolerance = 1e-4f;  // Mirror matching: relative to the bounding-box diagonal.
  bool masked = false;
  ShapeMask mask;  // Applied after mirroring.
};

struct DeriveReport {
  int shape = -1;        // Index of the new shape.
  size_t unmatched = 0;  // Mirror: moved vertices whose reflection matched no vertex (left still).
  size_t vertices_moved = 0;
};

// Adds shape `name` derived from shape `from` (by name or alias). Errors: unknown `from`,
// `name` already taken, bad axis or vertex index. Group, range and default are copied.
Result<DeriveReport> DeriveShape(Rig& rig, const std::string& name, const std::string& from,
                                 const DeriveOptions& options);

// The box of the vertices the shapes move noticeably (over 5% of a shape's largest move; of the
// shapes the rig's expressions bind when it has expressions, so the face and not an ear or a
// skirt), in scene space at rest, 1st to 99th percentile per axis so a stray vertex does not widen
// it: where a camera should look on a whole body whose shapes are a face. False when no shape moves
// anything.
bool ShapeFocusBox(const Rig& rig, std::array<float, 3>& lo, std::array<float, 3>& hi);

// True when the shapes act on a small part of the rig (the focus box's diagonal under a third of
// the whole rest-pose box's: a face on a body): where a render frames by default (a skinned rig
// through ShapeFocusJoint, which a pose carries along, rather than the box taken at rest).
bool FrameShapesByDefault(const Rig& rig, const std::array<float, 3>& lo,
                          const std::array<float, 3>& hi);

// The joint (node index) that carries most of what the shapes move, by skin weight summed over
// the vertices ShapeFocusBox counts (Uka's head, 頭); -1 for a rig without a skin.
int ShapeFocusJoint(const Rig& rig);

// For each vertex of `primitive`, its mirror image across the plane coordinate `axis` =
// `center` (the closest vertex within `tolerance` mesh units of the reflected position), or -1.
std::vector<int32_t> MirrorMap(const Primitive& primitive, int axis, float center, float tolerance);

}  // namespace engine
}  // namespace facespace
