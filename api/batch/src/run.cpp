#include "facespace/batch/run.h"
#include "facespace/files/durable.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "facespace/core/blend.h"
#include "facespace/formats/io.h"
#include "facespace/core/skeleton.h"
#include "facespace/core/weights.h"

namespace facespace::batch {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr char kTmpPrefix[] = ".fs-tmp-";

constexpr char kLockPrefix[] = ".fs-lock-";
constexpr char kManifest[] = "manifest.jsonl";

// dir/name, durably; the folder itself is synced once at the end of the run. `writer` keeps the
// temporary names of processes writing the same file (shards writing batch.json) apart.
Status WriteInBatch(const fs::path& dir, const std::string& name, std::string_view data, const std::string& writer = "") {
  return WriteFileDurably(dir, name, data, kTmpPrefix + name + writer, "'" + name + "'", false);
}

std::string ShardSuffix(size_t shard, size_t shards) {
  return "shard-" + std::to_string(shard + 1) + "-of-" + std::to_string(shards);
}
std::string ManifestName(size_t shard, size_t shards) {
  return shards > 1 ? "manifest." + ShardSuffix(shard, shards) + ".jsonl" : kManifest;
}
std::string RecordName(size_t shard, size_t shards) { return ShardSuffix(shard, shards) + ".json"; }

// "shard-I-of-N" + suffix -> {I-1, N}.
bool ParseShardName(std::string_view name, std::string_view prefix, std::string_view suffix, size_t* shard, size_t* shards) {
  if (name.size() <= prefix.size() + suffix.size() || name.substr(0, prefix.size()) != prefix ||
      name.substr(name.size() - suffix.size()) != suffix) {
    return false;
  }
  name = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
  unsigned long i = 0, n = 0;
  char tail = 0;
  const std::string text(name);
  if (std::sscanf(text.c_str(), "shard-%lu-of-%lu%c", &i, &n, &tail) != 2 || i < 1 || i > n) return false;
  if (text != "shard-" + std::to_string(i) + "-of-" + std::to_string(n)) return false;
  *shard = i - 1;
  *shards = n;
  return true;
}

// An exclusive lock held while a run writes its manifest: the same shard never runs twice at
// once (two array tasks given the same index, a rerun while the first still runs).
class RunLock {
 public:
  RunLock() = default;
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;
  ~RunLock() {
    if (fd_ >= 0) {
      ::unlink(path_.c_str());
      ::close(fd_);
    }
  }
  // False when another process holds it.
  bool Take(const fs::path& path) {
    path_ = path.string();
    fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) return true;  // A read-only folder fails later, with a better message.
    if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) return true;
    ::close(fd_);
    fd_ = -1;
    return false;
  }

 private:
  std::string path_;
  int fd_ = -1;
};

// True when a process holds the lock at `path` (the file may be gone: nobody).
bool Locked(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool held = ::flock(fd, LOCK_SH | LOCK_NB) != 0;
  ::close(fd);
  return held;
}

// The manifest lines of `dir` (manifest.jsonl and every shard's) whose variant `keep(index)` and
// whose file is there with its size, by index. A torn line (a kill mid-write) or a line for a
// missing file is dropped.
std::map<size_t, std::string> ReadManifests(const fs::path& dir, const BatchPlan& plan, const std::function<bool(size_t)>& keep) {
  std::map<size_t, std::string> lines;
  std::error_code ec;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    size_t shard = 0, shards = 0;
    if (name == kManifest || ParseShardName(name, "manifest.", ".jsonl", &shard, &shards)) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& path : files) {
    std::ifstream f(path, std::ios::binary);
    std::string line;
    while (std::getline(f, line)) {
      json j = json::parse(line, nullptr, false);
      if (j.is_discarded() || !j.is_object() || !j.contains("index") || !j["index"].is_number_unsigned() ||
          !j.contains("file") || !j["file"].is_string() || !j.contains("bytes") || !j["bytes"].is_number_unsigned()) {
        continue;
      }
      const size_t index = j["index"].get<size_t>();
      if (index >= plan.total || !keep(index) || lines.count(index) ||
          j["file"].get<std::string>() != VariantFile(plan, index)) {
        continue;
      }
      const fs::path file = dir / j["file"].get<std::string>();
      if (fs::is_regular_file(file, ec) && fs::file_size(file, ec) == j["bytes"].get<uint64_t>()) lines[index] = line;
    }
  }
  return lines;
}

