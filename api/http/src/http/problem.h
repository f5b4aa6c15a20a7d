// RFC 9457 problem details, and the one map from a Status to an HTTP status code.
#pragma once

#include <httplib.h>

#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "facespace/engine/status.h"
#include "problems.h"

namespace facespace::http {

const char* ReasonPhrase(int status);
// The phrase of a status line as cpp-httplib writes it ("413 Payload Too Large"), for the
// answers written without it (the connection front's), so every status line reads the same.
const char* StatusLinePhrase(int status);

// A problem document of `problem` (its type, status and title from problems.h). Field errors whose
// pointer starts with '?' name a query parameter ({"parameter": ...}); the others are JSON Pointers
// into the body ({"pointer": ...}). At most kMaxFieldErrors are listed; "errors_total" counts them
// all (with `omitted`) when more there were.
void SendProblem(const httplib::Request& req, httplib::Response& res, Problem problem,
                 const std::string& detail, const std::vector<FieldError>& fields = {},
                 std::span<const Warning> warnings = {}, size_t omitted = 0);
// The same document as JSON, for an answer that carries it (a failed job's "problem"), `instance`
// the path it is about.
nlohmann::json ProblemJson(Problem problem, const std::string& detail,
                           const std::vector<FieldError>& fields, const std::string& instance,
                           std::span<const Warning> warnings = {}, size_t omitted = 0);
// A Status's problem document (its reason's, else its code's).
nlohmann::json ProblemJson(const Status& s, const std::string& instance);
// The problem cpp-httplib answers an HTTP status with itself (a bad Range, Expect, headers too
// large...).
Problem ProblemOfHttpStatus(int status);

// The whole HTTP/1.1 answer of `res` on a connection closed after it, for answers written without
// cpp-httplib (the connection front's, and its pre-routing from the headers alone): the status line
// as cpp-httplib writes its own, the headers, Content-Length, Connection: close, the body.
std::string ClosingResponse(const httplib::Response& res, bool head_only = false);
// The same, for a connection kept open after it (the front's probes). `head_only`: a HEAD's answer,
// the body's length stated and the body left out.
std::string KeptAliveResponse(const httplib::Response& res, bool head_only = false);

// The problem for a Status: the one its reason names (else its code's), its message and fields.
void SendStatus(const httplib::Request& req, httplib::Response& res, const Status& status,
                std::span<const Warning> warnings = {});

void SendJson(httplib::Response& res, int status, const nlohmann::json& body);

// JSON text that never throws: invalid UTF-8 is replaced.
std::string Dump(const nlohmann::json& j);

}  // namespace facespace::http
