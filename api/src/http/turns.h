// Fair shares of the workers (issue 61): which waiting request runs next, by client address. An address
// runs at most `per_address` requests at once; once only a quarter of the workers is left, only an address
// that runs nothing may start one, so a request from an address running nothing always finds a worker
// however many others keep theirs busy; when a request ends, the waiting address running fewest goes first.
// Requests that need a scarce resource (the renderer's GL contexts) pass a gate first: at most `scarce_cap`
// of them hold a worker or a place in an address's line at once; the rest wait at the gate, in order,
// holding no worker (96 renders from six addresses had held every worker while they waited for 2 contexts).
// Not thread-safe: the front holds its lock around every call.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <deque>
#include <string>
#include <unordered_map>
#include <vector>

namespace facespace::api::http {

template <typename Item>
class FairTurns {
 public:
  FairTurns(size_t workers, size_t per_address, size_t scarce_cap = SIZE_MAX)
      : workers_(std::max<size_t>(1, workers)), per_address_(std::max<size_t>(1, per_address)), scarce_cap_(std::max<size_t>(1, scarce_cap)) {}

  // A request of `address` is whole: true when it starts now (counted as running), false when it waits.
  bool Arrive(const std::string& address, Item item, bool scarce = false) {
    if (scarce && scarce_in_ >= scarce_cap_) {
      gate_.push_back({address, item});
      return false;
    }
    scarce_in_ += scarce;
    return Admit(address, item);
  }

  // One of `address`'s requests ended (`scarce`: one that passed the gate): those that start now are
  // appended to `start` (counted as running).
  void End(const std::string& address, bool scarce, std::vector<Item>& start) {
    Release(address, start);
    if (!scarce) return;
    --scarce_in_;
    while (!gate_.empty() && scarce_in_ < scarce_cap_) {
      auto [from, item] = gate_.front();
      gate_.pop_front();
      ++scarce_in_;
      if (Admit(from, item)) start.push_back(item);
    }
  }

  size_t running() const { return running_; }

 private:
  bool Admit(const std::string& address, Item item) {
    Address& a = addresses_[address];
    if (!a.waiting.empty() || !MayStart(a.running)) {
      a.waiting.push_back(item);
      return false;
    }
    ++a.running;
    ++running_;
    return true;
  }

  void Release(const std::string& address, std::vector<Item>& start) {
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

  struct Address {
    size_t running = 0;
    std::deque<Item> waiting;
  };
  bool MayStart(size_t running) const { return running < per_address_ && (running == 0 || running_ + workers_ / 4 < workers_); }

  size_t workers_, per_address_, scarce_cap_;
  size_t running_ = 0, scarce_in_ = 0;
  std::deque<std::pair<std::string, Item>> gate_;
  std::unordered_map<std::string, Address> addresses_;
};

}  // namespace facespace::api::http
