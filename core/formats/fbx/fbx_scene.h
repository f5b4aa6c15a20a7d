// FBX's scene as the importer (fbx_import.cpp) reads it: the objects and their links, property
// templates, the transform stack, meshes split per material slot, and animation curves.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "common/split_mesh.h"
#include "facespace/engine/bezier.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"
#include "fbx/fbx_tree.h"

namespace facespace::formats::fbx_scene {

using fbx::Prop;
using FNode = fbx::Node;
using Mat4 = Eigen::Matrix4d;
using Vec3 = Eigen::Vector3d;

constexpr double kTicksPerSecond = 46186158000.0;
constexpr size_t kMaxControlPoints = 4'000'000;
constexpr size_t kMaxCorners = 16'000'000;
constexpr size_t kMaxPolygonCorners = 4096;
constexpr size_t kMaxJoints = 65535;    // Joint indices are uint16 in a Primitive.
constexpr size_t kMaxFrames = 100'000;  // Samples of one clip.
constexpr size_t kMaxClipValues = 32'000'000;

struct Object {
  int64_t id = 0;
  const FNode* node = nullptr;
  std::string cls;   // "Model", "Geometry", "Deformer", ...
  std::string name;  // Without its class prefix.
  std::string sub;   // "Mesh", "Shape", "LimbNode", "Skin", "Cluster", "BlendShapeChannel", ...
  std::string Describe() const {
    return cls + " '" + name + "'" + (sub.empty() ? "" : " (" + sub + ")");
  }
};

struct Link {
  int64_t other = 0;
  std::string prop;  // For OP links: the property name; "" for OO.
};

std::vector<double> Numbers(const Prop& p);

std::vector<int64_t> Ints(const Prop& p);

// `v` as an int when it is one in [lo, hi], else `fallback` (file numbers may be anything).
int IntIn(double v, int lo, int hi, int fallback);

// The array property of child `name` of `n`, or nullptr.
const Prop* ArrayOf(const FNode& n, std::string_view name);

class Scene {
 public:
  Status Index(const fbx::Document& doc) {
    if (const FNode* defs = doc.Find("Definitions")) {
      for (const FNode& t : defs->children) {
        if (t.name != "ObjectType" || t.props.empty()) continue;
        if (const FNode* tpl = t.Find("PropertyTemplate")) {
          if (const FNode* p70 = tpl->Find("Properties70")) templates_[t.props[0].s] = p70;
        }
      }
    }
    if (const FNode* settings = doc.Find("GlobalSettings"))
      settings_ = settings->Find("Properties70");
    const FNode* objects = doc.Find("Objects");
    if (!objects) return InvalidArgument("FBX: no Objects section");
    for (const FNode& n : objects->children) {
      if (n.props.size() < 2 || !n.props[0].IsScalarNumber() || n.props[1].kind != Prop::kString)
        continue;
      Object o;
      o.id = n.props[0].AsInt();
      o.node = &n;
      o.cls = n.name;
      o.name = fbx::ObjectName(n.props[1].s);
      if (n.props.size() > 2 && n.props[2].kind == Prop::kString) o.sub = n.props[2].s;
      if (o.id == 0) return InvalidArgument("FBX: " + o.Describe() + " has id 0, the scene root's");
      if (!objects_.emplace(o.id, o).second)
        return InvalidArgument("FBX: two objects have id " + std::to_string(o.id));
      order_.push_back(o.id);
    }
    if (const FNode* conns = doc.Find("Connections")) {
      for (const FNode& c : conns->children) {
        if (c.name != "C" || c.props.size() < 3 || c.props[0].kind != Prop::kString) continue;
        const int64_t child = c.props[1].AsInt(), parent = c.props[2].AsInt();
        const std::string prop = c.props[0].s == "OP" && c.props.size() > 3 ? c.props[3].s : "";
        sources_[parent].push_back({child, prop});
        targets_[child].push_back({parent, prop});
      }
    }
    return Status::Ok();
  }

  const Object* Get(int64_t id) const {
    auto it = objects_.find(id);
    return it == objects_.end() ? nullptr : &it->second;
  }
  const std::vector<int64_t>& order() const { return order_; }

  // Objects of class `cls` (and subclass `sub` unless empty) linked into `id`, in file order.
  std::vector<std::pair<const Object*, std::string>> Sources(int64_t id, std::string_view cls,
                                                             std::string_view sub = {}) const {
    return Filter(sources_, id, cls, sub);
  }
  // Objects of class `cls` that `id` links into.
  std::vector<std::pair<const Object*, std::string>> Targets(int64_t id, std::string_view cls,
                                                             std::string_view sub = {}) const {
    return Filter(targets_, id, cls, sub);
  }

