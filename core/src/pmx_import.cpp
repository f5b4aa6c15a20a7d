// MikuMikuDance PMX 2.0/2.1 models as a Rig: vertices with BDEF1/2/4 weights (SDEF and QDEF skinned
// as BDEF2 and BDEF4, reported), faces per material, bones as nodes and one skin, vertex morphs as
// sparse shapes, group morphs baked into shapes of their own (their vertex-morph children summed).
//
// Coordinates: MMD is left-handed, Y up, about 8 cm a unit. On load every position and offset becomes
// (x, y, -z) x 0.08 (right-handed metres, glTF's), and triangles swap two corners to stay front-facing.
//
// A parser of untrusted bytes: every read is bounds-checked, every count capped by what the bytes
// left could hold, every index checked; an error names the section and the item.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "facespace/core/io.h"

namespace facespace {

namespace {

constexpr float kMetresPerUnit = 0.08f;

class Bytes {
 public:
  explicit Bytes(std::span<const unsigned char> b) : b_(b) {}

  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }
  size_t pos() const { return pos_; }
  size_t left() const { return b_.size() - pos_; }

  bool Fail(const std::string& what) {
    if (error_.empty()) error_ = "byte " + std::to_string(pos_) + ": " + what;
    return false;
  }

  bool Raw(void* out, size_t n, const char* what) {
    if (n > left()) return Fail(std::string("truncated in ") + what);
    if (n == 0) return true;  // An empty text: `out` may be null.
    std::memcpy(out, b_.data() + pos_, n);
    pos_ += n;
    return true;
  }
  template <typename T>
  bool Get(T& out, const char* what) { return Raw(&out, sizeof(T), what); }
  bool Floats(float* out, int n, const char* what) {
    if (!Raw(out, sizeof(float) * static_cast<size_t>(n), what)) return false;
    for (int i = 0; i < n; ++i) {
      if (!std::isfinite(out[i])) return Fail(std::string("a non-finite number in ") + what);
    }
    return true;
  }
  bool Skip(size_t n, const char* what) {
    if (n > left()) return Fail(std::string("truncated in ") + what);
    pos_ += n;
    return true;
  }
  // A count of items of at least `item_bytes` each: never more than the bytes left could hold.
  bool Count(size_t item_bytes, size_t& out, const char* what) {
    int32_t n = 0;
    if (!Get(n, what)) return false;
    if (n < 0 || (item_bytes && static_cast<size_t>(n) > left() / item_bytes)) {
      return Fail(std::string(what) + ": count " + std::to_string(n) + " is more than the file holds");
    }
    out = static_cast<size_t>(n);
    return true;
  }
  // An index of `size` bytes (1, 2 or 4); vertex indices of 1 and 2 bytes are unsigned, the others signed.
  bool Index(int size, bool vertex, int64_t& out, const char* what) {
    if (size == 1) {
      uint8_t u = 0;
      if (!Get(u, what)) return false;
      out = vertex ? u : static_cast<int8_t>(u);
    } else if (size == 2) {
      uint16_t u = 0;
      if (!Get(u, what)) return false;
      out = vertex ? u : static_cast<int16_t>(u);
    } else {
      int32_t s = 0;
      if (!Get(s, what)) return false;
      out = s;
    }
    return true;
  }

 private:
  std::span<const unsigned char> b_;
  size_t pos_ = 0;
  std::string error_;
};

// UTF-16LE to UTF-8 (surrogate pairs joined; a lone surrogate becomes U+FFFD).
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

struct Header {
  bool utf8 = false;
  int extra_uv = 0;
  int vertex = 4, texture = 4, material = 4, bone = 4, morph = 4, rigid = 4;
};

bool Text(Bytes& r, const Header& h, std::string& out, const char* what) {
  size_t n = 0;
  if (!r.Count(1, n, what)) return false;
  std::vector<unsigned char> raw(n);
  if (!r.Raw(raw.data(), n, what)) return false;
  out = h.utf8 ? std::string(raw.begin(), raw.end()) : Utf16ToUtf8(raw.data(), n);
  return true;
}

struct Vertex {
  float pos[3], normal[3], uv[2];
  int64_t bones[4] = {-1, -1, -1, -1};
  float weights[4] = {0, 0, 0, 0};
  int count = 1;
};

struct PmxMaterial {
  std::string name, english;
  float diffuse[4];
  int64_t texture = -1;
  size_t indices = 0;
};

struct Bone {
  std::string name, english;
  float pos[3];
  int64_t parent = -1;
};

struct Morph {
  std::string name, english;
  int panel = 0, type = 0;
  std::vector<std::pair<int64_t, std::array<float, 3>>> vertex;  // (vertex, offset)
  std::vector<std::pair<int64_t, float>> group;                  // (morph, factor)
};

const char* PanelGroup(int panel) {
  switch (panel) {
    case 1: return "eyebrow";
    case 2: return "eye";
    case 3: return "mouth";
    case 4: return "other";
    default: return "system";
  }
}

}  // namespace

