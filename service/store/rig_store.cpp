#include "store/rig_store.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cinttypes>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "facespace/files/durable.h"
#include "facespace/formats/io.h"

namespace facespace {

namespace fs = std::filesystem;

namespace {

// Where a rig file's manifest lives: "dir/fox.glb" -> "dir/fox.manifest.json".
std::string ManifestPath(const std::string& rig_path) {
  const fs::path p(rig_path);
  return (p.parent_path() / (p.stem().string() + ".manifest.json")).string();
}

std::string ReadText(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

bool IsRigFile(const fs::path& p) {
  const std::string ext = p.extension().string();
  formats::RigFormat format;
  return RigFormatFromPath(p.filename().string(), &format);
}

}  // namespace

FileRigStore::FileRigStore(std::string dir, std::vector<std::string> read_only)
    : dir_(std::move(dir)), read_only_(std::move(read_only)) {
  while (dir_.size() > 1 && dir_.back() == '/')
    dir_.pop_back();  // Paths compare equal to the scan's.
}

FileRigStore::Stamp FileRigStore::StampOf(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return {};
  return {static_cast<long long>(st.st_size),
          static_cast<long long>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec,
          static_cast<unsigned long long>(st.st_ino)};
}

Result<std::map<std::string, FileRigStore::Entry>> FileRigStore::Scan(
    const std::map<std::string, Entry>& previous) {
  std::map<std::string, Entry> loaded;
  if (Status s = LoadFolder(dir_, false, previous, loaded); !s.ok()) return s;
  for (const std::string& dir : read_only_) {
    if (Status s = LoadFolder(dir, true, previous, loaded); !s.ok()) return s;
  }
  return loaded;
}

void FileRigStore::RemoveTemporaries(int older_than_seconds) {
  std::error_code ec;
  const auto now = fs::file_time_type::clock::now();
  for (const auto& e : fs::directory_iterator(dir_, ec)) {
    const std::string name = e.path().filename().string();
    if (!e.is_regular_file() || name.size() <= 4 || name[0] != '.' ||
        name.find(".tmp") == std::string::npos)
      continue;
    std::error_code time_ec;
    const auto written = fs::last_write_time(e.path(), time_ec);
    if (older_than_seconds > 0 &&
        (time_ec || now - written < std::chrono::seconds(older_than_seconds)))
      continue;
    files::RemoveAbandoned(e.path());  // Left by an upload that crashed (here or in another
                                       // instance): never published.
  }
}

Result<size_t> FileRigStore::LoadAll() {
  std::lock_guard<std::mutex> write_lock(write_mu_);
  RemoveTemporaries(0);
  auto loaded = Scan({});
  if (!loaded.ok()) return loaded.status();
  std::lock_guard<std::mutex> lock(mu_);
  map_ = std::move(loaded.value());
  return map_.size();
}

Result<FileRigStore::Changes> FileRigStore::Refresh() {
  std::lock_guard<std::mutex> write_lock(write_mu_);
  // Another instance's crashed upload: no upload here is in progress (the write lock), and one
  // elsewhere writes its temporaries within seconds, so ten minutes old is abandoned.
  RemoveTemporaries(kAbandonedSeconds);
  std::map<std::string, Entry> current;
  {
    std::lock_guard<std::mutex> lock(mu_);
    current = map_;
  }
  auto loaded = Scan(current);
  if (!loaded.ok()) return loaded.status();
  Changes changes;
  for (const auto& [id, e] : loaded.value()) {
    auto it = current.find(id);
    if (it == current.end())
      changes.added.push_back(id);
    else if (it->second.rig != e.rig)
      changes.replaced.push_back(id);
  }
  for (const auto& [id, e] : current) {
    if (!loaded->count(id)) changes.removed.push_back(id);
  }
  if (!changes.added.empty() || !changes.replaced.empty() || !changes.removed.empty()) {
    std::lock_guard<std::mutex> lock(mu_);
    map_ = std::move(loaded.value());
  }
  return changes;
}

Status FileRigStore::LoadFolder(const std::string& dir, bool read_only,
                                const std::map<std::string, Entry>& previous,
                                std::map<std::string, Entry>& loaded) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    return NotFound("rig store '" + dir + "' is not a readable directory");
  // Candidates: files in dir first, then in its immediate subfolders; the first id wins.
  std::vector<fs::path> top, nested;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.empty() || name[0] == '.') continue;  // Temporary files, being written or abandoned.
    if (e.is_regular_file() && IsRigFile(e.path())) top.push_back(e.path());
    if (e.is_directory()) {
      for (const auto& f : fs::directory_iterator(e.path(), ec)) {
        if (f.is_regular_file() && IsRigFile(f.path())) nested.push_back(f.path());
      }
    }
  }
  if (ec) return NotFound("cannot read rig store '" + dir + "': " + ec.message());
  std::sort(top.begin(), top.end());
  std::sort(nested.begin(), nested.end());
  top.insert(top.end(), nested.begin(), nested.end());
  // A folder holding one rig file may name it: rigs/uka/MS_Uka.pmx is "uka" (its stem is no id).
  std::map<fs::path, size_t> in_folder;
  for (const fs::path& p : nested) ++in_folder[p.parent_path()];
  for (const fs::path& p : top) {
    std::string id = p.stem().string();
    const std::string folder = p.parent_path().filename().string();
    if (!evaluator::IsValidRigId(id) && in_folder.count(p.parent_path()) &&
        in_folder[p.parent_path()] == 1 && evaluator::IsValidRigId(folder))
      id = folder;
    if (!evaluator::IsValidRigId(id)) {
      // Said once, not at every look at the store (--store-poll).
      if (misnamed_.insert(p.string()).second) {
        std::fprintf(stderr,
                     "facespace: skipping %s: '%s' is not a valid rig id "
                     "([a-z0-9][a-z0-9_-]{0,63}); rename it, or its folder\n",
                     p.c_str(), id.c_str());
      }
      continue;
    }
    if (loaded.count(id)) continue;
    const Stamp file = StampOf(p.string()), manifest = StampOf(ManifestPath(p.string()));
    if (auto it = previous.find(id); it != previous.end() && it->second.path == p.string() &&
                                     it->second.file == file && it->second.manifest == manifest) {
      loaded[id] = it->second;  // Unchanged: not read again.
      continue;
    }
    if (auto it = reported_.find(p.string());
        it != reported_.end() && it->second == std::pair(file, manifest))
      continue;
    std::ifstream f(p, std::ios::binary);
    std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)),
                                     std::istreambuf_iterator<char>());
    auto rig = formats::LoadRigFile(p.string());
    if (!rig.ok()) {
      std::fprintf(stderr, "facespace: skipping broken rig %s: %s\n", p.c_str(),
                   rig.status().message.c_str());
      reported_[p.string()] = {file, manifest};
      continue;
    }
    reported_.erase(p.string());
    auto stored = std::make_shared<evaluator::StoredRig>();
    stored->id = id;
    stored->rig = std::move(rig.value());
    stored->version = evaluator::RigVersion(bytes, ReadText(ManifestPath(p.string())));
    loaded[id] = {std::move(stored), p.string(), read_only, file, manifest};
  }
  return Status::Ok();
}

