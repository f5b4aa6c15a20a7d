// What every route handler gets: the server's parts, owned by api::Api and passed down.
#pragma once

#include <httplib.h>

#include <array>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "cache.h"
#include "facespace/api/http.h"
#include "facespace/api/pipeline.h"
#include "metrics.h"

namespace facespace::api::http {

// Workspaces for the pipeline, reused across requests (no allocation per request once warm). A
// free list rather than thread_local: with a thread per keep-alive connection, per-thread
// buffers would grow with every thread that ever blended (half a megabyte each on the MakeHuman
// face); here the idle ones are capped.
class WorkspacePool {
 public:
  explicit WorkspacePool(size_t keep) : keep_(keep) {}
  struct Return {
    WorkspacePool* pool;
    void operator()(Workspace* ws) const;
  };
  using Lease = std::unique_ptr<Workspace, Return>;
  Lease Acquire();

 private:
  size_t keep_;
  std::mutex mu_;
  std::vector<std::unique_ptr<Workspace>> idle_;
};

// What the service derives from a stored rig, per level of detail: the simplified rig and the box
// its shapes act in. Made once per rig version and level and kept; a new version of a rig drops
// its older entries.
struct DerivedRig {
  std::shared_ptr<const Rig> rig;
  bool has_focus = false;
  bool focus_small = false;  // FrameShapesByDefault: renders frame the focus unless told "all".
  std::array<float, 3> focus_min{}, focus_max{};
};

class DerivedRigs {
 public:
  // nullptr when the level of detail cannot be made.
  std::shared_ptr<const DerivedRig> At(const std::shared_ptr<const StoredRig>& stored, int lod);
  // The rig at a level of detail: the stored rig itself at 0 (no lookup), else At(...)->rig.
  std::shared_ptr<const Rig> RigAt(const std::shared_ptr<const StoredRig>& stored, int lod);
  // Framing on the shapes: the camera gets the kept box instead of a per-render one.
  void SetFocus(const std::shared_ptr<const StoredRig>& stored, int lod, render::Camera& camera);

 private:
  std::mutex mu_;
  std::map<std::string, std::shared_ptr<const DerivedRig>> derived_;
};

// Values kept per rig while it lives: entries hold their rig weakly, and one whose rig died (a
// replaced or deleted rig, an evicted level of detail) is dropped, so a new rig at the same address
// never meets an old value. Not locked: its owner holds its own mutex around each call.
template <typename Value>
class PerRig {
 public:
  // The rig's value, or null when there is none (or only a dead rig's at its address).
  Value* Find(const std::shared_ptr<const Rig>& rig) {
    auto it = entries_.find(rig.get());
    return it != entries_.end() && it->second.rig.lock() == rig ? &it->second.value : nullptr;
  }
  // The rig's value, made empty when there was none; a new entry is the time to drop dead ones.
  Value& At(const std::shared_ptr<const Rig>& rig) {
    auto it = entries_.find(rig.get());
    if (it == entries_.end()) {
      std::erase_if(entries_, [](const auto& e) { return e.second.rig.expired(); });
      it = entries_.emplace(rig.get(), Entry{rig, Value{}}).first;
    } else if (it->second.rig.lock() != rig) {
      it->second = Entry{rig, Value{}};
    }
    return it->second.value;
  }

 private:
  struct Entry {
    std::weak_ptr<const Rig> rig;
    Value value;
  };
  std::map<const Rig*, Entry> entries_;
};

// Glb writers kept per rig (a GlbVariantWriter holds one rig's exported template), leased one per
// request; a writer is only handed out for the rig it was made for while that rig lives (PerRig).
class GlbWriters {
 public:
  class Lease {
   public:
    Lease(GlbWriters& pool, std::shared_ptr<const Rig> rig, std::unique_ptr<GlbVariantWriter> writer)
        : pool_(pool), rig_(std::move(rig)), writer_(std::move(writer)) {}
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    ~Lease() { pool_.Release(rig_, std::move(writer_)); }
    GlbVariantWriter* get() const { return writer_.get(); }

   private:
    GlbWriters& pool_;
    std::shared_ptr<const Rig> rig_;
    std::unique_ptr<GlbVariantWriter> writer_;
  };
  Lease Acquire(const std::shared_ptr<const Rig>& rig);

