// The MMD model (from PMX or PMD) as a Rig, and Shift-JIS text through iconv.
#include <iconv.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <set>

#include "facespace/engine/rig.h"
#include "facespace/engine/transform.h"
#include "facespace/formats/io.h"
#include "mmd/mmd.h"

namespace facespace::formats::mmd {

namespace {

std::string Convert(const char* to, const char* from, const char* p, size_t n, bool skip_bad) {
  iconv_t cd = iconv_open(to, from);
  if (cd == reinterpret_cast<iconv_t>(-1)) return {};
  std::string out;
  char buf[256];
  char* in = const_cast<char*>(p);
  size_t in_left = n;
  while (in_left > 0) {
    char* o = buf;
    size_t o_left = sizeof buf;
    const size_t r = iconv(cd, &in, &in_left, &o, &o_left);
    out.append(buf, static_cast<size_t>(o - buf));
    if (r == static_cast<size_t>(-1) && errno != E2BIG) {
      if (!skip_bad) {
        out.clear();
        break;
      }
      ++in;  // EILSEQ or EINVAL (a character cut short): drop the byte.
      --in_left;
    }
  }
  iconv_close(cd);
  return out;
}

// One shape's offsets (N floats each: 3 for positions, 2 for UVs) summed per vertex, as a group
// morph's entries add up, then taken in vertex order; the sum is left empty for the next shape.
template <size_t N>
class OffsetSum {
 public:
  using Offsets = std::vector<std::pair<uint32_t, std::array<float, N>>>;
  explicit OffsetSum(size_t vertices) : acc_(vertices), hit_(vertices, 0) {}
  void Add(const std::vector<std::pair<int64_t, std::array<float, N>>>& offsets, float f) {
    for (const auto& [v, d] : offsets) {
      if (!hit_[v]) touched_.push_back(static_cast<uint32_t>(v));
      hit_[v] = 1;
      for (size_t c = 0; c < N; ++c) acc_[v][c] += f * d[c];
    }
  }
  Offsets Take() {
    std::sort(touched_.begin(), touched_.end());
    Offsets out;
    out.reserve(touched_.size());
    for (uint32_t v : touched_) {
      out.emplace_back(v, acc_[v]);
      acc_[v] = {};
      hit_[v] = 0;
    }
    touched_.clear();
    return out;
  }

 private:
  std::vector<std::array<float, N>> acc_;
  std::vector<char> hit_;
  std::vector<uint32_t> touched_;
};

}  // namespace

std::string SjisToUtf8(const unsigned char* p, size_t n) {
  const size_t len = static_cast<size_t>(std::find(p, p + n, 0) - p);
  return Convert("UTF-8", "CP932", reinterpret_cast<const char*>(p), len, true);
}

std::string Utf8ToSjis(const std::string& s) {
  return Convert("CP932", "UTF-8", s.data(), s.size(), false);
}

std::string Utf16ToUtf8(const unsigned char* p, size_t n) {
  std::string out;
  for (size_t i = 0; i + 1 < n; i += 2) {
    uint32_t c = p[i] | (p[i + 1] << 8);
    if (c >= 0xD800 && c < 0xDC00 && i + 3 < n) {
      const uint32_t d = p[i + 2] | (p[i + 3] << 8);
      if (d >= 0xDC00 && d < 0xE000) {
        c = 0x10000 + ((c - 0xD800) << 10) + (d - 0xDC00);
        i += 2;
      } else {
        c = 0xFFFD;
      }
    } else if (c >= 0xD800 && c < 0xE000) {
      c = 0xFFFD;
    }
    if (c < 0x80) {
      out += static_cast<char>(c);
    } else if (c < 0x800) {
      out += static_cast<char>(0xC0 | (c >> 6));
      out += static_cast<char>(0x80 | (c & 0x3F));
    } else if (c < 0x10000) {
      out += static_cast<char>(0xE0 | (c >> 12));
      out += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (c & 0x3F));
    } else {
      out += static_cast<char>(0xF0 | (c >> 18));
      out += static_cast<char>(0x80 | ((c >> 12) & 0x3F));
      out += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (c & 0x3F));
    }
  }
  return out;
}

