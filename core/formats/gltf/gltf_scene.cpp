// The glTF scene's parts as the rig's, after the meshes (gltf_import.cpp): images, materials, nodes
// and their hierarchy, skins, animations. Every index is range-checked; an error names the item.
#include <algorithm>
#include <cmath>

#include "facespace/formats/io.h"
#include "gltf/gltf_common.h"

namespace facespace::formats {

namespace {

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

// One animation sampler: increasing key times, values per key (x3 for cubic splines).
Status ReadSampler(const tinygltf::Model& model, const tinygltf::AnimationSampler& src,
                   const std::string& where, AnimationSampler& smp) {
  int comps = 0;
  if (Status st = ReadAccessor(model, src.input, smp.times, comps, where + " input"); !st.ok())
    return st;
  if (comps != 1 || smp.times.empty())
    return InvalidArgument(where + ": sampler input must be non-empty scalars");
  for (size_t k = 1; k < smp.times.size(); ++k) {
    if (!(smp.times[k] > smp.times[k - 1]))
      return InvalidArgument(where + ": keyframe times must increase");
  }
  if (Status st = ReadAccessor(model, src.output, smp.values, comps, where + " output"); !st.ok())
    return st;
  smp.interpolation = src.interpolation == "STEP"          ? Interpolation::kStep
                      : src.interpolation == "CUBICSPLINE" ? Interpolation::kCubicSpline
                                                           : Interpolation::kLinear;
  const size_t per_key = smp.values.size() / smp.times.size() /
                         (smp.interpolation == Interpolation::kCubicSpline ? 3 : 1);
  if (per_key == 0 ||
      per_key * smp.times.size() * (smp.interpolation == Interpolation::kCubicSpline ? 3 : 1) !=
          smp.values.size()) {
    return InvalidArgument(where + ": sampler output does not match its input");
  }
  smp.components = per_key;
  return Status::Ok();
}

// One channel onto `info`, its values per key checked against its path; paths not ours ("pointer")
// are skipped.
Status AddChannel(const Rig& rig, const tinygltf::AnimationChannel& ch, const std::string& where,
                  AnimationInfo& info) {
  if (ch.sampler < 0 || static_cast<size_t>(ch.sampler) >= info.sampler_data.size() ||
      ch.target_node < 0 || static_cast<size_t>(ch.target_node) >= rig.nodes.size()) {
    return InvalidArgument(where + ": channel with an invalid sampler or node");
  }
  AnimationChannel c{ch.sampler, ch.target_node, ChannelPath::kTranslation};
  const size_t comps = info.sampler_data[ch.sampler].components;
  size_t want = 0;
  if (ch.target_path == "translation") {
    c.path = ChannelPath::kTranslation;
    want = 3;
  } else if (ch.target_path == "rotation") {
    c.path = ChannelPath::kRotation;
    want = 4;
  } else if (ch.target_path == "scale") {
    c.path = ChannelPath::kScale;
    want = 3;
  } else if (ch.target_path == "weights") {
    c.path = ChannelPath::kWeights;
    info.has_weights = true;
    const int m = rig.nodes[ch.target_node].mesh;
    if (m < 0) return InvalidArgument(where + ": a weights channel targets a node without a mesh");
    want = rig.meshes[m].target_shapes.size();
  } else {
    return Status::Ok();
  }
  if (comps != want)
    return InvalidArgument(where + ": channel " + ch.target_path + " has " + std::to_string(comps) +
                           " values per key, expected " + std::to_string(want));
  info.channel_data.push_back(c);
  return Status::Ok();
}

}  // namespace

std::vector<int> ConvertImages(const tinygltf::Model& model, Rig& rig) {
  std::vector<int> image_map(model.images.size(), -1);
  for (size_t i = 0; i < model.images.size(); ++i) {
    const tinygltf::Image& im = model.images[i];
    if (IsPng(im.image) || IsJpeg(im.image)) {
      image_map[i] = static_cast<int>(rig.images.size());
      rig.images.push_back({im.name, IsPng(im.image) ? "image/png" : "image/jpeg", im.image});
    } else {
      const std::string kind = !im.mimeType.empty() ? im.mimeType : "unknown format";
      rig.load_warnings.push_back(
          {"texture_dropped",
           "image " + std::to_string(i) + " (" + kind +
               ") cannot be decoded here and was dropped; the geometry is kept",
           im.name, 0.0, false});
    }
  }
  return image_map;
}

UvTransforms ConvertMaterials(const tinygltf::Model& model, const std::vector<int>& image_map,
                              Rig& rig) {
  // The rig's image of a glTF texture index, or -1 (no such texture, or its image was dropped).
  const auto image_of_texture = [&model, &image_map](int texture) {
    if (texture < 0 || static_cast<size_t>(texture) >= model.textures.size()) return -1;
    const int src = model.textures[static_cast<size_t>(texture)].source;
    return src >= 0 && static_cast<size_t>(src) < image_map.size()
               ? image_map[static_cast<size_t>(src)]
               : -1;
  };
  UvTransforms material_uv_transform(model.materials.size(), {-1, {}});
  for (size_t i = 0; i < model.materials.size(); ++i) {
    const tinygltf::Material& sm = model.materials[i];
    Material m;
    m.name = sm.name;
    const auto& pbr = sm.pbrMetallicRoughness;
    for (size_t c = 0; c < 4 && c < pbr.baseColorFactor.size(); ++c)
      m.base_color_factor[c] = static_cast<float>(pbr.baseColorFactor[c]);
    m.metallic_factor = static_cast<float>(pbr.metallicFactor);
    m.roughness_factor = static_cast<float>(pbr.roughnessFactor);
    m.double_sided = sm.doubleSided;
    m.alpha_mode = sm.alphaMode.empty() ? "OPAQUE" : sm.alphaMode;
    m.alpha_cutoff = static_cast<float>(sm.alphaCutoff);
    // The other maps: the rig's image of a texture index, or -1. Only maps on TEXCOORD_0 without a
    // texture transform are kept (the base colour's transform is applied to the UVs); one left out
    // is said in a warning.
    const auto image_of = [&](const char* what, int texture, int texcoord,
                              const tinygltf::ExtensionMap& extensions) {
      if (texture < 0 || static_cast<size_t>(texture) >= model.textures.size()) return -1;
      std::array<float, 6> ignored;
      const bool transformed = TextureTransform(extensions, ignored.data());
      if (texcoord != 0 || transformed) {
        rig.load_warnings.push_back({"material_map_dropped",
                                     "material '" + sm.name + "': its " + what + " map is " +
                                         (transformed ? "under a texture transform"
                                                      : "on TEXCOORD_" + std::to_string(texcoord)) +
                                         ", which is not kept; it renders without it",
                                     sm.name, 0.0, false});
        return -1;
      }
      return image_of_texture(texture);
    };
    const auto& mr = pbr.metallicRoughnessTexture;
    m.metallic_roughness_image =
        image_of("metallic-roughness", mr.index, mr.texCoord, mr.extensions);
    m.normal_image = image_of("normal", sm.normalTexture.index, sm.normalTexture.texCoord,
                              sm.normalTexture.extensions);
    m.normal_scale = static_cast<float>(sm.normalTexture.scale);
    m.occlusion_image = image_of("occlusion", sm.occlusionTexture.index,
                                 sm.occlusionTexture.texCoord, sm.occlusionTexture.extensions);
    m.occlusion_strength = static_cast<float>(std::clamp(sm.occlusionTexture.strength, 0.0, 1.0));
    m.emissive_image = image_of("emissive", sm.emissiveTexture.index, sm.emissiveTexture.texCoord,
                                sm.emissiveTexture.extensions);
    for (size_t c = 0; c < 3 && c < sm.emissiveFactor.size(); ++c)
      m.emissive_factor[c] = static_cast<float>(sm.emissiveFactor[c]);
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

  return material_uv_transform;
}

Status ConvertNodes(const tinygltf::Model& model, Rig& rig) {
  rig.nodes.resize(model.nodes.size());
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    const tinygltf::Node& sn = model.nodes[i];
    Node& n = rig.nodes[i];
    n.name = sn.name;
    n.mesh = sn.mesh;
    if (n.mesh >= static_cast<int>(rig.meshes.size()))
      return InvalidArgument("node " + std::to_string(i) + ": mesh out of range");
    if (sn.matrix.size() == 16) {
      n.has_matrix = true;
      for (int k = 0; k < 16; ++k) n.matrix[k] = static_cast<float>(sn.matrix[k]);
    }
    if (sn.translation.size() == 3)
      for (int k = 0; k < 3; ++k) n.translation[k] = static_cast<float>(sn.translation[k]);
    if (sn.rotation.size() == 4)
      for (int k = 0; k < 4; ++k) n.rotation[k] = static_cast<float>(sn.rotation[k]);
    if (sn.scale.size() == 3)
      for (int k = 0; k < 3; ++k) n.scale[k] = static_cast<float>(sn.scale[k]);
    const std::pair<std::span<const float>, const char*> parts[] = {{n.matrix, "matrix"},
                                                                    {n.translation, "translation"},
                                                                    {n.rotation, "rotation"},
                                                                    {n.scale, "scale"}};
    for (const auto& [values, what] : parts) {
      if (!std::all_of(values.begin(), values.end(), [](float f) { return std::isfinite(f); }))
        return InvalidArgument("node " + std::to_string(i) + ": non-finite " + what);
    }
  }
  return Status::Ok();
}

Status LinkNodes(const tinygltf::Model& model, Rig& rig) {
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    for (int c : model.nodes[i].children) {
      if (c < 0 || static_cast<size_t>(c) >= rig.nodes.size() || rig.nodes[c].parent >= 0 ||
          c == static_cast<int>(i)) {
        return InvalidArgument("node " + std::to_string(i) + ": child " + std::to_string(c) +
                               " is invalid or has two parents");
      }
      rig.nodes[c].parent = static_cast<int>(i);
      rig.nodes[i].children.push_back(c);
    }
  }
  // A cycle leaves nodes that no root reaches; glTF forbids it.
  {
    std::vector<int> stack;
    std::vector<uint8_t> seen(rig.nodes.size(), 0);
    for (size_t i = 0; i < rig.nodes.size(); ++i)
      if (rig.nodes[i].parent < 0) stack.push_back(static_cast<int>(i));
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
        return InvalidArgument("scene " + std::to_string(scene) + ": invalid root node " +
                               std::to_string(r));
      }
      rig.scene_roots.push_back(r);
    }
  } else {
    for (size_t i = 0; i < rig.nodes.size(); ++i)
      if (rig.nodes[i].parent < 0) rig.scene_roots.push_back(static_cast<int>(i));
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
  return Status::Ok();
}

