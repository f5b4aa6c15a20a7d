// glb bodies of many variants written from a kept template (GlbVariantWriter,
// facespace/formats/io.h): the first variant is written by the glb writer (glb.cpp), the rest patch
// its attributes and bounds.
#include <algorithm>
#include <cstring>
#include <nlohmann/json.hpp>

#include "export/writers.h"
#include "facespace/formats/io.h"

namespace facespace::formats {

using namespace writers;
using writers::ExportGlb;

struct GlbTemplate {
  struct Attribute {
    size_t primitive = 0;
    int kind = 0;       // 0 positions, 1 normals, 2 tangents, 3 UVs (a rig with UV morphs).
    size_t offset = 0;  // In `bin`.
    int accessor = -1;  // POSITION: its bounds are patched.
  };
  const Rig* rig = nullptr;
  std::vector<size_t>
      shape;  // What the template was made for: posed, then per primitive skinned and sizes.
  nlohmann::json json;  // The glb's JSON, patched for each variant.
  std::string bin;      // The binary chunk, attributes overwritten for each variant.
  std::vector<Attribute> attributes;
  bool posed_nodes = false;
  std::string head;
  std::string whole;  // keep_targets: the whole glb.
  std::vector<double> lo, hi;
  std::vector<size_t> probe;  // The shape of the call at hand.
};

namespace {

// Whether some shape moves UVs (MMD's UV morphs): their variants' TEXCOORD_0 is patched too.
bool MovesTexcoords(const Rig& rig) {
  return std::any_of(rig.primitives.begin(), rig.primitives.end(), [](const Primitive& p) {
    return std::any_of(p.targets.begin(), p.targets.end(),
                       [](const SparseTarget& t) { return !t.texcoord_indices.empty(); });
  });
}

// What a template depends on besides the rig, into `shape` (kept: no allocation once warm).
void GlbShape(const Rig& rig, const BlendedRig& blended, std::vector<size_t>& shape) {
  shape.assign(1, blended.posed && blended.node_world.size() == rig.nodes.size());
  for (const BlendedPrimitive& bp : blended.primitives) {
    shape.insert(shape.end(),
                 {bp.skinned, bp.positions.size(), bp.normals.size(), bp.tangents.size()});
  }
}

uint32_t ReadU32(const std::string& s, size_t at) {
  uint32_t v;
  std::memcpy(&v, s.data() + at, 4);
  return v;
}

void AppendU32(std::string& s, uint32_t v) { s.append(reinterpret_cast<const char*>(&v), 4); }

// The template from one full export: its JSON, its binary chunk, and where each blended
// attribute lies in the binary chunk (meshes and primitives in the order ExportGlb writes them).
Status MakeTemplate(const std::string& glb, const Rig& rig, const BlendedRig& blended,
                    GlbTemplate& t);

// The same, with a JSON member of an unexpected type (nlohmann's exceptions) as a failure.
Status MakeTemplateOrFail(const std::string& glb, const Rig& rig, const BlendedRig& blended,
                          GlbTemplate& t) {
  try {
    return MakeTemplate(glb, rig, blended, t);
  } catch (const nlohmann::json::exception& e) {
    return Internal(std::string("glb template: ") + e.what());
  }
}

Status MakeTemplate(const std::string& glb, const Rig& rig, const BlendedRig& blended,
                    GlbTemplate& t) {
  if (glb.size() < 20 || glb.compare(0, 4, "glTF") != 0) return Internal("glb template: not a glb");
  const size_t json_bytes = ReadU32(glb, 12);
  if (20 + json_bytes > glb.size()) return Internal("glb template: JSON chunk");
  t.json = nlohmann::json::parse(
      glb.begin() + 20, glb.begin() + 20 + static_cast<std::ptrdiff_t>(json_bytes), nullptr, false);
  if (t.json.is_discarded()) return Internal("glb template: JSON");
  t.bin = 28 + json_bytes <= glb.size() ? glb.substr(28 + json_bytes) : std::string();
  t.attributes.clear();
  // Read through a const view: a member the glb lacks (a rig without meshes) must not be added.
  const nlohmann::json& root = t.json;
  static const nlohmann::json kNone = nlohmann::json::array();
  auto member = [&root](const char* key) -> const nlohmann::json& {
    return root.contains(key) ? root.at(key) : kNone;
  };
  const nlohmann::json& meshes = member("meshes");
  const nlohmann::json& accessors = member("accessors");
  const nlohmann::json& views = member("bufferViews");
  const int kinds = MovesTexcoords(rig) ? 4 : 3;
  for (size_t mi = 0; mi < rig.meshes.size(); ++mi) {
    const std::vector<int>& prims = rig.meshes[mi].primitives;
    for (size_t k = 0; k < prims.size(); ++k) {
      const BlendedPrimitive& bp = blended.primitives[prims[k]];
      const nlohmann::json& attributes = meshes.at(mi).at("primitives").at(k).at("attributes");
      const char* names[] = {"POSITION", "NORMAL", "TANGENT", "TEXCOORD_0"};
      const size_t bytes[] = {bp.positions.size() * 4, bp.normals.size() * 4,
                              bp.tangents.size() * 4,
                              rig.primitives[prims[k]].texcoords.size() * 4};
      for (int kind = 0; kind < kinds; ++kind) {
        if (!attributes.contains(names[kind])) continue;
        const int a = attributes[names[kind]].get<int>();
        const nlohmann::json& view = views.at(accessors.at(a).at("bufferView").get<size_t>());
        const size_t offset = view.value("byteOffset", size_t{0});
        if (view.at("byteLength").get<size_t>() != bytes[kind] ||
            offset + bytes[kind] > t.bin.size()) {
          return Internal("glb template: attribute sizes");
        }
        t.attributes.push_back({static_cast<size_t>(prims[k]), kind, offset, kind == 0 ? a : -1});
      }
    }
  }
  t.posed_nodes = blended.posed && blended.node_world.size() == rig.nodes.size();
  return Status::Ok();
}

}  // namespace

GlbVariantWriter::GlbVariantWriter() : t_(std::make_unique<GlbTemplate>()) {}
GlbVariantWriter::~GlbVariantWriter() = default;
GlbVariantWriter::GlbVariantWriter(GlbVariantWriter&&) noexcept = default;
GlbVariantWriter& GlbVariantWriter::operator=(GlbVariantWriter&&) noexcept = default;

Result<GlbVariantWriter::Pieces> GlbVariantWriter::Write(const Rig& rig, const BlendedRig& blended,
                                                         std::span<const float> weights,
                                                         std::span<const Warning> warnings,
                                                         const ExportOptions& options) {
  if (blended.primitives.size() != rig.primitives.size())
    return InvalidArgument("blended rig does not match the rig");
  GlbTemplate& t = *t_;
  if (options.keep_targets) {
    auto glb = ExportGlb(rig, blended, weights, warnings, options);
    if (!glb.ok()) return glb.status();
    t.whole = std::move(glb.value());
    return Pieces{t.whole, {}};
  }
  GlbShape(rig, blended, t.probe);
  // Material morphs change the materials' colours from variant to variant: no template patches
  // them, so such a rig's variants are exported whole.
  const bool colours_move = std::any_of(rig.shapes.begin(), rig.shapes.end(),
                                        [](const Shape& s) { return !s.material_morphs.empty(); });
  if (t.rig != &rig || t.shape != t.probe || colours_move) {
    // The first variant of this shape: exported whole, and kept as the template (when its
    // layout is the one expected; otherwise every call exports whole).
    auto glb = ExportGlb(rig, blended, weights, warnings, options);
    if (!glb.ok()) return glb.status();
    t.rig = nullptr;
    t.whole = std::move(glb.value());
    if (!colours_move && MakeTemplateOrFail(t.whole, rig, blended, t).ok()) {
      t.rig = &rig;
      t.shape = t.probe;
    }
    return Pieces{t.whole, {}};
  }
  // Later variants: what the blend changes, patched into the template.
  AsTinygltfWrites(AssetExtras(rig, weights, warnings), t.json["asset"]["extras"]);
  for (const GlbTemplate::Attribute& a : t.attributes) {
    const BlendedPrimitive& bp = blended.primitives[a.primitive];
    const std::span<const float> values = a.kind == 0   ? std::span<const float>(bp.positions)
                                          : a.kind == 1 ? std::span<const float>(bp.normals)
                                          : a.kind == 2
                                              ? std::span<const float>(bp.tangents)
                                              : TexcoordsOf(rig.primitives[a.primitive], bp);
    std::memcpy(t.bin.data() + a.offset, values.data(), values.size() * 4);
    if (a.accessor >= 0) {  // An attribute's accessor: the template has "accessors".
      FloatBounds(values, 3, values.size() / 3, t.lo, t.hi);
      nlohmann::json& accessor = t.json["accessors"][a.accessor];
      accessor["min"] = t.lo;
      accessor["max"] = t.hi;
    }
  }
  if (t.posed_nodes && !rig.nodes.empty()) {
    nlohmann::json& nodes = t.json["nodes"];
    for (size_t i = 0; i < rig.nodes.size(); ++i)
      nodes[i]["matrix"] = PosedLocalMatrix(rig, blended, i);
  }
  // The glb header and chunk headers as tinygltf writes them (JSON padded with spaces).
  const std::string text = t.json.dump();
  const size_t padded = (text.size() + 3) & ~size_t{3};
  t.head.clear();
  t.head += "glTF";
  AppendU32(t.head, 2);
  AppendU32(t.head,
            static_cast<uint32_t>(12 + 8 + padded + (t.bin.empty() ? 0 : 8 + t.bin.size())));
  AppendU32(t.head, static_cast<uint32_t>(padded));
  AppendU32(t.head, 0x4E4F534A);
  t.head += text;
  t.head.append(padded - text.size(), ' ');
  if (!t.bin.empty()) {
    AppendU32(t.head, static_cast<uint32_t>(t.bin.size()));
    AppendU32(t.head, 0x004E4942);
  }
  return Pieces{t.head, t.bin};
}

}  // namespace facespace::formats
