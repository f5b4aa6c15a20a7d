// /v1/rigs/{id}/capture: a face tracker's landmarks over frames (MediaPipe's face mesh, from a
// recorded video) as this rig's weights, the keys of a sequence (core/derive/capture.h).
#include "facespace/derive/capture.h"

#include <cmath>

#include "../http/cost.h"
#include "routes.h"

namespace facespace::http {

void PostCapture(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  evaluator::CaptureRequest r;
  if (!stored || !ReadJsonBody(req, res, evaluator::ParseCaptureRequest, r)) return;
  const bool registered = ctx.landmark_maps.Has(*stored);
  if (!WithinBudget(ctx, req, res, CaptureCost(stored->rig, r.frames.size(), registered))) return;
  const std::stop_token stop = net::StopOf(req);
  const auto t0 = std::chrono::steady_clock::now();
  auto map = ctx.landmark_maps.Get(*stored, stop);
  if (!map.ok()) {
    // The registration's fields name a derive's members (/target, /from): here it is the rig in
    // the path whose face the landmarks do not fit, which the message says.
    Status s = map.status();
    s.fields.clear();
    s.message = "MediaPipe's face could not be laid on this rig's: " + s.message;
    return SendStatus(req, res, s);
  }
  const double register_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  derive::CaptureOptions o;
  o.fps = r.fps;
  o.neutral = r.neutral;
  o.stop = stop;
  auto captured = derive::SolveFrames(*map.value(), r.frames, o);
  if (!captured.ok()) return SendStatus(req, res, captured.status());
  const derive::Captured& c = captured.value();
  char timing[160];
  std::snprintf(timing, sizeof timing,
                "solve;dur=%.3f;desc=\"per frame\", register;dur=%.1f;desc=\"%s\"",
                1e3 * c.solve_seconds / static_cast<double>(std::max<size_t>(r.frames.size(), 1)),
                registered ? 0.0 : register_ms, registered ? "kept" : "landmarks onto the rig");
  res.set_header("Server-Timing", timing);
  res.status = 200;
  res.set_content(evaluator::CaptureAnswerJson(stored->rig, c.weights, c.head, r.fps,
                                               map.value()->shapes.size()),
                  "application/json");
}

}  // namespace facespace::http
