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

#include "facespace/api/request.h"
#include "facespace/core/rig.h"
#include "facespace/core/variants.h"

namespace facespace::batch {

struct Plan {
  const Rig* rig = nullptr;
  api::BatchRequest request;
  SampleSpec sample;                          // When request.sampled.
  std::vector<std::vector<float>> weights;    // Explicit variants, resolved.
  size_t total = 0;
  std::string spec_json;                      // batch.json: {"request": ..., "rig": ..., "rig_version": ...}
};

// Parses and resolves a batch request (the POST body schema) against a rig. `rig_version`
// identifies the rig's content, so a rerun against another rig is refused.
Result<Plan> MakePlan(const Rig& rig, const std::string& rig_version, std::string_view request_json);

std::string VariantId(const Plan& plan, size_t index);
std::string VariantFile(const Plan& plan, size_t index);  // id + "." + format extension.
void VariantWeights(const Plan& plan, size_t index, std::span<float> out);

struct Progress {
  size_t done = 0;      // Variants of this shard complete, including those skipped.
  size_t skipped = 0;   // Complete before this run started.
  size_t total = 0;     // Variants of this shard.
  double seconds = 0;   // Since the run started.
};

struct RunOptions {
  std::string dir;
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

Result<Summary> Run(const Plan& plan, const RunOptions& options);

// Lowercase hex SHA-256 of bytes.
std::string Sha256Hex(std::span<const unsigned char> bytes);

}  // namespace facespace::batch