Result<Rig> LoadPmxMemory(std::span<const unsigned char> bytes, const std::string& name) {
  auto fail = [&](const Bytes& r) { return InvalidArgument(name + ": PMX " + r.error()); };
  Bytes r(bytes);
  char magic[4];
  float version = 0;
  uint8_t nglobals = 0;
  if (!r.Raw(magic, 4, "the header") || std::memcmp(magic, "PMX ", 4) != 0) return InvalidArgument(name + ": not a PMX file (no 'PMX ' magic)");
  if (!r.Get(version, "the header") || !r.Get(nglobals, "the header")) return fail(r);
  if (!(version >= 2.0f && version <= 2.1f)) return InvalidArgument(name + ": PMX version " + std::to_string(version) + " is not 2.0 or 2.1");
  if (nglobals < 8) return InvalidArgument(name + ": PMX header has " + std::to_string(nglobals) + " globals, 8 needed");
  uint8_t g[256];
  if (!r.Raw(g, nglobals, "the header")) return fail(r);
  Header h;
  h.utf8 = g[0] == 1;
  h.extra_uv = g[1];
  h.vertex = g[2], h.texture = g[3], h.material = g[4], h.bone = g[5], h.morph = g[6], h.rigid = g[7];
  for (int s : {h.vertex, h.texture, h.material, h.bone, h.morph, h.rigid}) {
    if (s != 1 && s != 2 && s != 4) return InvalidArgument(name + ": PMX index size " + std::to_string(s) + " is not 1, 2 or 4");
  }
  if (g[0] > 1 || h.extra_uv > 4) return InvalidArgument(name + ": PMX header: bad encoding or additional UV count");
  std::string model, model_en, comment, comment_en;
  if (!Text(r, h, model, "the model name") || !Text(r, h, model_en, "the model name") || !Text(r, h, comment, "the comment") ||
      !Text(r, h, comment_en, "the comment")) {
    return fail(r);
  }

  Rig rig;
  rig.name = name;
  std::vector<std::string> skipped;
  // Vertices.
  size_t nverts = 0;
  if (!r.Count(8 * 4 + 1 + h.bone + 4, nverts, "the vertex count")) return fail(r);
  std::vector<Vertex> verts(nverts);
  size_t sdef = 0, qdef = 0;
  for (size_t v = 0; v < nverts; ++v) {
    Vertex& x = verts[v];
    float extra[16];
    uint8_t kind = 0;
    if (!r.Floats(x.pos, 3, "a vertex") || !r.Floats(x.normal, 3, "a vertex") || !r.Floats(x.uv, 2, "a vertex") ||
        !r.Floats(extra, 4 * h.extra_uv, "a vertex") || !r.Get(kind, "a vertex")) {
      return fail(r);
    }
    if (kind == 0) {
      if (!r.Index(h.bone, false, x.bones[0], "a vertex's bone")) return fail(r);
      x.weights[0] = 1;
    } else if (kind == 1 || kind == 3) {
      if (!r.Index(h.bone, false, x.bones[0], "a vertex's bone") || !r.Index(h.bone, false, x.bones[1], "a vertex's bone") ||
          !r.Floats(&x.weights[0], 1, "a vertex weight")) {
        return fail(r);
      }
      x.weights[1] = 1 - x.weights[0];
      x.count = 2;
      if (kind == 3) {
        float sd[9];
        if (!r.Floats(sd, 9, "an SDEF vertex")) return fail(r);
        ++sdef;
      }
    } else if (kind == 2 || kind == 4) {
      for (int k = 0; k < 4; ++k) {
        if (!r.Index(h.bone, false, x.bones[k], "a vertex's bone")) return fail(r);
      }
      if (!r.Floats(x.weights, 4, "vertex weights")) return fail(r);
      x.count = 4;
      qdef += kind == 4;
    } else {
      r.Fail("vertex " + std::to_string(v) + " has weight type " + std::to_string(kind));
      return fail(r);
    }
    float edge;
    if (!r.Floats(&edge, 1, "a vertex")) return fail(r);
  }
  // Faces.
  size_t nindices = 0;
  if (!r.Count(static_cast<size_t>(h.vertex), nindices, "the face index count")) return fail(r);
  if (nindices % 3) return InvalidArgument(name + ": PMX: " + std::to_string(nindices) + " face indices is not whole triangles");
  std::vector<uint32_t> indices(nindices);
  for (size_t i = 0; i < nindices; ++i) {
    int64_t v = 0;
    if (!r.Index(h.vertex, true, v, "a face")) return fail(r);
    if (v < 0 || static_cast<size_t>(v) >= nverts) return InvalidArgument(name + ": PMX: face index " + std::to_string(i) + " is vertex " + std::to_string(v) + " of " + std::to_string(nverts));
    indices[i] = static_cast<uint32_t>(v);
  }
  // Textures (paths, kept for the report).
  size_t ntex = 0;
  if (!r.Count(4, ntex, "the texture count")) return fail(r);
  std::vector<std::string> textures(ntex);
  for (std::string& t : textures) {
    if (!Text(r, h, t, "a texture path")) return fail(r);
  }
  // Materials: each covers the next `indices` face indices.
  size_t nmats = 0;
  if (!r.Count(8, nmats, "the material count")) return fail(r);
  std::vector<PmxMaterial> mats(nmats);
  size_t covered = 0;
  for (PmxMaterial& m : mats) {
    float spec[8], edge[5];
    uint8_t flags, env_mode, toon_ref;
    int64_t env, toon;
    std::string memo;
    int32_t count = 0;
    if (!Text(r, h, m.name, "a material") || !Text(r, h, m.english, "a material") || !r.Floats(m.diffuse, 4, "a material") ||
        !r.Floats(spec, 7, "a material") || !r.Get(flags, "a material") || !r.Floats(edge, 5, "a material") ||
        !r.Index(h.texture, false, m.texture, "a material") || !r.Index(h.texture, false, env, "a material") || !r.Get(env_mode, "a material") ||
        !r.Get(toon_ref, "a material")) {
      return fail(r);
    }
    if (toon_ref == 0) {
      if (!r.Index(h.texture, false, toon, "a material")) return fail(r);
    } else {
      uint8_t t;
      if (!r.Get(t, "a material")) return fail(r);
    }
    if (!Text(r, h, memo, "a material") || !r.Get(count, "a material")) return fail(r);
    if (count < 0 || static_cast<size_t>(count) > nindices - covered || count % 3) {
      return InvalidArgument(name + ": PMX: material '" + m.name + "' covers " + std::to_string(count) + " face indices of the " + std::to_string(nindices - covered) + " left");
    }
    m.indices = static_cast<size_t>(count);
    covered += m.indices;
  }
  // Bones.
  size_t nbones = 0;
  if (!r.Count(8 + 12 + h.bone + 4 + 2, nbones, "the bone count")) return fail(r);
  if (nbones > 65534) return InvalidArgument(name + ": PMX: more than 65534 bones");
  std::vector<Bone> bones(nbones);
  size_t ik = 0, grants = 0;
  for (size_t b = 0; b < nbones; ++b) {
    Bone& x = bones[b];
    int32_t layer;
    uint16_t flags;
    if (!Text(r, h, x.name, "a bone") || !Text(r, h, x.english, "a bone") || !r.Floats(x.pos, 3, "a bone") ||
        !r.Index(h.bone, false, x.parent, "a bone's parent") || !r.Get(layer, "a bone") || !r.Get(flags, "a bone")) {
      return fail(r);
    }
    int64_t idx;
    float f[6];
    if ((flags & 0x0001) ? !r.Index(h.bone, false, idx, "a bone's tail") : !r.Floats(f, 3, "a bone's tail")) return fail(r);
    if (flags & 0x0300) {
      ++grants;
      if (!r.Index(h.bone, false, idx, "a bone's grant") || !r.Floats(f, 1, "a bone's grant")) return fail(r);
    }
    if ((flags & 0x0400) && !r.Floats(f, 3, "a bone's fixed axis")) return fail(r);
    if ((flags & 0x0800) && !r.Floats(f, 6, "a bone's local axes")) return fail(r);
    if ((flags & 0x2000) && !r.Skip(4, "a bone's external parent")) return fail(r);
    if (flags & 0x0020) {
      ++ik;
      int32_t loops;
      size_t links = 0;
      if (!r.Index(h.bone, false, idx, "an IK target") || !r.Get(loops, "an IK bone") || !r.Floats(f, 1, "an IK bone") ||
          !r.Count(static_cast<size_t>(h.bone) + 1, links, "the IK link count")) {
        return fail(r);
      }
      for (size_t l = 0; l < links; ++l) {
        uint8_t limited;
        if (!r.Index(h.bone, false, idx, "an IK link") || !r.Get(limited, "an IK link")) return fail(r);
        if (limited && !r.Floats(f, 6, "an IK link's limits")) return fail(r);
      }
    }
  }
  for (size_t b = 0; b < nbones; ++b) {
    if (bones[b].parent >= static_cast<int64_t>(nbones) || bones[b].parent < -1) {
      return InvalidArgument(name + ": PMX: bone '" + bones[b].name + "' has parent " + std::to_string(bones[b].parent) + " of " + std::to_string(nbones));
    }
  }
  for (size_t v = 0; v < nverts; ++v) {
    for (int k = 0; k < verts[v].count; ++k) {
      if (verts[v].bones[k] >= static_cast<int64_t>(nbones) || (verts[v].bones[k] < 0 && verts[v].weights[k] != 0)) {
        return InvalidArgument(name + ": PMX: vertex " + std::to_string(v) + " names bone " + std::to_string(verts[v].bones[k]) + " of " + std::to_string(nbones));
      }
    }
  }
  // Morphs.
  size_t nmorphs = 0;
  if (!r.Count(8 + 2 + 4, nmorphs, "the morph count")) return fail(r);
  std::vector<Morph> morphs(nmorphs);
  std::map<int, size_t> unapplied;  // Morph type -> count.
  for (size_t mi = 0; mi < nmorphs; ++mi) {
    Morph& m = morphs[mi];
    uint8_t panel, type;
    size_t n = 0;
    if (!Text(r, h, m.name, "a morph") || !Text(r, h, m.english, "a morph") || !r.Get(panel, "a morph") || !r.Get(type, "a morph")) return fail(r);
    m.panel = panel;
    m.type = type;
    const size_t item = type == 0 || type == 9 ? h.morph + 4 : type == 1 ? h.vertex + 12 : type == 2 ? h.bone + 28 : (type >= 3 && type <= 7) ? h.vertex + 16
                        : type == 8 ? h.material + 113 : type == 10 ? h.rigid + 25 : 0;
    if (!item) {
      r.Fail("morph '" + m.name + "' has type " + std::to_string(type));
      return fail(r);
    }
    if (!r.Count(item, n, "a morph's offset count")) return fail(r);
    for (size_t k = 0; k < n; ++k) {
      int64_t idx = 0;
      if (type == 1) {
        std::array<float, 3> d;
        if (!r.Index(h.vertex, true, idx, "a vertex morph") || !r.Floats(d.data(), 3, "a vertex morph")) return fail(r);
        if (idx < 0 || static_cast<size_t>(idx) >= nverts) return InvalidArgument(name + ": PMX: morph '" + m.name + "' moves vertex " + std::to_string(idx) + " of " + std::to_string(nverts));
        m.vertex.emplace_back(idx, d);
      } else if (type == 0) {
        float f;
        if (!r.Index(h.morph, false, idx, "a group morph") || !r.Floats(&f, 1, "a group morph")) return fail(r);
        if (idx < 0 || static_cast<size_t>(idx) >= nmorphs) return InvalidArgument(name + ": PMX: group morph '" + m.name + "' names morph " + std::to_string(idx) + " of " + std::to_string(nmorphs));
        m.group.emplace_back(idx, f);
      } else if (!r.Skip(item, "a morph")) {
        return fail(r);
      }
    }
    if (type != 0 && type != 1) ++unapplied[type];
  }
  // What follows (display frames, rigid bodies, joints) is physics and UI: not read.

  // The rig: nodes (a root, then the bones), one skin, one mesh with a primitive per material.
  Node root;
  root.name = model.empty() ? "pmx_root" : model;
  rig.nodes.push_back(root);
  rig.scene_roots = {0};
  Skin skin;
  skin.name = "pmx_skeleton";
  auto convert = [](const float* p) { return std::array<float, 3>{p[0] * kMetresPerUnit, p[1] * kMetresPerUnit, -p[2] * kMetresPerUnit}; };
  std::vector<int> order;  // Bones parents first (PMX does not promise it); a cycle is an error.
  {
    std::vector<int> state(nbones, 0);
    for (size_t b = 0; b < nbones; ++b) {
      std::vector<int> chain;
      for (int64_t c = static_cast<int64_t>(b); c >= 0 && state[c] != 2; c = bones[c].parent) {
        if (state[c] == 1) return InvalidArgument(name + ": PMX: bone '" + bones[c].name + "' is its own ancestor");
        state[c] = 1;
        chain.push_back(static_cast<int>(c));
      }
      for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
        state[*it] = 2;
        order.push_back(*it);
      }
    }
  }
  std::vector<int> node_of(nbones, -1);
  for (int b : order) {
    const Bone& x = bones[b];
    Node n;
    n.name = x.name;
    n.parent = x.parent < 0 ? 0 : node_of[x.parent];
    const std::array<float, 3> p = convert(x.pos);
    const std::array<float, 3> pp = x.parent < 0 ? std::array<float, 3>{0, 0, 0} : convert(bones[x.parent].pos);
    n.translation = {p[0] - pp[0], p[1] - pp[1], p[2] - pp[2]};
    node_of[b] = static_cast<int>(rig.nodes.size());
    rig.nodes[n.parent].children.push_back(node_of[b]);
    rig.nodes.push_back(n);
  }
  for (size_t b = 0; b < nbones; ++b) {
    skin.joints.push_back(node_of[b]);
    const std::array<float, 3> p = convert(bones[b].pos);
    const float ib[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -p[0], -p[1], -p[2], 1};
    skin.inverse_bind.insert(skin.inverse_bind.end(), ib, ib + 16);
  }
  Mesh mesh;
  mesh.name = model.empty() ? name : model;
  mesh.skin = nbones ? 0 : -1;
  // Shapes: vertex morphs, and group morphs baked from the vertex morphs they name. PMX 2.0 makes a
  // group inside a group invalid (against recursion), so those entries are not followed, and reported.
  // Each shape's offsets are summed per vertex and kept in vertex order.
  constexpr size_t kMaxBakedOffsets = size_t{1} << 26;  // ~1.5 GiB of group offsets: a hostile file, not a model.
  std::vector<std::array<float, 3>> acc(nverts, {0, 0, 0});
  std::vector<char> hit(nverts, 0);
  size_t baked = 0, nested = 0, other = 0;  // Group entries naming a group morph; naming a morph we do not apply.
  std::vector<std::vector<std::pair<uint32_t, std::array<float, 3>>>> deltas;
  for (size_t mi = 0; mi < nmorphs; ++mi) {
    const Morph& m = morphs[mi];
    if (m.type != 0 && m.type != 1) continue;
    std::vector<uint32_t> touched;
    auto add = [&](const Morph& src, float f) {
      for (const auto& [v, d] : src.vertex) {
        if (!hit[v]) touched.push_back(static_cast<uint32_t>(v));
        hit[v] = 1;
        for (int c = 0; c < 3; ++c) acc[v][c] += f * d[c];
      }
    };
    if (m.type == 1) add(m, 1.0f);
    for (const auto& [child, f] : m.group) {
      const Morph& c = morphs[child];
      if (c.type != 1) {
        ++(c.type == 0 ? nested : other);
        continue;
      }
      baked += c.vertex.size();
      if (baked > kMaxBakedOffsets) return InvalidArgument(name + ": PMX: group morphs name more than " + std::to_string(kMaxBakedOffsets) + " vertex offsets in all");
      add(c, f);
    }
    std::sort(touched.begin(), touched.end());
    std::vector<std::pair<uint32_t, std::array<float, 3>>> d;
    d.reserve(touched.size());
    for (uint32_t v : touched) {
      d.emplace_back(v, acc[v]);
      acc[v] = {0, 0, 0};
      hit[v] = 0;
    }
    Shape shape;
    shape.name = m.name.empty() ? "morph" + std::to_string(mi) : m.name;
    for (int k = 2; FindShape(rig, shape.name) >= 0; ++k) shape.name = m.name + "_" + std::to_string(k);
    if (!m.english.empty() && m.english != shape.name && FindShape(rig, m.english) < 0) shape.aliases.push_back(m.english);
    shape.group = PanelGroup(m.panel);
    mesh.target_shapes.push_back(static_cast<uint32_t>(rig.shapes.size()));
    rig.shapes.push_back(shape);
    deltas.push_back(std::move(d));
  }
  if (nested) skipped.push_back(std::to_string(nested) + " group-morph entries naming group morphs (PMX 2.0 does not nest groups)");
  if (other) skipped.push_back(std::to_string(other) + " group-morph entries naming bone, UV or material morphs");
  for (const auto& [type, count] : unapplied) {
    static const char* kNames[] = {"group", "vertex", "bone", "UV", "UV1", "UV2", "UV3", "UV4", "material", "flip", "impulse"};
    skipped.push_back(std::to_string(count) + " " + kNames[type] + " morph" + (count > 1 ? "s" : ""));
  }
  // One primitive per material, over the vertices its faces use (in vertex order, so that each
  // shape's offsets, in vertex order, land in ascending local indices).
  size_t nonempty = 0;
  for (const PmxMaterial& m : mats) nonempty += m.indices > 0;
  constexpr size_t kMaxTargets = size_t{1} << 22;  // Materials x shapes: 50 x 500 in a big model.
  if (nonempty * deltas.size() > kMaxTargets) {
    return InvalidArgument(name + ": PMX: " + std::to_string(nonempty) + " materials x " + std::to_string(deltas.size()) + " morphs is beyond " + std::to_string(kMaxTargets) + " targets");
  }
  std::vector<int32_t> remap(nverts, -1);
  std::vector<std::vector<uint32_t>> used_of;  // Per primitive, the PMX vertices it holds.
  size_t first = 0;
  for (size_t mi = 0; mi < nmats; ++mi) {
    const PmxMaterial& m = mats[mi];
    const std::span<const uint32_t> faces(indices.data() + first, m.indices);
    first += m.indices;
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
      for (uint32_t v : {faces[i], faces[i + 2], faces[i + 1]}) p.indices.push_back(static_cast<uint32_t>(remap[v]));  // Left- to right-handed: swap two corners.
    }
    for (uint32_t v : used) remap[v] = -1;
    size_t most = 1;
    for (uint32_t v : used) most = std::max<size_t>(most, static_cast<size_t>(verts[v].count));
    p.influences = nbones ? most : 0;
    for (uint32_t v : used) {
      const Vertex& x = verts[v];
      const auto pos = convert(x.pos);
      p.positions.insert(p.positions.end(), pos.begin(), pos.end());
      p.normals.insert(p.normals.end(), {x.normal[0], x.normal[1], -x.normal[2]});
      p.texcoords.insert(p.texcoords.end(), {x.uv[0], x.uv[1]});
      if (!nbones) continue;
      float total = 0;
      for (int k = 0; k < x.count; ++k) total += x.bones[k] >= 0 ? std::max(0.0f, x.weights[k]) : 0.0f;
      for (size_t k = 0; k < most; ++k) {
        const bool real = static_cast<int>(k) < x.count && x.bones[k] >= 0 && total > 0;
        p.joints.push_back(real ? static_cast<uint16_t>(x.bones[k]) : 0);
        p.joint_weights.push_back(real ? std::max(0.0f, x.weights[k]) / total : (k == 0 && total <= 0 ? 1.0f : 0.0f));
      }
    }
    p.source_has_normals = true;
    p.targets.resize(deltas.size());
    Material mat;
    mat.name = m.name;
    for (int c = 0; c < 4; ++c) mat.base_color_factor[c] = std::clamp(m.diffuse[c], 0.0f, 1.0f);
    if (mat.base_color_factor[3] < 1.0f) mat.alpha_mode = "BLEND";
    mat.metallic_factor = 0.0f;
    mat.roughness_factor = 0.9f;
    mat.double_sided = true;  // MMD draws most materials two-sided.
    if (m.texture >= 0 && static_cast<size_t>(m.texture) < textures.size()) {
      rig.load_warnings.push_back({"texture_not_loaded", "material '" + m.name + "': texture '" + textures[m.texture] + "' is not read", m.name, 0.0, false});
    }
    p.material = static_cast<int>(rig.materials.size());
    rig.materials.push_back(mat);
    FinalizePrimitive(p);
    mesh.primitives.push_back(static_cast<int>(rig.primitives.size()));
    rig.primitives.push_back(std::move(p));
    used_of.push_back(std::move(used));
  }
  if (rig.primitives.empty()) return InvalidArgument(name + ": PMX: no material covers any face");
  // Each shape's offsets to the primitives holding their vertices: per PMX vertex, its (primitive,
  // local index) slots (CSR), so the work is the offsets written, not materials x offsets.
  std::vector<uint32_t> slot_start(nverts + 1, 0);
  for (const auto& used : used_of) {
    for (uint32_t v : used) ++slot_start[v + 1];
  }
  for (size_t v = 0; v < nverts; ++v) slot_start[v + 1] += slot_start[v];
  std::vector<std::pair<uint32_t, uint32_t>> slots(slot_start[nverts]);
  {
    std::vector<uint32_t> fill(slot_start.begin(), slot_start.end() - 1);
    for (size_t q = 0; q < used_of.size(); ++q) {
      for (size_t k = 0; k < used_of[q].size(); ++k) slots[fill[used_of[q][k]]++] = {static_cast<uint32_t>(q), static_cast<uint32_t>(k)};
    }
  }
  for (size_t s = 0; s < deltas.size(); ++s) {
    for (const auto& [v, off] : deltas[s]) {
      if (off[0] == 0 && off[1] == 0 && off[2] == 0) continue;
      const std::array<float, 3> d = convert(off.data());
      for (uint32_t k = slot_start[v]; k < slot_start[v + 1]; ++k) {
        SparseTarget& t = rig.primitives[slots[k].first].targets[s];
        t.indices.push_back(slots[k].second);
        t.position_deltas.insert(t.position_deltas.end(), d.begin(), d.end());
      }
    }
    for (Primitive& p : rig.primitives) FinalizeTarget(p.targets[s]);
  }
  rig.meshes.push_back(std::move(mesh));
  Node mesh_node;
  mesh_node.name = rig.meshes[0].name + "_mesh";
  mesh_node.parent = 0;
  mesh_node.mesh = 0;
  rig.nodes[0].children.push_back(static_cast<int>(rig.nodes.size()));
  rig.nodes.push_back(mesh_node);
  if (nbones) {
    rig.skins.push_back(std::move(skin));
    rig.skin_count = 1;
    rig.joint_count = nbones;
  }
  if (sdef || qdef) {
    rig.load_warnings.push_back({"skinning_approximated", std::to_string(sdef) + " SDEF vertices skinned as BDEF2, " + std::to_string(qdef) + " QDEF as BDEF4", "", static_cast<double>(sdef + qdef), true});
  }
  if (ik || grants) {
    rig.load_warnings.push_back({"bone_constraints_skipped", std::to_string(ik) + " IK bones and " + std::to_string(grants) + " grant (inherit) bones are read but not applied", "", 0.0, false});
  }
  if (!skipped.empty()) {
    std::string list;
    for (const std::string& s : skipped) list += (list.empty() ? "" : ", ") + s;
    rig.load_warnings.push_back({"morphs_skipped", "not applied: " + list, "", 0.0, false});
  }
  CountMovedVertices(rig);
  DetectSymmetricPartners(rig);
  if (Status s = ValidateRig(rig); !s.ok()) return Prefixed(s, name + ": ");
  return rig;
}

}  // namespace facespace
