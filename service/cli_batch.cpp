// facespace batch: many variants of a rig as files, with a manifest, resumable and shardable.
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <charconv>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "batch.h"
#include "cli.h"

namespace facespace::cli {

namespace {

using nlohmann::json;

const char kBatchUsage[] =
    "usage: facespace batch RIG (--variants FILE.jsonl | --sample uniform|gaussian|grid|convex [--count N] [--seed S])\n"
    "         --out DIR [--format glb|obj|json|f32|png|jpeg|exr|tiff] [--jobs N] [--shard I/N] [--no-sheet]\n"
    "         [--shapes A,B,...] [--fix NAME=W ...] [--center JSON|@FILE] [--spread S] [--points JSON|@FILE]\n"
    "         [--active K] [--symmetric] [--sum-at-most-one] [--mode M] [--normals N] [--skinning S]\n"
    "         [--pose JSON|@FILE] [--animation CLIP --time T] [render flags: --width --height --view --yaw ...]\n"
    "  one file per variant in DIR, manifest.jsonl, batch.json and sheet.png (the first 16 variants);\n"
    "  rerun the same command to resume; --shard I/N (1-based) runs every N-th variant from the I-th.\n"
    "  --variants: JSON lines of {\"id\": \"...\", \"weights\": {...}} (or a bare weights object).\n";

std::atomic<bool> g_interrupted{false};

void OnInterrupt(int) { g_interrupted.store(true); }

bool ParseCount(const std::string& s, unsigned long long lo, unsigned long long hi, unsigned long long* out) {
  auto r = std::from_chars(s.data(), s.data() + s.size(), *out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && *out >= lo && *out <= hi;
}

// A JSON value from a flag: inline JSON, or @FILE.
bool JsonFlag(const std::string& flag, const std::string& v, json* out) {
  std::string text = v;
  if (!v.empty() && v[0] == '@' && !ReadFile(v.substr(1), text)) {
    std::fprintf(stderr, "error: %s: cannot read '%s'\n", flag.c_str(), v.substr(1).c_str());
    return false;
  }
  *out = json::parse(text, nullptr, false);
  if (out->is_discarded()) {
    std::fprintf(stderr, "error: %s: not valid JSON\n", flag.c_str());
    return false;
  }
  return true;
}

class ProgressBar {
 public:
  void operator()(const batch::Progress& p) {
    const double rate = p.seconds > 0 ? (p.done - p.skipped) / p.seconds : 0.0;
    const double eta = rate > 0 ? (p.total - p.done) / rate : 0.0;
    if (tty_) {
      const int width = 30, filled = static_cast<int>(width * p.done / std::max<size_t>(p.total, 1));
      std::fprintf(stderr, "\r[%s%s] %zu/%zu variants  %.1f/s  ETA %.0f s   ", std::string(filled, '#').c_str(),
                   std::string(width - filled, ' ').c_str(), p.done, p.total, rate, eta);
    } else if (p.done == p.total || p.seconds - last_ >= 2.0) {
      if (p.done == last_done_) return;
      std::fprintf(stderr, "variants: %zu/%zu (%.1f/s, ETA %.0f s)\n", p.done, p.total, rate, eta);
      last_ = p.seconds;
      last_done_ = p.done;
    }
  }
  void End() {
    if (tty_) std::fputc('\n', stderr);
  }

 private:
  bool tty_ = isatty(2);
  double last_ = 0;
  size_t last_done_ = static_cast<size_t>(-1);
};

}  // namespace

int Batch(const std::vector<std::string>& args) {
  std::vector<std::string> paths;
  json request = json::object();
  json sample = json::object();
  std::string variants_path, out_dir;
  batch::RunOptions run;
  bool quiet = false;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "-h" || a == "--help") {
      std::fputs(kBatchUsage, stdout);
      return 0;
    }
    if (a == "--symmetric" || a == "--sum-at-most-one") {
      sample[a == "--symmetric" ? "symmetric" : "sum_at_most_one"] = true;
      continue;
    }
    if (a == "--no-sheet" || a == "--quiet") {
      if (a == "--quiet") quiet = true;
      else run.sheet_cells = 0;
      continue;
    }
    if (a.rfind("--", 0) != 0 && a != "-o") {
      paths.push_back(a);
      continue;
    }
    if (i + 1 >= args.size()) {
      std::fprintf(stderr, "error: %s needs a value\n%s", a.c_str(), kBatchUsage);
      return 2;
    }
    const std::string v = args[++i];
    unsigned long long n = 0;
    double d = 0;
    auto number = [&](double* dst) {
      auto r = std::from_chars(v.data(), v.data() + v.size(), *dst);
      if (r.ec != std::errc() || r.ptr != v.data() + v.size()) {
        std::fprintf(stderr, "error: %s: '%s' is not a number\n", a.c_str(), v.c_str());
        return false;
      }
      return true;
    };
    json parsed;
    if (a == "--variants") variants_path = v;
    else if (a == "--sample") sample["method"] = v;
    else if (a == "--count" || a == "--active") {
      if (!ParseCount(v, a == "--count" ? 1 : 0, 100000000, &n)) {
        std::fprintf(stderr, "error: %s must be an integer%s, not '%s'\n", a.c_str(), a == "--count" ? " >= 1" : " >= 0", v.c_str());
        return 2;
      }
      sample[a.substr(2)] = n;
    } else if (a == "--seed") {
      if (!ParseCount(v, 0, ~0ull, &n)) {
        std::fprintf(stderr, "error: --seed must be an integer in 0..2^64-1, not '%s'\n", v.c_str());
        return 2;
      }
      sample["seed"] = n;
    } else if (a == "--spread") {
      if (!number(&d)) return 2;
      sample["spread"] = d;
    } else if (a == "--shapes") {
      for (const std::string& name : SplitList(v)) sample["shapes"].push_back(name);
    } else if (a == "--fix") {
      const size_t eq = v.rfind('=');
      if (eq == std::string::npos || eq == 0) {
        std::fprintf(stderr, "error: --fix takes NAME=W, got '%s'\n", v.c_str());
        return 2;
      }
      auto r = std::from_chars(v.data() + eq + 1, v.data() + v.size(), d);
      if (r.ec != std::errc() || r.ptr != v.data() + v.size()) {
        std::fprintf(stderr, "error: --fix %s: '%s' is not a number\n", v.substr(0, eq).c_str(), v.substr(eq + 1).c_str());
        return 2;
      }
      sample["fixed"][v.substr(0, eq)] = d;
    } else if (a == "--center" || a == "--points") {
      if (!JsonFlag(a, v, &parsed)) return 2;
      sample[a.substr(2)] = parsed;
    } else if (a == "--out" || a == "-o") out_dir = v;
    else if (a == "--format") request["format"] = v;
    else if (a == "--jobs") {
      if (!ParseCount(v, 1, 1024, &n)) {
        std::fprintf(stderr, "error: --jobs must be 1..1024, not '%s'\n", v.c_str());
        return 2;
      }
      run.jobs = static_cast<int>(n);
    } else if (a == "--shard") {
      const size_t slash = v.find('/');
      unsigned long long count = 0;
      if (slash == std::string::npos || !ParseCount(v.substr(0, slash), 1, 1000000, &n) ||
          !ParseCount(v.substr(slash + 1), 1, 1000000, &count) || n > count) {
        std::fprintf(stderr, "error: --shard takes I/N with 1 <= I <= N, got '%s'\n", v.c_str());
        return 2;
      }
      run.shard = n - 1;
      run.shards = count;
    } else if (a == "--pose" || a == "--camera" || a == "--blend") {
      if (!JsonFlag(a, v, &parsed)) return 2;
      request[a.substr(2)] = parsed;
    } else if (a == "--width" || a == "--height" || a == "--supersample" || a == "--quality") {
      if (!ParseCount(v, 1, 1 << 20, &n)) {
        std::fprintf(stderr, "error: %s must be a positive integer, not '%s'\n", a.c_str(), v.c_str());
        return 2;
      }
      request[a.substr(2)] = n;
    } else if (a == "--yaw" || a == "--pitch" || a == "--zoom" || a == "--distance" || a == "--fov") {
      if (!number(&d)) return 2;
      request["camera"][a.substr(2)] = d;
    } else if (a == "--time") {
      if (!number(&d)) return 2;
      request["time"] = d;
    } else if (a == "--animation") {
      ParseCount(v, 0, 1u << 30, &n) ? request["animation"] = n : request["animation"] = v;
    } else if (a == "--mode" || a == "--normals" || a == "--skinning" || a == "--view" || a == "--background") {
      request[a.substr(2)] = v;
    } else {
      std::fprintf(stderr, "error: unknown option '%s'\n%s", a.c_str(), kBatchUsage);
      return 2;
    }
  }
  if (paths.empty() || out_dir.empty() || variants_path.empty() == sample.empty()) {
    std::fprintf(stderr, "error: %s\n%s",
                 paths.empty() ? "no rig given" : out_dir.empty() ? "no output folder given (--out DIR)"
                                                                   : "give --variants FILE.jsonl or --sample METHOD (one of them)",
                 kBatchUsage);
    return 2;
  }
  if (!sample.empty()) {
    if (!sample.contains("method")) {
      std::fprintf(stderr, "error: sampling flags need --sample uniform|gaussian|grid|convex\n");
      return 2;
    }
    request["sample"] = sample;
  } else {
    std::string text;
    if (!ReadFile(variants_path, text)) {
      std::fprintf(stderr, "error: --variants: cannot read '%s'\n", variants_path.c_str());
      return 1;
    }
    size_t start = 0, line_no = 0;
    while (start < text.size()) {
      size_t end = text.find('\n', start);
      if (end == std::string::npos) end = text.size();
      ++line_no;
      const std::string line = text.substr(start, end - start);
      start = end + 1;
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      json j = json::parse(line, nullptr, false);
      if (j.is_discarded() || !(j.is_object() || j.is_array())) {
        std::fprintf(stderr, "error: %s:%zu: not a JSON object\n", variants_path.c_str(), line_no);
        return 1;
      }
      request["variants"].push_back(j.is_object() && j.contains("weights") ? j : json{{"weights", j}});
    }
    if (!request.contains("variants")) {
      std::fprintf(stderr, "error: %s holds no variants\n", variants_path.c_str());
      return 1;
    }
  }
  if (!request.contains("format")) request["format"] = "glb";