std::string JoinLines(const std::map<size_t, std::string>& lines) {
  std::string text;
  for (const auto& [index, line] : lines) text += line + "\n";
  return text;
}

// The contact sheet of the first `cells` variants, as a one-process run writes it.
Status WriteSheet(const BatchPlan& plan, const fs::path& dir, size_t cells, const api::Evaluator& evaluator) {
  std::vector<size_t> first;
  for (size_t k = 0; k < plan.total && first.size() < cells; ++k) first.push_back(k);
  api::Workspace ws;
  auto png = VariantSheet(plan, first, evaluator, ws);
  if (!png.ok()) return png.status();
  return WriteInBatch(dir, "sheet.png", png.value());
}

}  // namespace

std::string Sha256Hex(std::span<const std::string_view> pieces) {
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr);
  for (std::string_view p : pieces) EVP_DigestUpdate(ctx, p.data(), p.size());
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_DigestFinal_ex(ctx, md, &len);
  EVP_MD_CTX_free(ctx);
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < len; ++i) {
    out += hex[md[i] >> 4];
    out += hex[md[i] & 15];
  }
  return out;
}

namespace {

// One run of a batch (or a shard of one) in its folder: the workers write variants to temporary files
// and flush them in groups: the files of a group are flushed and renamed, and only then do their
// manifest lines go in, so resume never trusts a file the manifest does not vouch for, and the disk is
// not waited on once per file.
class BatchRun {
 public:
  BatchRun(const BatchPlan& plan, const RunOptions& options)
      : plan_(plan), options_(options), dir_(options.dir), manifest_name_(ManifestName(options.shard, options.shards)) {}

  // The folder taken (locked, its batch.json this request's, leftovers gone) and what is left to do.
  Status Prepare();
  // The pending variants over `jobs` workers, progress reported while they run.
  void Work(int jobs);
  // The manifest rewritten whole, then the shard's record or the contact sheet.
  Result<Summary> Finish();
  size_t pending() const { return pending_.size(); }

 private:
  struct Written {
    size_t index;
    int fd;
    std::string file, line;
  };
  // What one worker keeps: its workspace, its group of files not yet published, its warning counts.
  struct Worker {
    api::Workspace ws;
    api::ResolvedPoint point;
    std::vector<Written> group;
    std::chrono::steady_clock::time_point group_started;
    std::map<std::string, size_t> warned;  // Its variants per warning code, merged at its end.
    double max_sum = 0;
  };
  static constexpr size_t kGroupFiles = 32;
  static constexpr auto kGroupAge = std::chrono::milliseconds(250);

  double Elapsed() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }
  bool Cancelled() const { return options_.cancel && options_.cancel->load(); }
  bool Mine(size_t k) const { return k % options_.shards == options_.shard; }
  Status WriteManifest() { return WriteInBatch(dir_, manifest_name_, JoinLines(lines_)); }
  Status CheckSpec();
  Status Encode(size_t k, Worker& w);
  Status Flush(Worker& w);
  void RunWorker();
  void Report();

  const BatchPlan& plan_;
  const RunOptions& options_;
  const fs::path dir_;
  const std::string manifest_name_;
  const std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  RunLock lock_;
  std::map<size_t, std::string> lines_;  // Every variant done, by index (guarded by mu_ while workers run).
  std::vector<size_t> pending_;
  std::ofstream manifest_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::atomic<size_t> next_{0}, finished_{0};
  size_t running_ = 0;  // Workers still in their loop (guarded by mu_).
  Status failure_;
  Summary summary_;
};