const char* PanelGroup(int panel) {
  switch (panel) {
    case 1: return "eyebrow";
    case 2: return "eye";
    case 3: return "mouth";
    case 4: return "other";
    default: return "system";
  }
}

// A morph's group: its panel's, but the "other" panel (and the system one) holds whatever the
// author did not sort, and there the names say where most belong (Uka's 140: eye_wink_geo_L,
// mouth_a_geo_C, the ARKit set, 頬照り1 "cheek_blush1"): eyes, brows, mouth, cheeks, or the face as
// a whole ("..._face", MMD's 総 morphs); what none of them names stays "other".
std::string MorphGroup(int panel, const std::string& name, const std::string& english) {
  if (panel >= 1 && panel <= 3) return PanelGroup(panel);
  std::string text = name + " " + english;
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const auto has = [&text](std::initializer_list<const char*> words) {
    return std::any_of(words.begin(), words.end(),
                       [&text](const char* w) { return text.find(w) != std::string::npos; });
  };
  if (has({"_face"})) return "face";
  if (has({"brow"})) return "eyebrow";
  if (has({"eye", "pupil", "blink", "wink"})) return "eye";
  if (has({"mouth", "jaw", "tongue", "tooth", "teeth"})) return "mouth";
  if (has({"cheek", "blush", "nose"})) return "cheek";
  return PanelGroup(panel);
}

namespace {

// Bones that name a bone out of range, vertices that name a bone out of range: the file is broken.
Status CheckBoneIndices(const Model& in, const std::string& name) {
  const size_t nbones = in.bones.size();
  for (size_t b = 0; b < nbones; ++b) {
    if (in.bones[b].parent >= static_cast<int64_t>(nbones) || in.bones[b].parent < -1) {
      return InvalidArgument(name + ": " + std::string(in.format) + ": bone '" + in.bones[b].name +
                             "' has parent " + std::to_string(in.bones[b].parent) + " of " +
                             std::to_string(nbones));
    }
  }
  for (size_t v = 0; v < in.verts.size(); ++v) {
    const Vertex& x = in.verts[v];
    for (int k = 0; k < x.count; ++k) {
      if (x.bones[k] >= static_cast<int64_t>(nbones) || (x.bones[k] < 0 && x.weights[k] != 0)) {
        return InvalidArgument(name + ": " + std::string(in.format) + ": vertex " +
                               std::to_string(v) + " names bone " + std::to_string(x.bones[k]) +
                               " of " + std::to_string(nbones));
      }
    }
  }
  return Status::Ok();
}

// The bones parents first (PMX does not promise it); a cycle is an error.
Status BonesParentsFirst(const Model& in, const std::string& name, std::vector<int>& order) {
  const std::vector<Bone>& bones = in.bones;
  std::vector<int> state(bones.size(), 0);
  for (size_t b = 0; b < bones.size(); ++b) {
    std::vector<int> chain;
    for (int64_t c = static_cast<int64_t>(b); c >= 0 && state[c] != 2; c = bones[c].parent) {
      if (state[c] == 1)
        return InvalidArgument(name + ": " + std::string(in.format) + ": bone '" + bones[c].name +
                               "' is its own ancestor");
      state[c] = 1;
      chain.push_back(static_cast<int>(c));
    }
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      state[*it] = 2;
      order.push_back(*it);
    }
  }
  return Status::Ok();
}

// The root node, then a node per bone (parents first) into `rig`, and the skin over them; the node
// of each bone.
std::vector<int> AddSkeleton(const Model& in, std::span<const int> order, Rig& rig, Skin& skin) {
  const std::vector<Bone>& bones = in.bones;
  Node root;
  root.name = in.name.empty() ? "pmx_root" : in.name;
  rig.nodes.push_back(root);
  rig.scene_roots = {0};
  skin.name = "pmx_skeleton";
  std::vector<int> node_of(bones.size(), -1);
  for (int b : order) {
    const Bone& x = bones[b];
    Node n;
    n.name = x.name;
    n.parent = x.parent < 0 ? 0 : node_of[x.parent];
    const std::array<float, 3> p = ToGltf(x.pos);
    const std::array<float, 3> pp =
        x.parent < 0 ? std::array<float, 3>{0, 0, 0} : ToGltf(bones[x.parent].pos);
    n.translation = {p[0] - pp[0], p[1] - pp[1], p[2] - pp[2]};
    node_of[b] = static_cast<int>(rig.nodes.size());
    rig.nodes[n.parent].children.push_back(node_of[b]);
    rig.nodes.push_back(n);
  }
  for (size_t b = 0; b < bones.size(); ++b) {
    skin.joints.push_back(node_of[b]);
    const std::array<float, 3> p = ToGltf(bones[b].pos);
    const float ib[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -p[0], -p[1], -p[2], 1};
    skin.inverse_bind.insert(skin.inverse_bind.end(), ib, ib + 16);
  }
  return node_of;
}

