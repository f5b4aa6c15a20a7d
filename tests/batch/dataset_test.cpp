// Labelled samples against a CPU ray cast of the mesh they were drawn from: each pixel's ray, built
// from the camera KEY.json states (K, world_to_camera, near, far), is intersected in double
// precision with every triangle whose projection covers it; the hit must be the depth the EXR holds
// (1 mm), its interpolated normal the normal EXR's (2 degrees), its primitive's segment the PNG's
// id; each landmark's pixel must be its 3D point projected (0.5 px) and it visible just when no
// drawn triangle crosses the ray to it (the same ray cast). 100 samples of FaceCap and of Uka at
// 256 x 256 with the camera, light, background and (Uka) expressions and gaze drawn. GL rasterises
// on a grid of 1/256 px: at a silhouette, or a fold of a shape pushed past its range, that grid can
// put a pixel centre on the other side of an edge than the exact ray. Those pixels are counted,
// told apart (a layer behind the nearest, a surface 1/256 px away), and must stay under 1 in
// 10,000.
#include "facespace/batch/dataset.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "facespace/batch/run.h"
#include "facespace/engine/transform.h"
#include "facespace/offscreen/render.h"
#include "test_util.h"

namespace facespace {
namespace dataset_test {

using nlohmann::json;
namespace fs = std::filesystem;

// A decoded image file: its channels as floats, as stored.
std::vector<float> DecodeChannels(const std::string& bytes, const char* name, int* channels) {
  OIIO::Filesystem::IOMemReader proxy(bytes.data(), bytes.size());
  auto in = OIIO::ImageInput::open(name, nullptr, &proxy);
  if (!in) return {};
  const OIIO::ImageSpec& spec = in->spec();
  *channels = spec.nchannels;
  std::vector<float> values(static_cast<size_t>(spec.width) * spec.height * spec.nchannels);
  // PNG ids as they are (8 or 16 bits), not scaled to 0..1.
  const OIIO::TypeDesc type =
      std::string(name).ends_with(".png") ? OIIO::TypeDesc::UINT16 : OIIO::TypeDesc::FLOAT;
  if (type == OIIO::TypeDesc::UINT16) {
    std::vector<uint16_t> ids(values.size());
    if (!in->read_image(0, 0, 0, spec.nchannels, type, ids.data())) return {};
    const float scale = spec.format == OIIO::TypeDesc::UINT8
                            ? 1.0f / 257.0f
                            : 1.0f;  // 8-bit ids come widened as v * 257.
    for (size_t i = 0; i < ids.size(); ++i)
      values[i] = std::round(static_cast<float>(ids[i]) * scale);
  } else if (!in->read_image(0, 0, 0, spec.nchannels, type, values.data())) {
    return {};
  }
  return values;
}

// The camera KEY.json states.
struct StatedCamera {
  Eigen::Matrix3d K;
  Eigen::Matrix4d world_to_camera;
  Eigen::Vector3d eye;
  int width = 0, height = 0;
  double near = 0, far = 0;
  double Depth(const Eigen::Vector3d& p) const {
    return -(world_to_camera * p.homogeneous()).z();
  }  // Along -z.
  // The world-space direction of the ray through pixel position (x, y) (not unit).
  Eigen::Vector3d Ray(double x, double y) const {
    const Eigen::Vector3d c((x - K(0, 2)) / K(0, 0), -(y - K(1, 2)) / K(1, 1), -1.0);
    return world_to_camera.topLeftCorner<3, 3>().transpose() * c;
  }
  // Pixel position of world point p: K (x, -y, -z) / -z.
  Eigen::Vector2d Project(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d c = (world_to_camera * p.homogeneous()).head<3>();
    return {K(0, 0) * c.x() / -c.z() + K(0, 2), K(1, 1) * -c.y() / -c.z() + K(1, 2)};
  }
};

StatedCamera CameraOfJson(const json& j) {
  StatedCamera cam;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) cam.K(r, c) = j["K"][r][c].get<double>();
  }
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c)
      cam.world_to_camera(r, c) = j["world_to_camera"][r][c].get<double>();
  }
  cam.eye = -cam.world_to_camera.topLeftCorner<3, 3>().transpose() *
            cam.world_to_camera.topRightCorner<3, 1>();
  cam.near = j["near"].get<double>();
  cam.far = j["far"].get<double>();
  cam.width = j["width"].get<int>();
  cam.height = j["height"].get<int>();
  return cam;
}

