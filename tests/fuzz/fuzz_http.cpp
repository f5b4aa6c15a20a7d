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
#include "facespace/core/io.h"

namespace {

class MemoryStore : public facespace::api::RigStore {
 public:
  std::shared_ptr<const facespace::api::StoredRig> Get(const std::string& id) const override {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = rigs_.find(id);
    return it == rigs_.end() ? nullptr : it->second;
  }
  std::vector<std::shared_ptr<const facespace::api::StoredRig>> List() const override {
    std::lock_guard<std::mutex> lock(mu_);
    std::vector<std::shared_ptr<const facespace::api::StoredRig>> out;
    for (const auto& [id, r] : rigs_) out.push_back(r);
    return out;
  }
  facespace::Status Put(const std::string& id, std::span<const unsigned char> bytes, bool, bool* created) override {
    facespace::LoadOptions o;
    o.allow_external_files = false;
    o.read_manifest = false;
    auto rig = facespace::LoadGltfMemory(bytes, "", o);
    if (!rig.ok()) return rig.status();
    auto stored = std::make_shared<facespace::api::StoredRig>();
    stored->id = id;
    stored->rig = std::move(rig.value());
    stored->version = std::to_string(bytes.size());
    std::lock_guard<std::mutex> lock(mu_);
    *created = !rigs_.count(id);
    if (rigs_.size() < 4 || !*created) rigs_[id] = stored;  // Bounded, so a long run does not grow.
    return facespace::Status::Ok();
  }
  facespace::Status Delete(const std::string& id) override {
    std::lock_guard<std::mutex> lock(mu_);
    if (id == "facecap" || !rigs_.erase(id)) return facespace::NotFound("no rig");
    return facespace::Status::Ok();
  }
  void Seed() {
    auto rig = facespace::LoadRigFile(FACESPACE_SOURCE_DIR "/assets/facecap/facecap.glb");
    auto stored = std::make_shared<facespace::api::StoredRig>();
    stored->id = "facecap";
    stored->rig = std::move(rig.value());
    stored->version = "1";
    rigs_["facecap"] = stored;
  }

 private:
  mutable std::mutex mu_;
  std::map<std::string, std::shared_ptr<const facespace::api::StoredRig>> rigs_;
};

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
  MemoryStore store;
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
