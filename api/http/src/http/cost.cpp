#include "cost.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "problem.h"

namespace facespace::http {

namespace {

struct RigSize {
  size_t vertices = 0, triangles = 0, skinned = 0;
};

RigSize SizeOf(const Rig& rig) {
  RigSize s;
  for (const Primitive& p : rig.primitives) {
    const size_t v = p.positions.size() / 3;
    s.vertices += v;
    s.triangles += p.indices.size() / 3;
    if (!p.joints.empty()) s.skinned += v;
  }
  return s;
}

// "1.2 M" and such: figures for people.
std::string Amount(double v) {
  char buf[32];
  if (v >= 1e9)
    std::snprintf(buf, sizeof buf, "%.1f G", v / 1e9);
  else if (v >= 1e6)
    std::snprintf(buf, sizeof buf, "%.1f M", v / 1e6);
  else if (v >= 1e4)
    std::snprintf(buf, sizeof buf, "%.0f k", v / 1e3);
  else
    std::snprintf(buf, sizeof buf, "%.0f", v);
  return buf;
}

std::string Seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, s < 0.01 ? "%.4f" : s < 10 ? "%.2f" : "%.0f", s);
  return buf;
}

double Samples(const picture::RenderOptions& o) {
  const double ss = std::max(1, o.supersample);
  return static_cast<double>(std::max(0, o.width)) * std::max(0, o.height) * ss * ss;
}

double FrameSeconds(const RigSize& s) {
  return 2e-5 + 8e-9 * static_cast<double>(s.vertices) + 1.5e-8 * static_cast<double>(s.skinned);
}

}  // namespace

double FrameSeconds(const Rig& rig) { return FrameSeconds(SizeOf(rig)); }

double ImageSeconds(const picture::RenderOptions& o, const Rig& rig) {
  const RigSize s = SizeOf(rig);  // One walk over the primitives for the blend and the triangles.
  return kPerImage + FrameSeconds(s) + kPerSample * Samples(o) +
         1e-7 * static_cast<double>(s.triangles);
}

double BlendSeconds(const Rig& rig, size_t weighted) {
  size_t all = 0, largest = 0;
  for (const Shape& shape : rig.shapes) {
    all += shape.vertices_moved;
    largest = std::max(largest, shape.vertices_moved);
  }
  const double bound = weighted >= rig.shapes.size()
                           ? static_cast<double>(all)
                           : std::min(static_cast<double>(all),
                                      static_cast<double>(weighted) * static_cast<double>(largest));
  return kPerMovedVertex * bound;
}

Cost MeshCost(const Rig& rig, std::optional<formats::MeshFormat> format, size_t weighted) {
  const double blend = BlendSeconds(rig, weighted);
  if (format != formats::MeshFormat::kVrm && format != formats::MeshFormat::kVrm0) {
    return {kPerRequest + FrameSeconds(rig) + blend, "/weights",
            "one blend of " +
                (weighted >= rig.shapes.size() ? std::string("every") : std::to_string(weighted)) +
                " shape(s)"};
  }
  // A VRM: the whole rig written (every target of every vertex: 1.2e-8 s each, measured on Uka's,
  // 50k vertices x 213 shapes in 0.14 s with its thumbnail) and its thumbnail drawn.
  picture::RenderOptions thumbnail;
  thumbnail.width = thumbnail.height = evaluator::Evaluator::kThumbnailSize;
  const double seconds =
      kPerRequest + FrameSeconds(rig) + blend +
      1.2e-8 * static_cast<double>(rig.vertex_count()) * static_cast<double>(rig.shapes.size()) +
      ImageSeconds(thumbnail, rig);
  return {seconds, "/format",
          "the rig's VRM (" + std::to_string(rig.shapes.size()) + " shapes) and a 512² thumbnail"};
}

