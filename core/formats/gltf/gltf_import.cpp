// glTF 2.0 import: tinygltf parses, we convert once into core types, range-checking every
// index and byte offset on the way. EXT_meshopt_compression is decoded (meshoptimizer)
// before tinygltf sees the file, since tinygltf 2.7 does not know it.
#include <meshoptimizer.h>
#include <tiny_gltf.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>

#include "common/json_depth.h"
#include "facespace/formats/io.h"
#include "gltf/gltf_common.h"

namespace facespace::formats {

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
bool NoWrite(std::string*, const std::string&, const std::vector<unsigned char>&, void*) {
  return false;
}

// ---- model -> rig -------------------------------------------------------------------------

std::vector<std::string> TargetNames(const tinygltf::Value& extras) {
  std::vector<std::string> names;
  if (!extras.IsObject() || !extras.Has("targetNames")) return names;
  const tinygltf::Value& list = extras.Get("targetNames");
  if (!list.IsArray()) return names;
  for (size_t i = 0; i < list.ArrayLen(); ++i) {
    names.push_back(list.Get(static_cast<int>(i)).IsString()
                        ? list.Get(static_cast<int>(i)).Get<std::string>()
                        : "");
  }
  return names;
}

// A glTF primitive being read: its model, its attributes by name, and what errors call it.
struct PrimitiveSource {
  const tinygltf::Model& model;
  const tinygltf::Primitive& src;
  std::string what;  // "mesh M primitive P"
  int Attribute(const std::string& name) const {
    const auto it = src.attributes.find(name);
    return it == src.attributes.end() ? -1 : it->second;
  }
  // An attribute of `n` elements of want_min..want_max components into `dst` (absent: left empty);
  // a VEC3 colour gets alpha 1.
  Status Read(const char* name, size_t n, std::vector<float>& dst, int want_min,
              int want_max) const {
    const int a = Attribute(name);
    if (a < 0) return Status::Ok();
    int c = 0;
    if (Status s = ReadAccessor(model, a, dst, c, what + " " + name); !s.ok()) return s;
    if (c < want_min || c > want_max)
      return InvalidArgument(what + ": " + name + " has the wrong type");
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
  }
};

// POSITION, NORMAL (made unit length: quantized normals are not), TANGENT, TEXCOORD_0, COLOR_0, and
// our own application attribute _SOURCE_VERTEX: the source vertex of each vertex (rig.h), whole
// numbers.
Status ReadAttributes(const PrimitiveSource& in, Primitive& p) {
  int comps = 0;
  const int pos = in.Attribute("POSITION");
  if (pos < 0) return InvalidArgument(in.what + ": has no POSITION");
  if (Status s = ReadAccessor(in.model, pos, p.positions, comps, in.what + " POSITION"); !s.ok())
    return s;
  if (comps != 3) return InvalidArgument(in.what + ": POSITION must be VEC3");
  const size_t n = p.vertex_count();
  std::vector<float> source;
  for (Status s :
       {in.Read("NORMAL", n, p.normals, 3, 3), in.Read("TANGENT", n, p.tangents, 4, 4),
        in.Read("TEXCOORD_0", n, p.texcoords, 2, 2), in.Read("COLOR_0", n, p.colors, 3, 4),
        in.Read("_SOURCE_VERTEX", n, source, 1, 1)}) {
    if (!s.ok()) return s;
  }
  p.source_vertices.reserve(source.size());
  for (float f : source) {
    if (!(f >= 0.0f && f < static_cast<float>(Primitive::kMaxSourceVertex)) || f != std::floor(f)) {
      return InvalidArgument(in.what + ": _SOURCE_VERTEX holds " + std::to_string(f) +
                             ", not a vertex number");
    }
    p.source_vertices.push_back(static_cast<uint32_t>(f));
  }
  p.source_has_normals = !p.normals.empty();
  for (size_t v = 0; v < p.normals.size(); v += 3) {
    float* nn = &p.normals[v];
    const float len = std::sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
    if (len > 0.0f && std::fabs(len - 1.0f) > 1e-6f) {
      nn[0] /= len;
      nn[1] /= len;
      nn[2] /= len;
    }
  }
  return Status::Ok();
}

// One JOINTS_n/WEIGHTS_n pair appended: the influences re-laid out as `influences` consecutive
// entries per vertex.
Status AppendInfluences(const PrimitiveSource& in, int set, int ja, int wa, Primitive& p) {
  const size_t n = p.vertex_count();
  const std::string jn = "JOINTS_" + std::to_string(set), wn = "WEIGHTS_" + std::to_string(set);
  std::vector<float> j, w;
  int jc = 0, wc = 0;
  if (Status s = ReadAccessor(in.model, ja, j, jc, in.what + " " + jn); !s.ok()) return s;
  if (Status s = ReadAccessor(in.model, wa, w, wc, in.what + " " + wn); !s.ok()) return s;
  if (jc != 4 || wc != 4 || j.size() != 4 * n || w.size() != 4 * n) {
    return InvalidArgument(in.what + ": " + jn + "/" + wn +
                           " must be VEC4 with one element per vertex");
  }
  if (set > 15) return InvalidArgument(in.what + ": too many JOINTS_n sets");
  const size_t k_old = 4 * static_cast<size_t>(set), k_new = k_old + 4;
  std::vector<uint16_t> joints(k_new * n);
  std::vector<float> weights(k_new * n);
  for (size_t v = 0; v < n; ++v) {
    for (size_t k = 0; k < k_old; ++k) {
      joints[v * k_new + k] = p.joints[v * k_old + k];
      weights[v * k_new + k] = p.joint_weights[v * k_old + k];
    }
    for (size_t k = 0; k < 4; ++k) {
      const float jf = j[4 * v + k];
      if (jf < 0.0f || jf > 65535.0f)
        return InvalidArgument(in.what + ": " + jn + " has an invalid joint index");
      joints[v * k_new + k_old + k] = static_cast<uint16_t>(jf);
      weights[v * k_new + k_old + k] = std::max(w[4 * v + k], 0.0f);
    }
  }
  p.joints.swap(joints);
  p.joint_weights.swap(weights);
  p.influences = k_new;
  return Status::Ok();
}

// Skinning influences from every JOINTS_n/WEIGHTS_n pair, normalised per vertex (warned when they
// did not sum to 1; a vertex with none follows the first joint).
Status ReadInfluences(const PrimitiveSource& in, Primitive& p, std::vector<Warning>& warnings) {
  for (int set = 0;; ++set) {
    const std::string jn = "JOINTS_" + std::to_string(set), wn = "WEIGHTS_" + std::to_string(set);
    const int ja = in.Attribute(jn), wa = in.Attribute(wn);
    if (ja < 0 && wa < 0) break;
    if (ja < 0 || wa < 0)
      return InvalidArgument(in.what + ": " + (ja < 0 ? jn : wn) + " is missing its pair");
    if (Status s = AppendInfluences(in, set, ja, wa, p); !s.ok()) return s;
  }
  const size_t n = p.vertex_count();
  size_t renormalised = 0;
  for (size_t v = 0; v < n && p.influences; ++v) {
    float sum = 0.0f;
    for (size_t k = 0; k < p.influences; ++k) sum += p.joint_weights[v * p.influences + k];
    if (std::fabs(sum - 1.0f) > 2e-3f) ++renormalised;
    if (sum <= 0.0f) {
      p.joint_weights[v * p.influences] = 1.0f;
      continue;
    }
    for (size_t k = 0; k < p.influences; ++k) p.joint_weights[v * p.influences + k] /= sum;
  }
  if (renormalised) {
    warnings.push_back({"weights_normalised",
                        in.what + ": the skin weights of " + std::to_string(renormalised) + " of " +
                            std::to_string(n) + " vertices did not sum to 1 and were normalised",
                        "", static_cast<double>(renormalised), true});
  }
  return Status::Ok();
}

// The indices (or 0..n-1), checked, and the mode's strips, fans and loops as triangles and lines.
Status ReadTopology(const PrimitiveSource& in, Primitive& p) {
  const size_t n = p.vertex_count();
  const std::string& what = in.what;
  std::vector<uint32_t> indices;
  if (in.src.indices >= 0) {
    if (Status s = ReadIndices(in.model, in.src.indices, indices, what + " indices"); !s.ok())
      return s;
  } else {
    indices.resize(n);
    for (size_t i = 0; i < n; ++i) indices[i] = static_cast<uint32_t>(i);
  }
  for (uint32_t i : indices) {
    if (i >= n)
      return InvalidArgument(what + ": index " + std::to_string(i) + " beyond vertex count " +
                             std::to_string(n));
  }
  const int mode = in.src.mode;
  switch (mode) {
    case TINYGLTF_MODE_TRIANGLES:
    case -1:
      if (indices.size() % 3)
        return InvalidArgument(what + ": triangle index count not a multiple of 3");
      p.indices = std::move(indices);
      break;
    case TINYGLTF_MODE_TRIANGLE_STRIP:
      for (size_t i = 2; i < indices.size(); ++i) {
        const bool odd = i % 2;
        p.indices.insert(p.indices.end(),
                         {indices[i - 2], indices[odd ? i : i - 1], indices[odd ? i - 1 : i]});
      }
      break;
    case TINYGLTF_MODE_TRIANGLE_FAN:
      for (size_t i = 2; i < indices.size(); ++i)
        p.indices.insert(p.indices.end(), {indices[i - 1], indices[i], indices[0]});
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
      for (size_t i = 1; i < indices.size(); ++i)
        p.indices.insert(p.indices.end(), {indices[i - 1], indices[i]});
      if (mode == TINYGLTF_MODE_LINE_LOOP && indices.size() > 2)
        p.indices.insert(p.indices.end(), {indices.back(), indices[0]});
      break;
    default: return InvalidArgument(what + ": unknown mode " + std::to_string(mode));
  }
  return Status::Ok();
}

// Morph target t, made sparse: a vertex is kept when any of its deltas is non-zero; its UV deltas
// (TEXCOORD_0 targets, which glTF 2.0 allows) apart: they move other vertices.
Status ReadTarget(const PrimitiveSource& in, size_t t, Primitive& p) {
  const size_t n = p.vertex_count();
  const std::string twhat = in.what + " target " + std::to_string(t);
  const auto& target = in.src.targets[t];
  std::vector<float> dp, dn, dt;
  int comps = 0;
  for (const auto& [name, acc] : target) {
    std::vector<float>* dst = name == "POSITION"  ? &dp
                              : name == "NORMAL"  ? &dn
                              : name == "TANGENT" ? &dt
                                                  : nullptr;
    if (!dst) continue;
    if (Status s = ReadAccessor(in.model, acc, *dst, comps, twhat + " " + name); !s.ok()) return s;
    if (comps != 3) return InvalidArgument(twhat + ": " + name + " deltas must be VEC3");
    if (dst->size() != 3 * n)
      return InvalidArgument(twhat + ": " + name + " has " + std::to_string(dst->size() / 3) +
                             " vertices, the base has " + std::to_string(n));
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
  const auto uv = target.find("TEXCOORD_0");
  if (uv == target.end() || p.texcoords.empty()) return Status::Ok();
  if (Status s = ReadAccessor(in.model, uv->second, dp, comps, twhat + " TEXCOORD_0"); !s.ok())
    return s;
  if (comps != 2 || dp.size() != 2 * n)
    return InvalidArgument(twhat + ": TEXCOORD_0 deltas must be VEC2, one per vertex");
  for (size_t v = 0; v < n; ++v) {
    if (dp[2 * v] == 0.0f && dp[2 * v + 1] == 0.0f) continue;
    st.texcoord_indices.push_back(static_cast<uint32_t>(v));
    st.texcoord_deltas.insert(st.texcoord_deltas.end(), {dp[2 * v], dp[2 * v + 1]});
  }
  return Status::Ok();
}

Status ConvertPrimitive(const tinygltf::Model& model, const tinygltf::Primitive& src,
                        int mesh_index, int prim_index, Primitive& p,
                        std::vector<Warning>& warnings) {
  const PrimitiveSource in{
      model, src,
      "mesh " + std::to_string(mesh_index) + " primitive " + std::to_string(prim_index)};
  p.mesh = mesh_index;
  p.index_in_mesh = prim_index;
  if (Status s = ReadAttributes(in, p); !s.ok()) return s;
  if (Status s = ReadInfluences(in, p, warnings); !s.ok()) return s;
  if (Status s = ReadTopology(in, p); !s.ok()) return s;
  if (src.material >= static_cast<int>(model.materials.size()))
    return InvalidArgument(in.what + ": material out of range");
  p.material = src.material;
  p.targets.resize(src.targets.size());
  for (size_t t = 0; t < src.targets.size(); ++t) {
    if (Status s = ReadTarget(in, t, p); !s.ok()) return s;
  }
  return Status::Ok();
}

// The base colour's texture transform applied to a primitive's UVs (its UV deltas: the linear part
// alone).
void TransformUvs(const std::array<float, 6>& xf, Primitive& p) {
  const auto transform = [&xf](std::vector<float>& uv, float shift) {
    for (size_t v = 0; v < uv.size(); v += 2) {
      const float u = uv[v], w = uv[v + 1];
      uv[v] = xf[0] * u + xf[1] * w + shift * xf[2];
      uv[v + 1] = xf[3] * u + xf[4] * w + shift * xf[5];
    }
  };
  transform(p.texcoords, 1.0f);
  for (SparseTarget& t : p.targets) transform(t.texcoord_deltas, 0.0f);
}

// A mesh's targets as shapes, named across the file (targetNames, else the POSITION accessor's
// name, else target_N; a name twice in one mesh gets its index): the shape of each target into
// mesh.target_shapes.
Status NameTargets(const tinygltf::Model& model, size_t mi,
                   std::map<std::string, uint32_t>& shape_by_name, Rig& rig, Mesh& mesh) {
  const tinygltf::Mesh& sm = model.meshes[mi];
  const size_t target_count = sm.primitives.empty() ? 0 : sm.primitives[0].targets.size();
  std::vector<std::string> names = TargetNames(sm.extras);
  for (const auto& prim : sm.primitives) {
    if (prim.targets.size() != target_count)
      return InvalidArgument("mesh " + std::to_string(mi) +
                             ": primitives have different morph target counts");
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
                                       "'; target " + std::to_string(t) + " is called '" + unique +
                                       "'",
                                   unique, 0.0, false});
      name = unique;
    }
    used.push_back(name);
    auto [it, inserted] = shape_by_name.emplace(name, static_cast<uint32_t>(rig.shapes.size()));
    if (inserted) {
      Shape s;
      s.name = name;
      if (t < sm.weights.size() && std::isfinite(sm.weights[t]))
        s.default_weight = static_cast<float>(sm.weights[t]);
      rig.shapes.push_back(s);
    }
    mesh.target_shapes.push_back(it->second);
  }
  return Status::Ok();
}