// A hit along one pixel's ray.
struct Hit {
  double distance = INFINITY;
  int primitive = -1;
  Eigen::Vector3d normal{
      0, 0, 0};        // Interpolated, world space, facing the way the triangle faces the eye.
  double grazing = 1;  // |cos| of the angle between the ray and the triangle's plane normal.
};
// The hits along one pixel's ray, nearest first: a few kept in place (no allocation per pixel: the
// test runs under ASan too), the farthest let go past kKept.
struct Hits {
  static constexpr size_t kKept = 8;
  std::array<Hit, kKept> hit;
  size_t count = 0;
  void Add(const Hit& h) {
    size_t i = std::min(count, kKept - 1);
    if (count == kKept && h.distance >= hit[i].distance) return;
    while (i > 0 && hit[i - 1].distance > h.distance) hit[i] = hit[i - 1], --i;
    hit[i] = h;
    count = std::min(count + 1, kKept);
  }
  bool empty() const { return count == 0; }
  size_t size() const { return count; }
  const Hit& operator[](size_t k) const { return hit[k]; }
  const Hit* begin() const { return hit.data(); }
  const Hit* end() const { return hit.data() + count; }
};

// The blended mesh in world space, with its vertex normals, as the renderer places them.
struct WorldMesh {
  std::vector<std::vector<Eigen::Vector3d>> positions, normals;
};
WorldMesh WorldOf(const Rig& rig, const BlendedRig& b) {
  WorldMesh w;
  for (size_t p = 0; p < rig.primitives.size(); ++p) {
    const BlendedPrimitive& bp = b.primitives[p];
    const Eigen::Matrix4d m = Eigen::Map<const Eigen::Matrix4f>(bp.world.data()).cast<double>();
    const Eigen::Matrix3d nm = m.topLeftCorner<3, 3>().inverse().transpose();
    w.positions.emplace_back();
    w.normals.emplace_back();
    for (size_t v = 0; v < rig.primitives[p].vertex_count(); ++v) {
      const Eigen::Vector3d q(bp.positions[3 * v], bp.positions[3 * v + 1],
                              bp.positions[3 * v + 2]);
      w.positions.back().push_back((m * q.homogeneous()).head<3>());
      w.normals.back().push_back(
          (nm * Eigen::Vector3d(bp.normals[3 * v], bp.normals[3 * v + 1], bp.normals[3 * v + 2]))
              .normalized());
    }
  }
  return w;
}

// Whether a primitive shows (the renderer's rule): triangles of a material not wholly transparent.
bool Shows(const Rig& rig, const BlendedRig& b, const Primitive& p) {
  if (p.mode != PrimitiveMode::kTriangles) return false;
  if (p.material < 0) return true;
  const size_t m = static_cast<size_t>(p.material);
  return (m < b.material_colors.size() ? b.material_colors[m][3]
                                       : rig.materials[m].base_color_factor[3]) > 0.0f;
}

// Möller-Trumbore in double: the ray parameter t and barycentrics (u, v) of the hit, or false.
bool Intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& a,
               const Eigen::Vector3d& b, const Eigen::Vector3d& c, double* t, double* u,
               double* v) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a, pv = d.cross(e2);
  const double det = e1.dot(pv);
  if (std::abs(det) < 1e-300) return false;
  const Eigen::Vector3d tv = o - a, qv = tv.cross(e1);
  *u = tv.dot(pv) / det;
  *v = d.dot(qv) / det;
  *t = e2.dot(qv) / det;
  return *u >= 0 && *v >= 0 && *u + *v <= 1 && *t > 0;
}

