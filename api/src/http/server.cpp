// api::Api: the route table installed on a cpp-httplib server, with the hooks every request goes
// through (CORS, errors as problem details, metrics, the access log).
#include <chrono>
#include <cstdio>

#include "facespace/api/http.h"
#include "problem.h"
#include "route_table.h"

namespace facespace::api {

using http::CurrentRequest;
using httplib::Request;
using httplib::Response;

struct Api::Impl {
  http::Context ctx;
  Impl(RigStore& s, JobQueue* j, const render::Renderer& r, ApiOptions o) : ctx(s, j, r, std::move(o), http::MetricLabels()) {}
};

Api::Api(RigStore& store, const render::Renderer& renderer, ApiOptions options, JobQueue* jobs)
    : impl_(std::make_unique<Impl>(store, jobs, renderer, std::move(options))) {}
Api::~Api() = default;

std::string Api::MetricsText() const { return impl_->ctx.metrics.Text(impl_->ctx.store.List().size(), impl_->ctx.cache.Bytes()); }

void Api::Register(httplib::Server& server) {
  http::Context& ctx = impl_->ctx;
  server.set_payload_max_length(ctx.options.max_body);

  server.set_pre_routing_handler([&ctx](const Request& req, Response& res) {
    CurrentRequest().start = std::chrono::steady_clock::now();
    CurrentRequest().route = ctx.metrics.other_route();
    return http::PreRoute(ctx, req, res) ? httplib::Server::HandlerResponse::Handled : httplib::Server::HandlerResponse::Unhandled;
  });

  server.set_error_handler(httplib::Server::HandlerWithResponse([](const Request& req, Response& res) {
    if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
    switch (res.status) {
      case 404: http::SendProblem(req, res, 404, "not-found", "no route " + req.path.substr(0, 200)); break;
      case 413: http::SendProblem(req, res, 413, "body-too-large", "the request body is over the server's limit"); break;
      case 400: http::SendProblem(req, res, 400, "bad-request", "the request could not be parsed"); break;
      default:
        if (res.status >= 400) http::SendProblem(req, res, res.status, "error", http::ReasonPhrase(res.status));
        else return httplib::Server::HandlerResponse::Unhandled;
    }
    return httplib::Server::HandlerResponse::Handled;
  }));

  server.set_exception_handler([](const Request& req, Response& res, std::exception_ptr) {
    http::SendProblem(req, res, 500, "internal", "internal error");
  });

  server.set_logger([&ctx](const Request& req, const Response& res) {
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - CurrentRequest().start).count();
    ctx.metrics.Observe(CurrentRequest().route, res.status, seconds);
    if (ctx.options.log_requests) {
      const size_t bytes = res.body.empty() ? res.content_length_ : res.body.size();  // Cached bodies go out through a provider.
      std::fprintf(stderr, "%s %s %d %zu %.3fms\n", req.method.c_str(), req.path.c_str(), res.status, bytes, seconds * 1e3);
    }
  });

  // Every route of the table, then 405 with Allow for its path under the other methods.
  const std::vector<std::string> labels = http::MetricLabels();
  std::vector<std::string> paths;
  for (const http::Route& route : http::Routes()) {
    const size_t metric = static_cast<size_t>(std::find(labels.begin(), labels.end(), route.metric) - labels.begin());
    const std::string pattern = http::PathPattern(route.path);
    auto handler = [&ctx, metric, h = route.handler](const Request& req, Response& res) {
      CurrentRequest().route = metric;
      h(ctx, req, res);
    };
    const std::string method = route.method;
    if (method == "GET") server.Get(pattern, handler);
    else if (method == "POST") server.Post(pattern, handler);
    else if (method == "PUT") server.Put(pattern, handler);
    else server.Delete(pattern, handler);
    if (std::find(paths.begin(), paths.end(), route.path) == paths.end()) paths.push_back(route.path);
  }
  for (const std::string& path : paths) {
    std::string allow;
    bool allowed[4] = {};
    const char* const methods[4] = {"GET", "POST", "PUT", "DELETE"};
    for (const http::Route& route : http::Routes()) {
      for (int m = 0; m < 4; ++m) allowed[m] |= route.path == path && std::string(route.method) == methods[m];
    }
    for (int m = 0; m < 4; ++m) {
      if (allowed[m]) allow += std::string(allow.empty() ? "" : ", ") + methods[m];
    }
    auto not_allowed = [allow](const Request& req, Response& res) {
      res.set_header("Allow", allow);
      http::SendProblem(req, res, 405, "method-not-allowed", req.method + " is not allowed here; allowed: " + allow);
    };
    const std::string pattern = http::PathPattern(path);
    if (!allowed[0]) server.Get(pattern, not_allowed);
    if (!allowed[1]) server.Post(pattern, not_allowed);
    if (!allowed[2]) server.Put(pattern, not_allowed);
    if (!allowed[3]) server.Delete(pattern, not_allowed);
    server.Patch(pattern, not_allowed);
  }
}

}  // namespace facespace::api
