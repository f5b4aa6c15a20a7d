// Fair shares of the workers (issue 61): which waiting request runs next, by client address. An
// address runs at most `per_address` requests at once; once only a quarter of the workers is left,
// only an address that runs nothing may start one, so a request from an address running nothing
// always finds a worker however many others keep theirs busy; when a request ends, the waiting
// address running fewest goes first. Requests that need a scarce resource (the renderer's GL
// contexts, the speech decoder) pass its gate first: at most the gate's cap of them hold a worker
// or a place in an address's line at once; the rest wait at the gate, in order, holding no worker
// (96 renders from six addresses had held every worker while they waited for 2 contexts). Not
// thread-safe: the front holds its lock around every call.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace facespace::net {

template <typename Item>
class FairTurns {
 public:
  // `gate_caps`: each scarce resource's gate, its cap.
  FairTurns(size_t workers, size_t per_address, const std::vector<size_t>& gate_caps = {})
      : workers_(std::max<size_t>(1, workers)), per_address_(std::max<size_t>(1, per_address)) {
    for (size_t cap : gate_caps) gates_.push_back({std::max<size_t>(1, cap), 0, {}});
  }

  // A request of `address` is whole (`gate`: the scarce resource it needs, or -1): true when it
  // starts now (counted as running), false when it waits.
  bool Arrive(const std::string& address, Item item, int gate = -1) {
    if (Gate* g = GateOf(gate)) {
      if (g->in >= g->cap) {
        g->waiting.push_back({address, item});
        return false;
      }
      ++g->in;
    }
    return Admit(address, item);
  }

  // One of `address`'s requests ended (`gate`: the one it passed, or -1): those that start now are
  // appended to `start` (counted as running).
  void End(const std::string& address, int gate, std::vector<Item>& start) {
    Release(address, start);
    Gate* g = GateOf(gate);
    if (!g) return;
    --g->in;
    while (!g->waiting.empty() && g->in < g->cap) {
      auto [from, item] = g->waiting.front();
      g->waiting.pop_front();
      ++g->in;
      if (Admit(from, item)) start.push_back(item);
    }
  }

  size_t running() const { return running_; }

 private:
  bool Admit(const std::string& address, Item item) {
    Address& a = addresses_[address];
    if (!a.waiting.empty() || !MayStart(a.running)) {
      a.waiting.push_back(item);
      ++waiting_;
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
    while (waiting_ > 0) {  // The scan over the addresses only when some request waits its turn.
      Address* next = nullptr;
      for (auto& [name, a] : addresses_) {
        if (!a.waiting.empty() && MayStart(a.running) && (!next || a.running < next->running))
          next = &a;
      }
      if (!next) return;
      start.push_back(next->waiting.front());
      next->waiting.pop_front();
      --waiting_;
      ++next->running;
      ++running_;
    }
  }

  struct Address {
    size_t running = 0;
    std::deque<Item> waiting;
  };
  struct Gate {
    size_t cap = 1, in = 0;  // Requests past it, on a worker or in an address's line.
    std::deque<std::pair<std::string, Item>> waiting;
  };
  Gate* GateOf(int gate) {
    return gate >= 0 && static_cast<size_t>(gate) < gates_.size()
               ? &gates_[static_cast<size_t>(gate)]
               : nullptr;
  }
  bool MayStart(size_t running) const {
    return running < per_address_ && (running == 0 || running_ + workers_ / 4 < workers_);
  }

  size_t workers_, per_address_;
  size_t running_ = 0;
  size_t waiting_ = 0;  // Requests in the addresses' lines, every address's.
  std::vector<Gate> gates_;
  std::unordered_map<std::string, Address> addresses_;
};

}  // namespace facespace::net