// Each triangle of the primitives that show, in world space: f(primitive, its first index's place
// in the primitive's indices, its corners).
template <typename F>
void ForEachShownTriangle(const Rig& rig, const BlendedRig& b, const WorldMesh& w, F&& f) {
  for (size_t p = 0; p < rig.primitives.size(); ++p) {
    if (!Shows(rig, b, rig.primitives[p])) continue;
    const std::vector<uint32_t>& idx = rig.primitives[p].indices;
    for (size_t i = 0; i + 2 < idx.size(); i += 3)
      f(p, i, w.positions[p][idx[i]], w.positions[p][idx[i + 1]], w.positions[p][idx[i + 2]]);
  }
}

// Every pixel's hits: each triangle tried against the pixel centres its projection's box holds.
// With `near`: only the pixels it marks, each through nine rays moved by up to GL's subpixel step
// (1/256 px) each way: llvmpipe snaps vertices to that grid, so at a grazing fold or a silhouette
// the fragment at a pixel centre can be a surface the exact centre's ray just misses.
std::vector<Hits> CastAll(const Rig& rig, const BlendedRig& b, const WorldMesh& w,
                          const StatedCamera& cam, const std::vector<char>* near = nullptr) {
  std::vector<Hits> hits(static_cast<size_t>(cam.width) * cam.height);
  const int steps = near ? 1 : 0, grow = near ? 1 : 0;
  std::vector<Eigen::Vector3d> centre(hits.size());  // Each pixel centre's ray, made once.
  for (size_t at = 0; at < centre.size(); ++at)
    centre[at] = cam.Ray(static_cast<double>(at % cam.width) + 0.5,
                         static_cast<double>(at / cam.width) + 0.5);
  ForEachShownTriangle(
      rig, b, w,
      [&](size_t p, size_t i, const Eigen::Vector3d& A, const Eigen::Vector3d& B,
          const Eigen::Vector3d& C) {
        const std::vector<uint32_t>& idx = rig.primitives[p].indices;
        // The pixels to try: the box of the triangle's part beyond the near plane (GL clips the
        // rest).
        Eigen::Vector2d lo(INFINITY, INFINITY), hi(-INFINITY, -INFINITY);
        const Eigen::Vector3d* corners[3] = {&A, &B, &C};
        for (int e = 0; e < 3; ++e) {
          const Eigen::Vector3d &P = *corners[e], &Q = *corners[(e + 1) % 3];
          const double dp = cam.Depth(P) - cam.near, dq = cam.Depth(Q) - cam.near;
          if (dp >= 0) lo = lo.cwiseMin(cam.Project(P)), hi = hi.cwiseMax(cam.Project(P));
          if ((dp >= 0) != (dq >= 0)) {
            const Eigen::Vector2d x = cam.Project(P + (Q - P) * (dp / (dp - dq)));
            lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
          }
        }
        if (!(lo.x() <= hi.x())) return;  // Wholly before the near plane.
        // Front-facing as GL says: counter-clockwise with y up (pixel rows run down).
        const Eigen::Vector2d a = cam.Project(A), bb = cam.Project(B), c = cam.Project(C);
        const bool front =
            ((bb.x() - a.x()) * (a.y() - c.y()) - (a.y() - bb.y()) * (c.x() - a.x()) > 0) ==
            (cam.Depth(A) > 0 && cam.Depth(B) > 0 && cam.Depth(C) > 0);
        const int x0 = std::max(0, static_cast<int>(std::floor(lo.x() - 0.5)) - grow);
        const int x1 = std::min(cam.width - 1, static_cast<int>(std::ceil(hi.x() - 0.5)) + grow);
        const int y0 = std::max(0, static_cast<int>(std::floor(lo.y() - 0.5)) - grow);
        const int y1 = std::min(cam.height - 1, static_cast<int>(std::ceil(hi.y() - 0.5)) + grow);
        const Eigen::Vector3d e = (B - A).cross(C - A).normalized();
        for (int y = y0; y <= y1; ++y) {
          for (int x = x0; x <= x1; ++x) {
            const size_t at = static_cast<size_t>(y) * cam.width + x;
            if (near && !(*near)[at]) continue;
            for (int jy = -steps; jy <= steps; ++jy) {
              for (int jx = -steps; jx <= steps; ++jx) {
                const Eigen::Vector3d d =
                    near ? cam.Ray(x + 0.5 + jx / 256.0, y + 0.5 + jy / 256.0) : centre[at];
                double t, u, v;
                if (!Intersect(cam.eye, d, A, B, C, &t, &u, &v)) continue;
                const double z = cam.Depth(cam.eye + t * d);
                if (z < cam.near || z > cam.far) continue;  // Clipped, as GL clips it.
                const Eigen::Vector3d n = (1 - u - v) * w.normals[p][idx[i]] +
                                          u * w.normals[p][idx[i + 1]] +
                                          v * w.normals[p][idx[i + 2]];
                hits[at].Add({t * d.norm(), static_cast<int>(p), front ? n : Eigen::Vector3d(-n),
                              std::abs(e.dot(d.normalized()))});
              }
            }
          }
        }
      });
  return hits;
}

