// What the HTTP routes need from a rig store. The service implements it (service/rig_store).
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"
#include "facespace/formats/io.h"

namespace facespace::evaluator {

// A loaded rig, immutable once published, shared between requests.
struct StoredRig {
  std::string id;  // File stem: [a-z0-9][a-z0-9_-]{0,63}.
  Rig rig;
  std::string version;  // Changes whenever the stored file changes (content hash).
};

class RigStore {
 public:
  virtual ~RigStore() = default;
  // nullptr when absent.
  virtual std::shared_ptr<const StoredRig> Get(const std::string& id) const = 0;
  // Every rig, sorted by id.
  virtual std::vector<std::shared_ptr<const StoredRig>> List() const = 0;
  // Validates fully (`bytes` in `format`, with `manifest` applied: LoadUpload), then stores durably
  // (temp file, fsync, rename) as id + the format's extension, with the manifest beside it as
  // id.manifest.json (an empty `manifest`: none, and a previous one is dropped), and publishes
  // atomically. `created` tells whether the id was new. InvalidArgument for a bad rig, manifest
  // or id.
  virtual Status Put(const std::string& id, std::span<const unsigned char> bytes,
                     formats::RigFormat format, const std::string& manifest, bool* created) = 0;
  // Replaces the manifest of a stored rig (the rig file itself unchanged), validated against it
  // first. NotFound when absent; InvalidArgument (reason "invalid-manifest") when it does not
  // apply.
  virtual Status PutManifest(const std::string& id, const std::string& manifest) = 0;
  // NotFound when absent.
  virtual Status Delete(const std::string& id) = 0;
};

// The rig an upload describes: `bytes` in `format`, named `id`, then `manifest` (JSON text, README
// "Manifest"; empty: none) applied, which may name it otherwise. A manifest that does not apply is
// InvalidArgument with reason "invalid-manifest" and its fields' pointers under "/manifest".
Result<Rig> LoadUpload(const std::string& id, std::span<const unsigned char> bytes,
                       formats::RigFormat format, const std::string& manifest);

// A stored rig's version: a hash of its file's bytes and its manifest's text.
std::string RigVersion(std::span<const unsigned char> bytes, const std::string& manifest);

// True when `id` matches [a-z0-9][a-z0-9_-]{0,63}: never a path.
bool IsValidRigId(const std::string& id);

}  // namespace facespace::evaluator