  // The values of property `name`: the object's own, else its class's template; nullptr if neither.
  const FNode* Property(const Object& o, std::string_view name) const {
    if (const FNode* p70 = o.node->Find("Properties70")) {
      if (const FNode* p = FindP(*p70, name)) return p;
    }
    auto it = templates_.find(o.cls);
    return it == templates_.end() ? nullptr : FindP(*it->second, name);
  }
  double Number(const Object& o, std::string_view name, double fallback) const {
    const FNode* p = Property(o, name);
    return p && p->props.size() > 4 && p->props[4].IsScalarNumber() ? p->props[4].AsNumber()
                                                                    : fallback;
  }
  Vec3 Vector(const Object& o, std::string_view name, const Vec3& fallback) const {
    const FNode* p = Property(o, name);
    if (!p || p->props.size() < 7) return fallback;
    Vec3 v;
    for (int c = 0; c < 3; ++c) {
      if (!p->props[4 + c].IsScalarNumber() || !std::isfinite(p->props[4 + c].AsNumber()))
        return fallback;
      v[c] = p->props[4 + c].AsNumber();
    }
    return v;
  }
  double Setting(std::string_view name, double fallback) const {
    const FNode* p = settings_ ? FindP(*settings_, name) : nullptr;
    return p && p->props.size() > 4 && p->props[4].IsScalarNumber() ? p->props[4].AsNumber()
                                                                    : fallback;
  }

 private:
  static const FNode* FindP(const FNode& p70, std::string_view name) {
    for (const FNode& p : p70.children) {
      if (p.name == "P" && !p.props.empty() && p.props[0].kind == Prop::kString &&
          p.props[0].s == name)
        return &p;
    }
    return nullptr;
  }

  std::vector<std::pair<const Object*, std::string>> Filter(
      const std::unordered_map<int64_t, std::vector<Link>>& links, int64_t id, std::string_view cls,
      std::string_view sub) const {
    std::vector<std::pair<const Object*, std::string>> out;
    auto it = links.find(id);
    if (it == links.end()) return out;
    for (const Link& l : it->second) {
      const Object* o = Get(l.other);
      if (o && o->cls == cls && (sub.empty() || o->sub == sub)) out.emplace_back(o, l.prop);
    }
    return out;
  }

  std::unordered_map<int64_t, Object> objects_;
  std::vector<int64_t> order_;
  std::unordered_map<int64_t, std::vector<Link>> sources_, targets_;
  std::map<std::string, const FNode*, std::less<>> templates_;
  const FNode* settings_ = nullptr;
};

// ---------------------------------------------------------------------------------------------
// Transforms

Mat4 Translation(const Vec3& t);

Mat4 Scaling(const Vec3& s);

// Euler angles in degrees applied in `order` (FBX's enum: 0 XYZ, 1 XZY, 2 YZX, 3 YXZ, 4 ZXY,
// 5 ZYX, 6 spheric XYZ): XYZ rotates about X first, i.e. the matrix Rz * Ry * Rx.
Mat4 Rotation(const Vec3& deg, int order);

// The static parts of a Model's transform stack: everything but T, R and S themselves.
struct TransformStack {
  Vec3 t{0, 0, 0}, r{0, 0, 0}, s{1, 1, 1};
  Vec3 rotation_offset{0, 0, 0}, rotation_pivot{0, 0, 0}, scaling_offset{0, 0, 0},
      scaling_pivot{0, 0, 0};
  Mat4 pre = Mat4::Identity(), post_inverse = Mat4::Identity();
  int order = 0;
  Mat4 geometric = Mat4::Identity();

  // T * Roff * Rp * Rpre * R * Rpost^-1 * Rp^-1 * Soff * Sp * S * Sp^-1 (FBX SDK's local matrix).
  Mat4 Local(const Vec3& tt, const Vec3& rr, const Vec3& ss) const {
    return Translation(tt) * Translation(rotation_offset) * Translation(rotation_pivot) * pre *
           Rotation(rr, order) * post_inverse * Translation(-rotation_pivot) *
           Translation(scaling_offset) * Translation(scaling_pivot) * Scaling(ss) *
           Translation(-scaling_pivot);
  }
  Mat4 Local() const { return Local(t, r, s); }
};

TransformStack ReadStack(const Scene& scene, const Object& m);

// ---------------------------------------------------------------------------------------------
// Meshes

// A per-corner attribute (normals, UVs, colours): which value each corner reads.
struct Element {
  std::vector<double> values;
  std::vector<int64_t> index;  // IndexToDirect, else empty.
  enum Map { kCorner, kPoint, kPolygon, kAll } map = kCorner;
  int stride = 3;
  bool present = false;

