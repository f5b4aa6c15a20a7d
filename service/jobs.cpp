#include "jobs.h"

#include "durable.h"

#include <openssl/rand.h>

#include <chrono>
#include <ctime>
#include <random>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "batch.h"

namespace facespace {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string NewJobId() {
  unsigned char bytes[16];
  if (RAND_bytes(bytes, sizeof bytes) != 1) {
    std::random_device rd;
    for (unsigned char& b : bytes) b = static_cast<unsigned char>(rd());
  }
  static const char* hex = "0123456789abcdef";
  std::string id;
  for (unsigned char b : bytes) {
    id += hex[b >> 4];
    id += hex[b & 15];
  }
  return id;
}

std::string NowRfc3339() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// path, durably (temporary name, fsync, rename, folder fsync).
Status WriteJobFile(const fs::path& path, const std::string& text) {
  const std::string name = path.filename().string();
  return WriteFileDurably(path.parent_path(), name, text, ".tmp-" + name, "'" + name + "'");
}

std::string ReadText(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

size_t ManifestLines(const fs::path& path) {
  std::ifstream f(path);
  size_t n = 0;
  std::string line;
  while (std::getline(f, line)) n += !line.empty() && line.back() == '}';
  return n;
}

}  // namespace


FileJobQueue::FileJobQueue(std::string dir, api::RigStore& store, const render::Renderer& renderer, JobLimits limits)
    : dir_(std::move(dir)), store_(store), renderer_(renderer), limits_(limits) {}

FileJobQueue::~FileJobQueue() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stopping_ = true;
    if (running_) running_->cancel.store(true);
  }
  cv_.notify_all();
  if (runner_.joinable()) runner_.join();
}

Result<size_t> FileJobQueue::Start() {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (!fs::is_directory(dir_)) return FailedPrecondition("cannot create the jobs folder '" + dir_ + "'");
  std::vector<std::shared_ptr<Job>> found;
  for (const auto& e : fs::directory_iterator(dir_, ec)) {
    const std::string id = e.path().filename().string();
    if (!api::IsValidJobId(id)) continue;
    json j = json::parse(ReadText(e.path() / "job.json"), nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("request") || !j.contains("rig")) {
      fs::remove_all(e.path(), ec);  // Never accepted: the request did not reach the disk whole.
      continue;
    }
    auto job = std::make_shared<Job>();
    job->info.id = id;
    job->info.rig = j.value("rig", "");
    job->info.created = j.value("created", "");
    job->info.total = j.value("total", size_t{0});
    job->info.format = j["request"].value("format", "glb");
    job->body = j["request"].dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    job->info.done = ManifestLines(e.path() / "out" / "manifest.jsonl");
    json st = json::parse(ReadText(e.path() / "state.json"), nullptr, false);
    if (!st.is_discarded() && st.is_object()) {
      job->info.state = st.value("state", "failed");
      job->info.error = st.value("error", "");
    } else {
      auto rig = store_.Get(job->info.rig);
      if (!rig || rig->version != j.value("rig_version", "")) {
        job->info.state = "lost";
        job->info.error = "rig '" + job->info.rig + "' was " + (rig ? "replaced" : "removed") +
                          " while the job was unfinished; " + std::to_string(job->info.done) + " of " +
                          std::to_string(job->info.total) + " variants were done";
        WriteJobFile(e.path() / "state.json", json{{"state", job->info.state}, {"error", job->info.error}}.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
      } else {
        job->rig = rig;
        job->info.state = "queued";
      }
    }
    found.push_back(job);
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a->info.created < b->info.created; });
  size_t resumed = 0;
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (auto& job : found) {
      jobs_[job->info.id] = job;
      if (job->info.state == "queued") {
        queue_.push_back(job);
        ++resumed;
      }
    }
  }
  runner_ = std::thread([this] { RunLoop(); });
  return resumed;
}

