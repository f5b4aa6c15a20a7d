#include "facespace/api/http.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <list>
#include <malloc.h>
#include <map>
#include <mutex>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>
#include <unordered_map>

#include "facespace/api/request.h"
#include "facespace/core/blend.h"
#include "facespace/core/fit.h"
#include "facespace/core/io.h"
#include "facespace/core/lod.h"
#include "facespace/core/sequence.h"
#include "facespace/core/shape_tools.h"
#include "facespace/core/skeleton.h"
#include "facespace/core/weights.h"
#include "facespace/render/render.h"
#include "zip.h"

namespace facespace::api {

namespace {

using nlohmann::json;
using httplib::Request;
using httplib::Response;

// ---- routes and metrics -------------------------------------------------------------------

enum Route : int { kHealthz, kReadyz, kMetrics, kOpenApi, kRigs, kRig, kMesh, kCheck, kRender, kSheet, kSequence, kFit, kBatch, kJobs, kJob, kJobFiles, kOther, kRouteCount };
const char* const kRouteNames[kRouteCount] = {"/healthz", "/readyz", "/metrics", "/openapi.json", "/v1/rigs",
                                              "/v1/rigs/{id}", "/v1/rigs/{id}/mesh", "/v1/rigs/{id}/check",
                                              "/v1/rigs/{id}/render", "/v1/rigs/{id}/sheet", "/v1/rigs/{id}/sequence/*",
                                              "/v1/rigs/{id}/fit", "/v1/rigs/{id}/batch", "/v1/jobs", "/v1/jobs/{job}",
                                              "/v1/jobs/{job}/*", "other"};
const int kStatuses[] = {200, 201, 202, 204, 304, 400, 401, 403, 404, 405, 406, 409, 413, 415, 422, 429, 500, 503, 507};
constexpr int kStatusCount = sizeof(kStatuses) / sizeof(kStatuses[0]);
const double kBuckets[] = {0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5};
constexpr int kBucketCount = sizeof(kBuckets) / sizeof(kBuckets[0]);
const char* const kWarningCodes[] = {"extrapolation", "out_of_range", "negative_weight", "absolute_sum"};
constexpr int kWarningCount = 4;

struct Metrics {
  std::atomic<uint64_t> requests[kRouteCount][kStatusCount + 1] = {};  // Last column: other statuses.
  std::atomic<uint64_t> latency_buckets[kRouteCount][kBucketCount + 1] = {};
  std::atomic<uint64_t> latency_count[kRouteCount] = {};
  std::atomic<uint64_t> latency_sum_us[kRouteCount] = {};
  std::atomic<uint64_t> blends{0};
  std::atomic<uint64_t> cache_hits{0};
  std::atomic<uint64_t> cache_misses{0};
  std::atomic<uint64_t> warnings[kWarningCount] = {};

  void Observe(int route, int status, double seconds) {
    int s = kStatusCount;
    for (int i = 0; i < kStatusCount; ++i) {
      if (kStatuses[i] == status) s = i;
    }
    requests[route][s].fetch_add(1, std::memory_order_relaxed);
    int b = kBucketCount;
    for (int i = 0; i < kBucketCount; ++i) {
      if (seconds <= kBuckets[i]) {
        b = i;
        break;
      }
    }
    latency_buckets[route][b].fetch_add(1, std::memory_order_relaxed);
    latency_count[route].fetch_add(1, std::memory_order_relaxed);
    latency_sum_us[route].fetch_add(static_cast<uint64_t>(seconds * 1e6), std::memory_order_relaxed);
  }
};

// Per-request state that hooks share on the worker thread serving the request.
struct RequestState {
  std::chrono::steady_clock::time_point start;
  int route = kOther;
};
thread_local RequestState t_request;

// ---- blend scratch ------------------------------------------------------------------------

// What a blend writes into: the evaluated rig and the kernel's scratch, reused across requests
// (no allocation per request once warm). A free list rather than thread_local: with a thread
// per keep-alive connection, per-thread buffers would grow with every thread that ever blended
// (half a megabyte each on the MakeHuman face); here the idle ones are capped.
struct Scratch {
  BlendContext context;
  BlendedRig blended;
};

struct ScratchPool {
  std::mutex mu;
  std::vector<std::unique_ptr<Scratch>> idle;
};

ScratchPool& Scratches() {
  static ScratchPool pool;
  return pool;
}

struct ReturnScratch {
  void operator()(Scratch* s) const {
    static const size_t keep = 2 * std::max(2u, std::thread::hardware_concurrency());  // Asked once: a syscall.
    std::unique_ptr<Scratch> owned(s);
    ScratchPool& pool = Scratches();
    std::lock_guard lock(pool.mu);
    if (pool.idle.size() < keep) pool.idle.push_back(std::move(owned));
  }
};
using ScratchLease = std::unique_ptr<Scratch, ReturnScratch>;

ScratchLease LeaseScratch() {
  ScratchPool& pool = Scratches();
  {
    std::lock_guard lock(pool.mu);
    if (!pool.idle.empty()) {
      ScratchLease s(pool.idle.back().release());
      pool.idle.pop_back();
      return s;
    }
  }
  return ScratchLease(new Scratch);
}

// ---- encoded-response cache ----------------------------------------------------------------

struct Encoded {
  std::string body;
  std::string content_type;
};

// An LRU cache of encoded responses, sharded so concurrent requests rarely share a lock.
class ResponseCache {
 public:
  explicit ResponseCache(size_t cap_bytes) : shard_cap_(cap_bytes / kShards) {}

  std::shared_ptr<const Encoded> Get(const std::string& key) {
    Shard& s = ShardOf(key);
    std::lock_guard<std::mutex> lock(s.mu);
    auto it = s.map.find(key);
    if (it == s.map.end()) return nullptr;
    s.lru.splice(s.lru.begin(), s.lru, it->second);
    return it->second->second;
  }

