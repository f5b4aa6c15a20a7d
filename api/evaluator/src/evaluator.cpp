// Step 2: a resolved point to encoded bytes, with the fast paths and what is kept per rig.
#include "facespace/evaluator/evaluator.h"

#include <chrono>
#include <cstring>

#include "kept.h"

namespace facespace::evaluator {

struct Evaluator::Kept {
  DerivedRigs derived;
  GlbWriters glb_writers;
  F32Writers f32_writers;
};

namespace {

using Clock = std::chrono::steady_clock;

// Adds the milliseconds since `start` to `total`, and restarts the clock.
void Lap(Clock::time_point& start, double& total) {
  const auto now = Clock::now();
  total += std::chrono::duration<double, std::milli>(now - start).count();
  start = now;
}

// The rig evaluated at `point` into ws.blended. The point was checked: a failure here is ours.
Status Evaluate(const Rig& rig, const ResolvedPoint& point, BlendOptions options, Workspace& ws) {
  auto start = Clock::now();
  options.pose = point.pose_or_null();
  if (Status s = EvaluateRig(rig, point.weights, options, ws.blended, ws.context); !s.ok()) {
    return Internal("the blend failed: " + s.message);
  }
  Lap(start, ws.timing.blend);
  return Status::Ok();
}

Encoded Whole(std::string bytes) { return Encoded{std::move(bytes), {}, {}}; }

// The f32 body written over the rest's bytes (F32Writer), over ws.body; false when the writer
// does not serve this rig, point or spec.
bool F32Fast(const Rig& rig, const ResolvedPoint& point, const OutputSpec& spec,
             const formats::F32Writer& f32, Workspace& ws, std::string& out) {
  if (f32.mesh_space() != spec.mesh_space || point.pose_or_null() ||
      !SparseBlend::Serves(rig, spec.blend))
    return false;
  auto start = Clock::now();
  std::string bytes = std::move(ws.body);
  if (!f32.Write(rig, point.weights, ws.f32, bytes)) {
    ws.body = std::move(bytes);
    return false;
  }
  Lap(start, ws.timing.blend);
  out = std::move(bytes);
  return true;
}

// The blended glb through a writer that keeps the rig's template: its two pieces.
Result<formats::GlbVariantWriter::Pieces> GlbPieces(const Rig& rig, const ResolvedPoint& point,
                                                    const OutputSpec& spec, Workspace& ws,
                                                    formats::GlbVariantWriter& glb) {
  if (Status s = Evaluate(rig, point, spec.blend, ws); !s.ok()) return s;
  auto start = Clock::now();
  formats::ExportOptions options;
  options.keep_targets = spec.keep_targets;
  auto pieces = glb.Write(rig, ws.blended, point.weights, point.report.warnings, options);
  if (!pieces.ok()) return Prefixed(pieces.status(), "the export failed: ");
  Lap(start, ws.timing.encode);
  return pieces;
}

// A labelled grid of renders of `cells` (each with its own pose).
Result<std::string> Grid(const Rig& rig, std::span<const ResolvedPoint> cells,
                         const OutputSpec& spec, const picture::RenderOptions& options,
                         const picture::Renderer& renderer, Workspace& ws) {
  ws.cells.resize(cells.size());
  for (size_t c = 0; c < cells.size(); ++c) {
    if (ws.stop.stop_requested()) return Cancelled();
    if (Status s = Evaluate(rig, cells[c], spec.blend, ws); !s.ok()) return s;
    auto start = Clock::now();
    if (Status s = renderer.Draw(rig, ws.blended, options, ws.cells[c]); !s.ok())
      return Prefixed(s, "the render failed: ");
    Lap(start, ws.timing.draw);
  }
  auto start = Clock::now();
  auto bytes =
      renderer.Encode(renderer.Sheet(ws.cells, spec.labels, spec.columns, options.background),
                      spec.image_format, spec.quality, ws.helper_cpu);
  Lap(start, ws.timing.encode);
  // A workspace is kept for the next request: it keeps no large sheet's images.
  size_t pixels = 0;
  for (const picture::Image& c : ws.cells)
    pixels += static_cast<size_t>(c.width) * static_cast<size_t>(c.height);
  if (pixels > (size_t{1} << 20)) std::vector<picture::Image>().swap(ws.cells);
  return bytes;
}

}  // namespace

// ---- the spec -----------------------------------------------------------------------------------

OutputSpec OutputSpec::Mesh(const MeshRequest& r, formats::MeshFormat format) {
  OutputSpec s;
  s.kind = Kind::kMesh;
  s.blend = r.options;
  s.lod = r.lod;
  s.mesh_format = format;
  s.mesh_space = r.mesh_space;
  s.keep_targets = r.keep_targets;
  return s;
}

OutputSpec OutputSpec::Image(const RenderRequest& r, picture::ImageFormat format) {
  OutputSpec s;
  s.kind = Kind::kImage;
  s.blend = r.mesh.options;
  s.lod = r.mesh.lod;
  s.render = r.render;
  s.image_format = format;
  s.quality = r.quality;
  return s;
}

OutputSpec OutputSpec::Sheet(const SheetRequest& r, picture::ImageFormat format) {
  OutputSpec s = Image(r.base, format);
  s.kind = Kind::kSheet;
  s.columns = r.columns;
  s.labels = r.labels;
  return s;
}

OutputSpec OutputSpec::Pixels(const RenderRequest& r) {
  OutputSpec s = Image(r, picture::ImageFormat::kPng);
  s.kind = Kind::kPixels;
  return s;
}

OutputSpec OutputSpec::Frame(const BlendOptions& blend, bool f32) {
  OutputSpec s;
  s.kind = f32 ? Kind::kFrameF32 : Kind::kFrameJson;
  s.blend = blend;
  return s;
}

const char* OutputSpec::content_type() const {
  switch (kind) {
    case Kind::kMesh: return MeshFormatMimeType(mesh_format);
    case Kind::kImage:
    case Kind::kSheet: return picture::ImageFormatMimeType(image_format);
    case Kind::kFrameJson: return "application/json";
    case Kind::kFrameF32:
    case Kind::kPixels: return "application/octet-stream";
  }
  return "application/octet-stream";
}

// ---- the evaluator ------------------------------------------------------------------------------

Evaluator::Evaluator() : kept_(std::make_unique<Kept>()) {}
Evaluator::Evaluator(const picture::Renderer& renderer)
    : renderer_(&renderer), kept_(std::make_unique<Kept>()) {}
Evaluator::~Evaluator() = default;

std::shared_ptr<const DerivedRig> Evaluator::Derived(const std::shared_ptr<const StoredRig>& rig,
                                                     int lod) const {
  return kept_->derived.At(rig, lod);
}

void Evaluator::WarmPictures(const std::shared_ptr<const StoredRig>& rig, int lod) const {
  if (!renderer_) return;
  picture::RenderOptions options;  // Shaded: the occlusion is baked.
  kept_->derived.Prepare(rig, lod, options);
}

Status Evaluator::Thumbnail(const std::shared_ptr<const StoredRig>& stored, int lod, const Rig& rig,
                            Workspace& ws, std::vector<unsigned char>& png) const {
  if (!renderer_) return Status::Ok();  // A mesh-only evaluator writes VRMs without one.
  picture::RenderOptions options;
  options.width = options.height = kThumbnailSize;
  options.camera.frame = picture::Framing::kShapes;  // The face the shapes move, on a whole body,
  options.camera.zoom = 0.8f;                        // with its hair around it.
  options.srgb8 = true;
  options.helper_cpu = ws.helper_cpu;
  kept_->derived.Prepare(stored, lod, options);
  if (Status s = renderer_->Draw(rig, ws.blended, options, ws.image); !s.ok())
    return Prefixed(s, "the VRM's thumbnail: ");
  auto bytes = renderer_->Encode(ws.image, picture::ImageFormat::kPng, 0, ws.helper_cpu);
  if (!bytes.ok()) return bytes.status();
  png.assign(bytes->begin(), bytes->end());
  return Status::Ok();
}

Result<Encoded> Evaluator::Run(const std::shared_ptr<const StoredRig>& stored,
                               std::span<const ResolvedPoint> points, const OutputSpec& spec,
                               Workspace& ws) const {
  if (points.empty() || (spec.kind != OutputSpec::Kind::kSheet && points.size() != 1)) {
    return Internal("an output of " + std::to_string(points.size()) + " points");
  }
  const std::shared_ptr<const Rig> at = kept_->derived.RigAt(stored, spec.lod);
  if (!at) return Internal("the level of detail failed");
  const Rig& rig = *at;
  const ResolvedPoint& point = points[0];
  const bool picture = spec.kind == OutputSpec::Kind::kImage ||
                       spec.kind == OutputSpec::Kind::kPixels ||
                       spec.kind == OutputSpec::Kind::kSheet;
  if (picture && !renderer_)
    return FailedPrecondition(
        "this evaluator was handed no renderer: it makes meshes, not pictures");
  switch (spec.kind) {
    case OutputSpec::Kind::kMesh: {
      if (spec.mesh_format == formats::MeshFormat::kF32) {
        std::string bytes;
        if (F32Fast(rig, point, spec, *kept_->f32_writers.Get(at, spec.mesh_space), ws, bytes))
          return Whole(std::move(bytes));
      }
      if (spec.mesh_format == formats::MeshFormat::kGlb && !spec.keep_targets) {
        if (spec.pieces) {
          auto pieces = GlbPieces(rig, point, spec, ws, ws.glb);
          if (!pieces.ok()) return pieces.status();
          return Encoded{{}, pieces->head, pieces->bin};
        }
        const GlbWriters::Lease glb = kept_->glb_writers.Acquire(at);
        auto pieces = GlbPieces(rig, point, spec, ws, *glb);
        if (!pieces.ok()) return pieces.status();
        std::string bytes;
        bytes.reserve(pieces->head.size() + pieces->bin.size());
        return Whole(std::move(bytes.append(pieces->head).append(pieces->bin)));
      }
      if (Status s = Evaluate(rig, point, spec.blend, ws); !s.ok()) return s;
      auto start = Clock::now();
      formats::ExportOptions options;
      options.keep_targets = spec.keep_targets;
      options.mesh_space = spec.mesh_space;
      if (spec.mesh_format == formats::MeshFormat::kVrm ||
          spec.mesh_format == formats::MeshFormat::kVrm0) {
        if (Status s = Thumbnail(stored, spec.lod, rig, ws, options.thumbnail_png); !s.ok())
          return s;
      }
      auto bytes = ExportMesh(rig, ws.blended, point.weights, point.report.warnings,
                              spec.mesh_format, options);
      if (!bytes.ok()) {  // The request's fault (a VRM of a rig without a humanoid) as it is; else
                          // ours.
        return bytes.status().code == StatusCode::kInvalidArgument
                   ? bytes.status()
                   : Prefixed(bytes.status(), "the export failed: ");
      }
      Lap(start, ws.timing.encode);
      return Whole(std::move(bytes.value()));
    }
    case OutputSpec::Kind::kImage:
    case OutputSpec::Kind::kPixels: {
      if (Status s = Evaluate(rig, point, spec.blend, ws); !s.ok()) return s;
      auto start = Clock::now();
      picture::RenderOptions options = spec.render;
      options.helper_cpu = ws.helper_cpu;
      kept_->derived.Prepare(stored, spec.lod, options);
      options.srgb8 = spec.image_format !=
                      picture::ImageFormat::kExr;  // An 8-bit file: drawn straight into 8 bits.
      if (Status s = renderer_->Draw(rig, ws.blended, options, ws.image); !s.ok())
        return Prefixed(s, "the render failed: ");
      Lap(start, ws.timing.draw);
      if (spec.kind == OutputSpec::Kind::kPixels) return Encoded{};
      auto bytes = renderer_->Encode(ws.image, spec.image_format, spec.quality, ws.helper_cpu);
      Lap(start, ws.timing.encode);
      if (!bytes.ok()) return bytes.status();
      return Whole(std::move(bytes.value()));
    }
    case OutputSpec::Kind::kSheet: {
      picture::RenderOptions options = spec.render;
      options.helper_cpu = ws.helper_cpu;
      kept_->derived.Prepare(stored, spec.lod, options);
      auto bytes = Grid(rig, points, spec, options, *renderer_, ws);
      if (!bytes.ok()) return bytes.status();
      return Whole(std::move(bytes.value()));
    }
    case OutputSpec::Kind::kFrameJson: {
      if (Status s = Evaluate(rig, point, spec.blend, ws); !s.ok()) return s;
      return Whole(formats::PrimitivesJson(rig, ws.blended));
    }
    case OutputSpec::Kind::kFrameF32: {
      if (Status s = Evaluate(rig, point, spec.blend, ws); !s.ok()) return s;
      std::vector<float> positions;
      formats::WorldPositions(ws.blended, positions);
      const uint32_t size = static_cast<uint32_t>(positions.size() * 4);
      std::string chunk(4 + size, '\0');
      std::memcpy(chunk.data(), &size, 4);
      std::memcpy(chunk.data() + 4, positions.data(), size);
      return Whole(std::move(chunk));
    }
  }
  return Internal("an unknown output");
}

std::shared_ptr<const StoredRig> Unstored(Rig rig, std::string version) {
  auto stored = std::make_shared<StoredRig>();
  stored->id = rig.name;
  stored->rig = std::move(rig);
  stored->version = std::move(version);
  return stored;
}

Result<std::string> RigGlb(const Evaluator& evaluator,
                           const std::shared_ptr<const StoredRig>& rig) {
  ResolvedPoint defaults;
  for (const Shape& s : rig->rig.shapes) defaults.weights.push_back(s.default_weight);
  OutputSpec spec;
  spec.mesh_format = formats::MeshFormat::kGlb;
  spec.keep_targets = true;
  Workspace ws;
  auto glb = evaluator.Run(rig, defaults, spec, ws);
  if (!glb.ok()) return glb.status();
  return std::move(glb->bytes);
}

// ---- one call -----------------------------------------------------------------------------------

namespace {

Result<Output> Finish(Result<Encoded> encoded, const OutputSpec& spec,
                      std::vector<Warning> warnings, double sum) {
  if (!encoded.ok()) return encoded.status();
  return Output{std::move(encoded->bytes), spec.content_type(), std::move(warnings), sum};
}

}  // namespace

namespace {

// The point `mesh` names, made as `spec` says.
Result<Output> ProducePoint(const Evaluator& evaluator, const std::shared_ptr<const StoredRig>& rig,
                            const MeshRequest& mesh, const OutputSpec& spec, Workspace& ws) {
  ResolvedPoint point;
  if (Status s = ResolvePoint(rig->rig, mesh, point); !s.ok()) return s;
  return Finish(evaluator.Run(rig, point, spec, ws), spec, point.report.warnings, point.report.sum);
}

}  // namespace

Result<Output> ProduceMesh(const Evaluator& evaluator, const std::shared_ptr<const StoredRig>& rig,
                           const MeshRequest& request, formats::MeshFormat format, Workspace& ws) {
  return ProducePoint(evaluator, rig, request, OutputSpec::Mesh(request, format), ws);
}

Result<Output> ProduceImage(const Evaluator& evaluator, const std::shared_ptr<const StoredRig>& rig,
                            const RenderRequest& request, picture::ImageFormat format,
                            Workspace& ws) {
  return ProducePoint(evaluator, rig, request.mesh, OutputSpec::Image(request, format), ws);
}

Result<Output> ProduceSheet(const Evaluator& evaluator, const std::shared_ptr<const StoredRig>& rig,
                            const SheetRequest& request, picture::ImageFormat format,
                            Workspace& ws) {
  SheetPoints points;
  if (Status s = ResolveSheet(rig->rig, request, points); !s.ok()) return s;
  const OutputSpec spec = OutputSpec::Sheet(request, format);
  return Finish(evaluator.Run(rig, points.cells, spec, ws), spec, points.warnings, points.max_sum);
}

}  // namespace facespace::evaluator
