// Template definitions of context.h.
#pragma once

#include "problem.h"
#include "negotiate.h"

namespace facespace::api::http {

template <typename T, typename Parse>
bool ReadJsonBody(const httplib::Request& req, httplib::Response& res, Parse parse, T& out) {
  if (!AcceptsJsonBody(req, res)) return false;
  auto parsed = parse(req.body);
  if (!parsed.ok()) {
    SendStatus(req, res, parsed.status());
    return false;
  }
  out = std::move(parsed.value());
  return true;
}

template <typename Produce>
void SendCached(Context& ctx, const httplib::Request& req, httplib::Response& res, const std::string& key,
                const char* content_type, Produce produce) {
  std::shared_ptr<const Encoded> enc = ctx.cache.Get(key);
  ctx.metrics.CountCache(enc != nullptr);
  if (!enc) {
    Result<std::string> bytes = [&] {
      const WorkspacePool::Lease ws = ctx.workspaces.Acquire();
      return produce(*ws);
    }();
    if (!bytes.ok()) {
      SendStatus(req, res, bytes.status());
      return;
    }
    auto e = std::make_shared<Encoded>();
    e->body = std::move(bytes.value());
    e->content_type = content_type;
    enc = e;
    ctx.cache.Put(key, enc);
  }
  res.status = 200;
  res.set_content(enc->body, enc->content_type.c_str());
}

}  // namespace facespace::api::http