  void Put(const std::string& key, std::shared_ptr<const Encoded> value) {
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

  // Bytes held (bodies and keys), for /metrics.
  size_t Bytes() {
    size_t total = 0;
    for (Shard& s : shards_) {
      std::lock_guard<std::mutex> lock(s.mu);
      total += s.bytes;
    }
    return total;
  }

 private:
  static constexpr size_t kShards = 16;
  using Entry = std::pair<std::string, std::shared_ptr<const Encoded>>;
  struct Shard {
    std::mutex mu;
    std::list<Entry> lru;
    std::unordered_map<std::string, std::list<Entry>::iterator> map;
    size_t bytes = 0;
  };
  Shard& ShardOf(const std::string& key) { return shards_[std::hash<std::string>()(key) % kShards]; }
  size_t shard_cap_;
  std::array<Shard, kShards> shards_;
};

// ---- helpers -------------------------------------------------------------------------------

uint64_t Fnv1a(std::string_view s, uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

std::string Hex64(uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016" PRIx64, v);
  return buf;
}

const char* ReasonPhrase(int status) {
  switch (status) {
    case 400: return "Bad Request";
    case 401: return "Unauthorized";
    case 403: return "Forbidden";
    case 404: return "Not Found";
    case 405: return "Method Not Allowed";
    case 406: return "Not Acceptable";
    case 409: return "Conflict";
    case 413: return "Content Too Large";
    case 415: return "Unsupported Media Type";
    case 422: return "Unprocessable Content";
    case 429: return "Too Many Requests";
    case 500: return "Internal Server Error";
    case 503: return "Service Unavailable";
    case 507: return "Insufficient Storage";
  }
  return "Error";
}

// RFC 9457 problem details. Field errors whose pointer starts with '?' name a query
// parameter ({"parameter": ...}); the others are JSON Pointers into the body.
void SendProblem(const Request& req, Response& res, int status, const std::string& slug, const std::string& detail,
                 const std::vector<FieldError>& fields = {}, const std::string& warnings_json = "") {
  json p = {{"type", "urn:facespace:problem:" + slug},
            {"title", ReasonPhrase(status)},
            {"status", status},
            {"detail", detail},
            {"instance", req.path}};
  if (!fields.empty()) {
    json errors = json::array();
    for (const FieldError& f : fields) {
      if (!f.pointer.empty() && f.pointer[0] == '?') errors.push_back({{"parameter", f.pointer.substr(1)}, {"detail", f.message}});
      else errors.push_back({{"pointer", f.pointer}, {"detail", f.message}});
    }
    p["errors"] = errors;
  }
  if (!warnings_json.empty()) p["warnings"] = json::parse(warnings_json);
  res.status = status;
  res.set_content(p.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace), "application/problem+json");
}

void SendJson(Response& res, int status, const json& body) {
  res.status = status;
  res.set_content(body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace), "application/json");
}

// sf-string (RFC 9651): printable ASCII, with \ and " escaped; other bytes become '?'.
std::string SfString(const std::string& s) {
  std::string out = "\"";
  for (unsigned char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20 || c > 0x7e) {
      out += '?';
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + "\"";
}

// sf-decimal: at most 12 integer and 3 fractional digits.
std::string SfDecimal(double v) {
  if (!std::isfinite(v)) v = 0;
  v = std::max(-999999999999.0, std::min(999999999999.0, v));
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  std::string s = buf;
  while (s.size() > 1 && s.back() == '0' && s[s.size() - 2] != '.') s.pop_back();
  return s;
}

// Facespace-Warnings: a structured-field list, e.g.
//   extrapolation;value=1.7, out_of_range;shape="jawOpen";value=1.5
std::string WarningsHeader(const std::vector<Warning>& warnings) {
  std::string h;
  for (const Warning& w : warnings) {
    if (!h.empty()) h += ", ";
    h += w.code;
    if (!w.shape.empty()) h += ";shape=" + SfString(w.shape);
    if (w.has_value) h += ";value=" + SfDecimal(w.value);
  }
  return h;
}

bool ConstantTimeEquals(const std::string& a, const std::string& b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  const size_t n = std::max(a.size(), b.size());
  for (size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    diff |= static_cast<unsigned char>(x ^ y);
  }
  return diff == 0;
}

std::string_view TrimSpaces(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// The media type of a Content-Type value or of one Accept item, lowercased, without parameters.
std::string MediaType(std::string_view header) {
  std::string t(TrimSpaces(header.substr(0, header.find(';'))));
  for (char& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return t;
}

// The media types an Accept header lists, lowercased, most preferred first: by quality (q), then
// in the order given. Types with q=0 ("not acceptable", RFC 9110 12.5.1) are left out; a q that
// is not a number counts as 1.
std::vector<std::string> AcceptedTypes(std::string_view accept) {
  struct Item {
    std::string type;
    double q;
  };
  std::vector<Item> items;
  size_t start = 0;
  while (start <= accept.size()) {
    size_t end = accept.find(',', start);
    if (end == std::string_view::npos) end = accept.size();
    const std::string_view item = accept.substr(start, end - start);
    start = end + 1;
    std::string type = MediaType(item);
    size_t semi = item.find(';');
    double q = 1;
    while (semi != std::string_view::npos) {
      const size_t next = item.find(';', semi + 1);
      const std::string_view param = TrimSpaces(item.substr(semi + 1, next == std::string_view::npos ? next : next - semi - 1));
      if (param.size() > 2 && (param[0] == 'q' || param[0] == 'Q') && param[1] == '=') {
        double v = 1;
        const auto r = std::from_chars(param.data() + 2, param.data() + param.size(), v);
        q = r.ec == std::errc() ? v : 1;
      }
      semi = next;
    }
    if (!type.empty() && q > 0) items.push_back({std::move(type), q});
  }
  std::stable_sort(items.begin(), items.end(), [](const Item& a, const Item& b) { return a.q > b.q; });
  std::vector<std::string> types;
  types.reserve(items.size());
  for (Item& i : items) types.push_back(std::move(i.type));
  return types;
}

// The value of the most preferred type in `accept` that `produced` lists; `fallback` for no Accept
// header; false when it names only types we cannot produce.
template <typename T, size_t N>
bool PickFromAccept(const std::string& accept, const std::pair<std::string_view, T> (&produced)[N], T fallback, T* out) {
  if (accept.empty()) {
    *out = fallback;
    return true;
  }
  for (const std::string& type : AcceptedTypes(accept)) {
    for (const auto& [name, value] : produced) {
      if (type == name) {
        *out = value;
        return true;
      }
    }
  }
  return false;
}

// The mesh format an Accept header asks for.
bool FormatFromAccept(const std::string& accept, MeshFormat* format) {
  static constexpr std::pair<std::string_view, MeshFormat> kProduced[] = {
      {"model/gltf-binary", MeshFormat::kGlb}, {"model/obj", MeshFormat::kObj},
      {"application/json", MeshFormat::kJson}, {"application/octet-stream", MeshFormat::kF32},
      {"*/*", MeshFormat::kJson},              {"model/*", MeshFormat::kJson},
      {"application/*", MeshFormat::kJson}};
  return PickFromAccept(accept, kProduced, MeshFormat::kJson, format);
}

// The image format an Accept header asks for.
bool ImageFormatFromAccept(const std::string& accept, render::ImageFormat* format) {
  using render::ImageFormat;
  static constexpr std::pair<std::string_view, ImageFormat> kProduced[] = {
      {"image/png", ImageFormat::kPng},   {"image/*", ImageFormat::kPng},    {"*/*", ImageFormat::kPng},
      {"image/jpeg", ImageFormat::kJpeg}, {"image/x-exr", ImageFormat::kExr}, {"image/aces", ImageFormat::kExr},
      {"image/tiff", ImageFormat::kTiff}};
  return PickFromAccept(accept, kProduced, ImageFormat::kPng, format);
}

std::string FloatsCanonical(std::span<const float> v) {
  std::string s;
  for (float f : v) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%a,", static_cast<double>(f));
    s += buf;
  }
  return s;
}

std::string RenderCanonical(const api::RenderRequest& r, render::ImageFormat format) {
  const render::RenderOptions& o = r.render;
  const render::Camera& c = o.camera;
  return std::string(render::ImageFormatExtension(format)) + "|q" + std::to_string(r.quality) + "|" +
         std::to_string(o.width) + "x" + std::to_string(o.height) + "|" + render::ViewName(o.view) + "|ss" +
         std::to_string(o.supersample) + "|" + FloatsCanonical(o.background) + "|" +
         FloatsCanonical(std::array<float, 5>{c.yaw, c.pitch, c.distance, c.zoom, c.fov}) + (c.look_at ? "L" : "O") +
         (c.frame_shapes ? "S" : "A") +
         (c.look_at ? FloatsCanonical(c.eye) + FloatsCanonical(c.target) + FloatsCanonical(c.up) : "") + "|" +
         (r.mesh.options.mode == BlendMode::kAbsolute ? "abs" : "rel") + "|" +
         (r.mesh.options.normals == NormalMode::kRecompute ? "rec" : "bl") + (r.mesh.options.dual_quaternion ? "|dq" : "");
}

// The evaluated pose, bit for bit ("" for the rest pose).
std::string PoseCanonical(const Pose& pose, bool posed) {
  if (!posed) return "";
  std::string s = "|pose:";
  for (size_t i = 0; i < pose.local.size(); ++i) {
    if (pose.from_matrix[i]) {
      s += "m,";
      continue;
    }
    const Transform& t = pose.local[i];
    s += FloatsCanonical(t.translation) + FloatsCanonical(t.rotation) + FloatsCanonical(t.scale);
  }
  return s;
}

std::string WeightsCanonical(std::span<const float> w) {
  std::string s;
  s.reserve(w.size() * 8);
  for (float f : w) {
    uint32_t bits;
    std::memcpy(&bits, &f, 4);
    if (f == 0.0f) bits = 0;  // -0 and 0 are the same weight.
    char buf[9];
    std::snprintf(buf, sizeof buf, "%08x", bits);
    s += buf;
  }
  return s;
}

json RigSummary(const StoredRig& s) {
  const Rig& r = s.rig;
  return {{"id", s.id},           {"name", r.name},
          {"vertices", r.vertex_count()}, {"triangles", r.triangle_count()},
          {"shapes", r.shapes.size()},    {"primitives", r.primitives.size()},
          {"has_skeleton", r.skin_count > 0}, {"version", s.version}};
}

json RigDetail(const StoredRig& s) {
  const Rig& r = s.rig;
  json j = RigSummary(s);
  json shapes = json::array();
  for (size_t i = 0; i < r.shapes.size(); ++i) {
    const Shape& sh = r.shapes[i];
    json o = {{"index", i}, {"name", sh.name}, {"group", sh.group}, {"min", sh.min}, {"max", sh.max},
              {"default", sh.default_weight}, {"vertices_moved", sh.vertices_moved}};
    o["partner"] = sh.partner >= 0 ? json(r.shapes[sh.partner].name) : json(nullptr);
    o["aliases"] = sh.aliases;
    o["driven"] = sh.driven;
    shapes.push_back(o);
  }
  j["shapes"] = shapes;
  // What the manifest says beyond the shapes: in-betweens, correctives, statistics.
  json inbetweens = json::array();
  for (const InBetweens& ib : r.inbetweens) {
    json keys = json::array();
    for (const auto& [w, shape] : ib.keys) keys.push_back({{"shape", r.shapes[shape].name}, {"weight", w}});
    inbetweens.push_back({{"slider", r.shapes[ib.slider].name}, {"keys", keys}});
  }
  j["inbetweens"] = inbetweens;
  json correctives = json::array();
  for (const Corrective& c : r.correctives) {
    json drivers = json::array();
    for (uint32_t d : c.drivers) drivers.push_back(r.shapes[d].name);
    correctives.push_back({{"shape", r.shapes[c.shape].name}, {"drivers", drivers}, {"mode", c.use_min ? "min" : "product"}});
  }
  j["correctives"] = correctives;
  json controls = json::array();
  for (const Control& c : r.controls) {
    controls.push_back({{"name", c.name}, {"group", c.group}, {"min", c.min}, {"max", c.max},
                        {"negative", c.negative >= 0 ? json(r.shapes[c.negative].name) : json(nullptr)},
                        {"positive", r.shapes[c.positive].name},
                        {"partner", c.partner >= 0 ? json(r.controls[c.partner].name) : json(nullptr)}});
  }
  j["controls"] = controls;
  j["statistics"] = r.statistics.present ? json{{"components", r.statistics.components.size()}, {"bound", r.statistics.bound}} : json(nullptr);
  // Bounding box of the base mesh as shown (world space, every primitive).
  const auto world = PrimitiveWorldMatrices(r);
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  json prims = json::array();
  for (size_t p = 0; p < r.primitives.size(); ++p) {
    const Primitive& pr = r.primitives[p];
    const auto& m = world[p];
    for (size_t v = 0; v < pr.positions.size(); v += 3) {
      for (int c = 0; c < 3; ++c) {
        const float x = m[c] * pr.positions[v] + m[4 + c] * pr.positions[v + 1] + m[8 + c] * pr.positions[v + 2] + m[12 + c];
        lo[c] = std::min(lo[c], x);
        hi[c] = std::max(hi[c], x);
      }
    }
    prims.push_back({{"mesh", pr.mesh}, {"primitive", pr.index_in_mesh}, {"name", r.meshes[pr.mesh].name},
                     {"vertices", pr.vertex_count()}, {"triangles", pr.triangle_count()}, {"material", pr.material},
                     {"has_normals", pr.source_has_normals}, {"has_tangents", !pr.tangents.empty()}});
  }
  j["primitives"] = prims;
  j["bounding_box"] = r.primitives.empty() ? json(nullptr)
                                            : json({{"min", {lo[0], lo[1], lo[2]}}, {"max", {hi[0], hi[1], hi[2]}}});
  if (r.skins.empty()) {
    j["skeleton"] = nullptr;
  } else {
    json skins = json::array();
    for (const Skin& sk : r.skins) {
      json joints = json::array();
      for (int n : sk.joints) joints.push_back({{"node", n}, {"name", r.nodes[n].name}, {"parent", r.nodes[n].parent}});
      skins.push_back({{"name", sk.name}, {"joints", joints}});
    }
    j["skeleton"] = {{"skins", skins}, {"joints", r.joint_count}};
  }
  json anims = json::array();
  for (size_t a = 0; a < r.animations.size(); ++a) {
    const AnimationInfo& an = r.animations[a];
    anims.push_back({{"index", a}, {"name", an.name}, {"duration", an.duration}, {"channels", an.channels},
                     {"morph_weights", an.has_weights}});
  }
  j["animations"] = anims;
  j["load_warnings"] = json::parse(WarningsToJson(r.load_warnings));
  return j;
}

bool ParseNumber(const std::string& s, double* out) {
  if (s.empty() || s.size() > 64) return false;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || errno == ERANGE) return false;
  *out = v;
  return true;
}

bool ParseBool(const std::string& s, bool* out) {
  if (s == "true" || s == "1") *out = true;
  else if (s == "false" || s == "0") *out = false;
  else return false;
  return true;
}

}  // namespace

// ---- the API -------------------------------------------------------------------------------

struct Api::Impl {
  RigStore& store;
  ApiOptions options;
  JobQueue* jobs;
  Metrics metrics;
  ResponseCache cache;

