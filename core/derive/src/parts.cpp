// The target's parts: which are skin, eyes, parts on the skin or apart from it; eyes' turns.
#include "parts.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace facespace::derive {

// The primitives of the region called `name`, or empty.
std::vector<uint32_t> RegionPrimitives(const Rig& rig, const std::string& name) {
  for (const Region& r : rig.regions) {
    if (r.name == name) return r.primitives;
  }
  return {};
}

// ---- the target's parts ----------------------------------------------------------------------

// The source's eyes (its manifest's "eyes" region, one primitive each) in the target's frame.
std::vector<Eye> SourceEyes(const Rig& source, const Similarity& sim) {
  std::vector<Eye> eyes;
  const auto world = PrimitiveWorldMatrices(source);
  for (uint32_t p : RegionPrimitives(source, "eyes")) {
    Eigen::AlignedBox3d box;
    const Primitive& prim = source.primitives[p];
    const Eigen::Map<const Eigen::Matrix4f> m(world[p].data());
    for (size_t v = 0; v < prim.vertex_count(); ++v)
      box.extend((m.cast<double>() *
                  Vec3(prim.positions[3 * v], prim.positions[3 * v + 1], prim.positions[3 * v + 2])
                      .homogeneous())
                     .head<3>());
    if (box.isEmpty()) continue;
    eyes.push_back(
        {sim(box.center()), 0.5 * sim.scale * box.diagonal().maxCoeff(), box.center().x() > 0});
  }
  return eyes;
}

namespace {

// Per part: whether it is round, its points about as far from its centre as an eyeball's are, and
// as deep as wide (a ring of lashes, an iris's cap, a mouth's bag are not).
std::vector<uint8_t> RoundParts(const Surface& t) {
  const size_t parts = t.part_size.size();
  std::vector<Eigen::AlignedBox3d> boxes(parts);
  for (size_t i = 0; i < t.points.size(); ++i) boxes[t.part[i]].extend(t.points[i]);
  std::vector<double> r1(parts, 0), r2(parts, 0);
  for (size_t i = 0; i < t.points.size(); ++i) {
    const double r = (t.points[i] - boxes[t.part[i]].center()).norm();
    r1[t.part[i]] += r, r2[t.part[i]] += r * r;
  }
  std::vector<uint8_t> round(parts, 0);
  for (size_t p = 0; p < parts; ++p) {
    const double n = t.part_size[p], mean = r1[p] / n;
    const Vec3 e = boxes[p].diagonal();
    round[p] = std::sqrt(std::max(0.0, r2[p] / n - mean * mean)) < 0.2 * mean &&
               e.minCoeff() > 0.5 * e.maxCoeff();
  }
  return round;
}

}  // namespace

// The target's body: the triangles of its largest part and of parts of a size near it that are
// not round (a head in pieces, a mouth's inside; not eyeballs and teeth), which the face registers
// onto.
std::vector<uint8_t> HeadPoints(const Surface& t) {
  Eigen::AlignedBox3d box;
  for (const Vec3& q : t.points) box.extend(q);
  std::vector<uint8_t> head(t.points.size(), 1);
  const Vec3 e = box.diagonal();
  if (!(e.y() > 2.5 * e.z())) return head;
  for (size_t i = 0; i < t.points.size(); ++i)
    head[i] = t.points[i].y() >= box.max().y() - 0.16 * e.y();
  return head;
}

std::vector<Tri> BodyTriangles(const Surface& t, std::span<const uint8_t> head) {
  const auto round = RoundParts(t);
  std::vector<Tri> body;
  for (const Tri& tri : t.triangles) {
    const uint32_t part = t.part[tri[0]];
    if (!head.empty() && !(head[tri[0]] && head[tri[1]] && head[tri[2]])) continue;
    if (part == 0 || (16 * t.part_size[part] >= t.part_size[0] && !round[part]))
      body.push_back(tri);
  }
  return body;
}

// What each part of the target is: an eye where a round part sits in a source eye, skin where the
// face matched enough of it, else rigid (teeth, tongue: following the skin near them) or still (far
// away).
std::vector<PartKind> ClassifyParts(const Surface& t, std::span<const uint8_t> matched_triangle,
                                    std::span<const Eye> eyes, const ClosestPoint& skin,
                                    double reach) {
  const size_t parts = t.part_size.size();
  std::vector<size_t> tris(parts, 0), hits(parts, 0);
  for (size_t i = 0; i < t.triangles.size(); ++i) {
    ++tris[t.part[t.triangles[i][0]]];
    hits[t.part[t.triangles[i][0]]] += matched_triangle[i];
  }
  std::vector<Eigen::AlignedBox3d> boxes(parts);
  for (size_t i = 0; i < t.points.size(); ++i) boxes[t.part[i]].extend(t.points[i]);
  const auto round = RoundParts(t);
  std::vector<PartKind> kind(parts, PartKind::kStill);
  for (size_t p = 0; p < parts; ++p) {
    for (const Eye& e : eyes) {
      if (p > 0 && round[p] && (boxes[p].center() - e.centre).norm() < e.radius &&
          boxes[p].diagonal().norm() < 4 * e.radius)
        kind[p] = PartKind::kEye;
    }
    if (kind[p] == PartKind::kEye) continue;
    // The largest part, parts of a size near it the face reaches, and parts it mostly covers.
    const bool large = 8 * t.part_size[p] >= t.part_size[0],
               sizeable = 20 * t.part_size[p] >= t.part_size[0];
    if (p == 0 || (large && hits[p] > 0) || (2 * hits[p] >= tris[p] && sizeable)) {
      kind[p] = PartKind::kSkin;
      continue;
    }
    ClosestPoint::Hit hit;
    if (skin.Find(boxes[p].center(), hit, reach * reach)) kind[p] = PartKind::kRigid;
  }
  return kind;
}

// ---- eyes ------------------------------------------------------------------------------------

// How far an eye turns at weight 1 of ARKit's eyeLook shapes (the source's own eyes turn by their
// bones, which no shape records): 30 degrees in and out, 25 up and down.
constexpr double kLookSideways = 30.0, kLookVertical = 25.0;

// The turn (source frame) an eyeLook shape gives the eye on `left`, or identity.
Eigen::Matrix3d EyeTurn(const std::string& name, bool left) {
  if (name.rfind("eyeLook", 0) != 0) return Eigen::Matrix3d::Identity();
  const bool named_left = name.find("Left") != std::string::npos || name.ends_with("_L");
  const bool named_right = name.find("Right") != std::string::npos || name.ends_with("_R");
  if ((left && !named_left) || (!left && !named_right)) return Eigen::Matrix3d::Identity();
  constexpr double kRad = 3.14159265358979323846 / 180.0;
  // Looking along +z, y up: up turns +z towards +y (about -x); out, for the left eye, towards +x.
  if (name.find("Up") != std::string::npos)
    return Eigen::AngleAxisd(-kLookVertical * kRad, Vec3::UnitX()).matrix();
  if (name.find("Down") != std::string::npos)
    return Eigen::AngleAxisd(kLookVertical * kRad, Vec3::UnitX()).matrix();
  const bool out = name.find("Out") != std::string::npos;
  if (!out && name.find("In") == std::string::npos) return Eigen::Matrix3d::Identity();
  const double sign = (out == left) ? 1.0 : -1.0;
  return Eigen::AngleAxisd(sign * kLookSideways * kRad, Vec3::UnitY()).matrix();
}

}  // namespace facespace::derive
