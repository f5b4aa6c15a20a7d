// The service's own routes: liveness, readiness, metrics, the OpenAPI document.
#include "routes.h"

namespace facespace::api::http {

void GetHealth(Context&, const httplib::Request&, httplib::Response& res) {
  res.set_content("{\"status\":\"ok\"}", "application/json");
}

void GetReady(Context& ctx, const httplib::Request&, httplib::Response& res) {
  res.set_content("{\"status\":\"ready\",\"rigs\":" + std::to_string(ctx.store.List().size()) + "}", "application/json");
}

void GetMetrics(Context& ctx, const httplib::Request&, httplib::Response& res) {
  res.set_content(ctx.metrics.Text(ctx.store.List().size(), ctx.cache.Bytes()), "text/plain; version=0.0.4");
}

void GetOpenApi(Context& ctx, const httplib::Request&, httplib::Response& res) {
  res.set_header("Cache-Control", "public, max-age=3600");
  res.set_content(ctx.openapi, "application/json");
}

}  // namespace facespace::api::http
