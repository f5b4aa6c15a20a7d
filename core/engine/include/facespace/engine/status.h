// Status and Result: the error type of every fallible operation in core.
#pragma once

#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace facespace {
inline namespace engine {

// Codes follow abseil's canonical set. Only api/ maps them to HTTP statuses.
enum class StatusCode {
  kOk,
  kInvalidArgument,     // The caller's input is wrong (bad weight, unknown name, broken file).
  kNotFound,            // A named thing does not exist (file, rig).
  kFailedPrecondition,  // The input is well formed but cannot be used here.
  kResourceExhausted,   // A configured limit was exceeded.
  kStorageFull,         // The disk (or a quota) is full: retry when space is freed.
  kCancelled,  // The work was stopped: its client left, its deadline passed, or the server is
               // stopping.
  kInternal,   // A bug on our side.
};

const char* StatusCodeName(StatusCode code);

// Points at one offending field of an input: a JSON Pointer ("/weights/jawOpen") or a
// command-line flag ("--set"), with what is wrong with it.
struct FieldError {
  std::string pointer;
  std::string message;
};

// A key as one reference token of a JSON Pointer (RFC 6901): "~" becomes "~0", "/" becomes "~1".
std::string JsonPointerEscape(const std::string& key);

// How many offending fields a Status lists; past that they are only counted (Status::omitted), so
// an input with a million bad members costs a count, not a million messages.
inline constexpr size_t kMaxFieldErrors = 20;

struct Status {
  StatusCode code = StatusCode::kOk;
  std::string message;             // One line, meant for people. Empty when ok.
  std::vector<FieldError> fields;  // Offending fields, when the input is structured.
  std::string reason;  // A stable slug naming the kind of problem ("invalid-weights"), for
                       // clients to switch on; empty: the code says enough.
  size_t omitted = 0;  // Offending fields past kMaxFieldErrors, counted, not listed.

  bool ok() const { return code == StatusCode::kOk; }
  static Status Ok() { return {}; }
  // Whether another field error would only be counted: check it before building a costly message.
  bool full() const { return fields.size() >= kMaxFieldErrors; }
  // Lists the field, or counts it once kMaxFieldErrors are listed.
  void AddField(std::string pointer, std::string field_message) {
    if (full())
      ++omitted;
    else
      fields.push_back({std::move(pointer), std::move(field_message)});
  }
  // The same with the message made only when it is listed (a costly one: a closest-name search).
  template <typename MakeMessage>
  requires std::is_invocable_r_v<std::string, MakeMessage>
  void AddField(std::string pointer, MakeMessage&& make_message) {
    if (full())
      ++omitted;
    else
      fields.push_back({std::move(pointer), make_message()});
  }
  size_t field_count() const { return fields.size() + omitted; }
};

// A status of `code` with `message` (the factories below say which code means what).
Status StatusOf(StatusCode code, std::string message);
Status InvalidArgument(std::string message);
Status NotFound(std::string message);
Status FailedPrecondition(std::string message);
Status ResourceExhausted(std::string message);
Status Internal(std::string message);
// Work stopped part way (a std::stop_token fired): nothing half-made is kept or sent.
Status Cancelled(std::string message =
                     "stopped: the client left, the deadline passed or the server is stopping");
// An error of one field: the message "POINTER: MESSAGE" (just MESSAGE for the empty pointer), the
// field listed.
Status InvalidField(const std::string& pointer, const std::string& message,
                    StatusCode code = StatusCode::kInvalidArgument);
// The same status with `prefix` before its message ("shapes.json: ..."): code, fields and reason
// kept.
Status Prefixed(Status status, const std::string& prefix);
// The same status with its reason set.
Status WithReason(Status status, std::string reason);
// The same for a status passed up from below, when it is the caller's input that is wrong (invalid
// argument or failed precondition): a limit, a full disk or a cancellation keeps its own reason.
Status WithInputReason(Status status, std::string reason);

// A value or the Status that says why there is none.
template <typename T>
class Result {
 public:
  Result(T value) : value_(std::move(value)) {}          // NOLINT: implicit by design.
  Result(Status status) : status_(std::move(status)) {}  // NOLINT: implicit by design.

  bool ok() const { return value_.has_value(); }
  const Status& status() const { return status_; }
  T& value() & { return *value_; }
  const T& value() const& { return *value_; }
  T&& value() && { return std::move(*value_); }
  T* operator->() { return &*value_; }
  const T* operator->() const { return &*value_; }

 private:
  std::optional<T> value_;
  Status status_;
};

// Structured warning: the result was computed, but a person should know this.
// Codes are stable strings (snake_case) that clients may switch on.
struct Warning {
  std::string code;     // "extrapolation", "out_of_range", "negative_weight", "absolute_sum", ...
  std::string message;  // One line for people.
  std::string shape;    // The shape (or other named item) concerned; empty when none.
  double value = 0.0;   // The number the warning is about (sum, weight); see has_value.
  bool has_value = false;
};

// A warning about `count` things (names repaired, binds dropped...): "COUNT what", the count its
// value.
Warning CountWarning(std::string code, size_t count, const std::string& what);

}  // namespace engine
}  // namespace facespace
