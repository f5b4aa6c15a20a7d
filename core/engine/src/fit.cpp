#include "facespace/engine/fit.h"

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <cmath>

#include "facespace/engine/weights.h"

namespace facespace {
inline namespace engine {

namespace {

// Projects w onto {lo <= w <= hi} (and sum w <= 1 when asked), by bisection on the
// multiplier of the sum constraint.
void Project(Eigen::VectorXd& w, const Eigen::VectorXd& lo, const Eigen::VectorXd& hi,
             bool sum_le_one) {
  auto clamp = [&](double shift) {
    Eigen::VectorXd p = w.array() - shift;
    return Eigen::VectorXd(p.cwiseMax(lo).cwiseMin(hi));
  };
  Eigen::VectorXd p = clamp(0.0);
  if (!sum_le_one || p.sum() <= 1.0) {
    w = p;
    return;
  }
  double a = 0.0, b = std::max(1.0, w.cwiseAbs().maxCoeff() + hi.cwiseAbs().maxCoeff() +
                                        lo.cwiseAbs().maxCoeff());
  for (int i = 0; i < 100; ++i) {
    const double m = 0.5 * (a + b);
    (clamp(m).sum() > 1.0 ? a : b) = m;
  }
  w = clamp(b);
}

// The target fits the rig (its primitives and vertices, finite) and the rig can be fitted (no
// skin): its coordinates' count, or the error.
Result<size_t> CheckTarget(const Rig& rig, std::span<const std::vector<float>> target) {
  if (target.size() != rig.primitives.size()) {
    return InvalidArgument("the target has " + std::to_string(target.size()) +
                           " primitives, the rig " + std::to_string(rig.primitives.size()));
  }
  size_t rows = 0;
  for (size_t p = 0; p < target.size(); ++p) {
    if (target[p].size() != rig.primitives[p].positions.size()) {
      return InvalidArgument("primitive " + std::to_string(p) + " of the target has " +
                             std::to_string(target[p].size() / 3) + " vertices, the rig's has " +
                             std::to_string(rig.primitives[p].vertex_count()));
    }
    for (float f : target[p]) {
      if (!std::isfinite(f)) return InvalidArgument("the target has a non-finite coordinate");
    }
    rows += target[p].size();
  }
  for (const Mesh& m : rig.meshes) {
    if (m.skin >= 0)
      return FailedPrecondition("fitting a skinned rig is not supported: give an unskinned rig");
  }
  return rows;
}

// D: every primitive's sparse deltas stacked (3V x S), kept sparse: a face's shapes move a part of
// a body (MakeHuman's 352 over 15,593 vertices: 132 MB dense, D^T D 5.8 G multiply-adds).
Eigen::SparseMatrix<double> StackedDeltas(const Rig& rig, size_t rows) {
  std::vector<Eigen::Triplet<double>> entries;
  size_t row0 = 0;
  for (const Primitive& prim : rig.primitives) {
    const Mesh& mesh = rig.meshes[prim.mesh];
    for (size_t t = 0; t < prim.targets.size(); ++t) {
      const SparseTarget& st = prim.targets[t];
      const auto s = static_cast<Eigen::Index>(mesh.target_shapes[t]);
      for (size_t k = 0; k < st.indices.size(); ++k) {
        for (int c = 0; c < 3; ++c) {
          entries.emplace_back(static_cast<Eigen::Index>(row0 + 3 * st.indices[k] + c), s,
                               st.position_deltas[3 * k + c]);
        }
      }
    }
    row0 += prim.positions.size();
  }
  Eigen::SparseMatrix<double> d(static_cast<Eigen::Index>(rows),
                                static_cast<Eigen::Index>(rig.shapes.size()));
  d.setFromTriplets(entries.begin(), entries.end());  // A vertex a shape moves twice: summed.
  return d;
}

// Per stacked vertex, the scale its primitive's world matrix gives it (the cube root of the
// determinant's size): the residual is told in the scene's units, as the target came, not in mesh
// units (FaceCap's mesh is in units of 1.95 mm).
std::vector<double> VertexWorldScale(const Rig& rig, size_t vertices) {
  const auto world = PrimitiveWorldMatrices(rig);
  std::vector<double> scale;
  scale.reserve(vertices);
  for (size_t p = 0; p < rig.primitives.size() && p < world.size(); ++p) {
    const double det = Eigen::Map<const Eigen::Matrix4f>(world[p].data())
                           .topLeftCorner<3, 3>()
                           .cast<double>()
                           .determinant();
    scale.insert(scale.end(), rig.primitives[p].vertex_count(), std::cbrt(std::fabs(det)));
  }
  scale.resize(vertices, 1.0);
  return scale;
}

}  // namespace

Result<FitResult> FitWeights(const Rig& rig, std::span<const std::vector<float>> target,
                             const FitOptions& options) {
  const Result<size_t> checked = CheckTarget(rig, target);
  if (!checked.ok()) return checked.status();
  const size_t rows = checked.value();
  const size_t S = rig.shapes.size();
  FitResult r;
  // Stack base and target; optional rigid alignment of the target onto the base (Kabsch).
  Eigen::Matrix3Xd base(3, rows / 3), tgt(3, rows / 3);
  size_t col = 0;
  for (size_t p = 0; p < target.size(); ++p) {
    for (size_t v = 0; v < target[p].size(); v += 3, ++col) {
      for (int c = 0; c < 3; ++c) {
        base(c, col) = rig.primitives[p].positions[v + c];
        tgt(c, col) = target[p][v + c];
      }
    }
  }
  const Eigen::SparseMatrix<double> dense = StackedDeltas(rig, rows);
  if (options.stop.stop_requested()) return Cancelled();
  Eigen::MatrixXd dtd = Eigen::MatrixXd(dense.transpose() * dense);
  if (options.stop.stop_requested()) return Cancelled();
  for (size_t s = 0; s < S; ++s) {
    if (dtd(s, s) == 0.0) dtd(s, s) = 1.0;  // Shapes that move nothing get weight 0.
  }
  dtd.diagonal().array() += 1e-12 * std::max(1.0, dtd.diagonal().maxCoeff());
  const auto ldlt = dtd.ldlt();
  Eigen::VectorXd lo(S), hi(S);
  for (size_t s = 0; s < S; ++s) {
    lo(s) = options.bounded ? rig.shapes[s].min : -1e30;
    hi(s) = options.bounded ? rig.shapes[s].max : 1e30;
  }
  const double lipschitz =
      std::max(1e-30, dtd.selfadjointView<Eigen::Lower>().eigenvalues().maxCoeff());
  // min |D w - (target - base)|^2 (projected gradient when constrained).
  auto solve = [&](const Eigen::Matrix3Xd& t) {
    Eigen::VectorXd b(rows);
    for (size_t i = 0; i < rows / 3; ++i)
      b.segment<3>(3 * i) =
          t.col(static_cast<Eigen::Index>(i)) - base.col(static_cast<Eigen::Index>(i));
    const Eigen::VectorXd dtb = dense.transpose() * b;
    Eigen::VectorXd w = ldlt.solve(dtb);
    if (options.bounded || options.sum_at_most_one) {
      Project(w, lo, hi, options.sum_at_most_one);
      for (int it = 0; it < 20000; ++it) {
        if ((it & 255) == 0 && options.stop.stop_requested()) break;  // Told Cancelled below.
        Eigen::VectorXd next = w - (dtd * w - dtb) / lipschitz;
        Project(next, lo, hi, options.sum_at_most_one);
        const double step = (next - w).cwiseAbs().maxCoeff();
        w = next;
        if (step < 1e-10) break;
      }
    }
    return w;
  };
  const Eigen::Matrix3Xd original = tgt;
  Eigen::VectorXd w = solve(tgt);
  if (options.rigid_align && col > 2) {
    // Alternate: align the target onto the current fit (Kabsch), then fit again.
    Eigen::Matrix4d total = Eigen::Matrix4d::Identity();
    for (int round = 0; round < 30 && !options.stop.stop_requested(); ++round) {
      Eigen::Matrix3Xd fitted = base;
      const Eigen::VectorXd dw = dense * w;
      for (size_t i = 0; i < rows / 3; ++i)
        fitted.col(static_cast<Eigen::Index>(i)) += dw.segment<3>(3 * i);
      const Eigen::Vector3d cf = fitted.rowwise().mean(), ct = original.rowwise().mean();
      const Eigen::Matrix3d h = (original.colwise() - ct) * (fitted.colwise() - cf).transpose();
      Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
      d(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
      const Eigen::Matrix3d rot = svd.matrixV() * d * svd.matrixU().transpose();
      const Eigen::Vector3d t = cf - rot * ct;
      tgt = (rot * original).colwise() + t;
      const Eigen::VectorXd next = solve(tgt);
      const double change = (next - w).cwiseAbs().maxCoeff();
      w = next;
      total.setIdentity();
      total.topLeftCorner<3, 3>() = rot;
      total.topRightCorner<3, 1>() = t;
      if (change < 1e-7) break;
    }
    const Eigen::Matrix4f a = total.cast<float>();
    std::copy(a.data(), a.data() + 16, r.alignment.begin());
  }
  if (options.stop.stop_requested()) return Cancelled();
  Eigen::VectorXd b(rows);
  for (size_t i = 0; i < rows / 3; ++i)
    b.segment<3>(3 * i) =
        tgt.col(static_cast<Eigen::Index>(i)) - base.col(static_cast<Eigen::Index>(i));
  // A weight past its range by round-off alone (an exact round trip gives -4.6e-08 for a shape at
  // 0) is put on the bound: no warning for a point that is inside the authored space. The residual
  // below is of these weights.
  constexpr double kRoundOff = 1e-5;
  for (size_t s = 0; s < S; ++s) {
    const double lo_s = rig.shapes[s].min, hi_s = rig.shapes[s].max;
    if (w(s) < lo_s && w(s) > lo_s - kRoundOff) w(s) = lo_s;
    if (w(s) > hi_s && w(s) < hi_s + kRoundOff) w(s) = hi_s;
    if (std::fabs(w(s)) < kRoundOff)
      w(s) = 0.0;  // A weight of round-off alone (1e-7) is none: the answer lists what acts.
  }
  r.weights.resize(S);
  for (size_t s = 0; s < S; ++s) r.weights[s] = static_cast<float>(w(s));
  const Eigen::VectorXd residual = dense * w - b;
  const std::vector<double> scale = VertexWorldScale(rig, rows / 3);
  double sum2 = 0.0;
  for (size_t i = 0; i < rows / 3; ++i) {
    const double d2 = residual.segment<3>(3 * i).squaredNorm() * scale[i] * scale[i];
    sum2 += d2;
    r.max_error = std::max(r.max_error, std::sqrt(d2));
  }
  r.rms_error = rows ? std::sqrt(sum2 / static_cast<double>(rows / 3)) : 0.0;
  r.warnings = CheckWeights(rig, r.weights, BlendMode::kRelative).warnings;
  return r;
}

}  // namespace engine
}  // namespace facespace
