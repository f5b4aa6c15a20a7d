// The blend of only what a point moves: per primitive, the rest when none of the point's active
// shapes touches it, else its positions and normals blended exactly as EvaluateRig blends them
// (the same BlendShapeJob, so the same bits), with a bit per vertex that an active target moves.
// For writers that keep the rest's bytes and write over them only what moved (formats' F32Writer:
// on FaceCap a point moves one primitive of four, the head, not the eyes and teeth).
//
// It serves rigs without skins, in-betweens, correctives or flips, unposed, with blended normals
// (a shape's UV deltas do not matter: it blends positions and normals alone)
// (Serves). Immutable after construction: threads share one, each with its own scratch.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "facespace/engine/blend.h"
#include "facespace/engine/rig.h"

namespace facespace {
inline namespace engine {

class SparseBlend {
 public:
  struct Scratch {
    std::vector<float> target_weights, positions, normals;
    std::vector<uint64_t> moved;  // A bit per vertex (64 to a word): moved by an active target.
  };
  static bool Serves(const Rig& rig, const BlendOptions& options);

  // Checks `rig` once for every point (each target's shape and vertices). `rest`, when given,
  // receives the rig evaluated at rest (zero weights), for a writer that keeps its bytes.
  explicit SparseBlend(const Rig& rig, BlendedRig* rest = nullptr);
  bool ok() const { return ok_; }  // False: the rig is not served, and no point is.

  // Whether a point can be blended this way: weights one per shape of the rig this was made from,
  // finite.
  bool Accepts(const Rig& rig, std::span<const float> weights) const;

  enum class Outcome {
    kRest,      // No active shape moves the primitive: its rest stands.
    kBlended,   // scratch.positions, .normals and .moved hold it.
    kDeclined,  // An active target without normal deltas: EvaluateRig recomputes normals there.
  };
  // Primitive `primitive` at `weights` (Accepts), as EvaluateRig blends it.
  Outcome Blend(const Rig& rig, std::span<const float> weights, size_t primitive,
                Scratch& scratch) const;

 private:
  struct Targets {
    std::vector<uint32_t> shapes;  // The rig shape of each of the primitive's targets.
    std::vector<uint64_t> moved;   // Per target, a bit per vertex it moves (64 to a word).
  };
  bool ok_ = false;
  size_t shapes_ = 0;
  std::vector<Targets> primitives_;
};

}  // namespace engine
}  // namespace facespace
