#include "facespace/engine/basis.h"

#include <cmath>

namespace facespace {
inline namespace engine {

Result<ShapeBasis> CompressShapes(const Rig& rig, double max_error, BasisReport* report) {
  const size_t n = rig.shapes.size();
  if (n == 0) return FailedPrecondition("the rig has no shapes");
  std::vector<size_t> first(rig.primitives.size() + 1, 0);
  for (size_t p = 0; p < rig.primitives.size(); ++p)
    first[p + 1] = first[p] + rig.primitives[p].vertex_count();
  // Rows: the vertices any shape moves.
  std::vector<int32_t> row(first.back(), -1);
  ShapeBasis basis;
  size_t sparse_entries = 0;
  for (const Mesh& m : rig.meshes) {
    for (int pi : m.primitives) {
      for (const SparseTarget& t : rig.primitives[pi].targets) {
        sparse_entries += t.indices.size();
        for (uint32_t v : t.indices) {
          int32_t& r = row[first[pi] + v];
          if (r < 0) {
            r = static_cast<int32_t>(basis.vertices.size());
            basis.vertices.push_back(static_cast<uint32_t>(first[pi] + v));
          }
        }
      }
    }
  }
  const size_t M = basis.vertices.size();
  if (M == 0) return FailedPrecondition("no shape moves any vertex");
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(3 * M, n);
  for (const Mesh& m : rig.meshes) {
    for (int pi : m.primitives) {
      const Primitive& p = rig.primitives[pi];
      for (size_t t = 0; t < p.targets.size() && t < m.target_shapes.size(); ++t) {
        const SparseTarget& st = p.targets[t];
        for (size_t k = 0; k < st.indices.size(); ++k) {
          const size_t r = static_cast<size_t>(row[first[pi] + st.indices[k]]);
          for (int c = 0; c < 3; ++c)
            D(3 * r + c, m.target_shapes[t]) += st.position_deltas[3 * k + c];
        }
      }
    }
  }
  Eigen::BDCSVD<Eigen::MatrixXd> svd(D, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& sigma = svd.singularValues();
  const double total = sigma.squaredNorm();
  // Add components until the residual's largest vertex error is within the bound.
  Eigen::MatrixXd residual = D;
  auto max_vertex_error = [&](double* rms) {
    double worst = 0, sum = 0;
    for (size_t j = 0; j < n; ++j) {
      for (size_t r = 0; r < M; ++r) {
        const double e2 = residual.block<3, 1>(3 * r, j).squaredNorm();
        worst = std::max(worst, e2);
        sum += e2;
      }
    }
    *rms = std::sqrt(sum / static_cast<double>(M * n));
    return std::sqrt(worst);
  };
  size_t k = 0;
  double rms = 0, worst = max_vertex_error(&rms);
  const size_t rank = static_cast<size_t>(sigma.size());
  while (worst > max_error && k < rank && sigma(k) > 0) {
    residual.noalias() -= sigma(k) * svd.matrixU().col(k) * svd.matrixV().col(k).transpose();
    ++k;
    worst = max_vertex_error(&rms);
  }
  basis.components = svd.matrixU().leftCols(k).cast<float>();
  basis.coefficients =
      (sigma.head(k).asDiagonal() * svd.matrixV().leftCols(k).transpose()).cast<float>();
  basis.singular_values.assign(sigma.data(), sigma.data() + sigma.size());
  if (report) {
    report->shapes = n;
    report->moved_vertices = M;
    report->components = k;
    report->max_error = worst;
    report->rms_error = rms;
    report->diagonal = RigDiagonal(rig);
    report->energy_kept = total > 0 ? sigma.head(k).squaredNorm() / total : 1.0;
    report->sparse_bytes = sparse_entries * 16;
    report->dense_bytes = rig.vertex_count() * 12 * n;
    report->basis_bytes = (3 * M * k + k * n) * 4 + M * 4;
  }
  return basis;
}

QuantizeReport QuantizeDisplacements(const Rig& rig, int bits, Rig* dequantized) {
  QuantizeReport r;
  r.bits = bits;
  const double levels = std::ldexp(1.0, bits - 1) - 1.0;
  if (dequantized) *dequantized = rig;
  for (size_t pi = 0; pi < rig.primitives.size(); ++pi) {
    const Primitive& p = rig.primitives[pi];
    for (size_t t = 0; t < p.targets.size(); ++t) {
      const SparseTarget& st = p.targets[t];
      double scale = 0;
      for (float d : st.position_deltas) scale = std::max(scale, static_cast<double>(std::fabs(d)));
      r.bytes += 4 + st.indices.size() * (4 + static_cast<size_t>(3 * bits + 7) / 8);
      if (scale == 0) continue;
      for (size_t k = 0; k < st.indices.size(); ++k) {
        double e2 = 0;
        for (int c = 0; c < 3; ++c) {
          const double d = st.position_deltas[3 * k + c];
          const double q = std::round(d / scale * levels) / levels * scale;
          e2 += (q - d) * (q - d);
          if (dequantized)
            dequantized->primitives[pi].targets[t].position_deltas[3 * k + c] =
                static_cast<float>(q);
        }
        r.max_error = std::max(r.max_error, std::sqrt(e2));
      }
      if (dequantized)
        FinalizeTarget(
            dequantized->primitives[pi].targets[t]);  // Its move lengths are the new deltas'.
    }
  }
  return r;
}

}  // namespace engine
}  // namespace facespace
