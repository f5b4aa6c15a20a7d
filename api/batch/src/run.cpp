#include "facespace/batch/run.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "facespace/batch/dataset.h"
#include "facespace/files/durable.h"
#include "folder.h"
#include "maker.h"

namespace facespace::batch {

using nlohmann::json;

namespace {

// One run of a batch (or a shard of one) in its folder, with group commit: a variant's files are
// written, many are flushed together, and only then do their manifest lines go in, so resume never
// trusts a file the manifest does not vouch for, and the disk is not waited on once per file.
//   folder: each worker writes its variants' files under temporary names and publishes them in
//   groups
//           (flushed, renamed);
//   tar:    workers hand their samples to one writer that appends them in index order to their
//   shard's
//           part, syncs it once a group, then writes the group's lines; a shard whose samples are
//           all in is ended and renamed to its name, so a shard under its name is always whole.
class BatchRun {
 public:
  BatchRun(const BatchPlan& plan, const RunOptions& options)
      : plan_(plan),
        options_(options),
        dir_(options.dir),
        manifest_name_(ManifestName(options.shard, options.shards)),
        tar_(plan.request.dataset.archive == evaluator::Archive::kTar) {}

  // The folder taken (locked, its batch.json this request's, leftovers gone) and what is left to
  // do.
  Status Prepare();
  // The pending variants over `jobs` workers, progress reported while they run.
  void Work(int jobs);
  // The manifest rewritten whole, then the shard's record or the contact sheet.
  Result<Summary> Finish();
  size_t pending() const { return pending_.size(); }

 private:
  // A variant made by a worker. Its manifest line is head + tail; an archived one's position goes
  // between.
  struct Written {
    size_t index;
    std::vector<int> fds;            // Folder: its files, written under temporary names,
    std::vector<std::string> files;  // and their names.
    std::string head, tail;
    std::string tar;  // Tar: its members.
  };
  // What one worker keeps: its workspace, its group of files not yet published, its warning counts.
  struct Worker {
    evaluator::Workspace ws;
    evaluator::ResolvedPoint point;
    evaluator::Encoded encoded;      // A variant's one file,
    std::vector<SampleFile> sample;  // or a labelled sample's,
    NamedFiles files;                // named, as pieces.
    std::vector<Written> group;
    std::chrono::steady_clock::time_point group_started;
    std::map<std::string, size_t> warned;  // Its variants per warning code, merged at its end.
    double max_sum = 0;
    std::unique_ptr<MakerProcess>
        maker;  // Makes its variants, when the run has makers (RunOptions::makers).
  };
  static constexpr auto kGroupAge = std::chrono::milliseconds(250);
  static constexpr size_t kTarWindow =
      32;  // Samples made ahead of the one the tar writer waits for.

  double Elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  bool Cancelled() const { return options_.cancel && options_.cancel->load(); }
  // Folders split variants among shards one by one; tar archives by whole tar shards.
  bool Mine(size_t k) const {
    return (tar_ ? TarShardOf(plan_, k) : k) % options_.shards == options_.shard;
  }
  size_t TarShardEnd(size_t t) const {
    return std::min((t + 1) * plan_.request.dataset.shard_samples, plan_.total);
  }
  Status WriteManifest() { return WriteInBatch(dir_, manifest_name_, JoinLines(lines_)); }
  Status CheckSpec();
  Status ResumeTar();
  Status MakeFiles(size_t k, Worker& w);
  Status Make(size_t k, Worker& w, MadeVariant& out);
  Status Store(size_t k, Worker& w, MadeVariant&& made);
  Status Encode(size_t k, Worker& w);
  Status StartMakers(std::vector<Worker>& workers);
  Status Flush(Worker& w);
  Status Deliver(Written&& sample);
  Status AppendReady();
  Status Commit();
  void Published(size_t count);
  void RunWorker(Worker& w);
  void Report();

