// Keyframe sequences: frames as points, sampled and streamed through the evaluator; keys as JSON.
#include <cmath>

#include "facespace/engine/hierarchy.h"
#include "facespace/evaluator/answers.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/formats/io.h"
#include "facespace/physics/physics.h"

namespace facespace::evaluator {

bool SequencePose(const Rig& rig, const Sequence& sequence, float time, Pose& pose,
                  std::vector<float>& weights) {
  FaceState face;
  const bool has_face = SampleFace(sequence, time, face);
  std::vector<Warning> warnings;  // A face the rig cannot show was said once, by ResolveSequence.
  if (sequence.clip < 0 && sequence.layers.empty()) {
    return has_face ? PoseOfFaceAndWeights(rig, face, weights, pose, warnings)
                    : PoseOfWeightsAlone(rig, weights, pose);
  }
  // The clip's pose and weights at this time: its curves as it draws them (the keys are its weight
  // channel's keys; between them a curve need not be linear).
  PoseRequest request;
  if (sequence.clip >= 0) {
    ClipRequest clip;
    clip.index = sequence.clip;
    clip.time = time;
    clip.pointer = "/motion";
    clip.over_base = true;
    request.clips.push_back(clip);
  }
  for (const ClipRequest& layer : sequence.layers) {
    request.clips.push_back(layer);
    request.clips.back().time = time - layer.time;  // A layer's time is its start in the sequence.
  }
  std::vector<float> animated;
  std::vector<uint8_t> set;
  if (!BuildPose(rig, request, pose, animated, set, warnings, false).ok()) return false;
  for (size_t i = 0; i < set.size() && i < weights.size(); ++i) {
    if (set[i]) weights[i] = animated[i];
  }
  bool posed = true;
  if (has_face) ApplyFace(rig, face, weights, pose, posed, warnings);
  FinishPose(rig, weights, pose);
  return true;
}

SequencePhysics::SequencePhysics(const Rig& rig, const Sequence& sequence)
    : rig_(rig),
      sequence_(sequence),
      active_(sequence.physics && !rig.physics.empty() &&
              (sequence.clip >= 0 || !sequence.layers.empty()) && !sequence.keys.empty()) {}

SequencePhysics::~SequencePhysics() = default;

void SequencePhysics::Apply(float time, Pose& pose, std::vector<Warning>& warnings) {
  if (!active_ || !std::isfinite(time)) return;
  const float start = sequence_.keys.front().time;
  const long long last = static_cast<long long>(kMaxSeconds * kStepsPerSecond);
  const double wanted = std::min(std::max(0.0, static_cast<double>(time) - start) * kStepsPerSecond,
                                 static_cast<double>(last + 1));
  long long step = std::llround(wanted);
  if (step > last) {
    warnings.push_back({"physics_limited",
                        "physics is simulated for the first " + FormatNumber(kMaxSeconds) +
                            " s of a sequence; later frames hold its last step",
                        "", kMaxSeconds, true});
    step = last;
  }
  if (step == 0) return;  // The first frame: the bodies start where their bones are.
  if ((!sim_ || step < step_ ? step : step - step_) > budget_) {
    warnings.push_back(
        {"physics_limited",
         "this request's times go back and forth past the physics it may simulate (" +
             FormatNumber(kMaxSeconds) + " s in all): this frame is not simulated",
         "", kMaxSeconds, true});
    return;
  }
  if (!sim_ || step < step_) {
    if (!TickPose(start)) return;
    sim_ = physics::Simulation::Create(rig_, scratch_);
    step_ = 0;
    if (!sim_) {
      active_ = false;
      return;
    }
  }
  for (; step_ < step; ++step_, --budget_) {
    if (!TickPose(start + static_cast<float>(static_cast<double>(step_ + 1) / kStepsPerSecond)))
      return;
    sim_->Step(scratch_, 1.0f / kStepsPerSecond);
  }
  sim_->Apply(pose);
}

bool SequencePhysics::TickPose(float time) {
  weights_.resize(rig_.shapes.size());
  SampleSequence(sequence_, time, weights_);
  return SequencePose(rig_, sequence_, time, scratch_, weights_);
}

void SequencePoint(const Rig& rig, const Sequence& sequence, float time, BlendMode mode,
                   ResolvedPoint& point, SequencePhysics* physics) {
  point.weights.resize(rig.shapes.size());
  point.posed = false;
  point.report.warnings.clear();
  float f = 0.0f;
  SampleSequence(sequence, time, point.weights, &f);
  point.posed = SequencePose(rig, sequence, time, point.pose, point.weights);
  std::vector<Warning> physics_warnings;
  if (point.posed && physics) physics->Apply(time, point.pose, physics_warnings);
  CheckPoint(rig, mode, point);
  point.report.warnings.insert(point.report.warnings.end(), physics_warnings.begin(),
                               physics_warnings.end());
  const std::string at = "t=" + FormatNumber(time) + ": ";
  for (Warning& w : point.report.warnings) w.message = at + w.message;
  if (f < 0.0f || f > 1.0f) {
    point.report.warnings.insert(
        point.report.warnings.begin(),
        {"transition_extrapolation",
         at + "the transition gives " + FormatNumber(f) + ", outside [0, 1]", "", f, true});
  }
}

namespace {

// The nodes a pose moves from their rest (local translation, rotation x y z w, scale), by name:
// what a client that blends and skins on the GPU needs besides the weights.
std::string PoseJson(const Rig& rig, const Pose& pose, const Pose& rest) {
  std::string out = "{";
  bool first = true;
  auto vec = [](const float* v, int n) {
    std::string s = "[";
    for (int k = 0; k < n; ++k) s += (k ? "," : "") + FormatNumber(v[k]);
    return s + "]";
  };
  for (size_t n = 0; n < rig.nodes.size() && n < pose.local.size() && n < rest.local.size(); ++n) {
    const Transform& a = pose.local[n];
    const Transform& b = rest.local[n];
    const bool moved = a.translation != b.translation || a.rotation != b.rotation ||
                       a.scale != b.scale ||
                       (n < pose.from_matrix.size() && n < rest.from_matrix.size() &&
                        pose.from_matrix[n] != rest.from_matrix[n]);
    if (!moved) continue;
    out += std::string(first ? "" : ",") +
           formats::JsonString(rig.nodes[n].name.empty() ? "node" + std::to_string(n)
                                                         : rig.nodes[n].name) +
           ":";
    AnswerWriter<Answer::kPosedJoint>(out)
        .Raw("translation", vec(a.translation.data(), 3))
        .Raw("rotation", vec(a.rotation.data(), 4))
        .Raw("scale", vec(a.scale.data(), 3))
        .End();
    first = false;
  }
  return out + "}";
}

}  // namespace

Result<std::string> SampleSequenceJson(const Evaluator& evaluator,
                                       const std::shared_ptr<const StoredRig>& stored,
                                       const Sequence& sequence, std::span<const float> times,
                                       const BlendOptions& options, std::vector<Warning>& warnings,
                                       Workspace& ws, size_t max_bytes, bool weights_only) {
  const Rig& rig = stored->rig;
  const OutputSpec spec = OutputSpec::Frame(options, false);
  ResolvedPoint point;
  SequencePhysics physics(rig, sequence);
  const Pose rest = weights_only ? RestPose(rig) : Pose{};
  // Positions and normals placed by each primitive's node, as blend's JSON; or the weights and pose
  // alone.
  std::string out;
  AnswerWriter<Answer::kSequenceFrames> answer(out);
  if (weights_only) answer.Raw("format", "\"weights\"");
  if (!weights_only) answer.Raw("space", "\"world\"");
  answer.Open("frames") += '[';
  warnings.insert(warnings.end(), sequence.warnings.begin(), sequence.warnings.end());
  for (size_t i = 0; i < times.size(); ++i) {
    if (ws.stop.stop_requested()) return Cancelled();
    SequencePoint(rig, sequence, times[i], options.mode, point, &physics);
    warnings.insert(warnings.end(), point.report.warnings.begin(), point.report.warnings.end());
    if (i) out += ',';
    AnswerWriter<Answer::kFrame> frame(out);
    frame.Number("time", times[i]).Raw("weights", WeightsMapJson(rig, point.weights));
    if (weights_only) {
      if (point.posed) frame.Raw("pose", PoseJson(rig, point.pose, rest));
      frame.Number("sum", point.report.sum);
    } else {
      auto primitives = evaluator.Run(stored, point, spec, ws);
      if (!primitives.ok()) return primitives.status();
      frame.Raw("primitives", primitives->bytes);
    }
    frame.End();
    const double expected =
        i == 0 ? static_cast<double>(out.size()) * static_cast<double>(times.size())
               : static_cast<double>(out.size());
    if (expected > static_cast<double>(max_bytes)) {
      const auto mb = [](double bytes) { return FormatNumber(std::round(bytes / 1e5) / 10); };
      Status s = InvalidArgument(
          "the response would be about " + mb(expected) + " MB (" + std::to_string(times.size()) +
          " frames), over this server's limit of " + mb(static_cast<double>(max_bytes)) +
          " MB (--max-response): ask for fewer times, or stream the frames (sequence/stream, "
          "ndjson or f32)");
      s.fields.push_back(
          {"/times",
           "at most about " +
               std::to_string(std::max<size_t>(
                   1, static_cast<size_t>(
                          static_cast<double>(max_bytes) /
                          (expected / static_cast<double>(i == 0 ? times.size() : i + 1))))) +
               " times for this rig"});
      return WithReason(std::move(s), kResponseTooLarge);
    }
  }
  out += ']';
  return answer.Raw("warnings", formats::WarningsToJson(warnings)).End() + "\n";
}

size_t FrameCount(const Sequence& sequence, float fps) {
  const double duration = sequence.keys.back().time - sequence.keys.front().time;
  return static_cast<size_t>(std::floor(duration * fps + 1e-6)) + 1;
}

Result<std::string> StreamFrame(const Evaluator& evaluator,
                                const std::shared_ptr<const StoredRig>& stored,
                                const Sequence& sequence, size_t frame, float fps, bool f32,
                                const BlendOptions& options, Workspace& ws,
                                SequencePhysics* physics) {
  const Rig& rig = stored->rig;
  const float t = sequence.keys.front().time + static_cast<float>(frame) / fps;
  ResolvedPoint point;
  SequencePoint(rig, sequence, t, options.mode, point, physics);
  if (frame == 0)
    point.report.warnings.insert(point.report.warnings.begin(), sequence.warnings.begin(),
                                 sequence.warnings.end());
  if (!f32) {
    std::string line;
    AnswerWriter<Answer::kStreamFrame>(line)
        .Count("frame", frame)
        .Number("time", t)
        .Raw("weights", WeightsMapJson(rig, point.weights))
        .Raw("warnings", formats::WarningsToJson(point.report.warnings))
        .End();
    return line + "\n";
  }
  auto chunk = evaluator.Run(stored, point, OutputSpec::Frame(options, true), ws);
  if (!chunk.ok()) return chunk.status();
  return std::move(chunk->bytes);
}

std::string SequenceKeysJson(const Rig& rig, const Sequence& sequence) {
  std::string out = "[";
  for (size_t i = 0; i < sequence.keys.size(); ++i) {
    const Keyframe& k = sequence.keys[i];
    if (i) out += ',';
    AnswerWriter<Answer::kSequenceKey> key(out);
    key.Number("time", k.time).Raw("weights", WeightsMapJson(rig, k.weights));
    if (k.transition) key.Raw("transition", formats::JsonString(TransitionName(*k.transition)));
    key.End();
  }
  return out + "]";
}

std::string ReducedSequenceJson(const Rig& rig, const Sequence& original,
                                const ReduceResult& reduced, float tolerance) {
  std::string out;
  AnswerWriter<Answer::kReduced>(out)
      .Raw("keys", SequenceKeysJson(rig, reduced.sequence))
      .Raw("transition", formats::JsonString(TransitionName(original.transition)))
      .Count("kept", reduced.sequence.keys.size())
      .Count("removed", reduced.removed)
      .Number("max_error", reduced.max_error)
      .Number("tolerance", tolerance)
      .End();
  return out + "\n";
}

}  // namespace facespace::evaluator
