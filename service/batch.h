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
#pragma once

#include <atomic>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/api/pipeline.h"
#include "facespace/core/rig.h"
#include "facespace/core/variants.h"

namespace facespace::batch {

struct Progress {
  size_t done = 0;      // Variants of this shard complete, including those skipped.
  size_t skipped = 0;   // Complete before this run started.
  size_t total = 0;     // Variants of this shard.
  double seconds = 0;   // Since the run started.
};

struct RunOptions {
  std::string dir;
  const render::Renderer* renderer = nullptr;  // For image formats and the contact sheet; required.
  int jobs = 0;                      // Worker threads; 0 = every core.
  size_t shard = 0, shards = 1;      // Variant k belongs to shard k % shards.
  size_t sheet_cells = 16;           // Contact sheet of the first variants; 0 = none.
  std::function<void(const Progress&)> progress;  // From the calling thread, ~5 times a second and at the end.
  const std::atomic<bool>* cancel = nullptr;      // Set to stop: variants in flight finish, none is half-written.
};

struct Summary {
  size_t generated = 0, skipped = 0, total = 0;
  double seconds = 0;
  bool cancelled = false;
};

// Writes the variants of `plan` (api::MakeBatchPlan) that this shard lacks, then the manifest and the sheet.
Result<Summary> Run(const api::BatchPlan& plan, const RunOptions& options);

// Lowercase hex SHA-256 of the pieces one after the other.
std::string Sha256Hex(std::span<const std::string_view> pieces);

}  // namespace facespace::batch
