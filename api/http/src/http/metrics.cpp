#include "metrics.h"

#include <malloc.h>

#include <any>
#include <cstdio>

#include "facespace/net/front.h"

namespace facespace::http {

namespace {

const int kStatuses[] = {200, 201, 202, 204, 304, 400, 401, 403, 404, 405,
                         406, 409, 413, 415, 422, 429, 500, 503, 507};
constexpr int kStatusCount = sizeof(kStatuses) / sizeof(kStatuses[0]);
const double kBuckets[] = {0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025,
                           0.05,   0.1,   0.25,   0.5,   1.0,  2.5};
constexpr int kBucketCount = sizeof(kBuckets) / sizeof(kBuckets[0]);
// The warnings about leaving the authored space, counted by code.
const char* const kWarningCodes[] = {"extrapolation", "out_of_range", "negative_weight",
                                     "absolute_sum"};
constexpr int kWarningCount = sizeof(kWarningCodes) / sizeof(kWarningCodes[0]);

}  // namespace

struct Metrics::RouteCounters {
  std::atomic<uint64_t> requests[kStatusCount + 1] = {};  // Last: other statuses.
  std::atomic<uint64_t> buckets[kBucketCount + 1] = {};
  std::atomic<uint64_t> count{0};
  std::atomic<uint64_t> sum_us{0};
};

RequestState& StateOf(const httplib::Request& req) {
  net::Running* running = net::RunningOf(req);
  if (!running) {
    // A request no front serves (the fuzzer's in-process server, one request at a time).
    static RequestState unserved;
    return unserved;
  }
  if (!running->state.has_value()) running->state.emplace<RequestState>();
  return *std::any_cast<RequestState>(&running->state);
}

Metrics::Metrics(std::vector<std::string> routes)
    : labels_(std::move(routes)), warnings_(new std::atomic<uint64_t>[kWarningCount]()) {
  labels_.push_back("other");
  routes_.reset(new RouteCounters[labels_.size()]);
}

Metrics::~Metrics() = default;

void Metrics::Observe(size_t route, int status, double seconds) {
  RouteCounters& r = routes_[route < labels_.size() ? route : other_route()];
  int s = kStatusCount;
  for (int i = 0; i < kStatusCount; ++i) {
    if (kStatuses[i] == status) s = i;
  }
  r.requests[s].fetch_add(1, std::memory_order_relaxed);
  int b = kBucketCount;
  for (int i = 0; i < kBucketCount; ++i) {
    if (seconds <= kBuckets[i]) {
      b = i;
      break;
    }
  }
  r.buckets[b].fetch_add(1, std::memory_order_relaxed);
  r.count.fetch_add(1, std::memory_order_relaxed);
  r.sum_us.fetch_add(static_cast<uint64_t>(seconds * 1e6), std::memory_order_relaxed);
}

void Metrics::CountWarnings(std::span<const Warning> warnings) {
  for (const Warning& w : warnings) {
    for (int i = 0; i < kWarningCount; ++i) {
      if (w.code == kWarningCodes[i]) warnings_[i].fetch_add(1, std::memory_order_relaxed);
    }
  }
}

std::string Metrics::Text(size_t rigs_loaded, size_t cache_bytes) const {
  std::string out;
  out += "# HELP facespace_http_requests_total HTTP requests by route and status.\n";
  out += "# TYPE facespace_http_requests_total counter\n";
  for (size_t r = 0; r < labels_.size(); ++r) {
    for (int s = 0; s <= kStatusCount; ++s) {
      const uint64_t v = routes_[r].requests[s].load(std::memory_order_relaxed);
      if (!v) continue;
      out += "facespace_http_requests_total{route=\"" + labels_[r] + "\",status=\"" +
             (s < kStatusCount ? std::to_string(kStatuses[s]) : std::string("other")) + "\"} " +
             std::to_string(v) + "\n";
    }
  }
  out += "# HELP facespace_http_request_duration_seconds Request latency by route.\n";
  out += "# TYPE facespace_http_request_duration_seconds histogram\n";
  for (size_t r = 0; r < labels_.size(); ++r) {
    const uint64_t count = routes_[r].count.load(std::memory_order_relaxed);
    if (!count) continue;
    const std::string label = "route=\"" + labels_[r] + "\"";
    uint64_t cum = 0;
    for (int b = 0; b <= kBucketCount; ++b) {
      cum += routes_[r].buckets[b].load(std::memory_order_relaxed);
      char le[32];
      if (b < kBucketCount)
        std::snprintf(le, sizeof le, "%g", kBuckets[b]);
      else
        std::snprintf(le, sizeof le, "+Inf");
      out += "facespace_http_request_duration_seconds_bucket{" + label + ",le=\"" + le + "\"} " +
             std::to_string(cum) + "\n";
    }
    char sum[32];
    std::snprintf(sum, sizeof sum, "%.6f", routes_[r].sum_us.load(std::memory_order_relaxed) / 1e6);
    out += "facespace_http_request_duration_seconds_sum{" + label + "} " + sum + "\n";
    out += "facespace_http_request_duration_seconds_count{" + label + "} " + std::to_string(count) +
           "\n";
  }
  out += "# HELP facespace_blends_total Rig evaluations (cache misses of the mesh route).\n";
  out += "# TYPE facespace_blends_total counter\nfacespace_blends_total " +
         std::to_string(blends_.load()) + "\n";
  out +=
      "# HELP facespace_requests_over_budget_total Requests refused before their work for their "
      "estimated cost (422 over-budget).\n";
  out +=
      "# TYPE facespace_requests_over_budget_total counter\nfacespace_requests_over_budget_total " +
      std::to_string(over_budget_.load()) + "\n";
  out += "# HELP facespace_cache_requests_total Encoded-response cache lookups.\n";
  out += "# TYPE facespace_cache_requests_total counter\n";
  out +=
      "facespace_cache_requests_total{result=\"hit\"} " + std::to_string(cache_hits_.load()) + "\n";
  out += "facespace_cache_requests_total{result=\"miss\"} " + std::to_string(cache_misses_.load()) +
         "\n";
  out +=
      "# HELP facespace_weight_warnings_total Warnings about leaving the authored space, by "
      "code.\n";
  out += "# TYPE facespace_weight_warnings_total counter\n";
  for (int i = 0; i < kWarningCount; ++i) {
    out += "facespace_weight_warnings_total{code=\"" + std::string(kWarningCodes[i]) + "\"} " +
           std::to_string(warnings_[i].load()) + "\n";
  }
  out += "# HELP facespace_rigs_loaded Rigs in the store.\n# TYPE facespace_rigs_loaded gauge\n";
  out += "facespace_rigs_loaded " + std::to_string(rigs_loaded) + "\n";
  out += "# HELP facespace_cache_bytes Bytes of encoded responses held by the response cache.\n";
  out += "# TYPE facespace_cache_bytes gauge\nfacespace_cache_bytes " +
         std::to_string(cache_bytes) + "\n";
  // The allocator's view (glibc): what is allocated and not freed, and what was freed but kept.
  // Heap in use flat while RSS moves is fragmentation; heap in use growing is a leak.
  const struct mallinfo2 mi = mallinfo2();
  out +=
      "# HELP facespace_heap_in_use_bytes Heap bytes allocated and not yet freed (malloc arenas "
      "and mmapped blocks).\n";
  out += "# TYPE facespace_heap_in_use_bytes gauge\nfacespace_heap_in_use_bytes " +
         std::to_string(mi.uordblks + mi.hblkhd) + "\n";
  out += "# HELP facespace_heap_free_bytes Heap bytes freed but kept by the allocator for reuse.\n";
  out += "# TYPE facespace_heap_free_bytes gauge\nfacespace_heap_free_bytes " +
         std::to_string(mi.fordblks) + "\n";
  return out;
}

}  // namespace facespace::http
