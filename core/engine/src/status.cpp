#include "facespace/engine/status.h"

namespace facespace {
inline namespace engine {

const char* StatusCodeName(StatusCode code) {
  switch (code) {
    case StatusCode::kOk: return "ok";
    case StatusCode::kInvalidArgument: return "invalid_argument";
    case StatusCode::kNotFound: return "not_found";
    case StatusCode::kFailedPrecondition: return "failed_precondition";
    case StatusCode::kResourceExhausted: return "resource_exhausted";
    case StatusCode::kStorageFull: return "storage_full";
    case StatusCode::kCancelled: return "cancelled";
    case StatusCode::kInternal: return "internal";
  }
  return "unknown";
}

Status StatusOf(StatusCode code, std::string message) {
  return {code, std::move(message), {}, {}, 0};
}

Status InvalidArgument(std::string message) {
  return StatusOf(StatusCode::kInvalidArgument, std::move(message));
}
Status NotFound(std::string message) { return StatusOf(StatusCode::kNotFound, std::move(message)); }
Status FailedPrecondition(std::string message) {
  return StatusOf(StatusCode::kFailedPrecondition, std::move(message));
}
Status ResourceExhausted(std::string message) {
  return StatusOf(StatusCode::kResourceExhausted, std::move(message));
}
Status Internal(std::string message) { return StatusOf(StatusCode::kInternal, std::move(message)); }
Status Cancelled(std::string message) {
  return StatusOf(StatusCode::kCancelled, std::move(message));
}

Warning CountWarning(std::string code, size_t count, const std::string& what) {
  return {std::move(code), std::to_string(count) + " " + what, "", static_cast<double>(count),
          true};
}

Status InvalidField(const std::string& pointer, const std::string& message, StatusCode code) {
  Status s{code, pointer.empty() ? message : pointer + ": " + message, {{pointer, message}}, {}, 0};
  return s;
}

Status Prefixed(Status status, const std::string& prefix) {
  status.message = prefix + status.message;
  return status;
}

Status WithReason(Status status, std::string reason) {
  status.reason = std::move(reason);
  return status;
}

Status WithInputReason(Status status, std::string reason) {
  if (status.code == StatusCode::kInvalidArgument || status.code == StatusCode::kFailedPrecondition)
    status.reason = std::move(reason);
  return status;
}

std::string JsonPointerEscape(const std::string& key) {
  std::string r;
  for (char c : key) {
    if (c == '~')
      r += "~0";
    else if (c == '/')
      r += "~1";
    else
      r += c;
  }
  return r;
}

}  // namespace engine
}  // namespace facespace
