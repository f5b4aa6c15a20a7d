#include "problem.h"

#include "cost.h"
#include "facespace/formats/io.h"
#include "facespace/formats/rig_json.h"

namespace facespace::http {

using nlohmann::json;

const char* ReasonPhrase(int status) {
  switch (status) {
    case 400: return "Bad Request";
    case 401: return "Unauthorized";
    case 403: return "Forbidden";
    case 404: return "Not Found";
    case 405: return "Method Not Allowed";
    case 406: return "Not Acceptable";
    case 408: return "Request Timeout";
    case 409: return "Conflict";
    case 411: return "Length Required";
    case 413: return "Content Too Large";
    case 414: return "URI Too Long";
    case 415: return "Unsupported Media Type";
    case 416: return "Range Not Satisfiable";
    case 417: return "Expectation Failed";
    case 422: return "Unprocessable Content";
    case 429: return "Too Many Requests";
    case 500: return "Internal Server Error";
    case 503: return "Service Unavailable";
    case 507: return "Insufficient Storage";
  }
  return "Error";
}

const char* StatusLinePhrase(int status) {
  switch (status) {
    case 200: return "OK";
    case 204: return "No Content";
    case 304: return "Not Modified";
    case 413: return "Payload Too Large";
    case 414: return "URI Too Long";
    case 431: return "Request Header Fields Too Large";
    case 501: return "Not Implemented";
    case 505: return "HTTP Version Not Supported";
    default: return ReasonPhrase(status);
  }
}

namespace {

std::string WholeResponse(const httplib::Response& res, bool head_only, const char* connection) {
  std::string out =
      "HTTP/1.1 " + std::to_string(res.status) + " " + StatusLinePhrase(res.status) + "\r\n";
  for (const auto& [name, value] : res.headers) {
    if (name != "Content-Length" && name != "Connection") out += name + ": " + value + "\r\n";
  }
  out += "Content-Length: " + std::to_string(res.body.size()) + "\r\nConnection: " + connection +
         "\r\n\r\n";
  return head_only ? out : out + res.body;
}

}  // namespace

std::string ClosingResponse(const httplib::Response& res, bool head_only) {
  return WholeResponse(res, head_only, "close");
}
std::string KeptAliveResponse(const httplib::Response& res, bool head_only) {
  return WholeResponse(res, head_only, "keep-alive");
}

std::string Dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

Problem ProblemOfHttpStatus(int status) {
  switch (status) {
    case 404: return Problem::kNotFound;
    case 405: return Problem::kMethodNotAllowed;
    case 408: return Problem::kRequestTimeout;
    case 411: return Problem::kLengthRequired;
    case 413: return Problem::kBodyTooLarge;
    case 414: return Problem::kUriTooLong;
    case 415: return Problem::kUnsupportedMediaType;
    case 416: return Problem::kRangeNotSatisfiable;
    case 417: return Problem::kExpectationFailed;
    case 431: return Problem::kHeadersTooLarge;
    case 501: return Problem::kNotImplemented;
    case 505: return Problem::kHttpVersionNotSupported;
    default: return status >= 500 ? Problem::kInternal : Problem::kBadRequest;
  }
}

json ProblemJson(Problem problem, const std::string& detail, const std::vector<FieldError>& fields,
                 const std::string& instance, std::span<const Warning> warnings, size_t omitted) {
  const ProblemType& t = TypeOf(problem);
  json p = {{"type", "urn:facespace:problem:" + std::string(t.name)},
            {"title", t.title},
            {"status", t.status},
            {"detail", detail},
            {"instance", instance}};
  if (!fields.empty()) {
    // The first kMaxFieldErrors, and how many there were in all when that is more.
    json errors = json::array();
    for (size_t i = 0; i < fields.size() && i < kMaxFieldErrors; ++i) {
      const FieldError& f = fields[i];
      if (!f.pointer.empty() && f.pointer[0] == '?')
        errors.push_back({{"parameter", f.pointer.substr(1)}, {"detail", f.message}});
      else
        errors.push_back({{"pointer", f.pointer}, {"detail", f.message}});
    }
    p["errors"] = errors;
    if (fields.size() + omitted > errors.size()) p["errors_total"] = fields.size() + omitted;
  }
  if (!warnings.empty()) p["warnings"] = formats::WarningsValue(warnings);
  return p;
}

json ProblemJson(const Status& s, const std::string& instance) {
  return ProblemJson(ProblemOf(s), s.message, s.fields, instance, {}, s.omitted);
}

void SendProblem(const httplib::Request& req, httplib::Response& res, Problem problem,
                 const std::string& detail, const std::vector<FieldError>& fields,
                 std::span<const Warning> warnings, size_t omitted) {
  const json p = ProblemJson(problem, detail, fields, req.path, warnings, omitted);
  res.status = TypeOf(problem).status;
  // A refusal written before any route (the connection front's) states its cost as every answer
  // does.
  if (!res.has_header("Facespace-Cost")) res.set_header("Facespace-Cost", kConstantCost);
  res.set_content(Dump(p), "application/problem+json");
}

void SendStatus(const httplib::Request& req, httplib::Response& res, const Status& s,
                std::span<const Warning> warnings) {
  const Problem problem = ProblemOf(s);
  if (TypeOf(problem).status == 503 && !res.has_header("Retry-After"))
    res.set_header("Retry-After", "2");
  SendProblem(req, res, problem, s.message, s.fields, warnings, s.omitted);
}

void SendJson(httplib::Response& res, int status, const json& body) {
  res.status = status;
  res.set_content(Dump(body), "application/json");
}

}  // namespace facespace::http