Status ConvertSkins(const tinygltf::Model& model, Rig& rig) {
  rig.skin_count = model.skins.size();
  for (size_t si = 0; si < model.skins.size(); ++si) {
    const auto& skin = model.skins[si];
    rig.joint_count += skin.joints.size();
    Skin s{skin.name, {}, {}};
    for (int j : skin.joints) {
      if (j < 0 || static_cast<size_t>(j) >= rig.nodes.size())
        return InvalidArgument("skin '" + skin.name + "': joint out of range");
      s.joints.push_back(j);
    }
    if (skin.inverseBindMatrices >= 0) {
      int comps = 0;
      if (Status st = ReadAccessor(model, skin.inverseBindMatrices, s.inverse_bind, comps,
                                   "skin " + std::to_string(si) + " inverseBindMatrices");
          !st.ok()) {
        return st;
      }
      if (comps != 16 || s.inverse_bind.size() != 16 * s.joints.size()) {
        return InvalidArgument("skin " + std::to_string(si) +
                               ": needs one MAT4 inverse bind matrix per joint");
      }
    } else {
      for (size_t j = 0; j < s.joints.size(); ++j)
        s.inverse_bind.insert(s.inverse_bind.end(),
                              {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});
    }
    rig.skins.push_back(std::move(s));
  }
  // A mesh is skinned by the skin of the first node that shows it with one.
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    const int m = model.nodes[i].mesh, sk = model.nodes[i].skin;
    if (m < 0 || sk < 0) continue;
    if (static_cast<size_t>(sk) >= rig.skins.size())
      return InvalidArgument("node " + std::to_string(i) + ": skin out of range");
    if (rig.meshes[m].skin < 0) rig.meshes[m].skin = sk;
  }
  for (const Mesh& mesh : rig.meshes) {
    if (mesh.skin < 0) continue;
    const size_t joints = rig.skins[mesh.skin].joints.size();
    for (int pi : mesh.primitives) {
      for (uint16_t j : rig.primitives[pi].joints) {
        if (j >= joints)
          return InvalidArgument("mesh '" + mesh.name + "': joint index " + std::to_string(j) +
                                 " beyond its skin's " + std::to_string(joints) + " joints");
      }
    }
  }
  return Status::Ok();
}

Status ConvertAnimations(const tinygltf::Model& model, Rig& rig) {
  for (size_t ai = 0; ai < model.animations.size(); ++ai) {
    const auto& anim = model.animations[ai];
    const std::string where = "animation " + std::to_string(ai);
    AnimationInfo info;
    info.name = anim.name.empty() ? "animation_" + std::to_string(ai) : anim.name;
    info.channels = anim.channels.size();
    for (const tinygltf::AnimationSampler& src : anim.samplers) {
      AnimationSampler smp;
      if (Status s = ReadSampler(model, src, where, smp); !s.ok()) return s;
      info.duration = std::max(info.duration, smp.times.back());
      info.sampler_data.push_back(std::move(smp));
    }
    for (const auto& ch : anim.channels) {
      if (Status s = AddChannel(rig, ch, where, info); !s.ok()) return s;
    }
    rig.animations.push_back(std::move(info));
  }
  return Status::Ok();
}

}  // namespace facespace::formats
