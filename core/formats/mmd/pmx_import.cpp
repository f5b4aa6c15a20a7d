// MikuMikuDance PMX 2.0/2.1 models as a Rig: vertices with BDEF1/2/4 weights (SDEF and QDEF skinned
// as BDEF2 and BDEF4, reported), faces per material, bones as nodes and one skin, vertex morphs as
// sparse shapes, group morphs baked into shapes of their own (their vertex-morph children summed).
// Coordinates as mmd.h says.
//
// A parser of untrusted bytes: every read is bounds-checked, every count capped by what the bytes
// left could hold, every index checked; an error names the section and the item.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "facespace/formats/io.h"
#include "mmd/mmd.h"

namespace facespace::formats {

namespace {

using namespace mmd;

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

// The section's reader, the file and what was read, for every section below: a read that fails is
// Broken() (the reader's error, which names the section and item).
struct Pmx {
  Bytes r;
  Header h;
  const std::string& name;
  Model model;
  Status Broken() const { return InvalidArgument(name + ": PMX " + r.error()); }
  Status Bad(const std::string& what) const { return InvalidArgument(name + ": PMX: " + what); }
};

// The header: magic, version, the index sizes; then the model's names and comments.
Status ReadHeader(Pmx& p) {
  Bytes& r = p.r;
  char magic[4];
  float version = 0;
  uint8_t nglobals = 0;
  if (!r.Raw(magic, 4, "the header") || std::memcmp(magic, "PMX ", 4) != 0)
    return InvalidArgument(p.name + ": not a PMX file (no 'PMX ' magic)");
  if (!r.Get(version, "the header") || !r.Get(nglobals, "the header")) return p.Broken();
  if (!(version >= 2.0f && version <= 2.1f))
    return InvalidArgument(p.name + ": PMX version " + std::to_string(version) +
                           " is not 2.0 or 2.1");
  if (nglobals < 8)
    return InvalidArgument(p.name + ": PMX header has " + std::to_string(nglobals) +
                           " globals, 8 needed");
  uint8_t g[256];
  if (!r.Raw(g, nglobals, "the header")) return p.Broken();
  Header& h = p.h;
  h.utf8 = g[0] == 1;
  h.extra_uv = g[1];
  h.vertex = g[2], h.texture = g[3], h.material = g[4], h.bone = g[5], h.morph = g[6],
  h.rigid = g[7];
  for (int s : {h.vertex, h.texture, h.material, h.bone, h.morph, h.rigid}) {
    if (s != 1 && s != 2 && s != 4)
      return InvalidArgument(p.name + ": PMX index size " + std::to_string(s) +
                             " is not 1, 2 or 4");
  }
  if (g[0] > 1 || h.extra_uv > 4)
    return InvalidArgument(p.name + ": PMX header: bad encoding or additional UV count");
  std::string model_en, comment, comment_en;
  if (!Text(r, h, p.model.name, "the model name") || !Text(r, h, model_en, "the model name") ||
      !Text(r, h, comment, "the comment") || !Text(r, h, comment_en, "the comment")) {
    return p.Broken();
  }
  return Status::Ok();
}

// A vertex's bones and weights by its weight type: BDEF1, BDEF2, BDEF4, SDEF (as BDEF2), QDEF (as
// BDEF4).
bool ReadVertexWeights(Pmx& p, size_t v, uint8_t kind, Vertex& x) {
  Bytes& r = p.r;
  const int bone = p.h.bone;
  if (kind == 0) {
    x.weights[0] = 1;
    return r.Index(bone, false, x.bones[0], "a vertex's bone");
  }
  if (kind == 1 || kind == 3) {
    if (!r.Index(bone, false, x.bones[0], "a vertex's bone") ||
        !r.Index(bone, false, x.bones[1], "a vertex's bone") ||
        !r.Floats(&x.weights[0], 1, "a vertex weight")) {
      return false;
    }
    x.weights[1] = 1 - x.weights[0];
    x.count = 2;
    float sd[9];
    p.model.sdef += kind == 3;
    return kind != 3 || r.Floats(sd, 9, "an SDEF vertex");
  }
  if (kind == 2 || kind == 4) {
    for (int k = 0; k < 4; ++k) {
      if (!r.Index(bone, false, x.bones[k], "a vertex's bone")) return false;
    }
    x.count = 4;
    p.model.qdef += kind == 4;
    return r.Floats(x.weights, 4, "vertex weights");
  }
  return r.Fail("vertex " + std::to_string(v) + " has weight type " + std::to_string(kind));
}

Status ReadVertices(Pmx& p) {
  Bytes& r = p.r;
  size_t nverts = 0;
  if (!r.Count(8 * 4 + 1 + p.h.bone + 4, nverts, "the vertex count")) return p.Broken();
  p.model.verts.resize(nverts);
  for (size_t v = 0; v < nverts; ++v) {
    Vertex& x = p.model.verts[v];
    float extra[16], edge;
    uint8_t kind = 0;
    if (!r.Floats(x.pos, 3, "a vertex") || !r.Floats(x.normal, 3, "a vertex") ||
        !r.Floats(x.uv, 2, "a vertex") || !r.Floats(extra, 4 * p.h.extra_uv, "a vertex") ||
        !r.Get(kind, "a vertex") || !ReadVertexWeights(p, v, kind, x) ||
        !r.Floats(&edge, 1, "a vertex")) {
      return p.Broken();
    }
  }
  return Status::Ok();
}

// Faces (whole triangles of vertices there are), then the texture paths.
Status ReadFacesAndTextures(Pmx& p) {
  Bytes& r = p.r;
  const size_t nverts = p.model.verts.size();
  size_t nindices = 0;
  if (!r.Count(static_cast<size_t>(p.h.vertex), nindices, "the face index count"))
    return p.Broken();
  if (nindices % 3) return p.Bad(std::to_string(nindices) + " face indices is not whole triangles");
  p.model.indices.resize(nindices);
  for (size_t i = 0; i < nindices; ++i) {
    int64_t v = 0;
    if (!r.Index(p.h.vertex, true, v, "a face")) return p.Broken();
    if (v < 0 || static_cast<size_t>(v) >= nverts)
      return p.Bad("face index " + std::to_string(i) + " is vertex " + std::to_string(v) + " of " +
                   std::to_string(nverts));
    p.model.indices[i] = static_cast<uint32_t>(v);
  }
  size_t ntex = 0;
  if (!r.Count(4, ntex, "the texture count")) return p.Broken();
  p.model.textures.resize(ntex);
  for (std::string& t : p.model.textures) {
    if (!Text(r, p.h, t, "a texture path")) return p.Broken();
  }
  return Status::Ok();
}

// Materials: each covers the next `indices` face indices.
Status ReadMaterials(Pmx& p) {
  Bytes& r = p.r;
  const Header& h = p.h;
  const size_t nindices = p.model.indices.size();
  size_t nmats = 0;
  if (!r.Count(8, nmats, "the material count")) return p.Broken();
  p.model.mats.resize(nmats);
  size_t covered = 0;
  for (ModelMaterial& m : p.model.mats) {
    float spec[8], edge[5];
    uint8_t flags, env_mode, toon_ref, toon_shared;
    int64_t env, toon;
    std::string memo;
    int32_t count = 0;
    if (!Text(r, h, m.name, "a material") || !Text(r, h, m.english, "a material") ||
        !r.Floats(m.diffuse, 4, "a material") || !r.Floats(spec, 7, "a material") ||
        !r.Get(flags, "a material") || !r.Floats(edge, 5, "a material") ||
        !r.Index(h.texture, false, m.texture, "a material") ||
        !r.Index(h.texture, false, env, "a material") || !r.Get(env_mode, "a material") ||
        !r.Get(toon_ref, "a material") ||
        !(toon_ref == 0 ? r.Index(h.texture, false, toon, "a material")
                        : r.Get(toon_shared, "a material")) ||
        !Text(r, h, memo, "a material") || !r.Get(count, "a material")) {
      return p.Broken();
    }
    if (count < 0 || static_cast<size_t>(count) > nindices - covered || count % 3) {
      return p.Bad("material '" + m.name + "' covers " + std::to_string(count) +
                   " face indices of the " + std::to_string(nindices - covered) + " left");
    }
    m.indices = static_cast<size_t>(count);
    covered += m.indices;
    std::copy(edge, edge + 4, m.edge);
    m.edge_size =
        (flags & 0x10) && std::isfinite(edge[4]) ? std::clamp(edge[4], 0.0f, 10.0f) : 0.0f;
  }
  return Status::Ok();
}

// An IK bone's target, loops, angle and links (with their limits).
bool ReadIk(Pmx& p, Bone& x) {
  Bytes& r = p.r;
  size_t links = 0;
  if (!r.Index(p.h.bone, false, x.ik_effector, "an IK target") ||
      !r.Get(x.ik_loops, "an IK bone") || !r.Floats(&x.ik_angle, 1, "an IK bone") ||
      !r.Count(static_cast<size_t>(p.h.bone) + 1, links, "the IK link count")) {
    return false;
  }
  x.ik_links.resize(links);
  for (IkLinkData& l : x.ik_links) {
    uint8_t limited;
    if (!r.Index(p.h.bone, false, l.bone, "an IK link") || !r.Get(limited, "an IK link"))
      return false;
    l.limited = limited;
    if (limited && (!r.Floats(l.lower, 3, "an IK link's limits") ||
                    !r.Floats(l.upper, 3, "an IK link's limits")))
      return false;
  }
  return true;
}

// One bone: names, position, parent, layer, flags, and what its flags say follows (tail, grant,
// fixed axis, local axes, external parent, IK).
bool ReadBone(Pmx& p, Bone& x) {
  Bytes& r = p.r;
  const Header& h = p.h;
  int32_t layer;
  uint16_t flags;
  if (!Text(r, h, x.name, "a bone") || !Text(r, h, x.english, "a bone") ||
      !r.Floats(x.pos, 3, "a bone") || !r.Index(h.bone, false, x.parent, "a bone's parent") ||
      !r.Get(layer, "a bone") || !r.Get(flags, "a bone")) {
    return false;
  }
  x.layer = layer;
  x.after_physics = flags & 0x1000;
  int64_t idx;
  float f[6];
  if ((flags & 0x0001) ? !r.Index(h.bone, false, idx, "a bone's tail")
                       : !r.Floats(f, 3, "a bone's tail"))
    return false;
  if (flags & 0x0300) {
    ++p.model.grants;
    if (!r.Index(h.bone, false, x.grant, "a bone's grant") ||
        !r.Floats(&x.grant_ratio, 1, "a bone's grant"))
      return false;
    x.grant_rotation = flags & 0x0100;
    x.grant_translation = flags & 0x0200;
    x.grant_local = flags & 0x0080;
  }
  if ((flags & 0x0400) && !r.Floats(f, 3, "a bone's fixed axis")) return false;
  if ((flags & 0x0800) && !r.Floats(f, 6, "a bone's local axes")) return false;
  if ((flags & 0x2000) && !r.Skip(4, "a bone's external parent")) return false;
  if (flags & 0x0020) {
    ++p.model.ik;
    x.ik = true;
    return ReadIk(p, x);
  }
  return true;
}

Status ReadBones(Pmx& p) {
  size_t nbones = 0;
  if (!p.r.Count(8 + 12 + p.h.bone + 4 + 2, nbones, "the bone count")) return p.Broken();
  if (nbones > 65534) return p.Bad("more than 65534 bones");
  p.model.bones.resize(nbones);
  for (Bone& x : p.model.bones) {
    if (!ReadBone(p, x)) return p.Broken();
  }
  return Status::Ok();
}

// A material morph's entry: index, operation (0 multiply, 1 add), diffuse RGBA, specular RGB,
// specular power, ambient RGB, edge RGBA, edge size, texture, sphere and toon tints RGBA.
Status ReadMaterialMorph(Pmx& p, Morph& m) {
  MaterialMorph mm;
  int64_t idx = 0;
  uint8_t op;
  float v[28];
  if (!p.r.Index(p.h.material, false, idx, "a material morph") ||
      !p.r.Get(op, "a material morph") || !p.r.Floats(v, 28, "a material morph"))
    return p.Broken();
  if (idx < -1 || idx >= static_cast<int64_t>(p.model.mats.size())) {
    return p.Bad("material morph '" + m.name + "' names material " + std::to_string(idx) + " of " +
                 std::to_string(p.model.mats.size()));
  }
  if (op > 1)
    return p.Bad("material morph '" + m.name + "' has operation " + std::to_string(op) +
                 " (0 multiply, 1 add)");
  mm.material = static_cast<int>(idx);
  mm.add = op == 1;
  std::copy(v, v + 4, mm.diffuse.begin());
  std::copy(v + 4, v + 7, mm.specular.begin());
  mm.specular_power = v[7];
  std::copy(v + 8, v + 11, mm.ambient.begin());
  std::copy(v + 11, v + 15, mm.edge.begin());
  mm.edge_size = v[15];
  std::copy(v + 16, v + 20, mm.texture_tint.begin());
  std::copy(v + 20, v + 24, mm.sphere_tint.begin());
  std::copy(v + 24, v + 28, mm.toon_tint.begin());
  m.material.push_back(mm);
  return Status::Ok();
}

// One offset of morph m (of `type`): a vertex's, a group's or flip's entry, a UV's (the first UV
// set's x and y of its 4 floats), a bone's, a material's; the rest (additional UVs, impulses)
// skipped.
Status ReadMorphOffset(Pmx& p, Morph& m, int type, size_t item) {
  Bytes& r = p.r;
  const Header& h = p.h;
  const size_t nverts = p.model.verts.size(), nbones = p.model.bones.size(),
               nmorphs = p.model.morphs.size();
  int64_t idx = 0;
  if (type == 1 || type == 3) {
    const char* what = type == 1 ? "a vertex morph" : "a UV morph";
    float d[4];
    if (!r.Index(h.vertex, true, idx, what) || !r.Floats(d, type == 1 ? 3 : 4, what))
      return p.Broken();
    if (idx < 0 || static_cast<size_t>(idx) >= nverts) {
      return p.Bad(std::string(type == 1 ? "" : "UV ") + "morph '" + m.name + "' moves vertex " +
                   std::to_string(idx) + " of " + std::to_string(nverts));
    }
    if (type == 1)
      m.vertex.emplace_back(idx, std::array<float, 3>{d[0], d[1], d[2]});
    else
      m.uv.push_back({idx, {d[0], d[1]}});
  } else if (type == 0 || type == 9) {
    float f;
    const char* what = type == 0 ? "a group morph" : "a flip morph";
    if (!r.Index(h.morph, false, idx, what) || !r.Floats(&f, 1, what)) return p.Broken();
    if (idx < 0 || static_cast<size_t>(idx) >= nmorphs)
      return p.Bad(std::string(type == 0 ? "group" : "flip") + " morph '" + m.name +
                   "' names morph " + std::to_string(idx) + " of " + std::to_string(nmorphs));
    m.group.emplace_back(idx, f);
  } else if (type == 2) {
    BoneMorph b;
    if (!r.Index(h.bone, false, idx, "a bone morph") ||
        !r.Floats(b.translation.data(), 3, "a bone morph") ||
        !r.Floats(b.rotation.data(), 4, "a bone morph"))
      return p.Broken();
    if (idx < 0 || static_cast<size_t>(idx) >= nbones)
      return p.Bad("bone morph '" + m.name + "' names bone " + std::to_string(idx) + " of " +
                   std::to_string(nbones));
    b.node = static_cast<int>(idx);
    m.bone.push_back(b);
  } else if (type == 8) {
    return ReadMaterialMorph(p, m);
  } else if (!r.Skip(item, "a morph")) {
    return p.Broken();
  }
  return Status::Ok();
}

Status ReadMorphs(Pmx& p) {
  Bytes& r = p.r;
  const Header& h = p.h;
  size_t nmorphs = 0;
  if (!r.Count(8 + 2 + 4, nmorphs, "the morph count")) return p.Broken();
  p.model.morphs.resize(nmorphs);
  for (Morph& m : p.model.morphs) {
    uint8_t panel, type;
    size_t n = 0;
    if (!Text(r, h, m.name, "a morph") || !Text(r, h, m.english, "a morph") ||
        !r.Get(panel, "a morph") || !r.Get(type, "a morph"))
      return p.Broken();
    m.panel = panel;
    m.type = type;
    const size_t item = type == 0 || type == 9     ? h.morph + 4
                        : type == 1                ? h.vertex + 12
                        : type == 2                ? h.bone + 28
                        : (type >= 3 && type <= 7) ? h.vertex + 16
                        : type == 8                ? h.material + 113
                        : type == 10               ? h.rigid + 25
                                                   : 0;
    if (!item) {
      r.Fail("morph '" + m.name + "' has type " + std::to_string(type));
      return p.Broken();
    }
    if (!r.Count(item, n, "a morph's offset count")) return p.Broken();
    for (size_t k = 0; k < n; ++k) {
      if (Status s = ReadMorphOffset(p, m, type, item); !s.ok()) return s;
    }
    if (!MorphIsShape(type)) ++p.model.unapplied[type];
  }
  return Status::Ok();
}

// Display frames (skipped).
Status SkipDisplayFrames(Pmx& p) {
  Bytes& r = p.r;
  const Header& h = p.h;
  size_t nframes = 0;
  if (!r.Count(8 + 1 + 4, nframes, "the display frame count")) return p.Broken();
  for (size_t f = 0; f < nframes; ++f) {
    std::string frame, frame_en;
    uint8_t special;
    size_t n = 0;
    if (!Text(r, h, frame, "a display frame") || !Text(r, h, frame_en, "a display frame") ||
        !r.Get(special, "a display frame") ||
        !r.Count(1 + static_cast<size_t>(std::min(h.bone, h.morph)), n,
                 "a display frame's entry count")) {
      return p.Broken();
    }
    for (size_t e = 0; e < n; ++e) {
      uint8_t kind = 0;
      if (!r.Get(kind, "a display frame entry") ||
          !r.Skip(static_cast<size_t>(kind == 0 ? h.bone : h.morph), "a display frame entry"))
        return p.Broken();
    }
  }
  return Status::Ok();
}

// The rigid bodies and the joints between them.
Status ReadPhysics(Pmx& p) {
  Bytes& r = p.r;
  const Header& h = p.h;
  size_t nbodies = 0;
  if (!r.Count(8 + static_cast<size_t>(h.bone) + 4 + 9 * 4 + 5 * 4 + 1, nbodies,
               "the rigid body count"))
    return p.Broken();
  p.model.bodies.resize(nbodies);
  for (RigidBodyData& b : p.model.bodies) {
    std::string english;
    if (!Text(r, h, b.name, "a rigid body") || !Text(r, h, english, "a rigid body") ||
        !r.Index(h.bone, false, b.bone, "a rigid body's bone") || !r.Get(b.group, "a rigid body") ||
        !r.Get(b.mask, "a rigid body") || !r.Get(b.shape, "a rigid body") ||
        !r.Floats(b.size, 3, "a rigid body") || !r.Floats(b.pos, 3, "a rigid body") ||
        !r.Floats(b.rot, 3, "a rigid body") || !r.Floats(&b.mass, 1, "a rigid body") ||
        !r.Floats(&b.linear_damping, 1, "a rigid body") ||
        !r.Floats(&b.angular_damping, 1, "a rigid body") ||
        !r.Floats(&b.restitution, 1, "a rigid body") || !r.Floats(&b.friction, 1, "a rigid body") ||
        !r.Get(b.mode, "a rigid body")) {
      return p.Broken();
    }
  }
  size_t njoints = 0;
  if (!r.Count(8 + 1 + 2 * static_cast<size_t>(h.rigid) + 24 * 4, njoints, "the joint count"))
    return p.Broken();
  p.model.joints.resize(njoints);
  for (JointData& j : p.model.joints) {
    std::string english;
    uint8_t type;
    if (!Text(r, h, j.name, "a joint") || !Text(r, h, english, "a joint") ||
        !r.Get(type, "a joint") || !r.Index(h.rigid, false, j.a, "a joint's body") ||
        !r.Index(h.rigid, false, j.b, "a joint's body") || !r.Floats(j.pos, 3, "a joint") ||
        !r.Floats(j.rot, 3, "a joint") || !r.Floats(j.linear_lower, 3, "a joint") ||
        !r.Floats(j.linear_upper, 3, "a joint") || !r.Floats(j.angular_lower, 3, "a joint") ||
        !r.Floats(j.angular_upper, 3, "a joint") || !r.Floats(j.linear_spring, 3, "a joint") ||
        !r.Floats(j.angular_spring, 3, "a joint")) {
      return p.Broken();
    }
    j.type = type;
  }
  return Status::Ok();
}

}  // namespace

Result<Rig> LoadPmxMemory(std::span<const unsigned char> bytes, const std::string& name) {
  Pmx p{Bytes(bytes), {}, name, {}};
  for (Status (*section)(Pmx&) :
       {ReadHeader, ReadVertices, ReadFacesAndTextures, ReadMaterials, ReadBones, ReadMorphs}) {
    if (Status s = section(p); !s.ok()) return s;
  }
  // Display frames, then the rigid bodies and joints. A file that ends before them (some tools stop
  // after the morphs) has no physics.
  if (p.r.left() > 0) {
    if (Status s = SkipDisplayFrames(p); !s.ok()) return s;
    if (Status s = ReadPhysics(p); !s.ok()) return s;
  }
  return BuildRig(p.model, name);
}

}  // namespace facespace::formats