// Per point, whether a drawn triangle crosses the segment from the eye to it (short of the point
// by batch::kLandmarkOcclusionSlack of its distance), in front of the near plane: each triangle
// tried against the points its projection's box holds.
std::vector<char> Blocked(const Rig& rig, const BlendedRig& b, const WorldMesh& w,
                          const StatedCamera& cam, const std::vector<Eigen::Vector3d>& points) {
  std::vector<char> out(points.size(), 0);
  std::vector<Eigen::Vector2d> at;
  for (const Eigen::Vector3d& p : points) at.push_back(cam.Project(p));
  ForEachShownTriangle(
      rig, b, w,
      [&](size_t, size_t, const Eigen::Vector3d& A, const Eigen::Vector3d& B,
          const Eigen::Vector3d& C) {
        if (cam.Depth(A) < cam.near || cam.Depth(B) < cam.near || cam.Depth(C) < cam.near) return;
        const Eigen::Vector2d a = cam.Project(A), bb = cam.Project(B), c = cam.Project(C);
        const Eigen::Vector2d lo = a.cwiseMin(bb).cwiseMin(c), hi = a.cwiseMax(bb).cwiseMax(c);
        for (size_t k = 0; k < points.size(); ++k) {
          if (out[k] || (at[k].array() < lo.array()).any() || (at[k].array() > hi.array()).any())
            continue;
          double t, u, v;
          out[k] = Intersect(cam.eye, points[k] - cam.eye, A, B, C, &t, &u, &v) &&
                   t < 1.0 - batch::kLandmarkOcclusionSlack;
        }
      });
  return out;
}

// What one sample's comparison found.
struct Tally {
  size_t foreground = 0, coverage = 0, depth = 0, behind = 0, snapped = 0, normal = 0, segment = 0,
         landmarks = 0, projection = 0, visibility = 0, hidden = 0;
  double worst_depth = 0, worst_angle = 0, worst_px = 0;
};

