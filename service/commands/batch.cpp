// facespace batch: many variants of a rig as files, with a manifest, resumable and shardable.
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "commands/cli.h"
#include "commands/flags.h"
#include "facespace/batch/dataset.h"
#include "facespace/batch/run.h"
#include "facespace/offscreen/render.h"

namespace facespace::cli {

namespace {

// randomize.background.images: the folder's pictures, decoded on this thread before any worker
// starts (Decode opens the image module here, as render.h asks; its threads then keep the run from
// forking makers, maker.h, and the run makes its samples with threads).
Status LoadBackgrounds(batch::BatchPlan& plan, const picture::Renderer& renderer) {
  if (plan.request.dataset.randomize.background_images.empty()) return Status::Ok();
  return batch::LoadBackgroundImages(plan, renderer);
}

using nlohmann::json;

std::atomic<bool> g_interrupted{false};

void OnInterrupt(int) { g_interrupted.store(true); }

// A JSON value from a flag: inline JSON, or @FILE. Returns 0 or the exit code.
int JsonFlag(const std::string& flag, const std::string& v, json* out) {
  std::string text;
  if (!ReadAtFile(flag, v, text)) return 1;
  *out = json::parse(text, nullptr, false);
  if (!out->is_discarded()) return 0;
  std::fprintf(stderr, "error: %s: not valid JSON\n", flag.c_str());
  return 2;
}

class ProgressBar {
 public:
  void operator()(const batch::Progress& p) {
    const double rate = p.seconds > 0 ? (p.done - p.skipped) / p.seconds : 0.0;
    const double eta = rate > 0 ? (p.total - p.done) / rate : 0.0;
    if (tty_) {
      const int width = 30,
                filled = static_cast<int>(width * p.done / std::max<size_t>(p.total, 1));
      std::fprintf(stderr, "\r[%s%s] %zu/%zu variants  %.1f/s  ETA %.0f s   ",
                   std::string(filled, '#').c_str(), std::string(width - filled, ' ').c_str(),
                   p.done, p.total, rate, eta);
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

namespace {

// facespace batch merge DIR: one manifest and sheet from the shards of a sharded run.
int Merge(const std::vector<std::string>& args) {
  std::vector<std::string> positional, rig_paths;
  bool verify = true;
  Flags flags(
      "usage: facespace batch merge DIR [--rig RIG [FILES...]] [--no-verify]\n",
      "Checks that every shard of the batch in DIR finished (manifest.shard-I-of-N.jsonl and "
      "shard-I-of-N.json\n"
      "of `facespace batch ... --shard I/N|auto`) and every variant file is there with its hash, "
      "then writes\n"
      "manifest.jsonl and sheet.png as one process would have, and removes the shard files.\n"
      "The rig is the one the shards recorded, unless --rig names it (the same file: its hash is "
      "checked).\n");
  flags.Texts("--rig", "RIG", "the rig file, when it moved since the shards ran", &rig_paths);
  flags.Switch("--no-verify", "check sizes only, not each file's SHA-256", [&] { verify = false; });
  if (int rc = flags.Parse(args, positional); rc >= 0) return rc;
  if (positional.empty()) return flags.UsageError("no folder given");
  const std::string dir = positional[0];
  if (!rig_paths.empty())
    rig_paths.insert(rig_paths.end(), positional.begin() + 1, positional.end());
  else if (positional.size() > 1)
    return flags.UsageError("one folder; the rig goes after --rig");
  auto found = batch::FindShards(dir);
  if (!found.ok()) {
    PrintStatus(found.status());
    return 1;
  }
  size_t sheet_cells = 16;
  if (!found->finished.empty()) {
    sheet_cells = found->finished.front().sheet_cells;
    if (rig_paths.empty()) rig_paths = found->finished.front().rig_files;
  }
  if (rig_paths.empty()) {
    std::fprintf(stderr,
                 "error: none of the %zu shards of '%s' has finished (so none recorded its rig): "
                 "run them, then merge\n",
                 found->shards, dir.c_str());
    return 1;
  }
  std::string spec_text;
  if (!ReadFile(dir + "/batch.json", spec_text)) {
    std::fprintf(stderr, "error: '%s' has no batch.json: not a batch folder\n", dir.c_str());
    return 1;
  }
  const json spec = json::parse(spec_text, nullptr, false);
  if (spec.is_discarded() || !spec.is_object() || !spec.contains("request") ||
      !spec.contains("rig_version")) {
    std::fprintf(stderr, "error: '%s/batch.json' is not a batch's\n", dir.c_str());
    return 1;
  }
  std::string bytes;
  if (!ReadFile(rig_paths[0], bytes)) {
    std::fprintf(stderr, "error: cannot read the rig '%s' the shards ran on; give it with --rig\n",
                 rig_paths[0].c_str());
    return 1;
  }
  const std::string_view whole[] = {bytes};
  if (batch::Sha256Hex(whole) != spec["rig_version"]) {
    std::fprintf(stderr,
                 "error: '%s' is not the rig the batch ran on (its hash differs from batch.json's "
                 "rig_version)\n",
                 rig_paths[0].c_str());
    return 1;
  }
  Result<Rig> rig = LoadAndReport(rig_paths);
  if (!rig.ok()) return 1;
  auto plan = batch::MakeBatchPlan(
      evaluator::Unstored(std::move(rig.value()), spec["rig_version"].get<std::string>()),
      spec["request"].dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  if (!plan.ok()) {
    PrintStatus(plan.status());
    return 1;
  }
  const offscreen::OsMesaRenderer renderer(0);
  const evaluator::Evaluator evaluator(renderer);
  if (Status s = LoadBackgrounds(plan.value(), renderer); !s.ok()) {
    PrintStatus(s);
    return 1;
  }
  batch::MergeOptions options;
  options.dir = dir;
  options.evaluator = &evaluator;
  options.sheet_cells = sheet_cells;
  options.verify = verify;
  auto merged = batch::Merge(plan.value(), options);
  if (!merged.ok()) {
    PrintStatus(merged.status());
    return 1;
  }
  std::fprintf(stderr, "batch merge: %zu shards, %zu variants in %s (manifest.jsonl%s) in %.2f s\n",
               merged->shards, merged->variants, dir.c_str(), sheet_cells > 0 ? ", sheet.png" : "",
               merged->seconds);
  return 0;
}

// One line on what the generated variants warn of (each variant's manifest line has its own):
// "warnings: extrapolation in 100 of 100 variants (sum of weights up to 3.2), out_of_range in 4".
void PrintBatchWarnings(const batch::Summary& s) {
  if (s.generated == 0) return;
  if (s.warnings.empty()) {
    std::fprintf(stderr, "warnings: none in the %zu variants generated\n", s.generated);
    return;
  }
  std::string line;
  for (const auto& [code, count] : s.warnings) {
    line += (line.empty() ? "" : ", ") + code + " in " + std::to_string(count) +
            (line.empty() ? " of " + std::to_string(s.generated) + " variants" : "");
    if (code == "extrapolation") line += " (sum of weights up to " + FormatNumber(s.max_sum) + ")";
  }
  std::fprintf(stderr, "warnings: %s (each variant's are in manifest.jsonl)\n", line.c_str());
}

// What `facespace batch` is asked: the rig files, the request (as the batch route's body), how to
// run.
struct BatchArgs {
  std::vector<std::string> paths;
  json request = json::object();
  json sample = json::object();
  std::string variants_path, out_dir;
  batch::RunOptions run;
  bool quiet = false, shard_auto = false;
  size_t shard_count = 0;
};

// Flags that set a member of a JSON object (the request, its "sample", its "camera") from an
// integer, a number, JSON (inline or @FILE) or text.
std::function<int(const std::string&)> IntegerMember(json& into, const std::string& key,
                                                     long long lo, long long hi) {
  return [&into, key, lo, hi](const std::string& v) {
    long long n = 0;
    if (!IntIn("--" + key, v, lo, hi, &n)) return 2;
    into[key] = n;
    return 0;
  };
}
std::function<int(const std::string&)> NumberMember(json& into, const std::string& key) {
  return [&into, key](const std::string& v) {
    double d = 0;
    if (!NumberIn("--" + key, v, -1e300, 1e300, &d)) return 2;
    into[key] = d;
    return 0;
  };
}
std::function<int(const std::string&)> JsonMember(json& into, const std::string& key) {
  return [&into, key](const std::string& v) { return JsonFlag("--" + key, v, &into[key]); };
}
std::function<int(const std::string&)> TextMember(json& into, const std::string& key) {
  return [&into, key](const std::string& v) {
    into[key] = v;
    return 0;
  };
}

int SeedFlag(json& sample, const std::string& v) {
  unsigned long long n = 0;
  const auto r = std::from_chars(v.data(), v.data() + v.size(), n);
  if (r.ec != std::errc() || r.ptr != v.data() + v.size())
    return std::fprintf(stderr, "error: --seed must be an integer in 0..2^64-1, not '%s'\n",
                        v.c_str()),
           2;
  sample["seed"] = n;
  return 0;
}

int FixFlag(json& sample, const std::string& v) {
  const size_t eq = v.rfind('=');
  double d = 0;
  if (eq == std::string::npos || eq == 0)
    return std::fprintf(stderr, "error: --fix takes NAME=W, got '%s'\n", v.c_str()), 2;
  if (!NumberIn("--fix " + v.substr(0, eq), v.substr(eq + 1), -1e300, 1e300, &d)) return 2;
  sample["fixed"][v.substr(0, eq)] = d;
  return 0;
}

// The variants: a file of JSON lines, or the face space sampled.
void AddVariantFlags(Flags& flags, BatchArgs& a) {
  json& sample = a.sample;
  flags.Text("--variants", "FILE.jsonl", "the variants, one JSON line each", &a.variants_path);
  flags.Value("--sample", "METHOD", "sample the face space: uniform, gaussian, grid or convex",
              TextMember(sample, "method"));
  flags.Value("--count", "N", "variants to sample", IntegerMember(sample, "count", 1, 100000000));
  flags.Value("--seed", "S", "random seed (0..2^64-1); the same seed gives the same variants",
              [&sample](const std::string& v) { return SeedFlag(sample, v); });
  flags.Value("--shapes", "A,B,...", "the shapes varied (default: all)",
              [&sample](const std::string& v) {
                for (const std::string& name : SplitList(v)) sample["shapes"].push_back(name);
                return 0;
              });
  flags.Value("--fix", "NAME=W", "hold a shape at a weight (repeatable)",
              [&sample](const std::string& v) { return FixFlag(sample, v); });
  flags.Value("--center", "JSON|@FILE", "gaussian: the mean weights", JsonMember(sample, "center"));
  flags.Value("--spread", "S", "gaussian: standard deviation", NumberMember(sample, "spread"));
  flags.Value("--points", "JSON|@FILE", "grid: 2 or 3 weight vectors spanning a line or plane",
              JsonMember(sample, "points"));
  flags.Value("--active", "K", "only K of the varied shapes move in each variant",
              IntegerMember(sample, "active", 0, 100000000));
  flags.Switch("--symmetric", "a shape's left/right partner takes its weight",
               [&sample] { sample["symmetric"] = true; });
  flags.Switch("--sum-at-most-one", "scale each variant so its weights sum to at most 1",
               [&sample] { sample["sum_at_most_one"] = true; });
}

int ShardFlag(batch::RunOptions& run, bool& shard_auto, const std::string& v) {
  if (v == "auto") return shard_auto = true, 0;
  const size_t slash = v.find('/');
  long long n = 0, count = 0;
  if (slash == std::string::npos || !IntIn("--shard I", v.substr(0, slash), 1, 1000000, &n) ||
      !IntIn("--shard N", v.substr(slash + 1), 1, 1000000, &count) || n > count) {
    return std::fprintf(stderr, "error: --shard takes I/N with 1 <= I <= N, got '%s'\n", v.c_str()),
           2;
  }
  run.shard = static_cast<size_t>(n - 1);
  run.shards = static_cast<size_t>(count);
  return 0;
}

// Where and how: the folder, the format, workers, shards, the sheet, quiet.
void AddRunFlags(Flags& flags, BatchArgs& a) {
  flags.Text("--out, -o", "DIR", "the output folder", &a.out_dir);
  flags.Value("--format", "FORMAT",
              "glb (default), obj, json, f32, or an image: png, jpeg, exr, tiff, webp",
              TextMember(a.request, "format"));
  flags.Value("--jobs", "N", "worker threads (default: every core)", [&a](const std::string& v) {
    long long n = 0;
    if (!IntIn("--jobs", v, 1, 1024, &n)) return 2;
    a.run.jobs = static_cast<int>(n);
    return 0;
  });
  flags.Value("--shard", "I/N|auto",
              "run the I-th of N shards (1-based); auto: the scheduler's (Slurm array, Kubernetes "
              "Indexed Job)",
              [&a](const std::string& v) { return ShardFlag(a.run, a.shard_auto, v); });
  flags.Value("--shards", "N",
              "with --shard auto: the shard count (a Kubernetes Indexed Job's completions)",
              [&a](const std::string& v) {
                long long n = 0;
                if (!IntIn("--shards", v, 1, 1000000, &n)) return 2;
                a.shard_count = static_cast<size_t>(n);
                return 0;
              });
  flags.Value("--workers", "processes|threads",
              "who makes the variants: a process a job (the default for 1,000 renders or more: "
              "llvmpipe rasterises one context of a process at a time) or threads",
              [&a](const std::string& v) {
                if (v != "processes" && v != "threads")
                  return std::fprintf(stderr,
                                      "error: --workers: '%s' is not processes or threads\n",
                                      v.c_str()),
                         2;
                a.run.makers = v == "processes" ? batch::RunOptions::Makers::kProcesses
                                                : batch::RunOptions::Makers::kThreads;
                return 0;
              });
  flags.Switch("--no-sheet", "no contact sheet", [&a] { a.run.sheet_cells = 0; });
  flags.Value("--labels", "L,...",
              "a labelled dataset: depth, normals, segmentation, landmarks beside each render "
              "(KEY.json always)",
              [&a](const std::string& v) {
                a.request["labels"] = json::array();
                for (const std::string& name : SplitList(v)) a.request["labels"].push_back(name);
                return 0;
              });
  flags.Value("--archive", "folder|tar",
              "tar: WebDataset tar shards (shard-000000.tar, ...) instead of one file each",
              TextMember(a.request, "archive"));
  flags.Value("--shard-samples", "N", "samples in each tar shard (default 1000)",
              IntegerMember(a.request, "shard_samples", 1, 1000000));
  flags.Value("--randomize", "JSON|@FILE",
              "what varies per sample: camera, light, background, expressions, gaze (batch --help)",
              JsonMember(a.request, "randomize"));
  flags.Switch("-q, --quiet", "no progress bar, no warnings (errors and the closing line still)",
               [&a] { a.quiet = Quiet() = true; });
}

// Every variant's mesh options, pose, face and render settings, as the routes' members.
void AddRequestFlags(Flags& flags, json& request) {
  for (const char* key : {"mode", "normals", "skinning", "view", "background"}) {
    flags.Value(std::string("--") + key, "VALUE",
                std::string("as the mesh and render routes' \"") + key + "\"",
                TextMember(request, key));
  }
  flags.Value("--pose", "JSON|@FILE", "the pose of every variant", JsonMember(request, "pose"));
  flags.Value("--expressions", "JSON|@FILE",
              "expressions by name on every variant: {\"happy\": 0.5}",
              JsonMember(request, "expressions"));
  flags.Value("--gaze", "JSON|@FILE",
              "where every variant looks: {\"yaw\": 10, \"pitch\": 0} or {\"target\": [x, y, z]}",
              JsonMember(request, "gaze"));
  flags.Value("--blend", "JSON|@FILE", "clips blended, for every variant",
              JsonMember(request, "blend"));
  flags.Value(
      "--animation", "NAME|INDEX", "a clip, sampled at --time", [&request](const std::string& v) {
        const bool index =
            !v.empty() && v.find_first_not_of("0123456789") == std::string::npos && v.size() < 10;
        index ? request["animation"] = std::stoll(v) : request["animation"] = v;
        return 0;
      });
  flags.Value("--time", "SECONDS", "the time in --animation", NumberMember(request, "time"));
  flags.Value("--motion", "NAME", "a .vmd motion of a PMX/PMD rig (as --animation)",
              TextMember(request, "motion"));
  flags.Value("--frame", "N", "the time in MMD frames, 30 a second",
              NumberMember(request, "frame"));
  flags.Value("--camera", "JSON|@FILE", "render camera", JsonMember(request, "camera"));
  for (const char* key : {"width", "height", "supersample", "quality"}) {
    flags.Value(std::string("--") + key, "N", std::string("render ") + key,
                IntegerMember(request, key, 1, 1 << 20));
  }
  flags.Value("--exposure", "STOPS", "render exposure", NumberMember(request, "exposure"));
  for (const char* key : {"yaw", "pitch", "zoom", "distance", "fov"}) {
    flags.Value(std::string("--") + key, "X", std::string("render camera ") + key,
                NumberMember(request["camera"], key));
  }
}

// --variants FILE.jsonl into request["variants"]: {"id", "weights"} lines or bare weights. 0 or the
// exit code.
int ReadVariants(const std::string& path, json& request) {
  std::string text;
  if (!ReadFile(path, text))
    return std::fprintf(stderr, "error: --variants: cannot read '%s'\n", path.c_str()), 1;
  size_t start = 0, line_no = 0;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    ++line_no;
    const std::string line = text.substr(start, end - start);
    start = end + 1;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    json j = json::parse(line, nullptr, false);
    if (j.is_discarded() || !(j.is_object() || j.is_array()))
      return std::fprintf(stderr, "error: %s:%zu: not a JSON object\n", path.c_str(), line_no), 1;
    request["variants"].push_back(j.is_object() && j.contains("weights") ? j
                                                                         : json{{"weights", j}});
  }
  if (!request.contains("variants"))
    return std::fprintf(stderr, "error: %s holds no variants\n", path.c_str()), 1;
  return 0;
}

// --shard auto: the scheduler's shard (an array submitted again in part, sbatch --array=2, has
// fewer tasks than the folder's shards: refused). 0 or the exit code.
int ShardOfScheduler(BatchArgs& a) {
  auto shard =
      batch::ShardFromScheduler([](const char* name) { return std::getenv(name); }, a.shard_count);
  if (!shard.ok()) return std::fprintf(stderr, "error: %s\n", shard.status().message.c_str()), 2;
  if (auto found = batch::FindShards(a.out_dir);
      a.shard_count == 0 && found.ok() && found->shards != shard->shards) {
    std::fprintf(
        stderr,
        "error: '%s' holds shards of %zu but the scheduler gives %zu (%s): give --shards %zu\n",
        a.out_dir.c_str(), found->shards, shard->shards, shard->source.c_str(), found->shards);
    return 2;
  }
  a.run.shard = shard->shard;
  a.run.shards = shard->shards;
  std::fprintf(stderr, "batch: shard %zu/%zu (%s)\n", a.run.shard + 1, a.run.shards,
               shard->source.c_str());
  return 0;
}

// What a run did: a shard's line, an interruption's, or the whole batch's with its warnings.
int ReportBatch(const batch::Summary& s, const BatchArgs& a) {
  const char* out = a.out_dir.c_str();
  if (s.cancelled) {
    std::fprintf(stderr,
                 "interrupted: %zu of %zu variants are complete in %s; run the same command again "
                 "to resume\n",
                 s.skipped + s.generated, s.total, out);
    return 130;
  }
  if (a.run.shards > 1) {
    PrintBatchWarnings(s);
    std::fprintf(stderr,
                 "batch: shard %zu/%zu: %zu variants in %s (%zu generated, %zu already there) in "
                 "%.2f s; once every shard is done: facespace batch merge %s\n",
                 a.run.shard + 1, a.run.shards, s.total, out, s.generated, s.skipped, s.seconds,
                 out);
    return 0;
  }
  const std::string makers =
      s.processes ? ", " + std::to_string(s.processes) + " maker processes" : "";
  std::fprintf(
      stderr,
      "batch: %zu variants in %s (%zu generated, %zu already there) in %.2f s, %.1f variants/s%s\n",
      s.total, out, s.generated, s.skipped, s.seconds,
      s.seconds > 0 ? s.generated / s.seconds : 0.0, makers.c_str());
  PrintBatchWarnings(s);
  return 0;
}

// The rig loaded (its version the file's SHA-256), the plan made, the run done (SIGINT and SIGTERM
// stop it resumably), and reported.
int RunBatch(BatchArgs& a) {
  for (const std::string& path : a.paths) {
    std::error_code ec;
    const std::filesystem::path absolute = std::filesystem::absolute(path, ec);
    a.run.rig_files.push_back(ec ? path : absolute.lexically_normal().string());
  }
  Result<Rig> rig = LoadAndReport(a.paths);
  if (!rig.ok()) return 1;
  // Before the worker threads start (render.h says why), and only for pictures: a mesh batch
  // without a sheet never decodes a texture, and the module's loading took 0.35 s of a 550-variant
  // glb run's 0.78.
  const bool pictures =
      a.run.sheet_cells > 0 || (a.request.contains("format") && a.request["format"] != "glb" &&
                                a.request["format"] != "obj" && a.request["format"] != "json" &&
                                a.request["format"] != "f32");
  // Opened after the makers are forked (maker.h; its loading starts a logging library's threads),
  // and with makers only for the contact sheet: each maker opens its own (0.3 s) while this process
  // would keep them waiting.
  const bool sheet = a.run.sheet_cells > 0;
  if (!rig->images.empty() && pictures) {
    a.run.before_threads = [sheet](bool makers) {
      if (!makers || sheet) offscreen::OpenImageModule();
    };
  }
  std::string bytes;
  ReadFile(a.paths[0], bytes);
  const std::string_view whole[] = {bytes};
  auto plan = batch::MakeBatchPlan(
      evaluator::Unstored(std::move(rig.value()), batch::Sha256Hex(whole)),
      a.request.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  if (!plan.ok()) {
    PrintStatus(plan.status());
    return plan.status().code == StatusCode::kInvalidArgument ? 2 : 1;
  }
  struct sigaction sa {};
  sa.sa_handler = OnInterrupt;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  ProgressBar bar;
  const offscreen::OsMesaRenderer renderer(a.run.jobs);
  const evaluator::Evaluator evaluator(renderer);
  if (Status s = LoadBackgrounds(plan.value(), renderer); !s.ok()) {
    PrintStatus(s);
    return 2;
  }
  a.run.dir = a.out_dir;
  a.run.evaluator = &evaluator;
  a.run.cancel = &g_interrupted;
  if (!a.quiet) a.run.progress = [&bar](const batch::Progress& p) { bar(p); };
  auto summary = batch::Run(plan.value(), a.run);
  if (!a.quiet) bar.End();
  if (!summary.ok()) {
    PrintStatus(summary.status());
    return 1;
  }
  return ReportBatch(summary.value(), a);
}

}  // namespace

int Batch(const std::vector<std::string>& args) {
  if (!args.empty() && args[0] == "merge") return Merge({args.begin() + 1, args.end()});
  BatchArgs a;
  // Makers for big render runs unless --workers says (batch/run.h): 8-13% more samples a second
  // than threads (tests/bench/README.md, "Datasets").
  a.run.makers = batch::RunOptions::Makers::kAuto;
  Flags flags(
      "usage: facespace batch RIG (--variants FILE.jsonl | --sample uniform|gaussian|grid|convex "
      "[--count N] [--seed S])\n"
      "         --out DIR [--format glb|obj|json|f32|vrm|png|jpeg|exr|tiff|webp] [--jobs N] "
      "[--shard I/N|auto [--shards N]]\n"
      "         [--labels depth,normals,segmentation,landmarks] [--archive tar [--shard-samples "
      "N]] [--randomize JSON]\n"
      "         [sampling, pose, render flags]\n"
      "       facespace batch merge DIR\n",
      "One file per variant in DIR, manifest.jsonl, batch.json and sheet.png (the first 16 "
      "variants); rerun the\n"
      "same command to resume; --shard I/N (1-based) runs every N-th variant from the I-th, and "
      "shards share DIR;\n"
      "--shard auto takes I/N from a Slurm job array (SLURM_ARRAY_TASK_ID, _COUNT) or a Kubernetes "
      "Indexed Job\n"
      "(JOB_COMPLETION_INDEX, with --shards N). When every shard is done, `facespace batch merge "
      "DIR` writes the\n"
      "manifest and sheet a single run would have written (batch merge --help).\n"
      "--variants: JSON lines of {\"id\": \"...\", \"weights\": {...}} (or a bare weights "
      "object).\n"
      "A labelled dataset (--labels depth,normals,segmentation,landmarks): each sample is KEY.png, "
      "KEY.depth.exr\n"
      "(float32 distance along the ray, metres), KEY.normals.exr (half floats, camera space), "
      "KEY.seg.png (ids; legend in\n"
      "KEY.json) and KEY.json (camera K and world_to_camera, landmarks with pixel and 3D positions "
      "and\n"
      "visibility, the point). --archive tar writes them as WebDataset shards; --randomize varies "
      "each sample:\n"
      "  {\"seed\": 7, \"camera\": {\"yaw\": [-30, 30], \"pitch\": [-10, 10], \"zoom\": [0.9, "
      "1.1]},\n"
      "   \"light\": {\"yaw\": [-60, 60], \"pitch\": [-20, 30], \"exposure\": [-0.5, 0.5]}, "
      "\"background\": \"random\",\n"
      "   \"expressions\": {\"happy\": [0, 1]}, \"gaze\": {\"yaw\": [-20, 20], \"pitch\": [-10, "
      "10]}}\n");
  AddVariantFlags(flags, a);
  AddRunFlags(flags, a);
  AddRequestFlags(flags, a.request);
  if (int rc = flags.Parse(args, a.paths); rc >= 0) return rc;
  json& request = a.request;
  if (request.contains("camera") && request["camera"].is_null()) request.erase("camera");
  if (a.paths.empty() || a.out_dir.empty() || a.variants_path.empty() == a.sample.empty()) {
    return flags.UsageError(a.paths.empty() ? "no rig given"
                            : a.out_dir.empty()
                                ? "no output folder given (--out DIR)"
                                : "give --variants FILE.jsonl or --sample METHOD (one of them)");
  }
  if (!a.sample.empty() && !a.sample.contains("method"))
    return std::fprintf(stderr,
                        "error: sampling flags need --sample uniform|gaussian|grid|convex\n"),
           2;
  if (!a.sample.empty())
    request["sample"] = a.sample;
  else if (int rc = ReadVariants(a.variants_path, request); rc != 0)
    return rc;
  const bool labelled = request.contains("labels") || request.contains("randomize");
  if (!request.contains("format")) request["format"] = labelled ? "png" : "glb";
  if (a.shard_count != 0 && !a.shard_auto)
    return flags.UsageError("--shards N goes with --shard auto");
  if (a.shard_auto) {
    if (int rc = ShardOfScheduler(a); rc != 0) return rc;
  }
  return RunBatch(a);
}

}  // namespace facespace::cli