namespace {

Status ReadOnly(const std::string& id) {
  return WithReason(
      FailedPrecondition("rig '" + id +
                         "' is bundled with the server and read-only; upload under another id"),
      "read-only");
}

}  // namespace

std::shared_ptr<const evaluator::StoredRig> FileRigStore::Get(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = map_.find(id);
  return it == map_.end() ? nullptr : it->second.rig;
}

std::vector<std::shared_ptr<const evaluator::StoredRig>> FileRigStore::List() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<std::shared_ptr<const evaluator::StoredRig>> out;
  for (const auto& [id, e] : map_) out.push_back(e.rig);
  return out;
}

// A glTF's counts from its JSON alone (a linear parse), before any decoding: a file declaring
// 100,000 morph targets was decoded for half a minute before --max-shapes refused it.
Status FileRigStore::CheckDeclaredCounts(std::span<const unsigned char> bytes,
                                         formats::RigFormat format) const {
  std::string_view text;
  if (format == formats::RigFormat::kGlb) {
    if (bytes.size() < 20) return Status::Ok();  // The reader says what is wrong with it.
    uint32_t length = 0, type = 0;
    std::memcpy(&length, bytes.data() + 12, 4);
    std::memcpy(&type, bytes.data() + 16, 4);
    if (type != 0x4E4F534Au || length > bytes.size() - 20) return Status::Ok();
    text = std::string_view(reinterpret_cast<const char*>(bytes.data()) + 20, length);
  } else if (format == formats::RigFormat::kGltf) {
    text = std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  } else {
    return Status::Ok();
  }
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (!j.is_object()) return Status::Ok();
  size_t targets = 0, vertices = 0;
  const auto& accessors = j.value("accessors", nlohmann::json::array());
  const auto& meshes = j.value("meshes", nlohmann::json::array());
  for (const auto& mesh : meshes.is_array() ? meshes : nlohmann::json::array()) {
    const auto& prims = mesh.is_object() ? mesh.value("primitives", nlohmann::json::array())
                                         : nlohmann::json::array();
    for (const auto& prim : prims.is_array() ? prims : nlohmann::json::array()) {
      if (!prim.is_object()) continue;
      if (const auto t = prim.find("targets"); t != prim.end() && t->is_array())
        targets = std::max(targets, t->size());
      const auto a = prim.find("attributes");
      if (a == prim.end() || !a->is_object() || !a->contains("POSITION") ||
          !(*a)["POSITION"].is_number_unsigned())
        continue;
      const size_t index = (*a)["POSITION"].get<size_t>();
      if (accessors.is_array() && index < accessors.size() && accessors[index].is_object()) {
        const auto count = accessors[index].find("count");
        if (count != accessors[index].end() && count->is_number_unsigned())
          vertices += count->get<size_t>();
      }
    }
  }
  if (targets > max_shapes_) {
    return ResourceExhausted("the rig declares " + std::to_string(targets) +
                             " morph targets on a primitive (shapes); this server takes at most " +
                             std::to_string(max_shapes_) + " (--max-shapes)");
  }
  if (vertices > max_vertices_) {
    return ResourceExhausted("the rig declares " + std::to_string(vertices) +
                             " vertices; this server takes at most " +
                             std::to_string(max_vertices_) + " (--max-vertices)");
  }
  return Status::Ok();
}

