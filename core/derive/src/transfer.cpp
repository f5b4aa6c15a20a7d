// Deformation transfer in its Poisson form: a source triangle's deformation gradient S (Sumner &
// Popovic 2004: [e1 e2 n] deformed times its inverse at rest) is what the corresponding target
// triangle's displacement gradient should be; the target's displacements d minimise
//   sum_t a_t |grad_t d - (S_t - I)|^2 + mu sum_i m_i w_i |d_i - c_i|^2
// (c_i: the source's displacement at the corresponding point, w_i: 1 where the face matched, large
// far from the face, which holds the rest still, and 0 near it where nothing corresponds: the
// insides of lips and lids follow them). The matrix is the target's cotangent
// Laplacian plus the diagonal: the same for every shape, factorized once.
#include "transfer.h"

#include <Eigen/SparseCholesky>

namespace facespace::derive {

namespace {

// The gradients of the three hat functions of triangle (a, b, c), and its area.
void HatGradients(const Vec3& a, const Vec3& b, const Vec3& c, std::array<Vec3, 3>& g,
                  double& area) {
  const Vec3 n = (b - a).cross(c - a);
  const double twice = n.norm();
  area = 0.5 * twice;
  const Vec3 u = n / twice;
  g[0] = u.cross(c - b) / twice;
  g[1] = u.cross(a - c) / twice;
  g[2] = u.cross(b - a) / twice;
}

// Sumner's frame of a triangle: its two edges and its normal scaled to their length.
Eigen::Matrix3d Frame(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a, n = e1.cross(e2);
  Eigen::Matrix3d f;
  f << e1, e2, n / std::sqrt(n.norm());
  return f;
}

}  // namespace

PoissonSystem::PoissonSystem(std::span<const Vec3> points, std::span<const Tri> triangles,
                             std::span<const double> data_weight, double mu)
    : points_(points), triangles_(triangles), data_weight_(data_weight.begin(), data_weight.end()) {
  const size_t n = points.size();
  gradients_.resize(triangles.size());
  areas_.resize(triangles.size());
  mass_.assign(n, 0.0);
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(9 * triangles.size() + n);
  for (size_t t = 0; t < triangles.size(); ++t) {
    const Tri& tri = triangles[t];
    HatGradients(points[tri[0]], points[tri[1]], points[tri[2]], gradients_[t], areas_[t]);
    for (int i = 0; i < 3; ++i) mass_[tri[i]] += areas_[t] / 3;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j)
        trip.emplace_back(tri[i], tri[j], areas_[t] * gradients_[t][i].dot(gradients_[t][j]));
    }
  }
  mu_ = mu;
  for (size_t i = 0; i < n; ++i) trip.emplace_back(i, i, mu * mass_[i] * data_weight_[i] + 1e-12);
  Eigen::SparseMatrix<double> a(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
  a.setFromTriplets(trip.begin(), trip.end());
  solver_ = std::make_unique<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>>(a);
}

PoissonSystem::~PoissonSystem() = default;

bool PoissonSystem::ok() const { return solver_->info() == Eigen::Success; }

void PoissonSystem::Solve(std::span<const Eigen::Matrix3d> gradient,
                          std::span<const uint8_t> has_gradient, std::span<const Vec3> data,
                          std::vector<Vec3>& out) const {
  const auto n = static_cast<Eigen::Index>(points_.size());
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(n, 3);
  for (size_t t = 0; t < triangles_.size(); ++t) {
    if (!has_gradient[t]) continue;
    const Eigen::Matrix3d g = gradient[t] - Eigen::Matrix3d::Identity();
    for (int i = 0; i < 3; ++i)
      rhs.row(triangles_[t][i]) += areas_[t] * (g * gradients_[t][i]).transpose();
  }
  for (Eigen::Index i = 0; i < n; ++i)
    rhs.row(i) += mu_ * mass_[i] * data_weight_[i] * data[i].transpose();
  const Eigen::MatrixXd d = solver_->solve(rhs);
  out.resize(points_.size());
  for (Eigen::Index i = 0; i < n; ++i) out[i] = d.row(i).transpose();
}

Eigen::Matrix3d DeformationGradient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& da,
                                    const Vec3& db, const Vec3& dc) {
  const Eigen::Matrix3d rest = Frame(a, b, c);
  const Eigen::Matrix3d moved = Frame(a + da, b + db, c + dc);
  return moved * rest.inverse();
}

}  // namespace facespace::derive
