// The live socket's {"landmarks": {...}} messages (issue 64): a face tracker's points, one frame a
// message, as the rig's weights. The first message (or one with "neutral": true) is the
// performer's face at rest; each is solved as the capture route solves a frame, smoothed with the
// ones before.
#pragma once

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <stop_token>

#include "../http/context.h"
#include "facespace/derive/capture.h"

namespace facespace::http {

class LiveLandmarks {
 public:
  // `message` is the landmarks member: {"scheme", "image": [w, h], "points": [[x, y, z], ...],
  // "neutral": bool}. The solved weights by the rig's shape names (non-zero ones) into `weights`,
  // and the head's turn into `head`. The rig's landmarks are registered on the first message (a
  // quarter of a second on FaceCap). Errors name their member ("/landmarks/points/3").
  Status Feed(ServerState& ctx, const evaluator::StoredRig& rig, const nlohmann::json& message,
              std::stop_token stop, nlohmann::json& weights, nlohmann::json& head);

 private:
  std::shared_ptr<const derive::LandmarkRig> map_;
  std::optional<derive::FaceTracker> tracker_;
  size_t frames_ = 0;
  std::chrono::steady_clock::time_point last_;  // The last message's arrival.
};

}  // namespace facespace::http