 private:
  static constexpr size_t kKeptPerRig = 4;
  void Release(const std::shared_ptr<const Rig>& rig, std::unique_ptr<GlbVariantWriter> writer);
  std::mutex mu_;
  PerRig<std::vector<std::unique_ptr<GlbVariantWriter>>> free_;
};

// Core's F32Blender of each rig and space the mesh route served as f32 (the rest body made once),
// held while the rig lives (PerRig).
class F32Blenders {
 public:
  std::shared_ptr<const F32Blender> Get(const std::shared_ptr<const Rig>& rig, bool mesh_space);

 private:
  std::mutex mu_;
  PerRig<std::array<std::shared_ptr<const F32Blender>, 2>> blenders_;  // World space, mesh space.
};

// Response bodies handed back when the last holder lets go (the response was sent, or the cache
// dropped it), for the next f32 body to be written over: a FaceCap body is 100 KB, and a new one
// per request cost an allocation and a copy of the whole rest body. A few of at most 1 MB are kept.
class BodyPool {
 public:
  std::string Take();
  void Give(std::string body);
  // An Encoded whose body comes back here when it is freed (if the pool still exists).
  static std::shared_ptr<Encoded> MakeEncoded(const std::shared_ptr<BodyPool>& pool);

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
  static size_t Estimate(const render::RenderOptions& o, size_t cells);
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

struct Context {
  Context(RigStore& s, JobQueue* j, const render::Renderer& r, ApiOptions o, std::vector<std::string> route_labels);

  RigStore& store;
  JobQueue* jobs;                   // Null: the batch and job routes answer 503.
  const render::Renderer& renderer;
  const ApiOptions options;
  Metrics metrics;
  ResponseCache cache;
  WorkspacePool workspaces;
  DerivedRigs derived;
  GlbWriters glb_writers;
  F32Blenders f32_blenders;
  const std::shared_ptr<BodyPool> bodies = std::make_shared<BodyPool>();
  RenderBudget render_budget;
  const std::string openapi;  // The document, with this server's limits.
};

// ---- helpers the routes share ----

// The stored rig named by the path, or nullptr with a 404 sent.
std::shared_ptr<const StoredRig> FindRig(Context& ctx, const httplib::Request& req, httplib::Response& res,
                                         const std::string& id);

// A JSON body parsed by `parse`; false when an error was sent (415, 400 malformed, 422 schema).
template <typename T, typename Parse>
bool ReadJsonBody(const httplib::Request& req, httplib::Response& res, Parse parse, T& out);

// Answers from the response cache, or with `produce()` (the encoded body), which is then offered
// to the cache under `key` (kept as `admit` says). A failed `produce` is sent as its Status.
template <typename Produce>
void SendCached(Context& ctx, const httplib::Request& req, httplib::Response& res, const std::string& key,
                const char* content_type, Admit admit, Produce produce);

// Work past this many bytes hands its freed memory back to the system (malloc_trim) when done.
inline constexpr size_t kLargeWork = size_t{64} << 20;
void ReturnMemory();

// The render budget's check before a render of `cells` images: false with a 413 sent when the
// request alone is over it (naming the fields to lower).
bool CheckRenderBudget(Context& ctx, const httplib::Request& req, httplib::Response& res, const render::RenderOptions& o,
                       size_t cells);

// Runs `render` (which returns Result<std::string>) within the budget: a 503 status with reason
// "busy" when no room was made in time; memory handed back to the system after large work.
template <typename Render>
Result<std::string> WithinRenderBudget(Context& ctx, size_t bytes, Render render);

// After the pipeline's first step: Facespace-Weight-Sum and Facespace-Warnings set, warnings
// counted; false when `status` is an error, which was sent (a strict refusal with its warnings).
// "blend;dur=0.31, draw;dur=10.2, encode;dur=4.1": the steps that ran (Server-Timing header).
std::string ServerTiming(const Workspace::Timing& timing);

// The shared encoded bytes as the body, without a copy: the response holds the cache's entry
// until it is written.
void SendShared(httplib::Response& res, std::shared_ptr<const Encoded> enc);

bool AnswerPoint(Context& ctx, const httplib::Request& req, httplib::Response& res, const Status& status, double sum,
                 std::span<const Warning> warnings);

// True when the request carries the API key; otherwise sends 401 or 403.
bool Authorized(const Context& ctx, const httplib::Request& req, httplib::Response& res);

// The CORS headers for an allowed Origin, and the answer to OPTIONS; true when it was answered.
bool PreRoute(const Context& ctx, const httplib::Request& req, httplib::Response& res);

}  // namespace facespace::api::http

#include "context_inl.h"
