#include "facespace/batch/plan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "facespace/batch/dataset.h"

namespace facespace::batch {

using nlohmann::json;

namespace {

// A field error of the dataset members.
Status DatasetError(const std::string& pointer, const std::string& message) {
  Status s = InvalidArgument(pointer + ": " + message);
  s.fields.push_back({pointer, message});
  return s;
}

// The dataset's part of the plan: labels the rig can give, the segments, the seed of the draws, the
// randomised face tried once (an unknown expression is the request's fault, said now), the pose
// members.
Status PlanDataset(const json& request, BatchPlan& plan) {
  const evaluator::DatasetRequest& d = plan.request.dataset;
  if (!d.labelled()) return Status::Ok();
  const Rig& rig = plan.rig->rig;
  if (d.has(evaluator::Label::kLandmarks) && rig.landmarks.empty()) {
    return DatasetError("/labels", "the rig '" + rig.name +
                                       "' has no landmarks (its manifest's \"landmarks\" names "
                                       "none): leave \"landmarks\" out");
  }
  if (d.has(evaluator::Label::kLandmarks) && plan.output.lod != 0)
    return DatasetError("/lod", "landmarks are on the full mesh: lod must be 0");
  SegmentsOf(rig, plan.segment_of_primitive, plan.segment_names);
  const evaluator::Randomization& r = d.randomize;
  plan.draw_seed = r.seeded ? r.seed : plan.request.sampled ? plan.request.sample.seed : 1;
  PoseRequest bare = plan.request.render.mesh.pose;
  bare.expressions.clear();
  bare.gaze.reset();
  Pose pose;
  bool posed = false;
  std::vector<Warning> warnings;
  if (Status s = ResolvePoseAndWeights(rig, {}, bare, plan.bare_weights, pose, posed, warnings);
      !s.ok())
    return s;
  PoseRequest face = plan.request.render.mesh.pose;
  for (const auto& [name, strength] : r.expressions)
    face.expressions.push_back({name, -1, strength.hi, "/randomize/expressions/" + name});
  if (r.gaze_yaw || r.gaze_pitch) face.gaze = Gaze{};
  std::vector<float> tried;
  if (Status s = ResolvePoseAndWeights(rig, {}, face, tried, pose, posed, warnings); !s.ok())
    return s;
  json members = json::object();
  for (const char* key :
       {"pose", "animation", "motion", "time", "frame", "loop", "blend", "layers"}) {
    if (request.contains(key)) members[key] = request[key];
  }
  plan.pose_json = members.dump(-1, ' ', false, json::error_handler_t::replace);
  return Status::Ok();
}

}  // namespace

Result<BatchPlan> MakeBatchPlan(std::shared_ptr<const evaluator::StoredRig> owned,
                                std::string_view request_json) {
  auto request = evaluator::ParseBatchRequest(request_json);
  if (!request.ok()) return request.status();
  const Rig& rig = owned->rig;
  const std::string rig_version = owned->version;
  BatchPlan plan;
  plan.rig = std::move(owned);
  plan.request = std::move(request.value());
  if (plan.request.sampled) {
    auto spec = evaluator::ResolveSampleSpec(rig, plan.request);
    if (!spec.ok()) return spec.status();
    plan.sample = std::move(spec.value());
    plan.total = SampleCount(plan.sample, rig.shapes.size());
  } else {
    for (const auto& v : plan.request.variants) {
      auto w = ResolveWeights(rig, v.weights);
      if (!w.ok()) return w.status();
      plan.weights.push_back(std::move(w.value()));
    }
    plan.total = plan.weights.size();
  }
  // The face's part of the weights: with it less without it (a clip's weight channels stay out, as
  // ever).
  if (plan.request.render.mesh.pose.has_face()) {
    PoseRequest bare = plan.request.render.mesh.pose;
    bare.expressions.clear();
    bare.gaze.reset();
    std::vector<float> without;
    Pose unused_pose;
    bool unused_posed = false;
    std::vector<Warning> unused_warnings;
    if (Status s = ResolvePoseAndWeights(rig, {}, bare, without, unused_pose, unused_posed,
                                         unused_warnings);
        !s.ok())
      return s;
    plan.face_weights = std::move(without);
  }
  std::vector<float> with;
  if (Status s = ResolvePoseAndWeights(rig, {}, plan.request.render.mesh.pose, with, plan.pose,
                                       plan.posed, plan.pose_warnings);
      !s.ok()) {
    return s;
  }
  for (size_t k = 0; k < plan.face_weights.size(); ++k)
    plan.face_weights[k] = with[k] - plan.face_weights[k];
  json spec = {{"request", json::parse(request_json, nullptr, false)},
               {"rig", rig.name},
               {"rig_version", rig_version}};
  plan.spec_json = spec.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
  const evaluator::BatchRequest& r = plan.request;
  plan.output = r.image ? evaluator::OutputSpec::Image(r.render, r.image_format)
                        : evaluator::OutputSpec::Mesh(r.render.mesh, r.mesh_format);
  plan.output.pieces = true;
  if (Status s = PlanDataset(spec["request"], plan); !s.ok()) return s;
  return plan;
}

std::string VariantId(const BatchPlan& plan, size_t index) {
  if (!plan.request.sampled && !plan.request.variants[index].id.empty())
    return plan.request.variants[index].id;
  char buf[32];
  std::snprintf(buf, sizeof buf, "v%06zu", index);
  return buf;
}

std::string VariantFile(const BatchPlan& plan, size_t index) {
  return VariantId(plan, index) + "." + plan.request.format;
}

void VariantWeights(const BatchPlan& plan, size_t index, evaluator::ResolvedPoint& point) {
  const Rig& rig = plan.rig->rig;
  point.weights.resize(rig.shapes.size());
  if (plan.request.sampled)
    SampleVariant(rig, plan.sample, index, point.weights);
  else
    std::copy(plan.weights[index].begin(), plan.weights[index].end(), point.weights.begin());
  for (size_t s = 0; s < plan.face_weights.size() && s < point.weights.size(); ++s)
    point.weights[s] += plan.face_weights[s];
  point.pose = plan.pose;  // Same sizes every time: no allocation once warm.
  point.posed = plan.posed;
}

void VariantPoint(const BatchPlan& plan, size_t index, evaluator::ResolvedPoint& point) {
  VariantWeights(plan, index, point);
  evaluator::CheckPoint(plan.rig->rig, plan.request.render.mesh.options.mode, point);
  point.report.warnings.insert(point.report.warnings.end(), plan.pose_warnings.begin(),
                               plan.pose_warnings.end());
}

Result<std::string> VariantSheet(const BatchPlan& plan, std::span<const size_t> indices,
                                 const evaluator::Evaluator& evaluator, evaluator::Workspace& ws) {
  std::vector<evaluator::ResolvedPoint> cells(indices.size());
  evaluator::OutputSpec spec =
      evaluator::OutputSpec::Image(plan.request.render, picture::ImageFormat::kPng);
  spec.kind = evaluator::OutputSpec::Kind::kSheet;
  spec.quality = 90;
  for (size_t i = 0; i < indices.size(); ++i) {
    VariantPoint(plan, indices[i], cells[i]);
    spec.labels.push_back(VariantId(plan, indices[i]));
  }
  spec.render.width = spec.render.height = 256;
  spec.render.supersample = std::min(spec.render.supersample, 2);
  spec.columns = cells.size() >= 16
                     ? 4
                     : static_cast<int>(std::ceil(std::sqrt(static_cast<double>(cells.size()))));
  auto png = evaluator.Run(plan.rig, cells, spec, ws);
  if (!png.ok()) return png.status();
  return std::move(png->bytes);
}

}  // namespace facespace::batch
