#include "facespace/engine/sparse_blend.h"

#include <cmath>

namespace facespace {
inline namespace engine {

namespace {

// 64-bit words of a bit per vertex of `p`.
size_t MovedWords(const Primitive& p) { return (p.vertex_count() + 63) / 64; }

}  // namespace

bool SparseBlend::Serves(const Rig& rig, const BlendOptions& options) {
  if (options.normals != NormalMode::kBlend || options.pose || !rig.inbetweens.empty() ||
      !rig.correctives.empty() || !rig.flips.empty())
    return false;
  for (const Mesh& m : rig.meshes) {
    if (m.skin >= 0) return false;
  }
  return true;
}

SparseBlend::SparseBlend(const Rig& rig, BlendedRig* rest) {
  if (!Serves(rig, {})) return;
  BlendedRig at_rest;
  BlendContext context;
  if (!EvaluateRig(rig, std::vector<float>(rig.shapes.size(), 0.0f), {}, at_rest, context).ok())
    return;
  for (size_t pi = 0; pi < at_rest.primitives.size(); ++pi) {
    const BlendedPrimitive& b = at_rest.primitives[pi];
    const Primitive& p = rig.primitives[pi];
    if (b.positions.size() != p.positions.size() || b.normals.size() != p.normals.size() ||
        p.normals.size() != p.positions.size())
      return;
  }
  primitives_.resize(rig.primitives.size());
  for (const Mesh& mesh : rig.meshes) {
    for (int pi : mesh.primitives) primitives_[pi].shapes = mesh.target_shapes;
  }
  for (size_t pi = 0; pi < rig.primitives.size(); ++pi) {
    const Primitive& p = rig.primitives[pi];
    Targets& t = primitives_[pi];
    if (t.shapes.size() != p.targets.size()) return;
    const size_t words = MovedWords(p);
    t.moved.assign(words * p.targets.size(), 0);
    for (size_t k = 0; k < p.targets.size(); ++k) {
      if (t.shapes[k] >= rig.shapes.size()) return;
      for (uint32_t v : p.targets[k].indices) {
        if (v >= p.vertex_count()) return;
        t.moved[k * words + v / 64] |= uint64_t{1} << (v % 64);
      }
    }
  }
  shapes_ = rig.shapes.size();
  if (rest) *rest = std::move(at_rest);
  ok_ = true;
}

bool SparseBlend::Accepts(const Rig& rig, std::span<const float> weights) const {
  if (!ok_ || weights.size() != shapes_ || rig.shapes.size() != shapes_ ||
      rig.primitives.size() != primitives_.size())
    return false;
  for (float w : weights) {
    if (!std::isfinite(w)) return false;
  }
  return true;
}

SparseBlend::Outcome SparseBlend::Blend(const Rig& rig, std::span<const float> weights, size_t pi,
                                        Scratch& s) const {
  const Targets& t = primitives_[pi];
  const Primitive& p = rig.primitives[pi];
  if (!GatherTargetWeights(weights, t.shapes, s.target_weights)) return Outcome::kRest;
  // Blended as EvaluateRig blends a primitive (positions and normals: no tangents).
  s.positions.resize(p.positions.size());
  s.normals.resize(p.normals.size());
  // The normals' job declines an active target without normal deltas, as the blend does (it
  // recomputes normals there).
  if (!BlendChannel(p.positions, s.target_weights, p.targets, TargetChannel::kPosition, 3,
                    s.positions) ||
      !BlendChannel(p.normals, s.target_weights, p.targets, TargetChannel::kNormal, 3, s.normals))
    return Outcome::kDeclined;
  // The vertices any active target moves: the blend scales their normals to unit length.
  const size_t words = MovedWords(p);
  s.moved.assign(words, 0);
  for (size_t k = 0; k < p.targets.size(); ++k) {
    if (s.target_weights[k] == 0.0f) continue;
    const uint64_t* bits = &t.moved[k * words];
    for (size_t w = 0; w < words; ++w) s.moved[w] |= bits[w];
  }
  return Outcome::kBlended;
}

}  // namespace engine
}  // namespace facespace
