// The one path from a request to encoded bytes, for every surface: the HTTP routes, every CLI
// command, batch variants and sequence frames call it, and none of them evaluates or encodes on
// its own.
//
//   request ──ResolvePoint──> ResolvedPoint ──Evaluator::Run(point, OutputSpec, Workspace&)──>
//   Encoded
//             controls, pose,  (weights, pose,      the rig at its level of detail, evaluated,
//             weights, checks   warnings, sum)      then exported or rendered and encoded
//
// The two steps are separate so the service can answer from its response cache between them: the
// cache key is CacheKey(rig, points, spec), the one function that says what an output depends on.
// The fast paths (f32 bodies written over the rest's bytes, glb written over a kept template)
// and what is kept per rig (levels of detail, the box its shapes act in) live in the Evaluator.
// No HTTP here: errors are Status values whose `reason` names the problem ("invalid-weights");
// api/http/src/http maps them to status codes in one place.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <span>
#include <stop_token>
#include <string>
#include <vector>

#include "facespace/engine/blend.h"
#include "facespace/engine/fit.h"
#include "facespace/engine/sequence.h"
#include "facespace/engine/skeleton.h"
#include "facespace/engine/status.h"
#include "facespace/engine/weights.h"
#include "facespace/evaluator/request.h"
#include "facespace/evaluator/store.h"
#include "facespace/formats/io.h"
#include "facespace/physics/physics.h"
#include "facespace/picture/picture.h"

namespace facespace::evaluator {

// Status::reason of the evaluator's errors.
inline constexpr char kInvalidControls[] = "invalid-controls";
inline constexpr char kInvalidWeights[] = "invalid-weights";
inline constexpr char kLeavesAuthoredSpace[] = "weights-leave-authored-space";  // strict requests
inline constexpr char kInvalidSequence[] = "invalid-sequence";
inline constexpr char kResponseTooLarge[] = "response-too-large";
inline constexpr char kInvalidTarget[] = "invalid-target";

// A point of face space resolved against one rig: what a request's weights, controls and pose
// come to, and what the checks say about it.
struct ResolvedPoint {
  std::vector<float> weights;  // One per shape.
  Pose pose;
  bool posed = false;   // False: the rest pose.
  WeightReport report;  // Sum, warnings (the weights', then the pose's and controls'), Mahalanobis.
  size_t weight_warnings =
      0;  // How many warnings CheckPoint found (ResolvePoint keeps them first).
  const Pose* pose_or_null() const { return posed ? &pose : nullptr; }
};

// ---- step 1: the point ----------------------------------------------------------------------

// Controls, then the pose and the weights (core: ApplyControls, ResolvePoseAndWeights), then the
// checks (CheckWeights). Fills `point` as far as it got, also when a strict request is refused, so
// its warnings can still be reported. Errors: reason invalid-controls or invalid-weights (fields
// name the entries); with `request.strict` and any warning, reason weights-leave-authored-space.
Status ResolvePoint(const Rig& rig, const MeshRequest& request, ResolvedPoint& point);

// The checks alone, for a point whose weights and pose are set already (batch variants,
// sequence frames): point.report from CheckWeights.
void CheckPoint(const Rig& rig, BlendMode mode, ResolvedPoint& point);

// A sheet's cells as points, every one first, so nothing is rendered when one of them is wrong.
struct SheetPoints {
  std::vector<ResolvedPoint> cells;
  std::vector<Warning>
      warnings;  // Every cell's, each message prefixed "cell N: "; the pose's once.
  double max_sum = 0.0;
};
// Errors as ResolvePoint's, the message prefixed "cell N: "; strict refuses on any cell's warning.
Status ResolveSheet(const Rig& rig, const SheetRequest& request, SheetPoints& points);

// ---- step 2: what to make of the point --------------------------------------------------------

struct OutputSpec {
  enum class Kind {
    kMesh,       // The mesh in mesh_format.
    kImage,      // A render in image_format.
    kSheet,      // A labelled grid of renders, one cell per point, `columns` wide.
    kFrameJson,  // A sequence frame: the JSON export's primitives array (world space).
    kFrameF32,   // A stream frame: a uint32 byte count, then the world-space positions.
    kPixels,     // A render left in the workspace's image (8-bit sRGB), no bytes: a video's frame.
  };
  Kind kind = Kind::kMesh;
  BlendOptions blend;  // Mode, normals, skinning (the point's pose is the point's).
  int lod = 0;         // Level of detail of the rig (core/lod.h).
  // Meshes.
  formats::MeshFormat mesh_format = formats::MeshFormat::kJson;
  bool mesh_space = false;    // JSON, OBJ and f32 before the node transforms.
  bool keep_targets = false;  // glb: the rig with the point's weights as defaults.
  // glb: the bytes are left in the workspace as two pieces of one file (Encoded::pieces), for
  // callers that write them as they are (batch files); the workspace keeps its own writer, so it
  // must serve one rig (a batch worker's).
  bool pieces = false;
  // Images and sheets.
  picture::RenderOptions render;
  picture::ImageFormat image_format = picture::ImageFormat::kPng;
  int quality = 90;
  int columns = 4;
  std::vector<std::string> labels;  // One per cell.

