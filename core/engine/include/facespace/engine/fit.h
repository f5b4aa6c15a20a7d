// Fitting: the weights that best reproduce a target mesh with the rig's topology
// (projection onto the face space), by least squares over the shapes.
#pragma once

#include <span>
#include <stop_token>
#include <vector>

#include "facespace/engine/blend.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace {
inline namespace engine {

struct FitOptions {
  bool bounded = false;          // Keep every weight inside its shape's [min, max].
  bool sum_at_most_one = false;  // And their sum <= 1 (no extrapolation).
  bool rigid_align = false;  // First align the target rigidly (rotation + translation) to the base.
  std::stop_token stop;      // Fired: Cancelled between iterations (the projected gradient's, the
                             // alignment's rounds).
};

struct FitResult {
  std::vector<float> weights;  // One per shape.
  double rms_error =
      0.0;  // Vertex distance between fit and target (scene units), root mean square.
  double max_error = 0.0;  // And largest.
  std::vector<Warning> warnings;
  std::array<float, 16> alignment{1, 0, 0, 0, 0, 1, 0, 0,
                                  0, 0, 1, 0, 0, 0, 0, 1};  // Applied to the target.
};

// `target` holds, per primitive of the rig, xyz positions in the mesh's own space (as the
// JSON export writes them). Unskinned rigs only.
Result<FitResult> FitWeights(const Rig& rig, std::span<const std::vector<float>> target,
                             const FitOptions& options);

}  // namespace engine
}  // namespace facespace
