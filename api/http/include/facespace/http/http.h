// The HTTP API (v1) on cpp-httplib: routes, problem+json errors, warnings as headers,
// ETags and a response cache, CORS, metrics, OpenAPI. The code is in api/http/src/http (plumbing)
// and api/http/src/routes (one file per resource).
#pragma once

#include <httplib.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "facespace/batch/queue.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/evaluator/store.h"
#include "facespace/net/front.h"

namespace facespace::http {

struct ApiOptions {
  // Every limit and budget of the server by its setting's name (facespace serve's one table), for
  // /openapi.json's info.x-facespace-limits beside the ones below.
  std::vector<std::pair<std::string, double>> limits;
  std::string api_key;                    // Empty: uploads and deletes are refused.
  std::vector<std::string> cors_origins;  // Allowed browser origins; "*" allows any.
  size_t max_body = size_t{64} << 20;     // Request bodies above this get 413.
  size_t cache_bytes = size_t{64} << 20;  // Memory cap of the encoded-response cache.
  bool log_requests = true;               // One access-log line per request on stderr.
  int max_render_size = 2048;  // Largest render width or height (after supersampling: x4).
  int max_sheet_cells = 64;    // Largest contact sheet.
  size_t max_response = size_t{64}
                        << 20;  // Largest body built whole (sequence/sample): above, 422.
  size_t max_frames = 100000;   // Frames of one sequence stream.
  size_t render_budget = size_t{1}
                         << 30;  // Estimated working memory of one render or sheet; above, 413.
  size_t render_memory =
      size_t{2} << 30;  // ... of the renders in flight together; past it they wait, then 503.
  const net::FrontStats* front =
      nullptr;  // The connection front's counters, for /metrics (when there is one).
  float max_video_seconds = 60.0f;           // Speech as a WebM: longer is 422 video-too-long.
  long long max_video_pixels = 1920 * 1080;  // ... and larger frames 422.
  double anonymous_cpu =
      2.0;  // Estimated CPU-seconds a request without the key may cost (else 422 over-budget).
  double keyed_cpu = 600.0;  // ... with the key.
  // Live sessions (GET /v1/rigs/{id}/live, WebSocket): how many at once, in all and from one
  // address, and how long one may last without the key and with it.
  size_t max_live_sessions = 1024;
  size_t max_client_live_sessions = 128;
  int live_seconds = 3600;
  int keyed_live_seconds = 86400;
  // IPv4 addresses beside this machine's that live sessions may send VMC to and read VMC and
  // iFacialMocap from (serve --vmc-hosts); empty: loopback only.
  std::vector<std::string> vmc_hosts;
};

// The routes (api/http/src/http/route_table.cpp) over a store, an evaluator and a job queue that
// the caller owns and keeps alive while the server runs.
class Api {
 public:
  // `jobs` may be null: the batch and job routes then answer 503.
  Api(evaluator::RigStore& store, const evaluator::Evaluator& evaluator, ApiOptions options,
      batch::JobQueue* jobs = nullptr);
  ~Api();
  Api(const Api&) = delete;
  Api& operator=(const Api&) = delete;

  // Installs every route and hook on `server`.
  void Register(httplib::Server& server);

  // The pre-routing of a request from its line and headers alone (FrontOptions::head_check): a
  // whole response when it is refused before its body (404, 405, 411, 413, 401, 403), else nothing.
  std::optional<std::string> CheckHead(const net::RequestHeadView& head);

  // A probe (GET or HEAD /healthz, /readyz, /metrics) answered from its head alone on the front's
  // own thread (FrontOptions::probe): a whole keep-alive response, so that probes never wait for a
  // worker however many are busy; nothing for any other request.
  std::optional<std::string> Probe(const net::RequestHeadView& head);

  // A request the connection front refuses itself (FrontOptions::refusal), as problem+json.
  static std::string RefusalResponse(const net::RefusalInfo& info);

  // Whether an Authorization header's value carries the API key (FrontOptions::keyed: the request's
  // deadline is then the keyed one).
  bool Keyed(std::string_view authorization) const;

  // Prometheus text of the counters (also served at /metrics).
  std::string MetricsText() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The OpenAPI 3.1 document of the routes (served at /openapi.json), with the server's limits.
std::string OpenApiJson(const ApiOptions& limits);

}  // namespace facespace::http
