// A smooth field over scattered points (internal.h, PointField): a uniform grid of cells a radius
// wide, and Shepard's inverse-distance weights over the points within the radius of a query.
#include <cmath>

#include "internal.h"

namespace facespace::derive {

namespace {

// A cell's key from its integer coordinates (21 bits each: a million cells a side).
uint64_t CellKey(int64_t x, int64_t y, int64_t z) {
  constexpr int64_t kBias = 1 << 20;
  auto part = [](int64_t v) { return static_cast<uint64_t>((v + kBias) & 0x1FFFFF); };
  return part(x) | part(y) << 21 | part(z) << 42;
}

}  // namespace

PointField::PointField(std::span<const Vec3> points, std::vector<Vec3> values, double radius)
    : points_(points), values_(std::move(values)), radius_(radius > 0 ? radius : 1.0) {
  for (uint32_t i = 0; i < points_.size(); ++i) {
    const Vec3 c = (points_[i] / radius_).array().floor();
    cells_[CellKey(static_cast<int64_t>(c.x()), static_cast<int64_t>(c.y()),
                   static_cast<int64_t>(c.z()))]
        .push_back(i);
  }
}

Vec3 PointField::At(const Vec3& x, const Vec3& otherwise) const {
  const Vec3 c = (x / radius_).array().floor();
  const auto cx = static_cast<int64_t>(c.x()), cy = static_cast<int64_t>(c.y()),
             cz = static_cast<int64_t>(c.z());
  const double r2 = radius_ * radius_, eps = 1e-6 * r2;
  Vec3 sum = Vec3::Zero();
  double weights = 0;
  for (int64_t dx = -1; dx <= 1; ++dx) {
    for (int64_t dy = -1; dy <= 1; ++dy) {
      for (int64_t dz = -1; dz <= 1; ++dz) {
        const auto it = cells_.find(CellKey(cx + dx, cy + dy, cz + dz));
        if (it == cells_.end()) continue;
        for (uint32_t i : it->second) {
          const double d2 = (points_[i] - x).squaredNorm();
          if (d2 >= r2) continue;
          // Falling to 0 at the radius, so the field is continuous as points enter and leave it.
          const double w = (1.0 - d2 / r2) / (d2 + eps);
          sum += w * values_[i];
          weights += w;
        }
      }
    }
  }
  return weights > 0 ? Vec3(sum / weights) : otherwise;
}

}  // namespace facespace::derive
