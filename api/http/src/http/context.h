// What every route handler gets (ServerState), and the helpers the routes share.
#pragma once

#include <httplib.h>

#include <array>
#include <atomic>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string_view>
#include <vector>

#include "cache.h"
#include "derive_jobs.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/http/http.h"
#include "facespace/net/front.h"
#include "facespace/net/live_hub.h"
#include "landmark_maps.h"
#include "metrics.h"

namespace facespace::http {

// Workspaces for the pipeline, reused across requests (no allocation per request once warm). A
// free list rather than thread_local: with a thread per keep-alive connection, per-thread
// buffers would grow with every thread that ever blended (half a megabyte each on the MakeHuman
// face); here the idle ones are capped.
class WorkspacePool {
 public:
  explicit WorkspacePool(size_t keep) : keep_(keep) {}
  struct Return {
    WorkspacePool* pool;
    void operator()(evaluator::Workspace* ws) const;
  };
  using Lease = std::unique_ptr<evaluator::Workspace, Return>;
  // A workspace for a request whose stop token is `stop` and whose helper threads' CPU is charged
  // to `helper_cpu` (StopOf(req) and HelperCpuOf(req) in a route: Acquire(req)).
  Lease Acquire(std::stop_token stop, HelperCpu* helper_cpu);
  Lease Acquire(const httplib::Request& req) {
    return Acquire(net::StopOf(req), net::HelperCpuOf(req));
  }

 private:
  size_t keep_;
  std::mutex mu_;
  std::vector<std::unique_ptr<evaluator::Workspace>> idle_;
};

// Response bodies handed back when the last holder lets go (the response was sent, or the cache
// dropped it), for the next f32 body to be written over: a FaceCap body is 100 KB, and a new one
// per request cost an allocation and a copy of the whole rest body. A few of at most 1 MB are kept.
class BodyPool {
 public:
  std::string Take();
  void Give(std::string body);
  // A cached response whose body comes back here when it is freed (if the pool still exists).
  static std::shared_ptr<CachedResponse> MakeCached(const std::shared_ptr<BodyPool>& pool);

 private:
  static constexpr size_t kKept = 8, kLargest = size_t{1} << 20;
  std::mutex mu_;
  std::vector<std::string> idle_;
};

// The working memory of renders. A request's estimate (RenderBytes) must fit `per_request`
// (else 413); the renders in flight together must fit `total`: a render waits up to two seconds
// for room, then is answered 503 with Retry-After. Large work gives its memory back after.
class RenderBudget {
 public:
  RenderBudget(size_t per_request, size_t total) : per_request_(per_request), total_(total) {}
  size_t per_request() const { return per_request_; }
  // Bytes a render of `cells` images with these options may hold at once: per sample its float
  // colour, depth and read-back (36 bytes); per output pixel and cell the float image, the sheet's
  // copy and the 8-bit one (36 bytes).
  static size_t Estimate(const picture::RenderOptions& o, size_t cells);
  // Room for `bytes`, or false after the wait; Release gives it back.
  bool Acquire(size_t bytes);
  void Release(size_t bytes);
  size_t InFlight() const;

 private:
  size_t per_request_, total_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  size_t used_ = 0;
};

// The server's parts, owned by http::Api and passed to every route handler.
struct ServerState {
  ServerState(evaluator::RigStore& s, batch::JobQueue* j, const evaluator::Evaluator& e,
              ApiOptions o, std::vector<std::string> route_labels);

  evaluator::RigStore& store;
  batch::JobQueue* jobs;  // Null: the batch and job routes answer 503.
  const evaluator::Evaluator& evaluator;
  const ApiOptions options;
  Metrics metrics;
  ResponseCache cache;
  WorkspacePool workspaces;
  const std::shared_ptr<BodyPool> bodies = std::make_shared<BodyPool>();
  RenderBudget render_budget;
  const std::string openapi;        // The document, with this server's limits.
  std::atomic<bool> warmed{false};  // Every rig of the store at start encoded (/readyz).
  DeriveJobs derives;          // Its thread uses the store and the evaluator: it stops before them.
  LandmarkMaps landmark_maps;  // Captures' registrations, per rig version.
  net::LiveHub
      live;  // The WebSocket sessions (last: its threads use what is above, and stop first).
};

// ---- helpers the routes share ----

// The stored rig named by the path, or nullptr with a 404 sent.
std::shared_ptr<const evaluator::StoredRig> FindRig(ServerState& ctx, const httplib::Request& req,
                                                    httplib::Response& res, const std::string& id);

// A request whose weights are another rig's shapes ("vocabulary": RIG_ID) gets that rig from the
// store (ResolvePoint refuses the request at /vocabulary when there is none).
void AttachVocabulary(const ServerState& ctx, evaluator::MeshRequest& r);

// A JSON body parsed by `parse`; false when an error was sent (415, 400 malformed, 422 schema).
template <typename T, typename Parse>
bool ReadJsonBody(const httplib::Request& req, httplib::Response& res, Parse parse, T& out);

// Answers from the response cache, or with `produce()` (the encoded body), which is then offered
// to the cache under `key` (kept as `admit` says). A failed `produce` is sent as its Status.
template <typename Produce>
void SendCached(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                const std::string& key, const char* content_type, Admit admit, Produce produce);

// Work past this many bytes hands its freed memory back to the system (malloc_trim) when done.
inline constexpr size_t kLargeWork = size_t{64} << 20;
void ReturnMemory();

// The render budget's check before a render of `cells` images: false with a 413 sent when the
// request alone is over it (naming the fields to lower).
bool CheckRenderBudget(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                       const picture::RenderOptions& o, size_t cells);

// Runs `render` (which returns Result<Encoded>) within the budget: a 503 status with reason
// "busy" when no room was made in time; memory handed back to the system after large work.
template <typename Render>
Result<evaluator::Encoded> WithinRenderBudget(ServerState& ctx, size_t bytes, Render render);

// "blend;dur=0.31, draw;dur=10.2, encode;dur=4.1": the steps that ran (Server-Timing header).
std::string ServerTiming(const evaluator::Workspace::Timing& timing);

// The shared encoded bytes as the body, without a copy: the response holds the cache's entry
// until it is written.
void SendShared(httplib::Response& res, std::shared_ptr<const CachedResponse> enc);

// After the evaluator's first step (ResolvePoint): Facespace-Weight-Sum and Facespace-Warnings
// set, warnings counted; false when `status` is an error, which was sent (a strict refusal with
// its warnings).
bool ReportPoint(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                 const Status& status, double sum, std::span<const Warning> warnings);

// What an Authorization header's value says of this server's API key: the one reading of
// "Bearer KEY" for Authorized (which answers each refusal), CarriesKey and the front's deadline.
enum class KeyCheck { kNoKeyConfigured, kMissing, kNotBearer, kEmptyToken, kWrong, kRight };
KeyCheck CheckKey(const ApiOptions& options, std::string_view authorization);

// Whether the request carries this server's API key (Authorization: Bearer KEY); sends nothing.
bool CarriesKey(const ServerState& ctx, const httplib::Request& req);

// True when the request carries the API key; otherwise sends 401 or 403.
bool Authorized(const ServerState& ctx, const httplib::Request& req, httplib::Response& res);

// The CORS headers for an allowed Origin, and the answer to OPTIONS; true when it was answered.
bool PreRoute(const ServerState& ctx, const httplib::Request& req, httplib::Response& res);

}  // namespace facespace::http

#include "context_inl.h"