  static OutputSpec Mesh(const MeshRequest& request, formats::MeshFormat format);
  static OutputSpec Image(const RenderRequest& request, picture::ImageFormat format);
  static OutputSpec Sheet(const SheetRequest& request, picture::ImageFormat format);
  static OutputSpec Frame(const BlendOptions& blend, bool f32);
  static OutputSpec Pixels(const RenderRequest& request);
  const char* content_type() const;
};

// What a call made: the bytes, or (OutputSpec::pieces, glb) the two pieces they are in instead.
struct Encoded {
  std::string bytes;
  // With OutputSpec::pieces, a glb's head and binary chunk in the workspace, valid until its next
  // call; `bytes` is then empty.
  std::string_view head, bin;
  // What to write, one after the other: {head, bin}, or {bytes, ""}.
  std::array<std::string_view, 2> pieces() const {
    if (head.empty() && bin.empty()) return {bytes, {}};
    return {head, bin};
  }
};

// What a caller keeps between calls so that steady-state evaluation does not allocate: one per
// thread (the service leases them from a pool it owns).
struct Workspace {
  BlendContext context;
  BlendedRig blended;
  formats::F32Writer::Scratch f32;
  // A response body handed back once sent, for the next f32 body to be written over.
  std::string body;
  formats::GlbVariantWriter glb;  // OutputSpec::pieces' writer.
  // The request's stop token (client gone, deadline, SIGTERM): the evaluator's loops over sheet
  // cells, sequence frames and video frames check it between steps and end Cancelled.
  std::stop_token stop;
  // Where the CPU that helper threads spend for the request (the renderer's rasteriser, encoders'
  // helpers) is charged: the server's meter of the request (facespace/net/front.h); null: nowhere.
  HelperCpu* helper_cpu = nullptr;
  picture::Image image;
  std::vector<picture::Image> cells;
  // What the last call's steps took, in milliseconds (the service's Server-Timing header); the
  // caller zeroes it before a call, the steps add to it.
  struct Timing {
    double blend = 0, draw = 0, encode = 0;
  } timing;
};

// The text a response cache keys `spec` at `points` of `rig` by: the rig's id and version and,
// bit for bit, everything the bytes depend on. Equal keys, equal bytes.
std::string CacheKey(const StoredRig& rig, std::span<const ResolvedPoint> points,
                     const OutputSpec& spec);

// What is derived from a stored rig per level of detail: the simplified rig (the stored rig itself
// at 0) and the box its shapes act in.
struct DerivedRig {
  std::shared_ptr<const Rig> rig;
  bool has_focus = false;
  bool focus_small = false;  // FrameShapesByDefault: renders frame the focus unless told "all".
  std::array<float, 3> focus_min{}, focus_max{};
  int focus_joint = -1;  // ShapeFocusJoint when focus_small: a skinned rig's renders follow it.
};

class Evaluator {
 public:
  // An evaluator of meshes and frames: images, sheets and pixels are refused (FailedPrecondition).
  Evaluator();
  // One that also draws: `renderer` draws and encodes images and sheets; it must outlive the
  // evaluator.
  explicit Evaluator(const picture::Renderer& renderer);
  ~Evaluator();
  Evaluator(const Evaluator&) = delete;
  Evaluator& operator=(const Evaluator&) = delete;