// The folder belongs to one batch: the same request against the same rig.
Status BatchRun::CheckSpec() {
  const fs::path spec_path = dir_ / "batch.json";
  if (!fs::exists(spec_path)) return WriteInBatch(dir_, "batch.json", plan_.spec_json, "." + manifest_name_);
  std::ifstream f(spec_path, std::ios::binary);
  const std::string old((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (old == plan_.spec_json) return Status::Ok();
  return FailedPrecondition("'" + options_.dir + "' holds another batch (its batch.json differs from this request or rig): "
                            "use another output folder, or empty this one");
}

Status BatchRun::Prepare() {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (!fs::is_directory(dir_)) return FailedPrecondition("cannot create the output folder '" + options_.dir + "'");
  if (options_.shards == 0 || options_.shard >= options_.shards) return InvalidArgument("bad shard");
  if (!options_.evaluator) return InvalidArgument("no evaluator");
  const bool sharded = options_.shards > 1;
  if (!lock_.Take(dir_ / (kLockPrefix + manifest_name_))) {
    const std::string shard_text = std::to_string(options_.shard + 1) + "/" + std::to_string(options_.shards);
    return FailedPrecondition(std::string(sharded ? "shard " + shard_text + " of the batch" : "the batch") + " in '" + options_.dir +
                              "' is being written by another process; wait for it, or stop it first");
  }
  if (Status s = CheckSpec(); !s.ok()) return s;
  // Leftovers of a run that was killed: temporary files are never complete. Those another process
  // (another shard) is writing are locked, and stay.
  for (const auto& e : fs::directory_iterator(dir_, ec)) {
    if (e.path().filename().string().rfind(kTmpPrefix, 0) == 0) RemoveAbandoned(e.path());
  }
  // Resume: a manifest line (this run's, another shard count's, or a merged one) whose file is there
  // with its size is done; the rest is redone.
  lines_ = ReadManifests(dir_, plan_, [this](size_t k) { return Mine(k); });
  if (Status s = WriteManifest(); !s.ok()) return s;
  if (sharded) fs::remove(dir_ / RecordName(options_.shard, options_.shards), ec);  // Written again once every variant of the shard is there.
  for (size_t k = options_.shard; k < plan_.total; k += options_.shards) {
    ++summary_.total;
    if (lines_.count(k)) ++summary_.skipped;
    else pending_.push_back(k);
  }
  manifest_.open(dir_ / manifest_name_, std::ios::app | std::ios::binary);
  return Status::Ok();
}

// Variant k evaluated and written to its temporary file, its manifest line into the worker's group.
Status BatchRun::Encode(size_t k, Worker& w) {
  VariantPoint(plan_, k, w.point);
  auto encoded = options_.evaluator->Run(plan_.rig, w.point, plan_.output, w.ws);
  if (!encoded.ok()) return Prefixed(encoded.status(), VariantId(plan_, k) + ": ");
  const std::array<std::string_view, 2> pieces = encoded->pieces();
  const std::string file = VariantFile(plan_, k);
  Result<int> fd = WriteTemporary(dir_, kTmpPrefix + file, pieces, "'" + file + "'");
  if (!fd.ok()) return Prefixed(fd.status(), VariantId(plan_, k) + ": ");
  const std::vector<Warning>& warnings = w.point.report.warnings;
  for (size_t i = 0; i < warnings.size(); ++i) {  // Each code once per variant.
    bool first = true;
    for (size_t v = 0; v < i && first; ++v) first = warnings[v].code != warnings[i].code;
    if (first) ++w.warned[warnings[i].code];
  }
  w.max_sum = std::max(w.max_sum, w.point.report.sum);
  if (w.group.empty()) w.group_started = std::chrono::steady_clock::now();
  const auto text = [](const std::string& s) { return json(s).dump(-1, ' ', false, json::error_handler_t::replace); };
  w.group.push_back({k, fd.value(), file,
                     "{\"index\":" + std::to_string(k) + ",\"id\":" + text(VariantId(plan_, k)) + ",\"file\":" + text(file) +
                         ",\"bytes\":" + std::to_string(pieces[0].size() + pieces[1].size()) + ",\"sha256\":\"" + Sha256Hex(pieces) +
                         "\",\"weights\":" + api::WeightsMapJson(plan_.rig->rig, w.point.weights) + ",\"warnings\":" + WarningsToJson(warnings) + "}"});
  return Status::Ok();
}

// Publishes the worker's group; the lines of the files published go into the manifest.
Status BatchRun::Flush(Worker& w) {
  Status failed;
  size_t published = 0;
  for (Written& f : w.group) {
    if (!failed.ok()) {
      Discard(f.fd, dir_, kTmpPrefix + f.file);
      continue;
    }
    failed = Publish(f.fd, dir_, kTmpPrefix + f.file, f.file, "'" + f.file + "'");
    if (failed.ok()) ++published;
  }
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (size_t i = 0; i < published; ++i) {
      manifest_ << w.group[i].line << '\n';
      lines_[w.group[i].index] = std::move(w.group[i].line);
    }
    manifest_ << std::flush;
    summary_.generated += published;
  }
  finished_.fetch_add(published);
  cv_.notify_all();
  w.group.clear();
  return failed;
}

// A worker: variants taken one at a time until none is left, one fails or the run is cancelled.
void BatchRun::RunWorker() {
  Worker w;
  Status status;
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!failure_.ok() || Cancelled()) break;
    }
    const size_t slot = next_.fetch_add(1);
    if (slot >= pending_.size()) break;
    if (status = Encode(pending_[slot], w); !status.ok()) break;
    if (w.group.size() >= kGroupFiles || std::chrono::steady_clock::now() - w.group_started >= kGroupAge) {
      if (status = Flush(w); !status.ok()) break;
    }
  }
  if (Status s = Flush(w); status.ok()) status = s;
  std::lock_guard<std::mutex> lock(mu_);
  if (!status.ok() && failure_.ok()) failure_ = status;
  for (const auto& [code, count] : w.warned) summary_.warnings[code] += count;
  summary_.max_sum = std::max(summary_.max_sum, w.max_sum);
  --running_;
  cv_.notify_all();
}

