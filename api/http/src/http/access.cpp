// Who may call what: CORS for browser origins, the API key for routes that write.
#include <algorithm>

#include "../openapi/openapi.h"
#include "context.h"
#include "cost.h"
#include "facespace/net/framing.h"
#include "problem.h"
#include "route_table.h"

namespace facespace::http {

namespace {

bool ConstantTimeEquals(const std::string& a, const std::string& b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  const size_t n = std::max(a.size(), b.size());
  for (size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    diff |= static_cast<unsigned char>(x ^ y);
  }
  return diff == 0;
}

bool OriginAllowed(const ApiOptions& options, const std::string& origin) {
  for (const std::string& o : options.cors_origins) {
    if (o == "*" || o == origin) return true;
  }
  return false;
}

}  // namespace

KeyCheck CheckKey(const ApiOptions& options, std::string_view authorization) {
  if (options.api_key.empty()) return KeyCheck::kNoKeyConfigured;
  if (authorization.empty()) return KeyCheck::kMissing;
  constexpr std::string_view kBearer = "Bearer";
  if (authorization.size() < kBearer.size() ||
      !net::EqualsIgnoreCase(authorization.substr(0, kBearer.size()), kBearer))
    return KeyCheck::kNotBearer;
  const std::string_view rest = authorization.substr(kBearer.size());
  // "Bearer" and nothing after (a key file that was empty or not read): said as such.
  if (rest.find_first_not_of(" \t") == std::string_view::npos) return KeyCheck::kEmptyToken;
  if (rest[0] != ' ') return KeyCheck::kNotBearer;  // "Bearerx...": another scheme.
  return ConstantTimeEquals(std::string(rest.substr(1)), options.api_key) ? KeyCheck::kRight
                                                                          : KeyCheck::kWrong;
}

bool CarriesKey(const ServerState& ctx, const httplib::Request& req) {
  return CheckKey(ctx.options, req.get_header_value("Authorization")) == KeyCheck::kRight;
}

namespace {

// 401 with the Bearer challenge; false, for Authorized to return.
bool Unauthorized(const httplib::Request& req, httplib::Response& res, const std::string& detail) {
  res.set_header("WWW-Authenticate", "Bearer realm=\"facespace\"");
  SendProblem(req, res, Problem::kUnauthorized, detail);
  return false;
}

}  // namespace

bool Authorized(const ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  switch (CheckKey(ctx.options, req.get_header_value("Authorization"))) {
    case KeyCheck::kRight: return true;
    case KeyCheck::kNoKeyConfigured:
      SendProblem(req, res, Problem::kUploadsDisabled,
                  "this server has no API key configured: uploads, deletes and batch jobs are "
                  "disabled (start it with --api-key-file FILE, a file holding the key; bash "
                  ".ci/dev start makes build/api-key)");
      return false;
    case KeyCheck::kMissing:
      return Unauthorized(req, res, "this route needs the API key: Authorization: Bearer KEY");
    case KeyCheck::kNotBearer:
      return Unauthorized(req, res, "the Authorization header must use the Bearer scheme");
    case KeyCheck::kEmptyToken:
      return Unauthorized(req, res,
                          "the Bearer token is empty: Authorization: Bearer KEY (was the key file "
                          "empty or unread?)");
    case KeyCheck::kWrong:
      SendProblem(req, res, Problem::kForbidden, "wrong API key");
      return false;
  }
  return false;
}

namespace {

// A refusal sent before the body is read. When the request declared a body the client may be
// sending it still: the connection is marked to close, so its bytes are never read as a request.
// A query parameter its operation does not declare (the document's, openapi::QueryParameters) is
// refused alike on every route without a body: 422 naming it. The mesh and render GETs read theirs
// themselves (http/query_params.h, the same lists the document declares), with hints for the maps.
bool RefusedQuery(const httplib::Request& req, httplib::Response& res) {
  const PathRoutes routes = MatchPath(req.path);
  const Route* route =
      routes.path ? routes.Find(req.method == "HEAD" ? "GET" : req.method) : nullptr;
  if (!route) return false;
  const std::string_view path = route->path;
  if (path == "/v1/rigs/{id}/mesh" || path == "/v1/rigs/{id}/render") return false;
  const std::vector<openapi::QueryParameter>& declared =
      openapi::QueryParameters(route->method, path);
  for (const auto& [name, value] : req.params) {
    bool known = false;
    for (const openapi::QueryParameter& d : declared) {
      known = known || name == d.name ||
              (d.map && (name.starts_with(d.name + ".") || name.starts_with(d.name + "[")));
    }
    if (known) continue;
    std::string list;
    for (const openapi::QueryParameter& d : declared) list += (list.empty() ? "" : ", ") + d.name;
    const std::string detail =
        "unknown query parameter; " +
        (list.empty() ? std::string("this operation takes none") : "it takes " + list);
    SendProblem(req, res, Problem::kInvalidRequest, name.substr(0, 64) + ": " + detail,
                {{"?" + name.substr(0, 64), detail}});
    return true;
  }
  return false;
}

bool RefuseBeforeBody(const httplib::Request& req, httplib::Response& res) {
  if (req.has_header("Content-Length") || req.has_header("Transfer-Encoding"))
    res.set_header("Connection", "close");
  return true;
}

}  // namespace

bool PreRoute(const ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  // Every answer states its cost (401, 405 and OPTIONS too): this constant, replaced by the
  // estimate of a route whose work grows with the request (cost.h, WithinBudget).
  res.set_header("Facespace-Cost", kConstantCost);
  const std::string origin = req.get_header_value("Origin");
  const bool cors = !origin.empty() && OriginAllowed(ctx.options, origin);
  if (cors) {
    res.set_header("Access-Control-Allow-Origin", origin);
    res.set_header("Vary", "Origin");
    res.set_header(
        "Access-Control-Expose-Headers",
        "Facespace-Weight-Sum, Facespace-Warnings, Facespace-Cost, ETag, Location, Server-Timing");
    res.set_header("Timing-Allow-Origin",
                   origin);  // The browser's performance API sees Server-Timing too.
  }
  const bool bodiless = req.method == "GET" || req.method == "HEAD" || req.method == "DELETE";
  if (bodiless && !req.params.empty() && RefusedQuery(req, res)) return true;
  // GET and HEAD carry no body: cpp-httplib routes them (405 and 404 included) at no extra cost.
  if (req.method == "GET" || req.method == "HEAD") return false;

  // The others are answered from the request line and headers when they can be, before a body
  // is read: an unknown path, a method the path does not allow, a body over the limit or of no
  // stated length, a write without the key.
  const PathRoutes routes = MatchPath(req.path);
  if (!routes.path) {
    SendProblem(req, res, Problem::kNotFound, "no route " + req.path.substr(0, 200));
    return RefuseBeforeBody(req, res);
  }
  const std::string allow = routes.Allow();
  if (req.method == "OPTIONS") {
    res.status = 204;  // Preflight (or a plain OPTIONS): no body.
    res.set_header("Allow", allow);
    if (cors) {
      res.set_header("Access-Control-Allow-Methods", allow);
      res.set_header("Access-Control-Allow-Headers",
                     "Content-Type, Authorization, If-None-Match, Accept");
      res.set_header("Access-Control-Max-Age", "600");
    }
    return true;
  }
  const Route* route = routes.Find(req.method);
  if (!route) {
    res.set_header("Allow", allow);
    SendProblem(req, res, Problem::kMethodNotAllowed,
                req.method.substr(0, 20) + " is not allowed here; allowed: " + allow);
    return RefuseBeforeBody(req, res);
  }
  const bool chunked =
      req.get_header_value("Transfer-Encoding").find("chunked") != std::string::npos;
  if (req.method != "DELETE" && !chunked && !req.has_header("Content-Length")) {
    SendProblem(req, res, Problem::kLengthRequired,
                req.method + " " + route->path +
                    " needs a body with Content-Length (or Transfer-Encoding: chunked); this "
                    "request has neither");
    return RefuseBeforeBody(req, res);
  }
  if (req.has_header("Content-Length")) {
    const std::string length = req.get_header_value("Content-Length");
    const bool digits =
        !length.empty() && length.size() <= 19 &&
        std::all_of(length.begin(), length.end(), [](char c) { return c >= '0' && c <= '9'; });
    if (!digits || std::stoull(length) > ctx.options.max_body) {
      SendProblem(req, res, Problem::kBodyTooLarge,
                  "the request body (Content-Length: " + length.substr(0, 24) +
                      ") is over the server's limit of " + std::to_string(ctx.options.max_body) +
                      " bytes (--max-body)");
      return RefuseBeforeBody(req, res);
    }
  }
  if (route->key && !Authorized(ctx, req, res)) return RefuseBeforeBody(req, res);
  return false;
}

}  // namespace facespace::http
