// Step 1: a request's point resolved against a rig, and checked.
#include "facespace/evaluator/answers.h"
#include "facespace/evaluator/evaluator.h"
#include "facespace/formats/io.h"

namespace facespace::evaluator {

namespace {

Status Refused(const std::vector<Warning>& warnings) {
  return WithReason(
      FailedPrecondition(warnings[0].message + (warnings.size() > 1 ? " (and more)" : "")),
      kLeavesAuthoredSpace);
}

}  // namespace

void CheckPoint(const Rig& rig, BlendMode mode, ResolvedPoint& point) {
  point.report = CheckWeights(rig, point.weights, mode);
  point.weight_warnings = point.report.warnings.size();
}

namespace {

// The request's weights in this rig's own names: as they are, or retargeted from their vocabulary
// (core/retarget.h), whose expressions join the pose's.
Status OwnWeights(const Rig& rig, const MeshRequest& r, std::vector<WeightEntry>& entries,
                  PoseRequest& pose, std::vector<Warning>& warnings) {
  if (r.vocabulary == Vocabulary::kOwn) {
    entries = r.weights;
    return Status::Ok();
  }
  const std::string label =
      r.vocabulary == Vocabulary::kRig ? r.vocabulary_rig : VocabularyLabel(r.vocabulary);
  if (r.vocabulary == Vocabulary::kRig && !r.vocabulary_source) {
    Status s = InvalidArgument("vocabulary: no rig '" + r.vocabulary_rig + "' in the store");
    s.AddField("/vocabulary", "no rig '" + r.vocabulary_rig + "' in the store");
    return s;
  }
  Retargeted out;
  if (Status s =
          Retarget(rig, {r.vocabulary, r.vocabulary_source.get(), label}, r.weights, out, warnings);
      !s.ok())
    return s;
  entries = std::move(out.weights);
  pose.expressions.insert(pose.expressions.end(), out.expressions.begin(), out.expressions.end());
  return Status::Ok();
}

}  // namespace

Status ResolvePoint(const Rig& rig, const MeshRequest& r, ResolvedPoint& point) {
  std::vector<Warning> pose_warnings;
  std::vector<WeightEntry> entries;
  PoseRequest pose = r.pose;
  if (Status s = OwnWeights(rig, r, entries, pose, pose_warnings); !s.ok())
    return WithInputReason(std::move(s), kInvalidWeights);
  if (Status s = ApplyControls(rig, r.controls, entries, pose_warnings); !s.ok())
    return WithInputReason(std::move(s), kInvalidControls);
  if (Status s = ResolvePoseAndWeights(rig, entries, pose, point.weights, point.pose, point.posed,
                                       pose_warnings);
      !s.ok()) {
    return WithInputReason(std::move(s), kInvalidWeights);
  }
  CheckPoint(rig, r.options.mode, point);
  point.report.warnings.insert(point.report.warnings.end(), pose_warnings.begin(),
                               pose_warnings.end());
  if (r.strict && !point.report.warnings.empty()) return Refused(point.report.warnings);
  return Status::Ok();
}

Status ResolveSheet(const Rig& rig, const SheetRequest& request, SheetPoints& points) {
  points.cells.resize(request.cells.size());
  points.warnings.clear();
  points.max_sum = 0.0;
  MeshRequest cell = request.base.mesh;
  cell.strict = false;
  cell.controls.clear();
  for (size_t c = 0; c < request.cells.size(); ++c) {
    cell.weights = request.cells[c];
    ResolvedPoint& point = points.cells[c];
    if (Status s = ResolvePoint(rig, cell, point); !s.ok())
      return Prefixed(std::move(s), "cell " + std::to_string(c) + ": ");
    points.max_sum = std::max(points.max_sum, point.report.sum);
    // The pose's warnings (after the weights') are the same for every cell: reported once.
    const size_t shown = c == 0 ? point.report.warnings.size() : point.weight_warnings;
    for (size_t i = 0; i < shown; ++i) {
      Warning w = point.report.warnings[i];
      w.message = "cell " + std::to_string(c) + ": " + w.message;
      points.warnings.push_back(std::move(w));
    }
  }
  if (request.base.mesh.strict && !points.warnings.empty()) return Refused(points.warnings);
  return Status::Ok();
}

std::string WeightsMapJson(const Rig& rig, std::span<const float> w) {
  std::string out = "{";
  for (size_t k = 0; k < w.size(); ++k) {
    if (w[k] == 0.0f) continue;
    if (out.size() > 1) out += ',';
    out += formats::JsonString(rig.shapes[k].name) + ":" + FormatNumber(w[k]);
  }
  return out + "}";
}

std::string CheckJson(const Rig& rig, const ResolvedPoint& point) {
  const WeightReport& r = point.report;
  std::string out;
  AnswerWriter<Answer::kCheck> w(out);
  w.Number("sum", r.sum).Raw("weights", WeightsMapJson(rig, point.weights));
  if (r.mahalanobis >= 0) w.Number("mahalanobis", r.mahalanobis);
  if (r.vertex_sum > 0.0) {  // Beside a sum above 1: the most one vertex takes, and which stack.
    std::string names = "[";
    for (size_t k = 0; k < r.stacked_shapes.size(); ++k)
      names += (k ? "," : "") + formats::JsonString(rig.shapes[r.stacked_shapes[k]].name);
    w.Number("vertex_sum", r.vertex_sum).Raw("stacked", names + "]");
  }
  return w.Raw("warnings", formats::WarningsToJson(r.warnings)).End();
}

}  // namespace facespace::evaluator
