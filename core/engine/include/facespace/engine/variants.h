// Sampling points of the face space: the weight vectors of batch variant generation.
// Every variant is a pure function of (rig, spec, index): its own random stream is seeded
// from the spec's seed and its index, so any subset (a shard, a resumed run) reproduces the
// same weights, on any machine (own generator and normal transform, no std:: distributions).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace {
inline namespace engine {

enum class SampleMethod {
  kUniform,   // Each varied shape uniform in its [min, max].
  kGaussian,  // center + N(0, spread^2) per varied shape, clamped to the shape's range.
  kGrid,      // Evenly spaced: along a line (2 points), over a plane (3 points), or over the
              // ranges of 1-3 varied shapes when no points are given.
  kConvex,    // Random convex combination of the base and the varied shapes at weight 1
              // (flat Dirichlet): never extrapolates.
};

bool ParseSampleMethod(const std::string& name, SampleMethod* method);
const char* SampleMethodName(SampleMethod method);

struct SampleSpec {
  SampleMethod method = SampleMethod::kUniform;
  uint64_t seed = 0;
  size_t count = 0;              // Variants asked for (grid: rounded to steps^dims).
  std::vector<uint32_t> shapes;  // Shapes varied; empty = every shape not fixed.
  std::vector<std::pair<uint32_t, float>> fixed;  // Shapes held at a weight in every variant.
  std::vector<float> center;               // Gaussian mean, one per shape; empty = default weights.
  float spread = 0.1f;                     // Gaussian standard deviation, in weight units.
  std::vector<std::vector<float>> points;  // Grid: 2 or 3 full weight vectors.
  size_t active = 0;                       // Uniform/Gaussian/convex: only this many of the varied
                                           // shapes (picked at random per variant) move; 0 = all.
  bool symmetric = false;                  // A varied shape's symmetric partner takes its weight.
  bool sum_at_most_one = false;  // Scale the varied positive weights so the sum stays <= 1.
};

// Checks the spec against the rig (indices, sizes, finite numbers). Errors name the field.
Status ValidateSampleSpec(const Rig& rig, const SampleSpec& spec);

// How many variants the spec yields (the grid rounds count to a whole number of steps).
size_t SampleCount(const SampleSpec& spec, size_t shape_count);

// Writes variant `index`'s weights (one per shape) into out. The spec must be valid.
void SampleVariant(const Rig& rig, const SampleSpec& spec, size_t index, std::span<float> out);

}  // namespace engine
}  // namespace facespace
