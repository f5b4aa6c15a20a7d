#include "facespace/batch/dataset.h"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "background.h"
#include "facespace/engine/pose_request.h"
#include "facespace/engine/transform.h"

namespace facespace::batch {

using nlohmann::json;

namespace {

// A float as JSON by its shortest text (0.1f is 0.1, not 0.10000000149011612).
json Short(double v) {
  char buf[32];
  *std::to_chars(buf, buf + sizeof buf - 1, static_cast<float>(v)).ptr = '\0';
  return std::strtod(buf, nullptr);  // The double nearest that text prints as it.
}

// SplitMix64's finaliser: a well-mixed 64-bit value of its input.
uint64_t Mix(uint64_t z) {
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

// Draw `slot` of sample `index`, uniform in [lo, hi]: each slot its own stream, so the draws of one
// setting stay the same when another is added to the request.
float Uniform(uint64_t seed, size_t index, uint64_t slot, float lo, float hi) {
  const uint64_t bits = Mix(seed ^ Mix(static_cast<uint64_t>(index) * 0x100000001b3ull + slot));
  return lo + (hi - lo) * static_cast<float>(static_cast<double>(bits >> 11) * 0x1.0p-53);
}

}  // namespace

SampleDraw DrawSample(const BatchPlan& plan, size_t index) {
  const evaluator::Randomization& r = plan.request.dataset.randomize;
  SampleDraw d;
  d.render = plan.output.render;
  const uint64_t seed = plan.draw_seed;
  auto draw = [&](uint64_t slot, const std::optional<evaluator::Interval>& i, float& value,
                  bool scale) {
    if (!i) return;
    const float x = Uniform(seed, index, slot, i->lo, i->hi);
    value = scale ? value * x : value + x;
  };
  draw(1, r.yaw, d.render.camera.yaw, false);
  draw(2, r.pitch, d.render.camera.pitch, false);
  draw(3, r.zoom, d.render.camera.zoom, true);
  draw(4, r.light_yaw, d.render.light_yaw, false);
  draw(5, r.light_pitch, d.render.light_pitch, false);
  draw(6, r.exposure, d.render.exposure, false);
  if (r.random_background) {
    for (int c = 0; c < 3; ++c)
      d.render.background[c] = Uniform(seed, index, 7 + static_cast<uint64_t>(c), 0.0f, 1.0f);
    d.render.background[3] = 1.0f;
  } else if (!r.backgrounds.empty()) {
    const float pick = Uniform(seed, index, 10, 0.0f, static_cast<float>(r.backgrounds.size()));
    d.render.background =
        r.backgrounds[std::min(static_cast<size_t>(pick), r.backgrounds.size() - 1)];
  } else if (!plan.backgrounds.empty()) {
    d.render.background = {
        0, 0, 0, 0};  // Transparent: the sample's picture goes behind (PutOverBackground).
  }
  if (r.gaze_yaw || r.gaze_pitch) {
    d.gaze = Gaze{};
    draw(11, r.gaze_yaw, d.gaze->yaw, false);
    draw(12, r.gaze_pitch, d.gaze->pitch, false);
  }
  for (size_t e = 0; e < r.expressions.size(); ++e) {
    const auto& [name, strength] = r.expressions[e];
    WeightEntry entry;
    entry.name = name;
    entry.value = Uniform(seed, index, 100 + e, strength.lo, strength.hi);
    d.expressions.push_back(std::move(entry));
  }
  d.render.labels = true;
  d.render.segment_of_primitive = plan.segment_of_primitive;
  return d;
}

bool PinholeCamera::Project(const std::array<double, 3>& p, std::array<double, 2>& xy,
                            std::array<double, 3>& c) const {
  for (int r = 0; r < 3; ++r) {
    const double* row = &world_to_camera[static_cast<size_t>(4 * r)];
    c[static_cast<size_t>(r)] = row[0] * p[0] + row[1] * p[1] + row[2] * p[2] + row[3];
  }
  if (!(c[2] < 0.0)) return false;
  xy = {fx * c[0] / -c[2] + cx, fy * -c[1] / -c[2] + cy};
  return true;
}

PinholeCamera CameraOf(const picture::Image& image) {
  const auto P = [&image](int r, int c) {
    return static_cast<double>(image.projection[static_cast<size_t>(4 * c + r)]);
  };
  PinholeCamera cam;
  cam.width = image.width;
  cam.height = image.height;
  cam.fx = 0.5 * image.width * P(0, 0);
  cam.cx = 0.5 * image.width * (1.0 - P(0, 2));
  cam.fy = 0.5 * image.height * P(1, 1);
  cam.cy = 0.5 * image.height * (1.0 + P(1, 2));
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c)
      cam.world_to_camera[static_cast<size_t>(4 * r + c)] =
          image.view[static_cast<size_t>(4 * c + r)];
  }
  cam.near = P(2, 3) / (P(2, 2) - 1.0);
  cam.far = P(2, 3) / (P(2, 2) + 1.0);
  return cam;
}

