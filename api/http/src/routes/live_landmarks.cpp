#include "live_landmarks.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "routes.h"

namespace facespace::http {

using nlohmann::json;

namespace {

// The points of a landmarks message, flattened; false with the error in `s`.
bool ReadPoints(const json& m, std::vector<float>& out, Status& s) {
  for (auto it = m.begin(); it != m.end(); ++it) {
    const std::string& k = it.key();
    if (k != "scheme" && k != "image" && k != "points" && k != "neutral") {
      s = InvalidField("/landmarks/" + k.substr(0, 64),
                       "landmarks take scheme, image, points and neutral");
      return false;
    }
  }
  if (m.contains("scheme") && m["scheme"] != "mediapipe-478" && m["scheme"] != "mediapipe-468") {
    s = InvalidField("/landmarks/scheme", "must be mediapipe-478 or mediapipe-468");
    return false;
  }
  const json& p = m.value("points", json());
  if (!p.is_array() || (p.size() != 468 && p.size() != 478)) {
    s = InvalidField("/landmarks/points", "must be 468 or 478 points [x, y, z] (MediaPipe's)");
    return false;
  }
  out.clear();
  for (size_t i = 0; i < p.size(); ++i) {
    const json& q = p[i];
    if (!q.is_array() || q.size() != 3 || !q[0].is_number() || !q[1].is_number() ||
        !q[2].is_number()) {
      s = InvalidField("/landmarks/points/" + std::to_string(i), "must be [x, y, z]");
      return false;
    }
    for (int c = 0; c < 3; ++c) out.push_back(q[c].get<float>());
  }
  return true;
}

}  // namespace

Status LiveLandmarks::Feed(ServerState& ctx, const evaluator::StoredRig& rig, const json& message,
                           std::stop_token stop, json& weights, json& head) {
  if (!message.is_object())
    return InvalidField("/landmarks", "must be {\"scheme\", \"image\", \"points\": [...]}");
  std::vector<float> points;
  Status s;
  if (!ReadPoints(message, points, s)) return s;
  if (!map_) {
    auto map = ctx.landmark_maps.Get(rig, stop);
    if (!map.ok()) {
      Status e = map.status();
      e.fields.clear();
      e.message = "MediaPipe's face could not be laid on this rig's: " + e.message;
      return e;
    }
    map_ = map.value();
  }
  if (!tracker_ || message.value("neutral", false) == true) {
    tracker_.emplace(*map_, derive::CaptureOptions{});
    if (Status n = tracker_->SetNeutral(points, frames_); !n.ok()) return n;
  }
  // The smoothing's step: the time since the last message (a camera's rate varies with the
  // browser's load), within 1/240 s and half a second.
  const auto now = std::chrono::steady_clock::now();
  const float seconds = frames_ == 0 ? 0.0f
                                     : std::clamp(std::chrono::duration<float>(now - last_).count(),
                                                  1 / 240.0f, 0.5f);
  last_ = now;
  derive::FaceTracker::Frame frame;
  if (Status f = tracker_->Step(points, frames_++, frame, seconds); !f.ok()) return f;
  weights = json::object();
  for (size_t k = 0; k < frame.weights.size(); ++k)
    if (evaluator::RoundedWeight(frame.weights[k]) != 0.0)
      weights[rig.rig.shapes[k].name] = evaluator::RoundedWeight(frame.weights[k]);
  head = {evaluator::RoundedWeight(frame.head[0]), evaluator::RoundedWeight(frame.head[1]),
          evaluator::RoundedWeight(frame.head[2]), evaluator::RoundedWeight(frame.head[3])};
  return Status::Ok();
}

}  // namespace facespace::http