// Meshes, their primitives, and the shapes their targets are.
Status ConvertMeshes(const tinygltf::Model& model, const UvTransforms& uv_transforms, Rig& rig) {
  std::map<std::string, uint32_t> shape_by_name;
  for (size_t mi = 0; mi < model.meshes.size(); ++mi) {
    const tinygltf::Mesh& sm = model.meshes[mi];
    Mesh mesh;
    mesh.name = sm.name;
    if (Status s = NameTargets(model, mi, shape_by_name, rig, mesh); !s.ok()) return s;
    for (size_t pi = 0; pi < sm.primitives.size(); ++pi) {
      Primitive p;
      if (Status s = ConvertPrimitive(model, sm.primitives[pi], static_cast<int>(mi),
                                      static_cast<int>(pi), p, rig.load_warnings);
          !s.ok())
        return s;
      if (p.material >= 0 && uv_transforms[p.material].first == 0 && !p.texcoords.empty())
        TransformUvs(uv_transforms[p.material].second, p);
      FinalizePrimitive(p);
      mesh.primitives.push_back(static_cast<int>(rig.primitives.size()));
      rig.primitives.push_back(std::move(p));
    }
    rig.meshes.push_back(std::move(mesh));
  }
  return Status::Ok();
}

// The model as the rig: images and materials, then the meshes (whose primitives name materials),
// the nodes and their hierarchy, the skins and the animations (gltf_scene.cpp).
Status ConvertModel(const tinygltf::Model& model, Rig& rig) {
  const std::vector<int> image_map = ConvertImages(model, rig);
  const UvTransforms uv_transforms = ConvertMaterials(model, image_map, rig);
  if (Status s = ConvertMeshes(model, uv_transforms, rig); !s.ok()) return s;
  for (Status (*convert)(const tinygltf::Model&, Rig&) :
       {ConvertNodes, LinkNodes, ConvertSkins, ConvertAnimations}) {
    if (Status s = convert(model, rig); !s.ok()) return s;
  }
  DetectSymmetricPartners(rig);
  CountMovedVertices(rig);
  RepairNames(rig);
  return ValidateRig(rig);
}

