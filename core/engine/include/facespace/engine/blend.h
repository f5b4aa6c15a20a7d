// Blending: base + sum_j w_j * d_j over sparse targets, and the whole-rig evaluation that
// also keeps normals and tangents fresh.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace {
inline namespace engine {

// Which attribute of a SparseTarget a BlendShapeJob reads.
enum class TargetChannel { kPosition, kNormal, kTangent };

// A mesh's target weights from the rig's shape weights (target t is shape shapes[t]) into `out`,
// resized; true when any is non-zero. EvaluateRig's and SparseBlend's gather.
inline bool GatherTargetWeights(std::span<const float> weights, std::span<const uint32_t> shapes,
                                std::vector<float>& out) {
  out.resize(shapes.size());
  bool active = false;
  for (size_t t = 0; t < shapes.size(); ++t) {
    out[t] = weights[shapes[t]];
    active |= out[t] != 0.0f;
  }
  return active;
}

// Writes base + sum_t weights[t] * target[t].delta into out (xyz per vertex).
// Owns no buffer, never allocates. Targets with weight exactly 0 cost nothing.
struct BlendShapeJob {
  bool Validate() const;  // False if a span is too short, weights.size() != targets.size(),
                          // a target lacks the channel while its weight is non-zero, or a
                          // target index is beyond the vertex count.
  bool Run() const;       // Calls Validate(); on false, out is left untouched.

  std::span<const float> base;            // 3 floats per vertex.
  std::span<const float> weights;         // One per target. Any finite value; not clamped.
  std::span<const SparseTarget> targets;  // Finalized (runs built).
  TargetChannel channel = TargetChannel::kPosition;
  size_t stride = 3;     // Floats between vertices in base and out (3 or 4).
  std::span<float> out;  // Same size as base. May alias base.
};

// A BlendShapeJob of these members, run: false, `out` untouched, when the targets do not fit.
bool BlendChannel(std::span<const float> base, std::span<const float> weights,
                  std::span<const SparseTarget> targets, TargetChannel channel, size_t stride,
                  std::span<float> out);

enum class BlendMode {
  kRelative,  // p = base + sum w_j (S_j - base): the glTF convention.
  kAbsolute,  // p = (1 - sum w) base + sum w_j S_j: weights are barycentric and should sum to 1.
};

enum class NormalMode {
  kBlend,      // Blend the shapes' normal deltas and renormalise. A primitive where an active
               // target has no normal deltas is recomputed instead: never stale.
  kRecompute,  // Recompute from the blended positions over the faces the active shapes touch.
};

struct Pose;

struct BlendOptions {
  BlendMode mode = BlendMode::kRelative;
  NormalMode normals = NormalMode::kBlend;
  const Pose* pose = nullptr;  // Skeleton pose (skeleton.h); nullptr: the rest pose.
  bool dual_quaternion =
      false;  // Dual-quaternion skinning (keeps volume on twists) instead of linear.
};

struct BlendedPrimitive {
  std::vector<float> positions;  // xyz per vertex: mesh space, or scene space when skinned.
  std::vector<float> normals;    // xyz per vertex, unit length.
  std::vector<float> tangents;   // xyzw per vertex, or empty when the rig has none.
  std::vector<float> texcoords;  // uv per vertex when a shape moving UVs has a weight; else empty,
                                 // and the primitive's own hold (TexcoordsOf).
  bool skinned = false;  // Positions are in scene space (glTF ignores the node's transform).
  std::vector<float> morphed_positions;  // Skinned only: the positions after morphing, before
                                         // skinning (mesh space), for displacement views.
  std::array<float, 16> world{
      1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // Places the
                                                        // positions in the scene (identity when
                                                        // skinned), under the pose.
};

struct BlendedRig {
  std::vector<BlendedPrimitive> primitives;       // Same order as Rig::primitives.
  std::vector<std::array<float, 16>> node_world;  // World matrix of every node under the pose.
  bool posed = false;                             // A pose other than the rest pose was given.
  // Per material, its base colour (RGBA) under the shapes' material morphs; empty when no shape
  // with material morphs has a weight (the materials' own colours hold).
  std::vector<std::array<float, 4>> material_colors;
};

// The first UV set of `primitive` as blended: `blended`'s when a shape moved it, else its own.
inline std::span<const float> TexcoordsOf(const Primitive& primitive,
                                          const BlendedPrimitive& blended) {
  return blended.texcoords.empty() ? std::span<const float>(primitive.texcoords)
                                   : std::span<const float>(blended.texcoords);
}

// A material's alpha as drawn: its morphed colour's where material morphs act
// (BlendedRig::material_colors), else its own; 1 for no material (-1). Triangles of alpha 0 are
// not drawn into the label planes and hide nothing (MMD's overlays until a morph shows them).
inline float DrawnAlpha(const Rig& rig, const BlendedRig& blended, int material) {
  if (material < 0) return 1.0f;
  const size_t m = static_cast<size_t>(material);
  return m < blended.material_colors.size() ? blended.material_colors[m][3]
                                            : rig.materials[m].base_color_factor[3];
}

// base + sum_t weights[t] * target[t]'s UV deltas (2 floats per vertex) into `out`; `out` is left
// empty when no target of non-zero weight moves a UV (or `base` is empty). Indices must have been
// checked against the vertex count (ValidateRig).
void BlendTexcoords(std::span<const float> base, std::span<const float> weights,
                    std::span<const SparseTarget> targets, std::vector<float>& out);

// The materials' base colours under the material morphs of `weights` (MMD: diffuse times the
// texture tint; exact for untextured materials, the tint's add approximated as a factor on a
// texture), into `out` (one per material); `out` is left empty when no shape with material morphs
// has a weight.
void MorphedMaterialColors(const Rig& rig, std::span<const float> weights,
                           std::vector<std::array<float, 4>>& out);

// Per-evaluation scratch, owned by the caller and reused between calls so that steady-state
// evaluation does not allocate (as ozz's jobs take their context): once its vectors have grown
// to a rig's sizes, EvaluateRig allocates nothing.
struct BlendContext {
  std::vector<int> node_order;                // World matrices: nodes, parents before children.
  std::vector<int> mesh_node;                 // Per mesh: the first node that shows it.
  std::vector<float> target_weights;          // Per target of the current mesh.
  std::vector<uint8_t> vertex_mark;           // Per vertex of the largest primitive.
  std::vector<uint32_t> moved;                // Vertices moved by the active targets.
  std::vector<float> joint_matrices;          // Skinning: 16 floats per joint of the current skin.
  std::vector<float> joint_dual_quaternions;  // Skinning: 8 floats per joint, when asked.
  BlendedPrimitive unskinned;                 // Skinning: the morphed primitive before skinning.
  std::vector<uint32_t> affected;             // Vertices whose normals are recomputed.
  std::vector<float> effective;               // Shape weights after in-betweens and correctives.
};

// The weights the shapes are blended with: the given (slider) weights, with in-between
// sliders spread over their keys, driven shapes computed (Rig::inbetweens, correctives) and flip
// morphs' picks added (Rig::flips).
// `out` has one per shape. Without drivers, a copy.
void EffectiveWeights(const Rig& rig, std::span<const float> weights, std::span<float> out);

// Evaluates the rig at `weights` (one per shape, Rig::shapes order; in-betweens and
// correctives applied by EffectiveWeights). The weights must have
// been checked (finite, right count): returns InvalidArgument otherwise and writes nothing.
// In absolute mode the point is (1 - sum w) base + sum w_j S_j, which is the same vector
// as the relative formula; only the warnings differ (see CheckWeights).
Status EvaluateRig(const Rig& rig, std::span<const float> weights, const BlendOptions& options,
                   BlendedRig& out, BlendContext& context);

// Area-weighted normal of vertex v (unnormalised): the sum of the cross products of the faces
// around it in `primitive`'s adjacency, over `positions`.
void VertexNormalSum(const Primitive& primitive, std::span<const float> positions, uint32_t v,
                     float* n);

// Recomputes normals of the vertices around `moved` (vertex indices) from `positions`:
// n = normalize(n_base + N(positions) - N(base positions)) where N is the area-weighted
// smooth normal, so unmoved regions keep their authored normals exactly.
void RecomputeNormalsAround(const Primitive& primitive, std::span<const float> positions,
                            std::span<const uint32_t> moved, std::span<float> out_normals,
                            BlendContext& context);

// Smooth area-weighted vertex normals of a triangle list (unit length; +Z for isolated
// vertices). out has 3 floats per vertex.
void ComputeSmoothNormals(std::span<const float> positions, std::span<const uint32_t> triangles,
                          std::span<float> out);

}  // namespace engine
}  // namespace facespace
