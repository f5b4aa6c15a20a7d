// What a VRM carries beyond the glb (vrm.cpp writes 1.0, vrm0.cpp 0.x), each part worked out once
// from the rig and written in either version's words: secondary motion from MMD's physics, node
// constraints from MMD's grants, MToon from toon materials, expressions' material colour binds from
// material morphs, and the custom expressions apps look for (ARKit's 52, the 15 OVR visemes).
// Private to formats.
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "facespace/engine/blend.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace::formats::writers {

using nlohmann::ordered_json;

// A float as the shortest decimal that reads back as it (0.4, not 0.4000000059604645).
double Num(float x);

// ---- secondary motion (vrm_secondary.cpp) ----

// A spring chain: its joints from the root down, the last one the tail (VRM swings each joint
// towards the next), and the PMX collision groups its bodies collide with (bit i: group i).
struct SpringJoint {
  int node = -1;
  float hit_radius = 0.0f, stiffness = 1.0f, drag = 0.4f, gravity = 0.0f;
};
struct Spring {
  std::string name;
  bool branch = false;  // Starts at a branch of another chain (0.x, which swings a root's whole
                        // tree, skips it).
  std::vector<SpringJoint> joints;
  uint16_t collides_with = 0;
};
// A collider on a bone, in the bone's space: a sphere (offset, radius) or a capsule (offset to
// tail).
struct Collider {
  int node = -1;
  bool capsule = false;
  std::array<float, 3> offset{0, 0, 0}, tail{0, 0, 0};
  float radius = 0.0f;
  uint8_t group = 0;  // PMX's collision group.
};
struct SpringSetup {
  std::vector<Spring> springs;
  std::vector<Collider> colliders;
  bool empty() const { return springs.empty(); }
};

// MMD's physics as VRM spring bones: every chain of bones moved by dynamic bodies a spring (a
// branch starts its own), its stiffness from its joints' angular limits and springs, its drag from
// the bodies' damping, its hit radius from their size; the bodies that follow bones (head, body,
// limbs) colliders.
SpringSetup SpringsOf(const Rig& rig);

// VRMC_springBone (1.0), with one collider group per PMX collision group.
ordered_json SpringBone1(const SpringSetup& s);
// 0.x's secondaryAnimation: boneGroups (a chain's root and its settings) and colliderGroups
// (spheres; a capsule as spheres along it).
ordered_json SecondaryAnimation0(const SpringSetup& s);

// ---- node constraints (vrm_secondary.cpp) ----

// MMD's rotation grants as VRMC_node_constraint rotation constraints, on a copy of the rig. A
// constraint sets its node's rotation, so on a humanoid bone (which apps pose, and look-at turns)
// it would undo them: there the grant goes on a node inserted under the bone (carrying its children
// and skin), and the bone's own turn and the grant's add up as in MMD. Grants VRM cannot say (of
// translation, a ratio outside [0, 1], onto a swinging bone) are counted in `dropped`.
struct Constrained {
  Rig rig;
  std::vector<std::pair<int, ordered_json>> constraints;  // (node, VRMC_node_constraint)
  size_t dropped = 0;
};
Constrained WithNodeConstraints(const Rig& rig, std::span<const int> humanoid,
                                const SpringSetup& springs);

// ---- looks and faces (vrm_looks.cpp) ----

// VRMC_materials_mtoon (1.0) for a toon material; null for the others.
ordered_json MToon1(const Material& m, const ordered_json& gltf_material);
// 0.x's materialProperties entry for `m`, written as `gltf_material`: VRM/MToon's floats, vectors
// and textures for a toon material, else VRM_USE_GLTFSHADER.
ordered_json MaterialProperties0(const Material& m, const ordered_json& gltf_material);

// An expression's material colour binds: each material whose colour its shapes' material morphs
// change, with the colour at value 1 ({material, type: "color", targetValue}).
ordered_json MaterialColorBinds(const Rig& rig, const Expression& e);

// The custom expressions apps drive: ARKit's 52 blend shapes under their own names (the shapes the
// rig has by those names or aliases), and the rig's visemes as viseme_sil ... viseme_U (OVR's
// names).
std::vector<Expression> AppExpressions(const Rig& rig);

// ---- the glb both versions start from (vrm.cpp) ----

// The rig at rest as ExportGlb's keep_targets glb (its weights the meshes' defaults, no clips),
// split into its JSON and its binary chunk, to which the VRM's members are added.
struct GlbParts {
  ordered_json json;
  std::vector<unsigned char> bin;
};
Result<GlbParts> RestGlbParts(const Rig& rig, const BlendedRig& blended,
                              std::span<const float> weights, std::span<const Warning> warnings);
std::string PackGlb(const GlbParts& g);
// An image appended to the binary chunk with its view, image and texture: the image's index and the
// texture's.
std::pair<int, int> AddImage(GlbParts& g, std::span<const unsigned char> bytes,
                             const std::string& mime_type, const std::string& name);
void UseExtension(GlbParts& g, const std::string& name);

// What makes the rig an avatar: its humanoid's bones as (VRM bone name, node); or InvalidArgument
// naming
// "/format" when it lacks a required bone (each named) or, a humanoid, has no licence URL (a VRM's
// meta needs one).
Result<std::vector<std::pair<std::string, int>>> AvatarBones(const Rig& rig);
// The rig's expressions, then the app expressions (AppExpressions) whose names it does not use.
std::vector<Expression> VrmExpressions(const Rig& rig);
// The shape's morph targets: (mesh, target) for each mesh that carries it.
std::vector<std::pair<size_t, size_t>> TargetsOf(const Rig& rig, uint32_t shape);
// The look-at as both versions say it: from the head bone to between the eyes at rest, and a range
// map's input as the whole angle (VRM turns only the eyes: our head's and neck's shares fold into
// it).
std::array<float, 3> EyesFromHead(const Rig& rig, int head);
float WholeAngle(const GazeSetup& gaze, const RangeMap& m);
// The first node showing each mesh (-1: none), where VRM's binds point.
std::vector<int> MeshNodes(const Rig& rig);

// The rig turned half round about y (x and z negated: positions, normals, tangents, targets, nodes,
// skins, bodies, gaze): VRM 0.x's avatars face -z where glTF's and 1.0's face +z.
Rig TurnedHalfRound(const Rig& rig);

}  // namespace facespace::formats::writers
