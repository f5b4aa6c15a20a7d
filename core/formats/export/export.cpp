// ExportMesh picks the writer; the f32 body written over the rest's bytes (F32Writer); warnings as
// JSON.
#include <tiny_gltf.h>

#include <Eigen/Dense>
#include <charconv>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <sstream>

#include "export/writers.h"
#include "facespace/engine/enum_table.h"
#include "facespace/engine/normal_matrix.h"
#include "facespace/engine/transform.h"
#include "facespace/engine/weights.h"
#include "facespace/formats/io.h"
#include "facespace/formats/rig_json.h"

namespace facespace::formats {

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

nlohmann::json NumberValue(double value) {
  if (!std::isfinite(value)) return nullptr;
  if (value == std::floor(value) && std::fabs(value) < 1e15) return static_cast<int64_t>(value);
  return std::stod(FormatNumber(value));
}

nlohmann::json WarningsValue(std::span<const Warning> warnings) {
  nlohmann::json out = nlohmann::json::array();
  for (const Warning& w : warnings) {
    nlohmann::json o = {{"code", w.code}, {"message", w.message}};
    if (!w.shape.empty()) o["shape"] = w.shape;
    if (w.has_value) o["value"] = NumberValue(w.value);
    for (auto& [key, v] :
         o.items()) {  // As WarningsToJson's text, valid UTF-8 whatever the names held.
      if (v.is_string()) RepairUtf8(v.get_ref<std::string&>());
    }
    out.push_back(std::move(o));
  }
  return out;
}

// The text of WarningsValue: one declaration of a warning's members for the text writers and the
// JSON answers alike.
std::string WarningsToJson(std::span<const Warning> warnings) {
  return WarningsValue(warnings).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

Result<std::string> ExportMesh(const Rig& rig, const BlendedRig& blended,
                               std::span<const float> weights, std::span<const Warning> warnings,
                               MeshFormat format, const ExportOptions& options) {
  if (blended.primitives.size() != rig.primitives.size())
    return InvalidArgument("blended rig does not match the rig");
  switch (format) {
    case MeshFormat::kJson: return ExportJson(rig, blended, warnings, options.mesh_space);
    case MeshFormat::kObj: return ExportObj(rig, blended, warnings, options.mesh_space);
    case MeshFormat::kF32: return ExportF32(blended, options.mesh_space);
    case MeshFormat::kGlb: return ExportGlb(rig, blended, weights, warnings, options);
    case MeshFormat::kVrm: return ExportVrm(rig, blended, weights, warnings, options);
    case MeshFormat::kVrm0: return ExportVrm0(rig, blended, weights, warnings, options);
  }
  return InvalidArgument("unknown format");
}

// ---- f32 written over the rest's bytes ------------------------------------------------------

F32Writer::F32Writer(const Rig& rig, bool mesh_space) : F32Writer(rig, mesh_space, BlendedRig{}) {}

// `rest` is filled by blend_'s construction, before the body reads it.
F32Writer::F32Writer(const Rig& rig, bool mesh_space, BlendedRig&& rest)
    : mesh_space_(mesh_space), blend_(rig, &rest) {
  if (!blend_.ok()) return;
  rest_ = ExportF32(rest, mesh_space);
  // The body is every primitive's positions, in order, then every primitive's normals.
  primitives_.resize(rest.primitives.size());
  size_t at = 0, normals_at = 0;
  for (const BlendedPrimitive& b : rest.primitives) normals_at += b.positions.size() * 4;
  for (size_t pi = 0; pi < rest.primitives.size(); ++pi) {
    const BlendedPrimitive& b = rest.primitives[pi];
    primitives_[pi].placement = Placement(b, mesh_space);
    primitives_[pi].at = at;
    primitives_[pi].normals_at = normals_at;
    at += b.positions.size() * 4;
    normals_at += b.normals.size() * 4;
  }
  ok_ = normals_at == rest_.size();
}

bool F32Writer::Write(const Rig& rig, std::span<const float> weights, Scratch& s,
                      std::string& out) const {
  if (!ok_ || !blend_.Accepts(rig, weights)) return false;
  // Every byte of `out` is written below, so a body of this size handed back (a response sent)
  // is written over as it is: no allocation, and no copy of what the point's shapes move.
  out.resize(rest_.size());
  for (size_t pi = 0; pi < primitives_.size(); ++pi) {
    const Placed& placed = primitives_[pi];
    switch (blend_.Blend(rig, weights, pi, s)) {
      case SparseBlend::Outcome::kRest: {
        const size_t bytes = rig.primitives[pi].positions.size() * 4;
        std::memcpy(out.data() + placed.at, rest_.data() + placed.at, bytes);
        std::memcpy(out.data() + placed.normals_at, rest_.data() + placed.normals_at, bytes);
        break;
      }
      case SparseBlend::Outcome::kBlended:
        // The moved vertices' normals are scaled to unit length, as the blend leaves them, while
        // placed.
        WritePlaced(s.positions, s.normals, placed.placement, out.data() + placed.at,
                    out.data() + placed.normals_at, s.moved.data());
        break;
      case SparseBlend::Outcome::kDeclined: return false;
    }
  }
  return true;
}

}  // namespace facespace::formats
