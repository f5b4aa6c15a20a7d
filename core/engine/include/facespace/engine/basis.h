// Keeping the space small: an orthogonal basis of the shapes (PCA by SVD) within an error
// bound, and quantised displacements, each with the error it costs.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace {
inline namespace engine {

// The shapes' position displacements over the vertices any shape moves, as
// D (3 x moved vertices, by shapes) ~= components * coefficients.
struct ShapeBasis {
  std::vector<uint32_t> vertices;  // Global vertex index (primitives in order) of each row triple.
  Eigen::MatrixXf components;      // 3M x k, orthonormal columns.
  Eigen::MatrixXf coefficients;    // k x N: shape j = components * coefficients.col(j).
  std::vector<double> singular_values;  // All of them, descending.
};

struct BasisReport {
  size_t shapes = 0, moved_vertices = 0, components = 0;
  double max_error =
      0;  // Largest vertex distance between a shape (weight 1) and its reconstruction, mesh units.
  double rms_error = 0;  // Over every moved vertex of every shape.
  double diagonal = 0;   // Bounding-box diagonal, mesh units (errors relative to it are unit-free).
  double energy_kept = 0;  // Sum of kept squared singular values / total.
  size_t sparse_bytes =
      0;  // As stored now: per moved vertex of a shape, a uint32 index and 3 floats.
  size_t dense_bytes = 0;  // Every shape over every vertex, 3 floats.
  size_t basis_bytes = 0;  // Components (3M x k floats), coefficients (k x N), vertex indices (M).
};

// The fewest components whose reconstruction keeps every vertex of every shape within
// `max_error` (mesh units). Positions only; normals are recomputed from positions.
Result<ShapeBasis> CompressShapes(const Rig& rig, double max_error, BasisReport* report);

struct QuantizeReport {
  int bits = 16;
  double max_error = 0;  // Largest vertex distance, mesh units.
  size_t bytes = 0;      // uint32 index + 3 x bits per moved vertex, a float scale per target.
};

// Quantises every target's position deltas to signed `bits`-bit integers with one scale per
// target (max |component|) and reports the error; `dequantized` (if not null) receives the
// rig with the quantised deltas, to evaluate the effect.
QuantizeReport QuantizeDisplacements(const Rig& rig, int bits, Rig* dequantized);

}  // namespace engine
}  // namespace facespace
