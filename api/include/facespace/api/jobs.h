// What the batch routes need from a job queue. The service implements it (service/jobs).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/api/pipeline.h"
#include "facespace/api/store.h"
#include "facespace/core/status.h"

namespace facespace::api {

struct JobInfo {
  std::string id;          // 32 lowercase hex digits: unguessable, so knowing it is the access.
  std::string rig;
  std::string state;       // "queued", "running", "done", "failed", "cancelled", "lost"
  std::string error;       // Why it failed or was lost.
  std::string format;      // Of every variant file.
  std::string created;     // RFC 3339, UTC.
  size_t total = 0;        // Variants.
  size_t done = 0;         // Variants whose file is complete.
  double seconds = 0;      // Running time so far (this run of the service).
  double rate = 0;         // Variants per second while running.
};

// Status::reason of a refusal because the queue is full (HTTP 429 with Retry-After).
inline constexpr char kJobQueueFull[] = "job-queue-full";

class JobQueue {
 public:
  virtual ~JobQueue() = default;
  // Queues a batch planned against `rig` (MakeBatchPlan of `body`; the body is kept so that a
  // restart plans it again). InvalidArgument (with a field error) for more variants than the
  // server allows; ResourceExhausted with reason job-queue-full when the queue is full, with
  // *retry_after the seconds to wait.
  virtual Result<JobInfo> Submit(std::shared_ptr<const StoredRig> rig, std::shared_ptr<const BatchPlan> plan,
                                 std::string_view body, int* retry_after) = 0;
  virtual std::optional<JobInfo> Get(const std::string& id) const = 0;
  virtual std::vector<JobInfo> List() const = 0;  // Newest first.
  // Cancels a job (variants in flight finish) and deletes its files. NotFound when absent.
  virtual Status Remove(const std::string& id) = 0;
  // The folder holding the job's files (manifest.jsonl, variants, sheet.png).
  virtual std::string Folder(const std::string& id) const = 0;
};

// True for a job id: 32 lowercase hex digits.
bool IsValidJobId(const std::string& id);

}  // namespace facespace::api
