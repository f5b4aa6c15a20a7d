// Carries a request's Running (facespace/net/front.h) on the request: cpp-httplib's Request has no
// slot of the server's, and its `progress` (a client's download callback) is never used by a
// server; what it holds is found again by its type (RunningOf). Called anyway, it would let the
// transfer go on.
#pragma once

#include <cstdint>

#include "facespace/net/front.h"

namespace facespace::net {

struct Carrier {
  Running* running;
  bool operator()(uint64_t, uint64_t) const { return true; }
};

}  // namespace facespace::net