const char* kSupportedRequired[] = {
    "KHR_mesh_quantization",          "EXT_meshopt_compression", "KHR_texture_basisu",
    "KHR_texture_transform",          "KHR_materials_unlit",     "EXT_texture_webp",
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
    if (Status s = SplitGlb(bytes, text, bin); !s.ok() || !(s = CheckJsonDepth(text, "glb")).ok())
      return s;
    if (Status s = DecodeMeshoptGlb(bytes, decoded); !s.ok()) return s;
    if (!decoded.empty()) bytes = decoded;
    // Meshopt's decoding wrote a new JSON chunk.
    if (Status s = decoded.empty() ? Status::Ok() : SplitGlb(bytes, text, bin); !s.ok()) return s;
    json j = json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object())
      return InvalidArgument("glb: JSON chunk is not valid JSON");
    if (Status s = options.allow_external_files ? Status::Ok() : CheckEmbedded(j);
        !s.ok() || !(s = CheckImageViews(j)).ok())
      return s;
  } else {
    if (Status s =
            CheckJsonDepth({reinterpret_cast<const char*>(bytes.data()), bytes.size()}, "glTF");
        !s.ok())
      return s;
    json j = json::parse(bytes.begin(), bytes.end(), nullptr, false);
    if (j.is_discarded() || !j.is_object())
      return InvalidArgument("not a glTF file: neither glb nor valid JSON");
    if (Status s = options.allow_external_files ? Status::Ok() : CheckEmbedded(j);
        !s.ok() || !(s = CheckImageViews(j)).ok())
      return s;
    if (ListHas(j, "extensionsUsed", "EXT_meshopt_compression")) {
      return InvalidArgument(
          "EXT_meshopt_compression is read from .glb files only; pack this file as .glb");
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
  const bool ok =
      is_glb ? loader.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(),
                                           static_cast<unsigned int>(bytes.size()), base_dir)
             : loader.LoadASCIIFromString(&model, &err, &warn,
                                          reinterpret_cast<const char*>(bytes.data()),
                                          static_cast<unsigned int>(bytes.size()), base_dir);
  if (!ok) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    for (char& c : err)
      if (c == '\n') c = ';';
    return InvalidArgument("invalid glTF: " + (err.empty() ? std::string("parse failed") : err));
  }
  for (const std::string& ext : model.extensionsRequired) {
    if (std::find(std::begin(kSupportedRequired), std::end(kSupportedRequired), ext) ==
        std::end(kSupportedRequired)) {
      return FailedPrecondition("the file requires the glTF extension " + ext +
                                ", which is not supported");
    }
  }
  Rig rig;
  rig.credit = model.asset.copyright;
  // tinygltf's own warnings (unknown members and such) are passed on, a few at most.
  for (size_t start = 0, n = 0; start < warn.size() && n < 5; ++n) {
    size_t end = warn.find('\n', start);
    if (end == std::string::npos) end = warn.size();
    if (end > start)
      rig.load_warnings.push_back(
          {"gltf_warning", warn.substr(start, std::min<size_t>(end - start, 300)), "", 0.0, false});
    start = end + 1;
  }
  if (Status s = ConvertModel(model, rig); !s.ok()) return s;
  if (Status s = ApplyVrm(model, rig); !s.ok()) return s;
  return rig;
}

Result<Rig> LoadGltfFile(const std::string& path, const LoadOptions& options) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return NotFound("cannot open '" + path + "'");
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)),
                                   std::istreambuf_iterator<char>());
  std::string dir = path.find('/') == std::string::npos ? "." : path.substr(0, path.rfind('/'));
  Result<Rig> rig = LoadGltfMemory(bytes, dir, options);
  if (!rig.ok()) return Prefixed(rig.status(), path + ": ");
  return rig;
}

}  // namespace facespace::formats