void SegmentsOf(const Rig& rig, std::vector<uint32_t>& of_primitive,
                std::vector<std::string>& names) {
  names = {"background"};
  of_primitive.assign(rig.primitives.size(), 0);
  for (const Region& region : rig.regions) {
    names.push_back(region.name);
    for (uint32_t p : region.primitives) {
      if (p < of_primitive.size() && of_primitive[p] == 0)
        of_primitive[p] = static_cast<uint32_t>(names.size() - 1);
    }
  }
  std::vector<uint32_t> of_material(rig.materials.size() + 1, 0);  // The last: no material.
  for (size_t p = 0; p < rig.primitives.size(); ++p) {
    if (of_primitive[p] != 0) continue;
    const int m = rig.primitives[p].material;
    const size_t slot = m >= 0 ? static_cast<size_t>(m) : rig.materials.size();
    if (of_material[slot] == 0) {
      names.push_back(m >= 0 ? (rig.materials[slot].name.empty() ? "material " + std::to_string(m)
                                                                 : rig.materials[slot].name)
                             : "no material");
      of_material[slot] = static_cast<uint32_t>(names.size() - 1);
    }
    of_primitive[p] = of_material[slot];
  }
}

namespace {

// Sample `index`'s point: the variant's, with the drawn expressions and gaze on its face.
void SamplePoint(const BatchPlan& plan, size_t index, const SampleDraw& draw,
                 evaluator::ResolvedPoint& point) {
  if (draw.expressions.empty() && !draw.gaze) return VariantPoint(plan, index, point);
  VariantWeights(plan, index, point);  // Checked once the drawn face is on.
  const Rig& rig = plan.rig->rig;
  PoseRequest face = plan.request.render.mesh.pose;
  face.expressions.insert(face.expressions.end(), draw.expressions.begin(), draw.expressions.end());
  if (draw.gaze) face.gaze = draw.gaze;
  std::vector<float> with;
  std::vector<Warning> warnings;
  if (!ResolvePoseAndWeights(rig, {}, face, with, point.pose, point.posed, warnings).ok())
    return VariantPoint(plan, index, point);  // Tried by the plan.
  for (size_t s = 0; s < point.weights.size() && s < with.size(); ++s) {
    const float planned = s < plan.face_weights.size() ? plan.face_weights[s] : 0.0f;
    const float bare = s < plan.bare_weights.size() ? plan.bare_weights[s] : 0.0f;
    point.weights[s] += with[s] - bare - planned;
  }
  evaluator::CheckPoint(rig, plan.request.render.mesh.options.mode, point);
  point.report.warnings.insert(point.report.warnings.end(), warnings.begin(), warnings.end());
}

// Landmark `l` in world space under the blended rig.
std::array<double, 3> LandmarkAt(const Landmark& l, const BlendedRig& blended) {
  const BlendedPrimitive& b = blended.primitives[l.primitive];
  std::array<double, 3> out{0, 0, 0};
  for (int k = 0; k < 3; ++k) {
    float q[3];
    TransformPoint(b.world,
                   &b.positions[3 * static_cast<size_t>(l.vertices[static_cast<size_t>(k)])], q);
    for (int c = 0; c < 3; ++c)
      out[static_cast<size_t>(c)] += static_cast<double>(l.weights[static_cast<size_t>(k)]) * q[c];
  }
  return out;
}

// The drawn triangles in camera space, each with its box on the image, for occlusion tests.
struct DrawnTriangle {
  std::array<std::array<double, 3>, 3> c;  // Camera space.
  double x0, y0, x1, y1;                   // Pixels.
};

std::vector<DrawnTriangle> DrawnTriangles(const Rig& rig, const BlendedRig& blended,
                                          const PinholeCamera& cam) {
  std::vector<DrawnTriangle> out;
  std::vector<std::array<double, 3>> c;
  std::vector<std::array<double, 2>> xy;
  std::vector<char> in_front;
  for (size_t p = 0; p < rig.primitives.size(); ++p) {
    const Primitive& prim = rig.primitives[p];
    // Drawn as the renderer draws the labels: triangles of a material not wholly transparent.
    if (prim.mode != PrimitiveMode::kTriangles || !(DrawnAlpha(rig, blended, prim.material) > 0.0f))
      continue;
    const BlendedPrimitive& b = blended.primitives[p];
    const size_t n = b.positions.size() / 3;
    c.resize(n);
    xy.resize(n);
    in_front.resize(n);
    for (size_t v = 0; v < n; ++v) {
      float q[3];
      TransformPoint(b.world, &b.positions[3 * v], q);
      in_front[v] = cam.Project({q[0], q[1], q[2]}, xy[v], c[v]) && -c[v][2] >= cam.near;
    }
    for (size_t i = 0; i + 2 < prim.indices.size(); i += 3) {
      const uint32_t t[3] = {prim.indices[i], prim.indices[i + 1], prim.indices[i + 2]};
      if (!in_front[t[0]] || !in_front[t[1]] || !in_front[t[2]]) continue;  // Clipped: GL's.
      DrawnTriangle d{{c[t[0]], c[t[1]], c[t[2]]}, 1e300, 1e300, -1e300, -1e300};
      for (uint32_t v : t) {
        d.x0 = std::min(d.x0, xy[v][0]), d.x1 = std::max(d.x1, xy[v][0]);
        d.y0 = std::min(d.y0, xy[v][1]), d.y1 = std::max(d.y1, xy[v][1]);
      }
      out.push_back(d);
    }
  }
  return out;
}

// Whether a drawn triangle crosses the ray from the eye to camera-space point `c` (Moller-Trumbore)
// nearer than its own distance less kLandmarkOcclusionSlack of it.
bool Occluded(std::span<const DrawnTriangle> triangles, const std::array<double, 2>& xy,
              const std::array<double, 3>& c) {
  for (const DrawnTriangle& t : triangles) {
    if (xy[0] < t.x0 || xy[0] > t.x1 || xy[1] < t.y0 || xy[1] > t.y1) continue;
    double e1[3], e2[3], pv[3], qv[3];
    for (int k = 0; k < 3; ++k) e1[k] = t.c[1][k] - t.c[0][k], e2[k] = t.c[2][k] - t.c[0][k];
    pv[0] = c[1] * e2[2] - c[2] * e2[1], pv[1] = c[2] * e2[0] - c[0] * e2[2],
    pv[2] = c[0] * e2[1] - c[1] * e2[0];
    const double det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
    if (std::abs(det) < 1e-300) continue;
    const double tv[3] = {-t.c[0][0], -t.c[0][1], -t.c[0][2]};  // The eye is the origin.
    const double u = (tv[0] * pv[0] + tv[1] * pv[1] + tv[2] * pv[2]) / det;
    if (u < 0 || u > 1) continue;
    qv[0] = tv[1] * e1[2] - tv[2] * e1[1], qv[1] = tv[2] * e1[0] - tv[0] * e1[2],
    qv[2] = tv[0] * e1[1] - tv[1] * e1[0];
    const double v = (c[0] * qv[0] + c[1] * qv[1] + c[2] * qv[2]) / det;
    const double along = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) / det;  // 1: at c.
    if (v >= 0 && u + v <= 1 && along > 0 && along < 1.0 - kLandmarkOcclusionSlack) return true;
  }
  return false;
}

