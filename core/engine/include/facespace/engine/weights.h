// Weight vectors: resolving names and indices, and the warnings about leaving the
// authored part of shape space.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "facespace/engine/blend.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace {
inline namespace engine {

// One weight as a client gave it: by shape name (or alias) or by index.
struct WeightEntry {
  std::string name;      // Empty when given by index.
  long long index = -1;  // Used when name is empty.
  double value = 0.0;
  std::string pointer;  // Where it came from, for errors: "/weights/jawOpen", "--set", ...
};

// Dense weights in shape order; shapes not named are 0. Errors (nothing computed): unknown
// name (the message lists valid names and suggests the closest), index out of range,
// NaN or infinite value, a shape given twice. All errors are collected in Status::fields.
Result<std::vector<float>> ResolveWeights(const Rig& rig, std::span<const WeightEntry> entries);

// Turns control values into shape weights (two-sided: the negative shape gets -v below 0, the
// positive shape v above). Unknown controls are errors naming their pointer; a value outside
// the control's range warns control_out_of_range.
Status ApplyControls(const Rig& rig, std::span<const WeightEntry> controls,
                     std::vector<WeightEntry>& weights, std::vector<Warning>& warnings);

struct WeightReport {
  double sum = 0.0;  // Rounded to 6 significant digits: float weights' noise is not news.
  std::vector<Warning> warnings;
  double mahalanobis =
      -1.0;  // Distance from the mean in standard deviations; -1 without statistics.
  // When the sum is above 1: LargestVertexSum, the most of full shape moves stacking on one vertex
  // (a left and a right smile sum to 2, but no vertex moves more than one full smile's move;
  // jawOpen and mouthFunnel stack on the lips), and those shapes; else 0 and none.
  double vertex_sum = 0.0;
  std::vector<uint32_t> stacked_shapes;
};

// Per shape, its largest vertex move at weight 1, max_v |d_j(v)| over every primitive: of the
// shapes whose weight in `active` is above 0, or of every shape when `active` is empty; 0 for the
// others.
std::vector<float> LargestMoves(const Rig& rig, std::span<const float> active);

// Over the vertices, the largest sum of w_j |d_j(v)| / max_u |d_j(u)| of the shapes of positive
// weight (each shape's move at the vertex as a share of its largest, times its weight: 1 is one
// full shape), and the shapes moving that vertex (into `shapes`, in rig order); 0 when none moves a
// vertex.
double LargestVertexSum(const Rig& rig, std::span<const float> weights,
                        std::vector<uint32_t>& shapes);

// Mahalanobis distance of a point from the rig's statistical model (Rig::statistics):
// sqrt(sum_k (((w - mean) . c_k) / stddev_k)^2); 0 when the rig has none.
double MahalanobisDistance(const Rig& rig, std::span<const float> weights);

// Warnings (the result is still computed):
//   extrapolation   sum of weights > 1 (value = the sum; the message adds the largest sum on one
//   vertex
//                   and the shapes stacking there, or that none sees more than 1)
//   out_of_range    a weight outside its shape's [min, max] (shape and value)
//   negative_weight a weight < 0 that its range allows (shape and value)
//   absolute_sum    absolute mode and |sum - 1| > 1e-4 (value = the sum)
//   driven_shape    a weight given for an in-between or corrective shape (ignored)
//   implausible     Mahalanobis distance beyond the statistics' bound (value = the distance)
WeightReport CheckWeights(const Rig& rig, std::span<const float> weights, BlendMode mode);

// "1.7" rather than "1.70000005": the shortest text that reads back as the same float.
std::string FormatNumber(double value);

}  // namespace engine
}  // namespace facespace