void BatchRun::Report() {
  if (options_.progress) options_.progress({summary_.skipped + finished_.load(), summary_.skipped, summary_.total, Elapsed()});
}

void BatchRun::Work(int jobs) {
  // The count is set, under the lock, before any worker can end and lower it (a cancelled worker
  // ends at once).
  const size_t workers = pending_.empty() ? 0 : static_cast<size_t>(jobs);
  {
    std::lock_guard<std::mutex> lock(mu_);
    running_ = workers;
  }
  std::vector<std::thread> threads;
  for (size_t t = 0; t < workers; ++t) threads.emplace_back([this] { RunWorker(); });
  {
    std::unique_lock<std::mutex> lock(mu_);
    while (running_ > 0) {
      lock.unlock();
      Report();
      lock.lock();
      cv_.wait_for(lock, std::chrono::milliseconds(200));
    }
  }
  for (std::thread& t : threads) t.join();
  manifest_.close();
  summary_.cancelled = Cancelled();
  Report();
}

Result<Summary> BatchRun::Finish() {
  const Status written = WriteManifest();
  if (!failure_.ok()) return failure_;
  if (!written.ok()) return written;
  if (!summary_.cancelled && options_.shards > 1) {
    // The shard's record: merge's proof that it finished, and where the rig is.
    json record = {{"shard", options_.shard + 1}, {"shards", options_.shards}, {"variants", summary_.total},
                   {"sheet_cells", options_.sheet_cells}, {"rig_files", options_.rig_files}};
    if (Status s = WriteInBatch(dir_, RecordName(options_.shard, options_.shards), record.dump(2, ' ', false, json::error_handler_t::replace) + "\n");
        !s.ok()) {
      return s;
    }
  } else if (!summary_.cancelled && options_.sheet_cells > 0 && summary_.total > 0 && !fs::exists(dir_ / "sheet.png")) {
    // The contact sheet of the first variants, once they all exist.
    if (Status s = WriteSheet(plan_, dir_, options_.sheet_cells, *options_.evaluator); !s.ok()) return s;
  }
  SyncDir(dir_);
  summary_.seconds = Elapsed();
  return summary_;
}

}  // namespace

