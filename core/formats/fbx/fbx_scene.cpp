// FBX's scene (fbx_scene.h): objects, links, transforms, meshes, curves.
#include "fbx/fbx_scene.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>
#include <unordered_map>

#include "common/split_mesh.h"
#include "facespace/engine/bezier.h"

namespace facespace::formats::fbx_scene {

std::vector<double> Numbers(const Prop& p) {
  if (p.kind == Prop::kNumbers) return p.numbers;
  if (p.kind == Prop::kInts) return std::vector<double>(p.ints.begin(), p.ints.end());
  return {};
}

std::vector<int64_t> Ints(const Prop& p) {
  if (p.kind == Prop::kInts) return p.ints;
  std::vector<int64_t> out;
  if (p.kind == Prop::kNumbers) {
    out.reserve(p.numbers.size());
    for (double d : p.numbers)
      out.push_back(std::isfinite(d) && std::fabs(d) < 9e18 ? static_cast<int64_t>(d) : 0);
  }
  return out;
}

// `v` as an int when it is one in [lo, hi], else `fallback` (file numbers may be anything).
int IntIn(double v, int lo, int hi, int fallback) {
  return v >= lo && v <= hi && v == std::floor(v) ? static_cast<int>(v) : fallback;
}

// The array property of child `name` of `n`, or nullptr.
const Prop* ArrayOf(const FNode& n, std::string_view name) {
  const FNode* c = n.Find(name);
  if (!c || c->props.empty() || !c->props[0].IsArray()) return nullptr;
  return &c->props[0];
}

// ---------------------------------------------------------------------------------------------
// Transforms

Mat4 Translation(const Vec3& t) {
  Mat4 m = Mat4::Identity();
  m.block<3, 1>(0, 3) = t;
  return m;
}

Mat4 Scaling(const Vec3& s) {
  Mat4 m = Mat4::Identity();
  m(0, 0) = s.x();
  m(1, 1) = s.y();
  m(2, 2) = s.z();
  return m;
}

// Euler angles in degrees applied in `order` (FBX's enum: 0 XYZ, 1 XZY, 2 YZX, 3 YXZ, 4 ZXY,
// 5 ZYX, 6 spheric XYZ): XYZ rotates about X first, i.e. the matrix Rz * Ry * Rx.
Mat4 Rotation(const Vec3& deg, int order) {
  constexpr double kRad = M_PI / 180.0;
  const Eigen::Matrix3d x = Eigen::AngleAxisd(deg.x() * kRad, Vec3::UnitX()).toRotationMatrix();
  const Eigen::Matrix3d y = Eigen::AngleAxisd(deg.y() * kRad, Vec3::UnitY()).toRotationMatrix();
  const Eigen::Matrix3d z = Eigen::AngleAxisd(deg.z() * kRad, Vec3::UnitZ()).toRotationMatrix();
  Eigen::Matrix3d r;
  switch (order) {
    case 1: r = y * z * x; break;
    case 2: r = x * z * y; break;
    case 3: r = z * x * y; break;
    case 4: r = y * x * z; break;
    case 5: r = x * y * z; break;
    default: r = z * y * x; break;
  }
  Mat4 m = Mat4::Identity();
  m.block<3, 3>(0, 0) = r;
  return m;
}

TransformStack ReadStack(const Scene& scene, const Object& m) {
  TransformStack st;
  st.t = scene.Vector(m, "Lcl Translation", st.t);
  st.r = scene.Vector(m, "Lcl Rotation", st.r);
  st.s = scene.Vector(m, "Lcl Scaling", st.s);
  st.rotation_offset = scene.Vector(m, "RotationOffset", st.rotation_offset);
  st.rotation_pivot = scene.Vector(m, "RotationPivot", st.rotation_pivot);
  st.scaling_offset = scene.Vector(m, "ScalingOffset", st.scaling_offset);
  st.scaling_pivot = scene.Vector(m, "ScalingPivot", st.scaling_pivot);
  st.pre = Rotation(scene.Vector(m, "PreRotation", Vec3::Zero()), 0);
  st.post_inverse = Rotation(scene.Vector(m, "PostRotation", Vec3::Zero()), 0).transpose();
  const double order = scene.Number(m, "RotationOrder", 0);
  st.order = order >= 0 && order <= 6 ? static_cast<int>(order) : 0;
  st.geometric = Translation(scene.Vector(m, "GeometricTranslation", Vec3::Zero())) *
                 Rotation(scene.Vector(m, "GeometricRotation", Vec3::Zero()), 0) *
                 Scaling(scene.Vector(m, "GeometricScaling", Vec3(1, 1, 1)));
  return st;
}

Status ReadElement(const FNode& geom, const Object& o, std::string_view element,
                   std::string_view values_name, std::string_view index_name, int stride,
                   Element& out) {
  const FNode* e = geom.Find(element);
  if (!e) return Status::Ok();
  const Prop* values = ArrayOf(*e, values_name);
  if (!values) return Status::Ok();
  std::string mapping, reference;
  if (const FNode* m = e->Find("MappingInformationType"); m && !m->props.empty())
    mapping = m->props[0].s;
  if (const FNode* r = e->Find("ReferenceInformationType"); r && !r->props.empty())
    reference = r->props[0].s;
  if (mapping == "ByPolygonVertex") {
    out.map = Element::kCorner;
  } else if (mapping == "ByVertice" || mapping == "ByVertex" || mapping == "ByControlPoint") {
    out.map = Element::kPoint;
  } else if (mapping == "ByPolygon") {
    out.map = Element::kPolygon;
  } else if (mapping == "AllSame") {
    out.map = Element::kAll;
  } else {
    return InvalidArgument("FBX: " + o.Describe() + ": " + std::string(element) + " has mapping '" +
                           mapping.substr(0, 40) + "'");
  }
  out.values = Numbers(*values);
  out.stride = stride;
  if ((reference == "IndexToDirect" || reference == "Index") && !index_name.empty()) {
    const Prop* index = ArrayOf(*e, index_name);
    if (!index)
      return InvalidArgument("FBX: " + o.Describe() + ": " + std::string(element) +
                             " is IndexToDirect without " + std::string(index_name));
    out.index = Ints(*index);
  }
  for (double v : out.values) {
    if (!std::isfinite(v))
      return InvalidArgument("FBX: " + o.Describe() + ": " + std::string(element) +
                             " holds a non-finite value");
  }
  out.present = true;
  return Status::Ok();
}

namespace {

// A vertex of a split mesh: the control point and the attribute slots its corner reads.
struct VertexKey {
  int64_t point, normal, uv, color;
  bool operator==(const VertexKey& o) const {
    return point == o.point && normal == o.normal && uv == o.uv && color == o.color;
  }
};
struct VertexKeyHash {
  size_t operator()(const VertexKey& k) const {
    uint64_t h = static_cast<uint64_t>(k.point) * 0x9E3779B97F4A7C15ull;
    h ^= static_cast<uint64_t>(k.normal) + 0x7F4A7C159E3779B9ull + (h << 6) + (h >> 2);
    h ^= static_cast<uint64_t>(k.uv) + 0x94D049BB133111EBull + (h << 6) + (h >> 2);
    h ^= static_cast<uint64_t>(k.color) + 0xBF58476D1CE4E5B9ull + (h << 6) + (h >> 2);
    return static_cast<size_t>(h);
  }
};

}  // namespace

namespace {

// A geometry's control points (finite xyz) into `out` and its PolygonVertexIndex into `corners`,
// within the reader's limits.
Status ReadControlPoints(const Object& o, SplitMesh& out, std::vector<int64_t>& corners) {
  const FNode& g = *o.node;
  const Prop* vp = ArrayOf(g, "Vertices");
  const Prop* ip = ArrayOf(g, "PolygonVertexIndex");
  if (!vp || !ip)
    return InvalidArgument("FBX: " + o.Describe() + " has no Vertices or PolygonVertexIndex");
  out.points = Numbers(*vp);
  if (out.points.size() % 3 != 0)
    return InvalidArgument("FBX: " + o.Describe() + ": Vertices holds " +
                           std::to_string(out.points.size()) + " numbers, not xyz triples");
  out.point_count = out.points.size() / 3;
  if (out.point_count > kMaxControlPoints)
    return InvalidArgument("FBX: " + o.Describe() + ": more than " +
                           std::to_string(kMaxControlPoints) + " control points");
  for (double v : out.points) {
    if (!std::isfinite(v))
      return InvalidArgument("FBX: " + o.Describe() + ": a vertex is not finite");
  }
  corners = Ints(*ip);
  if (corners.size() > kMaxCorners)
    return InvalidArgument("FBX: " + o.Describe() + ": more than " + std::to_string(kMaxCorners) +
                           " polygon corners");
  return Status::Ok();
}

// A geometry's layer elements: normals, UVs, colours and material slots.
Status ReadElements(const FNode& g, const Object& o, Element& normals, Element& uvs,
                    Element& colors, Element& materials) {
  if (Status s = ReadElement(g, o, "LayerElementNormal", "Normals", "NormalsIndex", 3, normals);
      !s.ok())
    return s;
  if (normals.present && normals.index.empty()) {
    if (const FNode* e = g.Find("LayerElementNormal"); e && ArrayOf(*e, "NormalIndex"))
      normals.index = Ints(*ArrayOf(*e, "NormalIndex"));
  }
  if (Status s = ReadElement(g, o, "LayerElementUV", "UV", "UVIndex", 2, uvs); !s.ok()) return s;
  if (Status s = ReadElement(g, o, "LayerElementColor", "Colors", "ColorIndex", 4, colors); !s.ok())
    return s;
  if (Status s = ReadElement(g, o, "LayerElementMaterial", "Materials", "", 1, materials); !s.ok())
    return s;
  materials.index.clear();  // Materials are slot numbers themselves.
  return Status::Ok();
}

}  // namespace

Status SplitGeometry(const Object& o, const Mat4& geometric, std::vector<Warning>& warnings,
                     SplitMesh& out) {
  const FNode& g = *o.node;
  std::vector<int64_t> corners;
  if (Status s = ReadControlPoints(o, out, corners); !s.ok()) return s;
  Element normals, uvs, colors, materials;
  if (Status s = ReadElements(g, o, normals, uvs, colors, materials); !s.ok()) return s;

  const Eigen::Matrix3d normal_matrix = geometric.block<3, 3>(0, 0).inverse().transpose();
  std::map<int, size_t> prim_of_slot;
  std::vector<std::unordered_map<VertexKey, uint32_t, VertexKeyHash>> maps;
  size_t bad_corners = 0, degenerate = 0, polygon = 0;
  std::vector<uint32_t> poly;
  for (size_t c = 0, first = 0; c < corners.size(); ++c) {
    const bool last = corners[c] < 0;
    if (!last && c + 1 == corners.size()) {
      return InvalidArgument(
          "FBX: " + o.Describe() +
          ": PolygonVertexIndex does not end a polygon (its last index is not negative)");
    }
    if (!last) continue;
    // Polygon [first, c]: indices, the last one stored as ~index.
    const size_t n = c + 1 - first;
    if (n > kMaxPolygonCorners)
      return InvalidArgument("FBX: " + o.Describe() + ": polygon " + std::to_string(polygon) +
                             " has " + std::to_string(n) + " corners");
    int slot = 0;
    if (materials.present) {
      const int64_t m = materials.Slot(c, 0, polygon);
      slot = m < 0 ? 0 : IntIn(materials.values[static_cast<size_t>(m)], 0, 1000000, 0);
    }
    auto [it, inserted] = prim_of_slot.emplace(slot, out.primitives.size());
    if (inserted) {
      out.primitives.emplace_back();
      out.point_of_vertex.emplace_back();
      out.material_slot.push_back(slot);
      maps.emplace_back();
    }
    const size_t pi = it->second;
    Primitive& p = out.primitives[pi];
    poly.clear();
    for (size_t k = first; k <= c; ++k) {
      const int64_t raw = corners[k] < 0 ? ~corners[k] : corners[k];
      if (raw < 0 || static_cast<uint64_t>(raw) >= out.point_count) {
        return InvalidArgument("FBX: " + o.Describe() + ": polygon " + std::to_string(polygon) +
                               " uses control point " + std::to_string(raw) + " of " +
                               std::to_string(out.point_count));
      }
      const size_t point = static_cast<size_t>(raw);
      VertexKey key{raw, normals.present ? normals.Slot(k, point, polygon) : -1,
                    uvs.present ? uvs.Slot(k, point, polygon) : -1,
                    colors.present ? colors.Slot(k, point, polygon) : -1};
      if ((normals.present && key.normal < 0) || (uvs.present && key.uv < 0) ||
          (colors.present && key.color < 0))
        ++bad_corners;
      auto [vit, fresh] =
          maps[pi].emplace(key, static_cast<uint32_t>(out.point_of_vertex[pi].size()));
      if (fresh) {
        out.point_of_vertex[pi].push_back(static_cast<uint32_t>(point));
        const Eigen::Vector4d pos =
            geometric * Eigen::Vector4d(out.points[3 * point], out.points[3 * point + 1],
                                        out.points[3 * point + 2], 1.0);
        for (int a = 0; a < 3; ++a) p.positions.push_back(static_cast<float>(pos[a]));
        if (normals.present) {
          Vec3 nrm = key.normal < 0 ? Vec3::Zero()
                                    : Vec3(&normals.values[3 * static_cast<size_t>(key.normal)]);
          nrm = normal_matrix * nrm;
          if (nrm.norm() > 0) nrm.normalize();
          for (int a = 0; a < 3; ++a) p.normals.push_back(static_cast<float>(nrm[a]));
        }
        if (uvs.present) {
          const double* uv = key.uv < 0 ? nullptr : &uvs.values[2 * static_cast<size_t>(key.uv)];
          p.texcoords.push_back(uv ? static_cast<float>(uv[0]) : 0.0f);
          p.texcoords.push_back(uv ? static_cast<float>(1.0 - uv[1])
                                   : 0.0f);  // FBX's V points up, glTF's down.
        }
        if (colors.present) {
          for (int a = 0; a < 4; ++a)
            p.colors.push_back(
                key.color < 0
                    ? 1.0f
                    : static_cast<float>(colors.values[4 * static_cast<size_t>(key.color) + a]));
        }
      }
      poly.push_back(vit->second);
    }
    if (n >= 3) {
      for (size_t k = 1; k + 1 < n; ++k) {  // A fan: exact for the convex polygons DCC tools write.
        p.indices.insert(p.indices.end(), {poly[0], poly[k], poly[k + 1]});
      }
    } else {
      ++degenerate;
    }
    first = c + 1;
    ++polygon;
  }
  if (bad_corners) {
    warnings.push_back(
        {"attribute_out_of_range",
         o.Describe() + ": " + std::to_string(bad_corners) +
             " polygon corners index normals, UVs or colours beyond their arrays (zero used)",
         o.name, static_cast<double>(bad_corners), true});
  }
  if (degenerate) {
    warnings.push_back({"polygons_skipped",
                        o.Describe() + ": " + std::to_string(degenerate) +
                            " polygons with fewer than 3 corners (points, lines) skipped",
                        o.name, static_cast<double>(degenerate), true});
  }
  for (Primitive& p : out.primitives) {
    p.source_has_normals = normals.present;
    if (!normals.present) p.normals.clear();
  }
  return Status::Ok();
}

Status ReadCurve(const Object& o, Curve& c) {
  const Prop* tp = ArrayOf(*o.node, "KeyTime");
  const Prop* vp = ArrayOf(*o.node, "KeyValueFloat");
  if (!tp || !vp)
    return InvalidArgument("FBX: " + o.Describe() + " has no KeyTime or KeyValueFloat");
  const std::vector<int64_t> ticks = Ints(*tp);
  c.values = Numbers(*vp);
  if (ticks.size() != c.values.size()) {
    return InvalidArgument("FBX: " + o.Describe() + ": " + std::to_string(ticks.size()) +
                           " key times but " + std::to_string(c.values.size()) + " values");
  }
  c.times.resize(ticks.size());
  for (size_t k = 0; k < ticks.size(); ++k) {
    c.times[k] = static_cast<double>(ticks[k]) / kTicksPerSecond;
    if (!std::isfinite(c.values[k]))
      return InvalidArgument("FBX: " + o.Describe() + ": key " + std::to_string(k) +
                             " is not finite");
    if (k && !(c.times[k] > c.times[k - 1]))
      return InvalidArgument("FBX: " + o.Describe() + ": key times are not ascending at key " +
                             std::to_string(k));
  }
  // Attributes are run-length coded: attribute a covers KeyAttrRefCount[a] keys.
  c.flags.assign(ticks.size(), 0x4);  // Linear unless told.
  c.data.assign(4 * ticks.size(), 0.0f);
  const Prop* fp = ArrayOf(*o.node, "KeyAttrFlags");
  const Prop* dp = ArrayOf(*o.node, "KeyAttrDataFloat");
  const Prop* rp = ArrayOf(*o.node, "KeyAttrRefCount");
  if (fp && dp && rp) {
    const std::vector<int64_t> flags = Ints(*fp), refs = Ints(*rp);
    const std::vector<double> data = Numbers(*dp);
    size_t key = 0;
    for (size_t a = 0;
         a < refs.size() && a < flags.size() && 4 * a + 3 < data.size() && key < ticks.size();
         ++a) {
      if (refs[a] < 0)
        return InvalidArgument("FBX: " + o.Describe() + ": negative KeyAttrRefCount");
      for (int64_t r = 0; r < refs[a] && key < ticks.size(); ++r, ++key) {
        c.flags[key] = static_cast<uint32_t>(flags[a]);
        for (int d = 0; d < 4; ++d)
          c.data[4 * key + d] =
              std::isfinite(data[4 * a + d]) ? static_cast<float>(data[4 * a + d]) : 0.0f;
      }
    }
  }
  return Status::Ok();
}

// ---------------------------------------------------------------------------------------------

double FrameRate(const Scene& scene) {
  static constexpr double kRates[] = {24, 120,         100,         60,    50,    48,   30,
                                      30, 29.97002997, 29.97002997, 25,    24,    1000, 23.976,
                                      0,  96,          72,          59.94, 119.88};
  const double mode = scene.Setting("TimeMode", 0);
  double rate = 24;
  if (mode == 14) {
    rate = scene.Setting("CustomFrameRate", 24);
  } else if (mode >= 0 && mode < static_cast<double>(std::size(kRates))) {
    rate = kRates[static_cast<size_t>(mode)];
  }
  return std::isfinite(rate) && rate >= 1 && rate <= 1000 ? rate : 24;
}
// A cluster's 4x4 matrix `name` (Transform, TransformLink), column-major; false when it is missing
// or not 16 finite numbers.
bool ClusterMatrix(const Object& cluster, const char* name, Mat4& out) {
  const Prop* p = ArrayOf(*cluster.node, name);
  if (!p) return false;
  const std::vector<double> v = Numbers(*p);
  if (v.size() != 16) return false;
  for (int k = 0; k < 16; ++k) {
    if (!std::isfinite(v[k])) return false;
    out(k % 4, k / 4) = v[k];
  }
  return true;
}

// A cluster's control point weights, as influences of `joint`.
Status ClusterWeights(const Object& cluster, uint32_t joint, size_t point_count,
                      std::vector<Influences>& influences) {
  const Prop* ip = ArrayOf(*cluster.node, "Indexes");
  const Prop* wp = ArrayOf(*cluster.node, "Weights");
  if (!ip || !wp) return Status::Ok();  // A bone that moves nothing.
  const std::vector<int64_t> index = Ints(*ip);
  const std::vector<double> weight = Numbers(*wp);
  if (index.size() != weight.size()) {
    return InvalidArgument("FBX: cluster '" + cluster.name + "': " + std::to_string(index.size()) +
                           " Indexes but " + std::to_string(weight.size()) + " Weights");
  }
  for (size_t k = 0; k < index.size(); ++k) {
    if (index[k] < 0 || static_cast<uint64_t>(index[k]) >= point_count) {
      return InvalidArgument("FBX: cluster '" + cluster.name + "': Indexes[" + std::to_string(k) +
                             "] = " + std::to_string(index[k]) + " is beyond the " +
                             std::to_string(point_count) + " control points");
    }
    if (!std::isfinite(weight[k]))
      return InvalidArgument("FBX: cluster '" + cluster.name + "': a weight is not finite");
    if (weight[k] > 0)
      influences[static_cast<size_t>(index[k])].emplace_back(joint, static_cast<float>(weight[k]));
  }
  return Status::Ok();
}

}  // namespace facespace::formats::fbx_scene
