// facespace serve: configuration (flags, then environment, then defaults), the rig store,
// the HTTP server and graceful shutdown.
#include <malloc.h>
#include <algorithm>
#include <pthread.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "commands/cli.h"
#include "commands/flags.h"
#include "facespace/api/http.h"
#include "facespace/batch/queue.h"
#include "facespace/render/render.h"
#include "store/rig_store.h"
#include "server/web_assets.h"

namespace facespace::cli {

namespace {

struct ServeConfig {
  std::string rigs;   // Empty: the bundled rigs, read-only, with uploads in `store`.
  std::string store;  // Where uploads go; empty: --rigs when given, else DefaultStoreDir().
  std::string host = "127.0.0.1";
  int port = 8080;
  int threads = 64;   // Workers running whole requests; connections wait in the front, not on a thread.
  size_t max_connections = 4096;
  size_t max_client_connections = 256;
  size_t max_live_sessions = 1024;        // WebSocket sessions (GET /v1/rigs/{id}/live) at once, in all,
  size_t max_client_live_sessions = 128;  // ... and from one address.
  int live_seconds = 3600;                // How long one may last (without the API key).
  size_t body_budget_mb = 1024;
  size_t render_budget_mb = 1024;
  size_t render_memory_mb = 2048;
  std::string api_key_file;
  size_t max_body = size_t{64} << 20;
  size_t cache_mb = 64;
  int max_render = 2048;
  int max_sheet_cells = 64;
  size_t max_response = size_t{64} << 20;
  size_t max_frames = 100000;
  std::vector<std::string> cors_origins;
  bool quiet = false;
  size_t max_vertices = 1000000;  // Per uploaded rig.
  size_t max_shapes = 1024;
  int store_poll_ms = 1000;  // How often the store's folders are looked at for other processes' changes; 0: never.
  int render_threads = 0;    // GL contexts, i.e. renders drawing at once; 0: one per core.
  int read_timeout = 10;     // Seconds a client may take to send a request (slow clients are cut off).
  std::string jobs_dir;      // Default: $XDG_STATE_HOME/facespace/jobs or ~/.local/state/facespace/jobs.
  batch::JobLimits job_limits;
  // What one request may cost (issue 48): estimated CPU-seconds before the work, wall time after.
  double anonymous_cpu = 2.0;         // A request without the API key; over it: 422 over-budget.
  double keyed_cpu = 600.0;           // ... with the key.
  size_t max_client_requests = 16;    // Requests of one address running at once; its others wait.
  int request_deadline = 120;         // Seconds a request's work and answer may take; then it is stopped.
  int keyed_deadline = 1800;
  size_t min_send_rate_kib = 32;      // KiB a second a client must read an answer at (after a 10 s grace).
  double drain = 8.0;                 // Seconds after SIGTERM before the process exits whatever is left.
};

// $XDG_STATE_HOME/facespace/NAME, else ~/.local/state/facespace/NAME.
std::string StateDir(const std::string& name) {
  if (const char* x = std::getenv("XDG_STATE_HOME"); x && *x == '/') return std::string(x) + "/facespace/" + name;
  if (const char* h = std::getenv("HOME"); h && *h == '/') return std::string(h) + "/.local/state/facespace/" + name;
  return "/tmp/facespace-" + name + "-" + std::to_string(getuid());
}

std::string DefaultJobsDir() { return StateDir("jobs"); }

bool ParseSize(const std::string& s, long long lo, long long hi, long long* out) {
  if (s.empty() || s.size() > 18 || s.find_first_not_of("0123456789") != std::string::npos) return false;
  const long long v = std::stoll(s);
  if (v < lo || v > hi) return false;
  *out = v;
  return true;
}

void SplitOrigins(const std::string& s, std::vector<std::string>& out) {
  size_t start = 0;
  while (start <= s.size()) {
    size_t end = s.find(',', start);
    if (end == std::string::npos) end = s.size();
    std::string o = s.substr(start, end - start);
    while (!o.empty() && o.front() == ' ') o.erase(0, 1);
    while (!o.empty() && (o.back() == ' ' || o.back() == '/')) o.pop_back();
    if (!o.empty()) out.push_back(o);
    start = end + 1;
  }
}

// Applies one setting; returns an error line or "".
std::string Apply(ServeConfig& c, const std::string& key, const std::string& value) {
  long long n = 0;
  if (key == "rigs") c.rigs = value;
  else if (key == "store") c.store = value;
  else if (key == "host") c.host = value;
  else if (key == "port") {
    if (!ParseSize(value, 0, 65535, &n)) return "port must be 0..65535, not '" + value + "'";
    c.port = static_cast<int>(n);
  } else if (key == "threads") {
    if (!ParseSize(value, 1, 4096, &n)) return "threads must be 1..4096, not '" + value + "'";
    c.threads = static_cast<int>(n);
  } else if (key == "api-key-file") c.api_key_file = value;
  else if (key == "max-body") {
    if (!ParseSize(value, 1024, 1ll << 34, &n)) return "max-body must be 1024..17179869184 bytes, not '" + value + "'";
    c.max_body = static_cast<size_t>(n);
  } else if (key == "cache-mb") {
    if (!ParseSize(value, 0, 1 << 20, &n)) return "cache-mb must be 0..1048576, not '" + value + "'";
    c.cache_mb = static_cast<size_t>(n);
  } else if (key == "max-render") {
    if (!ParseSize(value, 16, 8192, &n)) return "max-render must be 16..8192 pixels, not '" + value + "'";
    c.max_render = static_cast<int>(n);
  } else if (key == "max-sheet-cells") {
    if (!ParseSize(value, 1, 4096, &n)) return "max-sheet-cells must be 1..4096, not '" + value + "'";
    c.max_sheet_cells = static_cast<int>(n);
  } else if (key == "max-response") {
    if (!ParseSize(value, 1024, 1ll << 34, &n)) return "max-response must be 1024..17179869184 bytes, not '" + value + "'";
    c.max_response = static_cast<size_t>(n);
  } else if (key == "max-frames") {
    if (!ParseSize(value, 1, 100000000, &n)) return "max-frames must be 1..100000000, not '" + value + "'";
    c.max_frames = static_cast<size_t>(n);
  } else if (key == "cors-origin") SplitOrigins(value, c.cors_origins);
  else if (key == "jobs-dir") c.jobs_dir = value;
  else if (key == "max-vertices") {
    if (!ParseSize(value, 3, 100000000, &n)) return "max-vertices must be 3..100000000, not '" + value + "'";
    c.max_vertices = static_cast<size_t>(n);
  } else if (key == "max-shapes") {
    if (!ParseSize(value, 0, 100000, &n)) return "max-shapes must be 0..100000, not '" + value + "'";
    c.max_shapes = static_cast<size_t>(n);
  } else if (key == "store-poll") {
    char* end = nullptr;
    const double s = std::strtod(value.c_str(), &end);
    if (value.empty() || *end || !(s >= 0 && s <= 3600)) return "store-poll must be 0..3600 seconds (0: never), not '" + value + "'";
    c.store_poll_ms = static_cast<int>(s * 1000);
  } else if (key == "render-threads") {
    if (!ParseSize(value, 0, 256, &n)) return "render-threads must be 0..256 (0: one per core), not '" + value + "'";
    c.render_threads = static_cast<int>(n);
  } else if (key == "read-timeout") {
    if (!ParseSize(value, 1, 3600, &n)) return "read-timeout must be 1..3600 seconds, not '" + value + "'";
    c.read_timeout = static_cast<int>(n);
  }
  else if (key == "max-connections") {
    if (!ParseSize(value, 1, 1000000, &n)) return "max-connections must be 1..1000000, not '" + value + "'";
    c.max_connections = static_cast<size_t>(n);
  } else if (key == "max-client-connections") {
    if (!ParseSize(value, 1, 1000000, &n)) return "max-client-connections must be 1..1000000, not '" + value + "'";
    c.max_client_connections = static_cast<size_t>(n);
  } else if (key == "max-live-sessions" || key == "max-client-live-sessions") {
    if (!ParseSize(value, 1, 1000000, &n)) return key + " must be 1..1000000, not '" + value + "'";
    (key == "max-live-sessions" ? c.max_live_sessions : c.max_client_live_sessions) = static_cast<size_t>(n);
  } else if (key == "live-seconds") {
    if (!ParseSize(value, 1, 86400, &n)) return "live-seconds must be 1..86400, not '" + value + "'";
    c.live_seconds = static_cast<int>(n);
  } else if (key == "render-budget-mb") {
    if (!ParseSize(value, 16, 1 << 20, &n)) return "render-budget-mb must be 16..1048576, not '" + value + "'";
    c.render_budget_mb = static_cast<size_t>(n);
  } else if (key == "render-memory-mb") {
    if (!ParseSize(value, 16, 1 << 20, &n)) return "render-memory-mb must be 16..1048576, not '" + value + "'";
    c.render_memory_mb = static_cast<size_t>(n);
  } else if (key == "body-budget-mb") {
    if (!ParseSize(value, 1, 1 << 20, &n)) return "body-budget-mb must be 1..1048576, not '" + value + "'";
    c.body_budget_mb = static_cast<size_t>(n);
  }
  else if (key == "anonymous-cpu" || key == "keyed-cpu" || key == "drain") {
    char* end = nullptr;
    const double v = std::strtod(value.c_str(), &end);
    if (value.empty() || *end || !(v > 0 && v <= 1e6)) return key + " must be a number of seconds above 0, not '" + value + "'";
    (key == "drain" ? c.drain : key == "keyed-cpu" ? c.keyed_cpu : c.anonymous_cpu) = v;
  } else if (key == "max-client-requests") {
    if (!ParseSize(value, 1, 100000, &n)) return "max-client-requests must be 1..100000, not '" + value + "'";
    c.max_client_requests = static_cast<size_t>(n);
  } else if (key == "request-deadline" || key == "keyed-deadline") {
    if (!ParseSize(value, 1, 86400, &n)) return key + " must be 1..86400 seconds, not '" + value + "'";
    (key == "request-deadline" ? c.request_deadline : c.keyed_deadline) = static_cast<int>(n);
  } else if (key == "min-send-rate") {
    if (!ParseSize(value, 0, 1 << 20, &n)) return "min-send-rate must be 0..1048576 KiB/s (0: none), not '" + value + "'";
    c.min_send_rate_kib = static_cast<size_t>(n);
  }
  else if (key == "max-jobs") {
    if (!ParseSize(value, 1, 1000, &n)) return "max-jobs must be 1..1000, not '" + value + "'";
    c.job_limits.max_jobs = static_cast<size_t>(n);
  } else if (key == "max-batch") {
    if (!ParseSize(value, 1, 65000, &n)) return "max-batch must be 1..65000 variants, not '" + value + "'";
    c.job_limits.max_batch = static_cast<size_t>(n);
  } else if (key == "batch-threads") {
    if (!ParseSize(value, 0, 1024, &n)) return "batch-threads must be 0..1024 (0: every core), not '" + value + "'";
    c.job_limits.threads = static_cast<int>(n);
  } else if (key == "keep-free-mb") {
    if (!ParseSize(value, 0, size_t{1} << 30, &n)) return "keep-free-mb must be 0..1073741824 MB (0: 5% of the disk, at most 1 GiB), not '" + value + "'";
    c.job_limits.keep_free = static_cast<size_t>(n) << 20;
  }
  else return "unknown option --" + key;
  return "";
}

// Every setting: its flag (--KEY), its environment variable (FACESPACE_ and the key in capitals with _ for -;
// cors-origin's is FACESPACE_CORS_ORIGINS), and its help ("WHAT: text").
constexpr std::pair<const char*, const char*> kSettings[] = {
    {"rigs", "DIR: rigs to serve (.glb/.gltf/... files and folders; default: the bundled ones, read-only)"},
    {"store", "DIR: where uploads are written (default: --rigs when given, else ~/.local/state/facespace/rigs)"},
    {"store-poll", "SECONDS: how often to pick up rigs other instances sharing the store changed (default 1; 0: never)"},
    {"host", "ADDRESS: to listen on (default 127.0.0.1)"},
    {"port", "N: to listen on, 0 for any free one (default 8080)"}, {"threads", "N: HTTP worker threads running whole requests (default 64)"},
    {"max-connections", "N: connections open at once; more get 503 (default 4096)"},
    {"max-client-connections", "N: connections open at once from one address; more get 503 (default 256)"},
    {"max-live-sessions", "N: live WebSocket sessions open at once; more get 503 (default 1024)"},
    {"max-client-live-sessions", "N: live sessions open at once from one address; more get 503 (default 128)"},
    {"live-seconds", "SECONDS: how long a live session without the API key may last (default 3600; with the key a day)"},
    {"render-budget-mb", "MB: estimated working memory of one render or sheet; above, 413 (default 1024)"},
    {"render-memory-mb", "MB: working memory of the renders in flight together; past it they wait 2 s, then 503 (default 2048)"},
    {"body-budget-mb", "MB: request bodies held in memory at once, all connections together; past it 503 (default 1024)"},
    {"api-key-file", "FILE: the key uploads, deletes and batch jobs need (none: they are refused)"},
    {"max-body", "BYTES: largest request body (default 64 MiB)"}, {"cors-origin", "ORIGIN: a browser origin allowed, or * (repeatable)"},
    {"cache-mb", "MB: response cache (default 64)"}, {"max-render", "PIXELS: largest render width or height (default 2048)"},
    {"max-sheet-cells", "N: cells of one contact sheet (default 64)"},
    {"max-response", "BYTES: largest response built whole, sequence/sample (default 64 MiB)"},
    {"max-frames", "N: frames of one sequence stream (default 100000)"},
    {"jobs-dir", "DIR: where batch jobs live"}, {"max-jobs", "N: batch jobs queued or running (default 4)"},
    {"max-batch", "N: variants per batch job (default 10000)"}, {"batch-threads", "N: threads of the running job (0: every core)"},
    {"keep-free-mb", "MB: the jobs folder's disk kept free: a batch that would pass it is refused 507, a running one stops failed (default 0: 5% of the disk, at most 1 GiB)"},
    {"max-vertices", "N: per uploaded rig (default 1000000)"}, {"max-shapes", "N: per uploaded rig (default 1024)"},
    {"read-timeout", "SECONDS: a client may take to send a whole request, head and body (default 10, plus 1 s per MiB of body)"},
    {"render-threads", "N: renders drawing at once (0: one per core)"},
    {"anonymous-cpu", "SECONDS: estimated CPU one request without the API key may cost; more is 422 over-budget (default 2)"},
    {"keyed-cpu", "SECONDS: ... one request with the key (default 600)"},
    {"max-client-requests", "N: requests of one address running at once; its others wait their turn (default 16)"},
    {"request-deadline", "SECONDS: a request's work and answer, then it is stopped (default 120)"},
    {"keyed-deadline", "SECONDS: ... for a request with the key (default 1800)"},
    {"min-send-rate", "KIB: a second a client must read an answer at, after a 10 s grace; slower ones are cut off (default 32)"},
    {"drain", "SECONDS: after SIGTERM, work in flight is stopped and the process exits within this (default 8)"}};

std::string EnvironmentName(std::string_view key) {
  std::string name = "FACESPACE_";
  for (char ch : key) name += ch == '-' ? '_' : static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  return key == "cors-origin" ? name + "S" : name;
}

// The configuration from the environment, then the flags (which win); -1 to go on, else the exit code.
int ReadServeConfig(const std::vector<std::string>& args, ServeConfig& c) {
  for (const auto& [key, help] : kSettings) {
    const std::string var = EnvironmentName(key);
    if (const char* v = std::getenv(var.c_str()); v && *v) {
      if (std::string e = Apply(c, key, v); !e.empty()) {
        std::fprintf(stderr, "facespace: %s: %s\n", var.c_str(), e.c_str());
        return 2;
      }
    }
  }
  Flags flags("usage: facespace serve [--rigs DIR] [--host 127.0.0.1] [--port 8080] [--api-key-file FILE] [more flags]\n",
              "The HTTP service on the rigs of --rigs (default: the bundled ones); the character-creator page at /.\n"
              "Every flag has an environment variable: FACESPACE_ and the flag in capitals with _ for - (FACESPACE_PORT,\n"
              "FACESPACE_CORS_ORIGINS comma-separated); flags win over the environment.\n"
              "Batch jobs are kept in --jobs-dir (default ~/.local/state/facespace/jobs) and resume after a restart.\n");
  for (const auto& [key, help] : kSettings) {
    const std::string h = help;
    flags.Value(std::string("--") + key, h.substr(0, h.find(':')), h.substr(h.find(':') + 2), [&c, key = std::string(key)](const std::string& v) {
      if (std::string e = Apply(c, key, v); !e.empty()) return std::fprintf(stderr, "error: --%s\n", e.c_str()), 2;
      return 0;
    });
  }
  flags.Switch("--quiet", "no access log", [&c] { c.quiet = true; });
  std::vector<std::string> positional;
  if (int rc = flags.Parse(args, positional); rc >= 0) return rc;
  if (!positional.empty()) return flags.UsageError("unexpected argument '" + positional[0] + "'");
  return -1;

}

// The estimates are of this build's work uninstrumented: under AddressSanitizer the same work costs about
// ten times the CPU, and the meter allows for it.
#if defined(__SANITIZE_ADDRESS__)
constexpr double kInstrumentedSlowdown = 10;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr double kInstrumentedSlowdown = 10;
#else
constexpr double kInstrumentedSlowdown = 1;
#endif
#else
constexpr double kInstrumentedSlowdown = 1;
#endif

// The API's options from the configuration: the key read from its file (empty when none); false, said
// on stderr, when the key file cannot be read or is too short.
bool MakeApiOptions(const ServeConfig& c, api::ApiOptions& options) {
  if (!c.api_key_file.empty()) {
    std::ifstream f(c.api_key_file, std::ios::binary);
    if (!f) {
      std::fprintf(stderr, "facespace: cannot read the API key file '%s'\n", c.api_key_file.c_str());
      return false;
    }
    std::string key((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    while (!key.empty() && (key.back() == '\n' || key.back() == '\r' || key.back() == ' ')) key.pop_back();
    if (key.size() < 3) {
      std::fprintf(stderr, "facespace: the API key in '%s' is empty or too short\n", c.api_key_file.c_str());
      return false;
    }
    options.api_key = key;
  }
  options.cors_origins = c.cors_origins;
  options.max_body = c.max_body;
  options.cache_bytes = c.cache_mb << 20;
  options.log_requests = !c.quiet;
  options.max_render_size = c.max_render;
  options.max_sheet_cells = c.max_sheet_cells;
  options.max_response = c.max_response;
  options.max_frames = c.max_frames;
  options.render_budget = c.render_budget_mb << 20;
  options.render_memory = std::max(c.render_memory_mb, c.render_budget_mb) << 20;
  options.anonymous_cpu = c.anonymous_cpu;
  options.keyed_cpu = c.keyed_cpu;
  options.max_live_sessions = c.max_live_sessions;
  options.max_client_live_sessions = c.max_client_live_sessions;
  options.live_seconds = c.live_seconds;

  return true;
}

// The connection front's options from the configuration; `api` answers its head checks once it exists.
api::FrontOptions MakeFrontOptions(const ServeConfig& c, api::Api* const& api_for_front) {
  api::FrontOptions front;
  front.workers = c.threads;
  front.request_timeout = c.read_timeout;
  front.keep_alive_timeout = 5;
  front.keep_alive_max = 10000;
  front.write_timeout = 10;
  front.max_body = c.max_body;
  front.max_connections = c.max_connections;
  front.max_per_client = c.max_client_connections;
  front.body_budget = c.body_budget_mb << 20;
  front.log_requests = !c.quiet;
  front.head_check = [&api_for_front](const api::RequestHeadView& head) { return api_for_front->CheckHead(head); };
  front.probe = [&api_for_front](const api::RequestHeadView& head) { return api_for_front->Probe(head); };
  front.max_client_requests = c.max_client_requests;
  front.request_deadline = c.request_deadline;
  front.keyed_deadline = c.keyed_deadline;
  front.min_send_rate = c.min_send_rate_kib << 10;
  // The meter behind the estimates: a request whose worker spends twice its budget (and a second) is stopped.
  front.cpu_limit = (2 * c.anonymous_cpu + 1) * kInstrumentedSlowdown;
  front.keyed_cpu_limit = (2 * c.keyed_cpu + 1) * kInstrumentedSlowdown;
  front.keyed = [&api_for_front](std::string_view authorization) { return api_for_front->Keyed(authorization); };
  // Work that waits for a scarce resource waits in the front, not on a worker: renders and sheets for a GL
  // context (gate 0, two a context), recognitions of a recording for the speech decoder (gate 1, two).
  front.scarce = [](std::string_view method, std::string_view target, std::string_view content_type) {
    const std::string_view path = target.substr(0, target.find('?'));
    if (!path.starts_with("/v1/rigs/")) return -1;
    if (path.ends_with("/render") || path.ends_with("/sheet")) return 0;
    if (method == "POST" && path.ends_with("/speech") && content_type.starts_with("audio/")) return 1;
    return -1;
  };
  const int contexts = c.render_threads > 0 ? c.render_threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  front.scarce_slots = {2 * static_cast<size_t>(contexts), 2};
  return front;
}

// The character-creator page at / and its files.
void ServePage(httplib::Server& server) {
  for (size_t i = 0; i < web::kAssetCount; ++i) {
    const web::Asset& asset = web::kAssets[i];
    const std::string path = asset.path;
    const char* type = path.ends_with(".html") ? "text/html; charset=utf-8"
                       : path.ends_with(".js")  ? "text/javascript; charset=utf-8"
                       : path.ends_with(".css") ? "text/css; charset=utf-8"
                                                : "image/svg+xml";
    auto handler = [&asset, type](const httplib::Request&, httplib::Response& res) {
      res.set_header("Cache-Control", "no-cache");
      res.set_header("Content-Security-Policy",
                     "default-src 'self'; img-src 'self' blob: data:; media-src 'self' blob:; connect-src *; style-src 'self'; script-src 'self'");
      res.set_content(reinterpret_cast<const char*>(asset.data), asset.size, type);
    };
    server.Get(path, handler);
    if (path == "/index.html") server.Get("/", handler);
  }

}

// Where uploads go, and what is served read-only: a given --rigs is the store itself (unless a
// --store is given too); the bundled rigs are never written. False, said on stderr, when the store
// folder cannot be made (a --rigs folder that is not there is a typo, refused when it is read).
bool StoreFolders(const ServeConfig& c, std::string& store_dir, std::vector<std::string>& read_only) {
  store_dir = c.store;
  if (c.rigs.empty()) {
    read_only.push_back(FACESPACE_DEFAULT_RIGS);
    if (store_dir.empty()) store_dir = StateDir("rigs");
  } else if (store_dir.empty()) {
    store_dir = c.rigs;
  } else {
    read_only.push_back(c.rigs);
  }
  if (std::error_code ec; store_dir != c.rigs && !std::filesystem::create_directories(store_dir, ec) && ec) {
    std::fprintf(stderr, "facespace: cannot create the store '%s': %s\n", store_dir.c_str(), ec.message().c_str());
    return false;
  }
  return true;
}

// Binds `server` to --host and --port (0: any free one) with the kernel's largest backlog; the port, or -1.
int Bind(httplib::Server& server, const ServeConfig& c) {
  // cpp-httplib's own socket options set SO_REUSEPORT, with which a second server on the same
  // port starts without a word and takes half the connections. SO_REUSEADDR alone still lets a
  // restart bind over connections in TIME_WAIT.
  int listening = -1;
  server.set_socket_options([&listening](int fd) {
    const int yes = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    listening = fd;  // The last socket tried is the one bound.
  });
  const int port = c.port == 0 ? server.bind_to_any_port(c.host) : (server.bind_to_port(c.host, c.port) ? c.port : -1);
  if (port < 0) {
    std::fprintf(stderr, "facespace: cannot listen on %s:%d (in use, or not an address of this machine)\n", c.host.c_str(), c.port);
    return -1;
  }
  // cpp-httplib listens with a backlog of 5. When 64 clients connect at once while the cores are
  // busy (renders in flight), the kernel drops the SYNs beyond it and the clients wait for their
  // retransmission, 1 s and then 3 s later: that was the load test's latency tail and its
  // time-outs. Listening again on a bound socket only changes the backlog (capped by
  // net.core.somaxconn).
  if (listening < 0 || ::listen(listening, SOMAXCONN) != 0) {
    std::fprintf(stderr, "facespace: warning: cannot raise the listen backlog; bursts of connections may wait\n");
  }
  return port;
}

// Serves until SIGINT or SIGTERM (taken by one thread with sigwait), then stops: the front stops the work
// in flight, and the process exits within `drain` seconds whatever is left. False when listening failed.
bool ListenUntilSignalled(httplib::Server& server, const sigset_t& signals, double drain_seconds) {
  std::atomic<bool> signalled{false};
  std::thread waiter([&server, &signalled, signals, drain = drain_seconds] {
    int sig = 0;
    sigwait(&signals, &sig);
    if (!signalled.exchange(true)) {
      std::fprintf(stderr, "facespace: %s received, stopping the requests in flight (at most %g s)\n", sig == SIGINT ? "SIGINT" : "SIGTERM", drain);
      // The drain is bounded: work that does not stop in time is left (files are written whole, so
      // nothing is half-stored) and the process exits as a stopped one does.
      std::thread([drain] {
        std::this_thread::sleep_for(std::chrono::duration<double>(drain));
        std::fprintf(stderr, "facespace: still draining after %g s (--drain): exiting\n", drain);
        std::fflush(stderr);
        std::_Exit(0);
      }).detach();
    }
    server.stop();
  });
  const bool ok = server.listen_after_bind();
  if (!signalled.exchange(true)) pthread_kill(waiter.native_handle(), SIGTERM);  // Wake the waiter.
  waiter.join();
  return ok;
}

}  // namespace

int Serve(const std::vector<std::string>& args) {
  ServeConfig c;
  if (int rc = ReadServeConfig(args, c); rc >= 0) return rc;

  api::ApiOptions options;
  if (!MakeApiOptions(c, options)) return 1;
  std::vector<std::string> read_only;
  std::string store_dir;
  if (!StoreFolders(c, store_dir, read_only)) return 1;
  if (const std::string problem = render::ImageModuleProblem(); !problem.empty()) {
    std::fprintf(stderr, "facespace: warning: %s: renders draw without textures or labels, and only PNG and WebP are written\n",
                 problem.c_str());
  }
  FileRigStore store(store_dir, read_only);
  store.SetUploadLimits(c.max_vertices, c.max_shapes);
  auto loaded = store.LoadAll();
  if (!loaded.ok()) {
    std::fprintf(stderr, "facespace: %s\n", loaded.status().message.c_str());
    return 1;
  }

  // SIGINT/SIGTERM are taken by one thread with sigwait: block them before any other thread
  // starts, so every worker inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  ::signal(SIGPIPE, SIG_IGN);

  if (c.jobs_dir.empty()) c.jobs_dir = DefaultJobsDir();
  // One renderer for every thread: its GL contexts are a bounded pool (--render-threads).
  render::OsMesaRenderer renderer(c.render_threads);
  const api::Evaluator evaluator(renderer);
  // Instances sharing a store (a shared filesystem behind a balancer) see each other's uploads,
  // replacements and deletes within --store-poll: a stat per file per poll, a read only of what
  // moved. The job runner asks too, for the rig of a job another instance accepted.
  auto refresh_store = [&store] {
    auto changes = store.Refresh();
    if (!changes.ok()) {
      std::fprintf(stderr, "facespace: store: %s\n", changes.status().message.c_str());
      return;
    }
    for (const auto& [what, ids] : {std::pair{"added", &changes->added}, std::pair{"replaced", &changes->replaced},
                                    std::pair{"removed", &changes->removed}}) {
      for (const std::string& id : *ids) std::fprintf(stderr, "facespace: store: rig '%s' %s on disk\n", id.c_str(), what);
    }
  };
  batch::FileJobQueue jobs(c.jobs_dir, store, evaluator, c.job_limits, c.store_poll_ms > 0 ? c.store_poll_ms / 1000.0 : 1.0, refresh_store);
  auto resumed = jobs.Start();
  if (!resumed.ok()) {
    std::fprintf(stderr, "facespace: %s\n", resumed.status().message.c_str());
    return 1;
  }
  if (resumed.value() > 0) std::fprintf(stderr, "facespace: resuming %zu unfinished batch job(s) from %s\n", resumed.value(), c.jobs_dir.c_str());

  // Large buffers (response bodies of big meshes, images, render read-backs) straight from and
  // back to the system: glibc's default raises this threshold to the largest block freed so far,
  // after which such buffers come from the per-thread arenas and stay there, fragmented.
  mallopt(M_MMAP_THRESHOLD, 256 * 1024);
  // Fewer malloc arenas than glibc's default of 8 per core: with hundreds of threads each
  // arena keeps its own free pieces, and RSS crept up (+6 MB/min after 10 min of soak, heap in
  // use flat) where 2 per core held it level (tests/bench/soak.sh).
  mallopt(M_ARENA_MAX, 2 * static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  // Connections wait in the front (one epoll thread, deadlines for whole requests, caps per client
  // and in all, a budget for bodies in memory); only whole requests take one of the workers.
  api::Api* api_for_front = nullptr;
  const api::FrontOptions front = MakeFrontOptions(c, api_for_front);
  const int threads = c.threads;
  api::FrontServer server(front);
  options.front = &server.Stats();
  server.set_tcp_nodelay(true);
  server.set_keep_alive_max_count(10000);
  server.set_keep_alive_timeout(5);
  server.set_read_timeout(c.read_timeout, 0);
  server.set_write_timeout(10, 0);
  api::Api api(store, evaluator, options, &jobs);
  api.Register(server);
  api_for_front = &api;
  ServePage(server);

  const int port = Bind(server, c);
  if (port < 0) return 1;
  std::string from = store_dir;
  for (const std::string& r : read_only) from += " and " + r + " (read-only)";
  std::fprintf(stderr, "facespace: serving %zu rig(s) from %s on http://%s:%d (%d threads%s)\n", loaded.value(), from.c_str(),
               c.host.c_str(), port, threads, options.api_key.empty() ? ", uploads disabled: no API key" : "");
  std::fprintf(stderr, "facespace: renderer: %s (%d at once)\n", renderer.Info().c_str(), renderer.Concurrency());
  std::fflush(stderr);

  std::mutex poll_mu;
  std::condition_variable poll_cv;
  bool poll_stop = false;
  std::thread poller([&] {
    std::unique_lock<std::mutex> lock(poll_mu);
    while (c.store_poll_ms > 0 && !poll_cv.wait_for(lock, std::chrono::milliseconds(c.store_poll_ms), [&] { return poll_stop; })) {
      lock.unlock();
      refresh_store();
      lock.lock();
    }
  });

  const bool ok = ListenUntilSignalled(server, signals, c.drain);
  {
    std::lock_guard<std::mutex> lock(poll_mu);
    poll_stop = true;
  }
  poll_cv.notify_all();
  poller.join();
  std::fprintf(stderr, "facespace: stopped\n");
  return ok ? 0 : 1;
}

}  // namespace facespace::cli
