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
// DIR/<job>/out/         the batch folder (run.h): variants, manifest, sheet
// Each instance runs one job at a time: the oldest unclaimed one, looked for when a job is
// submitted to it and every poll interval. A job resumes where it stopped (the batch runner skips
// complete variants) if its rig is in the store with the same version; otherwise it is "lost",
// with the reason. What Get and List say is read from the folder, so every instance says the same.
#pragma once

#include <atomic>
#include <condition_variable>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "facespace/batch/plan.h"
#include "facespace/engine/enum_table.h"
#include "facespace/evaluator/store.h"

namespace facespace::batch {

// Where a job is: a closed set, named in one table (its JSON and state.json spellings).
enum class JobState { kQueued, kRunning, kDone, kFailed, kCancelled, kLost };
inline constexpr EnumName<JobState> kJobStates[] = {
    {JobState::kQueued, "queued"}, {JobState::kRunning, "running"},     {JobState::kDone, "done"},
    {JobState::kFailed, "failed"}, {JobState::kCancelled, "cancelled"}, {JobState::kLost, "lost"}};
inline const char* Name(JobState s) { return EnumEntry(kJobStates, s).name; }
// Queued or running: not finished.
inline bool Unfinished(JobState s) { return s == JobState::kQueued || s == JobState::kRunning; }

// A job as the batch routes show it.
struct JobInfo {
  std::string id;  // 32 lowercase hex digits: unguessable, so knowing it is the access.
  std::string rig;
  JobState state = JobState::kQueued;
  std::string error;  // Why it failed or was lost.
  std::string
      format;  // Of every variant file (a labelled sample's picture: png unless the request said).
  std::vector<std::string>
      labels;           // A dataset's labels beside each picture (none for plain variants).
  std::string archive;  // "folder" or "tar" (WebDataset shards).
  std::string created;  // RFC 3339, UTC.
  size_t total = 0;     // Variants.
  size_t done = 0;      // Variants whose file is complete.
  double seconds = 0;   // Running time so far (this run of the service).
  double rate = 0;      // Variants per second while running.
};

// Status::reason of a refusal because the queue is full (HTTP 429 with Retry-After).
inline constexpr char kJobQueueFull[] = "job-queue-full";

// What the batch routes need from a job queue (FileJobQueue below; the API tests run without one).
class JobQueue {
 public:
  virtual ~JobQueue() = default;
  // Queues a batch planned against its rig (MakeBatchPlan of `body`; the body is kept so that a
  // restart plans it again). InvalidArgument (with a field error) for more variants than the
  // server allows; ResourceExhausted with reason job-queue-full when the queue is full, with
  // *retry_after the seconds to wait.
  virtual Result<JobInfo> Submit(std::shared_ptr<const BatchPlan> plan, std::string_view body,
                                 int* retry_after) = 0;
  virtual std::optional<JobInfo> Get(const std::string& id) const = 0;
  virtual std::vector<JobInfo> List() const = 0;  // Newest first.
  // Cancels a job (variants in flight finish) and deletes its files. NotFound when absent.
  virtual Status Remove(const std::string& id) = 0;
  // The folder holding the job's files (manifest.jsonl, variants, sheet.png).
  virtual std::string Folder(const std::string& id) const = 0;
};

// True for a job id: 32 lowercase hex digits.
bool IsValidJobId(const std::string& id);
// A new job id (OpenSSL's random bytes), and the time now as a job's `created` says it (RFC 3339,
// UTC).
std::string NewJobId();
std::string NowRfc3339();

struct JobLimits {
  size_t max_jobs = 4;       // Queued + running; past it Submit says ResourceExhausted (429).
  size_t max_batch = 10000;  // Variants per job.
  int threads = 0;           // Worker threads of the running job; 0 = every core.
  // Bytes the jobs folder's disk keeps free (--keep-free-mb): a job that would pass it is refused
  // (507), a running one that reaches it stops, failed, with what it made kept. 0: 5% of the disk,
  // at most 1 GiB.
  size_t keep_free = 0;
};

class FileJobQueue : public JobQueue {
 public:
  // `poll_seconds`: how often the folder is looked at for jobs other instances submitted or left;
  // `refresh_store`: picks up the store's changes on disk (a rig another instance just uploaded).
  FileJobQueue(std::string dir, evaluator::RigStore& store, const evaluator::Evaluator& evaluator,
               JobLimits limits, double poll_seconds = 1.0,
               std::function<void()> refresh_store = {});
  ~FileJobQueue() override;  // Stops: the running job halts between variants; this or another
                             // instance resumes it.

  // Reads the jobs in the folder and starts the runner. Returns the unfinished jobs (to be resumed
  // here or by another instance).
  Result<size_t> Start();

  Result<JobInfo> Submit(std::shared_ptr<const BatchPlan> plan, std::string_view body,
                         int* retry_after) override;
  std::optional<JobInfo> Get(const std::string& id) const override;
  std::vector<JobInfo> List() const override;
  Status Remove(const std::string& id) override;
  std::string Folder(const std::string& id) const override;

 private:
  struct Job {
    JobInfo info;
    std::string rig_version;
    std::shared_ptr<const BatchPlan>
        plan;  // Set when submitted here; else planned again from `body`.
    std::string body;
    std::atomic<bool> cancel{false};
    bool removed = false;
    double variant_bytes =
        0;  // About a variant's file: job.json's estimate, measured once the job runs.
    std::string out_of_room;  // Why the running job stopped for the disk (empty: it did not).
  };
  // The job in DIR/id as the folder says (null when it is not a job, or was deleted).
  std::shared_ptr<Job> Load(const std::string& id) const;
  // The jobs in the folder, oldest first (mu_ not held). The one running here keeps its live
  // figures.
  std::vector<std::shared_ptr<Job>> Scan() const;
  // The job this instance runs, if `id`, with its live figures (mu_ not held).
  std::shared_ptr<Job> RunningHere(const std::string& id) const;
  // Claims and runs the oldest job nobody runs, if any. True when one ran.
  bool RunNext();
  void Run(const std::shared_ptr<Job>& job, const std::shared_ptr<const evaluator::StoredRig>& rig,
           int claim);
  void Finish(Job& job, JobState state, const std::string& error);
  // The job's rig, when the store has it at the job's version (after a refresh, if asked).
  std::shared_ptr<const evaluator::StoredRig> RigFor(const Job& job, bool refresh) const;
  // Whether `need` more bytes fit beside what the unfinished jobs (`jobs`) have still to write, the
  // margin kept.
  Status CheckRoom(double need, size_t variants, const std::vector<std::shared_ptr<Job>>& jobs,
                   bool sampled) const;
  double KeepFree(double disk_bytes) const;
  void MarkLost(Job& job);

  std::string dir_;
  evaluator::RigStore& store_;
  const evaluator::Evaluator& evaluator_;
  JobLimits limits_;
  double poll_seconds_;
  std::function<void()> refresh_store_;
  std::string instance_;  // host:pid, written in the claim.
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::shared_ptr<Job> running_;
  std::map<std::string, std::shared_ptr<const BatchPlan>>
      submitted_;  // Plans of jobs submitted here, not yet run.
  bool stopping_ = false, wake_ = false;
  std::thread runner_;
};

}  // namespace facespace::batch
