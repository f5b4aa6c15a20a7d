#include "facespace/engine/blend.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "facespace/engine/normal_matrix.h"
#include "facespace/engine/skeleton.h"

namespace facespace {
inline namespace engine {

namespace {

const std::vector<float>& Deltas(const SparseTarget& t, TargetChannel c) {
  switch (c) {
    case TargetChannel::kNormal: return t.normal_deltas;
    case TargetChannel::kTangent: return t.tangent_deltas;
    case TargetChannel::kPosition: break;
  }
  return t.position_deltas;
}

// The vertices the targets of non-zero weight move, each once, in the order first met, into
// `moved`; `mark` is scratch of zeros, grown to `vertex_count` and left all zero. Indices must be
// below vertex_count (a BlendShapeJob that ran over the same targets checked them).
void MovedVertices(std::span<const SparseTarget> targets, std::span<const float> weights,
                   size_t vertex_count, std::vector<uint8_t>& mark, std::vector<uint32_t>& moved) {
  if (mark.size() < vertex_count) mark.resize(vertex_count, 0);
  moved.clear();
  for (size_t t = 0; t < targets.size() && t < weights.size(); ++t) {
    if (weights[t] == 0.0f) continue;
    for (uint32_t v : targets[t].indices) {
      if (!mark[v]) {
        mark[v] = 1;
        moved.push_back(v);
      }
    }
  }
  for (uint32_t v : moved) mark[v] = 0;
}

}  // namespace

bool BlendShapeJob::Validate() const {
  if (stride < 3 || base.size() != out.size() || base.size() % stride != 0) return false;
  if (weights.size() != targets.size()) return false;
  const size_t n = base.size() / stride;
  for (size_t t = 0; t < targets.size(); ++t) {
    if (weights[t] == 0.0f) continue;
    const SparseTarget& st = targets[t];
    if (Deltas(st, channel).size() != 3 * st.indices.size()) return false;
    if (st.runs.empty()) {
      // Indices are ascending (SparseTarget's contract): the last one bounds them all.
      if (!st.indices.empty() && st.indices.back() >= n) return false;
      continue;
    }
    if (st.runs.size() % 2 != 0) return false;
    size_t covered = 0;
    for (size_t r = 0; r < st.runs.size(); r += 2) {
      if (static_cast<size_t>(st.runs[r]) + st.runs[r + 1] > n) return false;
      covered += st.runs[r + 1];
    }
    if (covered != st.indices.size()) return false;
  }
  return true;
}

bool BlendShapeJob::Run() const {
  if (!Validate()) return false;
  if (out.data() != base.data()) std::memcpy(out.data(), base.data(), base.size() * sizeof(float));
  for (size_t t = 0; t < targets.size(); ++t) {
    const float w = weights[t];
    if (w == 0.0f) continue;
    const SparseTarget& st = targets[t];
    const float* d = Deltas(st, channel).data();
    const uint32_t* run = st.runs.data();
    const uint32_t* const run_end = run + st.runs.size();
    if (st.runs.empty()) {
      // Scattered target: one vertex at a time.
      for (uint32_t v : st.indices) {
        float* o = out.data() + stride * static_cast<size_t>(v);
        o[0] += w * d[0];
        o[1] += w * d[1];
        o[2] += w * d[2];
        d += 3;
      }
    } else if (stride == 3) {
      // A run of consecutive vertices is one contiguous xyz stream: a plain axpy.
      for (; run != run_end; run += 2) {
        float* o = out.data() + 3 * static_cast<size_t>(run[0]);
        const size_t m = 3 * static_cast<size_t>(run[1]);
        for (size_t k = 0; k < m; ++k) o[k] += w * d[k];
        d += m;
      }
    } else {
      for (; run != run_end; run += 2) {
        float* o = out.data() + stride * static_cast<size_t>(run[0]);
        for (uint32_t k = 0; k < run[1]; ++k, o += stride, d += 3) {
          o[0] += w * d[0];
          o[1] += w * d[1];
          o[2] += w * d[2];
        }
      }
    }
  }
  return true;
}

void ComputeSmoothNormals(std::span<const float> positions, std::span<const uint32_t> triangles,
                          std::span<float> out) {
  std::fill(out.begin(), out.end(), 0.0f);
  const size_t n = positions.size() / 3;
  for (size_t f = 0; f + 2 < triangles.size(); f += 3) {
    const uint32_t a = triangles[f], b = triangles[f + 1], c = triangles[f + 2];
    if (a >= n || b >= n || c >= n) continue;
    const float* pa = &positions[3 * a];
    const float* pb = &positions[3 * b];
    const float* pc = &positions[3 * c];
    const float e1[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]};
    const float e2[3] = {pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]};
    const float nx = e1[1] * e2[2] - e1[2] * e2[1];
    const float ny = e1[2] * e2[0] - e1[0] * e2[2];
    const float nz = e1[0] * e2[1] - e1[1] * e2[0];
    for (uint32_t v : {a, b, c}) {
      out[3 * v] += nx;
      out[3 * v + 1] += ny;
      out[3 * v + 2] += nz;
    }
  }
  for (size_t v = 0; v < n; ++v) {
    float* o = &out[3 * v];
    const float len2 = o[0] * o[0] + o[1] * o[1] + o[2] * o[2];
    if (len2 > 0.0f && std::isfinite(len2)) {
      Normalize3(o);
    } else {
      o[0] = 0.0f;
      o[1] = 0.0f;
      o[2] = 1.0f;
    }
  }
}

