// Request schemas: JSON (from HTTP bodies and the CLI's --weights) to core inputs.
// Parsing never throws; every error names the offending field as a JSON Pointer.
#pragma once

#include <algorithm>
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/engine/blend.h"
#include "facespace/engine/enum_table.h"
#include "facespace/engine/fit.h"
#include "facespace/engine/retarget.h"
#include "facespace/engine/sequence.h"
#include "facespace/engine/skeleton.h"
#include "facespace/engine/speech.h"
#include "facespace/engine/status.h"
#include "facespace/engine/variants.h"
#include "facespace/engine/weights.h"
#include "facespace/formats/io.h"
#include "facespace/picture/picture.h"

namespace facespace::evaluator {

// Parses a weight vector given as JSON text: a dense array in shape order ([0.5, 0, 1]) or a
// map by shape name or index ({"jawOpen": 0.5, "3": 1}). `pointer` prefixes field pointers.
Result<std::vector<WeightEntry>> ParseWeightsJson(std::string_view text,
                                                  const std::string& pointer = "");

struct MeshRequest {
  std::vector<WeightEntry> weights;
  std::vector<WeightEntry>
      controls;      // {"controls": {"nose/nose-trans-down|up": -0.4}}: see ApplyControls.
  PoseRequest pose;  // "pose", "animation" + "time" (+ "loop"), "blend".
  BlendOptions options;
  std::optional<formats::MeshFormat> format;  // Absent: decided by Accept, else JSON.
  bool strict = false;                        // Warnings become a 422.
  bool keep_targets = false;                  // glb: the rig with these weights as defaults.
  int lod = 0;              // Level of detail: 0 full, L ~ 1/2^L of the triangles (core/lod.h).
  bool mesh_space = false;  // "space": "mesh": JSON, OBJ and f32 before the node transforms.
  // "vocabulary": what the weights' names are (core/retarget.h): "arkit", "vrm", "mmd" or a rig's
  // id (kRig, `vocabulary_rig`; the caller that holds the store sets `vocabulary_source`).
  Vocabulary vocabulary = Vocabulary::kOwn;
  std::string vocabulary_rig;
  std::shared_ptr<const Rig> vocabulary_source;
};

// "arkit", "vrm", "mmd" or a rig's id (IsValidRigId) into r.vocabulary (and r.vocabulary_rig);
// false for other text. VocabularyLabel: the word of kArkit, kVrm, kMmd.
bool ParseVocabulary(std::string_view text, MeshRequest& r);
const char* VocabularyLabel(Vocabulary v);

// Body of POST /v1/rigs/{id}/mesh and /check:
// {"weights": {...}|[...], "mode": "relative"|"absolute", "normals": "blend"|"recompute",
//  "format": "glb"|"obj"|"json"|"f32", "strict": bool, "keep_targets": bool,
//  "pose": {"JOINT": {"rotation": [x, y, z, w] | "euler": [x, y, z], "translation", "scale"}},
//  "animation": NAME|INDEX, "time": SECONDS, "loop": bool,
//  "blend": [{"animation": NAME|INDEX, "time", "weight", "loop", "mask": [JOINT, ...]}],
//  "skinning": "linear"|"dual_quaternion", "lod": 0..4, "controls": {NAME: value},
//  "space": "world"|"mesh"}
// Malformed JSON is InvalidArgument with pointer "" and message starting "malformed JSON";
// schema errors name their field.
Result<MeshRequest> ParseMeshRequest(std::string_view body);

// Status::reason of a body (or --weights text) that is not JSON at all, rather than JSON that
// breaks the schema.
inline constexpr char kMalformedJson[] = "malformed-json";

// Body of POST /v1/rigs/{id}/render: the mesh body's weights, mode, normals and strict, plus
// {"camera": {"yaw", "pitch", "distance", "zoom", "fov"} | {"eye", "target", "up", "fov"},
//  "width", "height", "view": "shaded"|"wireframe"|"heatmap"|"normals"|"clay", "exposure": stops,
//  "background": "#rrggbb"|"#rrggbbaa"|"transparent"|[r, g, b, a?], "supersample": 1..4,
//  "format": "png"|"jpeg"|"exr"|"tiff"|"webp", "quality": 1..100}
struct RenderRequest {
  MeshRequest mesh;
  picture::RenderOptions render;
  std::optional<picture::ImageFormat> format;  // Absent: decided by Accept, else PNG.
  int quality = 90;
};
Result<RenderRequest> ParseRenderRequest(std::string_view body);

// One render setting given as text (a query parameter or a CLI flag): width, height, view,
// background, supersample, format, quality, yaw, pitch, distance, zoom, fov, camera (JSON).
// Returns "" or what is wrong with the value; `known` tells whether the key is a render key.
std::string ApplyRenderSetting(const std::string& key, const std::string& value, RenderRequest& r,
                               bool* known);

// Body of POST /v1/rigs/{id}/sheet: the render body's settings (one per cell) and
// {"cells": [{"weights": ..., "label": "..."}, ...], "columns": N}.
struct SheetRequest {
  RenderRequest base;
  std::vector<std::vector<WeightEntry>> cells;
  std::vector<std::string> labels;
  int columns = 4;
  std::string shape_cells;  // "cells": "shapes" or "shapes:GROUP", expanded by ExpandShapeCells.
};
Result<SheetRequest> ParseSheetRequest(std::string_view body);
// "cells": "shapes" (or "shapes:GROUP"): one cell per shape of the rig (of that group) at weight 1,
// labelled with its name (or an alias where `renderer`, when given, has no glyphs for it). An
// unknown group is an error naming /cells.
Status ExpandShapeCells(const Rig& rig, const picture::Renderer* renderer, SheetRequest& request);

// A skeleton setting given as text (query parameter or CLI flag): animation, time, loop,
// pose (JSON), blend (JSON), skinning (linear|dual_quaternion), lod (0..4). Returns "" or what is
// wrong; `known` tells whether the key is one.
std::string ApplyPoseSetting(const std::string& key, const std::string& value, MeshRequest& r,
                             bool* known);

// The short form of a gaze (the query's and the CLI's): "YAW,PITCH" (degrees) or "X,Y,Z" (a
// target), as the body's JSON text; "" when it is neither.
std::string GazeShortForm(const std::string& value);

// Checks the skeleton settings gathered by ApplyPoseSetting (time without animation, ...).
std::string FinishPoseSettings(MeshRequest& r);

// How a sequence's or a speech's frames are answered: a closed set, named in one table. Sample:
// json (meshes) or weights; stream: ndjson, weights (ndjson without meshes) or f32; speech adds wav
// (the audio) and webm (a video). Which a route takes, it says (FrameFormatsOf).
enum class FrameFormat { kJson, kWeights, kNdjson, kF32, kWav, kWebm };
inline constexpr EnumName<FrameFormat> kFrameFormats[] = {
    {FrameFormat::kJson, "json"},     {FrameFormat::kWeights, "weights"},
    {FrameFormat::kNdjson, "ndjson"}, {FrameFormat::kF32, "f32"},
    {FrameFormat::kWav, "wav"},       {FrameFormat::kWebm, "webm"}};
inline const char* Name(FrameFormat f) { return EnumEntry(kFrameFormats, f).name; }

// Bodies of POST /v1/rigs/{id}/sequence/{sample,stream,reduce}:
// {"keys": [{"time": 0, "weights": {...}|[...]} | {"time": 1, "shape": "jawOpen"}, ...],
//  "transition": "smoothstep"|..., "smooth": bool (Catmull-Rom), per key "transition" too,
//  sample: "times": [...], "format": "json"; stream: "fps", "format": "ndjson"|"f32";
//  reduce: "tolerance"; and "mode", "normals" as on the mesh route.}
struct SequenceRequest {
  struct Key {
    float time = 0.0f;
    std::vector<WeightEntry> weights;
    std::string shape;  // A shape key (one-hot), instead of weights.
    std::vector<WeightEntry>
        expressions;  // Expressions by name (core/face.h), added to the weights.
    std::optional<Transition> transition;
    std::string pointer;
  };
  std::vector<Key> keys;
  Transition transition;
  bool smooth = false;
  std::vector<float> times;
  float fps = 30.0f;
  std::optional<FrameFormat> format;  // None: the route's own (sample: json, stream: ndjson).
  float tolerance = 0.0f;
  bool has_tolerance = false;
  ClipRequest clip;  // "motion" or "animation" instead of keys (pointer empty: none).
  std::vector<ClipRequest> layers;  // "layers" instead of keys: each layer's time is its start.
  bool physics = true;              // "physics": false: no secondary motion (SequencePhysics).
  // "gaze": one gaze held ({"target"} or {"yaw", "pitch"}) or a track {"keys": [{"time", "target" |
  // "yaw", "pitch"}]}.
  std::vector<GazeKey> gaze;
  // "blink": {"per_minute": 15, "seed": 1}: natural blinks (core/face.h NaturalBlinks).
  bool blink = false;
  float blink_per_minute = 15.0f;
  uint64_t blink_seed = 1;
  BlendOptions options;
};
Result<SequenceRequest> ParseSequenceRequest(std::string_view body);

// The keys resolved against a rig (names, aliases, indices, shape keys), validated.
Result<Sequence> ResolveSequence(const Rig& rig, const SequenceRequest& request);

// A gaze track and natural blinks (over the keys' span) onto a resolved sequence; what the rig
// cannot show warns once in the sequence's warnings.
void AttachFace(const Rig& rig, std::span<const GazeKey> gaze, bool blink, float per_minute,
                uint64_t seed, Sequence& s);

// Body of POST /v1/rigs/{id}/speech (a JSON object, or a WAV file as the body itself):
// {"text": "..." (espeak-ng speaks it) | "audio": BASE64 WAV (PocketSphinx hears it), "transcript":
// "...",
//  "voice": "en-us", "rate": words a minute, "fps": 30, "strength": 0..1,
//  "format": "json"|"ndjson"|"f32"|"weights"|"wav"|"webm", "with_audio": bool (json: the WAV in it,
//  base64), the face under the speech: "weights", "expressions", "controls", "mode", "normals";
//  "gaze" (held or a track) and "blink" as on sequences; for webm the render route's "width",
//  "height", "camera", "view", "background", "supersample", "exposure"}
struct SpeechRequest {
  std::string text;
  std::string audio;  // WAV bytes (the base64 decoded, or the body).
  bool has_audio = false;
  std::string transcript;  // With audio: align to these words.
  std::string voice = kDefaultVoice;
  int rate = 175;
  float fps = 30.0f;
  float strength = 1.0f;
  FrameFormat format = FrameFormat::kJson;
  bool with_audio =
      false;  // json: the audio too, as a base64 WAV ("audio_wav"), for a page to play in sync.
  RenderRequest render;  // The face under the speech, the video's camera and size.
  std::vector<GazeKey> gaze;
  bool blink = false;
  float blink_per_minute = 15.0f;
  uint64_t blink_seed = 1;
};
// Errors name their field; text and audio both, or neither, is an error at /text.
Result<SpeechRequest> ParseSpeechRequest(std::string_view body);
// The same from a WAV body and the query's settings (voice, transcript, fps, format, ...), each ""
// when absent.
Result<SpeechRequest> SpeechRequestOfWav(
    std::string wav, const std::vector<std::pair<std::string, std::string>>& settings);

// A mesh to fit, as the JSON export writes it: {"space": "world"|"mesh", "primitives":
// [{"positions": [...]}, ...]}; without "space", world space (the export's default).
struct TargetMesh {
  std::vector<std::vector<float>> positions;  // Per primitive, xyz.
  bool mesh_space = false;
};

// Body of POST /v1/rigs/{id}/fit: {"target": TargetMesh (the mesh route's JSON), "bounded": bool,
// "sum_at_most_one": bool, "rigid_align": bool}.
struct FitRequest {
  TargetMesh target;
  FitOptions options;
};
Result<FitRequest> ParseFitRequest(std::string_view body);

// The target from the mesh JSON text.
Result<TargetMesh> ParseTargetJson(std::string_view text);

// Body of POST /v1/rigs/{id}/derive: {"from": SOURCE_ID, "as": RIG_ID, "shapes": ["arkit",
// "visemes"], "landmarks": {"scheme", "points": [...]}}, every member optional. The landmarks are
// kept as their JSON text, read by the derive itself (core/derive's ReadLandmarks).
struct DeriveRequest {
  std::string from = "facecap";  // The source rig, in the store.
  std::string as;                // The rig written; empty: the target itself, its shapes added.
  std::string shapes;            // "arkit,visemes" as the CLI's --shapes; empty: all and visemes.
  std::string landmarks;         // JSON text; empty: none.
};
Result<DeriveRequest> ParseDeriveRequest(std::string_view body);

// Body of POST /v1/rigs/{id}/capture (and `facespace capture`'s file): {"scheme":
// "mediapipe-478", "image": [w, h], "fps": 30, "frames": [[[x, y, z], ...], ...], "neutral": 0}.
// Each frame's points are flattened (3 per point); 468 or 478 points a frame.
struct CaptureRequest {
  std::array<int, 2> image{0, 0};
  float fps = 30;
  size_t neutral = 0;
  std::vector<std::vector<float>> frames;
};
inline constexpr size_t kMaxCaptureFrames = 3600;  // Two minutes at 30 a second.
Result<CaptureRequest> ParseCaptureRequest(std::string_view body);

// A solved weight as captures answer it: 0.8123 rather than 0.81234568357467651 (four places show
// every visible weight; below them, 0).
double RoundedWeight(float w);
// A capture's answer (the route's and `facespace capture`'s): {"scheme", "fps", "frames",
// "shapes", "keys": [{"time", "weights": {NAME: w, ...}}], "head": [[x, y, z, w], ...]}, per frame
// its weights (one per rig shape, the non-zero ones by name) and the head's turn.
std::string CaptureAnswerJson(const Rig& rig, std::span<const std::vector<float>> weights,
                              std::span<const std::array<float, 4>> head, float fps, size_t shapes);

// Body of POST /v1/rigs/{id}/batch, and the batch.json that `facespace batch` keeps in its
// output folder:
// {"variants": [{"id": "a", "weights": {...}|[...]}, ...]            an explicit list, or
//  "sample": {"method": "uniform"|"gaussian"|"grid"|"convex", "count": N, "seed": S,
//             "shapes": [NAME, ...], "fixed": {NAME: w}, "center": {NAME: w}, "spread": s,
//             "points": [{...}, {...}], "active": K, "symmetric": bool, "sum_at_most_one": bool},
//  "format": "glb"|"obj"|"json"|"f32"|"png"|"jpeg"|"exr"|"tiff"|"webp",
//  "mode", "normals", "skinning" as on the mesh route; the render route's settings for images}
// What a labelled sample holds beside its render (api/batch/dataset.h writes them): a closed set,
// named in one table (the request's and the CLI's spellings).
enum class Label { kDepth, kNormals, kSegmentation, kLandmarks };
inline constexpr EnumName<Label> kLabels[] = {{Label::kDepth, "depth"},
                                              {Label::kNormals, "normals"},
                                              {Label::kSegmentation, "segmentation"},
                                              {Label::kLandmarks, "landmarks"}};
inline const char* Name(Label l) { return EnumEntry(kLabels, l).name; }

// How a batch's files are laid out: one file each in the folder, or WebDataset tar shards.
enum class Archive { kFolder, kTar };
inline constexpr EnumName<Archive> kArchives[] = {{Archive::kFolder, "folder"},
                                                  {Archive::kTar, "tar"}};
inline const char* Name(Archive a) { return EnumEntry(kArchives, a).name; }

// A closed interval a randomised setting is drawn from, uniformly.
struct Interval {
  float lo = 0.0f, hi = 0.0f;
};

// "randomize": what varies from sample to sample beside the weights, drawn per sample from its own
// seeded stream (the same seed and index give the same draw, whatever the threads or shards):
// {"seed": S, "camera": {"yaw": [lo, hi], "pitch": [...], "zoom": [...]}, "light": {"yaw", "pitch",
//  "exposure": [...]}, "background": "random" | ["#rrggbb", ...] | {"images": DIR}, "expressions":
//  {NAME: [lo, hi]}, "gaze": {"yaw": [...], "pitch": [...]}}
struct Randomization {
  uint64_t seed = 1;
  bool seeded = false;  // "seed" given; else the sample's seed.
  std::optional<Interval> yaw, pitch, zoom, light_yaw, light_pitch, exposure, gaze_yaw, gaze_pitch;
  bool random_background = false;
  std::vector<std::array<float, 4>> backgrounds;  // One of these, uniformly (sRGB).
  std::string background_images;  // A folder of pictures, one behind each sample (the CLI's alone).
  std::vector<std::pair<std::string, Interval>> expressions;
  bool any() const {
    return yaw || pitch || zoom || light_yaw || light_pitch || exposure || gaze_yaw || gaze_pitch ||
           random_background || !backgrounds.empty() || !background_images.empty() ||
           !expressions.empty();
  }
};

// The dataset members of a batch: "labels": ["depth", "normals", "segmentation", "landmarks"] (or
// "depth,normals"), "archive": "folder" | "tar", "shard_samples": N (tar: samples a shard),
// "randomize".
struct DatasetRequest {
  std::vector<Label> labels;  // Each once, in the table's order.
  Archive archive = Archive::kFolder;
  size_t shard_samples = 1000;
  Randomization randomize;
  bool has(Label l) const { return std::find(labels.begin(), labels.end(), l) != labels.end(); }
  // A sample is more than one file: the render with its labels' files and KEY.json.
  bool labelled() const { return !labels.empty() || randomize.any(); }
};

struct BatchRequest {
  struct Variant {
    std::string id;  // "" = "v" + the index, zero-padded.
    std::vector<WeightEntry> weights;
  };
  std::vector<Variant> variants;
  bool sampled = false;
  // "sample": its plain members (method, seed, count, spread, active, symmetric,
  // sum_at_most_one) here; the members that name shapes below, resolved into `sample` by
  // ResolveSampleSpec once the rig is known.
  SampleSpec sample;
  std::vector<std::string> shapes;
  std::vector<WeightEntry> fixed, center;
  std::vector<std::vector<WeightEntry>> points;
  std::string format = "glb";  // File format of every variant.
  bool image = false;          // format is an image format (rendered).
  formats::MeshFormat mesh_format = formats::MeshFormat::kGlb;
  picture::ImageFormat image_format = picture::ImageFormat::kPng;
  RenderRequest render;       // Render settings and the mesh options (mode, normals, skinning).
  bool format_given = false;  // "format" was in the body (labels default to png).
  DatasetRequest dataset;
};
Result<BatchRequest> ParseBatchRequest(std::string_view body);

// A dataset member of a batch body ("labels", "archive", "shard_samples", "randomize") into `r`;
// false when `key` is not one. Errors name their field.
bool DatasetMember(const std::string& key, const nlohmann::json& value, DatasetRequest& r,
                   Status& errors);

// The sampling part resolved against a rig (names to indices). Errors name the field.
Result<SampleSpec> ResolveSampleSpec(const Rig& rig, const BatchRequest& request);

// True for a variant id usable as a file name: [A-Za-z0-9][A-Za-z0-9_.-]{0,63}, no "..".
bool IsValidVariantId(const std::string& id);

bool ParseBlendMode(std::string_view s, BlendMode* mode);
bool ParseNormalMode(std::string_view s, NormalMode* mode);

}  // namespace facespace::evaluator
