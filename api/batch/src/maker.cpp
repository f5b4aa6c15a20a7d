#include "maker.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "facespace/files/durable.h"

namespace facespace::batch {

namespace {

// A message's largest size: a labelled 4096² sample is about 250 MB; a bigger length is a broken
// pipe's.
constexpr uint64_t kMaxMessage = uint64_t{1} << 32;

bool ReadAll(int fd, void* data, size_t size) {
  char* p = static_cast<char*>(data);
  while (size > 0) {
    const ssize_t n = read(fd, p, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n, size -= static_cast<size_t>(n);
  }
  return true;
}

void PutU64(std::string& out, uint64_t n) { out.append(reinterpret_cast<const char*>(&n), 8); }

// One piece: its length, then its bytes (`more` after `piece`, as one).
void PutPiece(std::string& out, std::string_view piece, std::string_view more = {}) {
  PutU64(out, piece.size() + more.size());
  out.append(piece).append(more);
}

// The next piece of `in` from `at`, or false past its end.
bool TakePiece(std::string_view in, size_t& at, std::string_view& piece) {
  uint64_t n = 0;
  if (in.size() - at < 8) return false;
  std::memcpy(&n, in.data() + at, 8);
  at += 8;
  if (n > in.size() - at) return false;
  piece = in.substr(at, static_cast<size_t>(n));
  at += static_cast<size_t>(n);
  return true;
}

// The child's life: a variant number in, its message out, until the parent closes the pipe or dies.
[[noreturn]] void Serve(int from_parent, int to_parent, const MakerProcess::Make& make) {
  // Only its own pipe's ends stay open: another maker's copy of a pipe would keep that maker from
  // ever seeing its end, and the parent's files (its lock, its tar part) are not the child's to
  // hold.
  const unsigned lo = static_cast<unsigned>(std::min(from_parent, to_parent)),
                 hi = static_cast<unsigned>(std::max(from_parent, to_parent));
  if (lo > 3) close_range(3, lo - 1, 0);
  if (hi > lo + 1) close_range(lo + 1, hi - 1, 0);
  close_range(hi + 1, ~0u, 0);
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  signal(SIGINT, SIG_IGN);
  signal(SIGTERM, SIG_IGN);
  setenv("LP_NUM_THREADS", "0",
         0);  // llvmpipe rasterises in this thread: the process is the unit of work.
  uint64_t k = 0;
  MadeVariant made;
  std::string message;
  while (ReadAll(from_parent, &k, 8)) {
    made = MadeVariant{};
    const Status status = make(static_cast<size_t>(k), made);
    message = EncodeMade(status, made);
    const uint64_t n = message.size();
    if (files::WriteAll(to_parent, {reinterpret_cast<const char*>(&n), 8}) != 0 ||
        files::WriteAll(to_parent, message) != 0)
      break;
  }
  _exit(
      0);  // Never exit(): the parent's buffered streams (the manifest) must not be flushed twice.
}

}  // namespace

bool CanForkMakers() {
  DIR* tasks = opendir("/proc/self/task");
  if (!tasks) return false;
  int threads = 0;
  while (const dirent* e = readdir(tasks)) threads += e->d_name[0] != '.';
  closedir(tasks);
  return threads == 1;
}

std::string EncodeMade(const Status& status, const MadeVariant& made) {
  std::string out;
  PutU64(out, static_cast<uint64_t>(status.code));
  PutPiece(out, status.message);
  PutPiece(out, status.reason);
  if (!status.ok()) return out;
  PutPiece(out, made.head);
  PutPiece(out, made.tail);
  out.append(reinterpret_cast<const char*>(&made.sum), 8);
  std::string codes;
  for (const std::string& c : made.codes) codes += c + '\n';
  PutPiece(out, codes);
  PutPiece(out, made.tar);
  PutU64(out, made.files.size());
  for (const auto& [name, pieces] : made.files)
    PutPiece(out, name), PutPiece(out, pieces[0], pieces[1]);
  return out;
}

// A maker's message read into `out` (its views into `message`): the maker's status, or an error for
// a message that does not hold together.
Status DecodeMade(std::string_view message, MadeVariant& out) {
  out = MadeVariant{};
  const Status broken = Internal("a sample maker process sent a broken message");
  uint64_t code = 0;
  size_t at = 8;
  std::string_view text, reason, codes, tar, name, bytes;
  if (message.size() < 8) return broken;
  std::memcpy(&code, message.data(), 8);
  if (code > static_cast<uint64_t>(StatusCode::kInternal) || !TakePiece(message, at, text) ||
      !TakePiece(message, at, reason))
    return broken;
  if (code != 0)
    return WithReason(Status{static_cast<StatusCode>(code), std::string(text), {}, {}, 0},
                      std::string(reason));
  std::string_view head, tail;
  if (!TakePiece(message, at, head) || !TakePiece(message, at, tail) || message.size() - at < 8)
    return broken;
  std::memcpy(&out.sum, message.data() + at, 8);
  at += 8;
  if (!TakePiece(message, at, codes) || !TakePiece(message, at, tar)) return broken;
  out.head = head, out.tail = tail, out.tar = tar;
  for (size_t from = 0, end; (end = codes.find('\n', from)) != std::string_view::npos;
       from = end + 1)
    out.codes.emplace_back(codes.substr(from, end - from));
  uint64_t files = 0;
  if (message.size() - at < 8) return broken;
  std::memcpy(&files, message.data() + at, 8);
  at += 8;
  for (uint64_t i = 0; i < files;
       ++i) {  // Each file takes 16 bytes at least: a count past the end fails at once.
    if (!TakePiece(message, at, name) || !TakePiece(message, at, bytes)) return broken;
    out.files.push_back({std::string(name), {bytes, {}}});
  }
  return at == message.size() ? Status::Ok() : broken;
}

Result<std::unique_ptr<MakerProcess>> MakerProcess::Start(const Make& make) {
  signal(SIGPIPE, SIG_IGN);  // A maker that died is a failed write (EPIPE), not this process's end.
  int down[2], up[2];        // Parent to child, child to parent.
  if (pipe2(down, O_CLOEXEC) != 0) return Internal(std::string("pipe: ") + std::strerror(errno));
  if (pipe2(up, O_CLOEXEC) != 0) {
    close(down[0]), close(down[1]);
    return Internal(std::string("pipe: ") + std::strerror(errno));
  }
  const pid_t pid = fork();
  if (pid < 0) {
    for (int fd : {down[0], down[1], up[0], up[1]}) close(fd);
    return Internal(std::string("fork: ") + std::strerror(errno));
  }
  if (pid == 0) {
    close(down[1]), close(up[0]);
    Serve(down[0], up[1], make);
  }
  close(down[0]), close(up[1]);
  return std::unique_ptr<MakerProcess>(new MakerProcess(pid, down[1], up[0]));
}

MakerProcess::~MakerProcess() {
  close(to_child_);
  close(from_child_);
  int status = 0;
  while (pid_ > 0 && waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
}

// The child gone mid-answer: how it ended, for the run's error.
Status MakerProcess::Died() {
  const pid_t pid = pid_;
  int status = 0;
  pid_t r;
  while ((r = waitpid(pid, &status, 0)) < 0 && errno == EINTR) {
  }
  pid_ = -1;
  const std::string how = r != pid ? ""
                          : WIFSIGNALED(status)
                              ? " by signal " + std::to_string(WTERMSIG(status))
                              : " with exit code " + std::to_string(WEXITSTATUS(status));
  return Internal("sample maker process " + std::to_string(pid) + " ended" + how +
                  " before its variant was made; run the same command again to resume");
}

Status MakerProcess::Ask(size_t k, MadeVariant& out) {
  if (pid_ < 0) return Internal("the sample maker process has ended");
  const uint64_t index = k;
  uint64_t n = 0;
  const std::string_view asked(reinterpret_cast<const char*>(&index), 8);
  if (files::WriteAll(to_child_, asked) != 0 || !ReadAll(from_child_, &n, 8) || n > kMaxMessage)
    return Died();
  received_.resize(static_cast<size_t>(n));
  if (!ReadAll(from_child_, received_.data(), received_.size())) return Died();
  return DecodeMade(received_, out);
}

}  // namespace facespace::batch