void CompareSample(const batch::BatchPlan& plan, const std::vector<batch::SampleFile>& files,
                   const BlendedRig& blended, Tally& t) {
  const Rig& rig = plan.rig->rig;
  const json j = json::parse(files.back().bytes);
  const StatedCamera cam = CameraOfJson(j["camera"]);
  int ch = 0;
  const std::vector<float> depth = DecodeChannels(files[1].bytes, "d.exr", &ch);
  ASSERT_EQ(ch, 1);
  const std::vector<float> normals = DecodeChannels(files[2].bytes, "n.exr", &ch);
  ASSERT_EQ(ch, 3);
  const std::vector<float> seg = DecodeChannels(files[3].bytes, "s.png", &ch);
  ASSERT_EQ(ch, 1);
  const WorldMesh world = WorldOf(rig, blended);
  const std::vector<Hits> hits = CastAll(rig, blended, world, cam);
  const Eigen::Matrix3d to_camera = cam.world_to_camera.topLeftCorner<3, 3>();
  // Pixels whose centre's hits hold no surface at GL's depth: tried again through rays 1/256 px
  // around.
  std::vector<char> unmatched(hits.size(), 0);
  bool any = false;
  for (size_t i = 0; i < hits.size(); ++i) {
    if (depth[i] <= 0 || hits[i].empty()) continue;
    unmatched[i] = std::none_of(hits[i].begin(), hits[i].end(), [&](const Hit& h) {
      return std::abs(depth[i] - h.distance) <= 1e-3;
    });
    any |= unmatched[i] != 0;
  }
  const std::vector<Hits> nearby =
      any ? CastAll(rig, blended, world, cam, &unmatched) : std::vector<Hits>();
  for (size_t i = 0; i < hits.size(); ++i) {
    const bool drawn = depth[i] > 0, hit = !hits[i].empty();
    t.foreground += drawn;
    if (drawn != hit) {
      ++t.coverage;  // A pixel centre on a silhouette's edge, told apart by GL's fill rule.
      continue;
    }
    if (!hit) {
      t.segment += seg[i] != 0;
      continue;
    }
    // The surface drawn: the nearest hit, or where GL's subpixel grid (1/256 px) moved a grazing
    // fold's edge across the pixel centre, a hit behind it or one 1/256 px away. Either way a
    // surface on the ray, to 1 mm.
    const Hits* along = unmatched[i] ? &nearby[i] : &hits[i];
    size_t k = 0;
    while (k < along->size() && std::abs(depth[i] - (*along)[k].distance) > 1e-3) ++k;
    t.snapped += unmatched[i] && k < along->size();
    if (k == along->size()) {
      ++t.depth;
      t.worst_depth = std::max(t.worst_depth, std::abs(depth[i] - hits[i][0].distance));
      continue;
    }
    t.behind += along == &hits[i] && (*along)[k].distance - hits[i][0].distance > 1e-3;
    t.worst_depth = std::max(t.worst_depth, std::abs(depth[i] - (*along)[k].distance));
    // Of the surfaces there (two sheets back to back, as MMD's two-sided hair is made, tie), the
    // one whose normal is nearest GL's, and whether any has its segment.
    const Eigen::Vector3d theirs =
        Eigen::Vector3d(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]).normalized();
    double best = 180.0;
    bool same_segment = false;
    for (const Hit& h : *along) {
      if (std::abs(depth[i] - h.distance) > 1e-3) continue;
      const double angle =
          std::acos(std::clamp((to_camera * h.normal).normalized().dot(theirs), -1.0, 1.0)) *
          180.0 / M_PI;
      // A triangle seen within a degree of edge-on may face either way on GL's grid: its normal may
      // be turned.
      best = std::min(best,
                      h.grazing < std::sin(M_PI / 180.0) ? std::min(angle, 180.0 - angle) : angle);
      same_segment |=
          seg[i] == static_cast<float>(plan.segment_of_primitive[static_cast<size_t>(h.primitive)]);
    }
    t.worst_angle = std::max(t.worst_angle, best);
    t.normal += best > 2.0;
    t.segment += !same_segment;
  }
  std::vector<Eigen::Vector3d> points;
  for (const json& l : j["landmarks"])
    points.emplace_back(l["xyz"][0].get<double>(), l["xyz"][1].get<double>(),
                        l["xyz"][2].get<double>());
  const std::vector<char> blocked = Blocked(rig, blended, world, cam, points);
  for (size_t k = 0; k < points.size(); ++k) {
    const json& l = j["landmarks"][k];
    ++t.landmarks;
    const Eigen::Vector2d xy(l["xy"][0].get<double>(), l["xy"][1].get<double>()),
        projected = cam.Project(points[k]);
    t.worst_px = std::max(t.worst_px, (xy - projected).norm());
    t.projection += (xy - projected).norm() > 0.5;
    const bool visible =
        xy.x() >= 0 && xy.y() >= 0 && xy.x() < cam.width && xy.y() < cam.height && !blocked[k];
    t.visibility += visible != l["visible"].get<bool>();
    t.hidden += !visible;
  }
}