  Impl(RigStore& s, ApiOptions o, JobQueue* j) : store(s), options(std::move(o)), jobs(j), cache(options.cache_bytes) {}

  bool OriginAllowed(const std::string& origin) const {
    for (const std::string& o : options.cors_origins) {
      if (o == "*" || o == origin) return true;
    }
    return false;
  }

  // True when the request carries the API key; otherwise sends 401/403.
  bool Authorized(const Request& req, Response& res) {
    if (options.api_key.empty()) {
      SendProblem(req, res, 403, "uploads-disabled", "this server has no API key configured: uploads and deletes are disabled");
      return false;
    }
    const std::string auth = req.get_header_value("Authorization");
    if (auth.empty()) {
      res.set_header("WWW-Authenticate", "Bearer realm=\"facespace\"");
      SendProblem(req, res, 401, "unauthorized", "this route needs the API key: Authorization: Bearer KEY");
      return false;
    }
    const std::string prefix = "Bearer ";
    if (auth.size() < prefix.size() || !std::equal(prefix.begin(), prefix.end(), auth.begin(), [](char a, char b) {
          return std::tolower(static_cast<unsigned char>(a)) == std::tolower(static_cast<unsigned char>(b));
        })) {
      res.set_header("WWW-Authenticate", "Bearer realm=\"facespace\"");
      SendProblem(req, res, 401, "unauthorized", "the Authorization header must use the Bearer scheme");
      return false;
    }
    if (!ConstantTimeEquals(auth.substr(prefix.size()), options.api_key)) {
      SendProblem(req, res, 403, "forbidden", "wrong API key");
      return false;
    }
    return true;
  }

  // What the service derives from a stored rig, per level of detail: the simplified rig and
  // the box its shapes act in. Made once per rig version and level and kept; a new version of
  // a rig drops its older entries.
  struct Derived {
    std::shared_ptr<const Rig> rig;
    bool has_focus = false;
    std::array<float, 3> focus_min{}, focus_max{};
  };
  std::mutex derived_mu;
  std::map<std::string, std::shared_ptr<const Derived>> derived;

  std::shared_ptr<const Derived> DerivedAt(const std::shared_ptr<const StoredRig>& stored, int lod) {
    const std::string prefix = stored->id + "|";
    const std::string key = prefix + stored->version + "|" + std::to_string(lod);
    {
      std::lock_guard<std::mutex> lock(derived_mu);
      if (auto it = derived.find(key); it != derived.end()) return it->second;
    }
    auto d = std::make_shared<Derived>();
    if (lod == 0) {
      d->rig = std::shared_ptr<const Rig>(stored, &stored->rig);
    } else {
      auto made = MakeLod(stored->rig, lod);
      if (!made.ok()) return nullptr;
      d->rig = std::make_shared<const Rig>(std::move(made.value()));
    }
    d->has_focus = ShapeFocusBox(*d->rig, d->focus_min, d->focus_max);
    std::lock_guard<std::mutex> lock(derived_mu);
    for (auto it = derived.lower_bound(prefix); it != derived.end() && it->first.rfind(prefix, 0) == 0;) {
      it = it->first.rfind(prefix + stored->version + "|", 0) == 0 ? std::next(it) : derived.erase(it);
    }
    return derived.emplace(key, std::move(d)).first->second;
  }

  // The rig at a level of detail (0: the stored rig itself).
  std::shared_ptr<const Rig> RigAt(const std::shared_ptr<const StoredRig>& stored, int lod) {
    if (lod == 0) return std::shared_ptr<const Rig>(stored, &stored->rig);
    auto d = DerivedAt(stored, lod);
    return d ? d->rig : nullptr;
  }

  // Framing on the shapes: the render's camera gets the kept box instead of a per-render one.
  void SetFocus(const std::shared_ptr<const StoredRig>& stored, int lod, render::Camera& camera) {
    if (!camera.frame_shapes) return;
    if (auto d = DerivedAt(stored, lod); d && d->has_focus) {
      camera.has_focus = true;
      camera.focus_min = d->focus_min;
      camera.focus_max = d->focus_max;
    }
  }

  std::shared_ptr<const StoredRig> FindRig(const Request& req, Response& res, const std::string& id) {
    auto rig = IsValidRigId(id) ? store.Get(id) : nullptr;
    if (!rig) SendProblem(req, res, 404, "rig-not-found", "no rig with id '" + id.substr(0, 80) + "'");
    return rig;
  }

  // The mesh request from a POST body or GET query; false when an error was sent.
  // A JSON body (Content-Type application/json or none) parsed by `parse`; false when an
  // error was sent (415, 400 malformed, 422 schema).
  template <typename T, typename Parse>
  bool ReadJsonBody(const Request& req, Response& res, Parse parse, T& out) {
    const std::string ct = MediaType(req.get_header_value("Content-Type"));
    if (!ct.empty() && ct != "application/json") {
      SendProblem(req, res, 415, "unsupported-media-type", "the body must be application/json, not " + ct);
      return false;
    }
    auto parsed = parse(req.body);
    if (!parsed.ok()) {
      const bool malformed = IsMalformedJson(parsed.status());
      SendProblem(req, res, malformed ? 400 : 422, malformed ? "malformed-json" : "invalid-request", parsed.status().message,
                  parsed.status().fields);
      return false;
    }
    out = std::move(parsed.value());
    return true;
  }

  // A query parameter shared by the mesh and render routes: w.NAME, mode, normals, strict,
  // and the skeleton settings. False when the key is none of them.
  static bool MeshQueryParam(const std::string& key, const std::string& value, MeshRequest& mr, std::vector<FieldError>& errors) {
    const std::string where = "?" + key;
    if (key.rfind("w.", 0) == 0 || key.rfind("c.", 0) == 0) {  // A shape weight, or a control value.
      WeightEntry e;
      e.name = key.substr(2);
      e.pointer = where;
      if (e.name.empty()) errors.push_back({where, key.substr(0, 2) + " needs a name: w.SHAPE=0.5 or c.CONTROL=-0.4"});
      else if (!ParseNumber(value, &e.value)) errors.push_back({where, "'" + value.substr(0, 40) + "' is not a number"});
      else (key[0] == 'w' ? mr.weights : mr.controls).push_back(e);
    } else if (key == "mode") {
      if (!ParseBlendMode(value, &mr.options.mode)) errors.push_back({where, "must be relative or absolute"});
    } else if (key == "normals") {
      if (!ParseNormalMode(value, &mr.options.normals)) errors.push_back({where, "must be blend or recompute"});
    } else if (key == "strict") {
      if (!ParseBool(value, &mr.strict)) errors.push_back({where, "must be true or false"});
    } else {
      bool known = false;
      const std::string e = ApplyPoseSetting(key, value, mr, &known);
      if (!known) return false;
      if (!e.empty()) errors.push_back({where, e});
    }
    return true;
  }