Result<api::JobInfo> FileJobQueue::Submit(std::shared_ptr<const api::StoredRig> rig, std::shared_ptr<const api::BatchPlan> plan,
                                          std::string_view body, int* retry_after) {
  if (plan->total > limits_.max_batch) {
    const std::string ptr = plan->request.sampled ? "/sample/count" : "/variants";
    Status s = InvalidArgument(ptr + ": a batch has at most " + std::to_string(limits_.max_batch) + " variants; this one has " +
                               std::to_string(plan->total));
    s.fields.push_back({ptr, "at most " + std::to_string(limits_.max_batch) + " variants"});
    return s;
  }
  auto job = std::make_shared<Job>();
  job->info.id = NewJobId();
  job->info.rig = rig->id;
  job->info.state = "queued";
  job->info.format = plan->request.format;
  job->info.created = NowRfc3339();
  job->info.total = plan->total;
  job->rig = rig;
  job->plan = plan;
  job->body = std::string(body);
  std::unique_lock<std::mutex> lock(mu_);
  const size_t active = queue_.size() + (running_ ? 1 : 0);
  if (active >= limits_.max_jobs) {
    double rate = running_ && running_->info.rate > 0 ? running_->info.rate : 0.0;
    size_t remaining = running_ ? running_->info.total - running_->info.done : 0;
    for (const auto& q : queue_) remaining += q->info.total - q->info.done;
    // Until the running job ends, if its rate is known; else a guess.
    const double wait = rate > 0 && running_ ? (running_->info.total - running_->info.done) / rate : 10.0;
    *retry_after = static_cast<int>(std::clamp(wait, 1.0, 3600.0));
    return WithReason(ResourceExhausted("the job queue is full (" + std::to_string(active) + " of " + std::to_string(limits_.max_jobs) +
                             " jobs queued or running, " + std::to_string(remaining) + " variants to go)"), api::kJobQueueFull);
  }
  lock.unlock();
  const fs::path folder = fs::path(dir_) / job->info.id;
  std::error_code ec;
  fs::create_directories(folder, ec);
  json j = {{"id", job->info.id},          {"rig", rig->id},         {"rig_version", rig->version},
            {"created", job->info.created}, {"total", plan->total}, {"request", json::parse(body, nullptr, false)}};
  Status written = ec ? Internal("cannot create the job's folder: " + ec.message())
                      : WriteJobFile(folder / "job.json", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  if (!written.ok()) {
    fs::remove_all(folder, ec);
    return Prefixed(written, "cannot store the job: ");
  }
  lock.lock();
  jobs_[job->info.id] = job;
  queue_.push_back(job);
  const api::JobInfo info = job->info;
  lock.unlock();
  cv_.notify_all();
  return info;
}

std::optional<api::JobInfo> FileJobQueue::Get(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  return it->second->info;
}

std::vector<api::JobInfo> FileJobQueue::List() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<api::JobInfo> out;
  for (const auto& [id, job] : jobs_) out.push_back(job->info);
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.created > b.created || (a.created == b.created && a.id < b.id); });
  return out;
}

Status FileJobQueue::Remove(const std::string& id) {
  std::unique_lock<std::mutex> lock(mu_);
  auto it = jobs_.find(id);
  if (it == jobs_.end()) return NotFound("no job '" + id + "'");
  std::shared_ptr<Job> job = it->second;
  jobs_.erase(it);
  queue_.erase(std::remove(queue_.begin(), queue_.end(), job), queue_.end());
  job->removed = true;
  job->cancel.store(true);
  if (job == running_) return Status::Ok();  // The runner deletes the folder when the job stops.
  lock.unlock();
  std::error_code ec;
  fs::remove_all(fs::path(dir_) / id, ec);
  return Status::Ok();
}

std::string FileJobQueue::Folder(const std::string& id) const { return (fs::path(dir_) / id / "out").string(); }

void FileJobQueue::Finish(Job& job, const std::string& state, const std::string& error) {
  WriteJobFile(fs::path(dir_) / job.info.id / "state.json", json{{"state", state}, {"error", error}}.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  std::lock_guard<std::mutex> lock(mu_);
  job.info.state = state;
  job.info.error = error;
}

void FileJobQueue::RunLoop() {
  for (;;) {
    std::shared_ptr<Job> job;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      job = queue_.front();
      queue_.pop_front();
      running_ = job;
      job->info.state = "running";
    }
    Result<std::shared_ptr<const api::BatchPlan>> plan = job->plan;
    if (!job->plan) {  // Resumed at start: plan the stored request again.
      auto made = api::MakeBatchPlan(job->rig->rig, job->rig->version, job->body);
      plan = made.ok() ? Result<std::shared_ptr<const api::BatchPlan>>(std::make_shared<const api::BatchPlan>(std::move(made.value())))
                       : Result<std::shared_ptr<const api::BatchPlan>>(made.status());
    }
    if (!plan.ok()) {
      Finish(*job, "failed", plan.status().message);
    } else {
      batch::RunOptions options;
      options.dir = Folder(job->info.id);
      options.renderer = &renderer_;
      options.jobs = limits_.threads;
      options.cancel = &job->cancel;
      options.progress = [this, &job](const batch::Progress& p) {
        std::lock_guard<std::mutex> lock(mu_);
        job->info.done = p.done;
        job->info.seconds = p.seconds;
        job->info.rate = p.seconds > 0 ? (p.done - p.skipped) / p.seconds : 0.0;
      };
      auto summary = batch::Run(*plan.value(), options);
      bool removed = false, stopping = false;
      {
        std::lock_guard<std::mutex> lock(mu_);
        removed = job->removed;
        stopping = stopping_;
      }
      if (removed) {
        std::error_code ec;
        fs::remove_all(fs::path(dir_) / job->info.id, ec);
      } else if (!summary.ok()) {
        Finish(*job, "failed", summary.status().message);
      } else if (summary->cancelled) {
        if (!stopping) Finish(*job, "cancelled", "");
        // Stopping: no state.json, so the next start resumes it.
      } else {
        Finish(*job, "done", "");
      }
    }
    std::lock_guard<std::mutex> lock(mu_);
    running_.reset();
  }
}

}  // namespace facespace