Status FileRigStore::CheckLimits(const Rig& rig) const {
  if (rig.vertex_count() > max_vertices_) {
    return ResourceExhausted("the rig has " + std::to_string(rig.vertex_count()) +
                             " vertices; this server takes at most " +
                             std::to_string(max_vertices_) + " (--max-vertices)");
  }
  if (rig.shapes.size() > max_shapes_) {
    return ResourceExhausted("the rig has " + std::to_string(rig.shapes.size()) +
                             " shapes; this server takes at most " + std::to_string(max_shapes_) +
                             " (--max-shapes)");
  }
  return Status::Ok();
}

Status FileRigStore::Put(const std::string& id, std::span<const unsigned char> bytes,
                         formats::RigFormat format, const std::string& manifest, bool* created) {
  if (!evaluator::IsValidRigId(id)) return InvalidArgument("invalid rig id");
  // Validate fully before anything touches the disk; what the file declares first.
  if (Status s = CheckDeclaredCounts(bytes, format); !s.ok()) return s;
  auto rig = evaluator::LoadUpload(id, bytes, format, manifest);
  if (!rig.ok()) return rig.status();
  if (Status s = CheckLimits(rig.value()); !s.ok()) return s;
  auto stored = std::make_shared<evaluator::StoredRig>();
  stored->id = id;
  stored->rig = std::move(rig.value());
  stored->version = evaluator::RigVersion(bytes, manifest);

  std::lock_guard<std::mutex> write_lock(write_mu_);
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (auto it = map_.find(id); it != map_.end() && it->second.read_only) return ReadOnly(id);
  }
  static std::atomic<uint64_t> counter{0};
  auto tmp_name = [&id] {
    return "." + id + "." + std::to_string(::getpid()) + "." + std::to_string(counter++) + ".tmp";
  };
  const std::string file = id + RigFormatExtension(format), manifest_file = id + ".manifest.json";
  const std::string final_path = dir_ + "/" + file;
  // Both files are written and flushed under temporary names before anything is replaced: a full
  // disk leaves the old rig and its manifest as they were.
  const std::string rig_tmp = tmp_name(), manifest_tmp = tmp_name();
  const std::string_view rig_pieces[] = {
      std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size())};
  auto rig_fd = files::WriteTemporary(dir_, rig_tmp, rig_pieces, "the rig");
  if (!rig_fd.ok()) return rig_fd.status();
  if (Status s = files::Flush(rig_fd.value(), dir_, rig_tmp, "the rig"); !s.ok()) return s;
  int manifest_fd = -1;
  if (!manifest.empty()) {
    const std::string_view manifest_pieces[] = {manifest};
    auto fd = files::WriteTemporary(dir_, manifest_tmp, manifest_pieces, "the manifest");
    Status s = fd.ok() ? files::Flush(fd.value(), dir_, manifest_tmp, "the manifest") : fd.status();
    if (!s.ok()) {
      files::Discard(rig_fd.value(), dir_, rig_tmp);
      return s;
    }
    manifest_fd = fd.value();
  }
  // Then the old manifest goes first: a crash after it leaves a rig served plain, never the new
  // rig under a manifest written for the old one (which might not apply, and would hide the rig).
  std::error_code ec;
  fs::remove(dir_ + "/" + manifest_file, ec);
  if (Status s = files::Publish(rig_fd.value(), dir_, rig_tmp, file, "the rig"); !s.ok()) {
    if (manifest_fd >= 0) files::Discard(manifest_fd, dir_, manifest_tmp);
    return s;
  }
  if (manifest_fd >= 0) {
    if (Status s = files::Publish(manifest_fd, dir_, manifest_tmp, manifest_file, "the manifest");
        !s.ok())
      return s;
  }
  files::SyncDir(dir_);
  // Other extensions, if any, must not shadow the new file after a restart.
  for (formats::RigFormat other :
       {formats::RigFormat::kGlb, formats::RigFormat::kGltf, formats::RigFormat::kFbx,
        formats::RigFormat::kCollada, formats::RigFormat::kMd5, formats::RigFormat::kPmx,
        formats::RigFormat::kPmd}) {
    if (other != format) fs::remove(dir_ + "/" + id + RigFormatExtension(other), ec);
  }
  const Stamp file_stamp = StampOf(final_path), manifest_stamp = StampOf(ManifestPath(final_path));
  std::lock_guard<std::mutex> lock(mu_);
  *created = !map_.count(id);
  map_[id] = {std::move(stored), final_path, false, file_stamp, manifest_stamp};
  return Status::Ok();
}