  // Ends query parsing: the skeleton settings' cross-checks, then a 422 for any error.
  static bool FinishQuery(const Request& req, Response& res, MeshRequest& mr, std::vector<FieldError>& errors) {
    if (std::string e = FinishPoseSettings(mr); !e.empty()) errors.push_back({"?animation", e});
    if (errors.empty()) return true;
    SendProblem(req, res, 422, "invalid-request", errors[0].pointer.substr(1) + ": " + errors[0].message, errors);
    return false;
  }

  // The mesh request from a POST body or GET query; false when an error was sent.
  bool ReadMeshRequest(const Request& req, Response& res, MeshRequest& mr) {
    if (req.method == "POST") return ReadJsonBody(req, res, ParseMeshRequest, mr);
    std::vector<FieldError> errors;
    for (const auto& [key, value] : req.params) {
      const std::string where = "?" + key;
      if (key == "format") {
        MeshFormat f;
        if (ParseMeshFormat(value, &f)) mr.format = f;
        else errors.push_back({where, "must be one of glb, obj, json, f32"});
      } else if (key == "keep_targets") {
        if (!ParseBool(value, &mr.keep_targets)) errors.push_back({where, "must be true or false"});
      } else if (!MeshQueryParam(key, value, mr, errors)) {
        errors.push_back({where, "unknown parameter (weights are w.NAME=VALUE)"});
      }
    }
    return FinishQuery(req, res, mr, errors);
  }

  // Resolves and checks the weights; sets the warning headers. False when an error was sent.
  bool Weigh(const Request& req, Response& res, const StoredRig& rig, const MeshRequest& mr, std::vector<float>& w,
             WeightReport& report, Pose& pose, bool& posed) {
    std::vector<Warning> pose_warnings;
    std::vector<WeightEntry> entries = mr.weights;
    if (Status s = ApplyControls(rig.rig, mr.controls, entries, pose_warnings); !s.ok()) {
      SendProblem(req, res, 422, "invalid-controls", s.message, s.fields);
      return false;
    }
    if (Status s = ResolvePoseAndWeights(rig.rig, entries, mr.pose, w, pose, posed, pose_warnings); !s.ok()) {
      SendProblem(req, res, 422, "invalid-weights", s.message, s.fields);
      return false;
    }
    report = CheckWeights(rig.rig, w, mr.options.mode);
    report.warnings.insert(report.warnings.end(), pose_warnings.begin(), pose_warnings.end());
    res.set_header("Facespace-Weight-Sum", FormatNumber(report.sum));
    if (!report.warnings.empty()) res.set_header("Facespace-Warnings", WarningsHeader(report.warnings));
    for (const Warning& warning : report.warnings) {
      for (int i = 0; i < kWarningCount; ++i) {
        if (warning.code == kWarningCodes[i]) metrics.warnings[i].fetch_add(1, std::memory_order_relaxed);
      }
    }
    if (mr.strict && !report.warnings.empty()) {
      SendProblem(req, res, 422, "weights-leave-authored-space",
                  report.warnings[0].message + (report.warnings.size() > 1 ? " (and more)" : ""), {},
                  WarningsToJson(report.warnings));
      return false;
    }
    return true;
  }

  // Answers from the response cache, or with `produce()` (the encoded body) which is then
  // cached under `key`. A failed `produce` is a 500 with its message as the detail.
  template <typename Produce>
  void SendCached(const Request& req, Response& res, const std::string& key, const char* content_type, Produce produce) {
    std::shared_ptr<const Encoded> enc = cache.Get(key);
    (enc ? metrics.cache_hits : metrics.cache_misses).fetch_add(1, std::memory_order_relaxed);
    if (!enc) {
      Result<std::string> bytes = produce();
      if (!bytes.ok()) {
        SendProblem(req, res, 500, "internal", bytes.status().message);
        return;
      }
      auto e = std::make_shared<Encoded>();
      e->body = std::move(bytes.value());
      e->content_type = content_type;
      enc = e;
      cache.Put(key, enc);
    }
    res.status = 200;
    res.set_content(enc->body, enc->content_type.c_str());
  }

  void Mesh(const Request& req, Response& res) {
    t_request.route = kMesh;
    auto rig = FindRig(req, res, req.matches[1]);
    if (!rig) return;
    MeshRequest mr;
    if (!ReadMeshRequest(req, res, mr)) return;
    MeshFormat format;
    if (mr.format) {
      format = *mr.format;
    } else if (!FormatFromAccept(req.get_header_value("Accept"), &format)) {
      SendProblem(req, res, 406, "not-acceptable",
                  "cannot produce " + req.get_header_value("Accept").substr(0, 100) +
                      "; available: model/gltf-binary, model/obj, application/json, application/octet-stream");
      return;
    }
    std::vector<float> w;
    WeightReport report;
    Pose pose;
    bool posed = false;
    if (!Weigh(req, res, *rig, mr, w, report, pose, posed)) return;
    mr.options.pose = posed ? &pose : nullptr;

    const std::string canonical = PoseCanonical(pose, posed) + std::string(MeshFormatName(format)) + "|" +
                                  (mr.options.mode == BlendMode::kAbsolute ? "abs" : "rel") + "|" +
                                  (mr.options.normals == NormalMode::kRecompute ? "rec" : "bl") + "|" +
                                  (mr.keep_targets ? "t" : "-") + (mr.options.dual_quaternion ? "|dq|" : "|") + "lod" +
                                  std::to_string(mr.lod) + "|" + WeightsCanonical(w);
    const std::string key = rig->id + "|" + rig->version + "|" + canonical;
    if (NotModified(req, res, key)) return;
    SendCached(req, res, key, MeshFormatMimeType(format), [&]() -> Result<std::string> {
      const ScratchLease scratch = LeaseScratch();
      BlendContext& context = scratch->context;
      BlendedRig& blended = scratch->blended;
      const auto at = RigAt(rig, mr.lod);
      if (!at || !EvaluateRig(*at, w, mr.options, blended, context).ok()) return Status{StatusCode::kInternal, "the blend failed", {}};
      metrics.blends.fetch_add(1, std::memory_order_relaxed);
      ExportOptions export_options;
      export_options.keep_targets = mr.keep_targets;
      auto bytes = ExportMesh(*at, blended, w, report.warnings, format, export_options);
      if (!bytes.ok()) return Status{StatusCode::kInternal, "the export failed", {}};
      return bytes;
    });
  }

  // The render request from a POST body or GET query; false when an error was sent.
  bool ReadRenderRequest(const Request& req, Response& res, RenderRequest& rr) {
    if (req.method == "POST") return ReadJsonBody(req, res, ParseRenderRequest, rr);
    std::vector<FieldError> errors;
    for (const auto& [key, value] : req.params) {
      bool known = false;
      if (std::string e = ApplyRenderSetting(key, value, rr, &known); known) {
        if (!e.empty()) errors.push_back({"?" + key, e});
      } else if (!MeshQueryParam(key, value, rr.mesh, errors)) {
        errors.push_back({"?" + key, "unknown parameter"});
      }
    }
    return FinishQuery(req, res, rr.mesh, errors);
  }

  bool CheckSize(const Request& req, Response& res, const render::RenderOptions& o) {
    if (o.width > options.max_render_size || o.height > options.max_render_size) {
      SendProblem(req, res, 422, "image-too-large",
                  "width and height are limited to " + std::to_string(options.max_render_size) + " pixels",
                  {{std::string(req.method == "GET" ? "?" : "/") + (o.width > options.max_render_size ? "width" : "height"),
                    "at most " + std::to_string(options.max_render_size)}});
      return false;
    }
    return true;
  }

  // Picks the image format (explicit, else Accept); false when a 406 was sent.
  bool PickImageFormat(const Request& req, Response& res, const RenderRequest& rr, render::ImageFormat* format) {
    if (rr.format) {
      *format = *rr.format;
      return true;
    }
    if (ImageFormatFromAccept(req.get_header_value("Accept"), format)) return true;
    SendProblem(req, res, 406, "not-acceptable",
                "cannot produce " + req.get_header_value("Accept").substr(0, 100) +
                    "; available: image/png, image/jpeg, image/x-exr, image/tiff");
    return false;
  }

  // ETag + If-None-Match; true when a 304 was sent.
  bool NotModified(const Request& req, Response& res, const std::string& key) {
    const std::string etag = "\"" + Hex64(Fnv1a(key)) + "\"";
    res.set_header("ETag", etag);
    res.set_header("Cache-Control", req.method == "GET" ? "public, no-cache" : "no-store");
    res.set_header("Vary", "Accept");
    const std::string inm = req.get_header_value("If-None-Match");
    if (!inm.empty() && (inm == etag || inm == "*" || inm.find(etag) != std::string::npos)) {
      res.status = 304;
      return true;
    }
    return false;
  }