void VertexNormalSum(const Primitive& p, std::span<const float> pos, uint32_t v, float* n) {
  n[0] = n[1] = n[2] = 0.0f;
  for (uint32_t k = p.vertex_face_offsets[v]; k < p.vertex_face_offsets[v + 1]; ++k) {
    const uint32_t* f = &p.indices[3 * static_cast<size_t>(p.vertex_faces[k])];
    const float* pa = &pos[3 * static_cast<size_t>(f[0])];
    const float* pb = &pos[3 * static_cast<size_t>(f[1])];
    const float* pc = &pos[3 * static_cast<size_t>(f[2])];
    const float e1[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]};
    const float e2[3] = {pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]};
    n[0] += e1[1] * e2[2] - e1[2] * e2[1];
    n[1] += e1[2] * e2[0] - e1[0] * e2[2];
    n[2] += e1[0] * e2[1] - e1[1] * e2[0];
  }
}

void RecomputeNormalsAround(const Primitive& p, std::span<const float> positions,
                            std::span<const uint32_t> moved, std::span<float> out_normals,
                            BlendContext& ctx) {
  if (p.mode != PrimitiveMode::kTriangles) return;
  const size_t n = p.vertex_count();
  if (ctx.vertex_mark.size() < n) ctx.vertex_mark.resize(n, 0);
  ctx.affected.clear();
  // Every vertex of every face touching a moved vertex may change its normal.
  for (uint32_t v : moved) {
    for (uint32_t k = p.vertex_face_offsets[v]; k < p.vertex_face_offsets[v + 1]; ++k) {
      const uint32_t* f = &p.indices[3 * static_cast<size_t>(p.vertex_faces[k])];
      for (int c = 0; c < 3; ++c) {
        if (!ctx.vertex_mark[f[c]]) {
          ctx.vertex_mark[f[c]] = 1;
          ctx.affected.push_back(f[c]);
        }
      }
    }
  }
  for (uint32_t v : ctx.affected) {
    ctx.vertex_mark[v] = 0;
    float sum[3];
    VertexNormalSum(p, positions, v, sum);
    float* o = &out_normals[3 * static_cast<size_t>(v)];
    const float len = std::sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]);
    if (!(len > 1e-30f) || !std::isfinite(len)) continue;  // Degenerate now: keep what is there.
    const float* nb = &p.normals[3 * static_cast<size_t>(v)];
    const float* sb = &p.base_smooth_normals[3 * static_cast<size_t>(v)];
    for (int c = 0; c < 3; ++c) o[c] = nb[c] + sum[c] / len - sb[c];
    Normalize3(o);
  }
}

namespace {

bool HasChannel(const SparseTarget& t, TargetChannel c) {
  return t.indices.empty() || Deltas(t, c).size() == 3 * t.indices.size();
}

}  // namespace

bool BlendChannel(std::span<const float> base, std::span<const float> weights,
                  std::span<const SparseTarget> targets, TargetChannel channel, size_t stride,
                  std::span<float> out) {
  const BlendShapeJob job{.base = base,
                          .weights = weights,
                          .targets = targets,
                          .channel = channel,
                          .stride = stride,
                          .out = out};
  return job.Run();
}

