// The welded world-space surface of a rig, closest points on it, and similarity alignment.
#include <Eigen/SVD>
#include <algorithm>
#include <cstring>
#include <numeric>
#include <unordered_map>

#include "internal.h"

namespace facespace::derive {

namespace {

struct PositionKey {
  std::array<float, 3> p;
  bool operator==(const PositionKey& o) const { return p == o.p; }
};
struct PositionHash {
  size_t operator()(const PositionKey& k) const {
    uint32_t b[3];
    std::memcpy(b, k.p.data(), sizeof b);
    return (static_cast<size_t>(b[0]) * 73856093u) ^ (static_cast<size_t>(b[1]) * 19349663u) ^
           (static_cast<size_t>(b[2]) * 83492791u);
  }
};

uint32_t Find(std::vector<uint32_t>& parent, uint32_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

// Labels each point with its connected part, the largest part 0.
void LabelParts(Surface& s) {
  std::vector<uint32_t> parent(s.points.size());
  std::iota(parent.begin(), parent.end(), 0u);
  for (const Tri& t : s.triangles) {
    for (int k = 1; k < 3; ++k) parent[Find(parent, t[k])] = Find(parent, t[0]);
  }
  std::unordered_map<uint32_t, uint32_t> count;
  for (uint32_t i = 0; i < parent.size(); ++i) ++count[Find(parent, i)];
  std::vector<std::pair<uint32_t, uint32_t>> roots(count.begin(), count.end());
  std::sort(roots.begin(), roots.end(), [](auto a, auto b) {
    return a.second != b.second ? a.second > b.second : a.first < b.first;
  });
  std::unordered_map<uint32_t, uint32_t> label;
  for (uint32_t i = 0; i < roots.size(); ++i) label[roots[i].first] = i;
  s.part.resize(s.points.size());
  s.part_size.assign(roots.size(), 0);
  for (uint32_t i = 0; i < parent.size(); ++i) {
    s.part[i] = label[Find(parent, i)];
    ++s.part_size[s.part[i]];
  }
}

}  // namespace

Surface BuildSurface(const Rig& rig, std::span<const uint32_t> primitives) {
  Surface s;
  const auto world = PrimitiveWorldMatrices(rig);
  std::unordered_map<PositionKey, uint32_t, PositionHash> weld;
  for (uint32_t p = 0; p < rig.primitives.size(); ++p) {
    const Primitive& prim = rig.primitives[p];
    s.vertex_start.push_back(static_cast<uint32_t>(s.vertex_point.size()));
    const bool wanted =
        primitives.empty() ? prim.mode == PrimitiveMode::kTriangles
                           : std::find(primitives.begin(), primitives.end(), p) != primitives.end();
    const Eigen::Map<const Eigen::Matrix4f> m(world[p].data());
    for (size_t v = 0; v < prim.vertex_count(); ++v) {
      if (!wanted || prim.mode != PrimitiveMode::kTriangles) {
        s.vertex_point.push_back(UINT32_MAX);
        continue;
      }
      const Eigen::Vector4f w =
          m * Eigen::Vector4f(prim.positions[3 * v], prim.positions[3 * v + 1],
                              prim.positions[3 * v + 2], 1.0f);
      const auto [it, added] = weld.try_emplace(PositionKey{{w.x(), w.y(), w.z()}},
                                                static_cast<uint32_t>(s.points.size()));
      if (added) {
        s.points.emplace_back(w.x(), w.y(), w.z());
        s.point_primitive.push_back(p);
      }
      s.vertex_point.push_back(it->second);
    }
    if (!wanted || prim.mode != PrimitiveMode::kTriangles) continue;
    const uint32_t base = s.vertex_start.back();
    for (size_t f = 0; f + 2 < prim.indices.size(); f += 3) {
      const Tri t{s.vertex_point[base + prim.indices[f]],
                  s.vertex_point[base + prim.indices[f + 1]],
                  s.vertex_point[base + prim.indices[f + 2]]};
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
      const Vec3 n = (s.points[t[1]] - s.points[t[0]]).cross(s.points[t[2]] - s.points[t[0]]);
      if (!(n.squaredNorm() > 0)) continue;
      s.triangles.push_back(t);
    }
  }
  LabelParts(s);
  return s;
}

double Diagonal(std::span<const Vec3> points) {
  Eigen::AlignedBox3d box;
  for (const Vec3& p : points) box.extend(p);
  return points.empty() ? 0.0 : box.diagonal().norm();
}

std::vector<Vec3> PointNormals(std::span<const Vec3> points, std::span<const Tri> triangles) {
  std::vector<Vec3> n(points.size(), Vec3::Zero());
  for (const Tri& t : triangles) {
    const Vec3 f = (points[t[1]] - points[t[0]]).cross(points[t[2]] - points[t[0]]);
    for (uint32_t i : t) n[i] += f;
  }
  for (Vec3& v : n) v.normalize();
  return n;
}

// Ericson, Real-Time Collision Detection, 5.1.5.
Vec3 ClosestOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, Vec3& bary) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return bary = {1, 0, 0}, a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return bary = {0, 1, 0}, b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return bary = {1 - v, v, 0}, a + v * ab;
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return bary = {0, 0, 1}, c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return bary = {1 - w, 0, w}, a + w * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return bary = {0, 1 - w, w}, b + w * (c - b);
  }
  const double denom = 1 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return bary = {1 - v - w, v, w}, a + v * ab + w * ac;
}

