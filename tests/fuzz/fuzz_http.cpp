// libFuzzer: a whole HTTP request through the router (every route, the error handler, CORS,
// caching) with no socket: the request is fed to cpp-httplib's request processing over an
// in-memory stream. Rigs: FaceCap in a memory store that accepts uploads (key "fuzz-key").
#include <httplib.h>

#include <cstddef>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>

#include "facespace/api/http.h"
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
  facespace::render::OsMesaRenderer renderer{1};
  FuzzServer server;
  std::unique_ptr<facespace::api::Api> api;
  Harness() {
    store.Seed();
    facespace::api::ApiOptions o;
    o.api_key = "fuzz-key";
    o.cors_origins = {"http://front.test"};
    o.max_body = 1 << 20;
    o.cache_bytes = 1 << 20;
    o.log_requests = false;
    o.max_render_size = 32;  // Renders stay tiny: the fuzzer is after the parsing.
    api = std::make_unique<facespace::api::Api>(store, renderer, o);
    api->Register(server);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Harness h;
  h.server.Process(data, size);
  return 0;
}
