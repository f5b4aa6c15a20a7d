// What a batch run (run.cpp) and a merge (merge.cpp) share about the batch folder: the names in it,
// the lock a run holds, the manifest lines that vouch for files, the contact sheet, and the tar
// shards of an archived batch (tar.cpp). Internal to facespace_batch.
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <string_view>

#include "facespace/batch/plan.h"

namespace facespace::batch {

namespace fs = std::filesystem;

inline constexpr char kTmpPrefix[] = ".fs-tmp-";
inline constexpr char kLockPrefix[] = ".fs-lock-";
inline constexpr char kManifest[] = "manifest.jsonl";

// dir/name, durably; the folder itself is synced once at the end of the run. `writer` keeps the
// temporary names of processes writing the same file (shards writing batch.json) apart.
Status WriteInBatch(const fs::path& dir, const std::string& name, std::string_view data,
                    const std::string& writer = "");

std::string ManifestName(size_t shard,
                         size_t shards);  // manifest.jsonl, or manifest.shard-I-of-N.jsonl
std::string RecordName(size_t shard, size_t shards);  // shard-I-of-N.json
// "PREFIX" + "shard-I-of-N" + suffix -> {I-1, N}; false for any other name.
bool ParseShardName(std::string_view name, std::string_view prefix, std::string_view suffix,
                    size_t* shard, size_t* shards);

// An exclusive lock held while a run writes its manifest: the same shard never runs twice at
// once (two array tasks given the same index, a rerun while the first still runs).
class RunLock {
 public:
  RunLock() = default;
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;
  ~RunLock();
  bool Take(const fs::path& path);  // False when another process holds it.

 private:
  std::string path_;
  int fd_ = -1;
};
// True when a process holds the lock at `path` (the file may be gone: nobody).
bool Locked(const fs::path& path);

// The manifest lines of `dir` (manifest.jsonl and every shard's) whose variant `keep(index)` and
// whose files are there with their sizes (in the folder, or in a tar shard or its part), by index.
// A torn line (a kill mid-write) or a line for a missing file is dropped.
std::map<size_t, std::string> ReadManifests(const fs::path& dir, const BatchPlan& plan,
                                            const std::function<bool(size_t)>& keep);
std::string JoinLines(const std::map<size_t, std::string>& lines);

// The contact sheet of the first `cells` variants, as a one-process run writes it.
Status WriteSheet(const BatchPlan& plan, const fs::path& dir, size_t cells,
                  const evaluator::Evaluator& evaluator);

// ---- tar shards (tar.cpp) ----

// The tar shard holding sample `index`: shard-000000.tar holds the first `shard_samples`, and so
// on.
size_t TarShardOf(const BatchPlan& plan, size_t index);
std::string TarShardName(size_t shard);
// The shard being written: ".fs-part-shard-000000.tar", renamed to its name once whole.
std::string TarPartName(size_t shard);

// One member of a tar (POSIX ustar): its 512-byte header, `pieces` one after the other, zeros to a
// whole block. Deterministic: mode 0644, owner 0, time 0. Names over 100 bytes are refused.
Status AppendTarMember(std::string& out, const std::string& name,
                       std::array<std::string_view, 2> pieces);
// The end of an archive: two blocks of zeros.
inline constexpr size_t kTarEnd = 1024;

// The part file of a tar shard, appended to in order and synced in groups (group commit).
class TarPart {
 public:
  TarPart() = default;
  TarPart(const TarPart&) = delete;
  TarPart& operator=(const TarPart&) = delete;
  ~TarPart();
  // Opens shard `shard`'s part in `dir`, cut to `length` (what the manifest vouches for; a crash
  // may have left more).
  Status Open(const fs::path& dir, size_t shard, uint64_t length);
  Status Append(std::string_view bytes);  // At the end.
  Status Sync();                          // fdatasync: what was appended survives a crash.
  // The archive's end written and synced, the part renamed to the shard's name, the folder synced.
  Status Finish();
  bool open() const { return fd_ >= 0; }
  size_t shard() const { return shard_; }
  uint64_t length() const { return length_; }

 private:
  fs::path dir_;
  size_t shard_ = 0;
  uint64_t length_ = 0;
  int fd_ = -1;
};

}  // namespace facespace::batch
