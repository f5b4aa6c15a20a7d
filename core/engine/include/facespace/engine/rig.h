// The rig: a base mesh (one or more primitives) and N named shapes stored as sparse
// per-vertex displacements, plus what renders and exports need (nodes, materials, images).
//
// Layout (chosen with tests/bench/blend_bench.cpp, see README "Blend layout"): by shape.
// Each shape keeps, per primitive it moves, the sorted indices of the vertices it moves and
// their xyz deltas, plus the same indices grouped in runs of consecutive vertices, so the
// blend kernel does one multiply-add stream per run (real face shapes move contiguous
// regions: FaceCap's average run is 11 vertices). Exact zero deltas are elided.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "facespace/engine/status.h"

namespace facespace {
inline namespace engine {

// One shape's displacement of one primitive. Indices ascending and unique.
struct SparseTarget {
  std::vector<uint32_t> indices;       // Vertices moved, ascending.
  std::vector<float> position_deltas;  // 3 per index: dx, dy, dz (mesh units).
  std::vector<float> normal_deltas;    // 3 per index, or empty when the source has none.
  std::vector<float> tangent_deltas;   // 3 per index, or empty when the source has none.
  // Runs of consecutive indices: run r covers vertices [runs[2r], runs[2r] + runs[2r+1]),
  // whose deltas follow each other in the arrays above. Built by FinalizeTarget(); empty
  // when the target is scattered (average run shorter than 4), which blends by index.
  std::vector<uint32_t> runs;
  // The length of each index's position delta, built by FinalizeTarget() (empty before): what the
  // extrapolation check (core/weights.h) weighs per vertex, measured once per rig rather than per
  // point.
  std::vector<float> move_lengths;
  // What the shape does to the first UV set (MMD's UV morphs, glTF's TEXCOORD_0 targets): the
  // vertices whose UV moves, ascending, apart from the position indices (most shapes move no UV,
  // a UV morph moves no position), and 2 floats (du, dv) per index.
  std::vector<uint32_t> texcoord_indices;
  std::vector<float> texcoord_deltas;
};

// Builds `runs` from `indices` and `move_lengths` from `position_deltas`. Call after filling a
// target.
void FinalizeTarget(SparseTarget& target);

// Order-preserving vertex compaction (LOD, keeping some groups of an OBJ). `remap` holds per
// vertex -1 (dropped) or 0 (kept); RankKeptVertices turns each kept entry into the vertex's new
// index, its rank among the kept ones, so kept vertices keep their order. Returns how many.
size_t RankKeptVertices(std::span<int32_t> remap);

// `target` over the kept vertices of a ranked `remap`: dropped vertices' deltas go, indices
// stay ascending, runs rebuilt.
SparseTarget RemapTarget(const SparseTarget& target, std::span<const int32_t> remap);

enum class PrimitiveMode : int { kPoints = 0, kLines = 1, kTriangles = 4 };

struct Primitive {
  int mesh = 0;           // Index of the glTF mesh this primitive belongs to.
  int index_in_mesh = 0;  // Its index among that mesh's primitives.
  PrimitiveMode mode = PrimitiveMode::kTriangles;
  std::vector<float> positions;  // xyz per vertex, mesh space.
  std::vector<float> normals;    // xyz per vertex (computed on load when the source has none).
  bool source_has_normals = false;
  std::vector<float> tangents;        // xyzw per vertex, or empty.
  std::vector<float> texcoords;       // uv per vertex, or empty.
  std::vector<float> colors;          // rgba per vertex, or empty.
  std::vector<uint32_t> indices;      // Triangle list (3 per face) for kTriangles; else as mode.
  int material = -1;                  // Index into Rig::materials, or -1.
  std::vector<SparseTarget> targets;  // One per morph target of the mesh, in glTF order.
  // Skinning influences (JOINTS_n/WEIGHTS_n, every set): `influences` per vertex, joint
  // indices into the skin's joint list, weights normalised to sum 1. Empty when unskinned.
  size_t influences = 0;
  std::vector<uint16_t> joints;
  std::vector<float> joint_weights;
  // The source's vertex of each vertex, or empty (each vertex is its own). A source that gives UVs
  // per face corner (OBJ, MakeHuman) is split where a vertex's corners differ, as glTF needs:
  // its copies share this number, every target moves them alike, normals are recomputed over all
  // of their faces (no seam shows), and vertex numbers in a manifest mean these (the source's).
  // Stored in glTF as the application attribute _SOURCE_VERTEX.
  std::vector<uint32_t> source_vertices;
  static constexpr uint32_t kMaxSourceVertex = 1u << 24;  // Exact in a float accessor.

  // Derived on load (FinalizePrimitive): vertex -> incident faces (CSR), and the smooth
  // area-weighted normals of the base positions (used by normal recomputation).
  std::vector<uint32_t> vertex_face_offsets;  // vertex_count + 1 entries.
  std::vector<uint32_t> vertex_faces;
  std::vector<float> base_smooth_normals;

  size_t vertex_count() const { return positions.size() / 3; }
  size_t triangle_count() const {
    return mode == PrimitiveMode::kTriangles ? indices.size() / 3 : 0;
  }
};

// Fills the derived members of a primitive (adjacency, smooth normals, normals if missing,
// target runs). Call once after import.
void FinalizePrimitive(Primitive& primitive);

struct Mesh {
  std::string name;
  std::vector<int> primitives;  // Indices into Rig::primitives.
  std::vector<uint32_t>
      target_shapes;  // Morph target t of this mesh drives shape target_shapes[t].
  int skin = -1;      // Skin of the first node showing this mesh, or -1.
};

// An MMD bone morph's entry: at weight w the bone moves by w x translation and turns by rotation
// slerped from none by w, after what the clips animate (pose_request.h, ApplyBoneMorphs).
struct BoneMorph {
  int node = -1;
  std::array<float, 3> translation{0, 0, 0};
  std::array<float, 4> rotation{0, 0, 0, 1};  // x, y, z, w.
};

// An MMD material morph on one material (or on every one: material -1). At weight w (times
// `factor`, a group morph's share), a multiply scales each value by lerp(1, value, w) and an add
// adds w * value; per material, the product of the multiplies then the sum of the adds (as MMD).
struct MaterialMorph {
  int material = -1;
  bool add = false;
  float factor = 1.0f;
  std::array<float, 4> diffuse{1, 1, 1, 1};  // RGBA: the base colour (and alpha).
  std::array<float, 3> specular{1, 1, 1};
  float specular_power = 1.0f;
  std::array<float, 3> ambient{1, 1, 1};
  std::array<float, 4> edge{1, 1, 1, 1};
  float edge_size = 1.0f;
  std::array<float, 4> texture_tint{1, 1, 1, 1}, sphere_tint{1, 1, 1, 1}, toon_tint{1, 1, 1, 1};
};

struct Shape {
  std::string name;
  std::string group = "default";  // "identity", "expression", ... from the manifest.
  float min = 0.0f;               // Authored range; weights outside it warn.
  float max = 1.0f;
  float default_weight = 0.0f;       // From glTF mesh.weights or the manifest.
  int partner = -1;                  // Symmetric (left/right) partner shape, or -1.
  std::vector<std::string> aliases;  // Other names that address this shape.
  size_t vertices_moved = 0;         // Over all primitives.
  bool driven = false;               // Its weight is computed (an in-between or a corrective); a
                                     // weight given for it is ignored with a warning.
  std::vector<MaterialMorph>
      material_morphs;  // MMD: what the shape does to materials (most shapes: nothing).
  std::vector<BoneMorph> bone_morphs;  // MMD: bones the shape moves and turns (most shapes: none).
};

// An MMD flip morph (PMX 2.1): its weight, clamped to [0, 1], picks one of its n entries, entry
// floor((n + 1) w) - 1 (none below 1 / (n + 1), the last at 1), whose shape gets the entry's weight
// whole, not scaled by w: a switch, not a blend (EffectiveWeights).
struct Flip {
  uint32_t shape = 0;
  std::vector<std::pair<uint32_t, float>> entries;  // (shape, weight)
};

// In-between shapes on one slider (Maya's blendShape in-betweens): the slider shape's own
// target is its value at weight `full` (1 unless the source says otherwise); `keys` are the
// shapes reached at other weights (never 0, the base), ascending, on either side of 0 or beyond
// `full` (FBX's FullWeights may be negative). A slider value v interpolates linearly between the
// two neighbouring points of {(0, base), keys, (full, slider)} and extrapolates the end segments.
struct InBetweens {
  uint32_t slider = 0;
  float full = 1.0f;
  std::vector<std::pair<float, uint32_t>> keys;  // (weight, shape)
};

// A corrective (combination) shape driven by other shapes' weights: their product, or their
// minimum, so that e.g. smile + blink can fix what the two shapes do together.
struct Corrective {
  uint32_t shape = 0;
  std::vector<uint32_t> drivers;
  bool use_min = false;
};

// A control a character creator shows instead of raw shapes (MakeHuman's modifiers): a
// two-sided control in [-1, 1] drives `negative` with -v below 0 and `positive` with v above;
// a one-sided control in [0, 1] drives `positive` only.
struct Control {
  std::string name;  // "nose/nose-trans-down|up", "head/head-oval".
  std::string group = "default";
  float min = 0.0f, max = 1.0f;
  int negative = -1;  // Shape index, or -1 (one-sided).
  int positive = -1;
  int partner = -1;  // Mirrored left/right control, or -1.
};

// A face expression by name (VRM 1.0's presets, or a rig's own): weights of the rig's shapes at
// value 1, and how it overrides the blink, look-at and mouth expressions while it shows (VRM's
// overrideBlink/overrideLookAt/overrideMouth: core/face.h, ExpressionMultipliers).
enum class ExpressionOverride : uint8_t { kNone, kBlock, kBlend };
struct Expression {
  std::string name;
  std::vector<std::pair<uint32_t, float>> binds;  // (shape, weight at value 1)
  bool binary = false;  // Values above 0.5 show it whole, others not at all.
  ExpressionOverride blink = ExpressionOverride::kNone, look_at = ExpressionOverride::kNone,
                     mouth = ExpressionOverride::kNone;
  bool derived = false;  // From the shapes' names (core/face.h), not the manifest.
};

// VRM lookAt's range map: an angle (degrees, >= 0) to an output, out = output_scale * min(angle /
// input_max, 1): degrees of an eye bone's turn, or an eye shape's weight.
struct RangeMap {
  float input_max = 90.0f;
  float output_scale = 1.0f;
  float Map(float degrees) const;
};

// How the rig's eyes follow a gaze (core/face.h): eye bones, else per-eye shapes (ARKit's
// eyeLookIn/Out/ Up/Down), else the lookLeft/Right/Up/Down expressions; optionally the head and
// neck take a share.
struct GazeSetup {
  enum class Kind : uint8_t { kNone, kBones, kShapes, kExpressions };
  Kind kind = Kind::kNone;
  std::array<int, 2> eyes{-1, -1};  // Bones (left, right), kBones.
  // kShapes: per eye (left, right) the shapes turning it in (towards the nose), out, up, down.
  std::array<int, 2> look_in{-1, -1}, look_out{-1, -1}, look_up{-1, -1}, look_down{-1, -1};
  int head = -1, neck = -1;                    // Bones, or -1.
  float head_share = 0.0f, neck_share = 0.0f;  // Of the gaze's angles, turned by the head and neck.
  RangeMap horizontal_inner, horizontal_outer, vertical_down, vertical_up;
  std::array<float, 3> origin{0, 0, 0};  // Between the eyes at rest (world), for targets.
  bool faces_minus_z = false;  // The face looks along -z at rest (VRM 0.x), not glTF's +z.
  bool from_manifest = false;
};

// How a rig's mouth speaks (core/speech.h): per viseme (the 15 of OpenXR/Oculus, in Viseme's order)
// the weights of its shapes; `nolip`, shapes held at 0 while speaking (MMDAgent's shapemap NOLIP:
// other mouth shapes that would fight the visemes); `jaw`, the shapes that open the jaw (kept from
// chattering).
struct VisemeMap {
  std::array<std::vector<std::pair<uint32_t, float>>, 15> binds;
  std::vector<uint32_t> nolip;
  std::vector<uint32_t> jaw;
  uint16_t named = 0;  // Bit v: viseme v came from the manifest ("visemes"); else derived.
  bool nolip_named = false, jaw_named = false;  // The same for nolip and jaw.
  bool empty() const {
    for (const auto& b : binds) {
      if (!b.empty()) return false;
    }
    return true;
  }
};

// A statistical model of the weights (e.g. a PCA face space): components (orthonormal
// directions in weight space, one weight per shape) with their standard deviations, around a
// mean. The Mahalanobis distance of a point beyond `bound` warns (implausible).
struct ShapeStatistics {
  bool present = false;
  std::vector<float> mean;                     // One per shape.
  std::vector<std::vector<float>> components;  // Each one per shape.
  std::vector<float> stddev;                   // One per component, > 0.
  float bound = 3.0f;
};

struct Node {
  std::string name;
  int parent = -1;
  std::vector<int> children;
  int mesh = -1;  // Index into Rig::meshes, or -1.
  bool has_matrix = false;
  std::array<float, 16> matrix{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // Column-major.
  std::array<float, 3> translation{0, 0, 0};
  std::array<float, 4> rotation{0, 0, 0, 1};  // x, y, z, w.
  std::array<float, 3> scale{1, 1, 1};
};

// MMD's bone constraints (PMX, PMD), solved over a pose as MMD solves them (core/constraints.h).
// A grant adds a share of another bone's animated rotation and/or translation to a bone's own.
struct Grant {
  int node = -1, source = -1;
  float ratio = 1.0f;
  bool rotation = false, translation = false;
  bool local = false;  // The source's own animation, not what it inherits itself.
};

// One bone of an IK chain; `limited`: Euler angles (x, y, z, radians, in the rig's axes) kept in
// [lower, upper].
struct IkLink {
  int node = -1;
  bool limited = false;
  std::array<float, 3> lower{0, 0, 0}, upper{0, 0, 0};
};

// Cyclic coordinate descent: rotates the links (effector's parent first) so that the effector
// bone reaches the IK bone, `loops` times at most, each link by at most `max_angle` a step.
struct IkChain {
  int node = -1;      // The IK bone: where the effector is to be.
  int effector = -1;  // The bone brought there (PMX calls it the IK target).
  int loops = 1;
  float max_angle = 0.0f;  // Radians per link and iteration.
  std::vector<IkLink> links;
};

struct BoneConstraints {
  std::vector<int> order;  // Nodes in MMD's deform order (layer, then index; after-physics last).
  std::vector<Grant> grants;
  std::vector<IkChain> chains;
  bool empty() const { return grants.empty() && chains.empty(); }
};

// Secondary motion (MMD's rigid bodies and joints): bodies on bones, joined by spring joints, in
// the rig's space (metres, right-handed). core keeps the data; core/physics simulates it over time.
struct RigidBody {
  enum class Shape : uint8_t { kSphere, kBox, kCapsule };
  // kFollowBone: moved by its bone (kinematic). kPhysics: moves its bone. kPhysicsKeepPosition:
  // turns its bone, which keeps its place on its parent.
  enum class Mode : uint8_t { kFollowBone, kPhysics, kPhysicsKeepPosition };
  std::string name;
  int node = -1;  // Its bone; -1: none (follows the rig's root, drives nothing).
  Shape shape = Shape::kSphere;
  std::array<float, 3> size{
      0, 0, 0};  // Sphere: radius; box: half extents; capsule: radius, height (along y).
  std::array<float, 3> position{0, 0, 0};
  std::array<float, 4> rotation{0, 0, 0, 1};  // x, y, z, w; at rest.
  float mass = 0.0f, linear_damping = 0.0f, angular_damping = 0.0f, restitution = 0.0f,
        friction = 0.0f;
  uint8_t group = 0;                // 0-15.
  uint16_t collides_with = 0xffff;  // Bit i: collides with group i.
  Mode mode = Mode::kFollowBone;
};

// A six-degree-of-freedom spring joint between two bodies, its frame at rest; limits and springs
// along and about the frame's axes (angles: Euler x, y, z, radians; lower > upper: free).
struct PhysicsJoint {
  std::string name;
  int a = -1, b = -1;  // Bodies.
  std::array<float, 3> position{0, 0, 0};
  std::array<float, 4> rotation{0, 0, 0, 1};
  std::array<float, 3> linear_lower{0, 0, 0}, linear_upper{0, 0, 0}, angular_lower{0, 0, 0},
      angular_upper{0, 0, 0};
  std::array<float, 3> linear_stiffness{0, 0, 0}, angular_stiffness{0, 0, 0};  // 0: no spring.
};

struct Physics {
  std::vector<RigidBody> bodies;
  std::vector<PhysicsJoint> joints;
  // The scale it was authored at and is simulated at (MMD: 12.5 units a metre), where the masses,
  // springs and dampings hold; gravity in metres a second squared, down -y.
  float units_per_metre = 1.0f;
  float gravity = 9.8f;
  bool empty() const { return bodies.empty(); }
};

struct Image {
  std::string name;
  std::string
      mime_type;  // "image/png", "image/jpeg"; MMD textures also "image/bmp", "image/x-tga".
  std::vector<unsigned char> bytes;  // Encoded file contents; empty: not read (name is its path).
};

// What draws in place of a base-colour texture that could not be read (manifest "stand_in"): the
// material's colour as it is, or soft, a translucent blot over each UV island fading to its edges
// (an overlay whose shape was the texture's alpha: blush, marks), never an opaque rectangle.
enum class StandIn : uint8_t { kNone, kSoft };

struct Material {
  std::string name;
  std::array<float, 4> base_color_factor{1, 1, 1, 1};
  int base_color_image = -1;  // Index into Rig::images, or -1.
  int base_color_texcoord = 0;
  float metallic_factor = 1.0f;
  float roughness_factor = 1.0f;
  int metallic_roughness_image = -1;  // glTF's: roughness in green, metallic in blue (linear).
  int normal_image = -1;              // Tangent-space normal map (linear), TEXCOORD_0.
  float normal_scale = 1.0f;
  int occlusion_image = -1;  // Ambient occlusion in red (linear).
  float occlusion_strength = 1.0f;
  std::array<float, 3> emissive_factor{0, 0, 0};
  int emissive_image = -1;  // sRGB.
  bool double_sided = false;
  std::string alpha_mode = "OPAQUE";
  float alpha_cutoff = 0.5f;
  StandIn stand_in = StandIn::kNone;  // Only while the base colour's image is not read.
  // Drawn toon-shaded by its authors (MMD), with an outline (MMD's edge) in `outline_color`,
  // `outline_width` a fraction of the picture's height (0: none). VRM writes it as MToon
  // (VRMC_materials_mtoon); our renders stay lit as glTF's PBR.
  bool toon = false;
  std::array<float, 4> outline_color{0, 0, 0, 1};
  float outline_width = 0.0f;
};

struct Skin {
  std::string name;
  std::vector<int> joints;          // Node indices.
  std::vector<float> inverse_bind;  // 16 floats (column-major) per joint.
};

// kBezier (COLLADA BEZIER curves, kept as the file draws them): per key and component six floats,
// laid out per key as [values(c), x1(c), y1(c), x2(c), y2(c), ends(c)]: the curve from this key's
// value to `end` at the next key, with handles (x1, y1) and (x2, y2), x as a fraction of the key
// gap (in [0, 1], so x rises) and y as a value. `end` may differ from the next key's value (a
// step).
enum class Interpolation { kStep, kLinear, kCubicSpline, kBezier };
enum class ChannelPath { kTranslation, kRotation, kScale, kWeights };

struct AnimationSampler {
  std::vector<float> times;   // Ascending, seconds.
  std::vector<float> values;  // Per key: `components` floats (x3 for CUBICSPLINE:
                              // in-tangent, value, out-tangent; x6 for kBezier).
  size_t components = 0;
  Interpolation interpolation = Interpolation::kLinear;
  // Floats per key, and where a key's values start in them (CUBICSPLINE's in-tangents come first).
  size_t key_stride() const {
    return components * (interpolation == Interpolation::kCubicSpline ? 3
                         : interpolation == Interpolation::kBezier    ? 6
                                                                      : 1);
  }
  size_t value_offset() const {
    return interpolation == Interpolation::kCubicSpline ? components : 0;
  }
};

struct AnimationChannel {
  int sampler = 0;
  int node = 0;
  ChannelPath path = ChannelPath::kTranslation;
};

// An animation clip.
struct AnimationInfo {
  std::string name;
  float duration = 0.0f;  // Seconds: the latest keyframe time of any channel.
  size_t channels = 0;
  bool has_weights = false;  // Drives morph weights.
  std::vector<AnimationSampler> sampler_data;
  std::vector<AnimationChannel> channel_data;
};

// What a rig's authors allow done with it, in VRM 1.0 meta's terms: from the manifest ("terms",
// which names where the authors say so) or a VRM's meta. The defaults are VRM's most restrictive
// values, what stands when nothing is known: an export never grants more than its source.
struct UsageTerms {
  enum class Avatar : uint8_t { kOnlyAuthor, kOnlySeparatelyLicensedPerson, kEveryone };
  enum class Commercial : uint8_t { kPersonalNonProfit, kPersonalProfit, kCorporation };
  enum class Modification : uint8_t {
    kProhibited,
    kAllowModification,
    kAllowModificationRedistribution
  };
  Avatar avatar = Avatar::kOnlyAuthor;
  Commercial commercial = Commercial::kPersonalNonProfit;
  Modification modification = Modification::kProhibited;
  bool violent = false, sexual = false, political_or_religious = false, antisocial_or_hate = false;
  bool credit_required = true, redistribution = false;
  std::string source;  // Where the authors state them (manifest "terms"/"source", or "VRM meta");
                       // "": unknown.
};

// A named point on the surface (the manifest's "landmarks"): a barycentric point of three vertices
// of one primitive (a vertex itself: weights 1, 0, 0), moving with the blended mesh.
struct Landmark {
  std::string name;
  uint32_t primitive = 0;
  std::array<uint32_t, 3> vertices{};
  std::array<float, 3> weights{1.0f, 0.0f, 0.0f};
};

// A named part of the surface (the manifest's "regions": skin, eyes, teeth, hair ...): the
// primitives it covers, named there by mesh or by material.
struct Region {
  std::string name;
  std::vector<uint32_t> primitives;
};

// Where a rig's derived shapes came from (manifest "derivation"): what `facespace derive` made.
struct Derivation {
  std::string source;      // The rig whose shapes were transferred (its name); "": none derived.
  std::string credit;      // The source's attribution (FaceCap's CC-BY), kept with the shapes.
  std::string method;      // How: "nonrigid-icp+deformation-transfer".
  std::string alignment;   // "landmarks" or "shape".
  uint32_t landmarks = 0;  // Landmark pairs used.
  double mean_residual = 0, p95_residual = 0;  // The fit, as fractions of the head's diagonal.
  std::vector<std::string> shapes;             // The shapes derived.
};

struct Rig {
  std::string name;
  std::string
      credit;  // The attribution its license asks for (manifest "credit"); shown and exported.
  std::string license_url;  // Its licence (manifest "license_url"): a VRM's meta needs one.
  UsageTerms terms;         // What its authors allow (VRM's meta).
  Derivation derivation;    // Where its derived shapes came from, if it has any.
  // Where an editor starts and resets (manifest "start"): the neutral face (every weight 0, the
  // default) or the shapes' default weights (a glTF mesh's `weights`, FaceCap's capture frame).
  bool start_at_defaults = false;
  // A clip played looping as the base layer under every single motion asked for (manifest
  // "base_motion"; MMD players' full-body layer, e.g. a standing pose under expressions).
  std::string base_motion;
  std::vector<Primitive> primitives;  // In glTF mesh order, then primitive order.
  std::vector<Mesh> meshes;
  std::vector<Shape> shapes;  // Named across the file; order of first appearance.
  std::vector<Node> nodes;
  std::vector<int> scene_roots;  // Root nodes of the default scene.
  std::vector<Material> materials;
  std::vector<Image> images;
  std::vector<Warning> load_warnings;  // What the importer had to drop or fix.
  size_t skin_count = 0;               // Skeletons present in the source (not yet evaluated).
  size_t joint_count = 0;
  std::vector<Skin> skins;
  std::vector<AnimationInfo> animations;
  std::vector<Control> controls;       // From the manifest (or a MakeHuman modifiers file).
  std::vector<InBetweens> inbetweens;  // From the manifest: weights computed before blending.
  std::vector<Corrective> correctives;
  std::vector<Flip> flips;      // MMD's flip morphs: shapes that switch others on.
  BoneConstraints constraints;  // MMD's grants and IK, applied to every pose.
  Physics physics;              // Simulated over sequences (core/physics); stills ignore it.
  ShapeStatistics statistics;
  std::vector<Expression>
      expressions;  // By name (core/face.h): the manifest's, then those derived from shape names.
  GazeSetup gaze;
  VisemeMap visemes;  // How it speaks (core/speech.h): the manifest's, then derived.
  std::vector<Landmark>
      landmarks;  // The manifest's, in its order (FaceCap's and Uka's: iBUG 300-W's 68).
  std::string landmark_scheme;  // What they follow ("ibug-300w-68"), from the manifest.
  std::vector<Region> regions;  // The manifest's; a primitive in none is labelled by its material.

  size_t vertex_count() const;
  size_t triangle_count() const;
};

// Index of the shape called `name` (or with that alias), or -1.
int FindShape(const Rig& rig, const std::string& name);

// The shape name closest to `name` by edit distance (case-insensitive), or "" for none.
std::string ClosestShapeName(const Rig& rig, const std::string& name);

// Of `candidates`, the one closest to `name` by edit distance (case-insensitive) when it is
// plausibly a typo of it (at most a third of the name differs), else "". For "did you mean".
std::string ClosestName(std::string_view name, std::span<const std::string_view> candidates);

// " (did you mean 'X'?)" for ClosestName's answer, or "" when there is none.
std::string DidYouMean(std::string_view name, std::span<const std::string_view> candidates);

// The left/right counterpart of a shape name ("mouthSmile_L" -> "mouthSmile_R", "l-eye" ->
// "r-eye"), or "" when the name carries no side marker.
std::string CounterpartName(const std::string& name);

// Pairs shapes whose names differ only by a left/right marker (_L/_R, Left/Right, .L/.R,
// l-/r-, ...) as symmetric partners, unless a partner is already set.
void DetectSymmetricPartners(Rig& rig);

// Recounts Shape::vertices_moved from the targets.
void CountMovedVertices(Rig& rig);

// The diagonal of the box around every primitive's positions (mesh space, as stored): the rig's
// size, for tolerances relative to it. 0 for a rig with no vertices.
double RigDiagonal(const Rig& rig);

// Column-major 4x4 world matrix of each node (parent before child).
std::vector<std::array<float, 16>> NodeWorldMatrices(const Rig& rig);

// For each primitive, the world matrix of the first node (in node order) that shows its
// mesh; identity when no node does. Used by flat exports (OBJ, f32).
std::vector<std::array<float, 16>> PrimitiveWorldMatrices(const Rig& rig);

// World-space positions (xyz per primitive, as the flat exports write them) back into each
// primitive's mesh space: through the inverse of its PrimitiveWorldMatrices entry. Extra
// primitives beyond the rig's are left as they are.
void WorldToMeshSpace(const Rig& rig, std::span<std::vector<float>> positions);

// Checks internal consistency (index ranges, array sizes). Importers call it last, so a rig
// that passes is safe to evaluate without further checks.
Status ValidateRig(const Rig& rig);

// Replaces what is not UTF-8 in `s` (stray bytes, overlong forms, surrogates, past U+10FFFF)
// with U+FFFD. True when something was replaced.
bool RepairUtf8(std::string& s);

// Every name, group, alias and load warning of the rig as valid UTF-8 (names read from a file
// are bytes: a Latin-1 FBX, a broken Collada, a PMX with a stray UTF-16 surrogate), so every
// writer, JSON included, can take them. Importers call it before ValidateRig; a rig that needed
// it gets a `names_repaired` load warning.
void RepairNames(Rig& rig);

}  // namespace engine
}  // namespace facespace
