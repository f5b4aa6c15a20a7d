// The members of every JSON request body, declared once: name, type, range, default, documentation
// and example. The readers (src/request/) refuse a member no table names and check a number against
// its declared range; the OpenAPI document (api/http/src/openapi) writes its request schemas from
// these tables, and the TypeScript types the page and clients use are generated from that document.
#pragma once

#include <limits>
#include <nlohmann/json_fwd.hpp>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/engine/status.h"

namespace facespace::evaluator {

// What a member holds.
enum class Kind : unsigned char {
  kNumber,   // A finite number in [lo, hi].
  kInteger,  // An integer in [lo, hi].
  kBoolean,
  kString,  // `schema`, when given, is a pattern.
  kChoice,  // One of `choices` ("a|b|c").
  kSchema,  // `schema`: "#Name" (a component of the document) or JSON Schema text.
};

inline constexpr double kUnbounded = std::numeric_limits<double>::infinity();

struct Member {
  std::string_view name;
  Kind kind;
  std::string_view doc;
  double lo = -kUnbounded, hi = kUnbounded;
  std::string_view choices = {};
  std::string_view schema = {};
  std::string_view fallback =
      {};  // The default, as JSON text; empty: none (or it depends, as doc says).
  std::string_view example = {};  // JSON text; empty: none.
  bool required = false;

  // The table's words: Integer("width", "Pixels", 1, 4096).Default("512").Example("256").
  constexpr Member Default(std::string_view json_text) const {
    return With(&Member::fallback, json_text);
  }
  constexpr Member Example(std::string_view json_text) const {
    return With(&Member::example, json_text);
  }
  constexpr Member Required() const {
    Member m = *this;
    m.required = true;
    return m;
  }

 private:
  constexpr Member With(std::string_view Member::*field, std::string_view value) const {
    Member m = *this;
    m.*field = value;
    return m;
  }
};

constexpr Member Number(std::string_view name, std::string_view doc, double lo = -kUnbounded,
                        double hi = kUnbounded) {
  return {name, Kind::kNumber, doc, lo, hi};
}
constexpr Member Integer(std::string_view name, std::string_view doc, double lo, double hi) {
  return {name, Kind::kInteger, doc, lo, hi};
}
constexpr Member Boolean(std::string_view name, std::string_view doc) {
  return {name, Kind::kBoolean, doc};
}
constexpr Member String(std::string_view name, std::string_view doc,
                        std::string_view pattern = {}) {
  return {name, Kind::kString, doc, -kUnbounded, kUnbounded, {}, pattern};
}
constexpr Member Choice(std::string_view name, std::string_view doc, std::string_view choices) {
  return {name, Kind::kChoice, doc, -kUnbounded, kUnbounded, choices};
}
constexpr Member Schema(std::string_view name, std::string_view doc, std::string_view schema) {
  return {name, Kind::kSchema, doc, -kUnbounded, kUnbounded, {}, schema};
}

// Each object a request body holds, top level or nested.
enum class Body : unsigned char {
  kMesh,      // POST mesh and check.
  kRender,    // POST render.
  kSheet,     // POST sheet.
  kSequence,  // POST sequence/sample, /stream, /reduce.
  kBatch,     // POST batch.
  kFit,       // POST fit.
  kSpeech,    // POST speech (JSON).
  kDerive,    // POST derive.
  kCapture,   // POST capture.
  kCamera,
  kLight,
  kGaze,
  kGazeTrack,
  kGazeKey,
  kBlink,
  kJoint,       // One joint of "pose".
  kBlendClip,   // One clip of "blend".
  kLayer,       // One layer of "layers".
  kKey,         // One key of a sequence.
  kCell,        // One cell of a sheet.
  kVariant,     // One variant of a batch.
  kSample,      // A batch's "sample".
  kRandomize,   // A batch's "randomize".
  kLive,        // A text message of the live socket (GET /v1/rigs/{id}/live).
  kLiveSay,     // Its "say".
  kLiveListen,  // Its "listen".
  kLiveVmc,     // Its "vmc": a VMC receiver.
  kLiveInlet,   // Its "listen_vmc" and "listen_ifacialmocap": a UDP port.
  kLiveFrames,  // Its "frames": what the binary frames carry.
};
inline constexpr Body kBodies[] = {
    Body::kMesh,       Body::kRender,    Body::kSheet,     Body::kSequence,  Body::kBatch,
    Body::kFit,        Body::kSpeech,    Body::kDerive,    Body::kCapture,   Body::kCamera,
    Body::kLight,      Body::kGaze,      Body::kGazeTrack, Body::kGazeKey,   Body::kBlink,
    Body::kJoint,      Body::kBlendClip, Body::kLayer,     Body::kKey,       Body::kCell,
    Body::kVariant,    Body::kSample,    Body::kRandomize, Body::kLive,      Body::kLiveSay,
    Body::kLiveListen, Body::kLiveVmc,   Body::kLiveInlet, Body::kLiveFrames};

// The members `body` takes, in the order the document lists them.
std::span<const Member> Members(Body body);
// The document's component name for `body` ("MeshRequest", "Camera", ...) and what it is.
std::string_view SchemaName(Body body);
std::string_view Describe(Body body);
// The member of `body` named `name`, or nullptr.
const Member* FindMember(Body body, std::string_view name);
// Adds "unknown member" (with a "did you mean" or the list of members) at `pointer`/key.
void UnknownMember(std::string_view pointer, const std::string& key, Body body, Status& errors);
// Every member of the object `v` that `body` does not declare, as UnknownMember errors.
void RefuseUnknown(const nlohmann::json& v, std::string_view pointer, Body body, Status& errors);
// A number member of `body` within its declared kind and range: false, with "must be ..." at
// `pointer`, when it is not.
bool ReadNumber(Body body, std::string_view name, const nlohmann::json& v,
                const std::string& pointer, double* out, Status& errors);
// A kChoice member's choices, in order ("a|b|c" -> a, b, c).
std::vector<std::string_view> Choices(const Member& m);
// What a member must be, from its declaration: "an integer in [1, 4]", "true or false", ...
std::string Expected(const Member& m);

}  // namespace facespace::evaluator