// Each shape's offsets, summed per vertex of the model and kept in vertex order.
struct ShapeOffsets {
  std::vector<std::vector<std::pair<uint32_t, std::array<float, 3>>>> positions;
  std::vector<std::vector<std::pair<uint32_t, std::array<float, 2>>>> uvs;
};

// What one shape gathers from its morph and, for a group, the morphs it names: offsets (summed),
// material and bone morphs; and the count of group entries it cannot follow.
struct MorphBake {
  OffsetSum<3> positions;
  OffsetSum<2> uvs;
  std::vector<MaterialMorph> material;
  std::vector<BoneMorph> bone;
  size_t baked = 0, nested = 0,
         other = 0;  // Offsets baked; entries naming a group; naming a morph not applied.
};

constexpr size_t kMaxBakedOffsets =
    size_t{1} << 26;  // ~1.5 GiB of group offsets: a hostile file, not a model.

void AddBoneMorph(const Morph& src, float f, const std::vector<int>& node_of, MorphBake& bake) {
  for (const BoneMorph& b : src.bone) {
    const std::array<float, 3> t = ToGltf(b.translation.data());
    const std::array<float, 4> q =
        NormalizedQuaternion({-b.rotation[0], -b.rotation[1], b.rotation[2], b.rotation[3]});
    bake.bone.push_back(
        {node_of[b.node], {f * t[0], f * t[1], f * t[2]}, Slerp({0, 0, 0, 1}, q, f)});
  }
}

// A group's entry `c` at factor f: its vertex and UV offsets baked, its material and bone morphs
// kept. PMX 2.0 makes a group inside a group invalid (against recursion): those are counted, not
// followed.
Status BakeGroupEntry(const Model& in, const std::string& name, const Morph& c, float f,
                      const std::vector<int>& node_of, MorphBake& bake) {
  if (c.type == 8) {
    for (MaterialMorph mm : c.material) {
      mm.factor *= f;
      bake.material.push_back(mm);
    }
  } else if (c.type == 2) {
    AddBoneMorph(c, f, node_of, bake);
  } else if (c.type == 1 || c.type == 3) {
    bake.baked += c.type == 1 ? c.vertex.size() : c.uv.size();
    if (bake.baked > kMaxBakedOffsets) {
      return InvalidArgument(name + ": " + std::string(in.format) +
                             ": group morphs name more than " + std::to_string(kMaxBakedOffsets) +
                             " vertex offsets in all");
    }
    if (c.type == 1)
      bake.positions.Add(c.vertex, f);
    else
      bake.uvs.Add(c.uv, f);
  } else {
    ++(c.type == 0 ? bake.nested : bake.other);
  }
  return Status::Ok();
}

