#include "landmark_maps.h"

#include <algorithm>

#include "facespace/formats/io.h"

namespace facespace::http {

namespace {
std::string KeyOf(const evaluator::StoredRig& rig) { return rig.id + "@" + rig.version; }
}  // namespace

bool LandmarkMaps::Has(const evaluator::StoredRig& rig) const {
  std::lock_guard<std::mutex> lock(mu_);
  return maps_.count(KeyOf(rig)) > 0;
}

Result<std::shared_ptr<const derive::LandmarkRig>> LandmarkMaps::Get(
    const evaluator::StoredRig& rig, std::stop_token stop) {
  std::shared_ptr<const Rig> canonical;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (auto it = maps_.find(KeyOf(rig)); it != maps_.end()) return it->second;
    if (!canonical_) {
      auto loaded = formats::LoadRigFile(std::string(FACESPACE_TRACKERS_DIR) +
                                         "/mediapipe/canonical_face_model.obj");
      if (!loaded.ok())
        return Internal("MediaPipe's canonical face is missing: " + loaded.status().message);
      canonical_ = std::make_shared<const Rig>(std::move(loaded.value()));
    }
    canonical = canonical_;
  }
  derive::Options options;
  options.stop = stop;
  auto map = derive::MapLandmarks(rig.rig, *canonical, options);
  if (!map.ok()) return map.status();
  auto kept = std::make_shared<const derive::LandmarkRig>(std::move(map.value()));
  std::lock_guard<std::mutex> lock(mu_);
  const std::string key = KeyOf(rig);
  if (maps_.emplace(key, kept).second) order_.push_back(key);
  while (order_.size() > kKept) {
    maps_.erase(order_.front());
    order_.erase(order_.begin());
  }
  return kept;
}

}  // namespace facespace::http