double EncodeSeconds(picture::ImageFormat format, double pixels) {
  switch (format) {
    case picture::ImageFormat::kExr: return 110e-9 * pixels;
    case picture::ImageFormat::kTiff: return 100e-9 * pixels;
    case picture::ImageFormat::kWebp: return 25e-9 * pixels;
    case picture::ImageFormat::kJpeg: return 8e-9 * pixels;
    case picture::ImageFormat::kPng: break;
  }
  return 5e-9 * pixels;
}

size_t WeightedShapes(const evaluator::MeshRequest& r) {
  if (!r.controls.empty()) return SIZE_MAX;
  return static_cast<size_t>(std::count_if(r.weights.begin(), r.weights.end(),
                                           [](const WeightEntry& w) { return w.value != 0.0; }));
}

Cost RenderCost(const Rig& rig, const picture::RenderOptions& o, bool query,
                picture::ImageFormat format) {
  const double pixels = static_cast<double>(std::max(0, o.width)) * std::max(0, o.height);
  return {kPerRequest + ImageSeconds(o, rig) + EncodeSeconds(format, pixels),
          query ? "?supersample" : "/supersample",
          Amount(Samples(o)) + " samples (width x height x supersample squared), encoded as " +
              picture::ImageFormatExtension(format)};
}

Cost SheetCost(const Rig& rig, const picture::RenderOptions& o, size_t cells,
               picture::ImageFormat format) {
  const double pixels = static_cast<double>(cells) * std::max(0, o.width) * std::max(0, o.height);
  return {kPerRequest + static_cast<double>(cells) * ImageSeconds(o, rig) +
              EncodeSeconds(format, pixels),
          "/cells",
          std::to_string(cells) + " cells x " + Amount(Samples(o)) + " samples, encoded as " +
              picture::ImageFormatExtension(format)};
}

Cost FramesCost(const Rig& rig, size_t frames, double seconds, bool meshes, const char* field) {
  seconds =
      std::clamp(seconds, 0.0,
                 static_cast<double>(
                     evaluator::SequencePhysics::kMaxSeconds));  // Steps past it are not simulated.
  const double physics =
      rig.physics.bodies.empty()
          ? 0.0
          : 60.0 * seconds * kPerPhysicsBody * static_cast<double>(rig.physics.bodies.size());
  const double frame =
      meshes ? FrameSeconds(rig) : 2e-6 * static_cast<double>(rig.shapes.size() + 10);
  return {kPerRequest + static_cast<double>(frames) * frame + physics, field,
          Amount(static_cast<double>(frames)) + " frames" +
              (physics > 0 ? " and " + Amount(60.0 * seconds) + " physics steps" : "")};
}

Cost ReduceCost(const Rig& rig, size_t keys) {
  // O(K log K) samples, each a blend of the shapes that differ (ReduceSequence).
  const double k = static_cast<double>(std::max<size_t>(keys, 2));
  const double samples =
      2.0 * k * std::log2(k);  // Measured: 1,600 keys of all 52 FaceCap shapes ramping, 0.76 s.
  return {
      kPerRequest + samples * (FrameSeconds(rig) + 5e-9 * static_cast<double>(rig.shapes.size())),
      "/keys", Amount(static_cast<double>(keys)) + " keys (about " + Amount(samples) + " samples)"};
}

Cost FitCost(const Rig& rig, const evaluator::FitRequest& r) {
  size_t v = 0;
  for (const auto& p : r.target.positions) v += p.size() / 3;
  const double n = static_cast<double>(rig.shapes.size());
  return {kPerRequest + 6e-10 * static_cast<double>(v) * (n * n + 20.0), "/target",
          Amount(static_cast<double>(v)) + " vertices x " + std::to_string(rig.shapes.size()) +
              " shapes squared"};
}