// Shapes: vertex and UV morphs, and group morphs baked from the vertex and UV morphs they name
// (bone and material morphs kept by the shape, flips picking shapes at weights). Every morph is its
// own shape, as in MMD, whose motions name morphs by their (Japanese) names: an English name
// becomes an alias only when no morph of the file is called so.
Status AddShapes(const Model& in, const std::string& name, const std::vector<int>& node_of,
                 Rig& rig, Mesh& mesh, ShapeOffsets& offsets, std::vector<std::string>& skipped) {
  const std::vector<Morph>& morphs = in.morphs;
  MorphBake bake{OffsetSum<3>(in.verts.size()), OffsetSum<2>(in.verts.size()), {}, {}};
  std::set<std::string> morph_names;
  std::vector<int64_t> shape_of(morphs.size(), -1);  // A flip's entries name morphs: their shapes.
  for (size_t mi = 0, next = 0; mi < morphs.size(); ++mi) {
    morph_names.insert(morphs[mi].name);
    if (MorphIsShape(morphs[mi].type)) shape_of[mi] = static_cast<int64_t>(next++);
  }
  for (size_t mi = 0; mi < morphs.size(); ++mi) {
    const Morph& m = morphs[mi];
    if (!MorphIsShape(m.type)) continue;
    if (m.type == 9) {  // A flip: a shape of its own that moves nothing, picking one of its
                        // entries' shapes (EffectiveWeights).
      Flip flip{static_cast<uint32_t>(shape_of[mi]), {}};
      for (const auto& [child, w] : m.group) {
        if (shape_of[child] >= 0 && morphs[child].type != 9)
          flip.entries.emplace_back(static_cast<uint32_t>(shape_of[child]), w);
        else
          ++bake.other;
      }
      rig.flips.push_back(std::move(flip));
    }
    bake.material = m.material;  // A material morph's own, or a group's entries'.
    bake.bone.clear();           // A bone morph's own, or a group's entries' (by its factor).
    if (m.type == 2) AddBoneMorph(m, 1.0f, node_of, bake);
    if (m.type == 1) bake.positions.Add(m.vertex, 1.0f);
    if (m.type == 3) bake.uvs.Add(m.uv, 1.0f);
    for (size_t e = 0; m.type != 9 && e < m.group.size();
         ++e) {  // A flip's entries are picked, not baked.
      if (Status s =
              BakeGroupEntry(in, name, morphs[m.group[e].first], m.group[e].second, node_of, bake);
          !s.ok())
        return s;
    }
    Shape shape;
    shape.name = m.name.empty() ? "morph" + std::to_string(mi) : m.name;
    for (int k = 2; FindShape(rig, shape.name) >= 0; ++k)
      shape.name = m.name + "_" + std::to_string(k);
    if (!m.english.empty() && !morph_names.count(m.english) && FindShape(rig, m.english) < 0)
      shape.aliases.push_back(m.english);
    shape.group = MorphGroup(m.panel, m.name, m.english);
    shape.material_morphs = std::move(bake.material);
    shape.bone_morphs = std::move(bake.bone);
    mesh.target_shapes.push_back(static_cast<uint32_t>(rig.shapes.size()));
    rig.shapes.push_back(shape);
    offsets.positions.push_back(bake.positions.Take());
    offsets.uvs.push_back(bake.uvs.Take());
  }
  if (bake.nested)
    skipped.push_back(std::to_string(bake.nested) +
                      " group-morph entries naming group morphs (PMX 2.0 does not nest groups)");
  if (bake.other)
    skipped.push_back(std::to_string(bake.other) +
                      " group- or flip-morph entries naming additional-UV, flip or impulse morphs");
  return Status::Ok();
}

// A PMX material as the rig's: its diffuse colour (blended when see-through), two-sided, its
// texture by its path in the model's folder (the bytes read by LoadImagesBeside, a file's loader:
// until then reported as not loaded), one image per texture.
Material MaterialOf(const Model& in, const ModelMaterial& m, std::vector<int>& image_of, Rig& rig) {
  Material mat;
  mat.name = m.name;
  for (int c = 0; c < 4; ++c) mat.base_color_factor[c] = std::clamp(m.diffuse[c], 0.0f, 1.0f);
  if (mat.base_color_factor[3] < 1.0f) mat.alpha_mode = "BLEND";
  mat.metallic_factor = 0.0f;
  mat.roughness_factor = 0.9f;
  mat.double_sided = true;  // MMD draws most materials two-sided.
  // Toon-shaded, its edge (when drawn) an outline: MMD's edge size 1 as a quarter of a percent of
  // the picture's height (about what MMD draws at a full-body view; our choice).
  mat.toon = true;
  for (int c = 0; c < 4; ++c)
    mat.outline_color[c] = std::isfinite(m.edge[c]) ? std::clamp(m.edge[c], 0.0f, 1.0f) : 0.0f;
  mat.outline_width = 0.0025f * m.edge_size;
  if (m.texture >= 0 && static_cast<size_t>(m.texture) < in.textures.size()) {
    if (image_of[m.texture] < 0) {
      std::string path = in.textures[m.texture];
      std::replace(path.begin(), path.end(), '\\', '/');
      image_of[m.texture] = AddImageBeside(rig, path);
    }
    mat.base_color_image = image_of[m.texture];
  }
  return mat;
}

