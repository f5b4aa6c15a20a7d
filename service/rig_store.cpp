#include "rig_store.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cinttypes>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "durable.h"
#include "facespace/core/io.h"

namespace facespace {

namespace fs = std::filesystem;

namespace {

std::string Version(std::span<const unsigned char> bytes) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016" PRIx64, h);
  return buf;
}

bool IsRigFile(const fs::path& p) {
  const std::string ext = p.extension().string();
  RigFormat format;
  return RigFormatFromPath(p.filename().string(), &format);
}

}  // namespace

FileRigStore::FileRigStore(std::string dir) : dir_(std::move(dir)) {}

Result<size_t> FileRigStore::LoadAll() {
  std::error_code ec;
  if (!fs::is_directory(dir_, ec)) return NotFound("rig store '" + dir_ + "' is not a readable directory");
  // Candidates: files in dir_ first, then in its immediate subfolders; the first id wins.
  std::vector<fs::path> top, nested;
  for (const auto& e : fs::directory_iterator(dir_, ec)) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file() && name.size() > 4 && name[0] == '.' && name.find(".tmp") != std::string::npos) {
      fs::remove(e.path(), ec);  // Left by an upload that crashed: never published.
      continue;
    }
    if (e.is_regular_file() && IsRigFile(e.path())) top.push_back(e.path());
    if (e.is_directory() && name[0] != '.') {
      for (const auto& f : fs::directory_iterator(e.path(), ec)) {
        if (f.is_regular_file() && IsRigFile(f.path())) nested.push_back(f.path());
      }
    }
  }
  if (ec) return NotFound("cannot read rig store '" + dir_ + "': " + ec.message());
  std::sort(top.begin(), top.end());
  std::sort(nested.begin(), nested.end());
  top.insert(top.end(), nested.begin(), nested.end());
  std::map<std::string, Entry> loaded;
  // A folder holding one rig file may name it: rigs/uka/MS_Uka.pmx is "uka" (its stem is no id).
  std::map<fs::path, size_t> in_folder;
  for (const fs::path& p : nested) ++in_folder[p.parent_path()];
  for (const fs::path& p : top) {
    std::string id = p.stem().string();
    const std::string folder = p.parent_path().filename().string();
    if (!api::IsValidRigId(id) && in_folder.count(p.parent_path()) && in_folder[p.parent_path()] == 1 && api::IsValidRigId(folder)) id = folder;
    if (!api::IsValidRigId(id)) {
      std::fprintf(stderr, "facespace: skipping %s: '%s' is not a valid rig id ([a-z0-9][a-z0-9_-]{0,63})\n", p.c_str(), id.c_str());
      continue;
    }
    if (loaded.count(id)) continue;
    std::ifstream f(p, std::ios::binary);
    std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    auto rig = LoadRigFile(p.string());
    if (!rig.ok()) {
      std::fprintf(stderr, "facespace: skipping broken rig %s: %s\n", p.c_str(), rig.status().message.c_str());
      continue;
    }
    auto stored = std::make_shared<api::StoredRig>();
    stored->id = id;
    stored->rig = std::move(rig.value());
    stored->version = Version(bytes);
    loaded[id] = {std::move(stored), p.string()};
  }
  std::lock_guard<std::mutex> lock(mu_);
  map_ = std::move(loaded);
  return map_.size();
}

std::shared_ptr<const api::StoredRig> FileRigStore::Get(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = map_.find(id);
  return it == map_.end() ? nullptr : it->second.rig;
}

std::vector<std::shared_ptr<const api::StoredRig>> FileRigStore::List() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<std::shared_ptr<const api::StoredRig>> out;
  for (const auto& [id, e] : map_) out.push_back(e.rig);
  return out;
}

Status FileRigStore::Put(const std::string& id, std::span<const unsigned char> bytes, RigFormat format, bool* created) {
  if (!api::IsValidRigId(id)) return InvalidArgument("invalid rig id");
  // Validate fully before anything touches the disk.
  auto rig = LoadRigMemory(bytes, format, id);
  if (!rig.ok()) return rig.status();
  if (rig->vertex_count() > max_vertices_) {
    return ResourceExhausted("the rig has " + std::to_string(rig->vertex_count()) + " vertices; this server takes at most " +
                             std::to_string(max_vertices_) + " (--max-vertices)");
  }
  if (rig->shapes.size() > max_shapes_) {
    return ResourceExhausted("the rig has " + std::to_string(rig->shapes.size()) + " shapes; this server takes at most " +
                             std::to_string(max_shapes_) + " (--max-shapes)");
  }
  rig->name = id;
  auto stored = std::make_shared<api::StoredRig>();
  stored->id = id;
  stored->rig = std::move(rig.value());
  stored->version = Version(bytes);

  std::lock_guard<std::mutex> write_lock(write_mu_);
  static std::atomic<uint64_t> counter{0};
  const std::string file = id + RigFormatExtension(format);
  const std::string final_path = dir_ + "/" + file;
  const std::string tmp = "." + id + "." + std::to_string(::getpid()) + "." + std::to_string(counter++) + ".tmp";
  const std::string_view data(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  if (Status s = WriteFileDurably(dir_, file, data, tmp, "the rig"); !s.ok()) return s;
  // Other extensions, if any, must not shadow the new file after a restart.
  std::error_code ec;
  for (RigFormat other : {RigFormat::kGlb, RigFormat::kGltf, RigFormat::kFbx, RigFormat::kCollada, RigFormat::kMd5, RigFormat::kPmx, RigFormat::kPmd}) {
    if (other != format) fs::remove(dir_ + "/" + id + RigFormatExtension(other), ec);
  }
  std::lock_guard<std::mutex> lock(mu_);
  *created = !map_.count(id);
  map_[id] = {std::move(stored), final_path};
  return Status::Ok();
}

Status FileRigStore::Delete(const std::string& id) {
  std::lock_guard<std::mutex> write_lock(write_mu_);
  std::string path;
  {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = map_.find(id);
    if (it == map_.end()) return NotFound("no rig '" + id + "'");
    path = it->second.path;
  }
  if (::unlink(path.c_str()) != 0 && errno != ENOENT) {
    return Internal(std::string("cannot delete the rig file: ") + std::strerror(errno));
  }
  std::lock_guard<std::mutex> lock(mu_);
  map_.erase(id);
  return Status::Ok();
}

}  // namespace facespace
