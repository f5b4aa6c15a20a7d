// `facespace serve`'s configuration: every setting in one table (settings.cpp), from which come its
// flag (--KEY), its environment variable (FACESPACE_KEY), its help with its default, its range
// check, and, for the limits and budgets, /openapi.json's info.x-facespace-limits.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "facespace/batch/queue.h"

namespace facespace::cli {

struct ServeConfig {
  std::string rigs;   // Empty: the bundled rigs, read-only, with uploads in `store`.
  std::string store;  // Where uploads go; empty: --rigs when given, else DefaultStoreDir().
  std::string host = "127.0.0.1";
  int port = 8080;
  int threads =
      64;  // Workers running whole requests; connections wait in the front, not on a thread.
  size_t max_connections = 4096;
  size_t max_client_connections = 256;
  size_t max_live_sessions = 1024;  // WebSocket sessions (GET /v1/rigs/{id}/live) at once, in all,
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
  std::vector<std::string> vmc_hosts;  // Beside loopback, for VMC and iFacialMocap (IPv4).
  bool quiet = false;
  size_t max_vertices = 1000000;  // Per uploaded rig.
  size_t max_shapes = 1024;
  double store_poll =
      1;  // Seconds between looks at the store's folders for other processes' changes; 0: never.
  int render_threads = 0;  // GL contexts, i.e. renders drawing at once; 0: one per core.
  int read_timeout = 10;  // Seconds a client may take to send a request (slow clients are cut off).
  std::string
      jobs_dir;  // Default: $XDG_STATE_HOME/facespace/jobs or ~/.local/state/facespace/jobs.
  batch::JobLimits job_limits;
  size_t keep_free_mb = 0;  // The jobs folder's disk kept free (0: 5% of the disk, at most 1 GiB).
  // What one request may cost (issue 48): estimated CPU-seconds before the work, wall time after.
  double anonymous_cpu = 2.0;       // A request without the API key; over it: 422 over-budget.
  double keyed_cpu = 600.0;         // ... with the key.
  size_t max_client_requests = 16;  // Requests of one address running at once; its others wait.
  int request_deadline = 120;  // Seconds a request's work and answer may take; then it is stopped.
  int keyed_deadline = 1800;
  size_t min_send_rate_kib =
      32;              // KiB a second a client must read an answer at (after a 10 s grace).
  double drain = 8.0;  // Seconds after SIGTERM before the process exits whatever is left.
};

// The configuration from the environment, then the flags (which win); -1 to go on, else the exit
// code.
int ReadServeConfig(const std::vector<std::string>& args, ServeConfig& c);

// Every number of the table as it stands in `c`, by its key with _ for - ("max_body",
// "keyed_cpu"...): the server's limits and budgets, for /openapi.json.
std::vector<std::pair<std::string, double>> Limits(const ServeConfig& c);

}  // namespace facespace::cli
