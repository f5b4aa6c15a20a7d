// Batch variant generation: many points of the face space written as files, one per
// variant, with a manifest. Shared by `facespace batch` and the service's batch jobs.
//
// Output folder:
//   batch.json       the request and the rig's version; a rerun must match it
//   <id>.<ext>       one file per variant, written to a temporary name then renamed, so a
//                    file with its final name is always complete
//   manifest.jsonl   one line per variant: {"index", "id", "file", "bytes", "sha256",
//                    "weights" (non-zero, by name), "warnings"}, sorted by index when a run ends
//   sheet.png        a contact sheet of the first variants
// Rerunning skips the variants whose file is in the manifest with its size: resume.
//
// Shards (a scheduler's array tasks) share one folder: variant k belongs to shard k % N, each
// shard writes its own manifest.shard-I-of-N.jsonl (I 1-based) and, when all its variants are
// there, shard-I-of-N.json; no sheet. Merge checks that every shard finished and writes
// manifest.jsonl and sheet.png, byte-identical to a one-process run, and removes the shard files.
// A run holds a lock on its manifest (.fs-lock-<manifest>), so the same shard never runs twice at
// once.
#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/batch/plan.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/variants.h"

namespace facespace::batch {

// Files a worker writes before it syncs them as one group and reports progress (group commit).
inline constexpr size_t kGroupFiles = 32;

struct Progress {
  size_t done = 0;     // Variants of this shard complete, including those skipped.
  size_t skipped = 0;  // Complete before this run started.
  size_t total = 0;    // Variants of this shard.
  double seconds = 0;  // Since the run started.
};

struct RunOptions {
  std::string dir;
  const evaluator::Evaluator* evaluator =
      nullptr;   // Makes every file and the contact sheet; required.
  int jobs = 0;  // Worker threads; 0 = every core.
  // Who makes the variants. kProcesses: a maker process for each worker (maker.h), forked when the
  // run starts, from a one-thread process only (the CLI; never the service, whose threads a fork
  // would lose; threads when the process already runs others). kAuto: makers for a run of 1,000
  // renders or more (each maker starts its own llvmpipe, about 0.3 s, so a smaller run is quicker
  // with threads).
  enum class Makers { kThreads, kAuto, kProcesses };
  Makers makers = Makers::kThreads;
  // Once the makers are forked (`makers`: whether there are any), before any worker thread starts:
  // the place to open render.h's image module, which the workers need only when they make the
  // variants.
  std::function<void(bool makers)> before_threads;
  size_t shard = 0, shards = 1;  // Variant k belongs to shard k % shards.
  size_t sheet_cells = 16;       // Contact sheet of the first variants; 0 = none.
  std::vector<std::string>
      rig_files;  // Recorded by a shard (absolute paths), so merge can find the rig.
  std::function<void(const Progress&)>
      progress;  // From the calling thread, ~5 times a second and at the end.
  const std::atomic<bool>* cancel =
      nullptr;  // Set to stop: variants in flight finish, none is half-written.
};

struct Summary {
  size_t generated = 0, skipped = 0, total = 0;
  double seconds = 0;
  bool cancelled = false;
  // Of the variants generated: how many carry each warning code, and the largest sum of weights.
  std::map<std::string, size_t> warnings;
  double max_sum = 0;
  size_t processes = 0;  // Maker processes the run used; 0: its worker threads made the variants.
};

// Writes the variants of `plan` (MakeBatchPlan) that this shard lacks, then the manifest and the
// sheet.
Result<Summary> Run(const BatchPlan& plan, const RunOptions& options);

// What a shard recorded when it finished (shard-I-of-N.json).
struct ShardRecord {
  size_t shard = 0, shards = 1;  // 0-based shard.
  size_t variants = 0;
  size_t sheet_cells = 16;
  std::vector<std::string> rig_files;
};

// The shards of a sharded run in `dir`: how many, and the records of those that finished. An error
// when the folder holds no shard files or shards of different counts.
struct ShardsFound {
  size_t shards = 0;
  std::vector<ShardRecord> finished;  // By shard.
};
Result<ShardsFound> FindShards(const std::string& dir);

struct MergeOptions {
  std::string dir;
  const evaluator::Evaluator* evaluator = nullptr;  // Required.
  size_t sheet_cells = 16;
  bool verify = true;  // Hash every variant file against its manifest line.
};
struct MergeSummary {
  size_t shards = 0, variants = 0;
  double seconds = 0;
};
// Checks that every shard finished and every variant is there (its size, and its SHA-256 when
// verify), then writes manifest.jsonl and sheet.png as a one-process run would and removes the
// shard manifests and records. Nothing is removed when a check fails.
Result<MergeSummary> Merge(const BatchPlan& plan, const MergeOptions& options);

// The shard a scheduler gave this process: Slurm job arrays (SLURM_ARRAY_TASK_ID with
// SLURM_ARRAY_TASK_COUNT, or _MIN/_MAX/_STEP; with `count`, the task id is the shard, so part of
// an array can be submitted again), Kubernetes Indexed Jobs (JOB_COMPLETION_INDEX with `count`).
// `env` is getenv or a test's.
struct SchedulerShard {
  size_t shard = 0, shards = 1;  // 0-based shard.
  std::string source;  // "SLURM_ARRAY_TASK_ID=1 of SLURM_ARRAY_TASK_COUNT=4", for the log.
};
Result<SchedulerShard> ShardFromScheduler(const std::function<const char*(const char*)>& env,
                                          size_t count);

// Lowercase hex SHA-256 of the pieces one after the other.
std::string Sha256Hex(std::span<const std::string_view> pieces);

}  // namespace facespace::batch
