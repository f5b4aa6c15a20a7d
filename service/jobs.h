// Batch jobs of the service: a bounded FIFO queue run by one thread (each job on its own
// worker threads), kept on disk so that jobs survive a restart.
//
// DIR/<job>/job.json     the request, the rig id and version, the creation time (written
//                        before the job is accepted)
// DIR/<job>/state.json   written when the job ends: done, failed, cancelled or lost
// DIR/<job>/out/         the batch folder (service/batch.h): variants, manifest, sheet
// At start, a job without state.json resumes where it stopped (the batch runner skips
// complete variants) if its rig is still there with the same version; otherwise it is
// reported "lost" with the reason.
#pragma once

#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <thread>

#include "facespace/api/jobs.h"

namespace facespace {

struct JobLimits {
  size_t max_jobs = 4;        // Queued + running; past it Submit says ResourceExhausted (429).
  size_t max_batch = 10000;   // Variants per job.
  int threads = 0;            // Worker threads of the running job; 0 = every core.
};

class FileJobQueue : public api::JobQueue {
 public:
  FileJobQueue(std::string dir, api::RigStore& store, const render::Renderer& renderer, JobLimits limits);
  ~FileJobQueue() override;  // Stops: the running job halts between variants and resumes at the next start.

  // Reads the jobs of an earlier run and starts the runner. Returns the jobs resumed.
  Result<size_t> Start();

  Result<api::JobInfo> Submit(std::shared_ptr<const api::StoredRig> rig, std::shared_ptr<const api::BatchPlan> plan,
                              std::string_view body, int* retry_after) override;
  std::optional<api::JobInfo> Get(const std::string& id) const override;
  std::vector<api::JobInfo> List() const override;
  Status Remove(const std::string& id) override;
  std::string Folder(const std::string& id) const override;

 private:
  struct Job {
    api::JobInfo info;
    std::shared_ptr<const api::StoredRig> rig;
    std::shared_ptr<const api::BatchPlan> plan;  // Null for a job resumed at start: planned again from `body`.
    std::string body;
    std::atomic<bool> cancel{false};
    bool removed = false;
  };
  void RunLoop();
  void Finish(Job& job, const std::string& state, const std::string& error);

  std::string dir_;
  api::RigStore& store_;
  const render::Renderer& renderer_;
  JobLimits limits_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::map<std::string, std::shared_ptr<Job>> jobs_;
  std::deque<std::shared_ptr<Job>> queue_;
  std::shared_ptr<Job> running_;
  bool stopping_ = false;
  std::thread runner_;
};

}  // namespace facespace
