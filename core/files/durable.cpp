#include "facespace/files/durable.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>

namespace facespace::files {

Status WriteError(const std::string& doing, int e) {
  const bool full = e == ENOSPC || e == EDQUOT || e == EFBIG;
  return Status{full ? StatusCode::kStorageFull : StatusCode::kInternal,
                doing + ": " + std::strerror(e),
                {},
                {},
                0};
}

namespace {

// Closes and removes a temporary file after `e`, and says what failed.
Status Abandon(int fd, const std::string& tmp, const std::string& doing, int e) {
  if (fd >= 0) ::close(fd);
  ::unlink(tmp.c_str());
  return WriteError(doing, e);
}

}  // namespace

void SyncDir(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}

bool RemoveAbandoned(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  // Unlocked, and untouched for a while: a writer locks its file just after creating it, so a
  // fresh unlocked one may be a writer between the two (seen: a shard starting beside another
  // removed the temporary the other had just created, and the other's rename then failed).
  struct stat st {};
  const bool stale = ::fstat(fd, &st) == 0 && std::time(nullptr) - st.st_mtime > 10;
  const bool abandoned = stale && ::flock(fd, LOCK_EX | LOCK_NB) == 0;
  if (abandoned) ::unlink(path.c_str());
  ::close(fd);
  return abandoned;
}

int WriteAll(int fd, std::string_view data) {
  while (!data.empty()) {
    const ssize_t n = ::write(fd, data.data(), data.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return n < 0 ? errno : ENOSPC;
    data.remove_prefix(static_cast<size_t>(n));
  }
  return 0;
}

Result<int> WriteTemporary(const std::filesystem::path& dir, const std::string& tmp_name,
                           std::span<const std::string_view> pieces, const std::string& what) {
  const std::string tmp = (dir / tmp_name).string();
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0 && errno == EEXIST) {
    // A temporary file left by a crash. (Removed only then: an unlink takes the folder's lock, and
    // an unconditional one a file was most of a glb batch's system time, its workers waiting on
    // it.)
    ::unlink(tmp.c_str());
    fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  }
  if (fd < 0) return WriteError("cannot create " + what, errno);
  // Held until the file is published or dropped (the lock goes with the descriptor): another
  // process sharing the folder tells a temporary being written from one left by a crash.
  ::flock(fd, LOCK_EX | LOCK_NB);
  for (std::string_view data : pieces) {
    if (const int e = WriteAll(fd, data); e != 0)
      return Abandon(fd, tmp, "cannot write " + what, e);
  }
  // Start the write-back now, so that the flush in Publish finds it done or under way.
  ::sync_file_range(fd, 0, 0, SYNC_FILE_RANGE_WRITE);
  return fd;
}

Status Publish(int fd, const std::filesystem::path& dir, const std::string& tmp_name,
               const std::string& name, const std::string& what) {
  const std::string tmp = (dir / tmp_name).string();
  if (::fdatasync(fd) != 0) return Abandon(fd, tmp, "cannot flush " + what + " to disk", errno);
  if (::close(fd) != 0) return Abandon(-1, tmp, "cannot flush " + what + " to disk", errno);
  if (::rename(tmp.c_str(), (dir / name).c_str()) != 0)
    return Abandon(-1, tmp, "cannot publish " + what, errno);
  return Status::Ok();
}

Status Flush(int fd, const std::filesystem::path& dir, const std::string& tmp_name,
             const std::string& what) {
  if (::fdatasync(fd) != 0)
    return Abandon(fd, (dir / tmp_name).string(), "cannot flush " + what + " to disk", errno);
  return Status::Ok();
}

void Discard(int fd, const std::filesystem::path& dir, const std::string& tmp_name) {
  ::close(fd);
  ::unlink((dir / tmp_name).c_str());
}

GroupResult PublishGroup(const std::filesystem::path& dir, std::span<PendingFile> pending) {
  GroupResult out;
  if (pending.empty()) return out;
  // One flush for the group's data; a filesystem that cannot say (syncfs failed) gets one a file.
  const bool synced = ::syncfs(pending.front().fd) == 0;
  for (PendingFile& f : pending) {
    const std::string tmp = (dir / f.tmp_name).string();
    if (!out.status.ok()) {
      Discard(f.fd, dir, f.tmp_name);
      continue;
    }
    if (!synced && ::fdatasync(f.fd) != 0) {
      out.status = Abandon(f.fd, tmp, "cannot flush " + f.what + " to disk", errno);
    } else if (::close(f.fd) != 0) {
      out.status = Abandon(-1, tmp, "cannot flush " + f.what + " to disk", errno);
    } else if (::rename(tmp.c_str(), (dir / f.name).c_str()) != 0) {
      out.status = Abandon(-1, tmp, "cannot publish " + f.what, errno);
    } else {
      ++out.published;
    }
  }
  if (out.published) SyncDir(dir);
  return out;
}

Status WriteFileDurably(const std::filesystem::path& dir, const std::string& name,
                        std::string_view data, const std::string& tmp_name, const std::string& what,
                        bool sync_dir) {
  const std::string_view pieces[] = {data};
  auto fd = WriteTemporary(dir, tmp_name, pieces, what);
  if (!fd.ok()) return fd.status();
  if (Status s = Publish(fd.value(), dir, tmp_name, name, what); !s.ok()) return s;
  if (sync_dir) SyncDir(dir);
  return Status::Ok();
}

}  // namespace facespace::files
