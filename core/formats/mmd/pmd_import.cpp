// MikuMikuDance PMD (the format before PMX) as a Rig, through the same Model as PMX (mmd.h):
// fixed-size Shift-JIS names (iconv), BDEF2 vertices (a bone pair and a 0..100 weight), faces,
// materials with their texture names, bones (IK chains and grants counted and reported), and the
// "skins": one base listing the model vertices the expressions move, then each expression's offsets
// by position in that list (the layout of the course assignment's PA2). The English names, when the
// file has them, become aliases.
//
// A parser of untrusted bytes: every read is bounds-checked, counts capped by the bytes left, every
// index checked; an error names the section and the item.
#include <string>
#include <vector>

#include "facespace/formats/io.h"
#include "mmd/mmd.h"

namespace facespace::formats {

namespace {

using namespace mmd;

bool Name(Bytes& r, size_t n, std::string& out, const char* what) {
  unsigned char raw[256];
  if (!r.Raw(raw, n, what)) return false;
  out = SjisToUtf8(raw, n);
  return true;
}

// The reader, the file and what was read, for every section below: a read that fails is Broken()
// (the reader's error, which names the section and item).
struct Pmd {
  Bytes r;
  const std::string& name;
  Model model;
  size_t bone_frames = 0;  // The bone display names' count: the English names repeat them.
  Status Broken() const { return InvalidArgument(name + ": PMD " + r.error()); }
  Status Bad(const std::string& what) const { return InvalidArgument(name + ": PMD: " + what); }
};

Status ReadHeader(Pmd& p) {
  char magic[3];
  float version = 0;
  if (!p.r.Raw(magic, 3, "the header") || std::memcmp(magic, "Pmd", 3) != 0)
    return InvalidArgument(p.name + ": not a PMD file (no 'Pmd' magic)");
  if (!p.r.Get(version, "the header")) return p.Broken();
  if (version != 1.0f)
    return InvalidArgument(p.name + ": PMD version " + std::to_string(version) + " is not 1.0");
  p.model.format = "PMD";
  std::string comment;
  if (!Name(p.r, 20, p.model.name, "the model name") || !Name(p.r, 256, comment, "the comment"))
    return p.Broken();
  return Status::Ok();
}

// Vertices (two bones each, the first's weight in percent), then the faces.
Status ReadVerticesAndFaces(Pmd& p) {
  Bytes& r = p.r;
  size_t nverts = 0;
  if (!r.CountOf<uint32_t>(38, nverts, "the vertex count")) return p.Broken();
  p.model.verts.resize(nverts);
  for (Vertex& x : p.model.verts) {
    uint16_t bone[2];
    uint8_t weight, edge;
    if (!r.Floats(x.pos, 3, "a vertex") || !r.Floats(x.normal, 3, "a vertex") ||
        !r.Floats(x.uv, 2, "a vertex") || !r.Raw(bone, 4, "a vertex") ||
        !r.Get(weight, "a vertex") || !r.Get(edge, "a vertex") ||
        (weight > 100 && !r.Fail("a vertex weight of " + std::to_string(weight) + " (0..100)"))) {
      return p.Broken();
    }
    x.bones[0] = bone[0], x.bones[1] = bone[1];
    x.weights[0] = weight / 100.0f, x.weights[1] = 1.0f - weight / 100.0f;
    x.count = 2;
  }
  size_t nindices = 0;
  if (!r.CountOf<uint32_t>(2, nindices, "the face index count")) return p.Broken();
  if (nindices % 3) return p.Bad(std::to_string(nindices) + " face indices is not whole triangles");
  p.model.indices.resize(nindices);
  for (size_t i = 0; i < nindices; ++i) {
    uint16_t v;
    if (!r.Get(v, "a face")) return p.Broken();
    if (v >= nverts)
      return p.Bad("face index " + std::to_string(i) + " is vertex " + std::to_string(v) + " of " +
                   std::to_string(nverts));
    p.model.indices[i] = v;
  }
  return Status::Ok();
}

// Materials: no names; the texture field may be "colour.png*sphere.sph" (a sphere map after '*').
Status ReadMaterials(Pmd& p) {
  Bytes& r = p.r;
  const size_t nindices = p.model.indices.size();
  size_t nmats = 0, covered = 0;
  if (!r.CountOf<uint32_t>(70, nmats, "the material count")) return p.Broken();
  p.model.mats.resize(nmats);
  for (size_t mi = 0; mi < nmats; ++mi) {
    ModelMaterial& m = p.model.mats[mi];
    float rest[7];
    uint8_t toon, edge;
    uint32_t count;
    std::string texture;
    if (!r.Floats(m.diffuse, 4, "a material") || !r.Floats(rest, 7, "a material") ||
        !r.Get(toon, "a material") || !r.Get(edge, "a material") || !r.Get(count, "a material") ||
        !Name(r, 20, texture, "a material")) {
      return p.Broken();
    }
    m.name = "material" + std::to_string(mi);
    m.edge_size = edge ? 1.0f : 0.0f;  // PMD: a flag; black edges of size 1.
    if (count > nindices - covered || count % 3) {
      return p.Bad("material " + std::to_string(mi) + " covers " + std::to_string(count) +
                   " face indices of the " + std::to_string(nindices - covered) + " left");
    }
    m.indices = count;
    covered += count;
    texture = texture.substr(0, texture.find('*'));
    const bool sphere =
        texture.size() > 4 && (texture.ends_with(".sph") || texture.ends_with(".spa"));
    if (!texture.empty() && !sphere) {
      m.texture = static_cast<int64_t>(p.model.textures.size());
      p.model.textures.push_back(texture);
    }
  }
  return Status::Ok();
}

// Bones: types 5 and 9 follow another bone's rotation (grants), as PMX says them: type 9 (回転連動)
// turns with the bone its tail names, by its IK field / 100 (Uka's eyes: 両目 by 0.07, as her PMX);
// type 5 (回転影響下) with the bone its IK field names, whole.
Status ReadBones(Pmd& p) {
  size_t nbones = 0;
  if (!p.r.CountOf<uint16_t>(39, nbones, "the bone count")) return p.Broken();
  if (nbones > 65534) return p.Bad("more than 65534 bones");
  p.model.bones.resize(nbones);
  for (Bone& b : p.model.bones) {
    uint16_t parent = 0, tail = 0, ik_parent = 0;
    uint8_t type = 0;
    if (!Name(p.r, 20, b.name, "a bone") || !p.r.Get(parent, "a bone") ||
        !p.r.Get(tail, "a bone") || !p.r.Get(type, "a bone") || !p.r.Get(ik_parent, "a bone") ||
        !p.r.Floats(b.pos, 3, "a bone")) {
      return p.Broken();
    }
    b.parent = parent == 0xFFFF ? -1 : parent;
    if (type == 9 || type == 5) {
      ++p.model.grants;
      b.grant = type == 9 ? tail : ik_parent;
      b.grant_ratio = type == 9 ? static_cast<float>(ik_parent) / 100.0f : 1.0f;
      b.grant_rotation = true;
    }
  }
  return Status::Ok();
}

// IK chains: the IK bone, its effector, links, loops and the angle per step in units of 4 radians
// (as MMD reads PMD); a knee (a link named ひざ) turns about x alone, between -180 and -0.5
// degrees.
Status ReadIkChains(Pmd& p) {
  Bytes& r = p.r;
  std::vector<Bone>& bones = p.model.bones;
  size_t nik = 0;
  if (!r.CountOf<uint16_t>(11, nik, "the IK count")) return p.Broken();
  for (size_t k = 0; k < nik; ++k) {
    uint16_t ik_bone = 0, effector = 0, loops = 0;
    uint8_t chain = 0;
    float angle = 0;
    if (!r.Get(ik_bone, "an IK chain") || !r.Get(effector, "an IK chain") ||
        !r.Get(chain, "an IK chain") || !r.Get(loops, "an IK chain") ||
        !r.Floats(&angle, 1, "an IK chain")) {
      return p.Broken();
    }
    std::vector<IkLinkData> links(chain);
    for (IkLinkData& l : links) {
      uint16_t b = 0;
      if (!r.Get(b, "an IK chain")) return p.Broken();
      l.bone = b;
      if (b < bones.size() && bones[b].name.find("ひざ") != std::string::npos) {
        l.limited = true;
        l.lower[0] = -3.14159265f;
        l.upper[0] = -0.5f * 3.14159265f / 180.0f;
      }
    }
    if (ik_bone >= bones.size()) continue;  // Counted, and reported as not applied.
    Bone& b = bones[ik_bone];
    b.ik = true;
    b.ik_effector = effector;
    b.ik_loops = loops;
    b.ik_angle = angle * 4.0f;
    b.ik_links = std::move(links);
  }
  p.model.ik = nik;
  return Status::Ok();
}

// Skins: the base (type 0) lists model vertices and their positions; each expression lists
// (position in the base list, offset).
Status ReadSkins(Pmd& p) {
  Bytes& r = p.r;
  const size_t nverts = p.model.verts.size();
  size_t nskins = 0;
  if (!r.CountOf<uint16_t>(25, nskins, "the skin (morph) count")) return p.Broken();
  std::vector<uint32_t> base;
  for (size_t s = 0; s < nskins; ++s) {
    Morph m;
    size_t n = 0;
    uint8_t type = 0;
    if (!Name(r, 20, m.name, "a skin") || !r.CountOf<uint32_t>(16, n, "a skin's vertex count") ||
        !r.Get(type, "a skin"))
      return p.Broken();
    if ((s == 0) != (type == 0))
      return p.Bad("skin '" + m.name + "' is type " + std::to_string(type) + " at " +
                   std::to_string(s) + " (the base, type 0, comes first and only there)");
    if (type > 4) return p.Bad("skin '" + m.name + "' has type " + std::to_string(type));
    m.panel = type;
    m.type = 1;
    for (size_t k = 0; k < n; ++k) {
      uint32_t idx = 0;
      std::array<float, 3> d;
      if (!r.Get(idx, "a skin vertex") || !r.Floats(d.data(), 3, "a skin vertex"))
        return p.Broken();
      if (type == 0) {
        if (idx >= nverts)
          return p.Bad("the base skin names vertex " + std::to_string(idx) + " of " +
                       std::to_string(nverts));
        base.push_back(idx);
      } else if (idx >= base.size()) {
        return p.Bad("skin '" + m.name + "' names base entry " + std::to_string(idx) + " of " +
                     std::to_string(base.size()));
      } else {
        m.vertex.emplace_back(base[idx], d);
      }
    }
    if (type != 0) p.model.morphs.push_back(std::move(m));
  }
  return Status::Ok();
}

// Display lists (skipped), then the optional English names.
Status ReadDisplayAndEnglish(Pmd& p) {
  Bytes& r = p.r;
  size_t nlist = 0, ndisp = 0;
  if (!r.CountOf<uint8_t>(2, nlist, "the skin display list") ||
      !r.Skip(2 * nlist, "the skin display list") ||
      !r.CountOf<uint8_t>(50, p.bone_frames, "the bone display names") ||
      !r.Skip(50 * p.bone_frames, "the bone display names") ||
      !r.CountOf<uint32_t>(3, ndisp, "the bone display list") ||
      !r.Skip(3 * ndisp, "the bone display list")) {
    return p.Broken();
  }
  uint8_t english = 0;
  if (r.left() > 0 && !r.Get(english, "the English names")) return p.Broken();
  if (english != 1) return Status::Ok();
  std::string english_name, english_comment;
  if (!Name(r, 20, english_name, "the English names") ||
      !Name(r, 256, english_comment, "the English names"))
    return p.Broken();
  for (Bone& b : p.model.bones) {
    if (!Name(r, 20, b.english, "the English bone names")) return p.Broken();
  }
  for (Morph& m : p.model.morphs) {
    if (!Name(r, 20, m.english, "the English skin names")) return p.Broken();
  }
  if (!r.Skip(50 * p.bone_frames, "the English bone display names")) return p.Broken();
  return Status::Ok();
}

// Toon texture names (skipped), then the rigid bodies and joints, when the file has them.
Status ReadPhysics(Pmd& p) {
  Bytes& r = p.r;
  if (r.left() < 1000 + 4) return Status::Ok();
  size_t nbodies = 0, njoints = 0;
  if (!r.Skip(1000, "the toon textures") ||
      !r.CountOf<uint32_t>(83, nbodies, "the rigid body count"))
    return p.Broken();
  p.model.bodies.resize(nbodies);
  for (RigidBodyData& b : p.model.bodies) {
    uint16_t bone;
    if (!Name(r, 20, b.name, "a rigid body") || !r.Get(bone, "a rigid body") ||
        !r.Get(b.group, "a rigid body") || !r.Get(b.mask, "a rigid body") ||
        !r.Get(b.shape, "a rigid body") || !r.Floats(b.size, 3, "a rigid body") ||
        !r.Floats(b.pos, 3, "a rigid body") || !r.Floats(b.rot, 3, "a rigid body") ||
        !r.Floats(&b.mass, 1, "a rigid body") || !r.Floats(&b.linear_damping, 1, "a rigid body") ||
        !r.Floats(&b.angular_damping, 1, "a rigid body") ||
        !r.Floats(&b.restitution, 1, "a rigid body") || !r.Floats(&b.friction, 1, "a rigid body") ||
        !r.Get(b.mode, "a rigid body")) {
      return p.Broken();
    }
    b.bone = bone == 0xffff ? -1 : bone;
  }
  if (!r.CountOf<uint32_t>(124, njoints, "the joint count")) return p.Broken();
  p.model.joints.resize(njoints);
  for (JointData& j : p.model.joints) {
    uint32_t a, b;
    if (!Name(r, 20, j.name, "a joint") || !r.Get(a, "a joint") || !r.Get(b, "a joint") ||
        !r.Floats(j.pos, 3, "a joint") || !r.Floats(j.rot, 3, "a joint") ||
        !r.Floats(j.linear_lower, 3, "a joint") || !r.Floats(j.linear_upper, 3, "a joint") ||
        !r.Floats(j.angular_lower, 3, "a joint") || !r.Floats(j.angular_upper, 3, "a joint") ||
        !r.Floats(j.linear_spring, 3, "a joint") || !r.Floats(j.angular_spring, 3, "a joint")) {
      return p.Broken();
    }
    j.a = a, j.b = b;
  }
  return Status::Ok();
}

}  // namespace

Result<Rig> LoadPmdMemory(std::span<const unsigned char> bytes, const std::string& name) {
  Pmd p{Bytes(bytes), name, {}};
  for (Status (*section)(Pmd&) : {ReadHeader, ReadVerticesAndFaces, ReadMaterials, ReadBones,
                                  ReadIkChains, ReadSkins, ReadDisplayAndEnglish, ReadPhysics}) {
    if (Status s = section(p); !s.ok()) return s;
  }
  p.model.body_positions_from_bone = true;
  return BuildRig(p.model, name);
}

}  // namespace facespace::formats