json LandmarksJson(const Rig& rig, const BlendedRig& blended, const PinholeCamera& cam) {
  json list = json::array();
  const std::vector<DrawnTriangle> drawn = DrawnTriangles(rig, blended, cam);
  for (const Landmark& l : rig.landmarks) {
    const std::array<double, 3> p = LandmarkAt(l, blended);
    std::array<double, 2> xy{0, 0};
    std::array<double, 3> c{0, 0, 0};
    const bool visible = cam.Project(p, xy, c) && xy[0] >= 0 && xy[1] >= 0 && xy[0] < cam.width &&
                         xy[1] < cam.height && !Occluded(drawn, xy, c);
    list.push_back({{"name", l.name},
                    {"xy", {Short(xy[0]), Short(xy[1])}},
                    {"xyz", {Short(p[0]), Short(p[1]), Short(p[2])}},
                    {"visible", visible}});
  }
  return list;
}

json CameraJson(const PinholeCamera& cam, const picture::RenderOptions& o) {
  json w2c = json::array();
  for (int r = 0; r < 4; ++r) {
    json row = json::array();
    for (int c = 0; c < 4; ++c)
      row.push_back(Short(cam.world_to_camera[static_cast<size_t>(4 * r + c)]));
    w2c.push_back(row);
  }
  return {{"K", {{Short(cam.fx), 0, Short(cam.cx)}, {0, Short(cam.fy), Short(cam.cy)}, {0, 0, 1}}},
          {"world_to_camera", w2c},
          {"projection",
           "pixel = K (x, -y, -z) / -z for (x, y, z) = world_to_camera p: the camera looks down -z "
           "with y up (glTF); "
           "pixel centres at +0.5, origin top left"},
          {"fov_y_degrees", Short(o.camera.fov)},
          {"near", Short(cam.near)},
          {"far", Short(cam.far)},
          {"width", cam.width},
          {"height", cam.height}};
}

