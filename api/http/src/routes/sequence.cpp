// /v1/rigs/{id}/sequence/{sample,stream,reduce}: keyframe sequences.
#include "../http/cost.h"
#include "routes.h"

namespace facespace::http {

namespace {

// The sequence body resolved against the rig; false when an error was sent.
bool ReadSequence(const httplib::Request& req, httplib::Response& res, const Rig& rig,
                  evaluator::SequenceRequest& r, Sequence& seq) {
  if (!ReadJsonBody(req, res, evaluator::ParseSequenceRequest, r)) return false;
  auto resolved = ResolveSequence(rig, r);
  if (!resolved.ok()) {
    SendStatus(req, res, WithInputReason(resolved.status(), evaluator::kInvalidSequence));
    return false;
  }
  seq = std::move(resolved.value());
  return true;
}

double Duration(const Sequence& seq) {
  return seq.keys.empty() ? 0.0 : static_cast<double>(seq.keys.back().time) - seq.keys.front().time;
}

void Required(const httplib::Request& req, httplib::Response& res, const std::string& member,
              const std::string& what) {
  SendProblem(req, res, Problem::kInvalidRequest, "/" + member + ": is required (" + what + ")",
              {{"/" + member, "is required"}});
}

}  // namespace

void PostSequenceSample(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  evaluator::SequenceRequest r;
  Sequence seq;
  if (!stored || !ReadSequence(req, res, stored->rig, r, seq)) return;
  if (r.times.empty()) return Required(req, res, "times", "the times to sample");
  const evaluator::FrameFormat format = r.format.value_or(evaluator::FrameFormat::kJson);
  if (format != evaluator::FrameFormat::kJson && format != evaluator::FrameFormat::kWeights) {
    return SendProblem(req, res, Problem::kInvalidRequest,
                       "/format: sample as json (meshes) or weights (no meshes)",
                       {{"/format", "must be json or weights"}});
  }
  // Physics is simulated from the first key to the latest time asked for.
  const double span = static_cast<double>(*std::max_element(r.times.begin(), r.times.end())) -
                      seq.keys.front().time;
  if (!WithinBudget(ctx, req, res,
                    FramesCost(stored->rig, r.times.size(), span,
                               format != evaluator::FrameFormat::kWeights, "/times")))
    return;
  std::vector<Warning> warnings;
  const WorkspacePool::Lease ws = ctx.workspaces.Acquire(req);
  auto body =
      SampleSequenceJson(ctx.evaluator, stored, seq, r.times, r.options, warnings, *ws,
                         ctx.options.max_response, format == evaluator::FrameFormat::kWeights);
  if (!body.ok()) return SendStatus(req, res, body.status());
  ctx.metrics.CountBlends(r.times.size());
  if (!warnings.empty()) res.set_header("Facespace-Warnings", WarningsHeader(warnings));
  res.status = 200;
  res.set_content(std::move(body.value()), "application/json");
}

bool WithinFrameLimit(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                      size_t frames, const char* what, const char* over) {
  if (frames <= ctx.options.max_frames) return true;
  const std::string max = std::to_string(ctx.options.max_frames);
  SendProblem(req, res, Problem::kTooManyFrames,
              std::string("the ") + what + " would be " + std::to_string(frames) +
                  " frames (duration x fps), over this server's limit of " + max +
                  " (--max-frames)",
              {{"/fps", "at most " + max + " frames over " + over + " duration"}});
  return false;
}

void SendSequenceStream(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                        std::shared_ptr<const evaluator::StoredRig> stored,
                        std::shared_ptr<const Sequence> seq, float fps,
                        evaluator::FrameFormat format, const BlendOptions& options) {
  if (format != evaluator::FrameFormat::kNdjson && format != evaluator::FrameFormat::kF32 &&
      format != evaluator::FrameFormat::kWeights) {
    SendProblem(req, res, Problem::kInvalidRequest,
                "/format: stream as ndjson (weights, as \"weights\") or f32",
                {{"/format", "must be ndjson, weights or f32"}});
    return;
  }
  const size_t frames = evaluator::FrameCount(*seq, fps);
  if (!WithinFrameLimit(ctx, req, res, frames, "stream", "the keys'")) return;
  res.set_header("Facespace-Frames", std::to_string(frames));
  res.set_header("Cache-Control", "no-store");
  const bool f32 = format == evaluator::FrameFormat::kF32;
  // One frame per call, computed as the client reads: a client that closes stops the work.
  auto next = std::make_shared<size_t>(0);
  auto physics = std::make_shared<evaluator::SequencePhysics>(
      stored->rig, *seq);  // Carried from frame to frame.
  res.set_chunked_content_provider(
      f32 ? "application/octet-stream" : "application/x-ndjson",
      [&ctx, stored, seq, next, frames, f32, physics, fps, options, stop = net::StopOf(req),
       helper_cpu = net::HelperCpuOf(req)](size_t, httplib::DataSink& sink) {
        if (*next >= frames) {
          sink.done();
          return true;
        }
        if (stop.stop_requested()) return false;  // Gone, late, or SIGTERM: the stream ends.
        const WorkspacePool::Lease ws = ctx.workspaces.Acquire(stop, helper_cpu);
        auto chunk = StreamFrame(ctx.evaluator, stored, *seq, (*next)++, fps, f32, options, *ws,
                                 physics.get());
        if (!chunk.ok()) return false;
        if (f32) ctx.metrics.CountBlends(1);
        return sink.write(chunk->data(), chunk->size());
      });
  res.status = 200;
}

void PostSequenceStream(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  evaluator::SequenceRequest r;
  auto seq = std::make_shared<Sequence>();
  if (!stored || !ReadSequence(req, res, stored->rig, r, *seq)) return;
  const evaluator::FrameFormat format = r.format.value_or(evaluator::FrameFormat::kNdjson);
  const size_t frames = evaluator::FrameCount(*seq, r.fps);
  if (!WithinFrameLimit(ctx, req, res, frames, "stream", "the keys'") ||
      !WithinBudget(ctx, req, res,
                    FramesCost(stored->rig, frames, Duration(*seq),
                               format == evaluator::FrameFormat::kF32, "/fps"))) {
    return;
  }
  SendSequenceStream(ctx, req, res, stored, seq, r.fps, format, r.options);
}

void PostSequenceReduce(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  evaluator::SequenceRequest r;
  Sequence seq;
  if (!stored || !ReadSequence(req, res, stored->rig, r, seq)) return;
  if (!r.has_tolerance)
    return Required(req, res, "tolerance", "largest vertex error allowed, mesh units");
  if (!WithinBudget(ctx, req, res, ReduceCost(stored->rig, seq.keys.size()))) return;
  auto reduced = ReduceSequence(stored->rig, seq, r.tolerance, net::StopOf(req));
  if (!reduced.ok())
    return SendStatus(req, res, WithInputReason(reduced.status(), evaluator::kInvalidSequence));
  res.status = 200;
  res.set_content(evaluator::ReducedSequenceJson(stored->rig, seq, reduced.value(), r.tolerance),
                  "application/json");
}

}  // namespace facespace::http
