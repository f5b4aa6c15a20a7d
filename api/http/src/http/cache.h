// The encoded-response cache (keyed by the evaluator's CacheKey), and ETags from those keys.
#pragma once

#include <httplib.h>

#include <array>
#include <atomic>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "facespace/evaluator/evaluator.h"

namespace facespace::http {

// A response body as the cache keeps it, shared with the responses sending it.
struct CachedResponse {
  std::string body;
  std::string content_type;
};

// When a response is kept: at once (what is dear to make: renders, sheets), or only when its key
// comes a second time (what is cheap to make again: meshes, 0.03-0.3 ms for FaceCap).
enum class Admit { kFirstRequest, kSecondRequest };

// An LRU cache of encoded responses, sharded so concurrent requests rarely share a lock.
//
// A doorkeeper remembers the hashes of recent keys offered with Admit::kSecondRequest. Kept at
// once, every random point's 104 KB f32 body went into 64 MB that no cache level holds, so each
// response was written to and sent from cold memory and pushed out an older entry: the mesh
// route's server CPU per request was 15-25% higher than with no cache at all.
class ResponseCache {
 public:
  explicit ResponseCache(size_t cap_bytes) : shard_cap_(cap_bytes / kShards) {}
  std::shared_ptr<const CachedResponse> Get(const std::string& key);
  // Keeps `value` under `key` as `admit` says; true when kept.
  bool Offer(const std::string& key, std::shared_ptr<const CachedResponse> value, Admit admit);
  size_t Bytes();  // Bodies and keys held, for /metrics.

 private:
  void Put(const std::string& key, std::shared_ptr<const CachedResponse> value);
  // True when the key's hash was seen before (and is now forgotten); else remembers it.
  bool SeenBefore(size_t hash);
  static constexpr size_t kShards = 16;
  static constexpr size_t kDoorkeeperSlots = 1 << 14;  // Hashes, direct-mapped: 128 KB.
  std::unique_ptr<std::atomic<uint64_t>[]> doorkeeper_ =
      std::make_unique<std::atomic<uint64_t>[]>(kDoorkeeperSlots);
  using Entry = std::pair<std::string, std::shared_ptr<const CachedResponse>>;
  struct Shard {
    std::mutex mu;
    std::list<Entry> lru;
    std::unordered_map<std::string, std::list<Entry>::iterator> map;
    size_t bytes = 0;
  };
  Shard& ShardOf(const std::string& key) {
    return shards_[std::hash<std::string>()(key) % kShards];
  }
  size_t shard_cap_;
  std::array<Shard, kShards> shards_;
};

// ETag from the key, Cache-Control and Vary; true when If-None-Match matched and a 304 was set.
bool NotModified(const httplib::Request& req, httplib::Response& res, const std::string& key);

}  // namespace facespace::http
