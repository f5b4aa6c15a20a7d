// libFuzzer: a whole HTTP request through the connection front's framing and then the router
// (every route, the error handler, CORS, caching) with no socket: what the framing takes as one
// whole request (a chunked one made whole) is fed to cpp-httplib's request processing over an
// in-memory stream, as the front hands it to a worker. The framing found in two pieces must be the
// framing found at once. Rigs: FaceCap in a memory store that accepts uploads (key "fuzz-key").
#include <httplib.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <string_view>

#include "facespace/http/http.h"
#include "facespace/net/framing.h"
#include "facespace/offscreen/render.h"
#include "memory_store.h"

namespace {

class FuzzServer : public httplib::Server {
 public:
  void Process(const uint8_t* data, size_t size) {
    httplib::detail::BufferStream stream;
    stream.write(reinterpret_cast<const char*>(data), size);
    bool closed = false;
    process_request(stream, true, closed, [](httplib::Request&) {});
  }
};

struct Harness {
  facespace::test::MemoryStore store;
  facespace::offscreen::OsMesaRenderer renderer{1};
  facespace::evaluator::Evaluator evaluator{renderer};
  FuzzServer server;
  std::unique_ptr<facespace::http::Api> api;
  Harness() {
    store.Seed();
    facespace::http::ApiOptions o;
    o.api_key = "fuzz-key";
    o.cors_origins = {"http://front.test"};
    o.max_body = 1 << 20;
    o.cache_bytes = 1 << 20;
    o.log_requests = false;
    o.max_render_size = 32;  // Renders stay tiny: the fuzzer is after the parsing.
    api = std::make_unique<facespace::http::Api>(store, evaluator, o);
    api->Register(server);
  }
};

}  // namespace

namespace {

using facespace::net::ChunkedState;
using facespace::net::Framing;
using facespace::net::FramingError;
using facespace::net::HeadLimits;
using facespace::net::RequestHead;

// Where the first request in `bytes` ends as the front finds it, when it is whole: bytes given
// `split` at a time (0: at once).
Framing Frame(std::string_view bytes, size_t split, size_t& end, std::string& request) {
  HeadLimits limits;
  RequestHead head;
  FramingError error;
  ChunkedState chunked;
  size_t scan = 0, have = split ? std::min(split, bytes.size()) : bytes.size();
  bool in_body = false;
  while (true) {
    const std::string_view buf = bytes.substr(0, have);
    Framing f = Framing::kNeedMore;
    if (!in_body) {
      f = facespace::net::ParseHead(buf, scan, limits, head, error);
      if (f == Framing::kComplete) {
        in_body = true;
        chunked.pos = head.end;
      }
    }
    if (in_body) {
      if (head.chunked) {
        f = facespace::net::ParseChunked(buf, chunked, 1 << 20, error);
        end = chunked.pos;
      } else {
        f = buf.size() >= head.end + head.content_length ? Framing::kComplete : Framing::kNeedMore;
        end = head.end + head.content_length;
      }
    }
    if (f == Framing::kComplete) {  // As the front hands it on: a chunked body made whole.
      request = head.chunked ? facespace::net::Dechunked(bytes.substr(0, end), head)
                             : std::string(bytes.substr(0, end));
    }
    if (f != Framing::kNeedMore || have == bytes.size()) return f;
    have = std::min(bytes.size(), have + split);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Harness h;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  size_t end = 0, end_split = 0;
  std::string request, request_split;
  const Framing once = Frame(bytes, 0, end, request);
  const Framing pieces = Frame(bytes, 1 + size % 7, end_split, request_split);
  if (once != pieces ||
      (once == Framing::kComplete && (end != end_split || request != request_split)))
    __builtin_trap();
  if (once == Framing::kComplete)
    h.server.Process(reinterpret_cast<const uint8_t*>(request.data()), request.size());
  return 0;
}
