// Shards of a batch merged into one dataset, and the shard a scheduler gave this process (run.h).
#include <algorithm>
#include <charconv>
#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>

#include "facespace/batch/run.h"
#include "facespace/files/durable.h"
#include "folder.h"

namespace facespace::batch {

using nlohmann::json;

namespace {

// What manifest line `j` vouches for: its whole file, or (archived) its bytes in the tar shard
// `path`.
bool ReadRange(const fs::path& path, const json& j, std::string& data) {
  std::ifstream f(path, std::ios::binary);
  if (!j.contains("offset")) {
    data.assign((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    return static_cast<bool>(f) || f.eof();
  }
  data.resize(j["bytes"].get<size_t>());
  f.seekg(static_cast<std::streamoff>(j["offset"].get<uint64_t>()));
  return static_cast<bool>(f.read(data.data(), static_cast<std::streamsize>(data.size())));
}

}  // namespace

Result<ShardsFound> FindShards(const std::string& dir_name) {
  const fs::path dir = dir_name;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return NotFound("no folder '" + dir_name + "'");
  ShardsFound found;
  std::map<size_t, ShardRecord> records;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    size_t shard = 0, shards = 0;
    const bool record = ParseShardName(name, "", ".json", &shard, &shards);
    if (!record && !ParseShardName(name, "manifest.", ".jsonl", &shard, &shards)) continue;
    if (found.shards != 0 && shards != found.shards) {
      return FailedPrecondition(
          "'" + dir_name + "' holds shards of " + std::to_string(found.shards) + " and of " +
          std::to_string(shards) +
          ": runs with different shard counts cannot be merged; rerun with one count");
    }
    found.shards = shards;
    if (!record) continue;
    std::ifstream f(e.path(), std::ios::binary);
    json j = json::parse(f, nullptr, false);
    if (j.is_discarded() || !j.is_object())
      continue;  // Unreadable: the shard counts as unfinished.
    ShardRecord r;
    r.shard = shard;
    r.shards = shards;
    r.variants = j.value("variants", size_t{0});
    r.sheet_cells = j.value("sheet_cells", size_t{16});
    if (j.contains("rig_files") && j["rig_files"].is_array()) {
      for (const json& p : j["rig_files"]) {
        if (p.is_string()) r.rig_files.push_back(p.get<std::string>());
      }
    }
    records[shard] = std::move(r);
  }
  if (found.shards == 0)
    return FailedPrecondition("'" + dir_name +
                              "' holds no shards of a batch (no manifest.shard-I-of-N.jsonl)");
  for (auto& [shard, r] : records) found.finished.push_back(std::move(r));
  return found;
}

Result<MergeSummary> Merge(const BatchPlan& plan, const MergeOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const fs::path dir = options.dir;
  if (!options.evaluator) return InvalidArgument("no evaluator");
  {
    std::ifstream f(dir / "batch.json", std::ios::binary);
    const std::string spec((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    if (spec != plan.spec_json)
      return FailedPrecondition(
          "'" + options.dir + "/batch.json' is not this batch's (another request or rig version)");
  }
  auto found = FindShards(options.dir);
  if (!found.ok()) return found.status();
  const size_t shards = found->shards;
  std::vector<bool> finished(shards, false);
  for (const ShardRecord& r : found->finished) finished[r.shard] = true;
  std::string problems;
  size_t unfinished = 0;
  for (size_t i = 0; i < shards; ++i) {
    const bool running = Locked(dir / (kLockPrefix + ManifestName(i, shards)));
    if (finished[i] && !running) continue;
    if (++unfinished <= 8) {
      problems += std::string(problems.empty() ? "" : ", ") + std::to_string(i + 1) + "/" +
                  std::to_string(shards) + (running ? " (running)" : "");
    }
  }
  if (unfinished > 0) {
    return FailedPrecondition(std::to_string(unfinished) + " of " + std::to_string(shards) +
                              " shards of '" + options.dir + "' have not finished: " + problems +
                              (unfinished > 8 ? ", ..." : "") +
                              "; run them (again: each resumes where it stopped), then merge");
  }

  // Every variant, with its file, and (verify) the file's hash as its line says.
  std::map<size_t, std::string> lines = ReadManifests(dir, plan, [](size_t) { return true; });
  if (lines.size() != plan.total) {
    std::string missing;
    size_t count = 0;
    for (size_t k = 0; k < plan.total; ++k) {
      if (lines.count(k)) continue;
      if (++count <= 5) missing += std::string(missing.empty() ? "" : ", ") + VariantId(plan, k);
    }
    return FailedPrecondition(std::to_string(count) + " variants are missing from '" + options.dir +
                              "' (" + missing + (count > 5 ? ", ..." : "") +
                              "): rerun their shards, then merge");
  }
  if (options.verify) {
    std::string data;
    for (const auto& [index, line] : lines) {
      const json j = json::parse(line, nullptr, false);
      const std::string file =
          j.contains("shard") ? j["shard"].get<std::string>() : j["file"].get<std::string>();
      if (!ReadRange(dir / file, j, data))
        return FailedPrecondition("cannot read '" + file + "': rerun its shard, then merge");
      const std::string_view whole[] = {data};
      if (!j.contains("sha256") || j["sha256"] != Sha256Hex(whole)) {
        return FailedPrecondition(
            "'" + file +
            "' does not match its manifest line's sha256 (changed after it was written): "
            "remove it and rerun its shard, then merge");
      }
    }
  }
  if (Status s = WriteInBatch(dir, kManifest, JoinLines(lines)); !s.ok()) return s;
  if (options.sheet_cells > 0 && plan.total > 0) {
    if (Status s = WriteSheet(plan, dir, options.sheet_cells, *options.evaluator); !s.ok())
      return s;
  }
  files::SyncDir(dir);
  // manifest.jsonl vouches for every variant now: the shards' files go.
  std::error_code ec;
  for (size_t i = 0; i < shards; ++i) {
    fs::remove(dir / ManifestName(i, shards), ec);
    fs::remove(dir / RecordName(i, shards), ec);
  }
  files::SyncDir(dir);
  MergeSummary summary;
  summary.shards = shards;
  summary.variants = plan.total;
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

Result<SchedulerShard> ShardFromScheduler(const std::function<const char*(const char*)>& env,
                                          size_t count) {
  auto number = [&](const char* name, size_t* out) -> Result<bool> {
    const char* v = env(name);
    if (!v || !*v) return false;
    const std::string_view text(v);
    unsigned long long n = 0;
    const auto r = std::from_chars(text.data(), text.data() + text.size(), n);
    if (r.ec != std::errc() || r.ptr != text.data() + text.size()) {
      return InvalidArgument(std::string(name) + " is '" + v + "', not a whole number");
    }
    *out = static_cast<size_t>(n);
    return true;
  };
  SchedulerShard out;
  size_t id = 0, n = 0, lo = 0, hi = 0, step = 1;
  auto has_id = number("SLURM_ARRAY_TASK_ID", &id);
  if (!has_id.ok()) return has_id.status();
  if (has_id.value()) {
    auto has_count = number("SLURM_ARRAY_TASK_COUNT", &n);
    auto has_lo = number("SLURM_ARRAY_TASK_MIN", &lo);
    auto has_hi = number("SLURM_ARRAY_TASK_MAX", &hi);
    auto has_step = number("SLURM_ARRAY_TASK_STEP", &step);
    for (const auto* r : {&has_count, &has_lo, &has_hi, &has_step}) {
      if (!r->ok()) return r->status();
    }
    if (count != 0) {
      // With --shards, the array ids are the shards (0..N-1), so a part of the array can be
      // submitted again (sbatch --array=2) and still be shard 3/N.
      if (id >= count) {
        return InvalidArgument("SLURM_ARRAY_TASK_ID=" + std::to_string(id) +
                               " is not below --shards " + std::to_string(count) +
                               " (with --shards N the array ids are the shards: --array=0-" +
                               std::to_string(count - 1) + ", or a part of it)");
      }
      out.shard = id;
      out.shards = count;
      out.source =
          "SLURM_ARRAY_TASK_ID=" + std::to_string(id) + " with --shards " + std::to_string(count);
      return out;
    }
    if (!has_step.value() || step == 0) step = 1;
    if (!has_lo.value()) lo = 0;
    if (!has_count.value()) {
      if (!has_hi.value())
        return InvalidArgument(
            "SLURM_ARRAY_TASK_ID is set but neither SLURM_ARRAY_TASK_COUNT nor _MAX: give --shards "
            "N");
      n = hi < lo ? 0 : (hi - lo) / step + 1;
    }
    if (id < lo || (id - lo) % step != 0 || (id - lo) / step >= n) {
      return InvalidArgument(
          "SLURM_ARRAY_TASK_ID=" + std::to_string(id) + " is not one of " + std::to_string(n) +
          " evenly spaced tasks from " + std::to_string(lo) +
          " (arrays like --array=0-3 or 1-8:1 shard; for others give --shard I/N)");
    }
    out.shard = (id - lo) / step;
    out.shards = n;
    out.source =
        "SLURM_ARRAY_TASK_ID=" + std::to_string(id) + " of " + std::to_string(n) + " tasks";
  } else {
    auto has_index = number("JOB_COMPLETION_INDEX", &id);
    if (!has_index.ok()) return has_index.status();
    if (!has_index.value()) {
      return InvalidArgument(
          "--shard auto: no scheduler's task index in the environment (SLURM_ARRAY_TASK_ID of a "
          "Slurm job array, "
          "JOB_COMPLETION_INDEX of a Kubernetes Indexed Job); give --shard I/N");
    }
    if (count == 0)
      return InvalidArgument(
          "--shard auto with JOB_COMPLETION_INDEX needs --shards N (the Job's completions)");
    if (id >= count) {
      return InvalidArgument("JOB_COMPLETION_INDEX=" + std::to_string(id) +
                             " is not below --shards " + std::to_string(count));
    }
    out.shard = id;
    out.shards = count;
    out.source = "JOB_COMPLETION_INDEX=" + std::to_string(id) + " of " + std::to_string(count);
  }
  if (out.shards == 0 || out.shards > 1000000)
    return InvalidArgument("the scheduler's task count " + std::to_string(out.shards) +
                           " is out of range");
  return out;
}

}  // namespace facespace::batch