  const BatchPlan& plan_;
  const RunOptions& options_;
  const fs::path dir_;
  const std::string manifest_name_;
  const bool tar_;
  const std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  RunLock lock_;
  std::map<size_t, std::string>
      lines_;  // Every variant done, by index (guarded by mu_ while workers run).
  std::vector<size_t> pending_;
  std::ofstream manifest_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::atomic<size_t> next_{0}, finished_{0};
  size_t running_ = 0;  // Workers still in their loop (guarded by mu_).
  Status failure_;
  Summary summary_;
  // Tar (guarded by mu_): samples made and waiting for their turn, how many of pending_ are
  // appended, the lines appended but not yet synced, the part being written, where each part
  // resumes.
  std::map<size_t, Written> ready_;
  size_t appended_ = 0;
  std::vector<std::pair<size_t, std::string>> unsynced_;
  std::chrono::steady_clock::time_point unsynced_since_;
  TarPart part_;
  std::map<size_t, uint64_t> resume_at_;
};

// The folder belongs to one batch: the same request against the same rig.
Status BatchRun::CheckSpec() {
  const fs::path spec_path = dir_ / "batch.json";
  if (!fs::exists(spec_path))
    return WriteInBatch(dir_, "batch.json", plan_.spec_json, "." + manifest_name_);
  std::ifstream f(spec_path, std::ios::binary);
  const std::string old((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (old == plan_.spec_json) return Status::Ok();
  return FailedPrecondition(
      "'" + options_.dir +
      "' holds another batch (its batch.json differs from this request or rig): "
      "use another output folder, or empty this one");
}

// Tar: each of this run's shards resumes after the samples its part holds in order from its start
// (a shard is written in order, so what the manifest vouches for is such a run; anything after is
// cut). A shard found whole but not yet renamed (a crash between the two) is ended now; one under
// its name but not vouched for whole is redone.
Status BatchRun::ResumeTar() {
  std::error_code ec;
  for (size_t t = 0; t * plan_.request.dataset.shard_samples < plan_.total; ++t) {
    const size_t first = t * plan_.request.dataset.shard_samples, end = TarShardEnd(t);
    if (!Mine(first)) continue;
    uint64_t length = 0;
    size_t k = first;
    for (; k < end && lines_.count(k); ++k) {
      const json j = json::parse(lines_[k], nullptr, false);
      if (j.value("offset", uint64_t{1}) != length) break;
      length += j["bytes"].get<uint64_t>();
    }
    for (size_t rest = k; rest < end; ++rest) lines_.erase(rest);
    const bool whole = k == end, named = fs::exists(dir_ / TarShardName(t), ec);
    if (named &&
        !whole) {  // Its part is gone with the rename: the shard is made again from its start.
      fs::remove(dir_ / TarShardName(t), ec);
      for (size_t redo = first; redo < end; ++redo) lines_.erase(redo);
      length = 0;
    }
    if (whole && !named) {
      if (Status s = part_.Open(dir_, t, length); !s.ok()) return s;
      if (Status s = part_.Finish(); !s.ok()) return s;
    }
    resume_at_[t] = length;
  }
  return Status::Ok();
}

Status BatchRun::Prepare() {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (!fs::is_directory(dir_))
    return FailedPrecondition("cannot create the output folder '" + options_.dir + "'");
  if (options_.shards == 0 || options_.shard >= options_.shards)
    return InvalidArgument("bad shard");
  if (!options_.evaluator) return InvalidArgument("no evaluator");
  const bool sharded = options_.shards > 1;
  if (!lock_.Take(dir_ / (kLockPrefix + manifest_name_))) {
    const std::string shard_text =
        std::to_string(options_.shard + 1) + "/" + std::to_string(options_.shards);
    return FailedPrecondition(
        std::string(sharded ? "shard " + shard_text + " of the batch" : "the batch") + " in '" +
        options_.dir + "' is being written by another process; wait for it, or stop it first");
  }
  if (Status s = CheckSpec(); !s.ok()) return s;
  // Leftovers of a run that was killed: temporary files are never complete. Those another process
  // (another shard) is writing are locked, and stay.
  for (const auto& e : fs::directory_iterator(dir_, ec)) {
    if (e.path().filename().string().rfind(kTmpPrefix, 0) == 0) files::RemoveAbandoned(e.path());
  }
  // Resume: a manifest line (this run's, another shard count's, or a merged one) whose files are
  // there is done; the rest is redone.
  lines_ = ReadManifests(dir_, plan_, [this](size_t k) { return Mine(k); });
  if (tar_) {
    if (Status s = ResumeTar(); !s.ok()) return s;
  }
  if (Status s = WriteManifest(); !s.ok()) return s;
  if (sharded)
    fs::remove(dir_ / RecordName(options_.shard, options_.shards),
               ec);  // Written again once every variant of the shard is there.
  for (size_t k = 0; k < plan_.total; ++k) {
    if (!Mine(k)) continue;
    ++summary_.total;
    if (lines_.count(k))
      ++summary_.skipped;
    else
      pending_.push_back(k);
  }
  manifest_.open(dir_ / manifest_name_, std::ios::app | std::ios::binary);
  return Status::Ok();
}

// Variant k's files into w.files: a labelled sample's (dataset.h), or the one file of a mesh or
// render.
Status BatchRun::MakeFiles(size_t k, Worker& w) {
  w.files.clear();
  const std::string id = VariantId(plan_, k);
  if (plan_.labelled()) {
    if (Status s = MakeSample(plan_, k, *options_.evaluator, w.ws, w.point, w.sample); !s.ok())
      return s;
    for (const SampleFile& f : w.sample) w.files.push_back({id + "." + f.suffix, {f.bytes, {}}});
    return Status::Ok();
  }
  VariantPoint(plan_, k, w.point);
  auto encoded = options_.evaluator->Run(plan_.rig, w.point, plan_.output, w.ws);
  if (!encoded.ok()) return encoded.status();
  w.encoded = std::move(
      encoded.value());  // Its bytes (or views into the workspace) live until the next variant.
  w.files.push_back({VariantFile(plan_, k), w.encoded.pieces()});
  return Status::Ok();
}

// Variant k made: its files (a tar's as members), its manifest line's head and tail, its warnings.
Status BatchRun::Make(size_t k, Worker& w, MadeVariant& out) {
  if (Status s = MakeFiles(k, w); !s.ok()) return Prefixed(s, VariantId(plan_, k) + ": ");
  const std::vector<Warning>& warnings = w.point.report.warnings;
  for (size_t i = 0; i < warnings.size(); ++i) {  // Each code once per variant.
    bool first = true;
    for (size_t v = 0; v < i && first; ++v) first = warnings[v].code != warnings[i].code;
    if (first) out.codes.push_back(warnings[i].code);
  }
  out.sum = w.point.report.sum;
  const auto text = [](const std::string& s) {
    return json(s).dump(-1, ' ', false, json::error_handler_t::replace);
  };
  out.head = "{\"index\":" + std::to_string(k) + ",\"id\":" + text(VariantId(plan_, k)) +
             ",\"file\":" + text(w.files[0].first);
  std::string listed;  // The files beside the first (a folder's), or every member (a tar's).
  for (size_t i = tar_ ? 0 : 1; i < w.files.size(); ++i) {
    const auto& [name, pieces] = w.files[i];
    listed += std::string(listed.empty() ? "" : ",") + "{\"file\":" + text(name) +
              ",\"bytes\":" + std::to_string(pieces[0].size() + pieces[1].size()) + "}";
    if (tar_) {
      if (Status s = AppendTarMember(out.tar, name, pieces); !s.ok()) return s;
    }
  }
  const std::array<std::string_view, 2> whole =
      tar_ ? std::array<std::string_view, 2>{out.tar, {}} : w.files[0].second;
  out.tail = ",\"bytes\":" + std::to_string(whole[0].size() + whole[1].size()) + ",\"sha256\":\"" +
             Sha256Hex(whole) + "\"" + (listed.empty() ? "" : ",\"files\":[" + listed + "]") +
             ",\"weights\":" + evaluator::WeightsMapJson(plan_.rig->rig, w.point.weights) +
             ",\"warnings\":" + formats::WarningsToJson(warnings) + "}";
  if (!tar_) out.files = w.files;
  return Status::Ok();
}

// A made variant counted and stored: handed to the tar writer, or its files written under temporary
// names into the worker's group.
Status BatchRun::Store(size_t k, Worker& w, MadeVariant&& made) {
  for (const std::string& code : made.codes) ++w.warned[code];
  w.max_sum = std::max(w.max_sum, made.sum);
  Written out{k, {}, {}, std::move(made.head), std::move(made.tail), std::move(made.tar)};
  if (tar_) return Deliver(std::move(out));
  for (const auto& [name, pieces] : made.files) {
    Result<int> fd = files::WriteTemporary(dir_, kTmpPrefix + name, pieces, "'" + name + "'");
    if (!fd.ok()) {
      for (size_t i = 0; i < out.fds.size(); ++i)
        files::Discard(out.fds[i], dir_, kTmpPrefix + out.files[i]);
      return Prefixed(fd.status(), VariantId(plan_, k) + ": ");
    }
    out.fds.push_back(fd.value());
    out.files.push_back(name);
  }
  if (w.group.empty()) w.group_started = std::chrono::steady_clock::now();
  w.group.push_back(std::move(out));
  return Status::Ok();
}

// Variant k made, here or by the worker's maker process, and stored.
Status BatchRun::Encode(size_t k, Worker& w) {
  MadeVariant made;
  if (Status s = w.maker ? w.maker->Ask(k, made) : Make(k, w, made); !s.ok()) return s;
  return Store(k, w, std::move(made));
}

void BatchRun::Published(size_t count) {
  summary_.generated += count;
  finished_.fetch_add(count);
  cv_.notify_all();
}

// Publishes the worker's group with one sync (group commit, PublishGroup); the lines of the
// variants whose files were all published go into the manifest.
Status BatchRun::Flush(Worker& w) {
  std::vector<files::PendingFile> files;
  for (Written& v : w.group) {
    for (size_t i = 0; i < v.fds.size(); ++i)
      files.push_back({v.fds[i], kTmpPrefix + v.files[i], v.files[i], "'" + v.files[i] + "'"});
  }
  const files::GroupResult group = PublishGroup(dir_, files);
  const Status failed = group.status;
  size_t published = 0;
  for (size_t done = 0;
       published < w.group.size() && done + w.group[published].fds.size() <= group.published;
       ++published) {
    done += w.group[published].fds.size();
  }
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (size_t i = 0; i < published; ++i) {
      Written& v = w.group[i];
      manifest_ << v.head << v.tail << '\n';
      lines_[v.index] = v.head + v.tail;
    }
    manifest_ << std::flush;
    Published(published);
  }
  w.group.clear();
  return failed;
}

// Tar: a made sample waits for its turn; those whose turn came are appended.
Status BatchRun::Deliver(Written&& sample) {
  std::lock_guard<std::mutex> lock(mu_);
  if (!failure_.ok()) return Status::Ok();  // The run is ending; the sample is redone on resume.
  ready_.emplace(sample.index, std::move(sample));
  Status s = AppendReady();
  cv_.notify_all();
  return s;
}

// Tar (mu_ held): the ready samples appended in index order to their shards' parts, each shard
// ended when its last sample is in, the group committed when it is large or old enough.
Status BatchRun::AppendReady() {
  while (appended_ < pending_.size()) {
    const auto it = ready_.find(pending_[appended_]);
    if (it == ready_.end()) break;
    const size_t k = it->first, t = TarShardOf(plan_, k);
    if (!part_.open() || part_.shard() != t) {
      if (Status s = part_.Open(dir_, t, resume_at_[t]); !s.ok()) return s;
    }
    const uint64_t offset = part_.length();
    if (Status s = part_.Append(it->second.tar); !s.ok()) return s;
    if (unsynced_.empty()) unsynced_since_ = std::chrono::steady_clock::now();
    unsynced_.emplace_back(k, it->second.head + ",\"shard\":\"" + TarShardName(t) +
                                  "\",\"offset\":" + std::to_string(offset) + it->second.tail);
    ready_.erase(it);
    ++appended_;
    if (k + 1 == TarShardEnd(t)) {
      if (Status s = Commit(); !s.ok()) return s;
      if (Status s = part_.Finish(); !s.ok()) return s;
    } else if (unsynced_.size() >= kGroupFiles ||
               std::chrono::steady_clock::now() - unsynced_since_ >= kGroupAge) {
      if (Status s = Commit(); !s.ok()) return s;
    }
  }
  return Status::Ok();
}

// Tar (mu_ held): one sync of the part for the samples appended since the last, then their lines.
Status BatchRun::Commit() {
  if (unsynced_.empty()) return Status::Ok();
  if (Status s = part_.Sync(); !s.ok()) return s;
  for (auto& [k, line] : unsynced_) {
    manifest_ << line << '\n';
    lines_[k] = std::move(line);
  }
  manifest_ << std::flush;
  Published(unsynced_.size());
  unsynced_.clear();
  return Status::Ok();
}

// A worker: variants taken one at a time until none is left, one fails or the run is cancelled. A
// tar's worker waits while it is too far ahead of the sample the writer needs next.
void BatchRun::RunWorker(Worker& w) {
  Status status;
  for (;;) {
    const size_t slot = next_.fetch_add(1);
    {
      std::unique_lock<std::mutex> lock(mu_);
      while (tar_ && failure_.ok() && !Cancelled() && slot >= appended_ + kTarWindow)
        cv_.wait_for(lock, std::chrono::milliseconds(50));
      if (!failure_.ok() || Cancelled()) break;
    }
    if (slot >= pending_.size()) break;
    if (status = Encode(pending_[slot], w); !status.ok()) break;
    if (w.group.size() >= kGroupFiles ||
        (!w.group.empty() && std::chrono::steady_clock::now() - w.group_started >= kGroupAge)) {
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
  if (options_.progress)
    options_.progress(
        {summary_.skipped + finished_.load(), summary_.skipped, summary_.total, Elapsed()});
}

// A maker process for each worker (maker.h), forked before any thread starts, when the run asks for
// them (RunOptions::makers) and this process is still one thread; else the workers make their
// variants themselves.
Status BatchRun::StartMakers(std::vector<Worker>& workers) {
  using Makers = RunOptions::Makers;
  const bool renders = plan_.labelled() || plan_.output.kind == evaluator::OutputSpec::Kind::kImage;
  const bool asked = options_.makers == Makers::kProcesses ||
                     (options_.makers == Makers::kAuto && renders && pending_.size() >= 1000);
  if (!asked || workers.size() < 2 || !CanForkMakers()) return Status::Ok();
  Worker child;  // The child's own, copied with the process.
  const MakerProcess::Make make = [this, &child](size_t k, MadeVariant& out) {
    return Make(k, child, out);
  };
  for (Worker& w : workers) {
    auto maker = MakerProcess::Start(make);
    if (!maker.ok()) return maker.status();
    w.maker = std::move(maker.value());
  }
  summary_.processes = workers.size();
  return Status::Ok();
}

void BatchRun::Work(int jobs) {
  // The count is set, under the lock, before any worker can end and lower it (a cancelled worker
  // ends at once).
  const size_t workers = pending_.empty() ? 0 : static_cast<size_t>(jobs);
  {
    std::lock_guard<std::mutex> lock(mu_);
    running_ = workers;
  }
  std::vector<Worker> state(workers);
  if (Status s = StartMakers(state); !s.ok()) {
    std::lock_guard<std::mutex> lock(mu_);
    failure_ = s;
    running_ = 0;
  }
  if (options_.before_threads) options_.before_threads(summary_.processes > 0);
  std::vector<std::thread> threads;
  for (size_t t = 0; failure_.ok() && t < workers; ++t)
    threads.emplace_back([this, &w = state[t]] { RunWorker(w); });
  {
    std::unique_lock<std::mutex> lock(mu_);
    while (running_ > 0) {
      lock.unlock();
      Report();
      lock.lock();
      cv_.wait_for(lock, std::chrono::milliseconds(200));
    }
    // What a tar's writer appended before the run stopped is committed; samples made past a gap are
    // redone.
    if (Status s = Commit(); !s.ok() && failure_.ok()) failure_ = s;
    ready_.clear();
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
    json record = {{"shard", options_.shard + 1},
                   {"shards", options_.shards},
                   {"variants", summary_.total},
                   {"sheet_cells", options_.sheet_cells},
                   {"rig_files", options_.rig_files}};
    if (Status s = WriteInBatch(dir_, RecordName(options_.shard, options_.shards),
                                record.dump(2, ' ', false, json::error_handler_t::replace) + "\n");
        !s.ok()) {
      return s;
    }
  } else if (!summary_.cancelled && options_.sheet_cells > 0 && summary_.total > 0 &&
             !fs::exists(dir_ / "sheet.png")) {
    // The contact sheet of the first variants, once they all exist.
    if (Status s = WriteSheet(plan_, dir_, options_.sheet_cells, *options_.evaluator); !s.ok())
      return s;
  }
  files::SyncDir(dir_);
  summary_.seconds = Elapsed();
  return summary_;
}

}  // namespace

Result<Summary> Run(const BatchPlan& plan, const RunOptions& options) {
  BatchRun run(plan, options);
  if (Status s = run.Prepare(); !s.ok()) return s;
  int jobs = options.jobs > 0 ? options.jobs
                              : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  jobs = static_cast<int>(
      std::min<size_t>(static_cast<size_t>(jobs), std::max<size_t>(1, run.pending())));
  run.Work(jobs);
  return run.Finish();
}

}  // namespace facespace::batch
