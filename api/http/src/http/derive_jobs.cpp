#include "derive_jobs.h"

#include <algorithm>

namespace facespace::http {

using batch::JobState;

DeriveJobs::~DeriveJobs() {
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& j : jobs_) j->stop.request_stop();
}

Result<DeriveJobInfo> DeriveJobs::Submit(DeriveJobInfo info, DeriveWork work) {
  std::lock_guard<std::mutex> lock(mu_);
  const auto unfinished = std::count_if(
      jobs_.begin(), jobs_.end(), [](const auto& j) { return batch::Unfinished(j->info.state); });
  if (static_cast<size_t>(unfinished) >= kMaxUnfinished) {
    return WithReason(
        ResourceExhausted("derives run one at a time and " + std::to_string(kMaxUnfinished) +
                          " are queued or running; retry when one ends"),
        batch::kJobQueueFull);
  }
  // The oldest finished ones go first when too many are kept.
  for (size_t finished = jobs_.size() - static_cast<size_t>(unfinished);
       finished >= kKeptFinished;) {
    auto it = std::find_if(jobs_.begin(), jobs_.end(),
                           [](const auto& j) { return !batch::Unfinished(j->info.state); });
    if (it == jobs_.end()) break;
    jobs_.erase(it);
    --finished;
  }
  auto job = std::make_shared<Job>();
  info.id = batch::NewJobId();
  info.created = batch::NowRfc3339();
  info.state = JobState::kQueued;
  job->info = std::move(info);
  job->work = std::move(work);
  jobs_.push_back(job);
  if (!worker_.joinable()) worker_ = std::jthread([this](std::stop_token s) { Loop(s); });
  cv_.notify_all();
  return job->info;
}

std::optional<DeriveJobInfo> DeriveJobs::Get(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& j : jobs_)
    if (j->info.id == id) return j->info;
  return std::nullopt;
}

std::vector<DeriveJobInfo> DeriveJobs::List() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<DeriveJobInfo> out;
  for (auto it = jobs_.rbegin(); it != jobs_.rend(); ++it) out.push_back((*it)->info);
  return out;
}

bool DeriveJobs::Remove(const std::string& id) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it =
      std::find_if(jobs_.begin(), jobs_.end(), [&](const auto& j) { return j->info.id == id; });
  if (it == jobs_.end()) return false;
  (*it)->stop.request_stop();
  jobs_.erase(it);
  return true;
}

void DeriveJobs::Loop(const std::stop_token& stop) {
  while (!stop.stop_requested()) {
    std::shared_ptr<Job> job;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, stop, [&] {
        auto it = std::find_if(jobs_.begin(), jobs_.end(),
                               [](const auto& j) { return j->info.state == JobState::kQueued; });
        if (it != jobs_.end()) job = *it;
        return job != nullptr;
      });
      if (!job) return;
      job->info.state = JobState::kRunning;
    }
    std::stop_callback halt(stop, [&job] { job->stop.request_stop(); });
    auto progress = [this, &job](double f, const char* step) {
      std::lock_guard<std::mutex> lock(mu_);
      job->info.progress = std::clamp(f, 0.0, 1.0);
      job->info.step = step ? step : "";
    };
    Result<nlohmann::json> out = job->work(job->stop.get_token(), progress);
    std::lock_guard<std::mutex> lock(mu_);
    job->work = nullptr;  // What it held (the rigs) let go.
    if (out.ok()) {
      job->info.state = JobState::kDone;
      job->info.progress = 1;
      job->info.result = std::move(out.value());
    } else {
      const bool cancelled = out.status().code == StatusCode::kCancelled;
      job->info.state = cancelled ? JobState::kCancelled : JobState::kFailed;
      job->info.error = out.status();
    }
    job->info.step.clear();
  }
}

}  // namespace facespace::http
