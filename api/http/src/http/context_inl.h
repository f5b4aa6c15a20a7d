// Template definitions of context.h.
#pragma once

#include "negotiate.h"
#include "problem.h"

namespace facespace::http {

template <typename T, typename Parse>
bool ReadJsonBody(const httplib::Request& req, httplib::Response& res, Parse parse, T& out) {
  if (!AcceptsJsonBody(req, res)) return false;
  if (!req.params.empty()) {  // Not read: the client's setting would be silently lost.
    const std::string name = req.params.begin()->first;
    SendProblem(req, res, Problem::kInvalidRequest,
                name + ": query parameters are not read with a JSON body; give \"" + name +
                    "\" in the body",
                {{"?" + name, "is not read with a JSON body"}});
    return false;
  }
  auto parsed = parse(req.body);
  if (!parsed.ok()) {
    SendStatus(req, res, parsed.status());
    return false;
  }
  out = std::move(parsed.value());
  return true;
}

template <typename Render>
Result<evaluator::Encoded> WithinRenderBudget(ServerState& ctx, size_t bytes, Render render) {
  if (!ctx.render_budget.Acquire(bytes)) {
    return WithReason(
        ResourceExhausted(
            "the server is rendering as much as its memory budget allows; retry shortly"),
        "busy");
  }
  Result<evaluator::Encoded> out = render();
  ctx.render_budget.Release(bytes);
  if (bytes >= kLargeWork) ReturnMemory();
  return out;
}

template <typename Produce>
void SendCached(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                const std::string& key, const char* content_type, Admit admit, Produce produce) {
  std::shared_ptr<const CachedResponse> enc = ctx.cache.Get(key);
  ctx.metrics.CountCache(enc != nullptr);
  if (!enc) {
    evaluator::Workspace::Timing timing;
    Result<evaluator::Encoded> bytes = [&] {
      const WorkspacePool::Lease ws = ctx.workspaces.Acquire(req);
      ws->timing = {};
      Result<evaluator::Encoded> made = produce(*ws);
      timing = ws->timing;
      return made;
    }();
    if (!bytes.ok()) {
      SendStatus(req, res, bytes.status());
      return;
    }
    auto e = BodyPool::MakeCached(ctx.bodies);
    e->body = std::move(bytes->bytes);
    // The cache counts a body by its size: no large room left over from building it (text formats).
    if (e->body.capacity() > e->body.size() + e->body.size() / 8) e->body.shrink_to_fit();
    e->content_type = content_type;
    enc = e;
    ctx.cache.Offer(key, enc, admit);
    res.set_header("Server-Timing", ServerTiming(timing));
  } else {
    res.set_header("Server-Timing", "cache;desc=\"hit\"");
  }
  // A Range request gets its part as 206 (cpp-httplib cuts the body, and keeps a status set here).
  res.status = req.ranges.empty() ? 200 : 206;
  SendShared(res, enc);
}

}  // namespace facespace::http
