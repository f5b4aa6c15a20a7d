// Reading rigs (glTF 2.0, OBJ sequences, manifests) and writing blended meshes
// (glb, OBJ, JSON, raw float32). glTF and JSON libraries stay inside the .cpp files.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "facespace/engine/blend.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/sparse_blend.h"
#include "facespace/engine/status.h"
#include "facespace/engine/weights.h"

namespace facespace::formats {

struct LoadOptions {
  // Let a .gltf read external buffers and images beside it. Off for uploaded bytes, so a
  // request can never make us read our own disk.
  bool allow_external_files = true;
  // Apply "<stem>.manifest.json" found beside a file (see README "Manifest").
  bool read_manifest = true;
};

// Loads a .glb or .gltf file (format from the content, not the name).
Result<Rig> LoadGltfFile(const std::string& path, const LoadOptions& options = {});

// Loads glb bytes, or glTF JSON with embedded (data URI) buffers. `base_dir` is used for
// external references only when options.allow_external_files is set.
Result<Rig> LoadGltfMemory(std::span<const unsigned char> bytes, const std::string& base_dir,
                           const LoadOptions& options);

// A sequence of OBJ files as absolute shapes: the first is the base, each other one a shape
// named after its file stem. Connectivity must be identical; the first differing face is
// reported. Shapes are stored relative (S_j - base), exact zeros elided.
Result<Rig> LoadObjSequence(std::span<const std::string> paths);

// A MakeHuman rig: base.obj (hm08) and a folder of .target files ("index dx dy dz" lines,
// '#' comments), the OBJ's vertex order kept so target indices stay valid.
struct MakeHumanOptions {
  std::vector<std::string> groups = {"body"};  // OBJ groups ("g") whose faces are kept; "*" = all.
  bool metres = false;                         // Scale decimetres to metres.
  std::string modifiers;                       // modeling_modifiers.json: controls; "" = none.
  // MakeHuman proxies (.mhclo: eyes, teeth, ...) added as primitives: each vertex placed on the
  // base mesh (helper geometry included) as MakeHuman places it, and moved by every target as
  // that placement moves (exact at each target's full weight); its .mhmat's texture embedded.
  std::vector<std::string> proxies;
};
// Shapes are named after their files (stem), grouped by their folder; errors in a target file
// name the file and line (malformed line, index beyond the mesh, duplicate index). Vertices no
// kept face uses are dropped, order preserved (hm08's body is vertices 0-13379: unchanged).
// Each of `target_dirs` is read recursively, files sorted by path; a shape's group is its
// sub-folder, or the folder's own name for files directly in it.
Result<Rig> LoadMakeHuman(const std::string& obj_path, std::span<const std::string> target_dirs,
                          const MakeHumanOptions& options);

// Controls from MakeHuman's modeling_modifiers.json: [{"group", "modifiers": [{"target",
// "min", "max"}]}]. A modifier with min/max is a two-sided control "group/target-min|max" in
// [-1, 1]; one without, a one-sided "group/target" in [0, 1]. Modifiers whose targets the rig
// lacks are skipped; l-/r- controls become partners.
Status ApplyMakeHumanModifiers(Rig& rig, const std::string& json_text);

// A glb with its vertex data, indices and sparse morph targets compressed (EXT_meshopt_compression,
// lossless: meshoptimizer's codecs; a fallback buffer without data, so the extension is required).
// Views that do not shrink, or that several accessors share, stay as they are; a glb that already
// uses the extension, or that has several buffers, comes back unchanged.
Result<std::vector<unsigned char>> EncodeMeshoptGlb(std::span<const unsigned char> glb);

// The manifest (JSON text) that carries a rig's groups, ranges, partners, aliases and controls.
std::string ManifestJson(const Rig& rig);

// Doom 3 MD5: a .md5mesh (joints, meshes whose vertices are weighted joint-space positions) as a
// skinned rig, each .md5anim a clip (hierarchy flags over a base frame, a key per frame, linear).
// MD5 is Z-up: a root node ("md5_root", -90 degrees about X) makes it Y-up; units are kept.
// `anims`: (clip name, .md5anim text); one whose joints differ from the mesh's is skipped with an
// animation_skipped warning. Errors name the file and line.
Result<Rig> LoadMd5Memory(std::string_view mesh_text, const std::string& mesh_name,
                          std::span<const std::pair<std::string, std::string>> anims);
// A .md5mesh file, with every .md5anim in its folder as a clip (named by file stem).
Result<Rig> LoadMd5File(const std::string& path);

// FBX 7.x, binary or ASCII (see core/README.md "FBX" for what is read and what is reported as
// skipped). `name` names the rig and prefixes errors. Units and handedness are the file's; a root
// node ("fbx_root") turns a Z-up (or other) file Y-up.
Result<Rig> LoadFbxMemory(std::span<const unsigned char> bytes, const std::string& name);

// COLLADA (.dae): geometry, nodes, morph and skin controllers (a skin over a morph too), base
// colours, animated morph weights (see core/README.md "COLLADA"). Units are the file's; a root node
// ("collada_root") turns a Z-up or X-up file Y-up.
Result<Rig> LoadColladaMemory(std::span<const unsigned char> bytes, const std::string& name);

// MikuMikuDance PMX 2.0/2.1 (see core/README.md "MMD"): vertices with BDEF1/2/4 skinning, faces per
// material, bones and one skin, vertex morphs (and group morphs baked) as shapes named in Japanese
// with the English names as aliases. Converted once to right-handed metres: (x, y, -z) x 0.08.
Result<Rig> LoadPmxMemory(std::span<const unsigned char> bytes, const std::string& name);
// PMD, the MMD model format before PMX: the same rig (BDEF2 skinning; expressions from the
// base-skin layout, Shift-JIS names, English names as aliases when the file has them).
Result<Rig> LoadPmdMemory(std::span<const unsigned char> bytes, const std::string& name);
// A VMD motion as a clip of `rig` (a PMX/PMD model or one converted from it): bone keys matched to
// nodes and morph keys to shapes (or aliases) by Shift-JIS names cut to 15 bytes; bone keys sampled
// through their Bezier curves at 60 a second (straight segments keep their keys), morph keys
// linear. Names matching nothing are a `motion_names_unmatched` warning appended to `warnings`; a
// motion matching nothing is an error.
Result<AnimationInfo> LoadVmdMemory(std::span<const unsigned char> bytes, const Rig& rig,
                                    const std::string& clip_name, std::vector<Warning>* warnings);
// A new image of `rig` for the file at `path` in a model's folder (no bytes yet), with its
// `texture_not_loaded` warning until LoadImagesBeside reads it; returns its index.
int AddImageBeside(Rig& rig, const std::string& path);
// Reads the rig's images that have a path but no bytes (MMD and COLLADA textures) from the folder
// of `model_path`: paths stay inside that folder (no absolute paths, no ".."; letter case forgiven,
// as Windows tools write them), at most 64 MiB each, PNG, JPEG, BMP or TGA (mime type from the
// magic, TGA by its extension). Each image read drops its `texture_not_loaded` warning; the others
// keep it, saying why.
void LoadImagesBeside(Rig& rig, const std::string& model_path);
// Every .vmd beside `model_path` and in its motion/ folder as a clip of `rig`, named by file stem
// (a name already taken is kept); a motion that fails is an `animation_skipped` warning.
void AddVmdMotions(Rig& rig, const std::string& model_path);

// The formats a rig comes in, and how to tell them: by file extension, or by the bytes' magic.
enum class RigFormat { kGlb, kGltf, kFbx, kCollada, kMd5, kPmx, kPmd };
bool RigFormatFromPath(const std::string& path, RigFormat* format);
bool SniffRigFormat(std::span<const unsigned char> bytes, RigFormat* format);
const char* RigFormatExtension(
    RigFormat format);  // ".glb", ".gltf", ".fbx", ".dae", ".md5mesh", ".pmx", ".pmd"
// A rig from bytes of a known format (never reads other files: no external buffers, manifests or
// .md5anim clips). `name` names the rig.
Result<Rig> LoadRigMemory(std::span<const unsigned char> bytes, RigFormat format,
                          const std::string& name);

// Loads a rig from a path: .glb/.gltf, .md5mesh, .fbx, .dae, .pmx/.pmd (with the .vmd motions
// beside it and in its motion/ folder), or .obj (a single OBJ is a rig without shapes).
Result<Rig> LoadRigFile(const std::string& path, const LoadOptions& options = {});

// Applies a manifest (JSON text, schema in README "Manifest") to the rig's shapes.
Status ApplyManifest(Rig& rig, const std::string& json_text);
// The members a manifest may hold, as ApplyManifest reads them (any other is refused); the OpenAPI
// document's Manifest schema names the same (a test compares them).
std::vector<std::string_view> ManifestMembers();

// kVrm: a glb of the rig itself (as glb with keep_targets) at rest, with VRM 1.0's VRMC_vrm
// (export/vrm.cpp); kVrm0: the same as VRM 0.x (its "VRM" extension, turned to face -z:
// export/vrm0.cpp).
enum class MeshFormat { kGlb, kObj, kJson, kF32, kVrm, kVrm0 };

// "glb", "obj", "json", "f32", "vrm", "vrm0" -> format; false when unknown.
bool ParseMeshFormat(const std::string& name, MeshFormat* format);
const char* MeshFormatName(MeshFormat format);
const char* MeshFormatMimeType(MeshFormat format);

struct ExportOptions {
  // glb only: write the rig itself (base shape and sparse targets) with the weights as the
  // mesh's default `weights`, instead of the blended mesh, for clients that morph on the GPU.
  bool keep_targets = false;
  bool clips = true;  // With keep_targets: the rig's clips too (a VRM leaves them out: apps bring
                      // their motions).
  // JSON, OBJ and f32: positions and normals as each mesh stores them (before its node's
  // transform, still in a quantized mesh's units) instead of world space. glb carries its nodes
  // and is the same either way.
  bool mesh_space = false;
  // VRM only: a PNG of the avatar's face, its meta's thumbnail (empty: none).
  std::vector<unsigned char> thumbnail_png;
};

// Writes the evaluated rig. `weights` and `warnings` are recorded where the format has room
// (JSON body, glb asset.extras / mesh weights). Deterministic: same input, same bytes.
// JSON, OBJ and f32 are in world space (each primitive placed by its node's world transform, a
// quantized mesh's positions dequantized), or in mesh space with options.mesh_space.
//   JSON: {"space": "world"|"mesh", "primitives": [{"mesh", "primitive", "name", "positions",
//         "normals"}], "warnings"}, primitives in glTF mesh/primitive order.
//   OBJ:  one object per primitive, with vt/vn.
//   f32:  little-endian float32: every primitive's positions (xyz), then every primitive's
//         normals (xyz), primitives in the JSON order.
//   glb:  the node hierarchy, materials and textures, with the blended mesh (or the rig).
Result<std::string> ExportMesh(const Rig& rig, const BlendedRig& blended,
                               std::span<const float> weights, std::span<const Warning> warnings,
                               MeshFormat format, const ExportOptions& options = {});

struct GlbTemplate;  // GlbVariantWriter's kept export (export.cpp).

// The glb of many blended variants of one rig, byte for byte what ExportMesh(kGlb) writes, at a
// fraction of its cost (as ozz's jobs keep their buffers between calls): the first call exports
// through ExportMesh and keeps the result as a template; later calls patch only what a variant
// changes (asset extras, the POSITION bounds, posed node matrices) and copy positions, normals and
// tangents (and UVs, when UV morphs move them) into the kept binary chunk, whose other bytes
// (indices, UVs, colours, images) are written once. A change of shape (another rig, posed or not,
// skinned or not) rebuilds the template. With options.keep_targets nothing varies with the blend:
// each call is ExportMesh.
class GlbVariantWriter {
 public:
  GlbVariantWriter();
  ~GlbVariantWriter();
  GlbVariantWriter(GlbVariantWriter&&) noexcept;
  GlbVariantWriter& operator=(GlbVariantWriter&&) noexcept;

