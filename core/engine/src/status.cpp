#include "facespace/engine/status.h"

namespace facespace {

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

Status InvalidArgument(std::string message) {
  return {StatusCode::kInvalidArgument, std::move(message), {}, {}, 0};
}
Status NotFound(std::string message) { return {StatusCode::kNotFound, std::move(message), {}, {}, 0}; }
Status FailedPrecondition(std::string message) {
  return {StatusCode::kFailedPrecondition, std::move(message), {}, {}, 0};
}
Status ResourceExhausted(std::string message) {
  return {StatusCode::kResourceExhausted, std::move(message), {}, {}, 0};
}

Status Internal(std::string message) { return {StatusCode::kInternal, std::move(message), {}, {}, 0}; }
Status Cancelled(std::string message) { return {StatusCode::kCancelled, std::move(message), {}, {}, 0}; }

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
  if (status.code == StatusCode::kInvalidArgument || status.code == StatusCode::kFailedPrecondition) status.reason = std::move(reason);
  return status;
}

std::string JsonPointerEscape(const std::string& key) {
  std::string r;
  for (char c : key) {
    if (c == '~') r += "~0";
    else if (c == '/') r += "~1";
    else r += c;
  }
  return r;
}

}  // namespace facespace
