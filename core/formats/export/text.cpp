// The text and raw writers: JSON, OBJ and f32 (the glb writer is glb.cpp).
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

namespace facespace::formats {

using namespace writers;

namespace {
constexpr EnumName<MeshFormat> kMeshFormats[] = {
    {MeshFormat::kGlb, "glb", nullptr, "model/gltf-binary", "glb"},
    {MeshFormat::kObj, "obj", nullptr, "model/obj", "obj"},
    {MeshFormat::kJson, "json", nullptr, "application/json", "json"},
    {MeshFormat::kF32, "f32", nullptr, "application/octet-stream", "f32"},
    {MeshFormat::kVrm, "vrm", nullptr, "model/gltf-binary", "vrm"},
    {MeshFormat::kVrm0, "vrm0", nullptr, "model/gltf-binary", "vrm"}};
}  // namespace

bool ParseMeshFormat(const std::string& name, MeshFormat* format) {
  return ParseEnum(kMeshFormats, name, format);
}
const char* MeshFormatName(MeshFormat format) { return EnumEntry(kMeshFormats, format).name; }
const char* MeshFormatMimeType(MeshFormat format) {
  return EnumEntry(kMeshFormats, format).media_type;
}

namespace writers {

// Shortest text that reads back as the same float; JSON has no NaN so those become 0
// (weights are checked finite before evaluation, so this never happens in practice).
void AppendFloat(std::string& out, float f) {
  if (!std::isfinite(f)) f = 0.0f;
  char buf[32];
  auto r = std::to_chars(buf, buf + sizeof buf, f);
  out.append(buf, r.ptr);
}

// One OBJ line: "v x y z", "vt u v", "vn x y z".
void AppendObjLine(std::string& out, const char* tag, std::initializer_list<float> values) {
  out += tag;
  for (float f : values) {
    out += ' ';
    AppendFloat(out, f);
  }
  out += '\n';
}

void AppendFloats(std::string& out, std::span<const float> values) {
  out += '[';
  for (size_t i = 0; i < values.size(); ++i) {
    if (i) out += ',';
    AppendFloat(out, values[i]);
  }
  out += ']';
}

std::string ExportJson(const Rig& rig, const BlendedRig& blended, std::span<const Warning> warnings,
                       bool mesh_space) {
  return std::string("{\"space\":") + (mesh_space ? "\"mesh\"" : "\"world\"") +
         ",\"primitives\":" + PrimitivesJson(rig, blended, mesh_space) +
         ",\"warnings\":" + WarningsToJson(warnings) + "}\n";
}

// A primitive's node transform, or the identity in mesh space.
const std::array<float, 16>& Placement(const BlendedPrimitive& b, bool mesh_space) {
  static const std::array<float, 16> kIdentity = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  return mesh_space ? kIdentity : b.world;
}

// xyz triples as a JSON array, each through `place` (a point or a normal transform).
template <typename Place>
void AppendPlaced(std::string& out, std::span<const float> xyz, Place place) {
  out += '[';
  for (size_t v = 0; v + 2 < xyz.size(); v += 3) {
    float q[3];
    place(&xyz[v], q);
    for (int c = 0; c < 3; ++c) {
      if (v + c) out += ',';
      AppendFloat(out, q[c]);
    }
  }
  out += ']';
}

}  // namespace writers

std::string JsonString(const std::string& s) {
  return nlohmann::json(s).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string PrimitivesJson(const Rig& rig, const BlendedRig& blended, bool mesh_space) {
  std::string out = "[";
  for (size_t i = 0; i < rig.primitives.size(); ++i) {
    const Primitive& p = rig.primitives[i];
    const BlendedPrimitive& b = blended.primitives[i];
    if (i) out += ',';
    out += "{\"mesh\":" + std::to_string(p.mesh) +
           ",\"primitive\":" + std::to_string(p.index_in_mesh) +
           ",\"name\":" + JsonString(rig.meshes[p.mesh].name) + ",\"positions\":";
    if (mesh_space) {
      AppendFloats(out, b.positions);
      out += ",\"normals\":";
      AppendFloats(out, b.normals);
    } else {
      AppendPlaced(out, b.positions,
                   [&](const float* in, float* q) { TransformPoint(b.world, in, q, 1.0f); });
      out += ",\"normals\":";
      const NormalMatrix nm(b.world.data(), 4);
      AppendPlaced(out, b.normals, [&](const float* in, float* q) { nm.Apply(in, q); });
    }
    out += '}';
  }
  return out + "]";
}

namespace writers {

void NormalToWorld(const std::array<float, 16>& m, const float* n, float* out) {
  TransformNormal(m.data(), 4, n, out);
}

std::string ExportObj(const Rig& rig, const BlendedRig& blended, std::span<const Warning> warnings,
                      bool mesh_space) {
  std::string out = "# facespace blended mesh\n";
  for (const Warning& w : warnings) out += "# warning: " + w.message + "\n";
  size_t base_v = 1, base_vt = 1;  // vt and vn are numbered alike.
  for (size_t i = 0; i < rig.primitives.size(); ++i) {
    const Primitive& p = rig.primitives[i];
    const BlendedPrimitive& b = blended.primitives[i];
    const size_t n = p.vertex_count();
    std::string name =
        rig.meshes[p.mesh].name.empty() ? "mesh" + std::to_string(p.mesh) : rig.meshes[p.mesh].name;
    for (char& c : name)
      if (c == ' ' || c == '\n' || c == '\r') c = '_';
    out += "o " + name + "_" + std::to_string(p.index_in_mesh) + "\n";
    // A primitive split at UV seams is written welded again: one `v` per source vertex (the
    // source's numbering, as MakeHuman's targets use it), `vt`/`vn` per copy. Only when every
    // source number has a copy (a simplified LOD may have dropped some): else one `v` per vertex.
    std::vector<uint32_t> first_of;  // Source -> its first copy.
    const size_t sources =
        p.source_vertices.empty()
            ? 0
            : *std::max_element(p.source_vertices.begin(), p.source_vertices.end()) + size_t{1};
    if (sources > 0 && sources <= n) {  // More source numbers than vertices: some have no copy.
      first_of.assign(sources, UINT32_MAX);
      for (size_t v = n; v-- > 0;) first_of[p.source_vertices[v]] = static_cast<uint32_t>(v);
      if (std::find(first_of.begin(), first_of.end(), UINT32_MAX) != first_of.end())
        first_of.clear();
    }
    const bool welded = !first_of.empty();
    for (size_t k = 0; k < (welded ? first_of.size() : n); ++k) {
      const size_t v = welded ? first_of[k] : k;
      float q[3];
      TransformPoint(Placement(b, mesh_space), &b.positions[3 * v], q, 1.0f);
      AppendObjLine(out, "v", {q[0], q[1], q[2]});
    }
    const std::span<const float> uvs = TexcoordsOf(p, b);  // UV morphs move them.
    const bool uv = !uvs.empty();
    for (size_t v = 0; uv && v < n; ++v) {
      AppendObjLine(out, "vt", {uvs[2 * v], 1.0f - uvs[2 * v + 1]});
    }
    for (size_t v = 0; v < n; ++v) {
      float q[3];
      NormalToWorld(Placement(b, mesh_space), &b.normals[3 * v], q);
      AppendObjLine(out, "vn", {q[0], q[1], q[2]});
    }
    if (p.mode == PrimitiveMode::kTriangles) {
      for (size_t f = 0; f + 2 < p.indices.size(); f += 3) {
        out += 'f';
        for (int c = 0; c < 3; ++c) {
          const uint32_t v = p.indices[f + c];
          const std::string idx = std::to_string(base_vt + v);
          out += ' ' + std::to_string(base_v + (welded ? p.source_vertices[v] : v)) + '/' +
                 (uv ? idx : "") + '/' + idx;
        }
        out += '\n';
      }
    } else if (p.mode == PrimitiveMode::kLines) {
      for (size_t f = 0; f + 1 < p.indices.size(); f += 2) {
        const uint32_t a = p.indices[f], c = p.indices[f + 1];
        out += "l " + std::to_string(base_v + (welded ? p.source_vertices[a] : a)) + ' ' +
               std::to_string(base_v + (welded ? p.source_vertices[c] : c)) + '\n';
      }
    }
    base_v += welded ? first_of.size() : n;
    base_vt += n;
  }
  return out;
}

// A point placed by `m`: the one expression every f32 position goes through.
inline void PlacePoint(const std::array<float, 16>& m, const float* p, float* q) {
  for (int r = 0; r < 3; ++r)
    q[r] = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r] * 1.0f;
}

// One primitive's placed positions into `at` and its placed normals into `normals_at`, 64
// vertices at a time (vector instructions), through a small buffer: ExportF32's and F32Blender's
// placement, so both write the same bits. With `unit_first` (a bit per vertex, 64 to a word), the
// marked normals are first scaled to unit length, as the blend scales a moved vertex's.
void WritePlaced(std::span<const float> positions, std::span<const float> normals,
                 const std::array<float, 16>& m, char* at, char* normals_at,
                 const uint64_t* unit_first) {
  float q[3 * 64];
  for (size_t v = 0; v < positions.size(); v += std::size(q)) {
    const size_t chunk = std::min(std::size(q), positions.size() - v);
    const float* p = &positions[v];
    size_t i = 0;
#if defined(__SSE2__)
    // Four points at a time: PlacePoint's products and sums in its order (m[12 + r] * 1 is m[12 +
    // r]).
    for (; i + 12 <= chunk; i += 12) {
      __m128 x, y, z, o[3];
      LoadXyz4(p + i, x, y, z);
      for (int r = 0; r < 3; ++r) {
        o[r] = _mm_add_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_set1_ps(m[r]), x),
                                                _mm_mul_ps(_mm_set1_ps(m[4 + r]), y)),
                                     _mm_mul_ps(_mm_set1_ps(m[8 + r]), z)),
                          _mm_set1_ps(m[12 + r]));
      }
      StoreXyz4(o[0], o[1], o[2], q + i);
    }