  // The glb in two pieces, to be written one after the other: `head` (the glb header, the JSON
  // chunk and the binary chunk's header) and `bin` (the binary chunk). Valid until the next call.
  struct Pieces {
    std::string_view head, bin;
  };
  Result<Pieces> Write(const Rig& rig, const BlendedRig& blended, std::span<const float> weights,
                       std::span<const Warning> warnings, const ExportOptions& options = {});

 private:
  std::unique_ptr<GlbTemplate> t_;
};

// f32 bodies of many points of one rig, byte for byte what EvaluateRig + ExportMesh(kF32) write,
// written over the rest's bytes: the rig's rest (zero weights, rest pose) is exported once; a body
// takes the rest's bytes for the primitives a point leaves alone, and core's SparseBlend blends the
// primitives it moves, which are placed as ExportF32 places them, so the same bits. It serves the
// rigs and points SparseBlend serves (Write declines the others: false). Write takes the rig it
// was made from. Immutable after construction: threads share one, each with its own scratch.
class F32Writer {
 public:
  using Scratch = SparseBlend::Scratch;
  F32Writer(const Rig& rig, bool mesh_space);
  bool mesh_space() const { return mesh_space_; }
  // The body at `weights` (one per rig shape) into `out`, every byte of it written: a used body of
  // the same size is written over with no allocation. False: not served (see above).
  bool Write(const Rig& rig, std::span<const float> weights, Scratch& scratch,
             std::string& out) const;

 private:
  F32Writer(const Rig& rig, bool mesh_space, BlendedRig&& rest);
  struct Placed {
    std::array<float, 16>
        placement{};                // Its node's transform at rest, or the identity in mesh space.
    size_t at = 0, normals_at = 0;  // Byte offsets of its positions and its normals in a body.
  };
  bool mesh_space_;
  bool ok_ = false;
  SparseBlend blend_;
  std::vector<Placed> primitives_;
  std::string rest_;  // The body at rest.
};

// The JSON export's primitives array: [{"mesh", "primitive", "name", "positions", "normals"}],
// in world space (or each mesh's own with `mesh_space`).
std::string PrimitivesJson(const Rig& rig, const BlendedRig& blended, bool mesh_space = false);

// World-space float32 positions of every primitive, in order (the f32 export without normals).
void WorldPositions(const BlendedRig& blended, std::vector<float>& out);

// JSON text of one warning list: [{"code", "message", "shape"?, "value"?}, ...].
std::string WarningsToJson(std::span<const Warning> warnings);

// `s` as a JSON string (invalid UTF-8 replaced), for the bodies written as text where nlohmann
// would cost more than the body (per-frame JSON of sequences and meshes).
std::string JsonString(const std::string& s);

}  // namespace facespace::formats
