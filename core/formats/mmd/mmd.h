// MikuMikuDance internals shared by the PMX, PMD and VMD readers: a bounds-checked byte reader,
// Shift-JIS text, and the model as read from a PMX or PMD file, which becomes a Rig one way.
//
// Coordinates: MMD is left-handed, Y up, about 8 cm a unit. Every position and offset becomes
// (x, y, -z) x 0.08 (right-handed metres, glTF's); rotations (x, y, z, w) become (-x, -y, z, w).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace::formats::mmd {

constexpr float kMetresPerUnit = 0.08f;
constexpr float kFramesPerSecond = 30.0f;

inline std::array<float, 3> ToGltf(const float* p) {
  return {p[0] * kMetresPerUnit, p[1] * kMetresPerUnit, -p[2] * kMetresPerUnit};
}

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
  bool Get(T& out, const char* what) {
    return Raw(&out, sizeof(T), what);
  }
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
      return Fail(std::string(what) + ": count " + std::to_string(n) +
                  " is more than the file holds");
    }
    out = static_cast<size_t>(n);
    return true;
  }
  // A count stored as T (PMD: uint8, uint16 or uint32), capped like Count.
  template <typename T>
  bool CountOf(size_t item_bytes, size_t& out, const char* what) {
    T n = 0;
    if (!Get(n, what)) return false;
    if (static_cast<uint64_t>(n) > 0x7fffffffu ||
        (item_bytes && static_cast<size_t>(n) > left() / item_bytes)) {
      return Fail(std::string(what) + ": count " + std::to_string(static_cast<uint64_t>(n)) +
                  " is more than the file holds");
    }
    out = static_cast<size_t>(n);
    return true;
  }
  // An index of `size` bytes (1, 2 or 4); vertex indices of 1 and 2 bytes are unsigned, the others
  // signed.
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

// Shift-JIS (Windows code page 932, as MMD writes it) up to the first NUL, as UTF-8; a byte that
// does not decode (a character cut by a fixed-size field) is dropped.
std::string SjisToUtf8(const unsigned char* p, size_t n);
// UTF-8 as Shift-JIS bytes; empty when a character has no Shift-JIS form.
std::string Utf8ToSjis(const std::string& s);
// UTF-16LE to UTF-8 (surrogate pairs joined; a lone surrogate becomes U+FFFD).
std::string Utf16ToUtf8(const unsigned char* p, size_t n);

struct Vertex {
  float pos[3], normal[3], uv[2];
  int64_t bones[4] = {-1, -1, -1, -1};
  float weights[4] = {0, 0, 0, 0};
  int count = 1;
};

struct ModelMaterial {
  std::string name, english;
  float diffuse[4];
  float edge[4] = {0, 0, 0, 1};  // RGBA.
  float edge_size = 0.0f;        // 0: no edge drawn.
  int64_t texture = -1;
  size_t indices = 0;
};

struct IkLinkData {
  int64_t bone = -1;
  bool limited = false;
  float lower[3] = {0, 0, 0}, upper[3] = {0, 0, 0};  // Euler radians, MMD's axes.
};

struct Bone {
  std::string name, english;
  float pos[3];
  int64_t parent = -1;
  int32_t layer = 0;  // Deform layer: lower deforms first.
  bool after_physics = false;
  // Grant (PMX flags 0x100 rotation, 0x200 translation, 0x80 local); PMD's rotation-following
  // bones.
  int64_t grant = -1;
  float grant_ratio = 0;
  bool grant_rotation = false, grant_translation = false, grant_local = false;
  // IK (PMX flag 0x20; PMD's IK list): the effector ("target"), loops, angle per step, links.
  bool ik = false;
  int64_t ik_effector = -1;
  int32_t ik_loops = 0;
  float ik_angle = 0;
  std::vector<IkLinkData> ik_links;
};

// PMX morph types: 0 group, 1 vertex, 2 bone, 3 UV, 4-7 additional UV 1-4, 8 material, 9 flip,
// 10 impulse. Which become shapes: all but the additional UVs (sets only MMD's effect shaders read,
// which the rig does not carry) and impulses (a push on a rigid body, PMX 2.1; not simulated).
inline bool MorphIsShape(int type) { return type <= 3 || type == 8 || type == 9; }

struct Morph {
  std::string name, english;
  int panel = 0, type = 0;
  std::vector<std::pair<int64_t, std::array<float, 3>>> vertex;  // (vertex, offset)
  std::vector<std::pair<int64_t, float>> group;  // (morph, factor); type 9 (flip): (morph, weight).
  std::vector<std::pair<int64_t, std::array<float, 2>>> uv;  // Type 3: (vertex, UV offset).
  std::vector<MaterialMorph>
      material;  // Type 8; `material` is the PMX material index (-1: all) until BuildRig.
  std::vector<BoneMorph>
      bone;  // Type 2, in MMD's units and axes; `node` is the PMX bone index until BuildRig.
};

// A rigid body and a joint as the file says them (PMD: the body's position is from its bone).
struct RigidBodyData {
  std::string name;
  int64_t bone = -1;
  uint8_t group = 0, shape = 0, mode = 0;
  uint16_t mask = 0xffff;
  float size[3], pos[3], rot[3];  // rot: Euler radians, applied y, x, z.
  float mass, linear_damping, angular_damping, restitution, friction;
};

struct JointData {
  std::string name;
  int64_t a = -1, b = -1;
  uint8_t type = 0;      // 0: a spring joint (PMX 2.1 adds others).
  float pos[3], rot[3];  // rot: Euler radians, applied z, y, x.
  float linear_lower[3], linear_upper[3], angular_lower[3], angular_upper[3];
  float linear_spring[3], angular_spring[3];
};

// What a PMX or PMD file holds, in MMD's units and handedness.
struct Model {
  const char* format = "PMX";
  std::string name;
  std::vector<Vertex> verts;
  std::vector<uint32_t> indices;  // Checked against verts.
  std::vector<std::string> textures;
  std::vector<ModelMaterial> mats;  // Their face index counts add up to indices.size().
  std::vector<Bone> bones;
  std::vector<Morph> morphs;  // Vertex and group entries checked against verts and morphs.
  std::vector<RigidBodyData> bodies;
  std::vector<JointData> joints;
  bool body_positions_from_bone = false;  // PMD.
  size_t sdef = 0, qdef = 0, ik = 0, grants = 0;
  std::map<int, size_t> unapplied;  // PMX morph type -> count, for morphs not made shapes.
};

// The rig: a root node, the bones as nodes under it, one skin, one mesh with a primitive per
// material, the vertex and group morphs as sparse shapes. Checks bones and vertex weights; reports
// what it skips.
Result<Rig> BuildRig(const Model& m, const std::string& name);

// BuildRig's parts in mmd_rigging.cpp: the bones' grants and IK chains as the rig's constraints,
// and the rigid bodies and joints as its physics. What names no bone is dropped and counted in
// `dropped`.
void ReadConstraints(const std::vector<Bone>& bones, const std::vector<int>& node_of, Rig& rig,
                     size_t& dropped);
void ReadPhysics(const Model& in, const std::vector<int>& node_of, Rig& rig, size_t& dropped);

}  // namespace facespace::formats::mmd
