// The glb writer (tinygltf), and glb bodies of many variants written from a kept template.
#include <tiny_gltf.h>

#include <Eigen/Dense>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <sstream>

#include "export/writers.h"
#include "facespace/engine/animation.h"
#include "facespace/engine/constraints.h"
#include "facespace/engine/enum_table.h"
#include "facespace/engine/normal_matrix.h"
#include "facespace/engine/transform.h"
#include "facespace/engine/weights.h"
#include "facespace/formats/io.h"
#include "facespace/formats/rig_json.h"

namespace facespace::formats {

using namespace writers;

namespace {

// ---- glb ----------------------------------------------------------------------------------

tinygltf::Value ToValue(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::boolean: return tinygltf::Value(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
    case nlohmann::json::value_t::number_unsigned:
      return tinygltf::Value(static_cast<int>(j.get<int64_t>()));
    case nlohmann::json::value_t::number_float: return tinygltf::Value(j.get<double>());
    case nlohmann::json::value_t::string: return tinygltf::Value(j.get<std::string>());
    case nlohmann::json::value_t::array: {
      tinygltf::Value::Array a;
      for (const auto& e : j) a.push_back(ToValue(e));
      return tinygltf::Value(std::move(a));
    }
    case nlohmann::json::value_t::object: {
      tinygltf::Value::Object o;
      for (auto it = j.begin(); it != j.end(); ++it) o[it.key()] = ToValue(it.value());
      return tinygltf::Value(std::move(o));
    }
    default: return tinygltf::Value();
  }
}

class GlbBuilder {
 public:
  explicit GlbBuilder(tinygltf::Model& m) : m_(m) { m_.buffers.resize(1); }

  int View(const void* data, size_t bytes, int target) {
    auto& buf = m_.buffers[0].data;
    while (buf.size() % 4) buf.push_back(0);
    tinygltf::BufferView v;
    v.buffer = 0;
    v.byteOffset = buf.size();
    v.byteLength = bytes;
    v.target = target;
    const auto* p = static_cast<const unsigned char*>(data);
    buf.insert(buf.end(), p, p + bytes);
    m_.bufferViews.push_back(v);
    return static_cast<int>(m_.bufferViews.size() - 1);
  }

  // A float accessor of `comps` components; min/max when asked (POSITION needs them).
  int Floats(std::span<const float> values, int comps, bool minmax) {
    tinygltf::Accessor a;
    a.bufferView = View(values.data(), values.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER);
    a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    a.count = values.size() / comps;
    a.type = TypeOf(comps);
    if (minmax) MinMax(values, comps, a.count, a);
    m_.accessors.push_back(a);
    return static_cast<int>(m_.accessors.size() - 1);
  }

  // An unsigned short VEC4 accessor (JOINTS_n).
  int Joints(std::span<const uint16_t> values) {
    tinygltf::Accessor a;
    a.bufferView = View(values.data(), values.size() * 2, TINYGLTF_TARGET_ARRAY_BUFFER);
    a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    a.count = values.size() / 4;
    a.type = TINYGLTF_TYPE_VEC4;
    m_.accessors.push_back(a);
    return static_cast<int>(m_.accessors.size() - 1);
  }

  // Floats outside any vertex buffer (inverse binds, animation keys): no buffer view target.
  int Data(std::span<const float> values, int type, size_t count, bool minmax) {
    tinygltf::Accessor a;
    a.bufferView = View(values.data(), values.size() * 4, 0);
    a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    a.count = count;
    a.type = type;
    if (minmax) MinMax(values, 1, count, a);
    m_.accessors.push_back(a);
    return static_cast<int>(m_.accessors.size() - 1);
  }