#endif
    for (; i + 2 < chunk; i += 3) PlacePoint(m, p + i, q + i);
    std::memcpy(at + 4 * v, q, chunk * 4);
  }
  const NormalMatrix nm(m.data(), 4);
  for (size_t v = 0; v < normals.size(); v += std::size(q)) {
    const size_t chunk = std::min(std::size(q), normals.size() - v);
    nm.ApplyMany(&normals[v], chunk / 3, q, unit_first ? unit_first[v / std::size(q)] : 0);
    std::memcpy(normals_at + 4 * v, q, chunk * 4);
  }
}

std::string ExportF32(const BlendedRig& blended, bool mesh_space) {
  size_t floats = 0, normals_at = 0;
  for (const BlendedPrimitive& b : blended.primitives) {
    floats += b.positions.size() + b.normals.size();
    normals_at += b.positions.size() * 4;
  }
  std::string out(floats * 4,
                  '\0');  // Written in place, float by float: x86-64 and ARM64 are little-endian.
  size_t at = 0;
  for (const BlendedPrimitive& b : blended.primitives) {
    WritePlaced(b.positions, b.normals, Placement(b, mesh_space), out.data() + at,
                out.data() + normals_at);
    at += b.positions.size() * 4;
    normals_at += b.normals.size() * 4;
  }
  return out;
}

}  // namespace writers

}  // namespace facespace::formats