// What KEY.json says of the point and how it was drawn.
void PointJson(const BatchPlan& plan, const SampleDraw& draw, const evaluator::ResolvedPoint& point,
               json& j) {
  const Rig& rig = plan.rig->rig;
  j["weights"] = json::parse(evaluator::WeightsMapJson(rig, point.weights));
  json expressions = json::object();
  for (const auto* list : {&plan.request.render.mesh.pose.expressions, &draw.expressions}) {
    for (const WeightEntry& e : *list) expressions[e.name] = Short(e.value);
  }
  j["expressions"] = expressions;
  const std::optional<Gaze>& gaze = draw.gaze ? draw.gaze : plan.request.render.mesh.pose.gaze;
  if (gaze && gaze->has_target)
    j["gaze"] = {
        {"target", {Short(gaze->target[0]), Short(gaze->target[1]), Short(gaze->target[2])}}};
  else if (gaze)
    j["gaze"] = {{"yaw", Short(gaze->yaw)}, {"pitch", Short(gaze->pitch)}};
  j["pose"] = json::parse(plan.pose_json);
  const picture::RenderOptions& o = draw.render;
  j["render"] = {{"camera",
                  {{"yaw", Short(o.camera.yaw)},
                   {"pitch", Short(o.camera.pitch)},
                   {"zoom", Short(o.camera.zoom)}}},
                 {"light", {{"yaw", Short(o.light_yaw)}, {"pitch", Short(o.light_pitch)}}},
                 {"exposure", Short(o.exposure)},
                 {"background",
                  {Short(o.background[0]), Short(o.background[1]), Short(o.background[2]),
                   Short(o.background[3])}}};
  j["warnings"] = json::parse(formats::WarningsToJson(point.report.warnings));
}

