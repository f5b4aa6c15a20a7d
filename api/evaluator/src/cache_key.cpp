// CacheKey: the one text that says what an output depends on.
#include <cstdio>
#include <cstring>

#include "facespace/evaluator/evaluator.h"

namespace facespace::evaluator {

namespace {

std::string FloatsCanonical(std::span<const float> v) {
  std::string s;
  for (float f : v) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%a,", static_cast<double>(f));
    s += buf;
  }
  return s;
}

std::string OptionsCanonical(const BlendOptions& o) {
  return std::string(o.mode == BlendMode::kAbsolute ? "abs" : "rel") + "|" +
         (o.normals == NormalMode::kRecompute ? "rec" : "bl");
}
// Bits of each weight; -0 is 0.
std::string WeightsCanonical(std::span<const float> w) {
  std::string s;
  s.reserve(w.size() * 8);
  for (float f : w) {
    uint32_t bits;
    std::memcpy(&bits, &f, 4);
    if (f == 0.0f) bits = 0;  // -0 and 0 are the same weight.
    for (int shift = 28; shift >= 0; shift -= 4)
      s += "0123456789abcdef"[(bits >> shift) & 15];  // "%08x", without printf's cost.
  }
  return s;
}

// "" for the rest pose.
std::string PoseCanonical(const ResolvedPoint& point) {
  if (!point.posed) return "";
  const Pose& pose = point.pose;
  std::string s = "|pose:";
  for (size_t i = 0; i < pose.local.size(); ++i) {
    if (pose.from_matrix[i]) {
      s += "m,";
      continue;
    }
    const Transform& t = pose.local[i];
    s += FloatsCanonical(t.translation) + FloatsCanonical(t.rotation) + FloatsCanonical(t.scale);
  }
  return s;
}

std::string MeshCanonical(const OutputSpec& s, const ResolvedPoint& point) {
  return PoseCanonical(point) + MeshFormatName(s.mesh_format) + (s.mesh_space ? "|mesh|" : "|") +
         OptionsCanonical(s.blend) + "|" + (s.keep_targets ? "t" : "-") +
         (s.blend.dual_quaternion ? "|dq|" : "|") + "lod" + std::to_string(s.lod) + "|" +
         WeightsCanonical(point.weights);
}

std::string RenderCanonical(const OutputSpec& s) {
  const picture::RenderOptions& o = s.render;
  const picture::Camera& c = o.camera;
  return std::string(picture::ImageFormatExtension(s.image_format)) + "|q" +
         std::to_string(s.quality) + "|" + std::to_string(o.width) + "x" +
         std::to_string(o.height) + "|" + picture::ViewName(o.view) + "|ss" +
         std::to_string(o.supersample) + "|" + FloatsCanonical(o.background) + "|" +
         FloatsCanonical(std::array<float, 5>{c.yaw, c.pitch, c.distance, c.zoom, c.fov}) +
         (c.look_at ? "L" : "O") +
         (c.frame == picture::Framing::kShapes  ? "S"
          : c.frame == picture::Framing::kAll   ? "A"
          : c.frame == picture::Framing::kJoint ? "J" + c.frame_joint + "|"
                                                : "D") +
         (c.look_at ? FloatsCanonical(c.eye) + FloatsCanonical(c.target) + FloatsCanonical(c.up)
                    : "") +
         "|ev" + FloatsCanonical(std::array<float, 3>{o.exposure, o.light_yaw, o.light_pitch}) +
         "|" + OptionsCanonical(s.blend) + (s.blend.dual_quaternion ? "|dq" : "");
}

}  // namespace

std::string CacheKey(const StoredRig& rig, std::span<const ResolvedPoint> points,
                     const OutputSpec& spec) {
  std::string key = rig.id + "|" + rig.version + "|";
  switch (spec.kind) {
    case OutputSpec::Kind::kMesh: return key + MeshCanonical(spec, points[0]);
    case OutputSpec::Kind::kImage:
    case OutputSpec::Kind::kPixels:
      return key + (spec.kind == OutputSpec::Kind::kImage ? "render|" : "pixels|") +
             RenderCanonical(spec) + "|lod" + std::to_string(spec.lod) + "|" +
             WeightsCanonical(points[0].weights) + PoseCanonical(points[0]);
    case OutputSpec::Kind::kSheet:
      key += "sheet|" + std::to_string(spec.columns) + "|" + RenderCanonical(spec);
      for (size_t c = 0; c < points.size(); ++c)
        key += "|" + WeightsCanonical(points[c].weights) + "#" + spec.labels[c];
      if (!points.empty()) key += PoseCanonical(points[0]);
      return spec.lod == 0 ? key : key + "|lod" + std::to_string(spec.lod);
    case OutputSpec::Kind::kFrameJson:
    case OutputSpec::Kind::kFrameF32:
      return key + (spec.kind == OutputSpec::Kind::kFrameJson ? "frame-json|" : "frame-f32|") +
             OptionsCanonical(spec.blend) + (spec.blend.dual_quaternion ? "|dq|" : "|") +
             WeightsCanonical(points[0].weights) + PoseCanonical(points[0]);
  }
  return key;
}

}  // namespace facespace::evaluator
