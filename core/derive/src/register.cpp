// Non-rigid ICP (Amberg, Romdhani, Vetter, "Optimal Step Nonrigid ICP Algorithms for Surface
// Registration", CVPR 2007): each source point gets an affine transform X_i (4x3, acting on the row
// [x y z 1]); the energy  alpha^2 sum_edges |G (X_i - X_j)|^2 + sum_i w_i |v_i X_i - u_i|^2
// + beta^2 sum_landmarks |v_l X_l - t_l|^2  is minimised for a falling stiffness alpha, the closest
// target points u_i found again between solves. G = diag(1, 1, 1, gamma) weighs the translation.
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <set>

#include "internal.h"

namespace facespace::derive {

namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

std::vector<std::pair<uint32_t, uint32_t>> Edges(std::span<const Tri> triangles) {
  std::vector<std::pair<uint32_t, uint32_t>> e;
  e.reserve(3 * triangles.size());
  for (const Tri& t : triangles) {
    for (int k = 0; k < 3; ++k)
      e.emplace_back(std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3]));
  }
  std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end()), e.end());
  return e;
}

// Adds weight * v v^T to point i's 4x4 block.
void AddPointBlock(Triplets& t, uint32_t i, const Eigen::Vector4d& v, double weight) {
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) t.emplace_back(4 * i + r, 4 * i + c, weight * v[r] * v[c]);
  }
}

}  // namespace

std::vector<Vec3> RegisterNonRigid(std::span<const Vec3> source,
                                   std::span<const Tri> source_triangles,
                                   const ClosestPoint& target, std::span<const Vec3> target_normals,
                                   std::span<const std::pair<uint32_t, Vec3>> landmarks,
                                   const RegisterOptions& options, double diagonal,
                                   std::span<const uint8_t> fitted) {
  const size_t n = source.size();
  // Normalised frame: the source's centre at 0, the target's diagonal 1.
  Vec3 centre = Vec3::Zero();
  for (const Vec3& p : source) centre += p;
  centre /= static_cast<double>(std::max<size_t>(n, 1));
  const double unit = diagonal > 0 ? diagonal : 1.0;
  std::vector<Eigen::Vector4d> v(n);
  for (size_t i = 0; i < n; ++i) v[i] << (source[i] - centre) / unit, 1.0;
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(4 * static_cast<Eigen::Index>(n), 3);
  for (size_t i = 0; i < n; ++i) x.block<3, 3>(4 * i, 0).setIdentity();
  const auto edges = Edges(source_triangles);
  const double gamma2 = 1.0;
  const double reject2 = options.reject_distance * options.reject_distance;
  std::vector<Vec3> deformed(source.begin(), source.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
  for (double alpha : options.stiffness) {
    for (int it = 0; it < options.iterations && !options.stop.stop_requested(); ++it) {
      const auto normals = PointNormals(deformed, source_triangles);
      Triplets trip;
      trip.reserve(32 * edges.size() + 16 * n);
      Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(x.rows(), 3);
      for (const auto& [i, j] : edges) {
        for (int d = 0; d < 4; ++d) {
          const double g = alpha * alpha * (d == 3 ? gamma2 : 1.0);
          trip.emplace_back(4 * i + d, 4 * i + d, g);
          trip.emplace_back(4 * j + d, 4 * j + d, g);
          trip.emplace_back(4 * i + d, 4 * j + d, -g);
          trip.emplace_back(4 * j + d, 4 * i + d, -g);
        }
      }
      for (size_t i = 0; i < n; ++i) {
        ClosestPoint::Hit hit;
        // A small pull towards where it is keeps points without a partner (and the system) defined.
        constexpr double kHold = 1e-4;
        const Eigen::RowVector3d now = v[i].transpose() * x.block<4, 3>(4 * i, 0);
        AddPointBlock(trip, static_cast<uint32_t>(i), v[i], kHold);
        rhs.block<4, 3>(4 * i, 0) += kHold * v[i] * now;
        if (!fitted.empty() && !fitted[i]) continue;
        if (!target.Find(deformed[i], hit, reject2 * unit * unit)) continue;
        if (normals[i].dot(target_normals[hit.triangle]) < 0.5) continue;
        const Eigen::RowVector3d u = ((hit.point - centre) / unit).transpose();
        AddPointBlock(trip, static_cast<uint32_t>(i), v[i], 1.0);
        rhs.block<4, 3>(4 * i, 0) += v[i] * u;
      }
      const double beta2 = options.landmark_weight * std::max(alpha, 1.0) * std::max(alpha, 1.0);
      for (const auto& [i, t] : landmarks) {
        AddPointBlock(trip, i, v[i], beta2);
        rhs.block<4, 3>(4 * i, 0) += beta2 * v[i] * ((t - centre) / unit).transpose();
      }
      Eigen::SparseMatrix<double> a(x.rows(), x.rows());
      a.setFromTriplets(trip.begin(), trip.end());
      solver.compute(a);
      if (solver.info() != Eigen::Success) return deformed;
      x = solver.solve(rhs);
      for (size_t i = 0; i < n; ++i)
        deformed[i] = centre + unit * (v[i].transpose() * x.block<4, 3>(4 * i, 0)).transpose();
    }
  }
  return deformed;
}

}  // namespace facespace::derive