// The label planes as files, each as asked.
Status LabelFiles(const BatchPlan& plan, const picture::Renderer& renderer,
                  const picture::Image& image, std::vector<SampleFile>& files) {
  const evaluator::DatasetRequest& d = plan.request.dataset;
  const picture::LabelPlanes& planes = image.labels;
  if (d.has(evaluator::Label::kDepth)) {
    auto exr = renderer.EncodeData(planes.distance, image.width, image.height, 1,
                                   picture::DataPrecision::kFloat);
    if (!exr.ok()) return exr.status();
    files.push_back({"depth.exr", std::move(exr.value())});
  }
  if (d.has(evaluator::Label::kNormals)) {
    auto exr = renderer.EncodeData(planes.normal, image.width, image.height, 3,
                                   picture::DataPrecision::kHalf);
    if (!exr.ok()) return exr.status();
    files.push_back({"normals.exr", std::move(exr.value())});
  }
  if (d.has(evaluator::Label::kSegmentation)) {
    auto png = renderer.EncodeIds(planes.segment, image.width, image.height);
    if (!png.ok()) return png.status();
    files.push_back({"seg.png", std::move(png.value())});
  }
  return Status::Ok();
}

// Sample `index`'s picture (plan.backgrounds, drawn from its stream) behind what `image` drew over
// a transparent background; its index in plan.backgrounds.
size_t PutOverBackground(const BatchPlan& plan, size_t index, picture::Image& image) {
  const size_t n = plan.backgrounds.size();
  const size_t k = std::min(
      n - 1, static_cast<size_t>(Uniform(plan.draw_seed, index, 13, 0.0f, static_cast<float>(n))));
  BlendOver(image, plan.backgrounds[k]);
  return k;
}

}  // namespace

Status MakeSample(const BatchPlan& plan, size_t index, const evaluator::Evaluator& evaluator,
                  evaluator::Workspace& ws, evaluator::ResolvedPoint& point,
                  std::vector<SampleFile>& files) {
  files.clear();
  const SampleDraw draw = DrawSample(plan, index);
  SamplePoint(plan, index, draw, point);
  evaluator::OutputSpec spec = plan.output;
  spec.kind = evaluator::OutputSpec::Kind::kPixels;
  spec.render = draw.render;
  if (auto drawn = evaluator.Run(plan.rig, point, spec, ws); !drawn.ok()) return drawn.status();
  const size_t background = plan.backgrounds.empty() ? 0 : PutOverBackground(plan, index, ws.image);
  auto picture = evaluator.renderer()->Encode(ws.image, plan.request.image_format,
                                              plan.request.render.quality, ws.helper_cpu);
  if (!picture.ok()) return picture.status();
  files.push_back({plan.request.format, std::move(picture.value())});
  if (Status s = LabelFiles(plan, *evaluator.renderer(), ws.image, files); !s.ok()) return s;
  const PinholeCamera cam = CameraOf(ws.image);
  const std::string key = VariantId(plan, index);
  json j = {
      {"key", key},
      {"index", index},
      {"image",
       {{"file", key + "." + plan.request.format}, {"width", cam.width}, {"height", cam.height}}}};
  j["camera"] = CameraJson(cam, draw.render);
  const evaluator::DatasetRequest& d = plan.request.dataset;
  if (d.has(evaluator::Label::kDepth)) j["depth"] = "distance along the ray, metres";
  if (d.has(evaluator::Label::kNormals))
    j["normals"] = "camera space, unit (x right, y up, z toward the eye)";
  if (d.has(evaluator::Label::kSegmentation)) {
    json legend = json::object();
    for (size_t id = 0; id < plan.segment_names.size(); ++id)
      legend[std::to_string(id)] = plan.segment_names[id];
    j["segmentation"] = legend;
  }
  if (d.has(evaluator::Label::kLandmarks)) {
    j["landmark_scheme"] = plan.rig->rig.landmark_scheme;
    j["landmarks"] = LandmarksJson(plan.rig->rig, ws.blended, cam);
  }
  if (!plan.backgrounds.empty()) j["background_image"] = plan.backgrounds[background].name;
  PointJson(plan, draw, point, j);
  files.push_back({"json", j.dump(-1, ' ', false, json::error_handler_t::replace) + "\n"});
  return Status::Ok();
}

}  // namespace facespace::batch