namespace {

// Morphs one primitive into `bp`: positions, then fresh normals and tangents.
bool MorphPrimitive(const Primitive& p, std::span<const float> tw, bool any_active,
                    const BlendOptions& options, BlendedPrimitive& bp, BlendContext& ctx) {
  bp.positions.resize(p.positions.size());
  bp.normals.resize(p.normals.size());
  bp.tangents.resize(p.tangents.size());
  if (!BlendChannel(p.positions, tw, p.targets, TargetChannel::kPosition, 3, bp.positions))
    return false;
  BlendTexcoords(p.texcoords, tw, p.targets, bp.texcoords);
  if (!any_active) {
    std::copy(p.normals.begin(), p.normals.end(), bp.normals.begin());
    std::copy(p.tangents.begin(), p.tangents.end(), bp.tangents.begin());
    return true;
  }

  bool can_blend_normals = options.normals == NormalMode::kBlend;
  bool can_blend_tangents = !p.tangents.empty();
  for (size_t t = 0; t < p.targets.size(); ++t) {
    if (tw[t] == 0.0f) continue;
    can_blend_normals &= HasChannel(p.targets[t], TargetChannel::kNormal);
    can_blend_tangents &= HasChannel(p.targets[t], TargetChannel::kTangent);
  }
  MovedVertices(p.targets, tw, p.vertex_count(), ctx.vertex_mark, ctx.moved);

  // A blend job starts from a copy of its base: the base is copied here only where no job runs.
  std::span<const uint32_t> changed = ctx.moved;  // Vertices whose normal may differ.
  if (can_blend_normals) {
    if (!BlendChannel(p.normals, tw, p.targets, TargetChannel::kNormal, 3, bp.normals))
      std::copy(p.normals.begin(), p.normals.end(), bp.normals.begin());
    for (uint32_t v : ctx.moved) Normalize3(&bp.normals[3 * static_cast<size_t>(v)]);
  } else {
    std::copy(p.normals.begin(), p.normals.end(), bp.normals.begin());
    RecomputeNormalsAround(p, bp.positions, ctx.moved, bp.normals, ctx);
    changed = ctx.affected;
  }
  if (p.tangents.empty()) return true;
  if (can_blend_tangents) {
    if (!BlendChannel(p.tangents, tw, p.targets, TargetChannel::kTangent, 4, bp.tangents))
      std::copy(p.tangents.begin(), p.tangents.end(), bp.tangents.begin());
  } else {
    std::copy(p.tangents.begin(), p.tangents.end(), bp.tangents.begin());
  }
  // Keep the tangents of changed vertices orthogonal to their normals (Gram-Schmidt);
  // w (handedness) is kept.
  for (uint32_t v : changed) {
    float* t4 = &bp.tangents[4 * static_cast<size_t>(v)];
    const float* nn = &bp.normals[3 * static_cast<size_t>(v)];
    const float dot = t4[0] * nn[0] + t4[1] * nn[1] + t4[2] * nn[2];
    t4[0] -= dot * nn[0];
    t4[1] -= dot * nn[1];
    t4[2] -= dot * nn[2];
    if (t4[0] * t4[0] + t4[1] * t4[1] + t4[2] * t4[2] < 1e-12f) {
      // The deltas cancelled the tangent: any unit vector orthogonal to the normal.
      const float ax = std::fabs(nn[0]) < 0.9f ? 1.0f : 0.0f;
      const float ay = 1.0f - ax;
      t4[0] = ay * nn[2];
      t4[1] = -ax * nn[2];
      t4[2] = ax * nn[1] - ay * nn[0];
    }
    Normalize3(t4);
  }
  return true;
}

}  // namespace