  // `spec` at `points` of `rig` (one point, or a sheet's cells). The points were resolved against
  // `rig` (ResolvePoint, CheckPoint): a failure to evaluate them is ours (Internal); a failure to
  // draw or encode says so. Thread-safe: each thread brings its own workspace.
  Result<Encoded> Run(const std::shared_ptr<const StoredRig>& rig,
                      std::span<const ResolvedPoint> points, const OutputSpec& spec,
                      Workspace& ws) const;
  Result<Encoded> Run(const std::shared_ptr<const StoredRig>& rig, const ResolvedPoint& point,
                      const OutputSpec& spec, Workspace& ws) const {
    return Run(rig, std::span<const ResolvedPoint>(&point, 1), spec, ws);
  }

  // What draws its pictures; null for an evaluator of meshes.
  const picture::Renderer* renderer() const { return renderer_; }

  // The rig at a level of detail and the box its shapes act in (kept); null when it cannot be made.
  std::shared_ptr<const DerivedRig> Derived(const std::shared_ptr<const StoredRig>& rig,
                                            int lod) const;

  // What pictures of the rig at a level will need, made now rather than at the first (the occlusion
  // baked once per rig and level: a quarter second for a 50k-vertex rig); nothing for an evaluator
  // of meshes. The service's warm-up calls it for the rigs it starts with.
  void WarmPictures(const std::shared_ptr<const StoredRig>& rig, int lod) const;

  // A VRM's meta thumbnail: the face (the shapes' framing) at the evaluated point, kThumbnailSize
  // square.
  static constexpr int kThumbnailSize = 512;

 private:
  Status Thumbnail(const std::shared_ptr<const StoredRig>& stored, int lod, const Rig& rig,
                   Workspace& ws, std::vector<unsigned char>& png) const;
  struct Kept;
  const picture::Renderer* renderer_ = nullptr;
  std::unique_ptr<Kept> kept_;
};

// A rig that is not in a store (a CLI run, a test), as the evaluator takes one: its id is the
// rig's name, its version what the caller says identifies its content (batch.json records it).
std::shared_ptr<const StoredRig> Unstored(Rig rig, std::string version = "");

// The whole rig as a glb: every shape kept as a morph target, the mesh at the shapes' defaults
// (what `facespace convert` and `derive` write, and a derive job stores).
Result<std::string> RigGlb(const Evaluator& evaluator, const std::shared_ptr<const StoredRig>& rig);

// ---- one call: step 1 then step 2 -------------------------------------------------------------

// The bytes and what a client is told beside them.
struct Output {
  std::string bytes;
  std::string content_type;
  std::vector<Warning> warnings;
  double weight_sum = 0.0;
};

Result<Output> ProduceMesh(const Evaluator& evaluator, const std::shared_ptr<const StoredRig>& rig,
                           const MeshRequest& request, formats::MeshFormat format, Workspace& ws);
Result<Output> ProduceImage(const Evaluator& evaluator, const std::shared_ptr<const StoredRig>& rig,
                            const RenderRequest& request, picture::ImageFormat format,
                            Workspace& ws);
Result<Output> ProduceSheet(const Evaluator& evaluator, const std::shared_ptr<const StoredRig>& rig,
                            const SheetRequest& request, picture::ImageFormat format,
                            Workspace& ws);

// ---- weights only -----------------------------------------------------------------------------

// {"sum", "weights" (non-zero, by name), "mahalanobis"?, "warnings"}: the check route's body.
std::string CheckJson(const Rig& rig, const ResolvedPoint& point);

// {"name": w, ...} of the non-zero weights, floats as their shortest text.
std::string WeightsMapJson(const Rig& rig, std::span<const float> weights);

// ---- keyframe sequences -----------------------------------------------------------------------

// The rig's physics over a sequence (physics/physics.h): simulated 60 steps a second from the
// sequence's first key, each step's followed bodies on the sequence's pose at its time, for at
// most kMaxSeconds. Frames may come at any times in any order (an earlier time starts over); the
// same times give the same bytes. The steps in all are capped at one run to kMaxSeconds: times that
// go back and forth past it get their frames unsimulated, warned. Inert for a rig without physics,
// a sequence that does not pose the skeleton (no clip, no layers), or `physics: false`.
class SequencePhysics {
 public:
  static constexpr float kStepsPerSecond = 60.0f;
  static constexpr float kMaxSeconds = 600.0f;
  SequencePhysics(const Rig& rig, const Sequence& sequence);
  ~SequencePhysics();
  SequencePhysics(const SequencePhysics&) = delete;
  SequencePhysics& operator=(const SequencePhysics&) = delete;
  bool active() const { return active_; }
  // The simulated bones into `pose`, the sequence's pose at `time`. The first frame is the pose as
  // it is (bodies start where their bones are). Past kMaxSeconds: the last simulated step, warned.
  void Apply(float time, Pose& pose, std::vector<Warning>& warnings);

