// Durable file replacement (a crash leaves the old file or the new, never a mixture), for whatever
// keeps files: the rig store, batch jobs and the batch CLI. POSIX alone.
#pragma once

#include <filesystem>
#include <span>
#include <string>
#include <string_view>

#include "facespace/engine/status.h"

namespace facespace::files {

// Writes `data` to `dir/name` so that a crash leaves either the old file or the new one, never
// a mixture: written under `tmp_name` in the same folder (replacing a stale one), fsynced,
// renamed over `name`, and (with `sync_dir`) the folder fsynced, so the new name survives a
// crash too; a writer of many files may sync the folder once at the end. On failure the temporary
// file is removed and the old `name` is untouched. A full disk, quota or file size limit (ENOSPC,
// EDQUOT, EFBIG) is kStorageFull, so callers can say "retry when space is freed"; anything else
// kInternal. Messages name `what` ("the rig", "'v0001.glb'") and the system's reason.
Status WriteFileDurably(const std::filesystem::path& dir, const std::string& name,
                        std::string_view data, const std::string& tmp_name, const std::string& what,
                        bool sync_dir = true);

// The two halves of WriteFileDurably, for a writer of many files who flushes them in groups
// (write many, then flush each: the disk sees one stream of writes instead of one wait per file).
// WriteTemporary writes `pieces` one after the other to dir/tmp_name (replacing a stale one),
// starts the write-back and returns the open file; Publish flushes it (fdatasync), closes it and
// renames it over `name`; Discard closes and removes it. On failure nothing is left behind.
Result<int> WriteTemporary(const std::filesystem::path& dir, const std::string& tmp_name,
                           std::span<const std::string_view> pieces, const std::string& what);
Status Publish(int fd, const std::filesystem::path& dir, const std::string& tmp_name,
               const std::string& name, const std::string& what);
void Discard(int fd, const std::filesystem::path& dir, const std::string& tmp_name);

// Group commit: the temporaries of `pending` (each written by WriteTemporary in `dir`) made durable
// together and published: one syncfs of the folder's filesystem for all their data (each
// fdatasync'd instead where syncfs fails), then each renamed over its name, then the folder synced
// once, so their names survive a crash too. A file whose flush or rename fails is removed, and so
// is every one after it; the count published (a prefix of `pending`) is returned with the first
// failure.
struct PendingFile {
  int fd;
  std::string tmp_name, name, what;
};
struct GroupResult {
  size_t published = 0;
  Status status;
};
GroupResult PublishGroup(const std::filesystem::path& dir, std::span<PendingFile> pending);
// Flushes a temporary file (fdatasync) without publishing it, so that a later Publish of it cannot
// fail for space; on failure the temporary file is discarded.
Status Flush(int fd, const std::filesystem::path& dir, const std::string& tmp_name,
             const std::string& what);

// What a failed write says: kStorageFull for a full disk, quota or file size limit (ENOSPC, EDQUOT,
// EFBIG), else kInternal; "DOING: the system's reason".
Status WriteError(const std::string& doing, int err);

// All of `data` written to `fd`, through short writes and EINTR: 0, or the errno that stopped it
// (ENOSPC for a write that took nothing).
int WriteAll(int fd, std::string_view data);

// fsync of a folder, so that renames and new names in it survive a crash.
void SyncDir(const std::filesystem::path& dir);

// Removes a temporary file left by a crashed writer: one no process holds (WriteTemporary locks
// its file until it is published) and nobody wrote for 10 s (a writer between creating its file
// and locking it), so a writer sharing the folder is never cut short. True when it was removed.
bool RemoveAbandoned(const std::filesystem::path& path);

}  // namespace facespace::files
