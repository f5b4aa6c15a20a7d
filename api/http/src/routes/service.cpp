// The service's own routes: liveness, readiness, metrics, the OpenAPI document.
#include <tuple>

#include "../http/encoded.h"
#include "routes.h"

namespace facespace::http {

void GetHealth(ServerState&, const httplib::Request&, httplib::Response& res) {
  res.set_content("{\"status\":\"ok\"}", "application/json");
}

// Ready once every rig's description and topology are encoded (the warm-up beside the first
// requests): until then 503 with Retry-After, so an orchestrator sends traffic to an instance that
// answers at once.
void GetReady(ServerState& ctx, const httplib::Request&, httplib::Response& res) {
  const bool warm = ctx.warmed.load();
  if (!warm) res.set_header("Retry-After", "1");
  SendJson(res, warm ? 200 : 503,
           {{"status", warm ? "ready" : "warming"}, {"rigs", ctx.store.List().size()}});
}

std::string MetricsText(ServerState& ctx) {
  std::string out = ctx.metrics.Text(ctx.store.List().size(), ctx.cache.Bytes());
  auto gauge = [&out](const char* name, const char* type, const char* help, size_t value) {
    out += std::string("# HELP ") + name + " " + help + "\n# TYPE " + name + " " + type + "\n" +
           name + " " + std::to_string(value) + "\n";
  };
  gauge("facespace_render_memory_in_flight_bytes", "gauge",
        "Estimated working memory of the renders in flight (--render-memory-mb).",
        ctx.render_budget.InFlight());
  if (const net::FrontStats* f = ctx.options.front) {
    const std::tuple<const char*, const char*, const char*, const std::atomic<size_t>&> front[] = {
        // Connections and what the front refused from their heads.
        {"facespace_connections_open", "gauge", "Connections open (--max-connections).", f->open},
        {"facespace_connections_refused_total", "counter",
         "Connections refused with 503 for the caps.", f->refused_total},
        {"facespace_connections_refused_client_total", "counter",
         "... of them for --max-client-connections.", f->refused_client},
        // Requests that never reached a worker, and the bodies held meanwhile.
        {"facespace_requests_timed_out_total", "counter",
         "Requests not whole within --read-timeout (408).", f->timed_out},
        {"facespace_requests_bad_framing_total", "counter",
         "Requests refused for their framing (400, 414, 431, 501, 505).", f->bad_framing},
        {"facespace_requests_over_body_budget_total", "counter",
         "Bodies refused for --body-budget-mb (503).", f->over_budget},
        {"facespace_request_body_bytes", "gauge",
         "Request bytes held by the front (--body-budget-mb).", f->body_bytes},
        // Requests on workers, and the turns of one address.
        {"facespace_requests_in_flight", "gauge", "Requests running on workers now.", f->in_flight},
        {"facespace_requests_waited_turn_total", "counter",
         "Requests that waited for their address's turn (--max-client-requests).", f->waited_turn},
        // Work stopped before its end (issue 48): its client gone, its deadline, its CPU, a reader
        // too slow.
        {"facespace_requests_client_gone_total", "counter",
         "Requests stopped because their client hung up.", f->client_gone},
        {"facespace_requests_past_deadline_total", "counter",
         "Requests stopped at their deadline (--request-deadline, --keyed-deadline).",
         f->past_deadline},
        {"facespace_requests_over_cpu_total", "counter",
         "Requests stopped for the CPU their worker spent (twice their budget and 1 s).",
         f->over_cpu},
        {"facespace_responses_slow_reader_total", "counter",
         "Answers ended for a client reading slower than --min-send-rate, or not at all.",
         f->slow_readers}};
    for (const auto& [name, type, help, value] : front) gauge(name, type, help, value.load());
  }
  // Live sessions (GET /v1/rigs/{id}/live).
  const net::LiveHub::Counts& c = ctx.live.counts;
  gauge("facespace_live_sessions_open", "gauge",
        "Live WebSocket sessions open (--max-live-sessions).", ctx.live.open());
  const std::tuple<const char*, const char*, const std::atomic<size_t>&> live[] = {
      {"facespace_live_sessions_total", "Live sessions opened.", c.opened},
      {"facespace_live_sessions_refused_total", "Live handshakes refused with 503 for the caps.",
       c.refused},
      {"facespace_live_messages_total", "Messages received from live clients.", c.messages},
      {"facespace_live_frames_total", "Mesh frames sent to live clients.", c.frames},
      {"facespace_live_dropped_slow_total",
       "Live sessions closed (1008) for taking nothing sent to them.", c.dropped_slow},
      {"facespace_live_closed_flood_total", "Live sessions closed (1008) for a flood of messages.",
       c.closed_flood},
      {"facespace_live_closed_too_big_total",
       "Live sessions closed (1009) for a message over the cap.", c.closed_too_big}};
  for (const auto& [name, help, value] : live) gauge(name, "counter", help, value.load());
  return out;
}

void GetMetrics(ServerState& ctx, const httplib::Request&, httplib::Response& res) {
  res.set_content(MetricsText(ctx), "text/plain; version=0.0.4");
}

// The document is the process's own constant: encoded once per coding (encoded.h), not per request
// (64 clients asking for it with br put other clients' probes at p99 1.5 s).
void GetOpenApi(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  SendEncodedOnce(ctx, req, res, "openapi", "application/json", [&ctx] { return ctx.openapi; });
  res.headers.erase("Cache-Control");
  res.set_header("Cache-Control", "public, max-age=3600");
}

}  // namespace facespace::http
