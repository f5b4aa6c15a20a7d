#include "cache.h"

#include <cinttypes>
#include <cstdio>
#include <cstring>

namespace facespace::http {

std::shared_ptr<const CachedResponse> ResponseCache::Get(const std::string& key) {
  Shard& s = ShardOf(key);
  std::lock_guard<std::mutex> lock(s.mu);
  auto it = s.map.find(key);
  if (it == s.map.end()) return nullptr;
  s.lru.splice(s.lru.begin(), s.lru, it->second);
  return it->second->second;
}

void ResponseCache::Put(const std::string& key, std::shared_ptr<const CachedResponse> value) {
  const size_t size = value->body.size() + key.size();
  if (size > shard_cap_) return;
  Shard& s = ShardOf(key);
  std::lock_guard<std::mutex> lock(s.mu);
  if (s.map.count(key)) return;
  s.lru.emplace_front(key, std::move(value));
  s.map[key] = s.lru.begin();
  s.bytes += size;
  while (s.bytes > shard_cap_ && !s.lru.empty()) {
    auto& last = s.lru.back();
    s.bytes -= last.second->body.size() + last.first.size();
    s.map.erase(last.first);
    s.lru.pop_back();
  }
}

bool ResponseCache::SeenBefore(size_t hash) {
  const uint64_t tag = static_cast<uint64_t>(hash) | 1;  // Never 0, an empty slot.
  std::atomic<uint64_t>& slot =
      doorkeeper_[(hash >> 17) % kDoorkeeperSlots];  // Not the bits ShardOf uses.
  if (slot.load(std::memory_order_relaxed) == tag) {
    slot.store(0, std::memory_order_relaxed);
    return true;
  }
  slot.store(tag, std::memory_order_relaxed);
  return false;
}

bool ResponseCache::Offer(const std::string& key, std::shared_ptr<const CachedResponse> value,
                          Admit admit) {
  if (admit == Admit::kSecondRequest && !SeenBefore(std::hash<std::string>()(key))) return false;
  Put(key, std::move(value));
  return true;
}

size_t ResponseCache::Bytes() {
  size_t total = 0;
  for (Shard& s : shards_) {
    std::lock_guard<std::mutex> lock(s.mu);
    total += s.bytes;
  }
  return total;
}

namespace {

uint64_t Fnv1a(std::string_view s, uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

}  // namespace

bool NotModified(const httplib::Request& req, httplib::Response& res, const std::string& key) {
  char etag[19] = "\"0000000000000000\"";  // "%016" PRIx64 in quotes, by table.
  const uint64_t hash = Fnv1a(key);
  for (int i = 0; i < 16; ++i) etag[1 + i] = "0123456789abcdef"[(hash >> (60 - 4 * i)) & 15];
  res.set_header("ETag", etag);
  res.set_header("Cache-Control",
                 req.method == "GET" || req.method == "HEAD" ? "public, no-cache" : "no-store");
  res.set_header("Vary", "Accept");
  const std::string inm = req.get_header_value("If-None-Match");
  if (!inm.empty() && (inm == etag || inm == "*" || inm.find(etag) != std::string::npos)) {
    res.status = 304;
    return true;
  }
  return false;
}

}  // namespace facespace::http
