// The similarity that puts the source's face on the target's: from landmarks, or from the heads'
// own shape, refined by ICP.
#include <algorithm>
#include <map>

#include "internal.h"

namespace facespace::derive {

namespace {

// The rig vertex (primitive, index) of vertex `v` in the file's numbering: primitives in order,
// each counting its source's vertices (an OBJ's `v` lines, which UV seams split into copies).
bool FileVertex(const Rig& rig, long long v, uint32_t& primitive, uint32_t& index) {
  for (uint32_t p = 0; p < rig.primitives.size() && v >= 0; ++p) {
    const Primitive& prim = rig.primitives[p];
    const auto& sv = prim.source_vertices;
    const long long count = sv.empty()
                                ? static_cast<long long>(prim.vertex_count())
                                : (sv.empty() ? 0 : *std::max_element(sv.begin(), sv.end()) + 1LL);
    if (v < count) {
      primitive = p;
      if (sv.empty()) return index = static_cast<uint32_t>(v), true;
      const auto it = std::find(sv.begin(), sv.end(), static_cast<uint32_t>(v));
      if (it == sv.end()) return false;
      index = static_cast<uint32_t>(it - sv.begin());
      return true;
    }
    v -= count;
  }
  return false;
}

std::string Field(size_t i, const char* member) {
  return "/landmarks/points/" + std::to_string(i) + "/" + member;
}

}  // namespace

Result<std::vector<LandmarkPair>> PairLandmarks(const Rig& source, const Surface& skin,
                                                const Rig& target, const Surface& surface,
                                                const ClosestPoint& closest,
                                                std::span<const TargetLandmark> landmarks) {
  std::map<std::string, const Landmark*> by_name;
  for (const Landmark& l : source.landmarks) by_name[l.name] = &l;
  const double diagonal = Diagonal(surface.points);
  const auto world = PrimitiveWorldMatrices(target);
  std::vector<LandmarkPair> out;
  for (size_t i = 0; i < landmarks.size(); ++i) {
    const TargetLandmark& t = landmarks[i];
    const auto it = by_name.find(t.name);
    if (it == by_name.end())
      return InvalidField(Field(i, "name"), "the source has no landmark '" + t.name + "'" +
                                                (source.landmarks.empty() ? " (it has none)" : ""));
    const Landmark& s = *it->second;
    LandmarkPair pair{t.name, i, 0, Vec3::Zero(), Vec3::Zero()};
    float best = -1;
    for (int k = 0; k < 3; ++k) {
      const uint32_t point = skin.vertex_point[skin.vertex_start[s.primitive] + s.vertices[k]];
      if (point == UINT32_MAX) break;
      pair.source += s.weights[k] * skin.points[point];
      if (s.weights[k] > best) best = s.weights[k], pair.source_point = point;
    }
    if (best < 0) continue;  // Not on the source's skin (an eye's landmark): not for the fit.
    Vec3 q;
    if (t.vertex >= 0) {
      uint32_t p = 0, v = 0;
      if (!FileVertex(target, t.vertex, p, v) ||
          surface.vertex_point[surface.vertex_start[p] + v] == UINT32_MAX)
        return InvalidField(Field(i, "vertex"), "is not a vertex of the target's surface");
      q = surface.points[surface.vertex_point[surface.vertex_start[p] + v]];
    } else {
      const Eigen::Map<const Eigen::Matrix4f> m(world.empty() ? nullptr : world[0].data());
      const Vec3 local(t.position[0], t.position[1], t.position[2]);
      q = world.empty() ? local : (m.cast<double>() * local.homogeneous()).head<3>();
    }
    ClosestPoint::Hit hit;
    const double off = 0.02 * diagonal;
    if (!std::isfinite(q.squaredNorm()) || !closest.Find(q, hit, off * off))
      return InvalidField(Field(i, t.vertex >= 0 ? "vertex" : "position"),
                          "is off the target's surface (farther than 2% of its size)");
    pair.target = hit.point;
    out.push_back(std::move(pair));
  }
  return out;
}

Similarity AlignByShape(std::span<const Vec3> source, const Surface& target,
                        std::span<const uint8_t> head, const ClosestPoint& closest) {
  Eigen::AlignedBox3d sbox;
  size_t snose = 0;
  for (size_t i = 0; i < source.size(); ++i) {
    sbox.extend(source[i]);
    if (source[i].z() > source[snose].z()) snose = i;
  }
  // The target's nose: the most forward point of its largest part.
  size_t tnose = 0;
  for (size_t i = 0; i < target.points.size(); ++i) {
    if (target.part[i] == 0 && head[i] &&
        (!head[tnose] || target.points[i].z() > target.points[tnose].z()))
      tnose = i;
  }
  const Vec3 sn = source[snose], tn = target.points[tnose];
  const Vec3 sext = sbox.diagonal();
  // The face's width at the target: its points within the source's depth and height (scaled) of
  // the nose; the scale taken again from what that width is, a few times.
  double scale = 1;
  for (int round = 0; round < 6; ++round) {
    double lo = 0, hi = 0;
    for (size_t i = 0; i < target.points.size(); ++i) {
      if (!head[i]) continue;
      const Vec3 d = target.points[i] - tn;
      if (-d.z() > scale * sext.z() ||
          std::abs(d.y() - scale * (sbox.center().y() - sn.y())) > 0.5 * scale * sext.y())
        continue;
      lo = std::min(lo, d.x());
      hi = std::max(hi, d.x());
    }
    if (hi - lo > 0) scale = (hi - lo) / sext.x();
  }
  Similarity s;
  s.scale = scale;
  s.translation = tn - scale * sn;
  std::vector<Vec3> head_points;
  for (size_t i = 0; i < head.size(); ++i) {
    if (head[i]) head_points.push_back(target.points[i]);
  }
  return RefineSimilarity(s, source, closest, Diagonal(head_points), {}, 30);
}

Similarity RefineSimilarity(Similarity start, std::span<const Vec3> source,
                            const ClosestPoint& closest, double diagonal,
                            std::span<const LandmarkPair> landmarks, int iterations) {
  Similarity s = start;
  std::vector<Vec3> from, to;
  std::vector<double> weights, distances;
  for (int it = 0; it < iterations; ++it) {
    from.clear(), to.clear(), weights.clear(), distances.clear();
    const double reach = 0.1 * diagonal;
    for (const Vec3& p : source) {
      ClosestPoint::Hit hit;
      if (!closest.Find(s(p), hit, reach * reach)) continue;
      from.push_back(p), to.push_back(hit.point), weights.push_back(1.0);
      distances.push_back(hit.distance2);
    }
    if (from.size() < 3) break;
    // Trimmed: the closest 80% alone, a face's rim hanging over the target's sides left out.
    std::vector<double> sorted = distances;
    const size_t cut = sorted.size() * 8 / 10;
    std::nth_element(sorted.begin(), sorted.begin() + cut, sorted.end());
    for (size_t i = 0; i < weights.size(); ++i)
      weights[i] = distances[i] <= sorted[cut] ? 1.0 : 0.0;
    const double lw =
        landmarks.empty() ? 0 : static_cast<double>(from.size()) / (4.0 * landmarks.size());
    for (const LandmarkPair& l : landmarks)
      from.push_back(l.source), to.push_back(l.target), weights.push_back(lw);
    s = FitSimilarity(from, to, weights, true);
  }
  return s;
}

}  // namespace facespace::derive