void CheckRig(const std::string& path, const std::string& randomize) {
  static const offscreen::OsMesaRenderer renderer(1);
  const evaluator::Evaluator evaluator(renderer);
  auto stored = evaluator::Unstored(formats::LoadRigFile(path).value(), "v1");
  const std::string request =
      R"({"sample": {"method": "uniform", "count": 100, "seed": 11, "active": 4, "sum_at_most_one": true},
      "labels": ["depth", "normals", "segmentation", "landmarks"], "width": 256, "height": 256, "randomize": )" +
      randomize + "}";
  auto plan = batch::MakeBatchPlan(stored, request);
  ASSERT_TRUE(plan.ok()) << plan.status().message;
  evaluator::Workspace ws;
  evaluator::ResolvedPoint point;
  std::vector<batch::SampleFile> files;
  Tally t;
  for (size_t k = 0; k < plan->total; ++k) {
    ASSERT_TRUE(batch::MakeSample(plan.value(), k, evaluator, ws, point, files).ok());
    ASSERT_EQ(files.size(), 5u);
    CompareSample(plan.value(), files, ws.blended, t);
  }
  std::printf(
      "%s: %zu foreground pixels; %zu told apart on silhouettes; depth off by up to %.2g (%zu over "
      "1 mm), %zu a fold's layer behind the nearest, %zu a surface 1/256 px away; "
      "normals up to %.3g deg (%zu over 2); %zu segment ids differ; %zu landmarks, up to %.2g px "
      "off their projection, %zu hidden, %zu visibilities disagree\n",
      fs::path(path).filename().c_str(), t.foreground, t.coverage, t.worst_depth, t.depth, t.behind,
      t.snapped, t.worst_angle, t.normal, t.segment, t.landmarks, t.worst_px, t.hidden,
      t.visibility);
  EXPECT_GT(t.foreground, 100u * 256 * 256 / 10);  // The face fills the frame well.
  EXPECT_LE(t.coverage,
            t.foreground / 1000);  // Edge pixels only: GL's fill rule against an inclusive test.
  // Every pixel's depth is a surface along its ray (or 1/256 px from it), but for one in 100,000 or
  // fewer.
  EXPECT_LE(t.depth, t.foreground / 100000);
  EXPECT_LE(t.behind + t.snapped, t.foreground / 10000);
  EXPECT_LE(t.normal,
            t.foreground / 10000);  // At those folds' pixels: a sheet whose normal the grid turned.
  EXPECT_LE(t.segment,
            t.foreground / 1000);  // Where two parts' triangles lie within rounding of each other.
  EXPECT_EQ(t.landmarks, 100u * 68);
  EXPECT_EQ(t.projection, 0u);
  EXPECT_EQ(t.visibility, 0u);
  EXPECT_GT(t.hidden, 100u);  // Turned 40 degrees, the far cheek's contour; eye corners under lids.
}

TEST(Dataset, FaceCapLabelsAreTheMeshAsDrawn) {
  CheckRig(
      test::Bundled("facecap/facecap.glb"),
      R"({"camera": {"yaw": [-40, 40], "pitch": [-15, 15], "zoom": [0.8, 1.3]}, "light": {"yaw": [-60, 60], "exposure": [-1, 0.5]},
               "background": "random"})");
}

TEST(Dataset, UkaLabelsAreTheMeshAsDrawn) {
  CheckRig(
      test::Bundled("uka/MS_Uka.pmx"),
      R"({"camera": {"yaw": [-40, 40], "pitch": [-15, 15]}, "expressions": {"happy": [0, 1], "blush": [0, 1]},
               "gaze": {"yaw": [-20, 20], "pitch": [-10, 10]}, "background": ["#202020", "#e0e0ff"]})");
}

}  // namespace dataset_test
}  // namespace facespace
