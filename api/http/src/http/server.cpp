// http::Api: the route table installed on a cpp-httplib server, with the hooks every request goes
// through (CORS, errors as problem details, metrics, the access log).
#include <chrono>
#include <cstdio>
#include <thread>

#include "cost.h"
#include "encoded.h"
#include "facespace/http/http.h"
#include "facespace/net/framing.h"
#include "problem.h"
#include "route_table.h"
#include "routes/routes.h"

namespace facespace::http {

using http::Problem;
using http::RequestState;
using http::StateOf;
using httplib::Request;
using httplib::Response;

struct Api::Impl {
  http::ServerState ctx;
  // Encodes each rig's description and topology and bakes its occlusion beside the first requests
  // (routes/rigs.cpp, WarmRig); stopped and joined before `ctx` goes.
  std::jthread warm;
  Impl(evaluator::RigStore& s, batch::JobQueue* j, const evaluator::Evaluator& e, ApiOptions o)
      : ctx(s, j, e, std::move(o), http::MetricLabels()) {
    warm = std::jthread([this](std::stop_token stop) {
      for (const auto& rig : ctx.store.List()) {
        if (stop.stop_requested()) return;
        http::WarmRig(ctx, rig);
      }
      ctx.warmed = true;
    });
  }
};

Api::Api(evaluator::RigStore& store, const evaluator::Evaluator& evaluator, ApiOptions options,
         batch::JobQueue* jobs)
    : impl_(std::make_unique<Impl>(store, jobs, evaluator, std::move(options))) {}
Api::~Api() = default;

std::string Api::MetricsText() const { return http::MetricsText(impl_->ctx); }

bool Api::Keyed(std::string_view authorization) const {
  return http::CheckKey(impl_->ctx.options, authorization) == http::KeyCheck::kRight;
}

std::optional<std::string> Api::CheckHead(const net::RequestHeadView& head) {
  http::ServerState& ctx = impl_->ctx;
  Request req;
  req.method = head.method;
  req.path = head.target.substr(0, head.target.find('?'));
  for (const auto& [name, value] : head.headers) req.headers.emplace(name, value);
  Response res;
  if (!http::PreRoute(ctx, req, res)) return std::nullopt;
  ctx.metrics.Observe(ctx.metrics.other_route(), res.status, 0.0);
  if (ctx.options.log_requests)
    std::fprintf(stderr, "%s %s %d %zu -\n", req.method.c_str(), req.path.substr(0, 200).c_str(),
                 res.status, res.body.size());
  return http::ClosingResponse(res);
}

std::string Api::RefusalResponse(const net::RefusalInfo& info) {
  Request req;
  req.path = std::string(info.path);
  Response res;
  if (info.retry_after) res.set_header("Retry-After", "1");
  const http::Problem problem =
      info.why == net::Refusal::kTooManyConnections ? http::Problem::kTooManyConnections
      : info.why == net::Refusal::kBodyTooLarge     ? http::Problem::kBodyTooLarge
      : info.why == net::Refusal::kBusy             ? http::Problem::kBusy
      : info.why == net::Refusal::kRequestTimeout   ? http::Problem::kRequestTimeout
                                                    : http::ProblemOfHttpStatus(info.status);
  http::SendProblem(req, res, problem, std::string(info.detail));
  return http::ClosingResponse(res);
}

std::optional<std::string> Api::Probe(const net::RequestHeadView& head) {
  // A probe with a query goes to a worker, which refuses the parameters it does not declare as
  // every route does.
  if ((head.method != "GET" && head.method != "HEAD") || head.target.find('?') != std::string::npos)
    return std::nullopt;
  const std::string path = head.target.substr(0, head.target.find('?'));
  void (*handler)(http::ServerState&, const Request&, Response&) =
      path == "/healthz"   ? http::GetHealth
      : path == "/readyz"  ? http::GetReady
      : path == "/metrics" ? http::GetMetrics
                           : nullptr;
  if (!handler) return std::nullopt;
  http::ServerState& ctx = impl_->ctx;
  const auto start = std::chrono::steady_clock::now();
  Request req;
  req.method = head.method;
  req.path = path;
  for (const auto& [name, value] : head.headers) req.headers.emplace(name, value);
  Response res;
  http::PreRoute(ctx, req, res);  // CORS, as for every request (GET is never refused there).
  res.status = 200;               // PreRoute said its cost.
  handler(ctx, req, res);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const auto& labels = ctx.metrics.labels();
  const size_t metric =
      static_cast<size_t>(std::find(labels.begin(), labels.end(), path) - labels.begin());
  ctx.metrics.Observe(metric < labels.size() ? metric : ctx.metrics.other_route(), res.status,
                      seconds);
  if (ctx.options.log_requests)
    std::fprintf(stderr, "%s %s %d %zu %.3fms\n", req.method.c_str(), path.c_str(), res.status,
                 res.body.size(), seconds * 1e3);
  const bool close = net::EqualsIgnoreCase(req.get_header_value("Connection"), "close");
  return close ? http::ClosingResponse(res, req.method == "HEAD")
               : http::KeptAliveResponse(res, req.method == "HEAD");
}

namespace {

// An answer cpp-httplib made without a handler (no route, a body over the limit, a request it could
// not parse) as a problem.
httplib::Server::HandlerResponse AnswerError(const Request& req, Response& res) {
  if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
  switch (res.status) {
    case 404:
      http::SendProblem(req, res, Problem::kNotFound, "no route " + req.path.substr(0, 200));
      break;
    case 413:
      http::SendProblem(req, res, Problem::kBodyTooLarge,
                        "the request body is over the server's limit");
      break;
    case 414:
      http::SendProblem(
          req, res, Problem::kUriTooLong,
          "the request line is over 8,192 bytes: send long weight lists as a POST body");
      break;
    case 400:
      if (StateOf(req).started)
        http::SendProblem(req, res, Problem::kBadRequest, "the request body could not be read");
      else
        http::SendProblem(req, res, Problem::kBadRequest,
                          "the request line or headers could not be parsed");
      break;
    default:
      if (res.status >= 400)
        http::SendProblem(req, res, http::ProblemOfHttpStatus(res.status),
                          http::ReasonPhrase(res.status));
      else
        return httplib::Server::HandlerResponse::Unhandled;
  }
  return httplib::Server::HandlerResponse::Handled;
}

// The request's metrics, and its log line when the server logs requests.
void LogRequest(http::ServerState& ctx, const Request& req, const Response& res) {
  RequestState& r = StateOf(req);
  const double seconds =
      r.started ? std::chrono::duration<double>(std::chrono::steady_clock::now() - r.start).count()
                : 0.0;
  ctx.metrics.Observe(r.started ? r.route : ctx.metrics.other_route(), res.status, seconds);
  if (ctx.options.log_requests) {
    const size_t bytes = res.body.empty()
                             ? res.content_length_
                             : res.body.size();  // Cached bodies go out through a provider.
    // A request the parser refused has no method or path it could read.
    const char* method = req.method.empty() ? "-" : req.method.c_str();
    const std::string path = req.path.empty()
                                 ? (res.status == 414 ? "(request line over 8,192 bytes)" : "-")
                                 : req.path.substr(0, 200);
    if (r.started)
      std::fprintf(stderr, "%s %s %d %zu %.3fms\n", method, path.c_str(), res.status, bytes,
                   seconds * 1e3);
    else
      std::fprintf(stderr, "%s %s %d %zu -\n", method, path.c_str(), res.status, bytes);
  }
  r.started = false;
}

}  // namespace

void Api::Register(httplib::Server& server) {
  http::ServerState& ctx = impl_->ctx;
  server.set_payload_max_length(ctx.options.max_body);

  // The request's clock starts at its first hook: the Expect handler, else pre-routing. Requests
  // cpp-httplib refuses while parsing (400, 414) reach none: their log line has no duration.
  auto start = [&ctx](const Request& req, bool again) {
    RequestState& r = StateOf(req);
    if (r.started && !again) return;
    r.started = true;
    r.start = std::chrono::steady_clock::now();
    r.route = ctx.metrics.other_route();
  };
  server.set_expect_100_continue_handler([&ctx, start](const Request& req, Response& res) {
    start(req, true);
    http::HideAcceptEncoding(
        const_cast<Request&>(req));  // cpp-httplib's own object, not const (encoded.h).
    // 100 invites the body: never for one that will be refused from the headers.
    if (http::PreRoute(ctx, req, res)) {
      // cpp-httplib writes this answer without applying the body's length: without it the client
      // cannot tell where the answer ends, and sends the body after all.
      res.set_header("Content-Length", std::to_string(res.body.size()));
      return res.status;
    }
    res.headers.clear();  // Pre-routing runs again (and sets them again) once the body is in.
    return 100;
  });
  server.set_pre_routing_handler([&ctx, start](const Request& req, Response& res) {
    start(req,
          req.get_header_value("Expect") != "100-continue");  // Else the Expect handler started it.
    // Before anything can answer: cpp-httplib would compress the answer itself, unbounded
    // (encoded.h).
    http::HideAcceptEncoding(const_cast<Request&>(req));
    return http::PreRoute(ctx, req, res) ? httplib::Server::HandlerResponse::Handled
                                         : httplib::Server::HandlerResponse::Unhandled;
  });

  server.set_error_handler(httplib::Server::HandlerWithResponse(AnswerError));

  server.set_exception_handler([](const Request& req, Response& res, std::exception_ptr) {
    http::SendProblem(req, res, Problem::kInternal, "internal error");
  });

  server.set_logger([&ctx](const Request& req, const Response& res) { LogRequest(ctx, req, res); });

  // Every route of the table, then 405 with Allow for its path under the other methods.
  const std::vector<std::string> labels = http::MetricLabels();
  std::vector<std::string> paths;
  for (const http::Route& route : http::Routes()) {
    const size_t metric =
        static_cast<size_t>(std::find(labels.begin(), labels.end(), route.metric) - labels.begin());
    const std::string pattern = http::PathPattern(route.path);
    auto handler = [&ctx, metric, h = route.handler](const Request& req, Response& res) {
      StateOf(req).route = metric;
      // Its cost is stated before it works (PreRoute's constant, or the estimate: cost.h,
      // WithinBudget).
      h(ctx, req, res);
      http::CompressBody(req, res,
                         net::StopOf(req));  // On this worker, metered and stoppable (encoded.h).
    };
    const std::string method = route.method;
    if (method == "GET")
      server.Get(pattern, handler);
    else if (method == "POST")
      server.Post(pattern, handler);
    else if (method == "PUT")
      server.Put(pattern, handler);
    else
      server.Delete(pattern, handler);
    if (std::find(paths.begin(), paths.end(), route.path) == paths.end())
      paths.push_back(route.path);
  }
  for (const std::string& path : paths) {
    const std::string allow = http::MatchPath(path).Allow();
    auto not_allowed = [allow](const Request& req, Response& res) {
      res.set_header("Allow", allow);
      http::SendProblem(req, res, Problem::kMethodNotAllowed,
                        req.method + " is not allowed here; allowed: " + allow);
    };
    // Only GET reaches these: the methods with a body are answered by pre-routing, from the
    // headers.
    const http::PathRoutes routes = http::MatchPath(path);
    if (!routes.Find("GET")) server.Get(http::PathPattern(path), not_allowed);
  }
}

}  // namespace facespace::http
