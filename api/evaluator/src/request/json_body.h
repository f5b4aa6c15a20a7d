// The JSON body readers shared by the request schemas (api/http/src/request/): limits, members, the
// checked parse, and the readers of the members several requests share (weights, pose, render).
#pragma once

#include <array>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/evaluator/members.h"
#include "facespace/evaluator/request.h"

namespace facespace::evaluator::body {

using nlohmann::json;

inline constexpr char kMalformed[] = "malformed JSON";
// What one body may hold, sized to its route: a limit on the values parsed (every number, string,
// array and object counts one) bounds the memory and time of the parse before any work.
struct BodyLimits {
  size_t values;
  size_t depth = 64;
};
inline constexpr BodyLimits kPointBody{100000};  // mesh, check, render: weights, controls, a pose.
inline constexpr BodyLimits kSheetBody{400000};  // Up to --max-sheet-cells points.
inline constexpr BodyLimits kSequenceBody{500000};  // Keys and times.
inline constexpr BodyLimits kFitBody{
    3100000};  // A target mesh: three numbers a vertex, a million vertices.
inline constexpr BodyLimits kBatchBody{500000};  // Explicit variants.

Status FieldStatus(const std::string& pointer, const std::string& message);

Result<std::vector<WeightEntry>> WeightsFromJson(const json& j, const std::string& pointer);

bool FloatArray(const json& v, float* out, size_t n);

// A clip reference: a name or an index.
bool ClipRef(const json& v, ClipRequest& c);

void PoseFromJson(const json& v, PoseRequest& pose, Status& errors);

// {"target": [x, y, z]} or {"yaw": deg, "pitch": deg}; nullopt (errors added) when malformed.
std::optional<Gaze> GazeFromJson(const json& v, const std::string& ptr, Status& errors);

// A sequence's "gaze": one gaze held (at time 0) or {"keys": [{"time", "target" | "yaw", "pitch"},
// ...]}.
void GazeTrackFromJson(const json& v, const std::string& ptr, std::vector<GazeKey>& track,
                       Status& errors);
// "blink": {"per_minute", "seed"}.
void BlinkFromJson(const json& v, const std::string& ptr, float& per_minute, uint64_t& seed,
                   Status& errors);

void BlendFromJson(const json& v, PoseRequest& pose, Status& errors);
void LayersFromJson(const json& v, PoseRequest& pose, Status& errors);

// Handles a member shared by the mesh, check, render and sheet bodies. Returns false when
// the key is not one of them.
bool MeshMember(const std::string& key, const json& v, MeshRequest& r, bool mesh_format,
                Status& errors);

// "time", "frame" or "loop" without "animation" (or "motion") is an error; "animation" with "blend"
// too.
void FinishPose(PoseRequest& pose, Status& errors);

Status Finish(Status errors);

bool ParseBackground(const json& v, std::array<float, 4>& out);

// Range-checked number members of the camera and image.
bool Number(const json& v, double lo, double hi, double* out);

// The camera's framing: all, shapes, auto or joint:NAME. False for anything else.
bool ParseFraming(const std::string& value, picture::Camera& cam);

void CameraFromJson(const json& c, picture::Camera& cam, Status& errors);

// A render member; false when the key is not one.
bool RenderMember(const std::string& key, const json& v, RenderRequest& r, Status& errors);

// A JSON object within `limits`, named by JSON Pointers when it is not one.
Result<json> ParseObject(std::string_view body, BodyLimits limits);

// `body` parsed within `limits`, and member(key, value) called for each of its members in turn (it
// adds what it refuses to the reader's errors): the parse's own error (malformed JSON, over the
// limits, a member given twice), else OK. Every body reader but fit's (which reads its
// document whole first) walks its members through it.
template <typename Fn>
Status ReadMembers(std::string_view body, BodyLimits limits, Fn member) {
  auto j = ParseObject(body, limits);
  if (!j.ok()) return j.status();
  for (auto it = j->begin(); it != j->end(); ++it) member(it.key(), it.value());
  return Status::Ok();
}

}  // namespace facespace::evaluator::body
