// An in-memory rig store for the tests and fuzzers of the HTTP layer: FaceCap seeded, uploads
// of glTF accepted (bounded), deletes of anything but FaceCap.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "facespace/evaluator/store.h"
#include "facespace/formats/io.h"

namespace facespace::test {

class MemoryStore : public facespace::evaluator::RigStore {
 public:
  std::shared_ptr<const facespace::evaluator::StoredRig> Get(const std::string& id) const override {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = rigs_.find(id);
    return it == rigs_.end() ? nullptr : it->second;
  }
  std::vector<std::shared_ptr<const facespace::evaluator::StoredRig>> List() const override {
    std::lock_guard<std::mutex> lock(mu_);
    std::vector<std::shared_ptr<const facespace::evaluator::StoredRig>> out;
    for (const auto& [id, r] : rigs_) out.push_back(r);
    return out;
  }
  facespace::Status Put(const std::string& id, std::span<const unsigned char> bytes,
                        facespace::formats::RigFormat format, const std::string& manifest,
                        bool* created) override {
    auto rig = facespace::evaluator::LoadUpload(id, bytes, format, manifest);
    if (!rig.ok()) return rig.status();
    auto stored = std::make_shared<facespace::evaluator::StoredRig>();
    stored->id = id;
    stored->rig = std::move(rig.value());
    stored->version = facespace::evaluator::RigVersion(bytes, manifest);
    std::lock_guard<std::mutex> lock(mu_);
    *created = !rigs_.count(id);
    if (rigs_.size() < 4 || !*created) {  // Bounded, so a long run does not grow.
      rigs_[id] = stored;
      files_[id] = {std::vector<unsigned char>(bytes.begin(), bytes.end()), format};
    }
    return facespace::Status::Ok();
  }
  facespace::Status PutManifest(const std::string& id, const std::string& manifest) override {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = files_.find(id);
    if (it == files_.end()) return facespace::NotFound("no uploaded rig '" + id + "'");
    auto rig = facespace::evaluator::LoadUpload(id, it->second.first, it->second.second, manifest);
    if (!rig.ok()) return rig.status();
    auto stored = std::make_shared<facespace::evaluator::StoredRig>();
    stored->id = id;
    stored->rig = std::move(rig.value());
    stored->version = facespace::evaluator::RigVersion(it->second.first, manifest);
    rigs_[id] = stored;
    return facespace::Status::Ok();
  }
  facespace::Status Delete(const std::string& id) override {
    std::lock_guard<std::mutex> lock(mu_);
    if (id == "facecap" || !rigs_.erase(id)) return facespace::NotFound("no rig");
    files_.erase(id);
    return facespace::Status::Ok();
  }
  void Seed() {
    auto rig = facespace::formats::LoadRigFile(FACESPACE_SOURCE_DIR "/assets/facecap/facecap.glb");
    auto stored = std::make_shared<facespace::evaluator::StoredRig>();
    stored->id = "facecap";
    stored->rig = std::move(rig.value());
    stored->version = "1";
    rigs_["facecap"] = stored;
  }

 private:
  mutable std::mutex mu_;
  std::map<std::string, std::shared_ptr<const facespace::evaluator::StoredRig>> rigs_;
  std::map<std::string, std::pair<std::vector<unsigned char>, facespace::formats::RigFormat>>
      files_;  // Uploads.
};

}  // namespace facespace::test
