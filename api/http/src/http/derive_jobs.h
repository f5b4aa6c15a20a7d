// Derive jobs (POST /v1/rigs/{id}/derive): long work run one at a time on a thread of their own,
// beside the batch queue. They are kept in memory: a restart forgets a queued or running one (its
// client sees 404 and submits again); what a finished one made is a rig in the store, written
// durably by it. Each has a stop of its own (DELETE /v1/jobs/{id}, the server's stop).
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <stop_token>
#include <string>
#include <thread>
#include <vector>

#include "facespace/batch/queue.h"
#include "facespace/engine/status.h"

namespace facespace::http {

struct DeriveJobInfo {
  std::string id;  // As a batch job's: 32 lowercase hex digits.
  std::string rig, from, as;
  std::string created;
  batch::JobState state = batch::JobState::kQueued;
  size_t total = 0;       // Shapes to derive (and visemes to bake).
  double progress = 0;    // Fraction done.
  std::string step;       // What it does now ("register", "transfer", ...).
  Status error;           // A failed one's.
  nlohmann::json result;  // A finished one's: the rig written and its derivation.
};

// The work of a job: its stop, and where to say how far it is (a fraction, the step).
using DeriveWork = std::function<Result<nlohmann::json>(
    std::stop_token, const std::function<void(double, const char*)>& progress)>;

class DeriveJobs {
 public:
  static constexpr size_t kMaxUnfinished = 2;  // Queued + running; past it 429.
  static constexpr size_t kKeptFinished = 32;  // Finished ones whose status is kept, newest.

  DeriveJobs() = default;
  ~DeriveJobs();  // Stops the running job and joins its thread.
  DeriveJobs(const DeriveJobs&) = delete;
  DeriveJobs& operator=(const DeriveJobs&) = delete;

  // Queues `work` as the job `info` says (its id and created set here). ResourceExhausted (reason
  // job-queue-full) when kMaxUnfinished are queued or running.
  Result<DeriveJobInfo> Submit(DeriveJobInfo info, DeriveWork work);
  std::optional<DeriveJobInfo> Get(const std::string& id) const;
  std::vector<DeriveJobInfo> List() const;  // Newest first.
  // Forgets the job, stopping it if it runs (what it would write is not written). False when
  // unknown.
  bool Remove(const std::string& id);

 private:
  struct Job {
    DeriveJobInfo info;
    DeriveWork work;
    std::stop_source stop;
  };
  void Loop(const std::stop_token& stop);

  mutable std::mutex mu_;
  std::condition_variable_any cv_;
  std::deque<std::shared_ptr<Job>> jobs_;  // Oldest first.
  std::jthread worker_;                    // Started by the first Submit; last, so it goes first.
};

}  // namespace facespace::http