  Result<Rig> rig = LoadAndReport(paths);
  if (!rig.ok()) return 1;
  std::string bytes;
  ReadFile(paths[0], bytes);
  const std::string version = batch::Sha256Hex({reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size()});
  auto plan = api::MakeBatchPlan(rig.value(), version, request.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  if (!plan.ok()) {
    PrintStatus(plan.status());
    return plan.status().code == StatusCode::kInvalidArgument ? 2 : 1;
  }
  struct sigaction sa{};
  sa.sa_handler = OnInterrupt;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  ProgressBar bar;
  const render::OsMesaRenderer renderer(run.jobs);
  run.dir = out_dir;
  run.renderer = &renderer;
  run.cancel = &g_interrupted;
  if (!quiet) run.progress = [&bar](const batch::Progress& p) { bar(p); };
  auto summary = batch::Run(plan.value(), run);
  if (!quiet) bar.End();
  if (!summary.ok()) {
    PrintStatus(summary.status());
    return 1;
  }
  const batch::Summary& s = summary.value();
  if (s.cancelled) {
    std::fprintf(stderr, "interrupted: %zu of %zu variants are complete in %s; run the same command again to resume\n",
                 s.skipped + s.generated, s.total, out_dir.c_str());
    return 130;
  }
  std::fprintf(stderr, "batch: %zu variants in %s (%zu generated, %zu already there) in %.2f s, %.1f variants/s\n", s.total,
               out_dir.c_str(), s.generated, s.skipped, s.seconds, s.seconds > 0 ? s.generated / s.seconds : 0.0);
  return 0;
}

}  // namespace facespace::cli
