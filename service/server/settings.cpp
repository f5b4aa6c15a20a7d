// `facespace serve`'s settings, one table (settings.h).
#include "server/settings.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "commands/flags.h"
#include "facespace/engine/weights.h"

namespace facespace::cli {

namespace {

// One setting: a number (its range, integer or not, how it is read from and written to the
// configuration) or a text. `unit` names the value in the help; the help says no default, which
// comes from ServeConfig's own.
struct Setting {
  const char* key;
  const char* unit;
  const char* help;
  double lo = 0, hi = 0;
  bool fraction = false;  // A decimal number (seconds); else an integer.
  double (*get)(const ServeConfig&) = nullptr;
  void (*set)(ServeConfig&, double) = nullptr;
  void (*text)(ServeConfig&, const std::string&) = nullptr;  // A text setting: no range.
  bool limit = true;  // A limit or budget: listed in /openapi.json's x-facespace-limits.
};

#define FS_FIELD(f)                                              \
  [](const ServeConfig& c) { return static_cast<double>(c.f); }, \
      [](ServeConfig& c, double v) { c.f = static_cast<decltype(c.f)>(v); }
#define FS_TEXT(f) nullptr, nullptr, [](ServeConfig& c, const std::string& v) { c.f = v; }

constexpr double kBytes34 = 17179869184.0;  // 2^34.

// The comma-separated items of `s`, spaces (and with `slashes`, trailing slashes) trimmed, into
// `out`.
void SplitList(const std::string& s, bool slashes, std::vector<std::string>& out) {
  size_t start = 0;
  while (start <= s.size()) {
    size_t end = s.find(',', start);
    if (end == std::string::npos) end = s.size();
    std::string item = s.substr(start, end - start);
    while (!item.empty() && item.front() == ' ') item.erase(0, 1);
    while (!item.empty() && (item.back() == ' ' || (slashes && item.back() == '/')))
      item.pop_back();
    if (!item.empty()) out.push_back(item);
    start = end + 1;
  }
}

void SplitOrigins(ServeConfig& c, const std::string& s) { SplitList(s, true, c.cors_origins); }
void SplitHosts(ServeConfig& c, const std::string& s) { SplitList(s, false, c.vmc_hosts); }

const Setting kSettings[] = {
    {"rigs", "DIR",
     "rigs to serve (.glb/.gltf/... files and folders; default: the bundled ones, read-only)", 0, 0,
     false, FS_TEXT(rigs)},
    {"store", "DIR",
     "where uploads are written (default: --rigs when given, else ~/.local/state/facespace/rigs)",
     0, 0, false, FS_TEXT(store)},
    {"store-poll", "SECONDS",
     "how often to pick up rigs other instances sharing the store changed (0: never)", 0, 3600,
     true, FS_FIELD(store_poll), nullptr, false},
    {"host", "ADDRESS", "to listen on", 0, 0, false, FS_TEXT(host)},
    {"port", "N", "to listen on, 0 for any free one", 0, 65535, false, FS_FIELD(port), nullptr,
     false},
    {"threads", "N", "HTTP worker threads running whole requests", 1, 4096, false,
     FS_FIELD(threads)},
    {"max-connections", "N", "connections open at once; more get 503", 1, 1e6, false,
     FS_FIELD(max_connections)},
    {"max-client-connections", "N", "connections open at once from one address; more get 503", 1,
     1e6, false, FS_FIELD(max_client_connections)},
    {"max-live-sessions", "N", "live WebSocket sessions open at once; more get 503", 1, 1e6, false,
     FS_FIELD(max_live_sessions)},
    {"max-client-live-sessions", "N", "live sessions open at once from one address; more get 503",
     1, 1e6, false, FS_FIELD(max_client_live_sessions)},
    {"live-seconds", "SECONDS",
     "how long a live session without the API key may last (with the key a day)", 1, 86400, false,
     FS_FIELD(live_seconds)},
    {"render-budget-mb", "MB", "estimated working memory of one render or sheet; above, 413", 16,
     1 << 20, false, FS_FIELD(render_budget_mb)},
    {"render-memory-mb", "MB",
     "working memory of the renders in flight together; past it they wait 2 s, then 503", 16,
     1 << 20, false, FS_FIELD(render_memory_mb)},
    {"body-budget-mb", "MB",
     "request bodies held in memory at once, all connections together; past it 503", 1, 1 << 20,
     false, FS_FIELD(body_budget_mb)},
    {"api-key-file", "FILE",
     "the key uploads, deletes and batch jobs need (none: they are refused)", 0, 0, false,
     FS_TEXT(api_key_file)},
    {"max-body", "BYTES", "largest request body", 1024, kBytes34, false, FS_FIELD(max_body)},
    {"cors-origin", "ORIGIN",
     "a browser origin allowed, or * (repeatable; comma-separated in the environment)", 0, 0, false,
     nullptr, nullptr, SplitOrigins},
    {"vmc-hosts", "ADDRESSES",
     "IPv4 addresses beside this machine's that live sessions may send VMC to and read VMC and "
     "iFacialMocap from (comma-separated, repeatable; default: loopback only)",
     0, 0, false, nullptr, nullptr, SplitHosts},
    {"cache-mb", "MB", "response cache", 0, 1 << 20, false, FS_FIELD(cache_mb)},
    {"max-render", "PIXELS", "largest render width or height", 16, 8192, false,
     FS_FIELD(max_render)},
    {"max-sheet-cells", "N", "cells of one contact sheet", 1, 4096, false,
     FS_FIELD(max_sheet_cells)},
    {"max-response", "BYTES", "largest response built whole, sequence/sample", 1024, kBytes34,
     false, FS_FIELD(max_response)},
    {"max-frames", "N", "frames of one sequence stream", 1, 1e8, false, FS_FIELD(max_frames)},
    {"jobs-dir", "DIR", "where batch jobs live (default ~/.local/state/facespace/jobs)", 0, 0,
     false, FS_TEXT(jobs_dir)},
    {"max-jobs", "N", "batch jobs queued or running", 1, 1000, false,
     FS_FIELD(job_limits.max_jobs)},
    {"max-batch", "N", "variants per batch job", 1, 65000, false, FS_FIELD(job_limits.max_batch)},
    {"batch-threads", "N", "threads of the running job (0: every core)", 0, 1024, false,
     FS_FIELD(job_limits.threads)},
    {"keep-free-mb", "MB",
     "the jobs folder's disk kept free: a batch that would pass it is refused 507, a running one "
     "stops "
     "failed (0: 5% of the disk, at most 1 GiB)",
     0, 1 << 30, false, FS_FIELD(keep_free_mb)},
    {"max-vertices", "N", "per uploaded rig", 3, 1e8, false, FS_FIELD(max_vertices)},
    {"max-shapes", "N", "per uploaded rig", 0, 100000, false, FS_FIELD(max_shapes)},
    {"read-timeout", "SECONDS",
     "a client may take to send a whole request, head and body (plus 1 s per MiB of body)", 1, 3600,
     false, FS_FIELD(read_timeout)},
    {"render-threads", "N", "renders drawing at once (0: one per core)", 0, 256, false,
     FS_FIELD(render_threads)},
    {"anonymous-cpu", "SECONDS",
     "estimated CPU one request without the API key may cost; more is 422 over-budget", 1e-6, 1e6,
     true, FS_FIELD(anonymous_cpu)},
    {"keyed-cpu", "SECONDS", "... one request with the key", 1e-6, 1e6, true, FS_FIELD(keyed_cpu)},
    {"max-client-requests", "N",
     "requests of one address running at once; its others wait their turn", 1, 100000, false,
     FS_FIELD(max_client_requests)},
    {"request-deadline", "SECONDS", "a request's work and answer, then it is stopped", 1, 86400,
     false, FS_FIELD(request_deadline)},
    {"keyed-deadline", "SECONDS", "... for a request with the key", 1, 86400, false,
     FS_FIELD(keyed_deadline)},
    {"min-send-rate", "KIB",
     "a second a client must read an answer at, after a 10 s grace; slower ones are cut off (0: "
     "none)",
     0, 1 << 20, false, FS_FIELD(min_send_rate_kib)},
    {"drain", "SECONDS",
     "after SIGTERM, work in flight is stopped and the process exits within this", 1e-6, 1e6, true,
     FS_FIELD(drain), nullptr, false},
};

#undef FS_FIELD
#undef FS_TEXT

bool IsNumber(const Setting& s) { return s.set != nullptr; }

// A whole number as its digits (67108864, not 6.7e+07), else the shortest text that reads back as
// it.
std::string Text(double v) {
  if (v == std::floor(v) && std::fabs(v) < 1e15) return std::to_string(static_cast<long long>(v));
  return FormatNumber(v);
}

std::string Range(const Setting& s) { return Text(s.lo) + ".." + Text(s.hi); }

// Applies one setting's text; returns an error line or "".
std::string Apply(ServeConfig& c, const Setting& s, const std::string& value) {
  if (!IsNumber(s)) {
    s.text(c, value);
    return "";
  }
  char* end = nullptr;
  const double v = std::strtod(value.c_str(), &end);
  const bool integral = value.find_first_not_of("0123456789") == std::string::npos;
  if (value.empty() || *end || !(v >= s.lo && v <= s.hi) || (!s.fraction && !integral) ||
      value.size() > 24) {
    return std::string(s.key) + " must be " + (s.fraction ? "a number " : "an integer ") +
           Range(s) + " (" + s.unit + "), not '" + value.substr(0, 40) + "'";
  }
  s.set(c, v);
  return "";
}

std::string EnvironmentName(std::string_view key) {
  std::string name = "FACESPACE_";
  for (char ch : key)
    name += ch == '-' ? '_' : static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  return key == "cors-origin" ? name + "S" : name;
}

std::string Help(const Setting& s) {
  static const ServeConfig defaults;
  std::string help = s.help;
  if (IsNumber(s)) help += " (" + Range(s) + "; default " + Text(s.get(defaults)) + ")";
  if (std::string_view(s.key) == "host") help += " (default " + defaults.host + ")";
  return help;
}

}  // namespace

int ReadServeConfig(const std::vector<std::string>& args, ServeConfig& c) {
  for (const Setting& s : kSettings) {
    const std::string var = EnvironmentName(s.key);
    if (const char* v = std::getenv(var.c_str()); v && *v) {
      if (std::string e = Apply(c, s, v); !e.empty()) {
        std::fprintf(stderr, "facespace: %s: %s\n", var.c_str(), e.c_str());
        return 2;
      }
    }
  }
  Flags flags(
      "usage: facespace serve [--rigs DIR] [--host 127.0.0.1] [--port 8080] [--api-key-file FILE] "
      "[more flags]\n",
      "The HTTP service on the rigs of --rigs (default: the bundled ones); the character-creator "
      "page at /.\n"
      "Every flag has an environment variable: FACESPACE_ and the flag in capitals with _ for - "
      "(FACESPACE_PORT,\n"
      "FACESPACE_CORS_ORIGINS comma-separated); flags win over the environment.\n"
      "Batch jobs are kept in --jobs-dir (default ~/.local/state/facespace/jobs) and resume after "
      "a restart.\n");
  for (const Setting& s : kSettings) {
    flags.Value(std::string("--") + s.key, s.unit, Help(s), [&c, &s](const std::string& v) {
      if (std::string e = Apply(c, s, v); !e.empty())
        return std::fprintf(stderr, "error: --%s\n", e.c_str()), 2;
      return 0;
    });
  }
  flags.Switch("--quiet", "no access log", [&c] { c.quiet = true; });
  std::vector<std::string> positional;
  if (int rc = flags.Parse(args, positional); rc >= 0) return rc;
  if (!positional.empty()) return flags.UsageError("unexpected argument '" + positional[0] + "'");
  c.job_limits.keep_free = c.keep_free_mb << 20;
  return -1;
}

std::vector<std::pair<std::string, double>> Limits(const ServeConfig& c) {
  std::vector<std::pair<std::string, double>> out;
  for (const Setting& s : kSettings) {
    if (!IsNumber(s) || !s.limit) continue;
    std::string key = s.key;
    for (char& ch : key) ch = ch == '-' ? '_' : ch;
    out.emplace_back(key, s.get(c));
  }
  return out;
}

}  // namespace facespace::cli
