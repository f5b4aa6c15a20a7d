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

namespace facespace {

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
  Model model;
  std::string model_en, comment, comment_en;
  if (!Text(r, h, model.name, "the model name") || !Text(r, h, model_en, "the model name") || !Text(r, h, comment, "the comment") ||
      !Text(r, h, comment_en, "the comment")) {
    return fail(r);
  }

  // Vertices.
  size_t nverts = 0;
  if (!r.Count(8 * 4 + 1 + h.bone + 4, nverts, "the vertex count")) return fail(r);
  std::vector<Vertex>& verts = model.verts;
  verts.resize(nverts);
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
        ++model.sdef;
      }
    } else if (kind == 2 || kind == 4) {
      for (int k = 0; k < 4; ++k) {
        if (!r.Index(h.bone, false, x.bones[k], "a vertex's bone")) return fail(r);
      }
      if (!r.Floats(x.weights, 4, "vertex weights")) return fail(r);
      x.count = 4;
      model.qdef += kind == 4;
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
  model.indices.resize(nindices);
  for (size_t i = 0; i < nindices; ++i) {
    int64_t v = 0;
    if (!r.Index(h.vertex, true, v, "a face")) return fail(r);
    if (v < 0 || static_cast<size_t>(v) >= nverts) return InvalidArgument(name + ": PMX: face index " + std::to_string(i) + " is vertex " + std::to_string(v) + " of " + std::to_string(nverts));
    model.indices[i] = static_cast<uint32_t>(v);
  }
  // Textures (paths, kept for the report).
  size_t ntex = 0;
  if (!r.Count(4, ntex, "the texture count")) return fail(r);
  model.textures.resize(ntex);
  for (std::string& t : model.textures) {
    if (!Text(r, h, t, "a texture path")) return fail(r);
  }
  // Materials: each covers the next `indices` face indices.
  size_t nmats = 0;
  if (!r.Count(8, nmats, "the material count")) return fail(r);
  model.mats.resize(nmats);
  size_t covered = 0;
  for (ModelMaterial& m : model.mats) {
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
  std::vector<Bone>& bones = model.bones;
  bones.resize(nbones);
  for (size_t b = 0; b < nbones; ++b) {
    Bone& x = bones[b];
    int32_t layer;
    uint16_t flags;
    if (!Text(r, h, x.name, "a bone") || !Text(r, h, x.english, "a bone") || !r.Floats(x.pos, 3, "a bone") ||
        !r.Index(h.bone, false, x.parent, "a bone's parent") || !r.Get(layer, "a bone") || !r.Get(flags, "a bone")) {
      return fail(r);
    }
    x.layer = layer;
    x.after_physics = flags & 0x1000;
    int64_t idx;
    float f[6];
    if ((flags & 0x0001) ? !r.Index(h.bone, false, idx, "a bone's tail") : !r.Floats(f, 3, "a bone's tail")) return fail(r);
    if (flags & 0x0300) {
      ++model.grants;
      if (!r.Index(h.bone, false, x.grant, "a bone's grant") || !r.Floats(&x.grant_ratio, 1, "a bone's grant")) return fail(r);
      x.grant_rotation = flags & 0x0100;
      x.grant_translation = flags & 0x0200;
      x.grant_local = flags & 0x0080;
    }
    if ((flags & 0x0400) && !r.Floats(f, 3, "a bone's fixed axis")) return fail(r);
    if ((flags & 0x0800) && !r.Floats(f, 6, "a bone's local axes")) return fail(r);
    if ((flags & 0x2000) && !r.Skip(4, "a bone's external parent")) return fail(r);
    if (flags & 0x0020) {
      ++model.ik;
      x.ik = true;
      size_t links = 0;
      if (!r.Index(h.bone, false, x.ik_effector, "an IK target") || !r.Get(x.ik_loops, "an IK bone") || !r.Floats(&x.ik_angle, 1, "an IK bone") ||
          !r.Count(static_cast<size_t>(h.bone) + 1, links, "the IK link count")) {
        return fail(r);
      }
      x.ik_links.resize(links);
      for (IkLinkData& l : x.ik_links) {
        uint8_t limited;
        if (!r.Index(h.bone, false, l.bone, "an IK link") || !r.Get(limited, "an IK link")) return fail(r);
        l.limited = limited;
        if (limited && (!r.Floats(l.lower, 3, "an IK link's limits") || !r.Floats(l.upper, 3, "an IK link's limits"))) return fail(r);
      }
    }
  }
  // Morphs.
  size_t nmorphs = 0;
  if (!r.Count(8 + 2 + 4, nmorphs, "the morph count")) return fail(r);
  std::vector<Morph>& morphs = model.morphs;
  morphs.resize(nmorphs);
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
      } else if (type == 0 || type == 9) {
        float f;
        const char* what = type == 0 ? "a group morph" : "a flip morph";
        if (!r.Index(h.morph, false, idx, what) || !r.Floats(&f, 1, what)) return fail(r);
        if (idx < 0 || static_cast<size_t>(idx) >= nmorphs) return InvalidArgument(name + ": PMX: " + (type == 0 ? "group" : "flip") + " morph '" + m.name + "' names morph " + std::to_string(idx) + " of " + std::to_string(nmorphs));
        m.group.emplace_back(idx, f);
      } else if (type == 3) {
        // UV: the offset is 4 floats, of which the first UV set uses x and y.
        float d[4];
        if (!r.Index(h.vertex, true, idx, "a UV morph") || !r.Floats(d, 4, "a UV morph")) return fail(r);
        if (idx < 0 || static_cast<size_t>(idx) >= nverts) return InvalidArgument(name + ": PMX: UV morph '" + m.name + "' moves vertex " + std::to_string(idx) + " of " + std::to_string(nverts));
        m.uv.push_back({idx, {d[0], d[1]}});
      } else if (type == 2) {
        BoneMorph b;
        if (!r.Index(h.bone, false, idx, "a bone morph") || !r.Floats(b.translation.data(), 3, "a bone morph") || !r.Floats(b.rotation.data(), 4, "a bone morph")) return fail(r);
        if (idx < 0 || static_cast<size_t>(idx) >= nbones) return InvalidArgument(name + ": PMX: bone morph '" + m.name + "' names bone " + std::to_string(idx) + " of " + std::to_string(nbones));
        b.node = static_cast<int>(idx);
        m.bone.push_back(b);
      } else if (type == 8) {
        // Material: index, operation (0 multiply, 1 add), diffuse RGBA, specular RGB, specular power,
        // ambient RGB, edge RGBA, edge size, texture, sphere and toon tints RGBA.
        MaterialMorph mm;
        uint8_t op;
        float v[28];
        if (!r.Index(h.material, false, idx, "a material morph") || !r.Get(op, "a material morph") || !r.Floats(v, 28, "a material morph")) return fail(r);
        if (idx < -1 || idx >= static_cast<int64_t>(nmats)) return InvalidArgument(name + ": PMX: material morph '" + m.name + "' names material " + std::to_string(idx) + " of " + std::to_string(nmats));
        if (op > 1) return InvalidArgument(name + ": PMX: material morph '" + m.name + "' has operation " + std::to_string(op) + " (0 multiply, 1 add)");
        for (float x : v) {
          if (!std::isfinite(x)) return InvalidArgument(name + ": PMX: material morph '" + m.name + "' holds a value that is not finite");
        }
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
      } else if (!r.Skip(item, "a morph")) {
        return fail(r);
      }
    }
    if (!MorphIsShape(type)) ++model.unapplied[type];
  }
  // Display frames (skipped), then the rigid bodies and joints. A file that ends before them
  // (some tools stop after the morphs) has no physics.
  if (r.left() == 0) return BuildRig(model, name);
  size_t nframes = 0;
  if (!r.Count(8 + 1 + 4, nframes, "the display frame count")) return fail(r);
  for (size_t f = 0; f < nframes; ++f) {
    std::string frame, frame_en;
    uint8_t special;
    size_t n = 0;
    if (!Text(r, h, frame, "a display frame") || !Text(r, h, frame_en, "a display frame") || !r.Get(special, "a display frame") ||
        !r.Count(1 + static_cast<size_t>(std::min(h.bone, h.morph)), n, "a display frame's entry count")) {
      return fail(r);
    }
    for (size_t e = 0; e < n; ++e) {
      uint8_t kind;
      if (!r.Get(kind, "a display frame entry") || !r.Skip(static_cast<size_t>(kind == 0 ? h.bone : h.morph), "a display frame entry")) return fail(r);
    }
  }
  size_t nbodies = 0;
  if (!r.Count(8 + static_cast<size_t>(h.bone) + 4 + 9 * 4 + 5 * 4 + 1, nbodies, "the rigid body count")) return fail(r);
  model.bodies.resize(nbodies);
  for (RigidBodyData& b : model.bodies) {
    std::string english;
    if (!Text(r, h, b.name, "a rigid body") || !Text(r, h, english, "a rigid body") || !r.Index(h.bone, false, b.bone, "a rigid body's bone") ||
        !r.Get(b.group, "a rigid body") || !r.Get(b.mask, "a rigid body") || !r.Get(b.shape, "a rigid body") ||
        !r.Floats(b.size, 3, "a rigid body") || !r.Floats(b.pos, 3, "a rigid body") || !r.Floats(b.rot, 3, "a rigid body") ||
        !r.Floats(&b.mass, 1, "a rigid body") || !r.Floats(&b.linear_damping, 1, "a rigid body") || !r.Floats(&b.angular_damping, 1, "a rigid body") ||
        !r.Floats(&b.restitution, 1, "a rigid body") || !r.Floats(&b.friction, 1, "a rigid body") || !r.Get(b.mode, "a rigid body")) {
      return fail(r);
    }
  }
  size_t njoints = 0;
  if (!r.Count(8 + 1 + 2 * static_cast<size_t>(h.rigid) + 24 * 4, njoints, "the joint count")) return fail(r);
  model.joints.resize(njoints);
  for (JointData& j : model.joints) {
    std::string english;
    uint8_t type;
    if (!Text(r, h, j.name, "a joint") || !Text(r, h, english, "a joint") || !r.Get(type, "a joint") ||
        !r.Index(h.rigid, false, j.a, "a joint's body") || !r.Index(h.rigid, false, j.b, "a joint's body") ||
        !r.Floats(j.pos, 3, "a joint") || !r.Floats(j.rot, 3, "a joint") || !r.Floats(j.linear_lower, 3, "a joint") ||
        !r.Floats(j.linear_upper, 3, "a joint") || !r.Floats(j.angular_lower, 3, "a joint") || !r.Floats(j.angular_upper, 3, "a joint") ||
        !r.Floats(j.linear_spring, 3, "a joint") || !r.Floats(j.angular_spring, 3, "a joint")) {
      return fail(r);
    }
    j.type = type;
  }
  return BuildRig(model, name);
}


}  // namespace facespace
