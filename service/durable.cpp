#include "durable.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace facespace {

namespace {

Status WriteError(const std::string& doing, int e) {
  const bool full = e == ENOSPC || e == EDQUOT || e == EFBIG;
  return Status{full ? StatusCode::kStorageFull : StatusCode::kInternal, doing + ": " + std::strerror(e), {}, {}};
}

}  // namespace

void SyncDir(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}

Status WriteFileDurably(const std::filesystem::path& dir, const std::string& name, std::string_view data,
                        const std::string& tmp_name, const std::string& what, bool sync_dir) {
  const std::string tmp = (dir / tmp_name).string();
  ::unlink(tmp.c_str());  // A temporary file left by a crash.
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return WriteError("cannot create " + what, errno);
  size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::write(fd, data.data() + done, data.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int e = n < 0 ? errno : ENOSPC;
      ::close(fd);
      ::unlink(tmp.c_str());
      return WriteError("cannot write " + what, e);
    }
    done += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0) {
    const int e = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    return WriteError("cannot flush " + what + " to disk", e);
  }
  if (::close(fd) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    return WriteError("cannot flush " + what + " to disk", e);
  }
  if (::rename(tmp.c_str(), (dir / name).c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    return WriteError("cannot publish " + what, e);
  }
  if (sync_dir) SyncDir(dir);
  return Status::Ok();
}

}  // namespace facespace
