// DeriveShapes: align, register, transfer, write the shapes into the target.
#include "facespace/derive/derive.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <set>

#include "facespace/engine/face.h"
#include "internal.h"
#include "parts.h"
#include "transfer.h"

namespace facespace::derive {

// The world matrices' linear parts of each primitive.
std::vector<Eigen::Matrix3d> LinearParts(const Rig& rig) {
  std::vector<Eigen::Matrix3d> out;
  for (const auto& m : PrimitiveWorldMatrices(rig))
    out.push_back(Eigen::Map<const Eigen::Matrix4f>(m.data()).topLeftCorner<3, 3>().cast<double>());
  return out;
}

// Shape `shape`'s displacement of each point of `s` (world space; zero where it does not move).
void ShapeDisplacement(const Rig& rig, const Surface& s, std::span<const Eigen::Matrix3d> linear,
                       uint32_t shape, std::vector<Vec3>& out) {
  out.assign(s.points.size(), Vec3::Zero());
  for (const Mesh& mesh : rig.meshes) {
    for (size_t t = 0; t < mesh.target_shapes.size(); ++t) {
      if (mesh.target_shapes[t] != shape) continue;
      for (int p : mesh.primitives) {
        const SparseTarget& target = rig.primitives[p].targets[t];
        for (size_t k = 0; k < target.indices.size(); ++k) {
          const uint32_t point = s.vertex_point[s.vertex_start[p] + target.indices[k]];
          if (point == UINT32_MAX) continue;
          const float* d = &target.position_deltas[3 * k];
          out[point] = linear[p] * Vec3(d[0], d[1], d[2]);
        }
      }
    }
  }
}

// This thread's CPU time: a derive in a server runs beside other requests.
double CpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

namespace {

using Landmarks = std::vector<std::pair<uint32_t, Vec3>>;  // (source skin point, target position)
// The reach of the registration's move field (a fraction of the head's diagonal): about an eye's
// height, so that a lid's move ends where the target's other lid is.
constexpr double kOffsetRadius = 0.03;
// Around an eye (within this many of its radii) the source's moves weigh this much in the
// transfer against the gradients (elsewhere 1).
constexpr double kLidReach = 1.8;
constexpr double kLidWeight = 4.0;

void Progress(const Options& o, double f, const char* step) {
  if (o.progress) o.progress(f, step);
}

// ---- the correspondence ----------------------------------------------------------------------

struct Correspondence {
  std::vector<uint32_t>
      triangle_source;                 // Per target triangle: the source triangle, or UINT32_MAX.
  std::vector<uint32_t> point_source;  // Per target point: the source triangle, or UINT32_MAX.
  std::vector<Vec3> point_bary;
  std::vector<double> point_distance;
};

Correspondence Correspond(const Surface& t, std::span<const Vec3> registered,
                          std::span<const Tri> tris, const ClosestPoint& skin, double tolerance,
                          double reach) {
  Correspondence c;
  const auto tn = PointNormals(t.points, t.triangles);
  const auto sn = PointNormals(registered, tris);
  c.triangle_source.assign(t.triangles.size(), UINT32_MAX);
  for (size_t i = 0; i < t.triangles.size(); ++i) {
    const Tri& tri = t.triangles[i];
    const Vec3 centre = (t.points[tri[0]] + t.points[tri[1]] + t.points[tri[2]]) / 3;
    const Vec3 n = (t.points[tri[1]] - t.points[tri[0]])
                       .cross(t.points[tri[2]] - t.points[tri[0]])
                       .normalized();
    ClosestPoint::Hit hit;
    if (!skin.Find(centre, hit, tolerance * tolerance)) continue;
    const Tri& s = tris[hit.triangle];
    const Vec3 m = (registered[s[1]] - registered[s[0]])
                       .cross(registered[s[2]] - registered[s[0]])
                       .normalized();
    if (n.dot(m) > 0.3) c.triangle_source[i] = hit.triangle;
  }
  c.point_source.assign(t.points.size(), UINT32_MAX);
  c.point_bary.assign(t.points.size(), Vec3::Zero());
  c.point_distance.assign(t.points.size(), -1);
  for (size_t i = 0; i < t.points.size(); ++i) {
    ClosestPoint::Hit hit;
    if (!skin.Find(t.points[i], hit, reach * reach)) continue;
    const Tri& s = tris[hit.triangle];
    const Vec3 m = hit.barycentric[0] * sn[s[0]] + hit.barycentric[1] * sn[s[1]] +
                   hit.barycentric[2] * sn[s[2]];
    c.point_distance[i] = std::sqrt(hit.distance2);
    if (c.point_distance[i] <= tolerance && tn[i].dot(m) <= 0.3) continue;
    c.point_source[i] = hit.triangle;
    c.point_bary[i] = hit.barycentric;
  }
  return c;
}

// ---- the whole derive ------------------------------------------------------------------------

struct Prepared {
  Surface skin, target;
  Similarity sim;
  std::vector<Vec3> aligned, registered;  // The source's skin, before and after registration.
  // Per source triangle: how the registration stretched it (aligned to registered), which a
  // displacement of the source's follows onto the target (a wider eye's lids travel farther).
  std::vector<Eigen::Matrix3d> stretch;
  std::vector<LandmarkPair> pairs;
  double diag = 0;  // The target's head's diagonal: the unit of every distance.
};

Status CheckSize(const Rig& rig, const char* field, const Options& o) {
  if (rig.vertex_count() > o.max_vertices || rig.triangle_count() > o.max_triangles)
    return InvalidField(field,
                        "has " + std::to_string(rig.vertex_count()) + " vertices and " +
                            std::to_string(rig.triangle_count()) +
                            " triangles; a derive takes at most " + std::to_string(o.max_vertices) +
                            " and " + std::to_string(o.max_triangles),
                        StatusCode::kResourceExhausted);
  return Status::Ok();
}

// The source shapes to transfer: the options', or all; those the target has are kept.
Result<std::vector<uint32_t>> ShapesToDerive(const Rig& target, const Rig& source, const Options& o,
                                             Report& report) {
  std::vector<uint32_t> out;
  std::vector<std::string_view> names;
  for (const Shape& sh : source.shapes) names.push_back(sh.name);
  for (size_t i = 0; i < (o.shapes.empty() ? source.shapes.size() : o.shapes.size()); ++i) {
    const int s = o.shapes.empty() ? static_cast<int>(i) : FindShape(source, o.shapes[i]);
    if (s < 0)
      return InvalidField(
          "/shapes/" + std::to_string(i),
          "the source has no shape '" + o.shapes[i] + "'" + DidYouMean(o.shapes[i], names));
    if (source.shapes[s].driven) continue;
    if (FindShape(target, source.shapes[s].name) >= 0) {
      report.kept.push_back(source.shapes[s].name);
      continue;
    }
    out.push_back(static_cast<uint32_t>(s));
  }
  return out;
}

// A face bent onto what is not one: measured 0 onto itself, 0.04% onto ICT's head, 0.1% onto
// MakeHuman's, 11% onto a ball.
constexpr double kMaxDistorted = 0.02;

// The registration's figures, and the refusal of a poor one.
Status Measure(const Prepared& p, const ClosestPoint& closest, double diag, const Options& o,
               Report& r) {
  std::vector<double> d;
  for (const Vec3& q : p.registered) {
    ClosestPoint::Hit hit;
    const double reach = 0.1 * diag;
    d.push_back(closest.Find(q, hit, reach * reach) ? std::sqrt(hit.distance2) / diag : 0.1);
  }
  double sum = 0;
  for (double x : d) sum += x;
  r.mean_residual = d.empty() ? 0 : sum / static_cast<double>(d.size());
  std::sort(d.begin(), d.end());
  r.max_residual = d.empty() ? 0 : d[d.size() * 95 / 100];
  std::vector<RegionFit> lm;
  for (const LandmarkPair& l : p.pairs)
    lm.push_back({l.name, (p.registered[l.source_point] - l.target).norm() / diag});
  std::sort(lm.begin(), lm.end(),
            [](const RegionFit& a, const RegionFit& b) { return a.residual > b.residual; });
  lm.resize(std::min<size_t>(lm.size(), 5));
  r.worst = lm;
  const bool bad_landmark = !lm.empty() && lm[0].residual > 5 * o.max_mean_residual;
  if (r.distorted > kMaxDistorted) {
    char figure[200];
    std::snprintf(figure, sizeof figure,
                  "the target has no face the source's fits: %.1f%% of the face's triangles had to "
                  "be stretched or squeezed over twice to lie on it (at most %.1f%%)",
                  100 * r.distorted, 100 * kMaxDistorted);
    Status s = WithReason(FailedPrecondition(figure), "poor-fit");
    s.AddField("/target", "has no face where the source's was laid (give landmarks to place it)");
    return s;
  }
  if (r.mean_residual <= o.max_mean_residual && !bad_landmark) return Status::Ok();
  char figure[160];
  std::snprintf(figure, sizeof figure,
                "the source's face does not fit the target: %.2f%% of its size apart on average "
                "(at most %.2f%%)",
                100 * r.mean_residual, 100 * o.max_mean_residual);
  Status s = WithReason(FailedPrecondition(figure), "poor-fit");
  for (const RegionFit& f : lm) {
    const auto it = std::find_if(p.pairs.begin(), p.pairs.end(),
                                 [&](const LandmarkPair& l) { return l.name == f.name; });
    if (f.residual > o.max_mean_residual)
      s.AddField("/landmarks/points/" + std::to_string(it->index),
                 "'" + f.name + "' lands " + std::to_string(100 * f.residual) +
                     "% of the size away from it");
  }
  if (s.fields.empty())
    s.AddField("/target", "the registered face stays apart from the target's surface");
  return s;
}

// The source's points off its body (teeth inside its head) moved as one per part with the body
// near them, as the registration moved it; `body` marks the body's points.
void FollowBody(const Surface& s, std::span<const Tri> body, std::span<const uint8_t> on_body,
                std::span<const Vec3> aligned, std::vector<Vec3>& registered) {
  const ClosestPoint near(aligned, body);
  std::vector<std::vector<uint32_t>> members(s.part_size.size());
  for (uint32_t q = 0; q < aligned.size(); ++q) {
    if (!on_body[q]) members[s.part[q]].push_back(q);
  }
  for (const std::vector<uint32_t>& m : members) {
    std::vector<Vec3> from, to;
    for (uint32_t q : m) {
      ClosestPoint::Hit h;
      if (!near.Find(aligned[q], h, std::numeric_limits<double>::infinity())) return;
      const Tri& t = body[h.triangle];
      Vec3 move = Vec3::Zero();
      for (int k = 0; k < 3; ++k) move += h.barycentric[k] * (registered[t[k]] - aligned[t[k]]);
      from.push_back(aligned[q]), to.push_back(aligned[q] + move);
    }
    if (m.empty()) continue;
    const Similarity fit = FitSimilarity(from, to, std::vector<double>(m.size(), 1.0), false);
    for (uint32_t q : m) registered[q] = fit(aligned[q]);
  }
}

// Each triangle's deformation gradient from `from` to `to`, its stretches held within [1/2, 2].
std::vector<Eigen::Matrix3d> Stretches(std::span<const Vec3> from, std::span<const Vec3> to,
                                       std::span<const Tri> tris, double& distorted) {
  std::vector<Eigen::Matrix3d> out(tris.size());
  size_t clamped = 0;
  for (size_t t = 0; t < tris.size(); ++t) {
    const Tri& s = tris[t];
    const Eigen::Matrix3d j =
        DeformationGradient(from[s[0]], from[s[1]], from[s[2]], to[s[0]] - from[s[0]],
                            to[s[1]] - from[s[1]], to[s[2]] - from[s[2]]);
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(j, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Vec3 sigma = svd.singularValues().cwiseMax(0.5).cwiseMin(2.0);
    clamped += !j.allFinite() || sigma != svd.singularValues();
    out[t] = j.allFinite()
                 ? Eigen::Matrix3d(svd.matrixU() * sigma.asDiagonal() * svd.matrixV().transpose())
                 : Eigen::Matrix3d::Identity();
  }
  distorted = static_cast<double>(clamped) / static_cast<double>(std::max<size_t>(tris.size(), 1));
  return out;
}

Result<Prepared> Prepare(const Rig& target, const Rig& source, const Options& o, Report& report) {
  Prepared p;
  std::vector<uint32_t> skin = RegionPrimitives(source, "skin");
  p.skin = BuildSurface(source, skin);
  if (p.skin.triangles.empty())
    return InvalidField("/from", "the source has no face (no triangles in its skin)",
                        StatusCode::kFailedPrecondition);
  p.target = BuildSurface(target);
  if (p.target.triangles.size() < 16)
    return WithReason(InvalidField("/target",
                                   "has no surface to derive onto (" +
                                       std::to_string(p.target.triangles.size()) + " triangles)",
                                   StatusCode::kFailedPrecondition),
                      "no-face");
  const ClosestPoint closest(p.target.points, p.target.triangles);
  // A body's head alone: sizes are the head's, and the face lands there.
  const std::vector<uint8_t> head = HeadPoints(p.target);
  std::vector<Vec3> head_points;
  for (size_t i = 0; i < head.size(); ++i) {
    if (head[i]) head_points.push_back(p.target.points[i]);
  }
  const double diag = p.diag = Diagonal(head_points);
  auto pairs = PairLandmarks(source, p.skin, target, p.target, closest, o.landmarks);
  if (!pairs.ok()) return pairs.status();
  const std::vector<Tri> body = BodyTriangles(p.target, head);
  const ClosestPoint body_closest(p.target.points, body);
  p.pairs = std::move(pairs.value());
  report.landmarks_used = p.pairs.size();
  Progress(o, 0.05, "align");
  if (p.pairs.size() >= 4) {
    std::vector<Vec3> from, to;
    for (const LandmarkPair& l : p.pairs) from.push_back(l.source), to.push_back(l.target);
    const std::vector<double> w(from.size(), 1.0);
    p.sim = RefineSimilarity(FitSimilarity(from, to, w), p.skin.points, body_closest, diag, p.pairs,
                             10);
    report.alignment = Alignment::kLandmarks;
  } else {
    p.sim = AlignByShape(p.skin.points, p.target, head, body_closest);
    report.alignment = Alignment::kShape;
  }
  report.scale = p.sim.scale;
  if (o.stop.stop_requested()) return Cancelled();
  std::vector<Vec3> aligned;
  for (const Vec3& q : p.skin.points) aligned.push_back(p.sim(q));
  std::vector<Vec3> tn;
  for (const Tri& t : body)
    tn.push_back((p.target.points[t[1]] - p.target.points[t[0]])
                     .cross(p.target.points[t[2]] - p.target.points[t[0]])
                     .normalized());
  Landmarks lms;
  for (const LandmarkPair& l : p.pairs) lms.emplace_back(l.source_point, l.target);
  Progress(o, 0.1, "register");
  const std::vector<Tri> source_body = BodyTriangles(p.skin);
  std::vector<uint8_t> on_body(p.skin.points.size(), 0);
  for (const Tri& t : source_body) on_body[t[0]] = on_body[t[1]] = on_body[t[2]] = 1;
  RegisterOptions registration;
  registration.stop = o.stop;
  p.registered = RegisterNonRigid(aligned, p.skin.triangles, body_closest, tn, lms, registration,
                                  diag, on_body);
  if (o.stop.stop_requested()) return Cancelled();
  FollowBody(p.skin, source_body, on_body, aligned, p.registered);
  p.stretch = Stretches(aligned, p.registered, p.skin.triangles, report.distorted);
  p.aligned = std::move(aligned);
  if (o.stop.stop_requested()) return Cancelled();
  if (Status s = Measure(p, body_closest, diag, o, report); !s.ok()) return s;
  return p;
}

// The Poisson system's part of the target: its skin parts' points and triangles, renumbered.
struct SkinSystem {
  std::vector<uint32_t> local;        // Target point -> system point, or UINT32_MAX.
  std::vector<uint32_t> skin_points;  // System point -> target point.
  std::vector<uint32_t> triangle_of;  // System triangle -> target triangle.
  std::vector<Vec3> points;
  std::vector<Tri> triangles;
  std::vector<double> weight;  // The data term's, per point.
  double edge = 0;             // Mean edge length.
};

SkinSystem BuildSkinSystem(const Surface& t, std::span<const PartKind> kind,
                           const Correspondence& c, std::span<const Eye> eyes, double tolerance,
                           double diag) {
  // Lids sweep over the eyes: a sweep is mostly a move, which gradients do not carry; around an
  // eye the source's moves (their ends mapped onto the target's face) are held harder.
  auto by_eye = [&](const Vec3& q) {
    for (const Eye& e : eyes)
      if ((q - e.centre).norm() < kLidReach * e.radius) return true;
    return false;
  };
  SkinSystem s;
  s.local.assign(t.points.size(), UINT32_MAX);
  for (uint32_t q = 0; q < t.points.size(); ++q) {
    if (kind[t.part[q]] != PartKind::kSkin) continue;
    s.local[q] = static_cast<uint32_t>(s.skin_points.size());
    s.skin_points.push_back(q);
    s.points.push_back(t.points[q]);
    // Held to the source's displacement where it corresponds; free near the face (the insides of
    // lips and lids, which follow them); held still far from it.
    const bool data = c.point_source[q] != UINT32_MAX && c.point_distance[q] <= tolerance;
    const bool far = c.point_distance[q] < 0 || c.point_distance[q] > 0.1 * diag;
    s.weight.push_back(data ? (by_eye(t.points[q]) ? kLidWeight : 1.0) : far ? 20.0 : 0.0);
  }
  for (uint32_t i = 0; i < t.triangles.size(); ++i) {
    const Tri& tri = t.triangles[i];
    if (s.local[tri[0]] == UINT32_MAX) continue;
    s.triangles.push_back({s.local[tri[0]], s.local[tri[1]], s.local[tri[2]]});
    s.triangle_of.push_back(i);
    s.edge += (t.points[tri[1]] - t.points[tri[0]]).norm();
  }
  s.edge /= static_cast<double>(std::max<size_t>(s.triangles.size(), 1));
  return s;
}

// Each point of the parts beside the skin: its nearest skin point; and which of those parts lie
// on the skin (attached: points within a twentieth of the part's size of it on average) or apart.
std::vector<ClosestPoint::Hit> AttachParts(const Surface& t, const SkinSystem& sys,
                                           std::span<const std::vector<uint32_t>> members,
                                           std::vector<PartKind>& kind) {
  std::vector<ClosestPoint::Hit> attach(t.points.size());
  const ClosestPoint skin(sys.points, sys.triangles);
  for (size_t part = 0; part < kind.size(); ++part) {
    if (kind[part] != PartKind::kRigid) continue;
    Eigen::AlignedBox3d box;
    double sum = 0;
    for (uint32_t q : members[part]) {
      box.extend(t.points[q]);
      skin.Find(t.points[q], attach[q], std::numeric_limits<double>::infinity());
      sum += std::sqrt(attach[q].distance2);
    }
    if (sum / static_cast<double>(members[part].size()) < 0.05 * box.diagonal().norm())
      kind[part] = PartKind::kAttached;
  }
  return attach;
}

// One shape's displacement of every target point (world space).
struct Transfer {
  const Prepared& p;
  const Correspondence& c;
  const PointField& offsets;  // The registration's moves, aligned source -> target.
  // Per target point with a source point: where that lies (aligned), and the registration's move
  // there; the same for every shape.
  std::span<const Vec3> start, start_offset;
  std::span<const PartKind> kind;
  std::span<const Eye> eyes;
  const PoissonSystem& poisson;
  std::span<const uint32_t>
      local;  // Target point -> its index in the Poisson system, or UINT32_MAX.
  std::span<const uint32_t> skin_points;       // The system's points, target numbering.
  std::span<const Tri> skin_triangles;         // In the system's numbering.
  std::span<const uint32_t> skin_triangle_of;  // System triangle -> target triangle.
  std::span<const ClosestPoint::Hit> attach;   // Per target point: the nearest skin (system) point.
  std::span<const std::vector<uint32_t>> members;  // Per part: its points.
  double tolerance;

  void Run(const Rig& source, std::span<const Eigen::Matrix3d> linear, uint32_t shape,
           std::vector<Vec3>& out) const;
};

void Transfer::Run(const Rig& source, std::span<const Eigen::Matrix3d> linear, uint32_t shape,
                   std::vector<Vec3>& out) const {
  std::vector<Vec3> ds;
  ShapeDisplacement(source, p.skin, linear, shape, ds);
  const Eigen::Matrix3d& rot = p.sim.rotation;
  // The source's gradients, in the target's frame.
  std::vector<Eigen::Matrix3d> sg(p.skin.triangles.size());
  for (size_t t = 0; t < sg.size(); ++t) {
    const Tri& s = p.skin.triangles[t];
    const auto& x = p.skin.points;
    const Eigen::Matrix3d& j = p.stretch[t];
    sg[t] = j * rot * DeformationGradient(x[s[0]], x[s[1]], x[s[2]], ds[s[0]], ds[s[1]], ds[s[2]]) *
            rot.transpose() * j.inverse();
  }
  auto copied = [&](uint32_t point) {
    const Tri& s = p.skin.triangles[c.point_source[point]];
    const Vec3& b = c.point_bary[point];
    const Vec3 move = p.sim.scale * (rot * (b[0] * ds[s[0]] + b[1] * ds[s[1]] + b[2] * ds[s[2]]));
    if (move.squaredNorm() < 1e-10 * p.diag * p.diag) return move;
    const Vec3& here = start_offset[point];
    return Vec3(move + offsets.At(start[point] + move, here) - here);
  };
  std::vector<Eigen::Matrix3d> g(skin_triangles.size(), Eigen::Matrix3d::Identity());
  std::vector<uint8_t> has(skin_triangles.size(), 0);
  for (size_t t = 0; t < skin_triangles.size(); ++t) {
    const uint32_t s = c.triangle_source[skin_triangle_of[t]];
    if (s != UINT32_MAX) g[t] = sg[s], has[t] = 1;
  }
  std::vector<Vec3> data(skin_points.size(), Vec3::Zero()), d;
  for (size_t i = 0; i < skin_points.size(); ++i) {
    const uint32_t q = skin_points[i];
    if (c.point_source[q] != UINT32_MAX && c.point_distance[q] <= tolerance) data[i] = copied(q);
  }
  poisson.Solve(g, has, data, d);
  out.assign(p.target.points.size(), Vec3::Zero());
  for (size_t i = 0; i < skin_points.size(); ++i) out[skin_points[i]] = d[i];
  // Parts: eyes turn, attached ones follow the skin under each point, rigid ones the skin around.
  const auto& pts = p.target.points;
  const std::string& name = source.shapes[shape].name;
  auto under = [&](uint32_t q) {
    const ClosestPoint::Hit& h = attach[q];
    const Tri& t = skin_triangles[h.triangle];
    return Vec3(h.barycentric[0] * d[t[0]] + h.barycentric[1] * d[t[1]] +
                h.barycentric[2] * d[t[2]]);
  };
  for (size_t part = 0; part < kind.size(); ++part) {
    const std::vector<uint32_t>& m = members[part];
    if (kind[part] == PartKind::kEye) {
      for (const Eye& e : eyes) {
        const Eigen::Matrix3d turn = rot * EyeTurn(name, e.left) * rot.transpose();
        if (turn.isIdentity(1e-12)) continue;
        for (uint32_t q : m) {
          if ((pts[q] - e.centre).norm() < 1.5 * e.radius)
            out[q] = turn * (pts[q] - e.centre) + e.centre - pts[q];
        }
      }
    } else if (kind[part] == PartKind::kAttached) {
      for (uint32_t q : m) out[q] = under(q);
    } else if (kind[part] == PartKind::kRigid) {
      std::vector<Vec3> from, to;
      std::vector<double> w;
      // Where the source has the part too (its teeth), its own move (point by point where it has
      // all of it); else the skin's near it.
      size_t owned = 0;
      for (uint32_t q : m)
        owned += c.point_source[q] != UINT32_MAX && c.point_distance[q] <= tolerance;
      if (owned == m.size()) {
        for (uint32_t q : m) out[q] = copied(q);
        continue;
      }
      for (uint32_t q : m) {
        from.push_back(pts[q]);
        const bool own = c.point_source[q] != UINT32_MAX && c.point_distance[q] <= tolerance;
        to.push_back(pts[q] + (own ? copied(q) : under(q)));
        const double r = std::sqrt(attach[q].distance2) / tolerance;
        w.push_back(own ? 1.0 : 1.0 / (1.0 + r * r * r * r));
      }
      const Similarity fit = FitSimilarity(from, to, w, false);
      for (uint32_t q : m) out[q] = fit(pts[q]) - pts[q];
    }
  }
}

// A target's displacement (world, per point) as each primitive's sparse target (mesh space).
std::vector<SparseTarget> ToTargets(const Rig& target, const Surface& s,
                                    std::span<const Eigen::Matrix3d> inverse,
                                    std::span<const Vec3> d, double epsilon) {
  std::vector<SparseTarget> out(target.primitives.size());
  for (size_t p = 0; p < target.primitives.size(); ++p) {
    for (uint32_t v = 0; v < target.primitives[p].vertex_count(); ++v) {
      const uint32_t q = s.vertex_point[s.vertex_start[p] + v];
      if (q == UINT32_MAX || !(d[q].norm() > epsilon)) continue;
      const Vec3 m = inverse[p] * d[q];
      out[p].indices.push_back(v);
      for (int k = 0; k < 3; ++k) out[p].position_deltas.push_back(static_cast<float>(m[k]));
    }
    FinalizeTarget(out[p]);
  }
  return out;
}

}  // namespace

Result<Report> DeriveShapes(Rig& target, const Rig& source, const Options& o) {
  const double cpu0 = CpuSeconds();
  Report report;
  if (Status s = CheckSize(target, "/target", o); !s.ok()) return s;
  if (Status s = CheckSize(source, "/from", o); !s.ok()) return s;
  auto shapes = ShapesToDerive(target, source, o, report);
  if (!shapes.ok()) return shapes.status();
  auto prepared = Prepare(target, source, o, report);
  if (!prepared.ok()) return prepared.status();
  const Prepared& p = prepared.value();
  Progress(o, 0.4, "correspond");
  const double diag = p.diag;
  const double tolerance = 0.015 * diag;
  const ClosestPoint skin(p.registered, p.skin.triangles);
  const Correspondence c =
      Correspond(p.target, p.registered, p.skin.triangles, skin, tolerance, 0.2 * diag);
  std::vector<uint8_t> matched(c.triangle_source.size());
  for (size_t t = 0; t < matched.size(); ++t) matched[t] = c.triangle_source[t] != UINT32_MAX;
  report.matched_triangles = static_cast<size_t>(std::count(matched.begin(), matched.end(), 1));
  const auto eyes = SourceEyes(source, p.sim);
  auto kind = ClassifyParts(p.target, matched, eyes, skin, 0.05 * diag);
  const SkinSystem sys = BuildSkinSystem(p.target, kind, c, eyes, tolerance, diag);

  Progress(o, 0.45, "factorize");
  // The data term's weight against the gradients' (per point, a mean edge squared): measured on
  // ICT's head (tests/derive): 0.05 keeps the surface smoothest but closes the lids a fifth; 1
  // keeps every shape's triangles as unturned as ICT's own and closes them half; 5 closes them
  // three quarters and turns the mouth's corner over.
  constexpr double kKappa = 1.0;
  const PoissonSystem poisson(sys.points, sys.triangles, sys.weight,
                              kKappa / (sys.edge * sys.edge));
  if (!poisson.ok()) return Internal("the target's system could not be factorized");
  std::vector<std::vector<uint32_t>> members(kind.size());
  for (uint32_t q = 0; q < p.target.points.size(); ++q) members[p.target.part[q]].push_back(q);
  const std::vector<ClosestPoint::Hit> attach = AttachParts(p.target, sys, members, kind);
  for (PartKind k : kind) {
    report.parts_eyes += k == PartKind::kEye;
    report.parts_rigid += k == PartKind::kRigid || k == PartKind::kAttached;
    report.parts_still += k == PartKind::kStill;
  }
  // The registration's moves of the source's skin as a field: a displacement carried over ends
  // where the target's face is at its end (a lid meets the target's lower lid, not the source's).
  std::vector<Vec3> moves(p.aligned.size());
  for (size_t i = 0; i < moves.size(); ++i) moves[i] = p.registered[i] - p.aligned[i];
  const PointField offsets(p.aligned, std::move(moves), kOffsetRadius * p.diag);
  std::vector<Vec3> start(p.target.points.size(), Vec3::Zero()), start_offset(start);
  for (size_t q = 0; q < start.size(); ++q) {
    if (c.point_source[q] == UINT32_MAX) continue;
    const Tri& s = p.skin.triangles[c.point_source[q]];
    const Vec3& b = c.point_bary[q];
    start[q] = b[0] * p.aligned[s[0]] + b[1] * p.aligned[s[1]] + b[2] * p.aligned[s[2]];
    start_offset[q] = offsets.At(start[q], Vec3::Zero());
  }
  const Transfer transfer{
      p,      c,       offsets,   start,           start_offset,  kind,
      eyes,   poisson, sys.local, sys.skin_points, sys.triangles, sys.triangle_of,
      attach, members, tolerance};
  const auto linear = LinearParts(source);
  std::vector<Eigen::Matrix3d> inverse;
  for (const Eigen::Matrix3d& m : LinearParts(target)) inverse.push_back(m.inverse());
  std::vector<std::pair<Shape, std::vector<SparseTarget>>> made;
  std::vector<Vec3> d;
  for (size_t i = 0; i < shapes->size(); ++i) {
    if (o.stop.stop_requested()) return Cancelled();
    const uint32_t s = shapes.value()[i];
    transfer.Run(source, linear, s, d);
    Shape shape = source.shapes[s];
    shape.partner = -1;
    shape.material_morphs.clear();
    shape.bone_morphs.clear();
    made.emplace_back(std::move(shape), ToTargets(target, p.target, inverse, d, 1e-6 * diag));
    Progress(o, 0.5 + 0.5 * static_cast<double>(i + 1) / static_cast<double>(shapes->size()),
             "transfer");
  }
  // Nothing can fail from here: the target changes only now.
  for (auto& [shape, targets] : made) {
    report.derived.push_back(shape.name);
    AppendShape(target, std::move(shape), std::move(targets));
  }
  if (o.visemes) BakeVisemes(target, report);
  target.derivation = {source.name,
                       source.credit,
                       report.method,
                       report.alignment == Alignment::kLandmarks ? "landmarks" : "shape",
                       static_cast<uint32_t>(report.landmarks_used),
                       report.mean_residual,
                       report.max_residual,
                       report.derived};
  for (Shape& sh : target.shapes) sh.partner = -1;
  DetectSymmetricPartners(target);
  CountMovedVertices(target);
  std::erase_if(target.expressions, [](const Expression& e) { return e.derived; });
  if (!target.gaze.from_manifest) target.gaze = GazeSetup{};
  DeriveFace(target);
  report.seconds = CpuSeconds() - cpu0;
  return report;
}

Result<Landed> LandOnTarget(const Rig& target, const Rig& source, const Options& o,
                            Report& report) {
  if (Status s = CheckSize(target, "/target", o); !s.ok()) return s;
  if (Status s = CheckSize(source, "/from", o); !s.ok()) return s;
  auto prepared = Prepare(target, source, o, report);
  if (!prepared.ok()) return prepared.status();
  Prepared& p = prepared.value();
  Landed out;
  // On the skin: the largest part, not the eyes or teeth a landmark near them would land on.
  std::vector<Tri> skin;
  for (const Tri& t : p.target.triangles) {
    if (p.target.part[t[0]] == 0) skin.push_back(t);
  }
  const ClosestPoint closest(p.target.points, skin);
  for (uint32_t prim = 0; prim < source.primitives.size(); ++prim) {
    const auto& sv = source.primitives[prim].source_vertices;
    for (uint32_t v = 0; v < source.primitives[prim].vertex_count(); ++v) {
      const uint32_t file = sv.empty() ? v : sv[v];
      const uint32_t point = p.skin.vertex_point[p.skin.vertex_start[prim] + v];
      if (point == UINT32_MAX) continue;
      ClosestPoint::Hit hit;
      if (!closest.Find(p.registered[point], hit, 0.01 * p.diag * p.diag)) continue;
      if (out.spots.size() <= file) out.spots.resize(file + 1);
      out.spots[file] = {true, skin[hit.triangle], hit.barycentric};
    }
  }
  out.surface = std::move(p.target);
  out.diag = p.diag;
  return out;
}

}  // namespace facespace::derive