  // The value slot for a corner, or -1 when the file's arrays do not reach.
  int64_t Slot(size_t corner, size_t point, size_t polygon) const {
    size_t k = map == kCorner ? corner : map == kPoint ? point : map == kPolygon ? polygon : 0;
    int64_t v = static_cast<int64_t>(k);
    if (!index.empty()) {
      if (k >= index.size()) return -1;
      v = index[k];
    }
    if (v < 0 || static_cast<uint64_t>(v) >= values.size() / stride) return -1;
    return v;
  }
};

Status ReadElement(const FNode& geom, const Object& o, std::string_view element,
                   std::string_view values_name, std::string_view index_name, int stride,
                   Element& out);

// One Geometry split into primitives (one per material slot used), each vertex remembering
// the control point it came from, so shapes and skin weights follow.
struct SplitMesh {
  std::vector<Primitive> primitives;
  std::vector<std::vector<uint32_t>> point_of_vertex;  // Per primitive.
  std::vector<int> material_slot;                      // Per primitive.
  size_t point_count = 0;
  std::vector<double> points;  // xyz per control point.
};

Status SplitGeometry(const Object& o, const Mat4& geometric, std::vector<Warning>& warnings,
                     SplitMesh& out);

// A skin cluster's 4x4 matrix `name` (Transform, TransformLink), column-major; false when it is
// missing or not 16 finite numbers.
bool ClusterMatrix(const Object& cluster, const char* name, Mat4& out);
// A skin cluster's control point weights (Indexes, Weights), as influences of `joint`.
Status ClusterWeights(const Object& cluster, uint32_t joint, size_t point_count,
                      std::vector<Influences>& influences);

// ---------------------------------------------------------------------------------------------
// Animation curves

struct Curve {
  std::vector<double> times;  // Seconds.
  std::vector<double> values;
  std::vector<uint32_t> flags;  // Per key.
  std::vector<float> data;  // 4 per key: right slope, next left slope, packed weights, velocity.

  double At(double t) const {
    if (times.empty()) return 0.0;
    if (t <= times.front()) return values.front();
    if (t >= times.back()) return values.back();
    const size_t k =
        static_cast<size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin()) - 1;
    const double t0 = times[k], t1 = times[k + 1], v0 = values[k], v1 = values[k + 1];
    const double dt = t1 - t0;
    if (!(dt > 0)) return v1;
    const uint32_t f = flags[k];
    if (f & 0x2) return (f & 0x100) ? v1 : v0;  // Constant (or "constant next").
    const double u = (t - t0) / dt;
    if (!(f & 0x8)) return v0 + (v1 - v0) * u;  // Linear.
    // Cubic: a Bezier whose inner control points sit at (weight x dt) along the keys' tangents.
    const float raw = data[4 * k + 2];  // Two 16-bit weights (x 9999) packed in one number.
    const uint32_t packed = raw >= 0.0f && raw < 4294967296.0f ? static_cast<uint32_t>(raw) : 0;
    const double w0 = (f & 0x1000000) ? (packed & 0xffff) / 9999.0 : 1.0 / 3.0;
    const double w1 = (f & 0x2000000) ? (packed >> 16) / 9999.0 : 1.0 / 3.0;
    const double s0 = data[4 * k], s1 = data[4 * k + 1];
    const double x1 = w0, x2 = 1.0 - w1;  // Control points' times in [0, 1].
    const double y0 = v0, y1 = v0 + s0 * w0 * dt, y2 = v1 - s1 * w1 * dt, y3 = v1;
    // Default weights (1/3, 2/3) make x(s) = s; else x(s) rises for weights in [0, 1]: solved.
    if (std::fabs(x1 - 1.0 / 3.0) <= 1e-9 && std::fabs(x2 - 2.0 / 3.0) <= 1e-9)
      return CubicBezier(y0, y1, y2, y3, u);
    return BezierYAtX(0.0, x1, x2, 1.0, y0, y1, y2, y3, u);
  }
};

Status ReadCurve(const Object& o, Curve& c);

// An animated property: up to 3 curves (X, Y, Z or the one DeformPercent), each optional.
struct AnimatedProperty {
  const Curve* curves[3] = {nullptr, nullptr, nullptr};
};

// ---------------------------------------------------------------------------------------------

double FrameRate(const Scene& scene);
}  // namespace facespace::formats::fbx_scene