Cost SpeechCost(const Rig& rig, const evaluator::SpeechRequest& r, double seconds, int rate) {
  Cost c;
  if (r.has_audio) {
    c.seconds = kDecodePerSecond * seconds + kPerInputSample * seconds * rate;
    c.field = "/audio";
    c.formula = Seconds(seconds) + " s of audio at " + std::to_string(rate) + " Hz";
  } else {
    c.seconds = kSynthPerSecond * seconds;
    c.field = "/text";
    c.formula = "about " + Seconds(seconds) + " s of speech";
  }
  const size_t frames = static_cast<size_t>(std::ceil(seconds * std::max(1.0f, r.fps))) + 1;
  if (r.format == evaluator::FrameFormat::kWebm) {
    const double pixels = static_cast<double>(std::max(0, r.render.render.width)) *
                          std::max(0, r.render.render.height);
    c.seconds += static_cast<double>(frames) *
                 (ImageSeconds(r.render.render, rig) + kPerVideoPixel * pixels);
    c.field = r.render.render.supersample > 1 ? "/supersample" : "/fps";
    c.formula += ", " + Amount(static_cast<double>(frames)) + " video frames x " +
                 Amount(Samples(r.render.render)) + " samples";
  } else if (r.format != evaluator::FrameFormat::kJson &&
             r.format != evaluator::FrameFormat::kWav) {
    c.seconds +=
        FramesCost(rig, frames, seconds, r.format == evaluator::FrameFormat::kF32, "/fps").seconds;
    c.formula += ", " + Amount(static_cast<double>(frames)) + " frames";
  }
  c.seconds += kPerRequest;
  return c;
}

Cost UploadCost(size_t bytes) {
  return {kPerRequest + kPerUploadByte * static_cast<double>(bytes), "",
          Amount(static_cast<double>(bytes)) + " bytes"};
}

Cost DeriveCost(const Rig& target, const Rig& source, size_t shapes) {
  const auto v = static_cast<double>(target.vertex_count());
  const auto s = static_cast<double>(source.vertex_count());
  return {kPerRequest + kDerivePerVertex * (v + s) +
              kDerivePerShapeVertex * v * static_cast<double>(shapes),
          "/shapes",
          Amount(v) + " target vertices x " + std::to_string(shapes) + " shapes, and " + Amount(s) +
              " source vertices"};
}

Cost CaptureCost(const Rig& rig, size_t frames, bool registered) {
  const auto v = static_cast<double>(rig.vertex_count());
  const double per_frame =
      kCapturePerFrame * std::max(1.0, static_cast<double>(rig.shapes.size()) / 52.0);
  return {kPerRequest + (registered ? 0.0 : kCaptureRegister + kCapturePerVertex * v) +
              per_frame * static_cast<double>(frames),
          "/frames",
          Amount(static_cast<double>(frames)) + " frames x " + std::to_string(rig.shapes.size()) +
              " shapes" +
              (registered ? "" : ", and the landmarks registered on " + Amount(v) + " vertices")};
}

bool WithinBudget(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                  const Cost& cost) {
  res.headers.erase("Facespace-Cost");  // The route table's constant, said before the handler ran.
  res.set_header("Facespace-Cost", Seconds(cost.seconds));
  const bool keyed = CarriesKey(ctx, req);
  const double budget = keyed ? ctx.options.keyed_cpu : ctx.options.anonymous_cpu;
  if (cost.seconds <= budget) return true;
  ctx.metrics.CountOverBudget();
  const std::string limit = keyed ? "the keyed budget of " + Seconds(budget) + " (--keyed-cpu)"
                                  : "an anonymous request's budget of " + Seconds(budget) +
                                        " (--anonymous-cpu; with the API key, " +
                                        Seconds(ctx.options.keyed_cpu) + ")";
  SendProblem(
      req, res, Problem::kOverBudget,
      "this request would cost about " + Seconds(cost.seconds) + " CPU-seconds (" + cost.formula +
          "), over " + limit +
          ": ask for less at once (fewer frames, cells, keys or samples, a smaller size), or split "
          "it",
      {{cost.field, "about " + Seconds(cost.seconds) + " CPU-seconds, over " + Seconds(budget)}});
  return false;
}

}  // namespace facespace::http