  void Render(const Request& req, Response& res) {
    t_request.route = kRender;
    auto rig = FindRig(req, res, req.matches[1]);
    if (!rig) return;
    RenderRequest rr;
    render::ImageFormat format;
    if (!ReadRenderRequest(req, res, rr) || !CheckSize(req, res, rr.render) || !PickImageFormat(req, res, rr, &format)) return;
    std::vector<float> w;
    WeightReport report;
    Pose pose;
    bool posed = false;
    if (!Weigh(req, res, *rig, rr.mesh, w, report, pose, posed)) return;
    rr.mesh.options.pose = posed ? &pose : nullptr;
    const std::string key = rig->id + "|" + rig->version + "|render|" + RenderCanonical(rr, format) + "|lod" +
                            std::to_string(rr.mesh.lod) + "|" + WeightsCanonical(w) + PoseCanonical(pose, posed);
    if (NotModified(req, res, key)) return;
    SendCached(req, res, key, render::ImageFormatMimeType(format), [&]() -> Result<std::string> {
      const ScratchLease scratch = LeaseScratch();
      BlendContext& context = scratch->context;
      BlendedRig& blended = scratch->blended;
      render::Image image;
      const auto at = RigAt(rig, rr.mesh.lod);
      render::RenderOptions framed = rr.render;
      SetFocus(rig, rr.mesh.lod, framed.camera);
      if (!at || !EvaluateRig(*at, w, rr.mesh.options, blended, context).ok() || !render::Render(*at, blended, framed, image).ok()) {
        return Status{StatusCode::kInternal, "the render failed", {}};
      }
      metrics.blends.fetch_add(1, std::memory_order_relaxed);
      auto bytes = render::Encode(image, format, rr.quality);
      if (!bytes.ok()) return Status{StatusCode::kInternal, "the image encoding failed", {}};
      return bytes;
    });
  }

  void Sheet(const Request& req, Response& res) {
    t_request.route = kSheet;
    auto rig = FindRig(req, res, req.matches[1]);
    if (!rig) return;
    SheetRequest sr;
    if (!ReadJsonBody(req, res, ParseSheetRequest, sr)) return;
    render::ImageFormat format;
    if (!CheckSize(req, res, sr.base.render) || !PickImageFormat(req, res, sr.base, &format)) return;
    if (sr.cells.size() > static_cast<size_t>(options.max_sheet_cells)) {
      SendProblem(req, res, 422, "too-many-cells", "a sheet has at most " + std::to_string(options.max_sheet_cells) + " cells",
                  {{"/cells", "at most " + std::to_string(options.max_sheet_cells)}});
      return;
    }
    // Every cell's weights first, so nothing is rendered when one of them is wrong.
    std::vector<std::vector<float>> weights(sr.cells.size());
    std::vector<Warning> all_warnings;
    Pose pose;
    bool posed = false;
    double max_sum = 0.0;
    std::string key = rig->id + "|" + rig->version + "|sheet|" + std::to_string(sr.columns) + "|" + RenderCanonical(sr.base, format);
    for (size_t c = 0; c < sr.cells.size(); ++c) {
      std::vector<Warning> pose_warnings;
      if (Status st = ResolvePoseAndWeights(rig->rig, sr.cells[c], sr.base.mesh.pose, weights[c], pose, posed, pose_warnings);
          !st.ok()) {
        SendProblem(req, res, 422, "invalid-weights", "cell " + std::to_string(c) + ": " + st.message, st.fields);
        return;
      }
      WeightReport report = CheckWeights(rig->rig, weights[c], sr.base.mesh.options.mode);
      if (c == 0) report.warnings.insert(report.warnings.end(), pose_warnings.begin(), pose_warnings.end());
      max_sum = std::max(max_sum, report.sum);
      for (Warning& wn : report.warnings) {
        wn.message = "cell " + std::to_string(c) + ": " + wn.message;
        all_warnings.push_back(std::move(wn));
      }
      key += "|" + WeightsCanonical(weights[c]) + "#" + sr.labels[c];
    }
    key += PoseCanonical(pose, posed);
    sr.base.mesh.options.pose = posed ? &pose : nullptr;
    res.set_header("Facespace-Weight-Sum", FormatNumber(max_sum));
    if (!all_warnings.empty()) res.set_header("Facespace-Warnings", WarningsHeader(all_warnings));
    if (sr.base.mesh.strict && !all_warnings.empty()) {
      SendProblem(req, res, 422, "weights-leave-authored-space", all_warnings[0].message, {}, WarningsToJson(all_warnings));
      return;
    }
    if (NotModified(req, res, key)) return;
    SendCached(req, res, key, render::ImageFormatMimeType(format), [&]() -> Result<std::string> {
      const ScratchLease scratch = LeaseScratch();
      BlendContext& context = scratch->context;
      BlendedRig& blended = scratch->blended;
      render::RenderOptions framed = sr.base.render;
      SetFocus(rig, 0, framed.camera);
      std::vector<render::Image> images(sr.cells.size());
      for (size_t c = 0; c < sr.cells.size(); ++c) {
        if (!EvaluateRig(rig->rig, weights[c], sr.base.mesh.options, blended, context).ok() ||
            !render::Render(rig->rig, blended, framed, images[c]).ok()) {
          return Status{StatusCode::kInternal, "the render failed", {}};
        }
        metrics.blends.fetch_add(1, std::memory_order_relaxed);
      }
      auto bytes = render::Encode(render::ContactSheet(images, sr.labels, sr.columns, sr.base.render.background), format,
                                  sr.base.quality);
      if (!bytes.ok()) return Status{StatusCode::kInternal, "the image encoding failed", {}};
      return bytes;
    });
  }

  // The sequence body resolved against the rig; false when an error was sent.
  bool ReadSequence(const Request& req, Response& res, const StoredRig& rig, SequenceRequest& sr, Sequence& seq) {
    if (!ReadJsonBody(req, res, ParseSequenceRequest, sr)) return false;
    auto resolved = ResolveSequence(rig.rig, sr);
    if (!resolved.ok()) {
      SendProblem(req, res, 422, "invalid-sequence", resolved.status().message, resolved.status().fields);
      return false;
    }
    seq = std::move(resolved.value());
    return true;
  }

  void SequenceSample(const Request& req, Response& res) {
    t_request.route = kSequence;
    auto rig = FindRig(req, res, req.matches[1]);
    if (!rig) return;
    SequenceRequest sr;
    Sequence seq;
    if (!ReadSequence(req, res, *rig, sr, seq)) return;
    if (sr.times.empty()) {
      SendProblem(req, res, 422, "invalid-request", "/times: is required (the times to sample)", {{"/times", "is required"}});
      return;
    }
    std::vector<Warning> warnings;
    auto body = SampleSequenceJson(rig->rig, seq, sr.times, sr.options, warnings);
    if (!body.ok()) {
      SendProblem(req, res, 500, "internal", "the blend failed");
      return;
    }
    metrics.blends.fetch_add(sr.times.size(), std::memory_order_relaxed);
    if (!warnings.empty()) res.set_header("Facespace-Warnings", WarningsHeader(warnings));
    res.status = 200;
    res.set_content(body.value(), "application/json");
  }

  void SequenceStream(const Request& req, Response& res) {
    t_request.route = kSequence;
    auto rig = FindRig(req, res, req.matches[1]);
    if (!rig) return;
    auto sr = std::make_shared<SequenceRequest>();
    auto seq = std::make_shared<Sequence>();
    if (!ReadSequence(req, res, *rig, *sr, *seq)) return;
    const std::string format = sr->format.empty() ? "ndjson" : sr->format;
    if (format != "ndjson" && format != "f32") {
      SendProblem(req, res, 422, "invalid-request", "/format: stream as ndjson or f32", {{"/format", "must be ndjson or f32"}});
      return;
    }
    const double duration = seq->keys.back().time - seq->keys.front().time;
    const size_t frames = static_cast<size_t>(std::floor(duration * sr->fps + 1e-6)) + 1;
    if (frames > 100000) {
      SendProblem(req, res, 422, "too-many-frames", "at most 100000 frames a stream (duration x fps)", {{"/fps", "too many frames"}});
      return;
    }
    res.set_header("Facespace-Frames", std::to_string(frames));
    res.set_header("Cache-Control", "no-store");
    const bool f32 = format == "f32";
    // One frame per call, computed as the client reads: a client that closes stops the work.
    auto next = std::make_shared<size_t>(0);
    res.set_chunked_content_provider(
        f32 ? "application/octet-stream" : "application/x-ndjson",
        [this, rig, sr, seq, next, frames, f32](size_t, httplib::DataSink& sink) {
          if (*next >= frames) {
            sink.done();
            return true;
          }
          const float t = seq->keys.front().time + static_cast<float>(*next) / sr->fps;
          std::vector<float> w(rig->rig.shapes.size());
          float f = 0.0f;
          SampleSequence(*seq, t, w, &f);
          std::string chunk;
          if (f32) {
            const ScratchLease scratch = LeaseScratch();
            BlendContext& context = scratch->context;
            BlendedRig& blended = scratch->blended;
            if (!EvaluateRig(rig->rig, w, sr->options, blended, context).ok()) return false;
            metrics.blends.fetch_add(1, std::memory_order_relaxed);
            std::vector<float> pos;
            WorldPositions(blended, pos);
            const uint32_t bytes = static_cast<uint32_t>(pos.size() * 4);
            chunk.resize(4 + bytes);
            std::memcpy(chunk.data(), &bytes, 4);
            std::memcpy(chunk.data() + 4, pos.data(), bytes);
          } else {
            std::vector<Warning> warnings;
            SequenceFrameWarnings(rig->rig, t, f, w, sr->options.mode, warnings);
            chunk = "{\"frame\":" + std::to_string(*next) + ",\"time\":" + FormatNumber(t) + ",\"weights\":" + WeightsMapJson(rig->rig, w) +
                    ",\"warnings\":" + WarningsToJson(warnings) + "}\n";
          }
          ++*next;
          return sink.write(chunk.data(), chunk.size());
        });
    res.status = 200;
  }

