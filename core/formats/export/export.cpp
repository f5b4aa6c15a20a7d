// ExportMesh picks the writer; the f32 body blended where it is written (F32Blender); warnings as JSON.
#include <tiny_gltf.h>
#include "facespace/core/enum_table.h"
#include "facespace/core/transform.h"

#include <Eigen/Dense>
#include <charconv>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <sstream>

#include "facespace/formats/io.h"
#include "facespace/core/weights.h"
#include "facespace/core/normal_matrix.h"
#include "export/writers.h"

namespace facespace {

using namespace writers;

void WorldPositions(const BlendedRig& blended, std::vector<float>& out) {
  out.clear();
  for (const BlendedPrimitive& b : blended.primitives) {
    for (size_t v = 0; v < b.positions.size(); v += 3) {
      float q[3];
      TransformPoint(b.world, &b.positions[v], q, 1.0f);
      out.insert(out.end(), q, q + 3);
    }
  }
}

std::string WarningsToJson(std::span<const Warning> warnings) {
  std::string out = "[";
  for (size_t i = 0; i < warnings.size(); ++i) {
    const Warning& w = warnings[i];
    if (i) out += ',';
    out += "{\"code\":" + JsonString(w.code) + ",\"message\":" + JsonString(w.message);
    if (!w.shape.empty()) out += ",\"shape\":" + JsonString(w.shape);
    if (w.has_value) {
      out += ",\"value\":";
      out += std::isfinite(w.value) ? FormatNumber(w.value) : "null";
    }
    out += '}';
  }
  return out + "]";
}

Result<std::string> ExportMesh(const Rig& rig, const BlendedRig& blended, std::span<const float> weights,
                               std::span<const Warning> warnings, MeshFormat format,
                               const ExportOptions& options) {
  if (blended.primitives.size() != rig.primitives.size()) return InvalidArgument("blended rig does not match the rig");
  switch (format) {
    case MeshFormat::kJson: return ExportJson(rig, blended, warnings, options.mesh_space);
    case MeshFormat::kObj: return ExportObj(rig, blended, warnings, options.mesh_space);
    case MeshFormat::kF32: return ExportF32(blended, options.mesh_space);
    case MeshFormat::kGlb: return ExportGlb(rig, blended, weights, warnings, options);
  }
  return InvalidArgument("unknown format");
}

// ---- f32 blended where it is written --------------------------------------------------------

namespace {

// 64-bit words of a bit per vertex of `p` (F32Blender's moved vertices).
size_t MovedWords(const Primitive& p) { return (p.vertex_count() + 63) / 64; }

}  // namespace

bool F32Blender::Serves(const Rig& rig, const BlendOptions& options) {
  if (options.normals != NormalMode::kBlend || options.pose || !rig.inbetweens.empty() || !rig.correctives.empty()) return false;
  for (const Mesh& m : rig.meshes) {
    if (m.skin >= 0) return false;
  }
  return true;
}

F32Blender::F32Blender(const Rig& rig, bool mesh_space) : mesh_space_(mesh_space) {
  if (!Serves(rig, {})) return;
  BlendedRig rest;
  BlendContext ctx;
  if (!EvaluateRig(rig, std::vector<float>(rig.shapes.size(), 0.0f), {}, rest, ctx).ok()) return;
  rest_ = ExportF32(rest, mesh_space);
  // The body is every primitive's positions, in order, then every primitive's normals.
  primitives_.resize(rig.primitives.size());
  size_t at = 0, normals_at = 0;
  for (const BlendedPrimitive& b : rest.primitives) normals_at += b.positions.size() * 4;
  for (size_t pi = 0; pi < rest.primitives.size(); ++pi) {
    const BlendedPrimitive& b = rest.primitives[pi];
    const Primitive& p = rig.primitives[pi];
    if (b.positions.size() != p.positions.size() || b.normals.size() != p.normals.size() || p.normals.size() != p.positions.size()) return;
    primitives_[pi].placement = Placement(b, mesh_space);
    primitives_[pi].at = at;
    primitives_[pi].normals_at = normals_at;
    at += b.positions.size() * 4;
    normals_at += b.normals.size() * 4;
  }
  if (normals_at != rest_.size()) return;
  for (const Mesh& mesh : rig.meshes) {
    for (int pi : mesh.primitives) primitives_[pi].shapes = mesh.target_shapes;
  }
  // Each target's rig shape and the vertices it moves, checked once here for every point.
  for (size_t pi = 0; pi < rig.primitives.size(); ++pi) {
    const Primitive& p = rig.primitives[pi];
    Placed& placed = primitives_[pi];
    if (placed.shapes.size() != p.targets.size()) return;
    const size_t words = MovedWords(p);
    placed.moved.assign(words * p.targets.size(), 0);
    for (size_t t = 0; t < p.targets.size(); ++t) {
      if (placed.shapes[t] >= rig.shapes.size()) return;
      for (uint32_t v : p.targets[t].indices) {
        if (v >= p.vertex_count()) return;
        placed.moved[t * words + v / 64] |= uint64_t{1} << (v % 64);
      }
    }
  }
  shapes_ = rig.shapes.size();
  ok_ = true;
}

bool F32Blender::Write(const Rig& rig, std::span<const float> weights, Scratch& s, std::string& out) const {
  if (!ok_ || weights.size() != shapes_ || rig.shapes.size() != shapes_ || rig.primitives.size() != primitives_.size()) return false;
  for (float w : weights) {
    if (!std::isfinite(w)) return false;
  }
  // Every byte of `out` is written below, so a body of this size handed back (a response sent)
  // is written over as it is: no allocation, and no copy of what the point's shapes move.
  out.resize(rest_.size());
  for (size_t pi = 0; pi < primitives_.size(); ++pi) {
    const Placed& placed = primitives_[pi];
    const Primitive& p = rig.primitives[pi];
    s.target_weights.resize(p.targets.size());
    bool active = false;
    for (size_t t = 0; t < p.targets.size(); ++t) {
      s.target_weights[t] = weights[placed.shapes[t]];
      active |= s.target_weights[t] != 0.0f;
    }
    if (!active) {  // The rest's bytes.
      const size_t bytes = p.positions.size() * 4;
      std::memcpy(out.data() + placed.at, rest_.data() + placed.at, bytes);
      std::memcpy(out.data() + placed.normals_at, rest_.data() + placed.normals_at, bytes);
      continue;
    }
    // Blended as EvaluateRig blends a primitive (positions and normals: the f32 body has no
    // tangents), then placed whole as ExportF32 places it.
    s.positions.resize(p.positions.size());
    s.normals.resize(p.normals.size());
    BlendShapeJob pj{.base = p.positions, .weights = s.target_weights, .targets = p.targets,
                     .channel = TargetChannel::kPosition, .stride = 3, .out = s.positions};
    BlendShapeJob nj{.base = p.normals, .weights = s.target_weights, .targets = p.targets,
                     .channel = TargetChannel::kNormal, .stride = 3, .out = s.normals};
    // The normals' job declines an active target without normal deltas, as the blend does (it
    // recomputes normals there): so does this writer.
    if (!pj.Run() || !nj.Run()) return false;
    // The moved vertices (any active target's) have their normals scaled to unit length, as the
    // blend leaves them, while they are placed.
    const size_t words = MovedWords(p);
    s.moved.assign(words, 0);
    for (size_t t = 0; t < p.targets.size(); ++t) {
      if (s.target_weights[t] == 0.0f) continue;
      const uint64_t* bits = &placed.moved[t * words];
      for (size_t k = 0; k < words; ++k) s.moved[k] |= bits[k];
    }
    WritePlaced(s.positions, s.normals, placed.placement, out.data() + placed.at, out.data() + placed.normals_at, s.moved.data());
  }
  return true;
}

}  // namespace facespace