// The vertices `used` (in vertex order) as a primitive's attributes and joints.
void FillVertices(const Model& in, std::span<const uint32_t> used, Primitive& p) {
  const bool skinned = !in.bones.empty();
  size_t most = 1;
  for (uint32_t v : used) most = std::max<size_t>(most, static_cast<size_t>(in.verts[v].count));
  p.influences = skinned ? most : 0;
  for (uint32_t v : used) {
    const Vertex& x = in.verts[v];
    const auto pos = ToGltf(x.pos);
    p.positions.insert(p.positions.end(), pos.begin(), pos.end());
    p.normals.insert(p.normals.end(), {x.normal[0], x.normal[1], -x.normal[2]});
    p.texcoords.insert(p.texcoords.end(), {x.uv[0], x.uv[1]});
    if (!skinned) continue;
    float total = 0;
    for (int k = 0; k < x.count; ++k)
      total += x.bones[k] >= 0 ? std::max(0.0f, x.weights[k]) : 0.0f;
    for (size_t k = 0; k < most; ++k) {
      const bool real = static_cast<int>(k) < x.count && x.bones[k] >= 0 && total > 0;
      p.joints.push_back(real ? static_cast<uint16_t>(x.bones[k]) : 0);
      p.joint_weights.push_back(real ? std::max(0.0f, x.weights[k]) / total
                                     : (k == 0 && total <= 0 ? 1.0f : 0.0f));
    }
  }
}

// One primitive per material, over the vertices its faces use (in vertex order, so that each
// shape's offsets, in vertex order, land in ascending local indices); `used_of` gets each one's
// model vertices, `material_of` each PMX material's index in the rig (-1 for one without faces).
Status AddPrimitives(const Model& in, const std::string& name, size_t shapes, Rig& rig, Mesh& mesh,
                     std::vector<std::vector<uint32_t>>& used_of, std::vector<int>& material_of) {
  size_t nonempty = 0;
  for (const ModelMaterial& m : in.mats) nonempty += m.indices > 0;
  constexpr size_t kMaxTargets = size_t{1} << 22;  // Materials x shapes: 50 x 500 in a big model.
  if (nonempty * shapes > kMaxTargets) {
    return InvalidArgument(name + ": " + std::string(in.format) + ": " + std::to_string(nonempty) +
                           " materials x " + std::to_string(shapes) + " morphs is beyond " +
                           std::to_string(kMaxTargets) + " targets");
  }
  std::vector<int> image_of(in.textures.size(), -1);
  std::vector<int32_t> remap(in.verts.size(), -1);
  material_of.assign(in.mats.size(), -1);
  size_t first = 0;
  for (size_t mi = 0; mi < in.mats.size(); ++mi) {
    const std::span<const uint32_t> faces(in.indices.data() + first, in.mats[mi].indices);
    first += in.mats[mi].indices;
    if (faces.empty()) continue;
    std::vector<uint32_t> used;
    for (uint32_t v : faces) {
      if (remap[v] < 0) used.push_back(v);
      remap[v] = 0;
    }
    std::sort(used.begin(), used.end());
    for (size_t k = 0; k < used.size(); ++k) remap[used[k]] = static_cast<int32_t>(k);
    Primitive p;
    p.mesh = 0;
    p.index_in_mesh = static_cast<int>(rig.primitives.size());
    p.indices.reserve(faces.size());
    for (size_t i = 0; i < faces.size(); i += 3) {
      for (uint32_t v : {faces[i], faces[i + 2], faces[i + 1]})
        p.indices.push_back(
            static_cast<uint32_t>(remap[v]));  // Left- to right-handed: swap two corners.
    }
    for (uint32_t v : used) remap[v] = -1;
    FillVertices(in, used, p);
    p.source_has_normals = true;
    p.targets.resize(shapes);
    p.material = static_cast<int>(rig.materials.size());
    material_of[mi] = p.material;
    rig.materials.push_back(MaterialOf(in, in.mats[mi], image_of, rig));
    FinalizePrimitive(p);
    mesh.primitives.push_back(static_cast<int>(rig.primitives.size()));
    rig.primitives.push_back(std::move(p));
    used_of.push_back(std::move(used));
  }
  if (rig.primitives.empty())
    return InvalidArgument(name + ": " + std::string(in.format) + ": no material covers any face");
  return Status::Ok();
}

