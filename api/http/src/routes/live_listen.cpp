#include "live_listen.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <utility>

#include "facespace/net/live_hub.h"

namespace facespace::http {

Result<std::unique_ptr<LiveListener>> LiveListener::Open(std::function<void()> wake) {
  auto rec = speech::LiveRecognizer::Open();
  if (!rec.ok()) return rec.status();
  return std::unique_ptr<LiveListener>(new LiveListener(std::move(rec.value()), std::move(wake)));
}

LiveListener::LiveListener(std::unique_ptr<speech::LiveRecognizer> rec, std::function<void()> wake)
    : rec_(std::move(rec)), wake_(std::move(wake)) {
  thread_ = std::jthread([this](std::stop_token stop) { Run(stop); });
}

LiveListener::~LiveListener() {
  thread_.request_stop();
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

Status LiveListener::Feed(std::span<const int16_t> pcm) {
  std::lock_guard<std::mutex> lock(mu_);
  if (finishing_)
    return InvalidField("/listen", "listening has ended: {\"listen\": {...}} starts again");
  const Clock::time_point now = Clock::now();
  credit_ = std::min(
      kBurstSeconds * kRate,
      credit_ + kMaxRealTime * kRate * std::chrono::duration<double>(now - credit_at_).count());
  credit_at_ = now;
  const double n = static_cast<double>(pcm.size());
  if (n > credit_ ||
      queued_samples_ + pcm.size() > static_cast<size_t>(kMaxBacklogSeconds * kRate)) {
    return WithReason(ResourceExhausted("audio comes faster than it plays: at most " +
                                        std::to_string(kMaxRealTime).substr(0, 3) +
                                        " seconds of audio a second (a burst of " +
                                        std::to_string(static_cast<int>(kBurstSeconds)) + " s)"),
                      "audio-too-fast");
  }
  credit_ -= n;
  queued_samples_ += pcm.size();
  queue_.emplace_back(pcm.begin(), pcm.end());
  cv_.notify_all();
  return Status::Ok();
}

void LiveListener::Finish() {
  std::lock_guard<std::mutex> lock(mu_);
  finishing_ = true;
  cv_.notify_all();
}

void LiveListener::Cancel() {
  thread_.request_stop();
  cv_.notify_all();
}

Status LiveListener::Take(std::vector<TimedPhoneme>& out) {
  std::lock_guard<std::mutex> lock(mu_);
  out.insert(out.end(), sure_.begin(), sure_.end());
  sure_.clear();
  return std::exchange(error_, Status::Ok());
}

bool LiveListener::Ended() {
  std::lock_guard<std::mutex> lock(mu_);
  return ended_;
}

double LiveListener::TakeCpu() {
  std::lock_guard<std::mutex> lock(mu_);
  return std::exchange(cpu_, 0.0);
}

// The thread: each chunk decoded as it comes, the phonemes made sure given to the session's next
// turn.
void LiveListener::Run(std::stop_token stop) {
  setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()),
              kNice);  // Below the turns: frames come first.
  std::vector<TimedPhoneme> made;
  while (true) {
    std::vector<int16_t> chunk;
    bool finish = false;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, stop, [this] { return !queue_.empty() || finishing_; });
      if (stop.stop_requested()) return;
      if (!queue_.empty()) {
        chunk = std::move(queue_.front());
        queue_.pop_front();
        queued_samples_ -= chunk.size();
      } else {
        finish = true;
      }
    }
    const double start = ThreadCpuSeconds();
    const Status s = finish ? rec_->Finish(made) : rec_->Feed(chunk, made);
    {
      std::lock_guard<std::mutex> lock(mu_);
      cpu_ += ThreadCpuSeconds() - start;
      sure_.insert(sure_.end(), made.begin(), made.end());
      if (!s.ok() && error_.ok()) error_ = s;
      if (finish) ended_ = true;
    }
    const bool news = !made.empty() || !s.ok() || finish;
    made.clear();
    if (news) wake_();
    if (finish) return;
  }
}

}  // namespace facespace::http
