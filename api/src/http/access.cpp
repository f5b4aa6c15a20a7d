// Who may call what: CORS for browser origins, the API key for routes that write.
#include <algorithm>

#include "context.h"
#include "problem.h"

namespace facespace::api::http {

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

bool Authorized(const Context& ctx, const httplib::Request& req, httplib::Response& res) {
  if (ctx.options.api_key.empty()) {
    SendProblem(req, res, 403, "uploads-disabled", "this server has no API key configured: uploads and deletes are disabled");
    return false;
  }
  const std::string auth = req.get_header_value("Authorization");
  if (auth.empty()) {
    res.set_header("WWW-Authenticate", "Bearer realm=\"facespace\"");
    SendProblem(req, res, 401, "unauthorized", "this route needs the API key: Authorization: Bearer KEY");
    return false;
  }
  const std::string prefix = "Bearer ";
  if (auth.size() < prefix.size() || !std::equal(prefix.begin(), prefix.end(), auth.begin(), [](char a, char b) {
        return std::tolower(static_cast<unsigned char>(a)) == std::tolower(static_cast<unsigned char>(b));
      })) {
    res.set_header("WWW-Authenticate", "Bearer realm=\"facespace\"");
    SendProblem(req, res, 401, "unauthorized", "the Authorization header must use the Bearer scheme");
    return false;
  }
  if (!ConstantTimeEquals(auth.substr(prefix.size()), ctx.options.api_key)) {
    SendProblem(req, res, 403, "forbidden", "wrong API key");
    return false;
  }
  return true;
}

bool PreRoute(const Context& ctx, const httplib::Request& req, httplib::Response& res) {
  const std::string origin = req.get_header_value("Origin");
  if (!origin.empty() && OriginAllowed(ctx.options, origin)) {
    res.set_header("Access-Control-Allow-Origin", origin);
    res.set_header("Vary", "Origin");
    res.set_header("Access-Control-Expose-Headers", "Facespace-Weight-Sum, Facespace-Warnings, ETag, Location, Server-Timing");
    res.set_header("Timing-Allow-Origin", origin);  // The browser's performance API sees Server-Timing too.
    if (req.method == "OPTIONS") {
      res.set_header("Access-Control-Allow-Methods", "GET, POST, PUT, DELETE, OPTIONS");
      res.set_header("Access-Control-Allow-Headers", "Content-Type, Authorization, If-None-Match, Accept");
      res.set_header("Access-Control-Max-Age", "600");
    }
  }
  if (req.method != "OPTIONS") return false;
  res.status = 204;  // Preflight (or a plain OPTIONS): no body.
  res.set_header("Allow", "GET, POST, PUT, DELETE, OPTIONS");
  return true;
}

}  // namespace facespace::api::http
