// WebDataset tar shards of a batch (folder.h): members written in POSIX ustar, a shard's part
// appended to in order and synced in groups, renamed to its name once whole.
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "facespace/files/durable.h"
#include "folder.h"

namespace facespace::batch {

size_t TarShardOf(const BatchPlan& plan, size_t index) {
  return index / std::max<size_t>(1, plan.request.dataset.shard_samples);
}

std::string TarShardName(size_t shard) {
  char name[32];
  std::snprintf(name, sizeof name, "shard-%06zu.tar", shard);
  return name;
}

std::string TarPartName(size_t shard) { return ".fs-part-" + TarShardName(shard); }

Status AppendTarMember(std::string& out, const std::string& name,
                       std::array<std::string_view, 2> pieces) {
  if (name.empty() || name.size() > 99)
    return InvalidArgument("the tar member name '" + name.substr(0, 120) +
                           "' is longer than 99 bytes");
  const size_t size = pieces[0].size() + pieces[1].size();
  char header[512] = {};
  std::memcpy(header, name.data(), name.size());
  std::memcpy(header + 100, "0000644", 7);                                            // mode
  std::memcpy(header + 108, "0000000", 7);                                            // uid
  std::memcpy(header + 116, "0000000", 7);                                            // gid
  std::snprintf(header + 124, 12, "%011llo", static_cast<unsigned long long>(size));  // size
  std::memcpy(header + 136, "00000000000", 11);  // mtime: 0, for bytes that repeat
  header[156] = '0';                             // a regular file
  std::memcpy(header + 257, "ustar", 6);         // magic, with its NUL
  std::memcpy(header + 263, "00", 2);            // version
  std::memset(header + 148, ' ', 8);
  unsigned sum = 0;
  for (unsigned char c : header) sum += c;
  std::snprintf(header + 148, 8, "%06o", sum);  // Six digits, a NUL, and the space already there.
  out.append(header, sizeof header);
  out.append(pieces[0]).append(pieces[1]);
  out.append((512 - size % 512) % 512, '\0');
  return Status::Ok();
}

TarPart::~TarPart() {
  if (fd_ >= 0) ::close(fd_);
}

Status TarPart::Open(const fs::path& dir, size_t shard, uint64_t length) {
  if (fd_ >= 0) ::close(fd_);
  dir_ = dir;
  shard_ = shard;
  length_ = length;
  const std::string path = (dir / TarPartName(shard)).string();
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) return files::WriteError("opening '" + TarShardName(shard) + "'", errno);
  if (::ftruncate(fd_, static_cast<off_t>(length)) != 0 ||
      ::lseek(fd_, static_cast<off_t>(length), SEEK_SET) < 0) {
    return files::WriteError("resuming '" + TarShardName(shard) + "'", errno);
  }
  return Status::Ok();
}

Status TarPart::Append(std::string_view bytes) {
  if (const int e = files::WriteAll(fd_, bytes);
      e != 0) {  // Nothing half-written stays past what was appended whole.
    (void)!::ftruncate(fd_, static_cast<off_t>(length_));
    (void)!::lseek(fd_, static_cast<off_t>(length_), SEEK_SET);
    return files::WriteError("writing '" + TarShardName(shard_) + "'", e);
  }
  length_ += bytes.size();
  return Status::Ok();
}

Status TarPart::Sync() {
  if (::fdatasync(fd_) != 0)
    return files::WriteError("syncing '" + TarShardName(shard_) + "'", errno);
  return Status::Ok();
}

Status TarPart::Finish() {
  const uint64_t whole = length_;
  if (Status s = Append(std::string(kTarEnd, '\0')); !s.ok()) return s;
  if (Status s = Sync(); !s.ok()) return s;
  ::close(fd_);
  fd_ = -1;
  const fs::path part = dir_ / TarPartName(shard_), done = dir_ / TarShardName(shard_);
  if (::rename(part.c_str(), done.c_str()) != 0)
    return files::WriteError("publishing '" + TarShardName(shard_) + "'", errno);
  files::SyncDir(dir_);
  length_ = whole;
  return Status::Ok();
}

}  // namespace facespace::batch
