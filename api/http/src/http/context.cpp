#include "context.h"

#include <malloc.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <thread>

#include "negotiate.h"
#include "problem.h"

namespace facespace::http {

void WorkspacePool::Return::operator()(evaluator::Workspace* ws) const {
  std::unique_ptr<evaluator::Workspace> owned(ws);
  std::lock_guard lock(pool->mu_);
  if (pool->idle_.size() < pool->keep_) pool->idle_.push_back(std::move(owned));
}

WorkspacePool::Lease WorkspacePool::Acquire(std::stop_token stop, HelperCpu* helper_cpu) {
  Lease ws;
  {
    std::lock_guard lock(mu_);
    if (!idle_.empty()) {
      ws = Lease(idle_.back().release(), Return{this});
      idle_.pop_back();
    }
  }
  if (!ws) ws = Lease(new evaluator::Workspace, Return{this});
  ws->stop = std::move(stop);
  ws->helper_cpu = helper_cpu;
  return ws;
}

size_t RenderBudget::Estimate(const picture::RenderOptions& o, size_t cells) {
  const size_t ss = static_cast<size_t>(std::max(1, o.supersample));
  const size_t pixels =
      static_cast<size_t>(std::max(0, o.width)) * static_cast<size_t>(std::max(0, o.height));
  return pixels * ss * ss * 36 + pixels * std::max<size_t>(cells, 1) * 36;
}

bool RenderBudget::Acquire(size_t bytes) {
  std::unique_lock<std::mutex> lock(mu_);
  // A request alone may use the whole budget: it waits until nothing else is in flight.
  const size_t need = std::min(bytes, total_);
  if (!cv_.wait_for(lock, std::chrono::seconds(2), [&] { return used_ + need <= total_; }))
    return false;
  used_ += need;
  return true;
}

void RenderBudget::Release(size_t bytes) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    used_ -= std::min(bytes, total_);
  }
  cv_.notify_all();
}

size_t RenderBudget::InFlight() const {
  std::lock_guard<std::mutex> lock(mu_);
  return used_;
}

void ReturnMemory() { malloc_trim(0); }

bool CheckRenderBudget(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                       const picture::RenderOptions& o, size_t cells) {
  const size_t bytes = RenderBudget::Estimate(o, cells);
  if (bytes <= ctx.render_budget.per_request()) return true;
  const char* p = req.method == "GET" ? "?" : "/";
  std::vector<FieldError> fields = {{std::string(p) + "width", "lower width x height"}};
  if (o.supersample > 1)
    fields.push_back({std::string(p) + "supersample", "lower the supersampling"});
  if (cells > 1) fields.push_back({"/cells", "fewer cells"});
  SendProblem(
      req, res, Problem::kRenderTooLarge,
      "this render would need about " + std::to_string(bytes >> 20) +
          " MiB of working memory (width x height x supersample^2" +
          (cells > 1 ? std::string(", times ") + std::to_string(cells) + " cells" : std::string()) +
          "); this server allows " + std::to_string(ctx.render_budget.per_request() >> 20) +
          " MiB a request (--render-budget-mb)",
      fields);
  return false;
}

ServerState::ServerState(evaluator::RigStore& s, batch::JobQueue* j, const evaluator::Evaluator& e,
                         ApiOptions o, std::vector<std::string> route_labels)
    : store(s),
      jobs(j),
      evaluator(e),
      options(std::move(o)),
      metrics(std::move(route_labels)),
      cache(options.cache_bytes),
      workspaces(2 * std::max(2u, std::thread::hardware_concurrency())),
      render_budget(options.render_budget, options.render_memory),
      openapi(OpenApiJson(options)),
      live([this] {
        net::LiveLimits l;
        l.max_sessions = options.max_live_sessions;
        l.max_per_client = options.max_client_live_sessions;
        return l;
      }()) {}

std::shared_ptr<const evaluator::StoredRig> FindRig(ServerState& ctx, const httplib::Request& req,
                                                    httplib::Response& res, const std::string& id) {
  auto rig = evaluator::IsValidRigId(id) ? ctx.store.Get(id) : nullptr;
  if (!rig) {
    // The nearest id, for a typo ("facecpa"): the store's ids are few.
    std::vector<std::string> ids;
    for (const auto& r : ctx.store.List()) ids.push_back(r->id);
    const std::vector<std::string_view> views(ids.begin(), ids.end());
    SendProblem(req, res, Problem::kRigNotFound,
                "no rig with id '" + id.substr(0, 80) + "'" + DidYouMean(id.substr(0, 80), views));
  }
  return rig;
}

void AttachVocabulary(const ServerState& ctx, evaluator::MeshRequest& r) {
  if (r.vocabulary != Vocabulary::kRig) return;
  if (auto source = ctx.store.Get(r.vocabulary_rig))
    r.vocabulary_source = std::shared_ptr<const Rig>(source, &source->rig);
}

std::string BodyPool::Take() {
  std::lock_guard<std::mutex> lock(mu_);
  if (idle_.empty()) return {};
  std::string body = std::move(idle_.back());
  idle_.pop_back();
  return body;
}

void BodyPool::Give(std::string body) {
  if (body.capacity() < 4096 || body.capacity() > kLargest) return;
  std::lock_guard<std::mutex> lock(mu_);
  if (idle_.size() < kKept) idle_.push_back(std::move(body));
}

std::shared_ptr<CachedResponse> BodyPool::MakeCached(const std::shared_ptr<BodyPool>& pool) {
  return std::shared_ptr<CachedResponse>(new CachedResponse,
                                         [weak = std::weak_ptr<BodyPool>(pool)](CachedResponse* e) {
                                           if (auto p = weak.lock()) p->Give(std::move(e->body));
                                           delete e;
                                         });
}

std::string ServerTiming(const evaluator::Workspace::Timing& timing) {
  std::string out;
  auto add = [&](const char* name, double ms) {
    if (ms <= 0) return;
    char buf[32];  // "%.2f" by std::to_chars: the same digits without printf's parsing (a mesh
                   // request's headers were 2% of its CPU).
    const auto end =
        std::to_chars(buf, buf + sizeof buf, std::min(ms, 1e12), std::chars_format::fixed, 2).ptr;
    out.append(out.empty() ? "" : ", ").append(name).append(";dur=").append(buf, end);
  };
  add("blend", timing.blend);
  add("draw", timing.draw);
  add("encode", timing.encode);
  return out;
}

void SendShared(httplib::Response& res, std::shared_ptr<const CachedResponse> enc) {
  const std::string* body = &enc->body;
  res.set_content_provider(
      body->size(), enc->content_type,
      [body](size_t offset, size_t length, httplib::DataSink& sink) {
        return sink.write(body->data() + offset, length);
      },
      [enc](bool) {});
}

bool ReportPoint(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                 const Status& s, double sum, std::span<const Warning> warnings) {
  const bool refused = s.reason == evaluator::kLeavesAuthoredSpace;
  if (s.ok() || refused) {
    SetWeightHeaders(res, sum, warnings);
    ctx.metrics.CountWarnings(warnings);
  }
  if (s.ok()) return true;
  SendStatus(req, res, s, refused ? warnings : std::span<const Warning>());
  return false;
}

}  // namespace facespace::http
