// The derive's view of a target's parts (skin, eyes, parts lying on the skin or apart from it)
// and the shapes it writes: what derive.cpp, parts.cpp and sets.cpp share.
#pragma once

#include <string>
#include <vector>

#include "internal.h"

namespace facespace::derive {

// kAttached: a thin part lying on the skin (lashes, an eye's wet line), each point following the
// skin under it; kRigid: a part apart from it (teeth), moved as one by the skin around it.
enum class PartKind : uint8_t { kSkin, kEye, kAttached, kRigid, kStill };

struct Eye {
  Vec3 centre = Vec3::Zero();  // Target frame.
  double radius = 0;
  bool left = false;  // The subject's left (+x in the source's frame).
};

// The primitives of the region called `name`, or empty.
std::vector<uint32_t> RegionPrimitives(const Rig& rig, const std::string& name);

// The source's eyes (its manifest's "eyes" region, one primitive each) in the target's frame.
std::vector<Eye> SourceEyes(const Rig& source, const Similarity& sim);

// The points of the target's head: all of a head; of a figure standing along +y (taller than 2.5
// times its depth: a body), its top 16% (a head is an eighth of a body; with its chin and neck).
std::vector<uint8_t> HeadPoints(const Surface& t);

// The target's body: the triangles of its largest part and of parts of a size near it that are
// not round (a head in pieces, a mouth's inside; not eyeballs and teeth), within `head` where it
// is given, which the face registers onto.
std::vector<Tri> BodyTriangles(const Surface& t, std::span<const uint8_t> head = {});

// What each part of the target is: an eye where a round part sits in a source eye, skin where the
// face matched enough of it, else rigid (teeth, tongue: following the skin near them) or still (far
// away).
std::vector<PartKind> ClassifyParts(const Surface& t, std::span<const uint8_t> matched_triangle,
                                    std::span<const Eye> eyes, const ClosestPoint& skin,
                                    double reach);

// The turn (source frame) an eyeLook shape gives the eye on `left`, or identity.
Eigen::Matrix3d EyeTurn(const std::string& name, bool left);

// Appends shape `shape` (its targets per primitive) to the rig. A shape that moves nothing here
// (a tongueOut on a head without a tongue) is still there, on the first mesh, so a client naming it
// finds it.
void AppendShape(Rig& rig, Shape shape, std::vector<SparseTarget> targets);

// The 15 visemes as shapes ("viseme_sil" .. "viseme_U", the names web avatars carry), each the sum
// of the shapes the viseme table (engine/speech.h) binds, where `rig` lacks one by that name.
void BakeVisemes(Rig& rig, Report& report);

}  // namespace facespace::derive
