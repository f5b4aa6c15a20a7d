// glTF 2.0 import: tinygltf parses, we convert once into core types, range-checking every
// index and byte offset on the way. EXT_meshopt_compression is decoded (meshoptimizer)
// before tinygltf sees the file, since tinygltf 2.7 does not know it.
#include <tiny_gltf.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <meshoptimizer.h>
#include <nlohmann/json.hpp>

#include "facespace/formats/io.h"
#include "common/json_depth.h"
#include "gltf/gltf_common.h"

namespace facespace {

namespace {

using nlohmann::json;

// ---- tinygltf callbacks -------------------------------------------------------------------

bool KeepImageBytes(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                    const unsigned char* bytes, int size, void*) {
  image->image.assign(bytes, bytes + std::max(size, 0));
  image->as_is = true;
  return true;
}

bool NoFileExists(const std::string&, void*) { return false; }
std::string NoExpand(const std::string& path, void*) { return path; }
bool NoRead(std::vector<unsigned char>*, std::string* err, const std::string& path, void*) {
  if (err) *err += "external file '" + path + "' refused: uploads must embed their buffers\n";
  return false;
}
bool NoWrite(std::string*, const std::string&, const std::vector<unsigned char>&, void*) { return false; }

// ---- model -> rig -------------------------------------------------------------------------

std::vector<std::string> TargetNames(const tinygltf::Value& extras) {
  std::vector<std::string> names;
  if (!extras.IsObject() || !extras.Has("targetNames")) return names;
  const tinygltf::Value& list = extras.Get("targetNames");
  if (!list.IsArray()) return names;
  for (size_t i = 0; i < list.ArrayLen(); ++i) {
    names.push_back(list.Get(static_cast<int>(i)).IsString() ? list.Get(static_cast<int>(i)).Get<std::string>() : "");
  }
  return names;
}

bool IsPng(const std::vector<unsigned char>& b) {
  return b.size() > 8 && b[0] == 0x89 && b[1] == 'P' && b[2] == 'N' && b[3] == 'G';
}
bool IsJpeg(const std::vector<unsigned char>& b) {
  return b.size() > 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF;
}

// KHR_texture_transform of a textureInfo as an affine uv map, if any.
bool TextureTransform(const tinygltf::ExtensionMap& ext, float m[6]) {
  auto it = ext.find("KHR_texture_transform");
  if (it == ext.end() || !it->second.IsObject()) return false;
  const tinygltf::Value& v = it->second;
  float off[2] = {0, 0}, scale[2] = {1, 1}, rot = 0;
  auto read = [&](const char* key, float* dst, int n) {
    if (!v.Has(key)) return;
    const tinygltf::Value& a = v.Get(key);
    if (n == 1 && a.IsNumber()) dst[0] = static_cast<float>(a.GetNumberAsDouble());
    if (n > 1 && a.IsArray() && a.ArrayLen() == static_cast<size_t>(n)) {
      for (int i = 0; i < n; ++i) {
        if (a.Get(i).IsNumber()) dst[i] = static_cast<float>(a.Get(i).GetNumberAsDouble());
      }
    }
  };
  read("offset", off, 2);
  read("scale", scale, 2);
  read("rotation", &rot, 1);
  const float c = std::cos(rot), s = std::sin(rot);
  // uv' = T * R * S * uv, with R = [[c, s], [-s, c]] as the extension defines it.
  m[0] = c * scale[0];
  m[1] = s * scale[1];
  m[2] = off[0];
  m[3] = -s * scale[0];
  m[4] = c * scale[1];
  m[5] = off[1];
  return true;
}

Status ConvertPrimitive(const tinygltf::Model& model, const tinygltf::Primitive& src, int mesh_index,
                        int prim_index, Primitive& p, std::vector<Warning>& warnings) {
  const std::string what = "mesh " + std::to_string(mesh_index) + " primitive " + std::to_string(prim_index);
  p.mesh = mesh_index;
  p.index_in_mesh = prim_index;
  auto attr = [&](const char* name) {
    auto it = src.attributes.find(name);
    return it == src.attributes.end() ? -1 : it->second;
  };
  int comps = 0;
  const int pos = attr("POSITION");
  if (pos < 0) return InvalidArgument(what + ": has no POSITION");
  if (Status s = ReadAccessor(model, pos, p.positions, comps, what + " POSITION"); !s.ok()) return s;
  if (comps != 3) return InvalidArgument(what + ": POSITION must be VEC3");
  const size_t n = p.vertex_count();
  auto read_attr = [&](const char* name, std::vector<float>& dst, int want_min, int want_max) -> Status {
    const int a = attr(name);
    if (a < 0) return Status::Ok();
    int c = 0;
    if (Status s = ReadAccessor(model, a, dst, c, what + " " + name); !s.ok()) return s;
    if (c < want_min || c > want_max) return InvalidArgument(what + ": " + name + " has the wrong type");
    if (dst.size() != n * c) {
      return InvalidArgument(what + ": " + name + " has " + std::to_string(dst.size() / c) +
                             " elements but POSITION has " + std::to_string(n));
    }
    if (c == 3 && want_max == 4) {  // COLOR_0 as VEC3: add alpha 1.
      std::vector<float> rgba(n * 4, 1.0f);
      for (size_t v = 0; v < n; ++v) std::copy_n(&dst[3 * v], 3, &rgba[4 * v]);
      dst.swap(rgba);
    }
    return Status::Ok();
  };
  if (Status s = read_attr("NORMAL", p.normals, 3, 3); !s.ok()) return s;
  if (Status s = read_attr("TANGENT", p.tangents, 4, 4); !s.ok()) return s;
  if (Status s = read_attr("TEXCOORD_0", p.texcoords, 2, 2); !s.ok()) return s;
  if (Status s = read_attr("COLOR_0", p.colors, 3, 4); !s.ok()) return s;
  {
    // Our own application attribute: the source vertex of each vertex (rig.h), whole numbers.
    std::vector<float> source;
    if (Status s = read_attr("_SOURCE_VERTEX", source, 1, 1); !s.ok()) return s;
    p.source_vertices.reserve(source.size());
    for (float f : source) {
      if (!(f >= 0.0f && f < static_cast<float>(Primitive::kMaxSourceVertex)) || f != std::floor(f)) {
        return InvalidArgument(what + ": _SOURCE_VERTEX holds " + std::to_string(f) + ", not a vertex number");
      }
      p.source_vertices.push_back(static_cast<uint32_t>(f));
    }
  }
  p.source_has_normals = !p.normals.empty();
  for (size_t v = 0; v < p.normals.size(); v += 3) {  // Quantized normals are not unit length.
    float* nn = &p.normals[v];
    const float len = std::sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
    if (len > 0.0f && std::fabs(len - 1.0f) > 1e-6f) {
      nn[0] /= len;
      nn[1] /= len;
      nn[2] /= len;
    }
  }

  // Skinning influences from every JOINTS_n/WEIGHTS_n pair, normalised per vertex.
  for (int set = 0;; ++set) {
    const std::string jn = "JOINTS_" + std::to_string(set), wn = "WEIGHTS_" + std::to_string(set);
    const int ja = attr(jn.c_str()), wa = attr(wn.c_str());
    if (ja < 0 && wa < 0) break;
    if (ja < 0 || wa < 0) return InvalidArgument(what + ": " + (ja < 0 ? jn : wn) + " is missing its pair");
    std::vector<float> j, w;
    int jc = 0, wc = 0;
    if (Status s = ReadAccessor(model, ja, j, jc, what + " " + jn); !s.ok()) return s;
    if (Status s = ReadAccessor(model, wa, w, wc, what + " " + wn); !s.ok()) return s;
    if (jc != 4 || wc != 4 || j.size() != 4 * n || w.size() != 4 * n) {
      return InvalidArgument(what + ": " + jn + "/" + wn + " must be VEC4 with one element per vertex");
    }
    if (set > 15) return InvalidArgument(what + ": too many JOINTS_n sets");
    p.joints.resize((set + 1) * 4 * n);
    p.joint_weights.resize((set + 1) * 4 * n);
    // Re-lay out as `influences` consecutive entries per vertex.
    std::vector<uint16_t> joints(p.joints.size());
    std::vector<float> weights(p.joint_weights.size());
    const size_t k_old = 4 * static_cast<size_t>(set), k_new = k_old + 4;
    for (size_t v = 0; v < n; ++v) {
      for (size_t k = 0; k < k_old; ++k) {
        joints[v * k_new + k] = p.joints[v * k_old + k];
        weights[v * k_new + k] = p.joint_weights[v * k_old + k];
      }
      for (size_t k = 0; k < 4; ++k) {
        const float jf = j[4 * v + k];
        if (jf < 0.0f || jf > 65535.0f) return InvalidArgument(what + ": " + jn + " has an invalid joint index");
        joints[v * k_new + k_old + k] = static_cast<uint16_t>(jf);
        weights[v * k_new + k_old + k] = std::max(w[4 * v + k], 0.0f);
      }
    }
    p.joints.swap(joints);
    p.joint_weights.swap(weights);
    p.influences = k_new;
  }
  size_t renormalised = 0;
  for (size_t v = 0; v < n && p.influences; ++v) {
    float sum = 0.0f;
    for (size_t k = 0; k < p.influences; ++k) sum += p.joint_weights[v * p.influences + k];
    if (std::fabs(sum - 1.0f) > 2e-3f) ++renormalised;
    if (sum <= 0.0f) {
      p.joint_weights[v * p.influences] = 1.0f;  // No influence at all: follow the first joint.
      continue;
    }
    for (size_t k = 0; k < p.influences; ++k) p.joint_weights[v * p.influences + k] /= sum;
  }
  if (renormalised) {
    warnings.push_back({"weights_normalised",
                        what + ": the skin weights of " + std::to_string(renormalised) + " of " + std::to_string(n) +
                            " vertices did not sum to 1 and were normalised",
                        "", static_cast<double>(renormalised), true});
  }

  std::vector<uint32_t> indices;
  if (src.indices >= 0) {
    if (Status s = ReadIndices(model, src.indices, indices, what + " indices"); !s.ok()) return s;
  } else {
    indices.resize(n);
    for (size_t i = 0; i < n; ++i) indices[i] = static_cast<uint32_t>(i);
  }
  for (uint32_t i : indices) {
    if (i >= n) {
      return InvalidArgument(what + ": index " + std::to_string(i) + " beyond vertex count " + std::to_string(n));
    }
  }
  switch (src.mode) {
    case TINYGLTF_MODE_TRIANGLES:
    case -1:
      if (indices.size() % 3) return InvalidArgument(what + ": triangle index count not a multiple of 3");
      p.indices = std::move(indices);
      break;
    case TINYGLTF_MODE_TRIANGLE_STRIP:
      for (size_t i = 2; i < indices.size(); ++i) {
        const bool odd = i % 2;
        p.indices.insert(p.indices.end(), {indices[i - 2], indices[odd ? i : i - 1], indices[odd ? i - 1 : i]});
      }
      break;
    case TINYGLTF_MODE_TRIANGLE_FAN:
      for (size_t i = 2; i < indices.size(); ++i) p.indices.insert(p.indices.end(), {indices[i - 1], indices[i], indices[0]});
      break;
    case TINYGLTF_MODE_POINTS:
      p.mode = PrimitiveMode::kPoints;
      p.indices = std::move(indices);
      break;
    case TINYGLTF_MODE_LINE:
      p.mode = PrimitiveMode::kLines;
      if (indices.size() % 2) indices.pop_back();
      p.indices = std::move(indices);
      break;
    case TINYGLTF_MODE_LINE_LOOP:
    case TINYGLTF_MODE_LINE_STRIP:
      p.mode = PrimitiveMode::kLines;
      for (size_t i = 1; i < indices.size(); ++i) p.indices.insert(p.indices.end(), {indices[i - 1], indices[i]});
      if (src.mode == TINYGLTF_MODE_LINE_LOOP && indices.size() > 2) p.indices.insert(p.indices.end(), {indices.back(), indices[0]});
      break;
    default:
      return InvalidArgument(what + ": unknown mode " + std::to_string(src.mode));
  }
  if (src.material >= static_cast<int>(model.materials.size())) return InvalidArgument(what + ": material out of range");
  p.material = src.material;

  // Morph targets, made sparse: a vertex is kept when any of its deltas is non-zero.
  p.targets.resize(src.targets.size());
  for (size_t t = 0; t < src.targets.size(); ++t) {
    const std::string twhat = what + " target " + std::to_string(t);
    std::vector<float> dp, dn, dt;
    for (const auto& [name, acc] : src.targets[t]) {
      std::vector<float>* dst = name == "POSITION" ? &dp : name == "NORMAL" ? &dn : name == "TANGENT" ? &dt : nullptr;
      if (!dst) continue;
      if (Status s = ReadAccessor(model, acc, *dst, comps, twhat + " " + name); !s.ok()) return s;
      if (comps != 3) return InvalidArgument(twhat + ": " + name + " deltas must be VEC3");
      if (dst->size() != 3 * n) {
        return InvalidArgument(twhat + ": " + name + " has " + std::to_string(dst->size() / 3) +
                               " vertices, the base has " + std::to_string(n));
      }
    }
    SparseTarget& st = p.targets[t];
    for (size_t v = 0; v < n; ++v) {
      bool moved = false;
      for (int c = 0; c < 3; ++c) {
        moved |= (!dp.empty() && dp[3 * v + c] != 0.0f) || (!dn.empty() && dn[3 * v + c] != 0.0f) ||
                 (!dt.empty() && dt[3 * v + c] != 0.0f);
      }
      if (!moved) continue;
      st.indices.push_back(static_cast<uint32_t>(v));
      for (int c = 0; c < 3; ++c) {
        st.position_deltas.push_back(dp.empty() ? 0.0f : dp[3 * v + c]);
        if (!dn.empty()) st.normal_deltas.push_back(dn[3 * v + c]);
        if (!dt.empty() && !p.tangents.empty()) st.tangent_deltas.push_back(dt[3 * v + c]);
      }
    }
    // UV deltas (TEXCOORD_0 targets, which glTF 2.0 allows), apart: they move other vertices.
    const auto uv = src.targets[t].find("TEXCOORD_0");
    if (uv == src.targets[t].end() || p.texcoords.empty()) continue;
    if (Status s = ReadAccessor(model, uv->second, dp, comps, twhat + " TEXCOORD_0"); !s.ok()) return s;
    if (comps != 2 || dp.size() != 2 * n) return InvalidArgument(twhat + ": TEXCOORD_0 deltas must be VEC2, one per vertex");
    for (size_t v = 0; v < n; ++v) {
      if (dp[2 * v] == 0.0f && dp[2 * v + 1] == 0.0f) continue;
      st.texcoord_indices.push_back(static_cast<uint32_t>(v));
      st.texcoord_deltas.insert(st.texcoord_deltas.end(), {dp[2 * v], dp[2 * v + 1]});
    }
  }
  return Status::Ok();
}

Status ConvertModel(const tinygltf::Model& model, Rig& rig) {
  // Images: keep PNG and JPEG bytes; others cannot be decoded here and are dropped.
  std::vector<int> image_map(model.images.size(), -1);
  for (size_t i = 0; i < model.images.size(); ++i) {
    const tinygltf::Image& im = model.images[i];
    if (IsPng(im.image) || IsJpeg(im.image)) {
      image_map[i] = static_cast<int>(rig.images.size());
      rig.images.push_back({im.name, IsPng(im.image) ? "image/png" : "image/jpeg", im.image});
    } else {
      const std::string kind = !im.mimeType.empty() ? im.mimeType : "unknown format";
      rig.load_warnings.push_back({"texture_dropped",
                                   "image " + std::to_string(i) + " (" + kind +
                                       ") cannot be decoded here and was dropped; the geometry is kept",
                                   im.name, 0.0, false});
    }
  }
  // The rig's image of a glTF texture index, or -1 (no such texture, or its image was dropped).
  const auto image_of_texture = [&model, &image_map](int texture) {
    if (texture < 0 || static_cast<size_t>(texture) >= model.textures.size()) return -1;
    const int src = model.textures[static_cast<size_t>(texture)].source;
    return src >= 0 && static_cast<size_t>(src) < image_map.size() ? image_map[static_cast<size_t>(src)] : -1;
  };
  std::vector<std::pair<int, std::array<float, 6>>> material_uv_transform(model.materials.size(), {-1, {}});
  for (size_t i = 0; i < model.materials.size(); ++i) {
    const tinygltf::Material& sm = model.materials[i];
    Material m;
    m.name = sm.name;
    const auto& pbr = sm.pbrMetallicRoughness;
    for (size_t c = 0; c < 4 && c < pbr.baseColorFactor.size(); ++c) m.base_color_factor[c] = static_cast<float>(pbr.baseColorFactor[c]);
    m.metallic_factor = static_cast<float>(pbr.metallicFactor);
    m.roughness_factor = static_cast<float>(pbr.roughnessFactor);
    m.double_sided = sm.doubleSided;
    m.alpha_mode = sm.alphaMode.empty() ? "OPAQUE" : sm.alphaMode;
    m.alpha_cutoff = static_cast<float>(sm.alphaCutoff);
    // The other maps: the rig's image of a texture index, or -1. Only maps on TEXCOORD_0 without a
    // texture transform are kept (the base colour's transform is applied to the UVs); one left out
    // is said in a warning.
    const auto image_of = [&](const char* what, int texture, int texcoord, const tinygltf::ExtensionMap& extensions) {
      if (texture < 0 || static_cast<size_t>(texture) >= model.textures.size()) return -1;
      std::array<float, 6> ignored;
      const bool transformed = TextureTransform(extensions, ignored.data());
      if (texcoord != 0 || transformed) {
        rig.load_warnings.push_back({"material_map_dropped",
                                     "material '" + sm.name + "': its " + what + " map is " +
                                         (transformed ? "under a texture transform" : "on TEXCOORD_" + std::to_string(texcoord)) +
                                         ", which is not kept; it renders without it",
                                     sm.name, 0.0, false});
        return -1;
      }
      return image_of_texture(texture);
    };
    const auto& mr = pbr.metallicRoughnessTexture;
    m.metallic_roughness_image = image_of("metallic-roughness", mr.index, mr.texCoord, mr.extensions);
    m.normal_image = image_of("normal", sm.normalTexture.index, sm.normalTexture.texCoord, sm.normalTexture.extensions);
    m.normal_scale = static_cast<float>(sm.normalTexture.scale);
    m.occlusion_image = image_of("occlusion", sm.occlusionTexture.index, sm.occlusionTexture.texCoord, sm.occlusionTexture.extensions);
    m.occlusion_strength = static_cast<float>(std::clamp(sm.occlusionTexture.strength, 0.0, 1.0));
    m.emissive_image = image_of("emissive", sm.emissiveTexture.index, sm.emissiveTexture.texCoord, sm.emissiveTexture.extensions);
    for (size_t c = 0; c < 3 && c < sm.emissiveFactor.size(); ++c) m.emissive_factor[c] = static_cast<float>(sm.emissiveFactor[c]);
    const int tex = pbr.baseColorTexture.index;
    if (tex >= 0 && static_cast<size_t>(tex) < model.textures.size()) {
      m.base_color_image = image_of_texture(tex);
      m.base_color_texcoord = pbr.baseColorTexture.texCoord;
      std::array<float, 6> xf;
      if (TextureTransform(pbr.baseColorTexture.extensions, xf.data())) {
        material_uv_transform[i] = {pbr.baseColorTexture.texCoord, xf};
      }
    }
    rig.materials.push_back(m);
  }

  // Meshes, primitives and shapes named across the file.
  std::map<std::string, uint32_t> shape_by_name;
  for (size_t mi = 0; mi < model.meshes.size(); ++mi) {
    const tinygltf::Mesh& sm = model.meshes[mi];
    Mesh mesh;
    mesh.name = sm.name;
    size_t target_count = sm.primitives.empty() ? 0 : sm.primitives[0].targets.size();
    std::vector<std::string> names = TargetNames(sm.extras);
    for (const auto& prim : sm.primitives) {
      if (prim.targets.size() != target_count) {
        return InvalidArgument("mesh " + std::to_string(mi) + ": primitives have different morph target counts");
      }
      if (names.empty()) names = TargetNames(prim.extras);
    }
    std::vector<std::string> used;
    for (size_t t = 0; t < target_count; ++t) {
      std::string name = t < names.size() ? names[t] : "";
      if (name.empty()) {
        auto it = sm.primitives[0].targets[t].find("POSITION");
        if (it != sm.primitives[0].targets[t].end() && it->second >= 0 &&
            static_cast<size_t>(it->second) < model.accessors.size()) {
          name = model.accessors[it->second].name;
        }
      }
      if (name.empty()) name = "target_" + std::to_string(t);
      if (std::find(used.begin(), used.end(), name) != used.end()) {
        const std::string unique = name + "#" + std::to_string(t);
        rig.load_warnings.push_back({"duplicate_target_name",
                                     "mesh " + std::to_string(mi) + " names two targets '" + name +
                                         "'; target " + std::to_string(t) + " is called '" + unique + "'",
                                     unique, 0.0, false});
        name = unique;
      }
      used.push_back(name);
      auto [it, inserted] = shape_by_name.emplace(name, static_cast<uint32_t>(rig.shapes.size()));
      if (inserted) {
        Shape s;
        s.name = name;
        if (t < sm.weights.size() && std::isfinite(sm.weights[t])) s.default_weight = static_cast<float>(sm.weights[t]);
        rig.shapes.push_back(s);
      }
      mesh.target_shapes.push_back(it->second);
    }
    for (size_t pi = 0; pi < sm.primitives.size(); ++pi) {
      Primitive p;
      if (Status s = ConvertPrimitive(model, sm.primitives[pi], static_cast<int>(mi), static_cast<int>(pi), p, rig.load_warnings);
          !s.ok()) {
        return s;
      }
      if (p.material >= 0 && material_uv_transform[p.material].first == 0 && !p.texcoords.empty()) {
        const auto& xf = material_uv_transform[p.material].second;
        const auto transform = [&xf](std::vector<float>& uv, float shift) {  // UV deltas: the linear part alone.
          for (size_t v = 0; v < uv.size(); v += 2) {
            const float u = uv[v], w = uv[v + 1];
            uv[v] = xf[0] * u + xf[1] * w + shift * xf[2];
            uv[v + 1] = xf[3] * u + xf[4] * w + shift * xf[5];
          }
        };
        transform(p.texcoords, 1.0f);
        for (SparseTarget& t : p.targets) transform(t.texcoord_deltas, 0.0f);
      }
      FinalizePrimitive(p);
      mesh.primitives.push_back(static_cast<int>(rig.primitives.size()));
      rig.primitives.push_back(std::move(p));
    }
    rig.meshes.push_back(std::move(mesh));
  }

  // Nodes.
  rig.nodes.resize(model.nodes.size());
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    const tinygltf::Node& sn = model.nodes[i];
    Node& n = rig.nodes[i];
    n.name = sn.name;
    n.mesh = sn.mesh;
    if (n.mesh >= static_cast<int>(rig.meshes.size())) return InvalidArgument("node " + std::to_string(i) + ": mesh out of range");
    if (sn.matrix.size() == 16) {
      n.has_matrix = true;
      for (int k = 0; k < 16; ++k) n.matrix[k] = static_cast<float>(sn.matrix[k]);
    }
    if (sn.translation.size() == 3) for (int k = 0; k < 3; ++k) n.translation[k] = static_cast<float>(sn.translation[k]);
    if (sn.rotation.size() == 4) for (int k = 0; k < 4; ++k) n.rotation[k] = static_cast<float>(sn.rotation[k]);
    if (sn.scale.size() == 3) for (int k = 0; k < 3; ++k) n.scale[k] = static_cast<float>(sn.scale[k]);
    for (float f : n.matrix) if (!std::isfinite(f)) return InvalidArgument("node " + std::to_string(i) + ": non-finite matrix");
    for (float f : n.translation) if (!std::isfinite(f)) return InvalidArgument("node " + std::to_string(i) + ": non-finite translation");
    for (float f : n.rotation) if (!std::isfinite(f)) return InvalidArgument("node " + std::to_string(i) + ": non-finite rotation");
    for (float f : n.scale) if (!std::isfinite(f)) return InvalidArgument("node " + std::to_string(i) + ": non-finite scale");
  }
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    for (int c : model.nodes[i].children) {
      if (c < 0 || static_cast<size_t>(c) >= rig.nodes.size() || rig.nodes[c].parent >= 0 || c == static_cast<int>(i)) {
        return InvalidArgument("node " + std::to_string(i) + ": child " + std::to_string(c) + " is invalid or has two parents");
      }
      rig.nodes[c].parent = static_cast<int>(i);
      rig.nodes[i].children.push_back(c);
    }
  }
  // A cycle leaves nodes that no root reaches; glTF forbids it.
  {
    std::vector<int> stack;
    std::vector<uint8_t> seen(rig.nodes.size(), 0);
    for (size_t i = 0; i < rig.nodes.size(); ++i) if (rig.nodes[i].parent < 0) stack.push_back(static_cast<int>(i));
    size_t reached = 0;
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      if (seen[i]) continue;
      seen[i] = 1;
      ++reached;
      for (int c : rig.nodes[i].children) stack.push_back(c);
    }
    if (reached != rig.nodes.size()) return InvalidArgument("the node hierarchy has a cycle");
  }
  const int scene = model.defaultScene >= 0 ? model.defaultScene : 0;
  if (static_cast<size_t>(scene) < model.scenes.size()) {
    for (int r : model.scenes[scene].nodes) {
      if (r < 0 || static_cast<size_t>(r) >= rig.nodes.size() || rig.nodes[r].parent >= 0) {
        return InvalidArgument("scene " + std::to_string(scene) + ": invalid root node " + std::to_string(r));
      }
      rig.scene_roots.push_back(r);
    }
  } else {
    for (size_t i = 0; i < rig.nodes.size(); ++i) if (rig.nodes[i].parent < 0) rig.scene_roots.push_back(static_cast<int>(i));
  }
  // Unnamed meshes take the name of the nearest named node above the first node that shows
  // them ("head", "teeth" in FaceCap).
  for (const Node& n : rig.nodes) {
    if (n.mesh < 0 || !rig.meshes[n.mesh].name.empty()) continue;
    for (const Node* up = &n; up; up = up->parent >= 0 ? &rig.nodes[up->parent] : nullptr) {
      if (!up->name.empty()) {
        rig.meshes[n.mesh].name = up->name;
        break;
      }
    }
  }
  rig.skin_count = model.skins.size();
  for (size_t si = 0; si < model.skins.size(); ++si) {
    const auto& skin = model.skins[si];
    rig.joint_count += skin.joints.size();
    Skin s{skin.name, {}, {}};
    for (int j : skin.joints) {
      if (j < 0 || static_cast<size_t>(j) >= rig.nodes.size()) return InvalidArgument("skin '" + skin.name + "': joint out of range");
      s.joints.push_back(j);
    }
    if (skin.inverseBindMatrices >= 0) {
      int comps = 0;
      if (Status st = ReadAccessor(model, skin.inverseBindMatrices, s.inverse_bind, comps, "skin " + std::to_string(si) + " inverseBindMatrices");
          !st.ok()) {
        return st;
      }
      if (comps != 16 || s.inverse_bind.size() != 16 * s.joints.size()) {
        return InvalidArgument("skin " + std::to_string(si) + ": needs one MAT4 inverse bind matrix per joint");
      }
    } else {
      for (size_t j = 0; j < s.joints.size(); ++j) s.inverse_bind.insert(s.inverse_bind.end(), {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});
    }
    rig.skins.push_back(std::move(s));
  }
  // A mesh is skinned by the skin of the first node that shows it with one.
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    const int m = model.nodes[i].mesh, sk = model.nodes[i].skin;
    if (m < 0 || sk < 0) continue;
    if (static_cast<size_t>(sk) >= rig.skins.size()) return InvalidArgument("node " + std::to_string(i) + ": skin out of range");
    if (rig.meshes[m].skin < 0) rig.meshes[m].skin = sk;
  }
  for (const Mesh& mesh : rig.meshes) {
    if (mesh.skin < 0) continue;
    const size_t joints = rig.skins[mesh.skin].joints.size();
    for (int pi : mesh.primitives) {
      for (uint16_t j : rig.primitives[pi].joints) {
        if (j >= joints) return InvalidArgument("mesh '" + mesh.name + "': joint index " + std::to_string(j) + " beyond its skin's " + std::to_string(joints) + " joints");
      }
    }
  }
  for (size_t ai = 0; ai < model.animations.size(); ++ai) {
    const auto& anim = model.animations[ai];
    const std::string where = "animation " + std::to_string(ai);
    AnimationInfo info;
    info.name = anim.name.empty() ? "animation_" + std::to_string(ai) : anim.name;
    info.channels = anim.channels.size();
    for (size_t si = 0; si < anim.samplers.size(); ++si) {
      const auto& src = anim.samplers[si];
      AnimationSampler smp;
      int comps = 0;
      if (Status st = ReadAccessor(model, src.input, smp.times, comps, where + " input"); !st.ok()) return st;
      if (comps != 1 || smp.times.empty()) return InvalidArgument(where + ": sampler input must be non-empty scalars");
      for (size_t k = 1; k < smp.times.size(); ++k) {
        if (!(smp.times[k] > smp.times[k - 1])) return InvalidArgument(where + ": keyframe times must increase");
      }
      if (Status st = ReadAccessor(model, src.output, smp.values, comps, where + " output"); !st.ok()) return st;
      smp.interpolation = src.interpolation == "STEP" ? Interpolation::kStep
                          : src.interpolation == "CUBICSPLINE" ? Interpolation::kCubicSpline : Interpolation::kLinear;
      const size_t per_key = smp.values.size() / smp.times.size() / (smp.interpolation == Interpolation::kCubicSpline ? 3 : 1);
      if (per_key == 0 || per_key * smp.times.size() * (smp.interpolation == Interpolation::kCubicSpline ? 3 : 1) != smp.values.size()) {
        return InvalidArgument(where + ": sampler output does not match its input");
      }
      smp.components = per_key;
      info.duration = std::max(info.duration, smp.times.back());
      info.sampler_data.push_back(std::move(smp));
    }
    for (const auto& ch : anim.channels) {
      if (ch.sampler < 0 || static_cast<size_t>(ch.sampler) >= info.sampler_data.size() || ch.target_node < 0 ||
          static_cast<size_t>(ch.target_node) >= rig.nodes.size()) {
        return InvalidArgument(where + ": channel with an invalid sampler or node");
      }
      AnimationChannel c{ch.sampler, ch.target_node, ChannelPath::kTranslation};
      const size_t comps = info.sampler_data[ch.sampler].components;
      size_t want = 0;
      if (ch.target_path == "translation") { c.path = ChannelPath::kTranslation; want = 3; }
      else if (ch.target_path == "rotation") { c.path = ChannelPath::kRotation; want = 4; }
      else if (ch.target_path == "scale") { c.path = ChannelPath::kScale; want = 3; }
      else if (ch.target_path == "weights") {
        c.path = ChannelPath::kWeights;
        info.has_weights = true;
        const int m = rig.nodes[ch.target_node].mesh;
        if (m < 0) return InvalidArgument(where + ": a weights channel targets a node without a mesh");
        want = rig.meshes[m].target_shapes.size();
      } else {
        continue;  // "pointer" and others: not ours to animate.
      }
      if (comps != want) return InvalidArgument(where + ": channel " + ch.target_path + " has " + std::to_string(comps) + " values per key, expected " + std::to_string(want));
      info.channel_data.push_back(c);
    }
    rig.animations.push_back(std::move(info));
  }
  DetectSymmetricPartners(rig);
  CountMovedVertices(rig);
  RepairNames(rig);
  return ValidateRig(rig);
}