  void SequenceReduce(const Request& req, Response& res) {
    t_request.route = kSequence;
    auto rig = FindRig(req, res, req.matches[1]);
    if (!rig) return;
    SequenceRequest sr;
    Sequence seq;
    if (!ReadSequence(req, res, *rig, sr, seq)) return;
    if (!sr.has_tolerance) {
      SendProblem(req, res, 422, "invalid-request", "/tolerance: is required (largest vertex error allowed, mesh units)",
                  {{"/tolerance", "is required"}});
      return;
    }
    auto reduced = ReduceSequence(rig->rig, seq, sr.tolerance);
    if (!reduced.ok()) {
      SendProblem(req, res, 422, "invalid-sequence", reduced.status().message, reduced.status().fields);
      return;
    }
    res.status = 200;
    res.set_content("{\"keys\":" + SequenceKeysJson(rig->rig, reduced->sequence) + ",\"transition\":" +
                        json(TransitionName(seq.transition)).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + ",\"kept\":" + std::to_string(reduced->sequence.keys.size()) +
                        ",\"removed\":" + std::to_string(reduced->removed) + ",\"max_error\":" + FormatNumber(reduced->max_error) +
                        ",\"tolerance\":" + FormatNumber(sr.tolerance) + "}\n",
                    "application/json");
  }

  void Fit(const Request& req, Response& res) {
    t_request.route = kFit;
    auto rig = FindRig(req, res, req.matches[1]);
    if (!rig) return;
    FitRequest fr;
    if (!ReadJsonBody(req, res, ParseFitRequest, fr)) return;
    auto fit = FitWeights(rig->rig, fr.target, fr.options);
    if (!fit.ok()) {
      SendProblem(req, res, 422, "invalid-target", fit.status().message, {{"/target", fit.status().message}});
      return;
    }
    if (!fit->warnings.empty()) res.set_header("Facespace-Warnings", WarningsHeader(fit->warnings));
    res.status = 200;
    res.set_content(FitResultJson(rig->rig, fit.value(), fr.options.rigid_align), "application/json");
  }

  void Check(const Request& req, Response& res) {
    t_request.route = kCheck;
    auto rig = FindRig(req, res, req.matches[1]);
    if (!rig) return;
    MeshRequest mr;
    if (!ReadMeshRequest(req, res, mr)) return;
    std::vector<float> w;
    WeightReport report;
    Pose pose;
    bool posed = false;
    if (!Weigh(req, res, *rig, mr, w, report, pose, posed)) return;
    res.status = 200;
    res.set_content("{\"sum\":" + FormatNumber(report.sum) + ",\"weights\":" + WeightsMapJson(rig->rig, w) +
                        (report.mahalanobis >= 0 ? ",\"mahalanobis\":" + FormatNumber(report.mahalanobis) : std::string()) +
                        ",\"warnings\":" + WarningsToJson(report.warnings) + "}",
                    "application/json");
  }

  // ---- batch jobs ----

  static json JobJson(const JobInfo& j) {
    const std::string self = "/v1/jobs/" + j.id;
    json o = {{"id", j.id},       {"rig", j.rig},         {"state", j.state}, {"format", j.format},
              {"created", j.created}, {"total", j.total}, {"done", j.done},
              {"progress", j.total ? static_cast<double>(j.done) / static_cast<double>(j.total) : 1.0},
              {"rate", std::round(j.rate * 10.0) / 10.0}};
    if (j.state == "running" && j.rate > 0) o["eta_seconds"] = std::ceil(static_cast<double>(j.total - j.done) / j.rate);
    if (!j.error.empty()) o["error"] = j.error;
    o["links"] = {{"self", self}, {"manifest", self + "/manifest.jsonl"}, {"files", self + "/files/"}, {"sheet", self + "/files/sheet.png"}};
    if (j.state == "done") o["links"]["results"] = self + "/results.zip";
    return o;
  }

  bool JobsEnabled(const Request& req, Response& res) {
    if (jobs) return true;
    SendProblem(req, res, 503, "jobs-disabled", "this server runs no batch jobs");
    return false;
  }

  std::optional<JobInfo> FindJob(const Request& req, Response& res, const std::string& id) {
    std::optional<JobInfo> j = IsValidJobId(id) ? jobs->Get(id) : std::nullopt;
    if (!j) SendProblem(req, res, 404, "job-not-found", "no job with id '" + id.substr(0, 80) + "'");
    return j;
  }

  void Batch(const Request& req, Response& res) {
    t_request.route = kBatch;
    if (!JobsEnabled(req, res) || !Authorized(req, res)) return;  // It writes to the disk: a mutating route.
    auto rig = FindRig(req, res, req.matches[1]);
    if (!rig) return;
    const std::string ct = MediaType(req.get_header_value("Content-Type"));
    if (!ct.empty() && ct != "application/json") {
      SendProblem(req, res, 415, "unsupported-media-type", "the body must be application/json, not " + ct);
      return;
    }
    int retry_after = 0;
    auto job = jobs->Submit(rig, req.body, &retry_after);
    if (!job.ok()) {
      const Status& s = job.status();
      if (s.code == StatusCode::kResourceExhausted) {
        res.set_header("Retry-After", std::to_string(retry_after));
        SendProblem(req, res, 429, "job-queue-full", s.message);
      } else if (s.code == StatusCode::kInvalidArgument) {
        const bool malformed = IsMalformedJson(s);
        SendProblem(req, res, malformed ? 400 : 422, malformed ? "malformed-json" : "invalid-request", s.message, s.fields);
      } else if (s.code == StatusCode::kStorageFull) {
        SendProblem(req, res, 507, "storage-full", s.message);
      } else {
        SendProblem(req, res, 500, "storage-failed", s.message);
      }
      return;
    }
    res.set_header("Location", "/v1/jobs/" + job->id);
    SendJson(res, 202, JobJson(job.value()));
  }

  static const char* FileType(const std::string& name) {
    const std::string ext = name.substr(name.rfind('.') + 1);
    if (ext == "glb") return "model/gltf-binary";
    if (ext == "obj") return "model/obj";
    if (ext == "json") return "application/json";
    if (ext == "jsonl") return "application/x-ndjson";
    if (ext == "png") return "image/png";
    if (ext == "jpg" || ext == "jpeg") return "image/jpeg";
    if (ext == "exr") return "image/x-exr";
    if (ext == "tif" || ext == "tiff") return "image/tiff";
    return "application/octet-stream";
  }

