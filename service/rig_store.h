// The rig store: a directory of .glb/.gltf files, loaded once, served as immutable
// shared_ptr<const StoredRig>, replaced atomically on upload.
#pragma once

#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "facespace/api/store.h"

namespace facespace {

class FileRigStore : public api::RigStore {
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
  // loaded. Fails only when the directory cannot be read.
  Result<size_t> LoadAll();

  std::shared_ptr<const api::StoredRig> Get(const std::string& id) const override;
  std::vector<std::shared_ptr<const api::StoredRig>> List() const override;
  Status Put(const std::string& id, std::span<const unsigned char> bytes, RigFormat format, const std::string& manifest,
             bool* created) override;
  Status PutManifest(const std::string& id, const std::string& manifest) override;
  Status Delete(const std::string& id) override;

 private:
  struct Entry {
    std::shared_ptr<const api::StoredRig> rig;
    std::string path;
    bool read_only = false;
  };
  // The rigs of one folder (into `loaded`, ids already there kept); false when it cannot be read.
  Status LoadFolder(const std::string& dir, bool read_only, std::map<std::string, Entry>& loaded) const;
  Status CheckLimits(const Rig& rig) const;
  std::string dir_;
  std::vector<std::string> read_only_;
  mutable std::mutex mu_;     // Guards map_ (held only to copy or swap pointers).
  std::mutex write_mu_;       // Serialises uploads and deletes.
  std::map<std::string, Entry> map_;
  size_t max_vertices_ = 1000000;
  size_t max_shapes_ = 1024;
};

}  // namespace facespace