  int Indices(std::span<const uint32_t> idx, size_t vertex_count) {
    tinygltf::Accessor a;
    if (vertex_count <= 65535) {
      std::vector<uint16_t> small(idx.begin(), idx.end());
      a.bufferView = View(small.data(), small.size() * 2, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
      a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    } else {
      a.bufferView = View(idx.data(), idx.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
      a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    }
    a.count = idx.size();
    a.type = TINYGLTF_TYPE_SCALAR;
    m_.accessors.push_back(a);
    return static_cast<int>(m_.accessors.size() - 1);
  }

  // A sparse VEC3 delta accessor over `count` vertices. Empty targets become an accessor
  // without bufferView, which glTF defines as all zeros.
  int SparseDeltas(std::span<const uint32_t> indices, std::span<const float> deltas, size_t count,
                   int comps = 3) {
    tinygltf::Accessor a;
    a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    a.count = count;
    a.type = TypeOf(comps);
    std::vector<float> mm(deltas.begin(), deltas.end());
    if (indices.size() < count)
      mm.insert(mm.end(), static_cast<size_t>(comps), 0.0f);  // Implicit zeros.
    MinMax(mm, comps, mm.size() / static_cast<size_t>(comps), a);
    if (!indices.empty()) {
      a.sparse.isSparse = true;
      a.sparse.count = static_cast<int>(indices.size());
      a.sparse.indices.bufferView = View(indices.data(), indices.size() * 4, 0);
      a.sparse.indices.byteOffset = 0;
      a.sparse.indices.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
      a.sparse.values.bufferView = View(deltas.data(), deltas.size() * 4, 0);
      a.sparse.values.byteOffset = 0;
    }
    m_.accessors.push_back(a);
    return static_cast<int>(m_.accessors.size() - 1);
  }

 private:
  static int TypeOf(int comps) {
    return comps == 1   ? TINYGLTF_TYPE_SCALAR
           : comps == 2 ? TINYGLTF_TYPE_VEC2
           : comps == 3 ? TINYGLTF_TYPE_VEC3
                        : TINYGLTF_TYPE_VEC4;
  }
  static void MinMax(std::span<const float> values, int comps, size_t count,
                     tinygltf::Accessor& a) {
    FloatBounds(values, comps, count, a.minValues, a.maxValues);
  }
  tinygltf::Model& m_;
};
}  // namespace

namespace writers {

// Node i's local matrix under the evaluated pose (its world matrix relative to its parent's).
std::array<double, 16> PosedLocalMatrix(const Rig& rig, const BlendedRig& blended, size_t i) {
  Eigen::Matrix4f world = Eigen::Map<const Eigen::Matrix4f>(blended.node_world[i].data());
  const int parent = rig.nodes[i].parent;
  if (parent >= 0)
    world = Eigen::Map<const Eigen::Matrix4f>(blended.node_world[parent].data()).inverse() * world;
  std::array<double, 16> out;
  std::copy(world.data(), world.data() + 16, out.begin());
  return out;
}

// An accessor's min and max: per component, over `count` elements of `comps` floats.
void FloatBounds(std::span<const float> values, int comps, size_t count, std::vector<double>& lo,
                 std::vector<double>& hi) {
  lo.assign(comps, 0.0);
  hi.assign(comps, 0.0);
  for (size_t e = 0; e < count; ++e) {
    for (int c = 0; c < comps; ++c) {
      const double v = values[e * comps + c];
      if (e == 0 || v < lo[c]) lo[c] = v;
      if (e == 0 || v > hi[c]) hi[c] = v;
    }
  }
}

// glb's asset.extras: the caller's extras, the warnings and the non-zero weights by shape name.
nlohmann::json AssetExtras(const Rig& rig, std::span<const float> weights,
                           std::span<const Warning> warnings) {
  nlohmann::json extras = nlohmann::json::object();
  extras["warnings"] = WarningsValue(warnings);
  nlohmann::json wmap = nlohmann::json::object();
  for (size_t s = 0; s < rig.shapes.size() && s < weights.size(); ++s) {
    if (weights[s] != 0.0f) wmap[rig.shapes[s].name] = weights[s];
  }
  extras["weights"] = wmap;
  return extras;
}

// What tinygltf writes for JSON that went through ToValue: integers as int, empty arrays and
// objects as null, nulls left out. False when nothing is written.
bool AsTinygltfWrites(const nlohmann::json& j, nlohmann::json& out) {
  out = nlohmann::json();
  switch (j.type()) {
    case nlohmann::json::value_t::boolean: out = j.get<bool>(); return true;
    case nlohmann::json::value_t::number_integer:
    case nlohmann::json::value_t::number_unsigned:
      out = static_cast<int>(j.get<int64_t>());
      return true;
    case nlohmann::json::value_t::number_float: out = j.get<double>(); return true;
    case nlohmann::json::value_t::string: out = j; return true;
    case nlohmann::json::value_t::array:
      for (const auto& e : j) {
        nlohmann::json v;
        if (AsTinygltfWrites(e, v)) out.push_back(std::move(v));
      }
      return true;
    case nlohmann::json::value_t::object:
      for (auto it = j.begin(); it != j.end(); ++it) {
        nlohmann::json v;
        if (AsTinygltfWrites(it.value(), v)) out[it.key()] = std::move(v);
      }
      return true;
    default: return false;
  }
}

namespace {

// glTF has no material, bone or flip morphs: the materials carry their colours, and the mesh its
// pose, at the exported weights; a glb that keeps the targets says which shapes lost what they do.
void WarnUnexported(const Rig& rig, std::vector<Warning>& warnings) {
  const auto say = [&](auto does, const char* code, const std::string& what,
                       const std::string& kept) {
    std::string names;
    size_t count = 0;
    for (size_t s = 0; s < rig.shapes.size(); ++s) {
      if (does(s) && ++count <= 12) names += (names.empty() ? "" : ", ") + rig.shapes[s].name;
    }
    if (count) {
      warnings.push_back({code,
                          std::to_string(count) + (count == 1 ? " shape " : " shapes ") + what +
                              ": " + names + (count > 12 ? ", ..." : "") + "; " + kept,
                          "", static_cast<double>(count), false});
    }
  };
  say([&](size_t s) { return !rig.shapes[s].material_morphs.empty(); },
      "material_morphs_not_exported",
      "with MMD material morphs (they change materials), which glTF cannot say",
      "the materials hold their colours at the exported weights");
  say([&](size_t s) { return !rig.shapes[s].bone_morphs.empty(); }, "bone_morphs_not_exported",
      "with MMD bone morphs (they move bones), which a glTF morph target cannot say",
      "the mesh holds their pose at the exported weights");
  say(
      [&](size_t s) {
        return std::any_of(rig.flips.begin(), rig.flips.end(),
                           [s](const Flip& f) { return f.shape == s; });
      },
      "flip_morphs_not_exported",
      "as MMD flip morphs (they switch other shapes on), which glTF's linear weights cannot say",
      "the mesh holds what they pick at the exported weights");
}

// The images glTF carries (PNG and JPEG: other images, an MMD model's BMP or TGA, and unread ones
// are left out, their materials keeping the base colour), a texture each, then the materials
// (colours under the material morphs at these weights).
void WriteMaterials(const Rig& rig, const BlendedRig& blended, GlbBuilder& b, tinygltf::Model& m) {
  std::vector<int> texture_of(rig.images.size(), -1);
  for (size_t ii = 0; ii < rig.images.size(); ++ii) {
    const Image& im = rig.images[ii];
    if (im.bytes.empty() || (im.mime_type != "image/png" && im.mime_type != "image/jpeg")) continue;
    texture_of[ii] = static_cast<int>(m.textures.size());
    tinygltf::Image gi;
    gi.name = im.name;
    gi.mimeType = im.mime_type;
    gi.bufferView = b.View(im.bytes.data(), im.bytes.size(), 0);
    m.images.push_back(gi);
    tinygltf::Texture t;
    t.source = static_cast<int>(m.images.size() - 1);
    m.textures.push_back(t);
  }
  // Each map's glTF texture, or -1 (no image, or one glTF cannot carry): tinygltf writes a texture
  // info only when its index is set.
  const auto texture = [&texture_of](int image) {
    return image >= 0 ? texture_of[static_cast<size_t>(image)] : -1;
  };
  for (size_t mi = 0; mi < rig.materials.size(); ++mi) {
    const Material& mat = rig.materials[mi];
    tinygltf::Material gm;
    gm.name = mat.name;
    const auto& base =
        mi < blended.material_colors.size() ? blended.material_colors[mi] : mat.base_color_factor;
    gm.pbrMetallicRoughness.baseColorFactor.assign(base.begin(), base.end());
    gm.pbrMetallicRoughness.baseColorTexture.index = texture(mat.base_color_image);
    gm.pbrMetallicRoughness.baseColorTexture.texCoord = mat.base_color_texcoord;
    gm.pbrMetallicRoughness.metallicRoughnessTexture.index = texture(mat.metallic_roughness_image);
    gm.normalTexture.index = texture(mat.normal_image);
    gm.normalTexture.scale = mat.normal_scale;
    gm.occlusionTexture.index = texture(mat.occlusion_image);
    gm.occlusionTexture.strength = mat.occlusion_strength;
    gm.emissiveTexture.index = texture(mat.emissive_image);
    gm.emissiveFactor.assign(mat.emissive_factor.begin(), mat.emissive_factor.end());
    gm.pbrMetallicRoughness.metallicFactor = mat.metallic_factor;
    gm.pbrMetallicRoughness.roughnessFactor = mat.roughness_factor;
    gm.doubleSided = mat.double_sided;
    gm.alphaMode = mat.alpha_mode == "OPAQUE" && base[3] < 1.0f
                       ? "BLEND"
                       : mat.alpha_mode;  // Made see-through by a material morph.
    gm.alphaCutoff = mat.alpha_cutoff;
    m.materials.push_back(gm);
  }
}

// The skin itself (JOINTS_n / WEIGHTS_n, 4 influences per set), for clients that skin on the GPU.
void WriteSkinAttributes(const Primitive& p, GlbBuilder& b, tinygltf::Primitive& gp) {
  const size_t sets = (p.influences + 3) / 4, n = p.vertex_count();
  for (size_t set = 0; set < sets; ++set) {
    std::vector<uint16_t> joints(4 * n, 0);
    std::vector<float> jw(4 * n, 0.0f);
    for (size_t v = 0; v < n; ++v) {
      for (size_t k = 0; k < 4 && 4 * set + k < p.influences; ++k) {
        joints[4 * v + k] = p.joints[v * p.influences + 4 * set + k];
        jw[4 * v + k] = p.joint_weights[v * p.influences + 4 * set + k];
      }
    }
    gp.attributes["JOINTS_" + std::to_string(set)] = b.Joints(joints);
    gp.attributes["WEIGHTS_" + std::to_string(set)] = b.Floats(jw, 4, false);
  }
}

// The primitive's targets as sparse accessors. Targets without normal deltas get zero ones so every
// target has the same attributes; UV morphs as TEXCOORD_0 targets (glTF 2.0 lets a target morph
// TEXCOORD_n; clients MAY apply them).
void WriteTargets(const Primitive& p, GlbBuilder& b, tinygltf::Primitive& gp) {
  bool any_normals = false, all_tangents = !p.tangents.empty(), any_uvs = false;
  for (const SparseTarget& t : p.targets) {
    any_normals |= !t.normal_deltas.empty();
    all_tangents &= t.indices.empty() || !t.tangent_deltas.empty();
    any_uvs |= !t.texcoord_indices.empty();
  }
  for (const SparseTarget& t : p.targets) {
    std::map<std::string, int> gt;
    gt["POSITION"] = b.SparseDeltas(t.indices, t.position_deltas, p.vertex_count());
    if (any_normals) {
      std::vector<float> zeros;
      if (t.normal_deltas.empty()) zeros.assign(t.position_deltas.size(), 0.0f);
      gt["NORMAL"] = b.SparseDeltas(t.indices, t.normal_deltas.empty() ? zeros : t.normal_deltas,
                                    p.vertex_count());
    }
    if (all_tangents) gt["TANGENT"] = b.SparseDeltas(t.indices, t.tangent_deltas, p.vertex_count());
    if (any_uvs)
      gt["TEXCOORD_0"] = b.SparseDeltas(t.texcoord_indices, t.texcoord_deltas, p.vertex_count(), 2);
    gp.targets.push_back(gt);
  }
}

// One primitive: the blended one, or with `rig_data` the rig's own (base positions, targets, skin).
tinygltf::Primitive WritePrimitive(const Primitive& p, const BlendedPrimitive& bp, bool rig_data,
                                   bool skinned, GlbBuilder& b) {
  tinygltf::Primitive gp;
  gp.attributes["POSITION"] =
      b.Floats(rig_data ? std::span<const float>(p.positions) : bp.positions, 3, true);
  gp.attributes["NORMAL"] =
      b.Floats(rig_data ? std::span<const float>(p.normals) : bp.normals, 3, false);
  if (!p.tangents.empty())
    gp.attributes["TANGENT"] =
        b.Floats(rig_data ? std::span<const float>(p.tangents) : bp.tangents, 4, false);
  if (!p.texcoords.empty())
    gp.attributes["TEXCOORD_0"] =
        b.Floats(rig_data ? std::span<const float>(p.texcoords) : TexcoordsOf(p, bp), 2, false);
  if (!p.colors.empty()) gp.attributes["COLOR_0"] = b.Floats(p.colors, 4, false);
  if (!p.source_vertices.empty()) {
    // Floats: glTF allows no unsigned int in a vertex attribute; exact below 2^24 (ValidateRig).
    const std::vector<float> source(p.source_vertices.begin(), p.source_vertices.end());
    gp.attributes["_SOURCE_VERTEX"] = b.Floats(source, 1, false);
  }
  if (!p.indices.empty()) gp.indices = b.Indices(p.indices, p.vertex_count());
  if (rig_data && p.influences > 0 && skinned) WriteSkinAttributes(p, b, gp);
  gp.mode = static_cast<int>(p.mode);
  gp.material = p.material;
  if (rig_data && !p.targets.empty()) WriteTargets(p, b, gp);
  return gp;
}

void WriteMeshes(const Rig& rig, const BlendedRig& blended, std::span<const float> weights,
                 bool keep_targets, GlbBuilder& b, tinygltf::Model& m) {
  for (const Mesh& mesh : rig.meshes) {
    tinygltf::Mesh gm;
    gm.name = mesh.name;
    for (int pi : mesh.primitives)
      gm.primitives.push_back(WritePrimitive(rig.primitives[pi], blended.primitives[pi],
                                             keep_targets, mesh.skin >= 0, b));
    if (keep_targets && !mesh.target_shapes.empty()) {
      tinygltf::Value::Array names;
      for (uint32_t s : mesh.target_shapes) {
        names.push_back(tinygltf::Value(rig.shapes[s].name));
        gm.weights.push_back(s < weights.size() ? weights[s] : 0.0);
      }
      tinygltf::Value::Object ex;
      ex["targetNames"] = tinygltf::Value(std::move(names));
      gm.extras = tinygltf::Value(std::move(ex));
    }
    m.meshes.push_back(gm);
  }
}

// One node: the evaluated pose as its local matrix, else its own transform; its skin with the rig's
// data.
tinygltf::Node WriteNode(const Rig& rig, const BlendedRig& blended, size_t i, bool keep_targets,
                         bool mesh_elsewhere) {
  const Node& n = rig.nodes[i];
  tinygltf::Node gn;
  gn.name = n.name;
  gn.mesh = mesh_elsewhere ? -1 : n.mesh;
  gn.children = n.children;
  if (blended.posed && blended.node_world.size() == rig.nodes.size()) {
    const std::array<double, 16> local = PosedLocalMatrix(rig, blended, i);
    gn.matrix.assign(local.begin(), local.end());
  } else if (n.has_matrix) {
    gn.matrix.assign(n.matrix.begin(), n.matrix.end());
  } else {
    if (n.translation != std::array<float, 3>{0, 0, 0})
      gn.translation.assign(n.translation.begin(), n.translation.end());
    if (n.rotation != std::array<float, 4>{0, 0, 0, 1})
      gn.rotation.assign(n.rotation.begin(), n.rotation.end());
    if (n.scale != std::array<float, 3>{1, 1, 1}) gn.scale.assign(n.scale.begin(), n.scale.end());
  }
  if (keep_targets && n.mesh >= 0 && rig.meshes[n.mesh].skin >= 0 &&
      static_cast<size_t>(rig.meshes[n.mesh].skin) < rig.skins.size()) {
    gn.skin = rig.meshes[n.mesh].skin;
  }
  return gn;
}

// The nodes and the scene. Meshes whose primitives were skinned are already in scene space: they
// hang from a root node of their own (glTF ignores a skinned mesh node's transform; without the
// skin, a viewer would not).
void WriteNodes(const Rig& rig, const BlendedRig& blended, bool keep_targets, tinygltf::Model& m) {
  std::vector<uint8_t> skinned_mesh(rig.meshes.size(), 0);
  for (size_t pi = 0; pi < rig.primitives.size(); ++pi) {
    if (blended.primitives[pi].skinned && !keep_targets) skinned_mesh[rig.primitives[pi].mesh] = 1;
  }
  for (size_t i = 0; i < rig.nodes.size(); ++i) {
    tinygltf::Node gn = WriteNode(rig, blended, i, keep_targets,
                                  rig.nodes[i].mesh >= 0 && skinned_mesh[rig.nodes[i].mesh]);
    // tinygltf writes a node with no properties as null, which glTF forbids: name it.
    if (gn.name.empty() && gn.mesh < 0 && gn.children.empty() && gn.matrix.empty() &&
        gn.translation.empty() && gn.rotation.empty() && gn.scale.empty()) {
      gn.name = "node_" + std::to_string(m.nodes.size());
    }
    m.nodes.push_back(gn);
  }
  tinygltf::Scene scene;
  scene.nodes = rig.scene_roots;
  for (size_t mi = 0; mi < rig.meshes.size(); ++mi) {
    if (!skinned_mesh[mi]) continue;
    tinygltf::Node gn;
    gn.name = (rig.meshes[mi].name.empty() ? "mesh" + std::to_string(mi) : rig.meshes[mi].name) +
              " (skinned)";
    gn.mesh = static_cast<int>(mi);
    scene.nodes.push_back(static_cast<int>(m.nodes.size()));
    m.nodes.push_back(gn);
  }
  m.scenes.push_back(scene);
  m.defaultScene = 0;
}

// One sampler, linear (glTF has no Bezier: sampled at 60 a second); a weights sampler padded to
// `targets` values per key (a tool that appended shapes, mirror or derive, leaves the clip's keys
// short: the new targets get 0). -1 when it cannot be mapped (dropped).
int WriteSampler(const AnimationSampler& sampler, size_t targets, GlbBuilder& b,
                 tinygltf::Animation& ga) {
  const AnimationSampler s = LinearSampler(sampler, 60.0f);
  const bool scalar =
      s.components != 3 && s.components != 4;  // Morph weights: one scalar per target.
  std::vector<float> padded;
  std::span<const float> values = s.values;
  if (targets && s.components != targets) {
    if (s.components > targets || s.interpolation == Interpolation::kCubicSpline) return -1;
    for (size_t k = 0; k < s.times.size(); ++k) {
      padded.insert(padded.end(), s.values.begin() + static_cast<std::ptrdiff_t>(k * s.components),
                    s.values.begin() + static_cast<std::ptrdiff_t>((k + 1) * s.components));
      padded.resize((k + 1) * targets, 0.0f);
    }
    values = padded;
  }
  tinygltf::AnimationSampler gs;
  gs.input = b.Data(s.times, TINYGLTF_TYPE_SCALAR, s.times.size(), true);
  const size_t per_key = s.interpolation == Interpolation::kCubicSpline ? 3 : 1;
  gs.output = b.Data(values,
                     scalar              ? TINYGLTF_TYPE_SCALAR
                     : s.components == 3 ? TINYGLTF_TYPE_VEC3
                                         : TINYGLTF_TYPE_VEC4,
                     scalar ? values.size() : s.times.size() * per_key, false);
  gs.interpolation = s.interpolation == Interpolation::kStep          ? "STEP"
                     : s.interpolation == Interpolation::kCubicSpline ? "CUBICSPLINE"
                                                                      : "LINEAR";
  ga.samplers.push_back(gs);
  return static_cast<int>(ga.samplers.size() - 1);
}

// Clip ci, MMD's grants and IK (which have no glTF form) solved into it; nothing when no channel is
// left.
void WriteClip(const Rig& rig, size_t ci, GlbBuilder& b, tinygltf::Model& m) {
  const AnimationInfo clip = ClipWithConstraintsSolved(rig, static_cast<int>(ci), 30.0f);
  tinygltf::Animation ga;
  ga.name = clip.name;
  std::vector<size_t> targets(clip.sampler_data.size(),
                              0);  // A weights sampler's: its node's mesh's targets.
  for (const AnimationChannel& c : clip.channel_data) {
    if (c.path == ChannelPath::kWeights && rig.nodes[c.node].mesh >= 0)
      targets[c.sampler] = rig.meshes[rig.nodes[c.node].mesh].target_shapes.size();
  }
  std::vector<int> sampler_of(clip.sampler_data.size(), -1);
  for (size_t si = 0; si < clip.sampler_data.size(); ++si)
    sampler_of[si] = WriteSampler(clip.sampler_data[si], targets[si], b, ga);
  for (const AnimationChannel& c : clip.channel_data) {
    if (sampler_of[c.sampler] < 0) continue;
    tinygltf::AnimationChannel gc;
    gc.sampler = sampler_of[c.sampler];
    gc.target_node = c.node;
    gc.target_path = c.path == ChannelPath::kTranslation ? "translation"
                     : c.path == ChannelPath::kRotation  ? "rotation"
                     : c.path == ChannelPath::kScale     ? "scale"
                                                         : "weights";
    ga.channels.push_back(gc);
  }
  if (!ga.channels.empty()) m.animations.push_back(ga);
}

}  // namespace

Result<std::string> ExportGlb(const Rig& rig, const BlendedRig& blended,
                              std::span<const float> weights, std::span<const Warning> warnings,
                              const ExportOptions& options) {
  tinygltf::Model m;
  GlbBuilder b(m);
  m.asset.version = "2.0";
  m.asset.generator = "facespace";
  m.asset.copyright = rig.credit;
  std::vector<Warning> all_warnings(warnings.begin(), warnings.end());
  if (options.keep_targets) WarnUnexported(rig, all_warnings);
  m.asset.extras = ToValue(AssetExtras(rig, weights, all_warnings));
  WriteMaterials(rig, blended, b, m);
  WriteMeshes(rig, blended, weights, options.keep_targets, b, m);
  WriteNodes(rig, blended, options.keep_targets, m);
  if (options.keep_targets) {
    for (const Skin& skin : rig.skins) {
      tinygltf::Skin gs;
      gs.name = skin.name;
      gs.joints = skin.joints;
      gs.inverseBindMatrices =
          b.Data(skin.inverse_bind, TINYGLTF_TYPE_MAT4, skin.joints.size(), false);
      m.skins.push_back(gs);
    }
    for (size_t ci = 0; options.clips && ci < rig.animations.size(); ++ci) WriteClip(rig, ci, b, m);
  }
  m.buffers[0].data.resize((m.buffers[0].data.size() + 3) & ~size_t{3}, 0);
  if (m.buffers[0].data.empty()) m.buffers.clear();
  std::ostringstream os;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&m, os, false, true))
    return InvalidArgument("glb writer failed");
  return os.str();
}

}  // namespace writers

}  // namespace facespace::formats