// Material morphs to the rig's materials (a PMX material that covers no face has none: dropped).
void RemapMaterialMorphs(const std::vector<int>& material_of, Rig& rig) {
  for (Shape& shape : rig.shapes) {
    std::vector<MaterialMorph> kept;
    for (MaterialMorph mm : shape.material_morphs) {
      if (mm.material >= 0 && material_of[mm.material] < 0) continue;
      if (mm.material >= 0) mm.material = material_of[mm.material];
      kept.push_back(mm);
    }
    shape.material_morphs = std::move(kept);
  }
}

// Each shape's offsets to the primitives holding their vertices: per model vertex, its (primitive,
// local index) slots (CSR), so the work is the offsets written, not materials x offsets.
void ScatterOffsets(const ShapeOffsets& offsets, const std::vector<std::vector<uint32_t>>& used_of,
                    size_t nverts, Rig& rig) {
  std::vector<uint32_t> slot_start(nverts + 1, 0);
  for (const auto& used : used_of) {
    for (uint32_t v : used) ++slot_start[v + 1];
  }
  for (size_t v = 0; v < nverts; ++v) slot_start[v + 1] += slot_start[v];
  std::vector<std::pair<uint32_t, uint32_t>> slots(slot_start[nverts]);
  std::vector<uint32_t> fill(slot_start.begin(), slot_start.end() - 1);
  for (size_t q = 0; q < used_of.size(); ++q) {
    for (size_t k = 0; k < used_of[q].size(); ++k)
      slots[fill[used_of[q][k]]++] = {static_cast<uint32_t>(q), static_cast<uint32_t>(k)};
  }
  for (size_t s = 0; s < offsets.positions.size(); ++s) {
    for (const auto& [v, off] : offsets.positions[s]) {
      if (off[0] == 0 && off[1] == 0 && off[2] == 0) continue;
      const std::array<float, 3> d = ToGltf(off.data());
      for (uint32_t k = slot_start[v]; k < slot_start[v + 1]; ++k) {
        SparseTarget& t = rig.primitives[slots[k].first].targets[s];
        t.indices.push_back(slots[k].second);
        t.position_deltas.insert(t.position_deltas.end(), d.begin(), d.end());
      }
    }
    for (const auto& [v, off] : offsets.uvs[s]) {
      if (off[0] == 0 && off[1] == 0) continue;
      for (uint32_t k = slot_start[v]; k < slot_start[v + 1]; ++k) {
        SparseTarget& t = rig.primitives[slots[k].first].targets[s];
        t.texcoord_indices.push_back(slots[k].second);
        t.texcoord_deltas.insert(t.texcoord_deltas.end(), off.begin(), off.end());
      }
    }
    for (Primitive& p : rig.primitives) FinalizeTarget(p.targets[s]);
  }
}

