// The batch folder's names, lock, manifest lines and sheet (folder.h).
#include "folder.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "facespace/batch/run.h"
#include "facespace/files/durable.h"

namespace facespace::batch {

using nlohmann::json;

Status WriteInBatch(const fs::path& dir, const std::string& name, std::string_view data,
                    const std::string& writer) {
  return files::WriteFileDurably(dir, name, data, kTmpPrefix + name + writer, "'" + name + "'",
                                 false);
}

namespace {

std::string ShardSuffix(size_t shard, size_t shards) {
  return "shard-" + std::to_string(shard + 1) + "-of-" + std::to_string(shards);
}

uint64_t SizeOf(const fs::path& path) {
  std::error_code ec;
  const uint64_t size = fs::is_regular_file(path, ec) ? fs::file_size(path, ec) : 0;
  return ec ? 0 : size;
}

// Whether the files manifest line `j` of variant `index` vouches for are there: its file with its
// size (archived: its bytes in its tar shard, or in the part being written) and each of its
// "files".
bool LineHolds(const fs::path& dir, const BatchPlan& plan, size_t index, const json& j) {
  if (j.contains("shard")) {
    const size_t shard = TarShardOf(plan, index);
    if (j["shard"] != TarShardName(shard) || !j.contains("offset") ||
        !j["offset"].is_number_unsigned())
      return false;
    const uint64_t end = j["offset"].get<uint64_t>() + j["bytes"].get<uint64_t>();
    return std::max(SizeOf(dir / TarShardName(shard)), SizeOf(dir / TarPartName(shard))) >= end;
  }
  if (SizeOf(dir / j["file"].get<std::string>()) != j["bytes"].get<uint64_t>()) return false;
  const std::string key = VariantId(plan, index) + ".";
  for (const json& f : j.value("files", json::array())) {
    if (!f.is_object() || !f.contains("file") || !f["file"].is_string() || !f.contains("bytes") ||
        !f["bytes"].is_number_unsigned())
      return false;
    const std::string name = f["file"].get<std::string>();
    if (name.rfind(key, 0) != 0 || name.find('/') != std::string::npos ||
        SizeOf(dir / name) != f["bytes"].get<uint64_t>())
      return false;
  }
  return true;
}

}  // namespace

std::string ManifestName(size_t shard, size_t shards) {
  return shards > 1 ? "manifest." + ShardSuffix(shard, shards) + ".jsonl" : kManifest;
}
std::string RecordName(size_t shard, size_t shards) { return ShardSuffix(shard, shards) + ".json"; }

bool ParseShardName(std::string_view name, std::string_view prefix, std::string_view suffix,
                    size_t* shard, size_t* shards) {
  if (name.size() <= prefix.size() + suffix.size() || name.substr(0, prefix.size()) != prefix ||
      name.substr(name.size() - suffix.size()) != suffix) {
    return false;
  }
  name = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
  unsigned long i = 0, n = 0;
  char tail = 0;
  const std::string text(name);
  if (std::sscanf(text.c_str(), "shard-%lu-of-%lu%c", &i, &n, &tail) != 2 || i < 1 || i > n)
    return false;
  if (text != "shard-" + std::to_string(i) + "-of-" + std::to_string(n)) return false;
  *shard = i - 1;
  *shards = n;
  return true;
}

RunLock::~RunLock() {
  if (fd_ >= 0) {
    ::unlink(path_.c_str());
    ::close(fd_);
  }
}

bool RunLock::Take(const fs::path& path) {
  path_ = path.string();
  fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) return true;  // A read-only folder fails later, with a better message.
  if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) return true;
  ::close(fd_);
  fd_ = -1;
  return false;
}

bool Locked(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool held = ::flock(fd, LOCK_SH | LOCK_NB) != 0;
  ::close(fd);
  return held;
}

std::map<size_t, std::string> ReadManifests(const fs::path& dir, const BatchPlan& plan,
                                            const std::function<bool(size_t)>& keep) {
  std::map<size_t, std::string> lines;
  std::error_code ec;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    size_t shard = 0, shards = 0;
    if (name == kManifest || ParseShardName(name, "manifest.", ".jsonl", &shard, &shards))
      files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& path : files) {
    std::ifstream f(path, std::ios::binary);
    std::string line;
    while (std::getline(f, line)) {
      json j = json::parse(line, nullptr, false);
      if (j.is_discarded() || !j.is_object() || !j.contains("index") ||
          !j["index"].is_number_unsigned() || !j.contains("file") || !j["file"].is_string() ||
          !j.contains("bytes") || !j["bytes"].is_number_unsigned()) {
        continue;
      }
      const size_t index = j["index"].get<size_t>();
      if (index >= plan.total || !keep(index) || lines.count(index) ||
          j["file"].get<std::string>() != VariantFile(plan, index))
        continue;
      if (LineHolds(dir, plan, index, j)) lines[index] = line;
    }
  }
  return lines;
}

std::string JoinLines(const std::map<size_t, std::string>& lines) {
  std::string text;
  for (const auto& [index, line] : lines) text += line + "\n";
  return text;
}

Status WriteSheet(const BatchPlan& plan, const fs::path& dir, size_t cells,
                  const evaluator::Evaluator& evaluator) {
  std::vector<size_t> first;
  for (size_t k = 0; k < plan.total && first.size() < cells; ++k) first.push_back(k);
  evaluator::Workspace ws;
  auto png = VariantSheet(plan, first, evaluator, ws);
  if (!png.ok()) return png.status();
  return WriteInBatch(dir, "sheet.png", png.value());
}

std::string Sha256Hex(std::span<const std::string_view> pieces) {
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr);
  for (std::string_view p : pieces) EVP_DigestUpdate(ctx, p.data(), p.size());
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_DigestFinal_ex(ctx, md, &len);
  EVP_MD_CTX_free(ctx);
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < len; ++i) {
    out += hex[md[i] >> 4];
    out += hex[md[i] & 15];
  }
  return out;
}

}  // namespace facespace::batch