void EffectiveWeights(const Rig& rig, std::span<const float> weights, std::span<float> out) {
  std::copy(weights.begin(), weights.end(), out.begin());
  for (size_t s = 0; s < rig.shapes.size(); ++s) {
    if (rig.shapes[s].driven) out[s] = 0.0f;
  }
  for (const InBetweens& ib : rig.inbetweens) {
    const float v = weights[ib.slider];
    out[ib.slider] = 0.0f;
    // Walk the points in weight order, merging the keys with the base (at 0, shape -1) and the
    // slider (at full), until the segment [p0, p1] holds v or is the last one.
    std::pair<float, int> extra[2] = {{0.0f, -1}, {ib.full, static_cast<int>(ib.slider)}};
    if (extra[1].first < extra[0].first) std::swap(extra[0], extra[1]);
    size_t k = 0, e = 0;
    auto next = [&]() -> std::pair<float, int> {
      if (e < 2 && (k >= ib.keys.size() || extra[e].first <= ib.keys[k].first)) return extra[e++];
      const auto& key = ib.keys[k++];
      return {key.first, static_cast<int>(key.second)};
    };
    const size_t points = ib.keys.size() + 2;
    std::pair<float, int> p0 = next(), p1 = next();
    for (size_t taken = 2; taken < points && v > p1.first; ++taken) {
      p0 = p1;
      p1 = next();
    }
    const float t = (v - p0.first) / (p1.first - p0.first);
    if (p0.second >= 0) out[p0.second] += 1.0f - t;
    if (p1.second >= 0) out[p1.second] += t;
  }
  for (const Corrective& c : rig.correctives) {
    float w = c.use_min ? std::numeric_limits<float>::infinity() : 1.0f;
    for (uint32_t d : c.drivers) w = c.use_min ? std::min(w, weights[d]) : w * weights[d];
    out[c.shape] = c.drivers.empty() ? 0.0f : w;
  }
  for (const Flip& f : rig.flips) {
    const size_t n = f.entries.size();
    const float w = std::clamp(weights[f.shape], 0.0f, 1.0f);
    const size_t pick =
        std::min(static_cast<size_t>(static_cast<float>(n + 1) * w), n);  // 0: none.
    if (pick > 0) out[f.entries[pick - 1].first] += f.entries[pick - 1].second;
  }
}

void BlendTexcoords(std::span<const float> base, std::span<const float> weights,
                    std::span<const SparseTarget> targets, std::vector<float>& out) {
  out.clear();
  bool any = false;
  for (size_t t = 0; t < targets.size() && t < weights.size() && !any; ++t)
    any = weights[t] != 0.0f && !targets[t].texcoord_indices.empty();
  if (!any || base.empty()) return;
  out.assign(base.begin(), base.end());
  for (size_t t = 0; t < targets.size() && t < weights.size(); ++t) {
    const float w = weights[t];
    if (w == 0.0f) continue;
    const SparseTarget& st = targets[t];
    for (size_t k = 0; k < st.texcoord_indices.size(); ++k) {
      float* o = &out[2 * static_cast<size_t>(st.texcoord_indices[k])];
      o[0] += w * st.texcoord_deltas[2 * k];
      o[1] += w * st.texcoord_deltas[2 * k + 1];
    }
  }
}

void MorphedMaterialColors(const Rig& rig, std::span<const float> weights,
                           std::vector<std::array<float, 4>>& out) {
  out.clear();
  bool any = false;
  for (size_t s = 0; s < rig.shapes.size() && s < weights.size() && !any; ++s)
    any = weights[s] != 0.0f && !rig.shapes[s].material_morphs.empty();
  if (!any) return;
  // Per material: multiply and add factors of the diffuse colour and of the texture tint.
  const size_t n = rig.materials.size();
  std::vector<std::array<float, 4>> mul_d(n, {1, 1, 1, 1}), add_d(n, {0, 0, 0, 0}),
      mul_t(n, {1, 1, 1, 1}), add_t(n, {0, 0, 0, 0});
  for (size_t s = 0; s < rig.shapes.size() && s < weights.size(); ++s) {
    if (weights[s] == 0.0f) continue;
    for (const MaterialMorph& m : rig.shapes[s].material_morphs) {
      const float w = weights[s] * m.factor;
      const size_t first = m.material < 0 ? 0 : static_cast<size_t>(m.material),
                   last = m.material < 0 ? n : std::min(n, first + 1);
      for (size_t i = first; i < last; ++i) {
        for (int c = 0; c < 4; ++c) {
          if (m.add) {
            add_d[i][c] += w * m.diffuse[c];
            add_t[i][c] += w * m.texture_tint[c];
          } else {
            mul_d[i][c] *= 1.0f + w * (m.diffuse[c] - 1.0f);
            mul_t[i][c] *= 1.0f + w * (m.texture_tint[c] - 1.0f);
          }
        }
      }
    }
  }
  out.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const auto& base = rig.materials[i].base_color_factor;
    for (int c = 0; c < 4; ++c)
      out[i][c] = std::clamp((base[c] * mul_d[i][c] + add_d[i][c]) * (mul_t[i][c] + add_t[i][c]),
                             0.0f, 1.0f);
  }
}

