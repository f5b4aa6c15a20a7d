// The one path from a request to encoded bytes, for every surface: the HTTP routes, the CLI
// commands and batch jobs call it, and none of them evaluates or encodes on its own.
//
//   request ──ResolvePoint──> Point (weights, pose, warnings, sum) ──Encode*──> bytes
//             controls, pose,                                        evaluate, then
//             weights, checks                                        export or render + encode
//
// The two steps are separate so the service can answer from its response cache between them
// (the cache key is the resolved point); Produce* run both for callers without a cache.
// No HTTP here: errors are Status values whose `reason` names the problem ("invalid-weights");
// api/src/http maps them to status codes in one place.
#pragma once

#include <array>
#include <span>
#include <memory>
#include <string>
#include <vector>

#include "facespace/api/request.h"
#include "facespace/core/blend.h"
#include "facespace/core/fit.h"
#include "facespace/formats/io.h"
#include "facespace/core/sequence.h"
#include "facespace/core/skeleton.h"
#include "facespace/core/status.h"
#include "facespace/core/variants.h"
#include "facespace/core/weights.h"
#include "facespace/render/render.h"

namespace facespace::api {

// Status::reason of the pipeline's errors.
inline constexpr char kInvalidControls[] = "invalid-controls";
inline constexpr char kInvalidWeights[] = "invalid-weights";
inline constexpr char kLeavesAuthoredSpace[] = "weights-leave-authored-space";  // strict requests
inline constexpr char kInvalidSequence[] = "invalid-sequence";
inline constexpr char kResponseTooLarge[] = "response-too-large";
inline constexpr char kInvalidTarget[] = "invalid-target";

// A point of face space resolved against one rig: what a request's weights, controls and pose
// come to, and what the checks say about it.
struct Point {
  std::vector<float> weights;  // One per shape.
  Pose pose;
  bool posed = false;          // False: the rest pose.
  WeightReport report;         // Sum, warnings (the weights', then the pose's and controls'), Mahalanobis.
  size_t weight_warnings = 0;  // How many warnings CheckPoint found (ResolvePoint keeps them first).
  const Pose* pose_or_null() const { return posed ? &pose : nullptr; }
};

// What a caller keeps between calls so that steady-state evaluation does not allocate: one per
// thread (the service leases them from a pool it owns).
struct Workspace {
  BlendContext context;
  BlendedRig blended;
  F32Blender::Scratch f32;
  std::string body;  // A response body handed back once sent, for the next f32 body to be written over.
  render::Image image;
  std::vector<render::Image> cells;
  // What the last encode's steps took, in milliseconds (the service's Server-Timing header);
  // the caller zeroes it before a call, the steps add to it.
  struct Timing {
    double blend = 0, draw = 0, encode = 0;
  } timing;
};

// The result of one call: the bytes and what a client is told beside them.
struct Output {
  std::string bytes;
  std::string content_type;
  std::vector<Warning> warnings;
  double weight_sum = 0.0;
};

// ---- step 1: the point --------------------------------------------------------------------

// Controls, then the pose and the weights (core: ApplyControls, ResolvePoseAndWeights), then the
// checks (CheckWeights). Fills `point` as far as it got, also when a strict request is refused, so
// its warnings can still be reported. Errors: reason invalid-controls or invalid-weights (fields
// name the entries); with `request.strict` and any warning, reason weights-leave-authored-space.
Status ResolvePoint(const Rig& rig, const MeshRequest& request, Point& point);

// The checks alone, for a point whose weights and pose are set already (batch variants,
// sequence frames): point.report from CheckWeights.
void CheckPoint(const Rig& rig, BlendMode mode, Point& point);

// ---- step 2: evaluate and encode ------------------------------------------------------------

// The mesh at `point` in `format` (glb keeps the rig's targets when request.keep_targets). With
// `glb`, a writer that served this same rig before, a blended glb patches its template (the same
// bytes, a third of the time). With `f32`, a blender made for this same rig, an f32 body is
// blended where it is written when the blender serves the point (the rest's bytes, and the
// primitives the point moves blended and placed), written over `ws.body` when that holds a used
// body; else evaluated and exported as the other formats are.
Result<std::string> EncodeMesh(const Rig& rig, const Point& point, const MeshRequest& request, MeshFormat format,
                               Workspace& ws, GlbVariantWriter* glb = nullptr, const F32Blender* f32 = nullptr);

// The blended glb at `point` as the writer's two pieces (valid until its next call), for callers
// that write them as they are (batch files) instead of joining them.
Result<GlbVariantWriter::Pieces> EncodeGlb(const Rig& rig, const Point& point, const MeshRequest& request, Workspace& ws,
                                           GlbVariantWriter& glb);

// A render of the rig at `point`. Framing on the shapes uses request.render.camera's focus box
// when the caller set one (the service keeps it per rig), else the renderer computes it.
Result<std::string> EncodeImage(const Rig& rig, const Point& point, const RenderRequest& request,
                                render::ImageFormat format, const render::Renderer& renderer, Workspace& ws);

// ---- contact sheets -------------------------------------------------------------------------

struct SheetPoints {
  std::vector<Point> cells;
  std::vector<Warning> warnings;  // Every cell's, each message prefixed "cell N: "; the pose's once.
  double max_sum = 0.0;
};
// Every cell's point first, so nothing is rendered when one of them is wrong. Errors as
// ResolvePoint's, the message prefixed "cell N: "; strict refuses on any cell's warning.
Status ResolveSheet(const Rig& rig, const SheetRequest& request, SheetPoints& points);
Result<std::string> EncodeSheet(const Rig& rig, const SheetPoints& points, const SheetRequest& request,
                                render::ImageFormat format, const render::Renderer& renderer, Workspace& ws);

// A labelled grid of renders of `cells` (each with its own pose), `columns` wide.
Result<std::string> EncodeGrid(const Rig& rig, std::span<const Point> cells, std::span<const std::string> labels,
                               int columns, const render::RenderOptions& options, const BlendOptions& blend,
                               render::ImageFormat format, int quality, const render::Renderer& renderer, Workspace& ws);

// ---- one call: step 1 then step 2 -----------------------------------------------------------

Result<Output> ProduceMesh(const Rig& rig, const MeshRequest& request, MeshFormat format, Workspace& ws);
Result<Output> ProduceImage(const Rig& rig, const RenderRequest& request, render::ImageFormat format,
                            const render::Renderer& renderer, Workspace& ws);
Result<Output> ProduceSheet(const Rig& rig, const SheetRequest& request, render::ImageFormat format,
                            const render::Renderer& renderer, Workspace& ws);

// ---- weights only ---------------------------------------------------------------------------

// {"sum", "weights" (non-zero, by name), "mahalanobis"?, "warnings"}: the check route's body.
std::string CheckJson(const Rig& rig, const Point& point);

// {"name": w, ...} of the non-zero weights, floats as their shortest text.
std::string WeightsMapJson(const Rig& rig, std::span<const float> weights);

// ---- keyframe sequences ---------------------------------------------------------------------

// The sequence's frame at `time` as a point: sampled weights, the rest pose, checked. Its warnings:
// the transition leaving [0, 1] (transition_extrapolation), then the weights' own, each message
// prefixed with "t=TIME: ".
void SequencePoint(const Rig& rig, const Sequence& sequence, float time, BlendMode mode, Point& point);

// {"frames": [{"time", "weights", "primitives"}], "warnings": [...]}: the sample route's body and
// `facespace sequence --format json`. `warnings` receives the frames' warnings too.
// A body that would pass `max_bytes` (judged from its first frame, then checked as it grows) is
// refused before the work: 422 response-too-large on /times, naming the limit.
Result<std::string> SampleSequenceJson(const Rig& rig, const Sequence& sequence, std::span<const float> times,
                                       const BlendOptions& options, std::vector<Warning>& warnings, Workspace& ws,
                                       size_t max_bytes = static_cast<size_t>(-1));

// One frame of a stream: ndjson {"frame", "time", "weights", "warnings"} and a newline, or f32:
// a uint32 byte count then the world-space positions.
Result<std::string> StreamFrame(const Rig& rig, const Sequence& sequence, size_t frame, float fps, bool f32,
                                const BlendOptions& options, Workspace& ws);

// Frames from the first key to the last at `fps` (both ends included).
size_t FrameCount(const Sequence& sequence, float fps);

// JSON of a sequence's keys, weights by name (zeros left out), as a request takes them.
std::string SequenceKeysJson(const Rig& rig, const Sequence& sequence);

// {"keys", "transition", "kept", "removed", "max_error", "tolerance"}: a reduced sequence.
std::string ReducedSequenceJson(const Rig& rig, const Sequence& original, const ReduceResult& reduced, float tolerance);

// ---- fitting --------------------------------------------------------------------------------

// {"weights": {name: w, every shape}, "residual": {"rms", "max"}, "alignment"?, "warnings": [...]}
std::string FitResultJson(const Rig& rig, const FitResult& fit, bool aligned);

// FitWeights, then its JSON. Errors: reason invalid-target.
Result<Output> ProduceFit(const Rig& rig, const FitRequest& request);

// ---- batch variants -------------------------------------------------------------------------

// A batch request (ParseBatchRequest's schema) resolved against one rig: every variant's weights
// are a pure function of the plan and the variant's index.
struct BatchPlan {
  // Held, not pointed at: a queued plan outlives the store's entry when the rig is uploaded again
  // (even with the same bytes, so the same version) or deleted while the job waits.
  std::shared_ptr<const Rig> rig;
  BatchRequest request;
  SampleSpec sample;                        // When request.sampled.
  std::vector<std::vector<float>> weights;  // Explicit variants, resolved.
  size_t total = 0;
  std::string spec_json;                    // batch.json: {"request": ..., "rig": ..., "rig_version": ...}
  Pose pose;                                // The request's pose, shared by every variant.
  bool posed = false;
  std::vector<Warning> pose_warnings;
};

// Parses and resolves a batch body against a rig (the pose must resolve too). `rig_version`
// identifies the rig's content, so a rerun against another rig is refused. The plan keeps `rig`
// alive (a caller whose rig outlives the plan may pass a non-owning pointer: UnownedRig).
Result<BatchPlan> MakeBatchPlan(std::shared_ptr<const Rig> rig, const std::string& rig_version, std::string_view request_json);

// A pointer to `rig` that owns nothing, for a plan that cannot outlive it (a CLI run, a test).
inline std::shared_ptr<const Rig> UnownedRig(const Rig& rig) { return std::shared_ptr<const Rig>(std::shared_ptr<const Rig>(), &rig); }

std::string VariantId(const BatchPlan& plan, size_t index);    // The given id, else "v" + 6 digits.
std::string VariantFile(const BatchPlan& plan, size_t index);  // id + "." + the format's extension.

// Variant `index` as a point: its weights and the plan's pose, checked (the pose's warnings last).
void VariantPoint(const BatchPlan& plan, size_t index, Point& point);

// The contact sheet of the variants `indices`, labelled with their ids: 256 x 256 cells, PNG.
Result<std::string> VariantSheet(const BatchPlan& plan, std::span<const size_t> indices, const render::Renderer& renderer,
                                 Workspace& ws);

// What a batch worker keeps between variants of one plan: the evaluation scratch, the glb writer
// (core's GlbVariantWriter: the unchanged parts of the file are made once) and the other formats' bytes.
struct VariantEncoder {
  Workspace ws;
  GlbVariantWriter glb;
  std::string bytes;
};

// The variant at `point` in the plan's format (a mesh, or a render), as two pieces of one file to
// be written one after the other; they stay valid until the encoder's next call.
Result<std::array<std::string_view, 2>> EncodeVariant(const BatchPlan& plan, const Point& point,
                                                      const render::Renderer& renderer, VariantEncoder& encoder);

}  // namespace facespace::api
