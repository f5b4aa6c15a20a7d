// A connection as the front holds it (front.cpp), and the socket helpers the front uses (conn.cpp).
#pragma once

#include <atomic>
#include <string>
#include <string_view>

#include "facespace/net/framing.h"
#include "facespace/net/front.h"
#include "in_flight.h"

namespace facespace::net {

struct Conn : Peer {
  enum class State { kIdle, kHead, kBody, kBusy, kLinger };
  std::string buf;
  // Busy: a worker owns the connection (the front touches nothing of it but this); the worker's
  // writes before its store of another state are seen by the front's load of it.
  std::atomic<State> state{State::kIdle};
  RequestHead head;
  size_t head_scan = 0;
  ChunkedState chunked;
  size_t request_end = 0;
  Clock::time_point deadline;
  size_t served = 0;
  size_t reserved = 0;  // Bytes counted in the body budget.
  bool sent_continue = false;
  bool close_after = false;  // Set by the worker.
  bool keyed = false;        // The request carries the API key (its deadline is the keyed one).
  int gate = -1;             // The scarce resource's gate it passed (FrontOptions::scarce), or -1.
  // Set by a handler (UpgradeConnection): the head that answers instead, and who takes the socket
  // after.
  std::string upgrade_head;
  UpgradeTaker upgrade_take;
};

// The address and port of the socket's peer (`peer`) or its own end; left as they are when unknown.
void Address(int fd, bool peer, std::string& ip, int& port);
// Writes what it can at once (the socket is non-blocking); the front never waits on a client.
void SendNow(int fd, std::string_view bytes);

// Calls fn(name, value) for each field of the head as it came (values without surrounding blanks)
// until fn returns true; no allocation.
template <typename Fn>
void ForEachField(const Conn& c, Fn fn) {
  const std::string_view head(c.buf.data() + c.head.start, c.head.end - c.head.start);
  for (size_t pos = head.find("\r\n"); pos != std::string_view::npos && pos + 2 < head.size();) {
    pos += 2;
    const size_t eol = head.find("\r\n", pos);
    const std::string_view field =
        head.substr(pos, eol == std::string_view::npos ? std::string_view::npos : eol - pos);
    if (const size_t colon = field.find(':'); colon != std::string_view::npos) {
      std::string_view value = field.substr(colon + 1);
      while (!value.empty() && (value.front() == ' ' || value.front() == '\t'))
        value.remove_prefix(1);
      while (!value.empty() && (value.back() == ' ' || value.back() == '\t'))
        value.remove_suffix(1);
      if (fn(field.substr(0, colon), value)) return;
    }
    pos = eol;
  }
}

// The value of the head's first field `name`, or empty.
inline std::string_view HeaderValue(const Conn& c, std::string_view name) {
  std::string_view found;
  ForEachField(c, [&](std::string_view field, std::string_view value) {
    return EqualsIgnoreCase(field, name) && (found = value, true);
  });
  return found;
}

}  // namespace facespace::net
