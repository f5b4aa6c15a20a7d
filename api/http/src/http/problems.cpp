#include "problems.h"

#include <array>

#include "facespace/batch/queue.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/evaluator/request.h"

namespace facespace::http {

namespace {

using P = Problem;

constexpr std::array<ProblemType, static_cast<size_t>(P::kCount)> kTable = {{
    {P::kBadRequest, "bad-request", 400, "The request line, headers or body could not be read"},
    {P::kMalformedJson, "malformed-json", 400, "The body is not JSON"},
    {P::kUriTooLong, "uri-too-long", 414, "The request line is too long"},
    {P::kBodyTooLarge, "body-too-large", 413, "The body is over the server's limit"},
    {P::kBodyTooComplex, "body-too-complex", 413,
     "The body holds more values than the server reads"},
    {P::kTooDeep, "too-deep", 422, "JSON nested too deep"},
    {P::kLengthRequired, "length-required", 411, "A body needs its length"},
    {P::kUnsupportedMediaType, "unsupported-media-type", 415,
     "The body's Content-Type is not read here"},
    {P::kNotAcceptable, "not-acceptable", 406, "No answer of the type asked for"},
    {P::kMethodNotAllowed, "method-not-allowed", 405, "The method is not allowed here"},
    {P::kUpgradeRequired, "upgrade-required", 426, "A WebSocket upgrade is needed"},
    {P::kRequestTimeout, "request-timeout", 408, "The request did not come in time"},
    {P::kHeadersTooLarge, "headers-too-large", 431, "The request's headers are too large"},
    {P::kRangeNotSatisfiable, "range-not-satisfiable", 416,
     "The range asked for is not in the answer"},
    {P::kExpectationFailed, "expectation-failed", 417, "The Expect header cannot be met"},
    {P::kHttpVersionNotSupported, "http-version-not-supported", 505, "HTTP/1.1 only"},
    {P::kNotImplemented, "not-implemented", 501, "Not implemented"},
    {P::kUnauthorized, "unauthorized", 401, "An API key is needed"},
    {P::kForbidden, "forbidden", 403, "Wrong API key"},
    {P::kUploadsDisabled, "uploads-disabled", 403, "This server takes no uploads, deletes or jobs"},
    {P::kNotFound, "not-found", 404, "Not found"},
    {P::kRigNotFound, "rig-not-found", 404, "No such rig"},
    {P::kJobNotFound, "job-not-found", 404, "No such job"},
    {P::kFileNotFound, "file-not-found", 404, "No such file of the job"},
    {P::kInvalidId, "invalid-id", 422, "An id that cannot name a rig"},
    {P::kInvalidRequest, "invalid-request", 422, "The request is not valid"},
    {P::kInvalidWeights, "invalid-weights", 422, "The weights are not valid for this rig"},
    {P::kInvalidControls, "invalid-controls", 422, "The controls are not valid for this rig"},
    {P::kInvalidTarget, "invalid-target", 422, "The target mesh cannot be fitted"},
    {P::kInvalidSequence, "invalid-sequence", 422, "The sequence is not valid"},
    {P::kWeightsLeaveAuthoredSpace, "weights-leave-authored-space", 422,
     "The point leaves the authored space (strict)"},
    {P::kInvalidText, "invalid-text", 422, "The text cannot be spoken"},
    {P::kInvalidAudio, "invalid-audio", 422, "The audio cannot be read"},
    {P::kInvalidRate, "invalid-rate", 422, "The audio's sample rate is not one taken here"},
    {P::kInvalidRig, "invalid-rig", 422, "The rig file cannot be loaded"},
    {P::kInvalidManifest, "invalid-manifest", 422, "The manifest does not fit the rig"},
    {P::kInvalidVrm, "invalid-vrm", 422, "The VRM extensions are not valid"},
    {P::kUnknownVoice, "unknown-voice", 422, "No such voice"},
    {P::kNoMouth, "no-mouth", 422, "The rig has no mouth to speak with"},
    {P::kPoorFit, "poor-fit", 422, "The source's face does not fit this rig's"},
    {P::kNoFace, "no-face", 422, "The rig has no surface to derive a face onto"},
    {P::kNoExpressions, "no-expressions", 422, "No shape of the rig moves the tracked face"},
    {P::kTooLarge, "too-large", 413, "Over one of the server's limits"},
    {P::kResponseTooLarge, "response-too-large", 422,
     "The answer would be over the server's limit"},
    {P::kRenderTooLarge, "render-too-large", 413, "The render would be over the server's memory"},
    {P::kImageTooLarge, "image-too-large", 422, "The image is too large"},
    {P::kTooManyCells, "too-many-cells", 422, "Too many cells for one sheet"},
    {P::kTooManyFrames, "too-many-frames", 422, "Too many frames for one answer"},
    {P::kVideoTooLong, "video-too-long", 422, "The video would be too long"},
    {P::kTextTooLong, "text-too-long", 422, "The text is too long to speak at once"},
    {P::kSpeechTooLong, "speech-too-long", 413, "The speech would be over the server's limit"},
    {P::kSayQueueFull, "say-queue-full", 413, "Too much text waits to be spoken"},
    {P::kTranscriptTooLong, "transcript-too-long", 422, "More words than the audio can hold"},
    {P::kAudioTooLong, "audio-too-long", 413, "The audio is over the server's limit"},
    {P::kAudioTooFast, "audio-too-fast", 413, "Audio comes faster than it plays"},
    {P::kHostNotAllowed, "host-not-allowed", 403,
     "The server talks VMC and iFacialMocap with this machine, and the hosts its operator allows"},
    {P::kTooManyTargets, "too-many-targets", 422, "A live session sends to a few VMC receivers"},
    {P::kPortInUse, "port-in-use", 409, "The UDP port is taken"},
    {P::kOverBudget, "over-budget", 422, "The request's estimated cost is over its budget"},
    {P::kReadOnly, "read-only", 409, "The rig is bundled with the server"},
    {P::kJobNotDone, "job-not-done", 409, "The job has not finished"},
    {P::kRigChanged, "rig-changed", 409, "The rig changed while the job ran"},
    {P::kJobQueueFull, "job-queue-full", 429, "The job queue is full"},
    {P::kJobsDisabled, "jobs-disabled", 503, "This server runs no batch jobs"},
    {P::kStorageFull, "storage-full", 507, "The disk is full"},
    {P::kStorageFailed, "storage-failed", 500, "Storing failed"},
    {P::kBusy, "busy", 503, "A budget of the server's is in use: retry shortly"},
    {P::kTooManyConnections, "too-many-connections", 503, "Too many connections from this address"},
    {P::kTooManySessions, "too-many-sessions", 503, "Too many live sessions from this address"},
    {P::kCancelled, "cancelled", 503, "The work was stopped"},
    {P::kInternal, "internal", 500, "Internal error"},
}};

constexpr bool InEnumOrder() {
  for (size_t i = 0; i < kTable.size(); ++i) {
    if (static_cast<size_t>(kTable[i].problem) != i) return false;
  }
  return true;
}
static_assert(InEnumOrder(), "kTable lists the problems in enum order, one each");

// The reasons the lower layers name by constant are the table's.
constexpr std::string_view NameOf(P p) { return kTable[static_cast<size_t>(p)].name; }
static_assert(NameOf(P::kMalformedJson) == evaluator::kMalformedJson &&
              NameOf(P::kJobQueueFull) == batch::kJobQueueFull);
static_assert(NameOf(P::kInvalidWeights) == evaluator::kInvalidWeights &&
              NameOf(P::kInvalidControls) == evaluator::kInvalidControls &&
              NameOf(P::kInvalidTarget) == evaluator::kInvalidTarget &&
              NameOf(P::kInvalidSequence) == evaluator::kInvalidSequence &&
              NameOf(P::kWeightsLeaveAuthoredSpace) == evaluator::kLeavesAuthoredSpace &&
              NameOf(P::kResponseTooLarge) == evaluator::kResponseTooLarge);

}  // namespace

std::span<const ProblemType> Problems() { return kTable; }

const ProblemType& TypeOf(Problem p) { return kTable[static_cast<size_t>(p)]; }

std::optional<Problem> ProblemNamed(std::string_view name) {
  for (const ProblemType& t : kTable) {
    if (t.name == name) return t.problem;
  }
  return std::nullopt;
}

Problem ProblemOf(const Status& s) {
  if (auto named = ProblemNamed(s.reason)) return *named;
  switch (s.code) {
    case StatusCode::kInvalidArgument:
    case StatusCode::kFailedPrecondition: return P::kInvalidRequest;
    case StatusCode::kNotFound: return P::kNotFound;
    case StatusCode::kResourceExhausted: return P::kTooLarge;
    case StatusCode::kStorageFull: return P::kStorageFull;
    case StatusCode::kCancelled: return P::kCancelled;
    case StatusCode::kOk:
    case StatusCode::kInternal: return P::kInternal;
  }
  return P::kInternal;
}

}  // namespace facespace::http
