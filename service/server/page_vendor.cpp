#include "server/page_vendor.h"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <string>

namespace facespace::cli {

namespace {

const char* TypeOf(const std::string& name) {
  if (name.ends_with(".js")) return "text/javascript; charset=utf-8";
  if (name.ends_with(".wasm")) return "application/wasm";
  return "application/octet-stream";
}

// A file of the package, read once (a few at most: the package's own names).
std::shared_ptr<const std::string> Read(const std::string& name) {
  static std::mutex mu;
  static std::map<std::string, std::shared_ptr<const std::string>> kept;
  std::lock_guard<std::mutex> lock(mu);
  if (auto it = kept.find(name); it != kept.end()) return it->second;
  const std::filesystem::path path =
      std::filesystem::path(FACESPACE_PAGE_MODULES) / "@mediapipe/face_mesh" / name;
  std::ifstream f(path, std::ios::binary);
  if (!f) return nullptr;
  auto bytes = std::make_shared<const std::string>(std::istreambuf_iterator<char>(f),
                                                   std::istreambuf_iterator<char>());
  kept[name] = bytes;
  return bytes;
}

}  // namespace

void ServeVendor(httplib::Server& server) {
  server.Get(R"(/vendor/face_mesh/([a-z_]{1,64}\.(js|wasm|data|binarypb)))",
             [](const httplib::Request& req, httplib::Response& res) {
               const std::string name = req.matches[1];
               const auto bytes = Read(name);
               if (!bytes) {
                 res.status = 404;  // Worded by the API's error handler, as problem+json.
                 return;
               }
               res.set_header("Cache-Control", "max-age=86400");
               res.set_content(*bytes, TypeOf(name));
             });
}

}  // namespace facespace::cli