  void JobFile(const Request& req, Response& res, const std::string& name) {
    t_request.route = kJobFiles;
    if (!JobsEnabled(req, res)) return;
    auto job = FindJob(req, res, req.matches[1]);
    if (!job) return;
    std::string bytes;
    const std::filesystem::path path = std::filesystem::path(jobs->Folder(job->id)) / name;
    std::ifstream f(path, std::ios::binary);
    if (!IsValidVariantId(name) || !f) {
      SendProblem(req, res, 404, "file-not-found", "job " + job->id + " has no file '" + name.substr(0, 80) + "'" +
                                                       (job->state == "done" ? "" : " (yet: the job is " + job->state + ")"));
      return;
    }
    bytes.assign((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    res.set_header("Cache-Control", name == "manifest.jsonl" ? "no-cache" : "private, max-age=86400");
    res.set_content(std::move(bytes), FileType(name));
  }

  void Results(const Request& req, Response& res) {
    t_request.route = kJobFiles;
    if (!JobsEnabled(req, res)) return;
    auto job = FindJob(req, res, req.matches[1]);
    if (!job) return;
    if (job->state != "done") {
      SendProblem(req, res, 409, "job-not-done", "job " + job->id + " is " + job->state + " (" + std::to_string(job->done) +
                                                    " of " + std::to_string(job->total) +
                                                    " variants): its archive exists once it is done; finished files are at " +
                                                    "/v1/jobs/" + job->id + "/files/NAME");
      return;
    }
    // Entries: the manifest, batch.json, the sheet, then every variant in manifest order.
    const std::filesystem::path dir = jobs->Folder(job->id);
    auto names = std::make_shared<std::vector<std::string>>();
    for (const char* n : {"manifest.jsonl", "batch.json", "sheet.png"}) {
      if (std::filesystem::exists(dir / n)) names->push_back(n);
    }
    std::ifstream manifest(dir / "manifest.jsonl");
    for (std::string line; std::getline(manifest, line);) {
      json l = json::parse(line, nullptr, false);
      if (!l.is_discarded() && l.is_object() && l.contains("file") && l["file"].is_string()) names->push_back(l["file"]);
    }
    auto zip = std::make_shared<ZipStream>();
    auto next = std::make_shared<size_t>(0);
    res.set_header("Content-Disposition", "attachment; filename=\"facespace-batch-" + job->id + ".zip\"");
    res.set_chunked_content_provider("application/zip", [dir, names, zip, next](size_t, httplib::DataSink& sink) {
      if (*next == names->size()) {
        const std::string end = zip->Finish();
        sink.write(end.data(), end.size());
        sink.done();
        return true;
      }
      const std::string& name = (*names)[(*next)++];
      std::ifstream f(dir / name, std::ios::binary);
      const std::string data((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
      const std::string ext = name.substr(name.rfind('.') + 1);
      const std::string entry = zip->Entry(name, data, ext == "obj" || ext == "json" || ext == "jsonl");
      if (!f || zip->failed()) return false;  // A file vanished (job deleted) or the archive would pass 4 GiB.
      return sink.write(entry.data(), entry.size());
    });
  }

  void PutRig(const Request& req, Response& res) {
    t_request.route = kRig;
    if (!Authorized(req, res)) return;
    const std::string id = req.matches[1];
    if (!IsValidRigId(id)) {
      SendProblem(req, res, 422, "invalid-id", "rig ids are 1 to 64 characters of [a-z0-9_-], starting with a letter or digit",
                  {{"?id", "invalid rig id"}});
      return;
    }
    const std::string ct = MediaType(req.get_header_value("Content-Type"));
    if (ct != "model/gltf-binary" && ct != "model/gltf+json") {
      SendProblem(req, res, 415, "unsupported-media-type",
                  "upload a rig as model/gltf-binary (.glb) or model/gltf+json (.gltf with embedded buffers)" +
                      (ct.empty() ? std::string() : ", not " + ct));
      return;
    }
    if (req.body.empty()) {
      SendProblem(req, res, 422, "invalid-rig", "the body is empty");
      return;
    }
    bool created = false;
    const auto* data = reinterpret_cast<const unsigned char*>(req.body.data());
    Status s = store.Put(id, std::span<const unsigned char>(data, req.body.size()), ct == "model/gltf-binary", &created);
    if (!s.ok()) {
      const int status = s.code == StatusCode::kResourceExhausted ? 413
                         : s.code == StatusCode::kStorageFull ? 507
                         : s.code == StatusCode::kInternal    ? 500
                                                              : 422;
      SendProblem(req, res, status, status == 507 ? "storage-full" : status == 500 ? "storage-failed" : "invalid-rig", s.message, s.fields);
      return;
    }
    auto stored = store.Get(id);
    res.set_header("Location", "/v1/rigs/" + id);
    SendJson(res, created ? 201 : 200, stored ? RigSummary(*stored) : json{{"id", id}});
  }

  void DeleteRig(const Request& req, Response& res) {
    t_request.route = kRig;
    if (!Authorized(req, res)) return;
    const std::string id = req.matches[1];
    Status s = IsValidRigId(id) ? store.Delete(id) : NotFound("");
    if (s.code == StatusCode::kNotFound) {
      SendProblem(req, res, 404, "rig-not-found", "no rig with id '" + id.substr(0, 80) + "'");
    } else if (!s.ok()) {
      SendProblem(req, res, 500, "storage-failed", s.message);
    } else {
      res.status = 204;
    }
  }
};

Api::Api(RigStore& store, ApiOptions options, JobQueue* jobs)
    : impl_(std::make_unique<Impl>(store, std::move(options), jobs)) {}
Api::~Api() = default;

std::string Api::MetricsText() const {
  const Metrics& m = impl_->metrics;
  std::string out;
  out += "# HELP facespace_http_requests_total HTTP requests by route and status.\n";
  out += "# TYPE facespace_http_requests_total counter\n";
  for (int r = 0; r < kRouteCount; ++r) {
    for (int s = 0; s <= kStatusCount; ++s) {
      const uint64_t v = m.requests[r][s].load(std::memory_order_relaxed);
      if (!v) continue;
      out += "facespace_http_requests_total{route=\"" + std::string(kRouteNames[r]) + "\",status=\"" +
             (s < kStatusCount ? std::to_string(kStatuses[s]) : std::string("other")) + "\"} " + std::to_string(v) + "\n";
    }
  }
  out += "# HELP facespace_http_request_duration_seconds Request latency by route.\n";
  out += "# TYPE facespace_http_request_duration_seconds histogram\n";
  for (int r = 0; r < kRouteCount; ++r) {
    const uint64_t count = m.latency_count[r].load(std::memory_order_relaxed);
    if (!count) continue;
    const std::string label = "route=\"" + std::string(kRouteNames[r]) + "\"";
    uint64_t cum = 0;
    for (int b = 0; b <= kBucketCount; ++b) {
      cum += m.latency_buckets[r][b].load(std::memory_order_relaxed);
      char le[32];
      if (b < kBucketCount) std::snprintf(le, sizeof le, "%g", kBuckets[b]);
      else std::snprintf(le, sizeof le, "+Inf");
      out += "facespace_http_request_duration_seconds_bucket{" + label + ",le=\"" + le + "\"} " + std::to_string(cum) + "\n";
    }
    char sum[32];
    std::snprintf(sum, sizeof sum, "%.6f", m.latency_sum_us[r].load(std::memory_order_relaxed) / 1e6);
    out += "facespace_http_request_duration_seconds_sum{" + label + "} " + sum + "\n";
    out += "facespace_http_request_duration_seconds_count{" + label + "} " + std::to_string(count) + "\n";
  }
  out += "# HELP facespace_blends_total Rig evaluations (cache misses of the mesh route).\n";
  out += "# TYPE facespace_blends_total counter\nfacespace_blends_total " + std::to_string(m.blends.load()) + "\n";
  out += "# HELP facespace_cache_requests_total Encoded-response cache lookups.\n";
  out += "# TYPE facespace_cache_requests_total counter\n";
  out += "facespace_cache_requests_total{result=\"hit\"} " + std::to_string(m.cache_hits.load()) + "\n";
  out += "facespace_cache_requests_total{result=\"miss\"} " + std::to_string(m.cache_misses.load()) + "\n";
  out += "# HELP facespace_weight_warnings_total Warnings about leaving the authored space, by code.\n";
  out += "# TYPE facespace_weight_warnings_total counter\n";
  for (int i = 0; i < kWarningCount; ++i) {
    out += "facespace_weight_warnings_total{code=\"" + std::string(kWarningCodes[i]) + "\"} " +
           std::to_string(m.warnings[i].load()) + "\n";
  }
  out += "# HELP facespace_rigs_loaded Rigs in the store.\n# TYPE facespace_rigs_loaded gauge\n";
  out += "facespace_rigs_loaded " + std::to_string(impl_->store.List().size()) + "\n";
  out += "# HELP facespace_cache_bytes Bytes of encoded responses held by the response cache.\n";
  out += "# TYPE facespace_cache_bytes gauge\nfacespace_cache_bytes " + std::to_string(impl_->cache.Bytes()) + "\n";
  // The allocator's view (glibc): what is allocated and not freed, and what was freed but kept.
  // Heap in use flat while RSS moves is fragmentation; heap in use growing is a leak.
  const struct mallinfo2 mi = mallinfo2();
  out += "# HELP facespace_heap_in_use_bytes Heap bytes allocated and not yet freed (malloc arenas and mmapped blocks).\n";
  out += "# TYPE facespace_heap_in_use_bytes gauge\nfacespace_heap_in_use_bytes " + std::to_string(mi.uordblks + mi.hblkhd) + "\n";
  out += "# HELP facespace_heap_free_bytes Heap bytes freed but kept by the allocator for reuse.\n";
  out += "# TYPE facespace_heap_free_bytes gauge\nfacespace_heap_free_bytes " + std::to_string(mi.fordblks) + "\n";
  return out;
}

void Api::Register(httplib::Server& server) {
  Impl& I = *impl_;
  server.set_payload_max_length(I.options.max_body);

  server.set_pre_routing_handler([&I](const Request& req, Response& res) {
    t_request.start = std::chrono::steady_clock::now();
    t_request.route = kOther;
    const std::string origin = req.get_header_value("Origin");
    if (!origin.empty() && I.OriginAllowed(origin)) {
      res.set_header("Access-Control-Allow-Origin", origin);
      res.set_header("Vary", "Origin");
      res.set_header("Access-Control-Expose-Headers", "Facespace-Weight-Sum, Facespace-Warnings, ETag, Location");
      if (req.method == "OPTIONS") {
        res.set_header("Access-Control-Allow-Methods", "GET, POST, PUT, DELETE, OPTIONS");
        res.set_header("Access-Control-Allow-Headers", "Content-Type, Authorization, If-None-Match, Accept");
        res.set_header("Access-Control-Max-Age", "600");
      }
    }
    if (req.method == "OPTIONS") {  // Preflight (or a plain OPTIONS): no body.
      res.status = 204;
      res.set_header("Allow", "GET, POST, PUT, DELETE, OPTIONS");
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });

  server.set_error_handler(httplib::Server::HandlerWithResponse([](const Request& req, Response& res) {
    if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
    switch (res.status) {
      case 404: SendProblem(req, res, 404, "not-found", "no route " + req.path.substr(0, 200)); break;
      case 413: SendProblem(req, res, 413, "body-too-large", "the request body is over the server's limit"); break;
      case 400: SendProblem(req, res, 400, "bad-request", "the request could not be parsed"); break;
      default:
        if (res.status >= 400) SendProblem(req, res, res.status, "error", ReasonPhrase(res.status));
        else return httplib::Server::HandlerResponse::Unhandled;
    }
    return httplib::Server::HandlerResponse::Handled;
  }));

  server.set_exception_handler([](const Request& req, Response& res, std::exception_ptr) {
    SendProblem(req, res, 500, "internal", "internal error");
  });

  server.set_logger([&I](const Request& req, const Response& res) {
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_request.start).count();
    I.metrics.Observe(t_request.route, res.status, seconds);
    if (I.options.log_requests) {
      std::fprintf(stderr, "%s %s %d %zu %.3fms\n", req.method.c_str(), req.path.c_str(), res.status, res.body.size(),
                   seconds * 1e3);
    }
  });

  // 405 with Allow for a known path under another method.
  auto not_allowed = [](const char* allow) {
    return [allow](const Request& req, Response& res) {
      res.set_header("Allow", allow);
      SendProblem(req, res, 405, "method-not-allowed", req.method + " is not allowed here; allowed: " + allow);
    };
  };
  auto all_methods = [&server](const std::string& pattern, const httplib::Server::Handler& h, bool get, bool post,
                               bool put, bool del) {
    if (!get) server.Get(pattern, h);
    if (!post) server.Post(pattern, h);
    if (!put) server.Put(pattern, h);
    if (!del) server.Delete(pattern, h);
    server.Patch(pattern, h);
  };

  server.Get("/healthz", [](const Request&, Response& res) {
    t_request.route = kHealthz;
    res.set_content("{\"status\":\"ok\"}", "application/json");
  });
  server.Get("/readyz", [&I](const Request&, Response& res) {
    t_request.route = kReadyz;
    res.set_content("{\"status\":\"ready\",\"rigs\":" + std::to_string(I.store.List().size()) + "}", "application/json");
  });
  server.Get("/metrics", [this](const Request&, Response& res) {
    t_request.route = kMetrics;
    res.set_content(MetricsText(), "text/plain; version=0.0.4");
  });
  server.Get("/openapi.json", [](const Request&, Response& res) {
    t_request.route = kOpenApi;
    res.set_header("Cache-Control", "public, max-age=3600");
    res.set_content(OpenApiJson(), "application/json");
  });
  for (const char* p : {"/healthz", "/readyz", "/metrics", "/openapi.json"}) all_methods(p, not_allowed("GET"), true, false, false, false);

  server.Get("/v1/rigs", [&I](const Request&, Response& res) {
    t_request.route = kRigs;
    json list = json::array();
    for (const auto& r : I.store.List()) list.push_back(RigSummary(*r));
    SendJson(res, 200, {{"rigs", list}});
  });
  all_methods("/v1/rigs", not_allowed("GET"), true, false, false, false);

  const std::string rig = R"(/v1/rigs/([^/]+))";
  server.Get(rig, [&I](const Request& req, Response& res) {
    t_request.route = kRig;
    if (auto r = I.FindRig(req, res, req.matches[1])) {
      res.set_header("ETag", "\"" + r->version + "\"");
      SendJson(res, 200, RigDetail(*r));
    }
  });
  server.Put(rig, [&I](const Request& req, Response& res) { I.PutRig(req, res); });
  server.Delete(rig, [&I](const Request& req, Response& res) { I.DeleteRig(req, res); });
  all_methods(rig, not_allowed("GET, PUT, DELETE"), true, false, true, true);

  server.Post(rig + "/mesh", [&I](const Request& req, Response& res) { I.Mesh(req, res); });
  server.Get(rig + "/mesh", [&I](const Request& req, Response& res) { I.Mesh(req, res); });
  all_methods(rig + "/mesh", not_allowed("GET, POST"), true, true, false, false);
  server.Post(rig + "/check", [&I](const Request& req, Response& res) { I.Check(req, res); });
  all_methods(rig + "/check", not_allowed("POST"), false, true, false, false);
  server.Post(rig + "/render", [&I](const Request& req, Response& res) { I.Render(req, res); });
  server.Get(rig + "/render", [&I](const Request& req, Response& res) { I.Render(req, res); });
  all_methods(rig + "/render", not_allowed("GET, POST"), true, true, false, false);
  server.Post(rig + "/sheet", [&I](const Request& req, Response& res) { I.Sheet(req, res); });
  all_methods(rig + "/sheet", not_allowed("POST"), false, true, false, false);
  server.Post(rig + "/sequence/sample", [&I](const Request& req, Response& res) { I.SequenceSample(req, res); });
  server.Post(rig + "/sequence/stream", [&I](const Request& req, Response& res) { I.SequenceStream(req, res); });
  server.Post(rig + "/sequence/reduce", [&I](const Request& req, Response& res) { I.SequenceReduce(req, res); });
  all_methods(rig + "/sequence/(sample|stream|reduce)", not_allowed("POST"), false, true, false, false);
  server.Post(rig + "/fit", [&I](const Request& req, Response& res) { I.Fit(req, res); });
  all_methods(rig + "/fit", not_allowed("POST"), false, true, false, false);
  server.Get(rig + "/topology", [&I](const Request& req, Response& res) {
    t_request.route = kRig;
    auto stored = I.FindRig(req, res, req.matches[1]);
    if (!stored) return;
    int lod = 0;
    if (req.has_param("lod")) {
      const std::string v = req.get_param_value("lod");
      if (v.size() != 1 || v[0] < '0' || v[0] - '0' > kMaxLod) {
        SendProblem(req, res, 422, "invalid-request", "lod: must be an integer level of detail 0.." + std::to_string(kMaxLod),
                    {{"?lod", "must be 0.." + std::to_string(kMaxLod)}});
        return;
      }
      lod = v[0] - '0';
    }
    const auto derived = I.DerivedAt(stored, lod);
    const Rig* at = derived ? derived->rig.get() : nullptr;
    if (!at) {
      SendProblem(req, res, 500, "internal", "the level of detail failed");
      return;
    }
    // Triangle lists per primitive, in the order of the f32 and JSON mesh outputs.
    std::string out = "{\"primitives\":[";
    for (size_t p = 0; p < at->primitives.size(); ++p) {
      const Primitive& pr = at->primitives[p];
      if (p) out += ',';
      out += "{\"mesh\":" + std::to_string(pr.mesh) + ",\"primitive\":" + std::to_string(pr.index_in_mesh) +
             ",\"vertices\":" + std::to_string(pr.vertex_count()) + ",\"mode\":" + std::to_string(static_cast<int>(pr.mode)) +
             ",\"indices\":[";
      for (size_t i = 0; i < pr.indices.size(); ++i) {
        if (i) out += ',';
        out += std::to_string(pr.indices[i]);
      }
      out += "]}";
    }
    out += "]";
    if (derived->has_focus) {  // Where the shapes act, for clients that frame a view.
      const auto& lo = derived->focus_min;
      const auto& hi = derived->focus_max;
      out += ",\"focus\":{\"min\":[" + FormatNumber(lo[0]) + "," + FormatNumber(lo[1]) + "," + FormatNumber(lo[2]) + "],\"max\":[" +
             FormatNumber(hi[0]) + "," + FormatNumber(hi[1]) + "," + FormatNumber(hi[2]) + "]}";
    }
    out += "}";
    res.set_header("ETag", "\"" + stored->version + "-" + std::to_string(lod) + "\"");
    res.set_header("Cache-Control", "no-cache");
    res.set_content(std::move(out), "application/json");
  });
  all_methods(rig + "/topology", not_allowed("GET"), true, false, false, false);
  server.Post(rig + "/batch", [&I](const Request& req, Response& res) { I.Batch(req, res); });
  all_methods(rig + "/batch", not_allowed("POST"), false, true, false, false);
  server.Get("/v1/jobs", [&I](const Request& req, Response& res) {
    t_request.route = kJobs;
    if (!I.JobsEnabled(req, res)) return;
    json list = json::array();
    for (const JobInfo& j : I.jobs->List()) list.push_back(Impl::JobJson(j));
    SendJson(res, 200, {{"jobs", list}});
  });
  all_methods("/v1/jobs", not_allowed("GET"), true, false, false, false);
  const std::string job = R"(/v1/jobs/([^/]+))";
  server.Get(job, [&I](const Request& req, Response& res) {
    t_request.route = kJob;
    if (!I.JobsEnabled(req, res)) return;
    if (auto j = I.FindJob(req, res, req.matches[1])) {
      res.set_header("Cache-Control", "no-cache");
      SendJson(res, 200, Impl::JobJson(*j));
    }
  });
  server.Delete(job, [&I](const Request& req, Response& res) {
    t_request.route = kJob;
    if (!I.JobsEnabled(req, res) || !I.Authorized(req, res)) return;
    const std::string id = req.matches[1];
    Status s = IsValidJobId(id) ? I.jobs->Remove(id) : NotFound("");
    if (!s.ok()) SendProblem(req, res, 404, "job-not-found", "no job with id '" + id.substr(0, 80) + "'");
    else res.status = 204;
  });
  all_methods(job, not_allowed("GET, DELETE"), true, false, false, true);
  server.Get(job + "/manifest.jsonl", [&I](const Request& req, Response& res) { I.JobFile(req, res, "manifest.jsonl"); });
  server.Get(job + "/files/([^/]+)", [&I](const Request& req, Response& res) { I.JobFile(req, res, req.matches[2]); });
  server.Get(job + "/results.zip", [&I](const Request& req, Response& res) { I.Results(req, res); });
  all_methods(job + "/(manifest.jsonl|files/[^/]+|results.zip)", not_allowed("GET"), true, false, false, false);
}


}  // namespace facespace::api
