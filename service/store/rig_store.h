// The rig store: a directory of .glb/.gltf files, loaded once, served as immutable
// shared_ptr<const StoredRig>, replaced atomically on upload.
#pragma once

#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "facespace/evaluator/store.h"

namespace facespace {

class FileRigStore : public evaluator::RigStore {
 public:
  // `dir` holds the rigs: files directly in it, and in its immediate subfolders (a file in
  // the folder itself wins over one of the same id in a subfolder). Uploads go to `dir`.
  // `read_only` folders (the bundled rigs) are served too, after `dir`'s, but never written: a
  // PUT or DELETE of one of their rigs is refused (reason "read-only", HTTP 409).
  explicit FileRigStore(std::string dir, std::vector<std::string> read_only = {});

  // Uploads beyond these are refused (ResourceExhausted: HTTP 413) before anything is stored.
  void SetUploadLimits(size_t max_vertices, size_t max_shapes) {
    max_vertices_ = max_vertices;
    max_shapes_ = max_shapes;
  }

  // Loads every rig; a broken file is reported on stderr and skipped. Returns the number
  // loaded. Fails only when the directory cannot be read. Temporary files left by a crashed
  // upload are removed (never one another process is writing: durable.h, RemoveAbandoned).
  Result<size_t> LoadAll();

  // What a Refresh found changed on disk, by id.
  struct Changes {
    std::vector<std::string> added, replaced, removed;
  };
  // Looks at the folders again and publishes what other processes sharing them changed: a rig
  // file or manifest added, replaced (renamed in: never half-written) or removed. Only files
  // whose stamp (size, mtime, inode) moved are read, so a refresh of an unchanged store costs a
  // stat per file; a broken file is reported once per version.
  Result<Changes> Refresh();

  std::shared_ptr<const evaluator::StoredRig> Get(const std::string& id) const override;
  std::vector<std::shared_ptr<const evaluator::StoredRig>> List() const override;
  Status Put(const std::string& id, std::span<const unsigned char> bytes, formats::RigFormat format,
             const std::string& manifest, bool* created) override;
  Status PutManifest(const std::string& id, const std::string& manifest) override;
  Status Delete(const std::string& id) override;

 private:
  // A file's identity on disk: what changes when it is replaced or rewritten. size -1: absent.
  struct Stamp {
    long long size = -1, mtime_ns = 0;
    unsigned long long inode = 0;
    bool operator==(const Stamp&) const = default;
  };
  struct Entry {
    std::shared_ptr<const evaluator::StoredRig> rig;
    std::string path;
    bool read_only = false;
    Stamp file, manifest;  // Of the rig file and its manifest when read.
  };
  static Stamp StampOf(const std::string& path);
  // The rigs of one folder (into `loaded`, ids already there kept), reusing those of `previous`
  // whose files have not moved; false when the folder cannot be read.
  Status LoadFolder(const std::string& dir, bool read_only,
                    const std::map<std::string, Entry>& previous,
                    std::map<std::string, Entry>& loaded);
  Result<std::map<std::string, Entry>> Scan(const std::map<std::string, Entry>& previous);
  Status CheckLimits(const Rig& rig) const;
  // The path of the writable rig `id` into `path`: NotFound, or reason read-only (a bundled rig).
  Status WritablePath(const std::string& id, std::string& path) const;
  // Removes the store's upload temporaries written more than `older_than_seconds` ago (0: all).
  void RemoveTemporaries(int older_than_seconds);
  static constexpr int kAbandonedSeconds = 600;
  Status CheckDeclaredCounts(std::span<const unsigned char> bytes, formats::RigFormat format) const;
  std::string dir_;
  std::vector<std::string> read_only_;
  mutable std::mutex mu_;  // Guards map_ (held only to copy or swap pointers).
  std::mutex write_mu_;    // Serialises uploads, deletes and refreshes.
  std::map<std::string, std::pair<Stamp, Stamp>>
      reported_;                    // Broken files said once (under write_mu_).
  std::set<std::string> misnamed_;  // Files whose name is no rig id, said once (under write_mu_).
  std::map<std::string, Entry> map_;
  size_t max_vertices_ = 1000000;
  size_t max_shapes_ = 1024;
};

}  // namespace facespace
