// facespace serve: configuration (flags, then environment, then defaults), the rig store,
// the HTTP server and graceful shutdown.
#include <arpa/inet.h>
#include <malloc.h>
#include <pthread.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <thread>

#include "commands/cli.h"
#include "commands/flags.h"
#include "facespace/batch/queue.h"
#include "facespace/http/http.h"
#include "facespace/offscreen/render.h"
#include "server/page_vendor.h"
#include "server/settings.h"
#include "server/web_assets.h"
#include "store/rig_store.h"

namespace facespace::cli {

namespace {

// $XDG_STATE_HOME/facespace/NAME, else ~/.local/state/facespace/NAME.
std::string StateDir(const std::string& name) {
  if (const char* x = std::getenv("XDG_STATE_HOME"); x && *x == '/')
    return std::string(x) + "/facespace/" + name;
  if (const char* h = std::getenv("HOME"); h && *h == '/')
    return std::string(h) + "/.local/state/facespace/" + name;
  return "/tmp/facespace-" + name + "-" + std::to_string(getuid());
}

std::string DefaultJobsDir() { return StateDir("jobs"); }

// The estimates are of this build's work uninstrumented: under AddressSanitizer the same work costs
// about ten times the CPU, and the meter allows for it.
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

// The API's options from the configuration: the key read from its file (empty when none); false,
// said on stderr, when the key file cannot be read or is too short.
bool MakeApiOptions(const ServeConfig& c, http::ApiOptions& options) {
  if (!c.api_key_file.empty()) {
    std::ifstream f(c.api_key_file, std::ios::binary);
    if (!f) {
      std::fprintf(stderr, "facespace: cannot read the API key file '%s'\n",
                   c.api_key_file.c_str());
      return false;
    }
    std::string key((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    while (!key.empty() && (key.back() == '\n' || key.back() == '\r' || key.back() == ' '))
      key.pop_back();
    if (key.size() < 3) {
      std::fprintf(stderr, "facespace: the API key in '%s' is empty or too short\n",
                   c.api_key_file.c_str());
      return false;
    }
    options.api_key = key;
  }
  options.limits = Limits(c);
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
  for (const std::string& h : c.vmc_hosts) {
    in_addr a{};
    if (inet_pton(AF_INET, h.c_str(), &a) != 1) {
      std::fprintf(stderr, "facespace: --vmc-hosts takes IPv4 addresses, not '%s'\n",
                   h.substr(0, 64).c_str());
      return false;
    }
  }
  options.vmc_hosts = c.vmc_hosts;

  return true;
}

// The connection front's options from the configuration; `api` answers its head checks and words
// its refusals.
net::FrontOptions MakeFrontOptions(const ServeConfig& c, http::Api& api) {
  net::FrontOptions front;
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
  front.head_check = [&api](const net::RequestHeadView& head) { return api.CheckHead(head); };
  front.probe = [&api](const net::RequestHeadView& head) { return api.Probe(head); };
  front.refusal = &http::Api::RefusalResponse;
  front.max_client_requests = c.max_client_requests;
  front.request_deadline = c.request_deadline;
  front.keyed_deadline = c.keyed_deadline;
  front.min_send_rate = c.min_send_rate_kib << 10;
  // The meter behind the estimates: a request whose worker spends twice its budget (and a second)
  // is stopped.
  front.cpu_limit = (2 * c.anonymous_cpu + 1) * kInstrumentedSlowdown;
  front.keyed_cpu_limit = (2 * c.keyed_cpu + 1) * kInstrumentedSlowdown;
  front.keyed = [&api](std::string_view authorization) { return api.Keyed(authorization); };
  // Work that waits for a scarce resource waits in the front, not on a worker: renders and sheets
  // for a GL context (gate 0, two a context), recognitions of a recording for the speech decoder
  // (gate 1, two).
  front.scarce = [](std::string_view method, std::string_view target,
                    std::string_view content_type) {
    const std::string_view path = target.substr(0, target.find('?'));
    if (!path.starts_with("/v1/rigs/")) return -1;
    if (path.ends_with("/render") || path.ends_with("/sheet")) return 0;
    if (method == "POST" && path.ends_with("/speech") && content_type.starts_with("audio/"))
      return 1;
    return -1;
  };
  const int contexts = c.render_threads > 0
                           ? c.render_threads
                           : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  front.scarce_slots = {2 * static_cast<size_t>(contexts), 2};
  return front;
}

// The character-creator page at / and its files.
void ServePage(httplib::Server& server) {
  for (size_t i = 0; i < web::kAssetCount; ++i) {
    const web::Asset& asset = web::kAssets[i];
    const std::string path = asset.path;
    const char* type = path.ends_with(".html")  ? "text/html; charset=utf-8"
                       : path.ends_with(".js")  ? "text/javascript; charset=utf-8"
                       : path.ends_with(".css") ? "text/css; charset=utf-8"
                                                : "image/svg+xml";
    // MediaPipe's tracker (the camera, /vendor) compiles its wasm and its emscripten glue evaluates
    // code: 'wasm-unsafe-eval' and 'unsafe-eval', scripts still from this origin alone.
    auto handler = [&asset, type](const httplib::Request&, httplib::Response& res) {
      res.set_header("Cache-Control", "no-cache");
      res.set_header(
          "Content-Security-Policy",
          "default-src 'self'; img-src 'self' blob: data:; media-src 'self' blob:; "
          "connect-src *; style-src 'self'; script-src 'self' 'wasm-unsafe-eval' 'unsafe-eval'");
      res.set_content(reinterpret_cast<const char*>(asset.data), asset.size, type);
    };
    server.Get(path, handler);
    if (path == "/index.html") server.Get("/", handler);
  }
}

// Where uploads go, and what is served read-only: a given --rigs is the store itself (unless a
// --store is given too); the bundled rigs are never written. False, said on stderr, when the store
// folder cannot be made (a --rigs folder that is not there is a typo, refused when it is read).
bool StoreFolders(const ServeConfig& c, std::string& store_dir,
                  std::vector<std::string>& read_only) {
  store_dir = c.store;
  if (c.rigs.empty()) {
    read_only.push_back(FACESPACE_DEFAULT_RIGS);
    if (store_dir.empty()) store_dir = StateDir("rigs");
  } else if (store_dir.empty()) {
    store_dir = c.rigs;
  } else {
    read_only.push_back(c.rigs);
  }
  if (std::error_code ec;
      store_dir != c.rigs && !std::filesystem::create_directories(store_dir, ec) && ec) {
    std::fprintf(stderr, "facespace: cannot create the store '%s': %s\n", store_dir.c_str(),
                 ec.message().c_str());
    return false;
  }
  return true;
}

// Binds `server` to --host and --port (0: any free one) with the kernel's largest backlog; the
// port, or -1.
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
  const int port = c.port == 0 ? server.bind_to_any_port(c.host)
                               : (server.bind_to_port(c.host, c.port) ? c.port : -1);
  if (port < 0) {
    std::fprintf(stderr,
                 "facespace: cannot listen on %s:%d (in use, or not an address of this machine)\n",
                 c.host.c_str(), c.port);
    return -1;
  }
  // cpp-httplib listens with a backlog of 5. When 64 clients connect at once while the cores are
  // busy (renders in flight), the kernel drops the SYNs beyond it and the clients wait for their
  // retransmission, 1 s and then 3 s later: that was the load test's latency tail and its
  // time-outs. Listening again on a bound socket only changes the backlog (capped by
  // net.core.somaxconn).
  if (listening < 0 || ::listen(listening, SOMAXCONN) != 0) {
    std::fprintf(
        stderr,
        "facespace: warning: cannot raise the listen backlog; bursts of connections may wait\n");
  }
  return port;
}

// Serves until SIGINT or SIGTERM (taken by one thread with sigwait), then stops: the front stops
// the work in flight, and the process exits within `drain` seconds whatever is left. False when
// listening failed.
bool ListenUntilSignalled(httplib::Server& server, const sigset_t& signals, double drain_seconds) {
  std::atomic<bool> signalled{false};
  std::thread waiter([&server, &signalled, signals, drain = drain_seconds] {
    int sig = 0;
    sigwait(&signals, &sig);
    if (!signalled.exchange(true)) {
      std::fprintf(stderr,
                   "facespace: %s received, stopping the requests in flight (at most %g s)\n",
                   sig == SIGINT ? "SIGINT" : "SIGTERM", drain);
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

// Instances sharing a store (a shared filesystem behind a balancer) see each other's uploads,
// replacements and deletes within --store-poll: a stat per file per poll, a read only of what
// moved. The job runner asks too, for the rig of a job another instance accepted.
void RefreshStore(FileRigStore& store) {
  auto changes = store.Refresh();
  if (!changes.ok()) {
    std::fprintf(stderr, "facespace: store: %s\n", changes.status().message.c_str());
    return;
  }
  for (const auto& [what, ids] :
       {std::pair{"added", &changes->added}, std::pair{"replaced", &changes->replaced},
        std::pair{"removed", &changes->removed}}) {
    for (const std::string& id : *ids)
      std::fprintf(stderr, "facespace: store: rig '%s' %s on disk\n", id.c_str(), what);
  }
}

void TuneMalloc() {
  // Large buffers (response bodies of big meshes, images, render read-backs) straight from and
  // back to the system: glibc's default raises this threshold to the largest block freed so far,
  // after which such buffers come from the per-thread arenas and stay there, fragmented.
  mallopt(M_MMAP_THRESHOLD, 256 * 1024);
  // Fewer malloc arenas than glibc's default of 8 per core: with hundreds of threads each
  // arena keeps its own free pieces, and RSS crept up (+6 MB/min after 10 min of soak, heap in
  // use flat) where 2 per core held it level (tests/bench/soak.sh).
  mallopt(M_ARENA_MAX, 2 * static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
}

sigset_t BlockStopSignals() {
  // SIGINT/SIGTERM are taken by one thread with sigwait: block them before any other thread
  // starts, so every worker inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  ::signal(SIGPIPE, SIG_IGN);
  return signals;
}

}  // namespace

int Serve(const std::vector<std::string>& args) {
  ServeConfig c;
  if (int rc = ReadServeConfig(args, c); rc >= 0) return rc;

  http::ApiOptions options;
  if (!MakeApiOptions(c, options)) return 1;
  std::vector<std::string> read_only;
  std::string store_dir;
  if (!StoreFolders(c, store_dir, read_only)) return 1;
  if (const std::string problem = offscreen::ImageModuleProblem(); !problem.empty()) {
    std::fprintf(stderr,
                 "facespace: warning: %s: renders draw without textures or labels, and only PNG "
                 "and WebP are written\n",
                 problem.c_str());
  }
  FileRigStore store(store_dir, read_only);
  store.SetUploadLimits(c.max_vertices, c.max_shapes);
  auto loaded = store.LoadAll();
  if (!loaded.ok()) {
    std::fprintf(stderr, "facespace: %s\n", loaded.status().message.c_str());
    return 1;
  }

  const sigset_t signals = BlockStopSignals();

  if (c.jobs_dir.empty()) c.jobs_dir = DefaultJobsDir();
  // One renderer for every thread: its GL contexts are a bounded pool (--render-threads).
  offscreen::OsMesaRenderer renderer(c.render_threads);
  const evaluator::Evaluator evaluator(renderer);
  auto refresh_store = [&store] { RefreshStore(store); };
  batch::FileJobQueue jobs(c.jobs_dir, store, evaluator, c.job_limits,
                           c.store_poll > 0 ? c.store_poll : 1.0, refresh_store);
  auto resumed = jobs.Start();
  if (!resumed.ok()) {
    std::fprintf(stderr, "facespace: %s\n", resumed.status().message.c_str());
    return 1;
  }
  if (resumed.value() > 0)
    std::fprintf(stderr, "facespace: resuming %zu unfinished batch job(s) from %s\n",
                 resumed.value(), c.jobs_dir.c_str());

  TuneMalloc();
  // Connections wait in the front (one epoll thread, deadlines for whole requests, caps per client
  // and in all, a budget for bodies in memory); only whole requests take one of the workers.
  // The API first (it reports the front's counters), then the front that calls it: no start-up
  // cycle.
  net::FrontStats front_stats;
  options.front = &front_stats;
  http::Api api(store, evaluator, options, &jobs);
  const int threads = c.threads;
  net::FrontServer server(MakeFrontOptions(c, api), front_stats);
  server.set_tcp_nodelay(true);
  server.set_keep_alive_max_count(10000);
  server.set_keep_alive_timeout(5);
  server.set_read_timeout(c.read_timeout, 0);
  server.set_write_timeout(10, 0);
  api.Register(server);
  ServePage(server);
  ServeVendor(server);

  const int port = Bind(server, c);
  if (port < 0) return 1;
  std::string from = store_dir;
  for (const std::string& r : read_only) from += " and " + r + " (read-only)";
  std::fprintf(stderr, "facespace: serving %zu rig(s) from %s on http://%s:%d (%d threads%s)\n",
               loaded.value(), from.c_str(), c.host.c_str(), port, threads,
               options.api_key.empty() ? ", uploads disabled: no API key" : "");
  std::fprintf(stderr, "facespace: renderer: %s (%d at once)\n", renderer.Info().c_str(),
               renderer.Concurrency());
  std::fflush(stderr);

  std::mutex poll_mu;
  std::condition_variable poll_cv;
  bool poll_stop = false;
  std::thread poller([&] {
    std::unique_lock<std::mutex> lock(poll_mu);
    while (c.store_poll > 0 &&
           !poll_cv.wait_for(lock, std::chrono::milliseconds(static_cast<int>(c.store_poll * 1000)),
                             [&] { return poll_stop; })) {
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