const char* kSupportedRequired[] = {"KHR_mesh_quantization", "EXT_meshopt_compression", "KHR_texture_basisu",
                                    "KHR_texture_transform", "KHR_materials_unlit", "EXT_texture_webp",
                                    "KHR_materials_emissive_strength"};

}  // namespace

Result<Rig> LoadGltfMemory(std::span<const unsigned char> bytes, const std::string& base_dir,
                           const LoadOptions& options) {
  if (bytes.size() > 0xFFFFFFF0u) return InvalidArgument("file too large for glTF");
  const bool is_glb = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
  std::vector<unsigned char> decoded;
  if (is_glb) {
    std::string text;  // Its depth checked before any recursive reader sees it.
    std::span<const unsigned char> bin;
    if (Status s = SplitGlb(bytes, text, bin); !s.ok() || !(s = CheckJsonDepth(text, "glb")).ok()) return s;
    if (Status s = DecodeMeshoptGlb(bytes, decoded); !s.ok()) return s;
    if (!decoded.empty()) bytes = decoded;
    // Meshopt's decoding wrote a new JSON chunk.
    if (Status s = decoded.empty() ? Status::Ok() : SplitGlb(bytes, text, bin); !s.ok()) return s;
    json j = json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return InvalidArgument("glb: JSON chunk is not valid JSON");
    if (Status s = options.allow_external_files ? Status::Ok() : CheckEmbedded(j); !s.ok() || !(s = CheckImageViews(j)).ok()) return s;
  } else {
    if (Status s = CheckJsonDepth({reinterpret_cast<const char*>(bytes.data()), bytes.size()}, "glTF"); !s.ok()) return s;
    json j = json::parse(bytes.begin(), bytes.end(), nullptr, false);
    if (j.is_discarded() || !j.is_object()) return InvalidArgument("not a glTF file: neither glb nor valid JSON");
    if (Status s = options.allow_external_files ? Status::Ok() : CheckEmbedded(j); !s.ok() || !(s = CheckImageViews(j)).ok()) return s;
    if (ListHas(j, "extensionsUsed", "EXT_meshopt_compression")) {
      return InvalidArgument("EXT_meshopt_compression is read from .glb files only; pack this file as .glb");
    }
  }

  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(KeepImageBytes, nullptr);
  if (!options.allow_external_files) {
    tinygltf::FsCallbacks fs{NoFileExists, NoExpand, NoRead, NoWrite, nullptr};
    loader.SetFsCallbacks(fs);
  }
  tinygltf::Model model;
  std::string err, warn;
  const bool ok = is_glb ? loader.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(),
                                                       static_cast<unsigned int>(bytes.size()), base_dir)
                         : loader.LoadASCIIFromString(&model, &err, &warn,
                                                      reinterpret_cast<const char*>(bytes.data()),
                                                      static_cast<unsigned int>(bytes.size()), base_dir);
  if (!ok) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    for (char& c : err) if (c == '\n') c = ';';
    return InvalidArgument("invalid glTF: " + (err.empty() ? std::string("parse failed") : err));
  }
  for (const std::string& ext : model.extensionsRequired) {
    if (std::find(std::begin(kSupportedRequired), std::end(kSupportedRequired), ext) == std::end(kSupportedRequired)) {
      return FailedPrecondition("the file requires the glTF extension " + ext + ", which is not supported");
    }
  }
  Rig rig;
  rig.credit = model.asset.copyright;
  // tinygltf's own warnings (unknown members and such) are passed on, a few at most.
  for (size_t start = 0, n = 0; start < warn.size() && n < 5; ++n) {
    size_t end = warn.find('\n', start);
    if (end == std::string::npos) end = warn.size();
    if (end > start) rig.load_warnings.push_back({"gltf_warning", warn.substr(start, std::min<size_t>(end - start, 300)), "", 0.0, false});
    start = end + 1;
  }
  if (Status s = ConvertModel(model, rig); !s.ok()) return s;
  if (Status s = ApplyVrm(model, rig); !s.ok()) return s;
  return rig;
}

Result<Rig> LoadGltfFile(const std::string& path, const LoadOptions& options) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return NotFound("cannot open '" + path + "'");
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  std::string dir = path.find('/') == std::string::npos ? "." : path.substr(0, path.rfind('/'));
  Result<Rig> rig = LoadGltfMemory(bytes, dir, options);
  if (!rig.ok()) return Prefixed(rig.status(), path + ": ");
  return rig;
}

}  // namespace facespace