Status EvaluateRig(const Rig& rig, std::span<const float> given, const BlendOptions& options,
                   BlendedRig& out, BlendContext& ctx) {
  if (given.size() != rig.shapes.size()) {
    return InvalidArgument("expected " + std::to_string(rig.shapes.size()) + " weights, got " +
                           std::to_string(given.size()));
  }
  for (float w : given) {
    if (!std::isfinite(w)) return InvalidArgument("weights must be finite");
  }
  std::span<const float> weights = given;
  if (!rig.inbetweens.empty() || !rig.correctives.empty() || !rig.flips.empty()) {
    ctx.effective.resize(given.size());
    EffectiveWeights(rig, given, ctx.effective);
    weights = ctx.effective;
  }
  if (options.pose && options.pose->local.size() != rig.nodes.size())
    return InvalidArgument("the pose does not match the rig");
  MorphedMaterialColors(rig, weights, out.material_colors);
  WorldMatricesInto(rig, options.pose, out.node_world, ctx.node_order);
  out.posed = options.pose != nullptr;
  out.primitives.resize(rig.primitives.size());
  // Each mesh is placed by the first node that shows it.
  std::vector<int>& mesh_node = ctx.mesh_node;
  mesh_node.assign(rig.meshes.size(), -1);
  for (size_t i = 0; i < rig.nodes.size(); ++i) {
    if (rig.nodes[i].mesh >= 0 && mesh_node[rig.nodes[i].mesh] < 0)
      mesh_node[rig.nodes[i].mesh] = static_cast<int>(i);
  }
  const std::array<float, 16> identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  for (size_t mi = 0; mi < rig.meshes.size(); ++mi) {
    const Mesh& mesh = rig.meshes[mi];
    const bool any_active = GatherTargetWeights(weights, mesh.target_shapes, ctx.target_weights);
    const std::span<const float> tw(ctx.target_weights);
    const bool skinned = mesh.skin >= 0 && static_cast<size_t>(mesh.skin) < rig.skins.size();
    if (skinned) {
      JointMatrices(rig, mesh.skin, out.node_world, ctx.joint_matrices);
      if (options.dual_quaternion) DualQuaternions(ctx.joint_matrices, ctx.joint_dual_quaternions);
    }
    for (int pi : mesh.primitives) {
      const Primitive& p = rig.primitives[pi];
      BlendedPrimitive& bp = out.primitives[pi];
      const bool skin_this = skinned && p.influences > 0;
      // Morph first, then skin (glTF's order).
      BlendedPrimitive& morphed = skin_this ? ctx.unskinned : bp;
      if (!MorphPrimitive(p, tw, any_active, options, morphed, ctx)) {
        return InvalidArgument("primitive " + std::to_string(pi) + " cannot be blended");
      }
      bp.skinned = skin_this;
      if (!skin_this) bp.morphed_positions.clear();
      bp.world = skin_this || mesh_node[mi] < 0 ? identity : out.node_world[mesh_node[mi]];
      if (!skin_this) continue;
      bp.positions.resize(morphed.positions.size());
      bp.normals.resize(morphed.normals.size());
      bp.tangents.resize(morphed.tangents.size());
      bp.texcoords.swap(morphed.texcoords);  // UVs do not skin.
      SkinningJob skin{
          .joint_matrices = ctx.joint_matrices,
          .influences = p.influences,
          .joints = p.joints,
          .weights = p.joint_weights,
          .in_positions = morphed.positions,
          .in_normals = morphed.normals,
          .in_tangents = morphed.tangents,
          .out_positions = bp.positions,
          .out_normals = bp.normals,
          .out_tangents = bp.tangents,
          .joint_dual_quaternions = options.dual_quaternion
                                        ? std::span<const float>(ctx.joint_dual_quaternions)
                                        : std::span<const float>()};
      if (!skin.Run())
        return InvalidArgument("primitive " + std::to_string(pi) + " cannot be skinned");
      bp.morphed_positions.assign(morphed.positions.begin(), morphed.positions.end());
    }
  }
  return Status::Ok();
}

}  // namespace engine
}  // namespace facespace
