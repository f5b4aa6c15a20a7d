// Batch jobs of the service: a bounded FIFO queue kept on disk, so that jobs survive a restart,
// and shared by every instance whose --jobs-dir is the same folder (a shared filesystem).
//
// DIR/<job>/job.json     the request, the rig id and version, the creation time (written
//                        before the job is accepted)
// DIR/<job>/.claim       locked (flock) by the instance running the job, for as long as it runs;
//                        says which (host:pid) and, each second, its rate (for the others' ETA).
//                        The lock goes with the process, so a job whose instance died is
//                        claimed, and resumed, by another.
// DIR/<job>/cancel       a delete through an instance that does not run the job: the one that
//                        does stops it and removes the folder
// DIR/<job>/state.json   written when the job ends: done, failed, cancelled or lost
// DIR/<job>/out/         the batch folder (service/batch.h): variants, manifest, sheet
// Each instance runs one job at a time: the oldest unclaimed one, looked for when a job is
// submitted to it and every poll interval. A job resumes where it stopped (the batch runner skips
// complete variants) if its rig is in the store with the same version; otherwise it is "lost",
// with the reason. What Get and List say is read from the folder, so every instance says the same.
#pragma once

#include <condition_variable>
#include <functional>
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
  // `poll_seconds`: how often the folder is looked at for jobs other instances submitted or left;
  // `refresh_store`: picks up the store's changes on disk (a rig another instance just uploaded).
  FileJobQueue(std::string dir, api::RigStore& store, const render::Renderer& renderer, JobLimits limits,
               double poll_seconds = 1.0, std::function<void()> refresh_store = {});
  ~FileJobQueue() override;  // Stops: the running job halts between variants; this or another instance resumes it.

  // Reads the jobs in the folder and starts the runner. Returns the unfinished jobs (to be resumed
  // here or by another instance).
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
    std::string rig_version;
    std::shared_ptr<const api::BatchPlan> plan;  // Set when submitted here; else planned again from `body`.
    std::string body;
    std::atomic<bool> cancel{false};
    bool removed = false;
  };
  // The job in DIR/id as the folder says (null when it is not a job, or was deleted).
  std::shared_ptr<Job> Load(const std::string& id) const;
  // The jobs in the folder, oldest first (mu_ not held). The one running here keeps its live figures.
  std::vector<std::shared_ptr<Job>> Scan() const;
  // The job this instance runs, if `id`, with its live figures (mu_ not held).
  std::shared_ptr<Job> RunningHere(const std::string& id) const;
  // Claims and runs the oldest job nobody runs, if any. True when one ran.
  bool RunNext();
  void Run(const std::shared_ptr<Job>& job, const std::shared_ptr<const api::StoredRig>& rig, int claim);
  void Finish(Job& job, const std::string& state, const std::string& error);
  // The job's rig, when the store has it at the job's version (after a refresh, if asked).
  std::shared_ptr<const api::StoredRig> RigFor(const Job& job, bool refresh) const;
  Status CheckRoom(const api::StoredRig& rig, const api::BatchPlan& plan) const;
  void MarkLost(Job& job);

  std::string dir_;
  api::RigStore& store_;
  const render::Renderer& renderer_;
  JobLimits limits_;
  double poll_seconds_;
  std::function<void()> refresh_store_;
  std::string instance_;  // host:pid, written in the claim.
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::shared_ptr<Job> running_;
  std::map<std::string, std::shared_ptr<const api::BatchPlan>> submitted_;  // Plans of jobs submitted here, not yet run.
  bool stopping_ = false, wake_ = false;
  std::thread runner_;
};

}  // namespace facespace