 private:
  const Rig& rig_;
  const Sequence& sequence_;
  bool active_ = false;
  std::unique_ptr<physics::Simulation> sim_;
  long long step_ = 0;
  long long budget_ = static_cast<long long>(kMaxSeconds * kStepsPerSecond);
  Pose scratch_;
  std::vector<float> weights_;
  bool TickPose(float time);  // The sequence's pose at a step's time into scratch_.
};

// The sequence's pose at `time` (its clip or layers over the rig's base motion, the bone morphs of
// `weights`, the constraints solved); `weights` (sampled from the keys) take what the clips
// animate. False when it poses nothing (no clip, no layers, no bone morph) or the pose cannot be
// built.
bool SequencePose(const Rig& rig, const Sequence& sequence, float time, Pose& pose,
                  std::vector<float>& weights);

// The sequence's frame at `time` as a point: sampled weights, the clip's pose (else the rest
// pose) with the bones `physics` simulates (when given), checked. Its warnings: the transition
// leaving [0, 1] (transition_extrapolation), then the weights' own, each message prefixed with
// "t=TIME: ".
void SequencePoint(const Rig& rig, const Sequence& sequence, float time, BlendMode mode,
                   ResolvedPoint& point, SequencePhysics* physics = nullptr);

// {"frames": [{"time", "weights", "primitives"}], "warnings": [...]}: the sample route's body and
// `facespace sequence --format json`; with `weights_only` ("format": "weights"), each frame's time,
// weights, sum and (when posed) "pose": the nodes moved from rest, {NAME: {translation, rotation,
// scale}}, and no mesh. `warnings` receives the frames' warnings too.
// A body that would pass `max_bytes` (judged from its first frame, then checked as it grows) is
// refused before the work: 422 response-too-large on /times, naming the limit.
Result<std::string> SampleSequenceJson(const Evaluator& evaluator,
                                       const std::shared_ptr<const StoredRig>& rig,
                                       const Sequence& sequence, std::span<const float> times,
                                       const BlendOptions& options, std::vector<Warning>& warnings,
                                       Workspace& ws, size_t max_bytes = static_cast<size_t>(-1),
                                       bool weights_only = false);

// One frame of a stream: ndjson {"frame", "time", "weights", "warnings"} and a newline, or f32:
// a uint32 byte count then the world-space positions.
Result<std::string> StreamFrame(const Evaluator& evaluator,
                                const std::shared_ptr<const StoredRig>& rig,
                                const Sequence& sequence, size_t frame, float fps, bool f32,
                                const BlendOptions& options, Workspace& ws,
                                SequencePhysics* physics = nullptr);

// Frames from the first key to the last at `fps` (both ends included).
size_t FrameCount(const Sequence& sequence, float fps);

// JSON of a sequence's keys, weights by name (zeros left out), as a request takes them.
std::string SequenceKeysJson(const Rig& rig, const Sequence& sequence);

// {"keys", "transition", "kept", "removed", "max_error", "tolerance"}: a reduced sequence.
std::string ReducedSequenceJson(const Rig& rig, const Sequence& original,
                                const ReduceResult& reduced, float tolerance);

// ---- fitting ----------------------------------------------------------------------------------

// {"weights": {name: w, every shape}, "residual": {"rms", "max"}, "alignment"?, "warnings": [...]}
std::string FitResultJson(const Rig& rig, const FitResult& fit, bool aligned);

// FitWeights, then its JSON. Errors: reason invalid-target.
Result<Output> ProduceFit(const Rig& rig, const FitRequest& request);

}  // namespace facespace::evaluator
