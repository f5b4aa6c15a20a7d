// The derive's steps over plain data: a rig's welded surface in world space, closest points on it,
// similarity alignment, non-rigid registration, and the Poisson transfer of deformation gradients.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <span>
#include <stop_token>
#include <unordered_map>
#include <vector>

#include "facespace/derive/derive.h"
#include "facespace/engine/rig.h"

namespace facespace::derive {

using Vec3 = Eigen::Vector3d;
using Tri = std::array<uint32_t, 3>;

// A rig's triangles in world space with the copies of a vertex (UV seams, split normals) welded:
// one point per distinct world position. Degenerate triangles (two equal corners, or no area) are
// left out. Each rig vertex knows its point; each point its connected part.
struct Surface {
  std::vector<Vec3> points;
  std::vector<Tri> triangles;
  std::vector<uint32_t> vertex_start;  // Per primitive: where its vertices begin in vertex_point.
  std::vector<uint32_t> vertex_point;  // Per rig vertex (all primitives in order): its point.
  std::vector<uint32_t> part;          // Per point: its connected part (largest first).
  std::vector<uint32_t> part_size;     // Points per part.
  std::vector<uint32_t> point_primitive;  // Per point: a primitive showing it.
};

// The surface of `primitives` of `rig` (all triangle primitives when empty).
Surface BuildSurface(const Rig& rig, std::span<const uint32_t> primitives = {});

double Diagonal(std::span<const Vec3> points);

// Closest points on a triangle set: a bounding-volume hierarchy, built once, queried many times.
class ClosestPoint {
 public:
  ClosestPoint(std::span<const Vec3> points, std::span<const Tri> triangles);
  struct Hit {
    uint32_t triangle = 0;
    Vec3 point = Vec3::Zero();
    Vec3 barycentric = Vec3::Zero();
    double distance2 = 0;
  };
  // The closest point to `q` no farther than sqrt(max_distance2); false when there is none.
  bool Find(const Vec3& q, Hit& hit, double max_distance2) const;

 private:
  struct Node {
    Eigen::AlignedBox3d box;
    uint32_t first = 0, count = 0;  // Leaf: triangles order[first, first + count); else children.
    uint32_t left = 0, right = 0;
  };
  uint32_t Build(uint32_t first, uint32_t count, std::vector<Vec3>& centers);
  std::span<const Vec3> points_;
  std::span<const Tri> triangles_;
  std::vector<uint32_t> order_;
  std::vector<Node> nodes_;
};

// The closest point of triangle (a, b, c) to p, with its barycentric weights.
Vec3 ClosestOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, Vec3& bary);

// p -> scale * rotation * p + translation.
struct Similarity {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  double scale = 1;
  Vec3 translation = Vec3::Zero();
  Vec3 operator()(const Vec3& p) const { return scale * (rotation * p) + translation; }
};

// The similarity that best maps `from` onto `to` (Umeyama 1991), weighted; identity for fewer than
// three pairs. `allow_scale` false: a rigid motion.
Similarity FitSimilarity(std::span<const Vec3> from, std::span<const Vec3> to,
                         std::span<const double> weights, bool allow_scale = true);

// Per-point smooth normals (area weighted) of a triangle set.
std::vector<Vec3> PointNormals(std::span<const Vec3> points, std::span<const Tri> triangles);

// Non-rigid ICP (Amberg, Romdhani, Vetter 2007): per-point affine transforms of `source` (already
// aligned) pulled onto `target`, kept smooth by a stiffness that falls over `stiffness`; landmark
// pairs (source point, target position) pull harder; points `fitted` marks 0 (all fitted when
// empty) seek no partner and go where their neighbours take them. Returns the deformed points.
struct RegisterOptions {
  std::vector<double> stiffness = {50, 20, 10, 5, 2, 1};
  int iterations = 3;  // Per stiffness.
  double reject_distance =
      0.05;                    // Correspondences farther than this fraction of the diagonal drop.
  double landmark_weight = 1;  // Relative to a data point's.
  std::stop_token stop;        // Checked between solves: the points as they are then.
};
std::vector<Vec3> RegisterNonRigid(std::span<const Vec3> source,
                                   std::span<const Tri> source_triangles,
                                   const ClosestPoint& target,
                                   std::span<const Vec3> target_normals_of_triangles,
                                   std::span<const std::pair<uint32_t, Vec3>> landmarks,
                                   const RegisterOptions& options, double diagonal,
                                   std::span<const uint8_t> fitted = {});

// A smooth field of values given at points: at x, the mean of the values of the points within
// `radius`, weighted by inverse distance (falling to 0 at the radius); `otherwise` where none is.
class PointField {
 public:
  PointField(std::span<const Vec3> points, std::vector<Vec3> values, double radius);
  Vec3 At(const Vec3& x, const Vec3& otherwise) const;

 private:
  std::span<const Vec3> points_;
  std::vector<Vec3> values_;
  double radius_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> cells_;
};

// A landmark both heads have: the source's (a point of its skin surface) and where it is on the
// target (on its surface).
struct LandmarkPair {
  std::string name;
  size_t index = 0;  // In Options::landmarks, for the error's field.
  uint32_t source_point = 0;
  Vec3 source = Vec3::Zero();
  Vec3 target = Vec3::Zero();
};

// The target's landmarks (Options::landmarks) paired by name with the source's (its manifest's),
// each put on the target's surface; a landmark the source lacks, a vertex beyond the mesh or a
// position off it is refused naming "/landmarks/points/I".
Result<std::vector<LandmarkPair>> PairLandmarks(const Rig& source, const Surface& skin,
                                                const Rig& target, const Surface& surface,
                                                const ClosestPoint& closest,
                                                std::span<const TargetLandmark> landmarks);

// A similarity putting `source` (a face, y up, looking along +z as glTF's) onto the front of
// `target`: nose tips together, the face's width matched, then refined by ICP.
Similarity AlignByShape(std::span<const Vec3> source, const Surface& target,
                        std::span<const uint8_t> head, const ClosestPoint& closest);

// ICP over similarities from `start`: trimmed closest points, the landmarks weighed in.
Similarity RefineSimilarity(Similarity start, std::span<const Vec3> source,
                            const ClosestPoint& closest, double diagonal,
                            std::span<const LandmarkPair> landmarks, int iterations);

// This thread's CPU time, in seconds: a derive in a server runs beside other requests.
double CpuSeconds();

// Each primitive's world matrix's linear part.
std::vector<Eigen::Matrix3d> LinearParts(const Rig& rig);

// Shape `shape`'s displacement of each point of `s` (world space; zero where it does not move).
void ShapeDisplacement(const Rig& rig, const Surface& s, std::span<const Eigen::Matrix3d> linear,
                       uint32_t shape, std::vector<Vec3>& out);

// Where the source's vertices land on the target once registered onto it as a derive registers it
// (the same caps, landmarks, cancellation and poor-fit refusal): per source vertex in the file's
// numbering (MediaPipe's canonical face: vertex i is its tracker's landmark i), a triangle of the
// target's surface and the closest point's barycentric weights; `found` false for a vertex that
// lands nowhere near it.
struct Spot {
  bool found = false;
  Tri triangle{};
  Vec3 weights = Vec3::Zero();
};
struct Landed {
  Surface surface;  // The target's.
  std::vector<Spot> spots;
  double diag = 0;  // The target head's diagonal.
};
Result<Landed> LandOnTarget(const Rig& target, const Rig& source, const Options& o, Report& report);

}  // namespace facespace::derive
