#include "facespace/api/pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

namespace facespace::api {

namespace {

using nlohmann::json;

std::string JsonString(const std::string& s) { return json(s).dump(-1, ' ', false, json::error_handler_t::replace); }

// Adds the milliseconds since `start` to `total`, and restarts the clock.
void Lap(std::chrono::steady_clock::time_point& start, double& total) {
  const auto now = std::chrono::steady_clock::now();
  total += std::chrono::duration<double, std::milli>(now - start).count();
  start = now;
}

// The rig evaluated at `point` into ws.blended. The point was checked: a failure here is ours.
Status Evaluate(const Rig& rig, const Point& point, BlendOptions options, Workspace& ws) {
  auto start = std::chrono::steady_clock::now();
  options.pose = point.pose_or_null();
  if (Status s = EvaluateRig(rig, point.weights, options, ws.blended, ws.context); !s.ok()) {
    return Internal("the blend failed: " + s.message);
  }
  Lap(start, ws.timing.blend);
  return Status::Ok();
}

Status Refused(const std::vector<Warning>& warnings) {
  return WithReason(FailedPrecondition(warnings[0].message + (warnings.size() > 1 ? " (and more)" : "")), kLeavesAuthoredSpace);
}

}  // namespace

// ---- step 1 -------------------------------------------------------------------------------

void CheckPoint(const Rig& rig, BlendMode mode, Point& point) {
  point.report = CheckWeights(rig, point.weights, mode);
  point.weight_warnings = point.report.warnings.size();
}

Status ResolvePoint(const Rig& rig, const MeshRequest& r, Point& point) {
  std::vector<Warning> pose_warnings;
  std::vector<WeightEntry> entries = r.weights;
  if (Status s = ApplyControls(rig, r.controls, entries, pose_warnings); !s.ok()) return WithReason(std::move(s), kInvalidControls);
  if (Status s = ResolvePoseAndWeights(rig, entries, r.pose, point.weights, point.pose, point.posed, pose_warnings); !s.ok()) {
    return WithReason(std::move(s), kInvalidWeights);
  }
  CheckPoint(rig, r.options.mode, point);
  point.report.warnings.insert(point.report.warnings.end(), pose_warnings.begin(), pose_warnings.end());
  if (r.strict && !point.report.warnings.empty()) return Refused(point.report.warnings);
  return Status::Ok();
}

// ---- step 2 -------------------------------------------------------------------------------

Result<GlbVariantWriter::Pieces> EncodeGlb(const Rig& rig, const Point& point, const MeshRequest& request, Workspace& ws,
                                           GlbVariantWriter& glb) {
  if (Status s = Evaluate(rig, point, request.options, ws); !s.ok()) return s;
  auto start = std::chrono::steady_clock::now();
  ExportOptions options;
  options.keep_targets = request.keep_targets;
  auto pieces = glb.Write(rig, ws.blended, point.weights, point.report.warnings, options);
  if (!pieces.ok()) return Prefixed(pieces.status(), "the export failed: ");
  Lap(start, ws.timing.encode);
  return pieces;
}

Result<std::string> EncodeMesh(const Rig& rig, const Point& point, const MeshRequest& request, MeshFormat format,
                               Workspace& ws, GlbVariantWriter* glb, const F32Blender* f32) {
  if (f32 && format == MeshFormat::kF32 && f32->mesh_space() == request.mesh_space && !point.pose_or_null() &&
      F32Blender::Serves(rig, request.options)) {
    auto start = std::chrono::steady_clock::now();
    std::string bytes = std::move(ws.body);
    if (f32->Write(rig, point.weights, ws.f32, bytes)) {
      Lap(start, ws.timing.blend);
      return bytes;
    }
    ws.body = std::move(bytes);
  }
  if (glb && format == MeshFormat::kGlb) {
    auto pieces = EncodeGlb(rig, point, request, ws, *glb);
    if (!pieces.ok()) return pieces.status();
    std::string bytes;
    bytes.reserve(pieces->head.size() + pieces->bin.size());
    return bytes.append(pieces->head).append(pieces->bin);
  }
  if (Status s = Evaluate(rig, point, request.options, ws); !s.ok()) return s;
  auto start = std::chrono::steady_clock::now();
  ExportOptions options;
  options.keep_targets = request.keep_targets;
  options.mesh_space = request.mesh_space;
  auto bytes = ExportMesh(rig, ws.blended, point.weights, point.report.warnings, format, options);
  if (!bytes.ok()) return Prefixed(bytes.status(), "the export failed: ");
  Lap(start, ws.timing.encode);
  return bytes;
}

Result<std::string> EncodeImage(const Rig& rig, const Point& point, const RenderRequest& request,
                                render::ImageFormat format, const render::Renderer& renderer, Workspace& ws) {
  if (Status s = Evaluate(rig, point, request.mesh.options, ws); !s.ok()) return s;
  auto start = std::chrono::steady_clock::now();
  render::RenderOptions options = request.render;
  options.srgb8 = format != render::ImageFormat::kExr;  // An 8-bit file: drawn straight into 8 bits.
  if (Status s = renderer.Draw(rig, ws.blended, options, ws.image); !s.ok()) return Prefixed(s, "the render failed: ");
  Lap(start, ws.timing.draw);
  auto bytes = render::Encode(ws.image, format, request.quality);
  Lap(start, ws.timing.encode);
  return bytes;
}

// ---- sheets -------------------------------------------------------------------------------

Status ResolveSheet(const Rig& rig, const SheetRequest& request, SheetPoints& points) {
  points.cells.resize(request.cells.size());
  points.warnings.clear();
  points.max_sum = 0.0;
  MeshRequest cell = request.base.mesh;
  cell.strict = false;
  cell.controls.clear();
  for (size_t c = 0; c < request.cells.size(); ++c) {
    cell.weights = request.cells[c];
    Point& point = points.cells[c];
    if (Status s = ResolvePoint(rig, cell, point); !s.ok()) return Prefixed(std::move(s), "cell " + std::to_string(c) + ": ");
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

Result<std::string> EncodeGrid(const Rig& rig, std::span<const Point> cells, std::span<const std::string> labels,
                               int columns, const render::RenderOptions& options, const BlendOptions& blend,
                               render::ImageFormat format, int quality, const render::Renderer& renderer, Workspace& ws) {
  ws.cells.resize(cells.size());
  for (size_t c = 0; c < cells.size(); ++c) {
    if (Status s = Evaluate(rig, cells[c], blend, ws); !s.ok()) return s;
    auto start = std::chrono::steady_clock::now();
    if (Status s = renderer.Draw(rig, ws.blended, options, ws.cells[c]); !s.ok()) return Prefixed(s, "the render failed: ");
    Lap(start, ws.timing.draw);
  }
  auto start = std::chrono::steady_clock::now();
  auto bytes = render::Encode(render::ContactSheet(ws.cells, labels, columns, options.background), format, quality);
  Lap(start, ws.timing.encode);
  // A workspace is kept for the next request: it keeps no large sheet's images.
  size_t pixels = 0;
  for (const render::Image& c : ws.cells) pixels += static_cast<size_t>(c.width) * static_cast<size_t>(c.height);
  if (pixels > (size_t{1} << 20)) std::vector<render::Image>().swap(ws.cells);
  return bytes;
}

Result<std::string> EncodeSheet(const Rig& rig, const SheetPoints& points, const SheetRequest& request,
                                render::ImageFormat format, const render::Renderer& renderer, Workspace& ws) {
  return EncodeGrid(rig, points.cells, request.labels, request.columns, request.base.render, request.base.mesh.options,
                    format, request.base.quality, renderer, ws);
}

// ---- one call -----------------------------------------------------------------------------

namespace {

Result<Output> Finish(Result<std::string> bytes, const char* content_type, std::vector<Warning> warnings, double sum) {
  if (!bytes.ok()) return bytes.status();
  return Output{std::move(bytes.value()), content_type, std::move(warnings), sum};
}

}  // namespace

Result<Output> ProduceMesh(const Rig& rig, const MeshRequest& request, MeshFormat format, Workspace& ws) {
  Point point;
  if (Status s = ResolvePoint(rig, request, point); !s.ok()) return s;
  return Finish(EncodeMesh(rig, point, request, format, ws), MeshFormatMimeType(format), point.report.warnings, point.report.sum);
}

Result<Output> ProduceImage(const Rig& rig, const RenderRequest& request, render::ImageFormat format,
                            const render::Renderer& renderer, Workspace& ws) {
  Point point;
  if (Status s = ResolvePoint(rig, request.mesh, point); !s.ok()) return s;
  return Finish(EncodeImage(rig, point, request, format, renderer, ws), render::ImageFormatMimeType(format),
                point.report.warnings, point.report.sum);
}

Result<Output> ProduceSheet(const Rig& rig, const SheetRequest& request, render::ImageFormat format,
                            const render::Renderer& renderer, Workspace& ws) {
  SheetPoints points;
  if (Status s = ResolveSheet(rig, request, points); !s.ok()) return s;
  return Finish(EncodeSheet(rig, points, request, format, renderer, ws), render::ImageFormatMimeType(format), points.warnings,
                points.max_sum);
}

// ---- weights only -------------------------------------------------------------------------

std::string WeightsMapJson(const Rig& rig, std::span<const float> w) {
  std::string out = "{";
  for (size_t k = 0; k < w.size(); ++k) {
    if (w[k] == 0.0f) continue;
    if (out.size() > 1) out += ',';
    out += JsonString(rig.shapes[k].name) + ":" + FormatNumber(w[k]);
  }
  return out + "}";
}

std::string CheckJson(const Rig& rig, const Point& point) {
  const WeightReport& r = point.report;
  return "{\"sum\":" + FormatNumber(r.sum) + ",\"weights\":" + WeightsMapJson(rig, point.weights) +
         (r.mahalanobis >= 0 ? ",\"mahalanobis\":" + FormatNumber(r.mahalanobis) : std::string()) +
         ",\"warnings\":" + WarningsToJson(r.warnings) + "}";
}

// ---- sequences ----------------------------------------------------------------------------

void SequencePoint(const Rig& rig, const Sequence& sequence, float time, BlendMode mode, Point& point) {
  point.weights.resize(rig.shapes.size());
  point.posed = false;
  float f = 0.0f;
  SampleSequence(sequence, time, point.weights, &f);
  if (sequence.clip >= 0) {
    // The clip's pose at this time (its weight channel is the sequence's keys).
    PoseRequest request;
    ClipRequest clip;
    clip.index = sequence.clip;
    clip.time = time;
    clip.pointer = "/motion";
    request.clips.push_back(clip);
    std::vector<float> animated;
    std::vector<uint8_t> set;
    std::vector<Warning> warnings;
    point.posed = BuildPose(rig, request, point.pose, animated, set, warnings).ok();
  }
  CheckPoint(rig, mode, point);
  const std::string at = "t=" + FormatNumber(time) + ": ";
  for (Warning& w : point.report.warnings) w.message = at + w.message;
  if (f < 0.0f || f > 1.0f) {
    point.report.warnings.insert(point.report.warnings.begin(),
                                 {"transition_extrapolation", at + "the transition gives " + FormatNumber(f) + ", outside [0, 1]", "", f, true});
  }
}

Result<std::string> SampleSequenceJson(const Rig& rig, const Sequence& sequence, std::span<const float> times,
                                       const BlendOptions& options, std::vector<Warning>& warnings, Workspace& ws,
                                       size_t max_bytes) {
  Point point;
  std::string out = "{\"frames\":[";
  for (size_t i = 0; i < times.size(); ++i) {
    SequencePoint(rig, sequence, times[i], options.mode, point);
    warnings.insert(warnings.end(), point.report.warnings.begin(), point.report.warnings.end());
    if (Status s = Evaluate(rig, point, options, ws); !s.ok()) return s;
    out += std::string(i ? "," : "") + "{\"time\":" + FormatNumber(times[i]) + ",\"weights\":" + WeightsMapJson(rig, point.weights) +
           ",\"primitives\":" + PrimitivesJson(rig, ws.blended) + "}";
    const double expected = i == 0 ? static_cast<double>(out.size()) * static_cast<double>(times.size()) : static_cast<double>(out.size());
    if (expected > static_cast<double>(max_bytes)) {
      const auto mb = [](double bytes) { return FormatNumber(std::round(bytes / 1e5) / 10); };
      Status s = InvalidArgument("the response would be about " + mb(expected) + " MB (" + std::to_string(times.size()) +
                                 " frames), over this server's limit of " + mb(static_cast<double>(max_bytes)) +
                                 " MB (--max-response): ask for fewer times, or stream the frames (sequence/stream, ndjson or f32)");
      s.fields.push_back({"/times", "at most about " + std::to_string(std::max<size_t>(1, static_cast<size_t>(static_cast<double>(max_bytes) / (expected / static_cast<double>(i == 0 ? times.size() : i + 1))))) + " times for this rig"});
      return WithReason(std::move(s), kResponseTooLarge);
    }
  }
  return out + "],\"warnings\":" + WarningsToJson(warnings) + "}\n";
}

size_t FrameCount(const Sequence& sequence, float fps) {
  const double duration = sequence.keys.back().time - sequence.keys.front().time;
  return static_cast<size_t>(std::floor(duration * fps + 1e-6)) + 1;
}

Result<std::string> StreamFrame(const Rig& rig, const Sequence& sequence, size_t frame, float fps, bool f32,
                                const BlendOptions& options, Workspace& ws) {
  const float t = sequence.keys.front().time + static_cast<float>(frame) / fps;
  Point point;
  SequencePoint(rig, sequence, t, options.mode, point);
  if (!f32) {
    return "{\"frame\":" + std::to_string(frame) + ",\"time\":" + FormatNumber(t) + ",\"weights\":" + WeightsMapJson(rig, point.weights) +
           ",\"warnings\":" + WarningsToJson(point.report.warnings) + "}\n";
  }
  if (Status s = Evaluate(rig, point, options, ws); !s.ok()) return s;
  std::vector<float> pos;
  WorldPositions(ws.blended, pos);
  const uint32_t bytes = static_cast<uint32_t>(pos.size() * 4);
  std::string chunk(4 + bytes, '\0');
  std::memcpy(chunk.data(), &bytes, 4);
  std::memcpy(chunk.data() + 4, pos.data(), bytes);
  return chunk;
}

std::string SequenceKeysJson(const Rig& rig, const Sequence& sequence) {
  std::string out = "[";
  for (size_t i = 0; i < sequence.keys.size(); ++i) {
    const Keyframe& k = sequence.keys[i];
    out += std::string(i ? "," : "") + "{\"time\":" + FormatNumber(k.time) + ",\"weights\":" + WeightsMapJson(rig, k.weights);
    if (k.transition) out += ",\"transition\":" + JsonString(TransitionName(*k.transition));
    out += "}";
  }
  return out + "]";
}

std::string ReducedSequenceJson(const Rig& rig, const Sequence& original, const ReduceResult& reduced, float tolerance) {
  return "{\"keys\":" + SequenceKeysJson(rig, reduced.sequence) + ",\"transition\":" + JsonString(TransitionName(original.transition)) +
         ",\"kept\":" + std::to_string(reduced.sequence.keys.size()) + ",\"removed\":" + std::to_string(reduced.removed) +
         ",\"max_error\":" + FormatNumber(reduced.max_error) + ",\"tolerance\":" + FormatNumber(tolerance) + "}\n";
}

// ---- fitting ------------------------------------------------------------------------------

std::string FitResultJson(const Rig& rig, const FitResult& fit, bool aligned) {
  std::string out = "{\"weights\":{";
  for (size_t s = 0; s < rig.shapes.size(); ++s) {
    out += std::string(s ? "," : "") + JsonString(rig.shapes[s].name) + ":" + FormatNumber(fit.weights[s]);
  }
  out += "},\"residual\":{\"rms\":" + FormatNumber(fit.rms_error) + ",\"max\":" + FormatNumber(fit.max_error) + "}";
  if (aligned) {
    out += ",\"alignment\":[";
    for (int i = 0; i < 16; ++i) out += std::string(i ? "," : "") + FormatNumber(fit.alignment[i]);
    out += "]";
  }
  return out + ",\"warnings\":" + WarningsToJson(fit.warnings) + "}\n";
}

Result<Output> ProduceFit(const Rig& rig, const FitRequest& request) {
  std::vector<std::vector<float>> target = request.target.positions;
  if (!request.target.mesh_space) WorldToMeshSpace(rig, target);
  auto fit = FitWeights(rig, target, request.options);
  if (!fit.ok()) {
    Status s = WithReason(fit.status(), kInvalidTarget);
    if (s.fields.empty()) s.fields.push_back({"/target", s.message});
    return s;
  }
  return Output{FitResultJson(rig, fit.value(), request.options.rigid_align), "application/json", fit->warnings, 0.0};
}

// ---- batch variants -----------------------------------------------------------------------

Result<BatchPlan> MakeBatchPlan(std::shared_ptr<const Rig> owned, const std::string& rig_version, std::string_view request_json) {
  auto request = ParseBatchRequest(request_json);
  if (!request.ok()) return request.status();
  const Rig& rig = *owned;
  BatchPlan plan;
  plan.rig = std::move(owned);
  plan.request = std::move(request.value());
  if (plan.request.sampled) {
    auto spec = ResolveSampleSpec(rig, plan.request);
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
  std::vector<float> unused;
  if (Status s = ResolvePoseAndWeights(rig, {}, plan.request.render.mesh.pose, unused, plan.pose, plan.posed, plan.pose_warnings);
      !s.ok()) {
    return s;
  }
  json spec = {{"request", json::parse(request_json, nullptr, false)}, {"rig", rig.name}, {"rig_version", rig_version}};
  plan.spec_json = spec.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
  return plan;
}

std::string VariantId(const BatchPlan& plan, size_t index) {
  if (!plan.request.sampled && !plan.request.variants[index].id.empty()) return plan.request.variants[index].id;
  char buf[32];
  std::snprintf(buf, sizeof buf, "v%06zu", index);
  return buf;
}

std::string VariantFile(const BatchPlan& plan, size_t index) { return VariantId(plan, index) + "." + plan.request.format; }

void VariantPoint(const BatchPlan& plan, size_t index, Point& point) {
  const Rig& rig = *plan.rig;
  point.weights.resize(rig.shapes.size());
  if (plan.request.sampled) SampleVariant(rig, plan.sample, index, point.weights);
  else std::copy(plan.weights[index].begin(), plan.weights[index].end(), point.weights.begin());
  point.pose = plan.pose;  // Same sizes every time: no allocation once warm.
  point.posed = plan.posed;
  CheckPoint(rig, plan.request.render.mesh.options.mode, point);
  point.report.warnings.insert(point.report.warnings.end(), plan.pose_warnings.begin(), plan.pose_warnings.end());
}

Result<std::array<std::string_view, 2>> EncodeVariant(const BatchPlan& plan, const Point& point,
                                                      const render::Renderer& renderer, VariantEncoder& encoder) {
  const BatchRequest& r = plan.request;
  if (!r.image && r.mesh_format == MeshFormat::kGlb) {
    auto pieces = EncodeGlb(*plan.rig, point, r.render.mesh, encoder.ws, encoder.glb);
    if (!pieces.ok()) return pieces.status();
    return std::array<std::string_view, 2>{pieces->head, pieces->bin};
  }
  auto bytes = r.image ? EncodeImage(*plan.rig, point, r.render, r.image_format, renderer, encoder.ws)
                       : EncodeMesh(*plan.rig, point, r.render.mesh, r.mesh_format, encoder.ws);
  if (!bytes.ok()) return bytes.status();
  encoder.bytes = std::move(bytes.value());
  return std::array<std::string_view, 2>{encoder.bytes, {}};
}

Result<std::string> VariantSheet(const BatchPlan& plan, std::span<const size_t> indices, const render::Renderer& renderer,
                                 Workspace& ws) {
  std::vector<Point> cells(indices.size());
  std::vector<std::string> labels;
  for (size_t i = 0; i < indices.size(); ++i) {
    VariantPoint(plan, indices[i], cells[i]);
    labels.push_back(VariantId(plan, indices[i]));
  }
  render::RenderOptions cell = plan.request.render.render;
  cell.width = cell.height = 256;
  cell.supersample = std::min(cell.supersample, 2);
  const int columns = cells.size() >= 16 ? 4 : static_cast<int>(std::ceil(std::sqrt(static_cast<double>(cells.size()))));
  return EncodeGrid(*plan.rig, cells, labels, columns, cell, plan.request.render.mesh.options, render::ImageFormat::kPng, 90,
                    renderer, ws);
}

}  // namespace facespace::api
