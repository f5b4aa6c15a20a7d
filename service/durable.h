// Durable file replacement, shared by the rig store, batch jobs and the batch CLI.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "facespace/core/status.h"

namespace facespace {

// Writes `data` to `dir/name` so that a crash leaves either the old file or the new one, never
// a mixture: written under `tmp_name` in the same folder (replacing a stale one), fsynced,
// renamed over `name`, and (with `sync_dir`) the folder fsynced, so the new name survives a
// crash too; a writer of many files may sync the folder once at the end. On failure the temporary file is removed and the
// old `name` is untouched. A full disk, quota or file size limit (ENOSPC, EDQUOT, EFBIG) is
// kStorageFull, so callers can say "retry when space is freed"; anything else kInternal.
// Messages name `what` ("the rig", "'v0001.glb'") and the system's reason.
Status WriteFileDurably(const std::filesystem::path& dir, const std::string& name, std::string_view data,
                        const std::string& tmp_name, const std::string& what, bool sync_dir = true);

// fsync of a folder, so that renames and new names in it survive a crash.
void SyncDir(const std::filesystem::path& dir);

}  // namespace facespace