Result<Summary> Run(const BatchPlan& plan, const RunOptions& options) {
  BatchRun run(plan, options);
  if (Status s = run.Prepare(); !s.ok()) return s;
  int jobs = options.jobs > 0 ? options.jobs : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  jobs = static_cast<int>(std::min<size_t>(static_cast<size_t>(jobs), std::max<size_t>(1, run.pending())));
  run.Work(jobs);
  return run.Finish();
}

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
      return FailedPrecondition("'" + dir_name + "' holds shards of " + std::to_string(found.shards) + " and of " +
                                std::to_string(shards) + ": runs with different shard counts cannot be merged; rerun with one count");
    }
    found.shards = shards;
    if (!record) continue;
    std::ifstream f(e.path(), std::ios::binary);
    json j = json::parse(f, nullptr, false);
    if (j.is_discarded() || !j.is_object()) continue;  // Unreadable: the shard counts as unfinished.
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
  if (found.shards == 0) return FailedPrecondition("'" + dir_name + "' holds no shards of a batch (no manifest.shard-I-of-N.jsonl)");
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
    if (spec != plan.spec_json) return FailedPrecondition("'" + options.dir + "/batch.json' is not this batch's (another request or rig version)");
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
      problems += std::string(problems.empty() ? "" : ", ") + std::to_string(i + 1) + "/" + std::to_string(shards) +
                  (running ? " (running)" : "");
    }
  }
  if (unfinished > 0) {
    return FailedPrecondition(std::to_string(unfinished) + " of " + std::to_string(shards) + " shards of '" + options.dir +
                              "' have not finished: " + problems + (unfinished > 8 ? ", ..." : "") +
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
    return FailedPrecondition(std::to_string(count) + " variants are missing from '" + options.dir + "' (" + missing +
                              (count > 5 ? ", ..." : "") + "): rerun their shards, then merge");
  }
  if (options.verify) {
    std::string data;
    for (const auto& [index, line] : lines) {
      const json j = json::parse(line, nullptr, false);
      const std::string file = j["file"].get<std::string>();
      std::ifstream f(dir / file, std::ios::binary);
      data.assign((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
      const std::string_view whole[] = {data};
      if (!j.contains("sha256") || j["sha256"] != Sha256Hex(whole)) {
        return FailedPrecondition("'" + file + "' does not match its manifest line's sha256 (changed after it was written): "
                                  "remove it and rerun its shard, then merge");
      }
    }
  }
  if (Status s = WriteInBatch(dir, kManifest, JoinLines(lines)); !s.ok()) return s;
  if (options.sheet_cells > 0 && plan.total > 0) {
    if (Status s = WriteSheet(plan, dir, options.sheet_cells, *options.evaluator); !s.ok()) return s;
  }
  SyncDir(dir);
  // manifest.jsonl vouches for every variant now: the shards' files go.
  std::error_code ec;
  for (size_t i = 0; i < shards; ++i) {
    fs::remove(dir / ManifestName(i, shards), ec);
    fs::remove(dir / RecordName(i, shards), ec);
  }
  SyncDir(dir);
  MergeSummary summary;
  summary.shards = shards;
  summary.variants = plan.total;
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

Result<SchedulerShard> ShardFromScheduler(const std::function<const char*(const char*)>& env, size_t count) {
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
        return InvalidArgument("SLURM_ARRAY_TASK_ID=" + std::to_string(id) + " is not below --shards " + std::to_string(count) +
                               " (with --shards N the array ids are the shards: --array=0-" + std::to_string(count - 1) + ", or a part of it)");
      }
      out.shard = id;
      out.shards = count;
      out.source = "SLURM_ARRAY_TASK_ID=" + std::to_string(id) + " with --shards " + std::to_string(count);
      return out;
    }
    if (!has_step.value() || step == 0) step = 1;
    if (!has_lo.value()) lo = 0;
    if (!has_count.value()) {
      if (!has_hi.value()) return InvalidArgument("SLURM_ARRAY_TASK_ID is set but neither SLURM_ARRAY_TASK_COUNT nor _MAX: give --shards N");
      n = hi < lo ? 0 : (hi - lo) / step + 1;
    }
    if (id < lo || (id - lo) % step != 0 || (id - lo) / step >= n) {
      return InvalidArgument("SLURM_ARRAY_TASK_ID=" + std::to_string(id) + " is not one of " + std::to_string(n) +
                             " evenly spaced tasks from " + std::to_string(lo) +
                             " (arrays like --array=0-3 or 1-8:1 shard; for others give --shard I/N)");
    }
    out.shard = (id - lo) / step;
    out.shards = n;
    out.source = "SLURM_ARRAY_TASK_ID=" + std::to_string(id) + " of " + std::to_string(n) + " tasks";
  } else {
    auto has_index = number("JOB_COMPLETION_INDEX", &id);
    if (!has_index.ok()) return has_index.status();
    if (!has_index.value()) {
      return InvalidArgument("--shard auto: no scheduler's task index in the environment (SLURM_ARRAY_TASK_ID of a Slurm job array, "
                             "JOB_COMPLETION_INDEX of a Kubernetes Indexed Job); give --shard I/N");
    }
    if (count == 0) return InvalidArgument("--shard auto with JOB_COMPLETION_INDEX needs --shards N (the Job's completions)");
    if (id >= count) {
      return InvalidArgument("JOB_COMPLETION_INDEX=" + std::to_string(id) + " is not below --shards " + std::to_string(count));
    }
    out.shard = id;
    out.shards = count;
    out.source = "JOB_COMPLETION_INDEX=" + std::to_string(id) + " of " + std::to_string(count);
  }
  if (out.shards == 0 || out.shards > 1000000) return InvalidArgument("the scheduler's task count " + std::to_string(out.shards) + " is out of range");
  return out;
}

}  // namespace facespace::batch