ClosestPoint::ClosestPoint(std::span<const Vec3> points, std::span<const Tri> triangles)
    : points_(points), triangles_(triangles) {
  order_.resize(triangles.size());
  std::iota(order_.begin(), order_.end(), 0u);
  std::vector<Vec3> centers(triangles.size());
  for (size_t t = 0; t < triangles.size(); ++t) {
    centers[t] = (points[triangles[t][0]] + points[triangles[t][1]] + points[triangles[t][2]]) / 3;
  }
  nodes_.reserve(2 * triangles.size() / 4 + 1);
  if (!triangles.empty()) Build(0, static_cast<uint32_t>(triangles.size()), centers);
}

uint32_t ClosestPoint::Build(uint32_t first, uint32_t count, std::vector<Vec3>& centers) {
  const uint32_t index = static_cast<uint32_t>(nodes_.size());
  nodes_.push_back({});
  Eigen::AlignedBox3d box, center_box;
  for (uint32_t i = first; i < first + count; ++i) {
    for (uint32_t v : triangles_[order_[i]]) box.extend(points_[v]);
    center_box.extend(centers[order_[i]]);
  }
  nodes_[index].box = box;
  if (count <= 4) {
    nodes_[index].first = first;
    nodes_[index].count = count;
    return index;
  }
  int axis = 0;
  center_box.diagonal().maxCoeff(&axis);
  const uint32_t mid = first + count / 2;
  std::nth_element(order_.begin() + first, order_.begin() + mid, order_.begin() + first + count,
                   [&](uint32_t a, uint32_t b) { return centers[a][axis] < centers[b][axis]; });
  const uint32_t left = Build(first, mid - first, centers);
  const uint32_t right = Build(mid, first + count - mid, centers);
  nodes_[index].left = left;
  nodes_[index].right = right;
  return index;
}

bool ClosestPoint::Find(const Vec3& q, Hit& hit, double max_distance2) const {
  if (nodes_.empty()) return false;
  double best = max_distance2;
  bool found = false;
  uint32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    if (n.box.squaredExteriorDistance(q) > best) continue;
    if (n.count > 0) {
      for (uint32_t i = n.first; i < n.first + n.count; ++i) {
        const Tri& t = triangles_[order_[i]];
        Vec3 bary;
        const Vec3 c = ClosestOnTriangle(q, points_[t[0]], points_[t[1]], points_[t[2]], bary);
        const double d2 = (c - q).squaredNorm();
        if (d2 <= best) {
          best = d2;
          found = true;
          hit = {order_[i], c, bary, d2};
        }
      }
      continue;
    }
    // Nearer child last, so it is taken first.
    const double dl = nodes_[n.left].box.squaredExteriorDistance(q);
    const double dr = nodes_[n.right].box.squaredExteriorDistance(q);
    if (top + 2 > 128) continue;  // Depth is log2 of the triangles: never near this.
    if (dl < dr) {
      stack[top++] = n.right;
      stack[top++] = n.left;
    } else {
      stack[top++] = n.left;
      stack[top++] = n.right;
    }
  }
  return found;
}

Similarity FitSimilarity(std::span<const Vec3> from, std::span<const Vec3> to,
                         std::span<const double> weights, bool allow_scale) {
  Similarity s;
  double total = 0;
  Vec3 mf = Vec3::Zero(), mt = Vec3::Zero();
  for (size_t i = 0; i < from.size(); ++i) {
    total += weights[i];
    mf += weights[i] * from[i];
    mt += weights[i] * to[i];
  }
  if (from.size() < 3 || !(total > 0)) return s;
  mf /= total;
  mt /= total;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double var = 0;
  for (size_t i = 0; i < from.size(); ++i) {
    cov += weights[i] * (to[i] - mt) * (from[i] - mf).transpose();
    var += weights[i] * (from[i] - mf).squaredNorm();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) d(2, 2) = -1;
  s.rotation = svd.matrixU() * d * svd.matrixV().transpose();
  s.scale = allow_scale && var > 0 ? (svd.singularValues().asDiagonal() * d).trace() / var : 1.0;
  s.translation = mt - s.scale * (s.rotation * mf);
  return s;
}

}  // namespace facespace::derive
