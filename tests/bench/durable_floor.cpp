// The disk's floor under a batch (issue 62): N files of SIZE bytes made durable as facespace batch
// makes them (files::WriteTemporary, then files::PublishGroup a group of batch::kGroupFiles), and
// the same bytes as one stream synced a group (tar shards), with nothing blended or encoded. What
// a variant costs in a folder can be no less than the first figure.
// usage: durable_floor DIR [N] [SIZE]
#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "facespace/batch/run.h"
#include "facespace/files/durable.h"

namespace {

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Seconds for n files in `dir`, published a group at a time; negative on a failure.
double Folder(const std::filesystem::path& dir, size_t n, const std::string& bytes) {
  namespace files = facespace::files;
  const std::string_view piece = bytes;
  std::vector<files::PendingFile> group;
  const auto start = Clock::now();
  for (size_t i = 0; i < n; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "v%06zu.glb", i);
    const std::string tmp = std::string(".") + name + ".tmp";
    auto fd = files::WriteTemporary(dir, tmp, {&piece, 1}, name);
    if (!fd.ok()) return -1;
    group.push_back({fd.value(), tmp, name, name});
    if (group.size() >= facespace::batch::kGroupFiles || i + 1 == n) {
      if (!files::PublishGroup(dir, group).status.ok()) return -1;
      group.clear();
    }
  }
  return Since(start);
}

// Seconds for the same bytes appended to one file, synced a group at a time.
double Stream(const std::filesystem::path& dir, size_t n, const std::string& bytes) {
  const int fd = open((dir / "all.tar").c_str(), O_CREAT | O_WRONLY | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return -1;
  const auto start = Clock::now();
  for (size_t i = 0; i < n; ++i) {
    if (facespace::files::WriteAll(fd, bytes) != 0) return close(fd), -1;
    if ((i + 1) % facespace::batch::kGroupFiles == 0 || i + 1 == n) fdatasync(fd);
  }
  const double s = Since(start);
  close(fd);
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return std::fprintf(stderr, "usage: durable_floor DIR [N] [SIZE]\n"), 2;
  const std::filesystem::path dir = argv[1];
  const size_t n = argc > 2 ? std::strtoul(argv[2], nullptr, 10) : 500;
  const size_t size = argc > 3 ? std::strtoul(argv[3], nullptr, 10) : 155000;
  std::string bytes(size, '\0');
  for (size_t i = 0; i < size; ++i) bytes[i] = static_cast<char>((i * 2654435761u) >> 24);
  std::filesystem::create_directories(dir / "folder");
  std::filesystem::create_directories(dir / "stream");
  const double folder = Folder(dir / "folder", n, bytes);
  const double stream = Stream(dir / "stream", n, bytes);
  if (folder < 0 || stream < 0) return std::fprintf(stderr, "durable_floor: a write failed\n"), 1;
  std::printf(
      "durable_floor %zu files of %zu bytes: %.3f ms a file in a folder, %.3f ms in one stream\n",
      n, size, folder * 1e3 / n, stream * 1e3 / n);
  return 0;
}
