// Prometheus counters: requests and latency by route label and status, blends, cache lookups,
// warnings by code. Route labels come from the route table (route_table.h).
#pragma once

#include <httplib.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "facespace/engine/status.h"

namespace facespace::http {

class Metrics {
 public:
  // `routes`: the labels, in the order route indices refer to; one more, "other", is added last.
  explicit Metrics(std::vector<std::string> routes);
  ~Metrics();

  size_t other_route() const { return labels_.size() - 1; }
  const std::vector<std::string>& labels() const { return labels_; }
  void Observe(size_t route, int status, double seconds);
  void CountWarnings(std::span<const Warning> warnings);
  void CountBlends(uint64_t n) { blends_.fetch_add(n, std::memory_order_relaxed); }
  void CountOverBudget() { over_budget_.fetch_add(1, std::memory_order_relaxed); }
  void CountCache(bool hit) {
    (hit ? cache_hits_ : cache_misses_).fetch_add(1, std::memory_order_relaxed);
  }

  // The Prometheus text of the counters; the gauges are the caller's.
  std::string Text(size_t rigs_loaded, size_t cache_bytes) const;

 private:
  struct RouteCounters;
  std::vector<std::string> labels_;
  std::unique_ptr<RouteCounters[]> routes_;
  std::atomic<uint64_t> blends_{0}, cache_hits_{0}, cache_misses_{0}, over_budget_{0};
  std::unique_ptr<std::atomic<uint64_t>[]> warnings_;
};

// Per-request state the hooks share, carried on the request (facespace/net/front.h,
// Running::state).
struct RequestState {
  std::chrono::steady_clock::time_point start;
  bool started = false;  // False for a request refused by the parser: its start is unknown.
  size_t route = 0;
};
RequestState& StateOf(const httplib::Request& req);

}  // namespace facespace::http
