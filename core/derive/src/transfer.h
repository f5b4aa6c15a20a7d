// The target's Poisson system for deformation transfer (transfer.cpp says the energy).
#pragma once

#include <Eigen/SparseCholesky>
#include <memory>

#include "internal.h"

namespace facespace::derive {

class PoissonSystem {
 public:
  // `data_weight` per point: how strongly its displacement is held to the data (0: not at all).
  PoissonSystem(std::span<const Vec3> points, std::span<const Tri> triangles,
                std::span<const double> data_weight, double mu);
  ~PoissonSystem();
  bool ok() const;
  // The displacements whose gradients best match `gradient` (per triangle, where has_gradient;
  // the identity elsewhere) and whose values are held to `data` by the data weights.
  void Solve(std::span<const Eigen::Matrix3d> gradient, std::span<const uint8_t> has_gradient,
             std::span<const Vec3> data, std::vector<Vec3>& out) const;
  std::span<const double> mass() const { return mass_; }

 private:
  std::span<const Vec3> points_;
  std::span<const Tri> triangles_;
  std::vector<double> data_weight_, mass_, areas_;
  std::vector<std::array<Vec3, 3>> gradients_;
  double mu_ = 0;
  std::unique_ptr<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>> solver_;
};

// Sumner's deformation gradient of triangle (a, b, c) moved by (da, db, dc).
Eigen::Matrix3d DeformationGradient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& da,
                                    const Vec3& db, const Vec3& dc);

}  // namespace facespace::derive
