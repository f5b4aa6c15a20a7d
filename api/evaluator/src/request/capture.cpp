// Request schema of capture (a tracker's landmarks over frames, to a rig's weights).
#include <cmath>

#include "json_body.h"

namespace facespace::evaluator {

using namespace body;

namespace {

// Frames of 478 points of three numbers, and their arrays.
constexpr BodyLimits kCaptureBody{kMaxCaptureFrames * 478 * 4 + 64};

void ReadFrames(const json& v, CaptureRequest& r, Status& errors) {
  if (!v.is_array() || v.empty() || v.size() > kMaxCaptureFrames) {
    errors.AddField("/frames", "must be 1 to " + std::to_string(kMaxCaptureFrames) +
                                   " frames of [[x, y, z], ...]");
    return;
  }
  r.frames.reserve(v.size());
  for (size_t f = 0; f < v.size() && !errors.full(); ++f) {
    const std::string at = "/frames/" + std::to_string(f);
    const json& frame = v[f];
    if (!frame.is_array() || (frame.size() != 468 && frame.size() != 478)) {
      errors.AddField(at, "must be 468 or 478 points (MediaPipe's face mesh)");
      continue;
    }
    std::vector<float> points;
    points.reserve(3 * frame.size());
    for (size_t i = 0; i < frame.size(); ++i) {
      const json& p = frame[i];
      const bool ok =
          p.is_array() && p.size() == 3 && p[0].is_number() && p[1].is_number() && p[2].is_number();
      if (!ok) {
        errors.AddField(at + "/" + std::to_string(i), "must be [x, y, z], three numbers");
        break;
      }
      for (int c = 0; c < 3; ++c) points.push_back(p[c].get<float>());
    }
    r.frames.push_back(std::move(points));
  }
}

}  // namespace

Result<CaptureRequest> ParseCaptureRequest(std::string_view body) {
  CaptureRequest r;
  Status errors = InvalidArgument("");
  bool has_image = false, has_frames = false;
  const Status parsed = ReadMembers(body, kCaptureBody, [&](const std::string& key, const json& v) {
    double d = 0;
    if (key == "scheme") {
      if (v != "mediapipe-478" && v != "mediapipe-468")
        errors.AddField("/scheme", "must be mediapipe-478 or mediapipe-468");
    } else if (key == "image") {
      has_image = true;
      if (!v.is_array() || v.size() != 2 || !v[0].is_number_integer() ||
          !v[1].is_number_integer() || v[0] < 1 || v[1] < 1 || v[0] > 16384 || v[1] > 16384)
        errors.AddField("/image", "must be [width, height], 1 to 16384 pixels each");
      else
        r.image = {v[0].get<int>(), v[1].get<int>()};
    } else if (key == "fps") {
      if (ReadNumber(Body::kCapture, key, v, "/fps", &d, errors)) r.fps = static_cast<float>(d);
    } else if (key == "neutral") {
      if (ReadNumber(Body::kCapture, key, v, "/neutral", &d, errors))
        r.neutral = static_cast<size_t>(d);
    } else if (key == "frames") {
      has_frames = true;
      ReadFrames(v, r, errors);
    } else {
      UnknownMember("", key, Body::kCapture, errors);
    }
  });
  if (!parsed.ok()) return parsed;
  if (!has_image) errors.AddField("/image", "is required: [width, height]");
  if (!has_frames) errors.AddField("/frames", "is required");
  if (errors.fields.empty() && r.neutral >= r.frames.size())
    errors.AddField("/neutral", "is frame " + std::to_string(r.neutral) + " of " +
                                    std::to_string(r.frames.size()) + " (from 0)");
  if (!errors.fields.empty()) return Finish(errors);
  return r;
}

double RoundedWeight(float w) { return std::round(static_cast<double>(w) * 1e4) / 1e4; }

std::string CaptureAnswerJson(const Rig& rig, std::span<const std::vector<float>> weights,
                              std::span<const std::array<float, 4>> head, float fps,
                              size_t shapes) {
  json keys = json::array(), turns = json::array();
  for (size_t f = 0; f < weights.size(); ++f) {
    json named = json::object();
    for (size_t k = 0; k < weights[f].size(); ++k) {
      if (RoundedWeight(weights[f][k]) != 0.0)
        named[rig.shapes[k].name] = RoundedWeight(weights[f][k]);
    }
    keys.push_back({{"time", static_cast<double>(f) / fps}, {"weights", std::move(named)}});
  }
  for (const auto& q : head)
    turns.push_back(
        {RoundedWeight(q[0]), RoundedWeight(q[1]), RoundedWeight(q[2]), RoundedWeight(q[3])});
  return json{{"scheme", "mediapipe-478"}, {"fps", fps},
              {"frames", weights.size()},  {"shapes", shapes},
              {"keys", std::move(keys)},   {"head", std::move(turns)}}
      .dump();
}

}  // namespace facespace::evaluator
