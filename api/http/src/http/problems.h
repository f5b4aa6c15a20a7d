// Every problem the service answers, declared once: its type (urn:facespace:problem:<name>), its
// HTTP status and its title (RFC 9457: the same for every occurrence of the type; the detail says
// what this one was). SendProblem takes one of these; a Status's reason names one (HttpStatus reads
// its status here); /openapi.json lists them all (the Problem schema's type enum and
// x-facespace-problems).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "facespace/engine/status.h"

namespace facespace::http {

enum class Problem : uint8_t {
  // The request as bytes and HTTP.
  kBadRequest,
  kMalformedJson,
  kUriTooLong,
  kBodyTooLarge,
  kBodyTooComplex,
  kTooDeep,
  kLengthRequired,
  kUnsupportedMediaType,
  kNotAcceptable,
  kMethodNotAllowed,
  kUpgradeRequired,
  kRequestTimeout,
  kHeadersTooLarge,
  kRangeNotSatisfiable,
  kExpectationFailed,
  kHttpVersionNotSupported,
  kNotImplemented,
  // Who asks.
  kUnauthorized,
  kForbidden,
  kUploadsDisabled,
  // What is named.
  kNotFound,
  kRigNotFound,
  kJobNotFound,
  kFileNotFound,
  kInvalidId,
  // What the request says.
  kInvalidRequest,
  kInvalidWeights,
  kInvalidControls,
  kInvalidTarget,
  kInvalidSequence,
  kWeightsLeaveAuthoredSpace,
  kInvalidText,
  kInvalidAudio,
  kInvalidRate,
  kInvalidRig,
  kInvalidManifest,
  kInvalidVrm,
  kUnknownVoice,
  kNoMouth,
  kPoorFit,
  kNoFace,
  kNoExpressions,
  // Its size and cost.
  kTooLarge,
  kResponseTooLarge,
  kRenderTooLarge,
  kImageTooLarge,
  kTooManyCells,
  kTooManyFrames,
  kVideoTooLong,
  kTextTooLong,
  kSpeechTooLong,
  kSayQueueFull,
  kTranscriptTooLong,
  kAudioTooLong,
  kAudioTooFast,
  kHostNotAllowed,
  kTooManyTargets,
  kPortInUse,
  kOverBudget,
  // The state of things.
  kReadOnly,
  kJobNotDone,
  kRigChanged,
  kJobQueueFull,
  kJobsDisabled,
  kStorageFull,
  kStorageFailed,
  // The server's own room.
  kBusy,
  kTooManyConnections,
  kTooManySessions,
  kCancelled,
  kInternal,
  kCount
};

struct ProblemType {
  Problem problem;
  std::string_view name;  // The slug after urn:facespace:problem:, and a Status's reason.
  int status;
  std::string_view title;
};

// The table, in enum order.
std::span<const ProblemType> Problems();
const ProblemType& TypeOf(Problem p);
// The problem a Status reason names, if it is one of the table's.
std::optional<Problem> ProblemNamed(std::string_view name);
// The problem of a Status: the one its reason names, else the generic one of its code.
Problem ProblemOf(const Status& s);

}  // namespace facespace::http
