// The landmarks' places on each rig (core/derive/capture.h's MapLandmarks), made on a rig's first
// capture and kept per rig version: a registration costs a derive's first second, a frame's solve
// a third of a millisecond.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <stop_token>
#include <string>

#include "facespace/derive/capture.h"
#include "facespace/evaluator/store.h"

namespace facespace::http {

class LandmarkMaps {
 public:
  // The map of `rig`, made now if not kept (cancelled by `stop`); errors as MapLandmarks', or the
  // canonical face missing (kInternal).
  Result<std::shared_ptr<const derive::LandmarkRig>> Get(const evaluator::StoredRig& rig,
                                                         std::stop_token stop);
  // Whether `rig`'s map is kept (the cost of a capture says so).
  bool Has(const evaluator::StoredRig& rig) const;

 private:
  static constexpr size_t kKept = 8;  // Rig versions; the oldest goes first.
  mutable std::mutex mu_;
  std::shared_ptr<const Rig> canonical_;
  std::map<std::string, std::shared_ptr<const derive::LandmarkRig>> maps_;  // By id@version.
  std::vector<std::string> order_;
};

}  // namespace facespace::http
