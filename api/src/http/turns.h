// Fair shares of the workers (issue 61): which waiting request runs next, by client address. An address
// runs at most `per_address` requests at once; once only a quarter of the workers is left, only an address
// that runs nothing may start one, so a request from an address running nothing always finds a worker
// however many others keep theirs busy; when a request ends, the waiting address running fewest goes first.
// Not thread-safe: the front holds its lock around every call.
#pragma once

#include <algorithm>
#include <cstddef>
#include <deque>
#include <string>
#include <unordered_map>
#include <vector>

namespace facespace::api::http {

template <typename Item>
class FairTurns {
 public:
  FairTurns(size_t workers, size_t per_address) : workers_(std::max<size_t>(1, workers)), per_address_(std::max<size_t>(1, per_address)) {}

  // A request of `address` is whole: true when it starts now (counted as running), false when it waits.
  bool Arrive(const std::string& address, Item item) {
    Address& a = addresses_[address];
    if (!a.waiting.empty() || !MayStart(a.running)) {
      a.waiting.push_back(item);
      return false;
    }
    ++a.running;
    ++running_;
    return true;
  }

  // One of `address`'s requests ended: those that start now are appended to `start` (counted as running).
  void End(const std::string& address, std::vector<Item>& start) {
    auto it = addresses_.find(address);
    if (it == addresses_.end()) return;
    --it->second.running;
    --running_;
    if (it->second.running == 0 && it->second.waiting.empty()) addresses_.erase(it);
    while (true) {
      Address* next = nullptr;
      for (auto& [name, a] : addresses_) {
        if (!a.waiting.empty() && MayStart(a.running) && (!next || a.running < next->running)) next = &a;
      }
      if (!next) return;
      start.push_back(next->waiting.front());
      next->waiting.pop_front();
      ++next->running;
      ++running_;
    }
  }

  size_t running() const { return running_; }

 private:
  struct Address {
    size_t running = 0;
    std::deque<Item> waiting;
  };
  bool MayStart(size_t running) const { return running < per_address_ && (running == 0 || running_ + workers_ / 4 < workers_); }

  size_t workers_, per_address_;
  size_t running_ = 0;
  std::unordered_map<std::string, Address> addresses_;
};

}  // namespace facespace::api::http
