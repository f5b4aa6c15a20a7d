// What the evaluator keeps per rig between calls: the levels of detail and the box the shapes act
// in, the glb writers holding a rig's exported template, and the f32 blenders holding its rest
// body.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "facespace/evaluator/evaluator.h"
#include "facespace/formats/lod.h"

namespace facespace::evaluator {

// Values kept per rig while it lives: entries hold their rig weakly, and one whose rig died (a
// replaced or deleted rig, an evicted level of detail) is dropped, so a new rig at the same address
// never meets an old value. Not locked: its owner holds its own mutex around each call.
template <typename Value>
class PerRig {
 public:
  // The rig's value, or null when there is none (or only a dead rig's at its address).
  Value* Find(const std::shared_ptr<const Rig>& rig) {
    auto it = entries_.find(rig.get());
    return it != entries_.end() && it->second.rig.lock() == rig ? &it->second.value : nullptr;
  }
  // The rig's value, made empty when there was none; a new entry is the time to drop dead ones.
  Value& At(const std::shared_ptr<const Rig>& rig) {
    auto it = entries_.find(rig.get());
    if (it == entries_.end()) {
      std::erase_if(entries_, [](const auto& e) { return e.second.rig.expired(); });
      it = entries_.emplace(rig.get(), Entry{rig, Value{}}).first;
    } else if (it->second.rig.lock() != rig) {
      it->second = Entry{rig, Value{}};
    }
    return it->second.value;
  }

 private:
  struct Entry {
    std::weak_ptr<const Rig> rig;
    Value value;
  };
  std::map<const Rig*, Entry> entries_;
};

// DerivedRig made once per stored rig and level and kept while the stored rig lives (PerRig, keyed
// by the stored rig's own Rig): a replaced or deleted rig's entries go. Level 0's entry holds no
// rig (At hands out the stored rig itself with its box), so no entry keeps its stored rig alive.
class DerivedRigs {
 public:
  // nullptr when the level of detail cannot be made.
  std::shared_ptr<const DerivedRig> At(const std::shared_ptr<const StoredRig>& stored, int lod);
  // The rig at a level of detail: the stored rig itself at 0 (no lookup), else At(...)->rig.
  std::shared_ptr<const Rig> RigAt(const std::shared_ptr<const StoredRig>& stored, int lod);
  // What a picture of the rig at a level takes from what is kept: the camera's framing on the
  // shapes (the kept box instead of a per-render one) and, for the views that shade, the baked
  // occlusion.
  void Prepare(const std::shared_ptr<const StoredRig>& stored, int lod,
               picture::RenderOptions& options);

 private:
  // The rig's occlusion at a level, baked on first use at its neutral weights and rest pose (one
  // bake at a time: a second caller waits for the first's rather than baking again).
  std::shared_ptr<const RigOcclusion> Occlusion(const std::shared_ptr<const StoredRig>& stored,
                                                int lod);

  std::mutex mu_;
  PerRig<std::array<std::shared_ptr<const DerivedRig>, formats::kMaxLod + 1>> derived_;
  std::mutex bake_mu_;  // Held while baking; taken before mu_.
  PerRig<std::array<std::shared_ptr<const RigOcclusion>, formats::kMaxLod + 1>>
      occlusion_;  // Under mu_.
};

// Glb writers kept per rig (a GlbVariantWriter holds one rig's exported template), leased one per
// call; a writer is only handed out for the rig it was made for while that rig lives (PerRig).
class GlbWriters {
 public:
  class Lease {
   public:
    Lease(GlbWriters& pool, std::shared_ptr<const Rig> rig,
          std::unique_ptr<formats::GlbVariantWriter> writer)
        : pool_(pool), rig_(std::move(rig)), writer_(std::move(writer)) {}
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    ~Lease() { pool_.Release(rig_, std::move(writer_)); }
    formats::GlbVariantWriter& operator*() const { return *writer_; }

   private:
    GlbWriters& pool_;
    std::shared_ptr<const Rig> rig_;
    std::unique_ptr<formats::GlbVariantWriter> writer_;
  };
  Lease Acquire(const std::shared_ptr<const Rig>& rig);

 private:
  static constexpr size_t kKeptPerRig = 4;
  void Release(const std::shared_ptr<const Rig>& rig,
               std::unique_ptr<formats::GlbVariantWriter> writer);
  std::mutex mu_;
  PerRig<std::vector<std::unique_ptr<formats::GlbVariantWriter>>> free_;
};

// The F32Writer of each rig and space served as f32 (the rest body made once), held while the
// rig lives (PerRig).
class F32Writers {
 public:
  std::shared_ptr<const formats::F32Writer> Get(const std::shared_ptr<const Rig>& rig,
                                                bool mesh_space);

 private:
  std::mutex mu_;
  PerRig<std::array<std::shared_ptr<const formats::F32Writer>, 2>>
      writers_;  // World space, mesh space.
};

}  // namespace facespace::evaluator