// What the rig does not carry of the model, said once each: SDEF/QDEF skinning, constraints,
// rigid bodies, morphs.
void WarnUnapplied(const Model& in, const std::vector<int>& node_of,
                   std::vector<std::string> skipped, Rig& rig) {
  if (in.sdef || in.qdef) {
    rig.load_warnings.push_back({"skinning_approximated",
                                 std::to_string(in.sdef) + " SDEF vertices skinned as BDEF2, " +
                                     std::to_string(in.qdef) + " QDEF as BDEF4",
                                 "", static_cast<double>(in.sdef + in.qdef), true});
  }
  size_t dropped = 0;
  ReadConstraints(in.bones, node_of, rig, dropped);
  const size_t ik = in.ik, grants = in.grants;
  const size_t unread =
      (ik + grants) - std::min(ik + grants, rig.constraints.grants.size() +
                                                rig.constraints.chains.size() + dropped);
  if (dropped || unread) {
    rig.load_warnings.push_back(
        {"bone_constraints_skipped",
         std::to_string(dropped + unread) + " of the " + std::to_string(ik) + " IK bones and " +
             std::to_string(grants) + " grant (inherit) bones are not applied" +
             (dropped
                  ? " (" + std::to_string(dropped) +
                        " name no bone or themselves, or would take a pose past the work allowed)"
                  : ""),
         "", static_cast<double>(dropped + unread), false});
  }
  size_t physics_dropped = 0;
  ReadPhysics(in, node_of, rig, physics_dropped);
  if (physics_dropped) {
    rig.load_warnings.push_back(
        {"physics_skipped",
         std::to_string(physics_dropped) + " of the " + std::to_string(in.bodies.size()) +
             " rigid bodies and " + std::to_string(in.joints.size()) +
             " joints name no bone or body, have an unknown shape, mode or joint type, or pass the "
             "counts allowed (1,024 bodies, 2,048 joints): not simulated",
         "", static_cast<double>(physics_dropped), false});
  }
  for (const auto& [type, count] : in.unapplied) {
    static const char* kNames[] = {"group",
                                   "vertex",
                                   "bone",
                                   "UV",
                                   "additional-UV-1",
                                   "additional-UV-2",
                                   "additional-UV-3",
                                   "additional-UV-4",
                                   "material",
                                   "flip",
                                   "impulse"};
    const char* why = type == 10 ? " (a push on a rigid body, PMX 2.1: not simulated)"
                                 : " (the model's additional UV sets, which only MMD effect "
                                   "shaders read, are not carried)";
    skipped.push_back(std::to_string(count) + " " + kNames[type] + " morph" +
                      (count > 1 ? "s" : "") + why);
  }
  if (!skipped.empty()) {
    std::string list;
    for (const std::string& s : skipped) list += (list.empty() ? "" : ", ") + s;
    rig.load_warnings.push_back({"morphs_skipped", "not applied: " + list, "", 0.0, false});
  }
}

}  // namespace

// The rig: nodes (a root, then the bones), one skin, one mesh with a primitive per material, a
// shape per morph.
Result<Rig> BuildRig(const Model& in, const std::string& name) {
  if (Status s = CheckBoneIndices(in, name); !s.ok()) return s;
  std::vector<int> order;
  if (Status s = BonesParentsFirst(in, name, order); !s.ok()) return s;
  Rig rig;
  rig.name = name;
  Skin skin;
  const std::vector<int> node_of = AddSkeleton(in, order, rig, skin);
  Mesh mesh;
  mesh.name = in.name.empty() ? name : in.name;
  mesh.skin = in.bones.empty() ? -1 : 0;
  ShapeOffsets offsets;
  std::vector<std::string> skipped;
  if (Status s = AddShapes(in, name, node_of, rig, mesh, offsets, skipped); !s.ok()) return s;
  std::vector<std::vector<uint32_t>> used_of;  // Per primitive, the model vertices it holds.
  std::vector<int> material_of;
  if (Status s = AddPrimitives(in, name, offsets.positions.size(), rig, mesh, used_of, material_of);
      !s.ok())
    return s;
  RemapMaterialMorphs(material_of, rig);
  ScatterOffsets(offsets, used_of, in.verts.size(), rig);
  rig.meshes.push_back(std::move(mesh));
  Node mesh_node;
  mesh_node.name = rig.meshes[0].name + "_mesh";
  mesh_node.parent = 0;
  mesh_node.mesh = 0;
  rig.nodes[0].children.push_back(static_cast<int>(rig.nodes.size()));
  rig.nodes.push_back(mesh_node);
  if (!in.bones.empty()) {
    rig.skins.push_back(std::move(skin));
    rig.skin_count = 1;
    rig.joint_count = in.bones.size();
  }
  WarnUnapplied(in, node_of, std::move(skipped), rig);
  CountMovedVertices(rig);
  DetectSymmetricPartners(rig);
  RepairNames(rig);
  if (Status s = ValidateRig(rig); !s.ok()) return Prefixed(s, name + ": ");
  return rig;
}

}  // namespace facespace::formats::mmd