Status FileRigStore::WritablePath(const std::string& id, std::string& path) const {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = map_.find(id);
  if (it == map_.end()) return NotFound("no rig '" + id + "'");
  if (it->second.read_only) return ReadOnly(id);
  path = it->second.path;
  return Status::Ok();
}

Status FileRigStore::PutManifest(const std::string& id, const std::string& manifest) {
  std::lock_guard<std::mutex> write_lock(write_mu_);
  std::string path;
  if (Status s = WritablePath(id, path); !s.ok()) return s;
  // The rig as its file holds it, without the manifest it has now.
  std::ifstream f(path, std::ios::binary);
  const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)),
                                         std::istreambuf_iterator<char>());
  auto rig = formats::LoadRigFile(
      path, {.allow_external_files = true, .read_manifest = false});  // As LoadAll reads it.
  if (!rig.ok()) return Internal("the stored rig no longer loads: " + rig.status().message);
  rig->name = id;
  if (!manifest.empty()) {
    if (Status s = formats::ApplyManifest(rig.value(), manifest); !s.ok()) {
      for (FieldError& fe : s.fields) fe.pointer = "/manifest" + fe.pointer;
      return WithInputReason(s, "invalid-manifest");
    }
  }
  if (Status s = CheckLimits(rig.value()); !s.ok()) return s;  // Derived shapes count too.
  auto stored = std::make_shared<evaluator::StoredRig>();
  stored->id = id;
  stored->rig = std::move(rig.value());
  stored->version = evaluator::RigVersion(bytes, manifest);
  const fs::path p(path);
  const std::string manifest_file = p.stem().string() + ".manifest.json";
  static std::atomic<uint64_t> counter{0};
  const std::string tmp = "." + id + ".manifest." + std::to_string(::getpid()) + "." +
                          std::to_string(counter++) + ".tmp";
  if (Status s =
          files::WriteFileDurably(p.parent_path(), manifest_file, manifest, tmp, "the manifest");
      !s.ok())
    return s;
  const Stamp manifest_stamp = StampOf(ManifestPath(path));
  std::lock_guard<std::mutex> lock(mu_);
  map_[id].rig = std::move(stored);
  map_[id].manifest = manifest_stamp;
  return Status::Ok();
}

Status FileRigStore::Delete(const std::string& id) {
  std::lock_guard<std::mutex> write_lock(write_mu_);
  std::string path;
  if (Status s = WritablePath(id, path); !s.ok()) return s;
  if (::unlink(path.c_str()) != 0 && errno != ENOENT) {
    return Internal(std::string("cannot delete the rig file: ") + std::strerror(errno));
  }
  ::unlink(ManifestPath(path).c_str());  // Its manifest, if any: never applied to a later upload.
  std::lock_guard<std::mutex> lock(mu_);
  map_.erase(id);
  return Status::Ok();
}

}  // namespace facespace
