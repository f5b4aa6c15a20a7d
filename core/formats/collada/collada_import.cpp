// COLLADA 1.4/1.5 (.dae) as a Rig: geometry (triangles, polylist, polygons; shared or split
// inputs), the node hierarchy (matrix, translate, rotate, scale), morph controllers (NORMALIZED and
// RELATIVE), skin controllers (bind shape matrix, inverse binds, any number of influences), a skin
// over a morph, base colours, and animated morph weights as clips.
//
// A parser of untrusted XML (pugixml reads it): every index is checked against its source's
// accessor, every reference resolved or reported, nesting and instancing capped.
#include <pugixml.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <map>
#include <set>
#include <string_view>
#include <unordered_map>

#include "facespace/formats/io.h"
#include "common/bezier.h"
#include "common/split_mesh.h"

namespace facespace {

namespace {

using Mat4 = Eigen::Matrix4d;
using Vec3 = Eigen::Vector3d;

constexpr size_t kMaxDepth = 128;          // Node nesting (instance_node included).
constexpr size_t kMaxNodes = 100'000;
constexpr size_t kMaxValues = 64'000'000;  // Numbers in one array.
constexpr size_t kMaxSamples = 100'000;
constexpr double kSampleRate = 60.0;       // Clips are sampled at 60 per second (and at every key).

Status Bad(const std::string& what) { return InvalidArgument("COLLADA: " + what); }

std::string Describe(const pugi::xml_node& n) {
  std::string s = std::string("<") + n.name();
  if (const char* id = n.attribute("id").value(); *id) s += std::string(" id=\"") + std::string(id).substr(0, 60) + "\"";
  return s + ">";
}

// A number read from the file, as it would be printed in a message: never cast to an integer
// type first (a finite double such as 7e65 does not fit in one).
std::string Number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.10g", v);
  return text;
}

// "#id" -> "id" (a bare id is taken as is).
std::string_view Fragment(std::string_view url) { return !url.empty() && url[0] == '#' ? url.substr(1) : url; }

// Whitespace separated numbers; false on a token that is not a finite number.
bool ParseNumbers(const char* text, std::vector<double>& out, size_t limit) {
  out.clear();
  const char* p = text;
  for (;;) {
    while (*p == ' ' || *p == '\n' || *p == '\t' || *p == '\r') ++p;
    if (!*p) return true;
    if (out.size() >= limit) return false;
    char* end = nullptr;
    const double v = std::strtod(p, &end);
    if (end == p || !std::isfinite(v)) return false;
    out.push_back(v);
    p = end;
  }
}

std::vector<std::string> ParseWords(const char* text) {
  std::vector<std::string> out;
  std::string_view s(text);
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    const size_t start = i;
    while (i < s.size() && !std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    if (i > start) out.emplace_back(s.substr(start, i - start));
  }
  return out;
}

// A <source>: numbers or names, read through its accessor (count x stride, from an offset).
struct Source {
  std::vector<double> numbers;
  std::vector<std::string> names;
  size_t count = 0, stride = 1;
  const double* At(size_t i) const { return &numbers[i * stride]; }
};

Mat4 RowMajor(const double* v) {
  Mat4 m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m(r, c) = v[4 * r + c];
  }
  return m;
}

class Reader {
 public:
  explicit Reader(const pugi::xml_document& doc, std::string name) : doc_(doc) { rig_.name = std::move(name); }

  Result<Rig> Run() {
    root_ = doc_.child("COLLADA");
    if (!root_) return Bad("no <COLLADA> root element");
    IndexIds(root_);
    if (Status s = Scene(); !s.ok()) return s;
    if (rig_.primitives.empty()) return Bad("the scene shows no mesh");
    if (Status s = Animations(); !s.ok()) return s;
    CountMovedVertices(rig_);
    DetectSymmetricPartners(rig_);
    RepairNames(rig_);
    if (Status s = ValidateRig(rig_); !s.ok()) return s;
    return std::move(rig_);
  }

 private:
  void IndexIds(pugi::xml_node root) {
    // Iterative: hostile files may nest deeply.
    std::vector<pugi::xml_node> stack{root};
    while (!stack.empty()) {
      pugi::xml_node n = stack.back();
      stack.pop_back();
      if (const char* id = n.attribute("id").value(); *id) ids_.emplace(id, n);
      for (pugi::xml_node c = n.last_child(); c; c = c.previous_sibling()) {
        if (c.type() == pugi::node_element) stack.push_back(c);
      }
    }
  }

  pugi::xml_node ById(std::string_view url) const {
    auto it = ids_.find(std::string(Fragment(url)));
    return it == ids_.end() ? pugi::xml_node() : it->second;
  }

  Status ReadSource(pugi::xml_node src, Source& out) {
    if (!src || std::strcmp(src.name(), "source") != 0) return Bad("a referenced <source> is missing");
    pugi::xml_node accessor = src.child("technique_common").child("accessor");
    pugi::xml_node array;
    for (pugi::xml_node c : src.children()) {
      const std::string_view n = c.name();
      if (n.size() > 6 && n.substr(n.size() - 6) == "_array") array = c;
    }
    if (!array) return Bad(Describe(src) + " has no array");
    const std::string_view kind = array.name();
    if (kind == "float_array" || kind == "int_array") {
      if (!ParseNumbers(array.child_value(), out.numbers, kMaxValues)) return Bad(Describe(array) + " holds something that is not a finite number (or too many)");
    } else {
      out.names = ParseWords(array.child_value());
      if (out.names.size() > kMaxValues) return Bad(Describe(array) + " is too long");
    }
    const size_t have = kind == "float_array" || kind == "int_array" ? out.numbers.size() : out.names.size();
    out.stride = 1;
    out.count = have;
    if (accessor) {
      const long long count = accessor.attribute("count").as_llong(-1), stride = accessor.attribute("stride").as_llong(1);
      const long long offset = accessor.attribute("offset").as_llong(0);
      if (count < 0 || stride < 1 || stride > 64 || offset != 0) return Bad(Describe(src) + ": its accessor's count, stride or offset is invalid");
      // The accessor rules (SCEA's animation_morph lists more names than its accessor counts).
      if (static_cast<unsigned long long>(count) * static_cast<unsigned long long>(stride) > have) {
        return Bad(Describe(src) + ": its accessor reads " + std::to_string(count) + " x " + std::to_string(stride) + " values of " + std::to_string(have));
      }
      out.count = static_cast<size_t>(count);
      out.stride = static_cast<size_t>(stride);
    }
    return Status::Ok();
  }

  // ---- geometry ----

  struct Split {
    std::vector<Primitive> primitives;
    std::vector<std::vector<uint32_t>> point_of_vertex;  // Position index of each vertex.
    std::vector<std::string> material_symbol;
    size_t point_count = 0;
    std::vector<double> points;  // xyz per position index.
  };

  // The <mesh>'s positions (through <vertices>).
  Status Positions(pugi::xml_node mesh, std::vector<double>& out, pugi::xml_node* vertices_out = nullptr) {
    pugi::xml_node vertices = mesh.child("vertices");
    if (!vertices) return Bad(Describe(mesh.parent()) + " has no <vertices>");
    if (vertices_out) *vertices_out = vertices;
    for (pugi::xml_node in : vertices.children("input")) {
      if (std::string_view(in.attribute("semantic").value()) != "POSITION") continue;
      Source s;
      if (Status st = ReadSource(ById(in.attribute("source").value()), s); !st.ok()) return st;
      if (s.stride < 3) return Bad(Describe(mesh.parent()) + ": positions have fewer than 3 components");
      out.clear();
      for (size_t i = 0; i < s.count; ++i) out.insert(out.end(), s.At(i), s.At(i) + 3);
      return Status::Ok();
    }
    return Bad(Describe(mesh.parent()) + ": <vertices> has no POSITION input");
  }

  Status SplitGeometry(pugi::xml_node geometry, Split& out) {
    pugi::xml_node mesh = geometry.child("mesh");
    if (!mesh) return Bad(Describe(geometry) + " is not a <mesh> (splines and convex meshes are not read)");
    pugi::xml_node vertices;
    if (Status s = Positions(mesh, out.points, &vertices); !s.ok()) return s;
    out.point_count = out.points.size() / 3;
    // Normals/texcoords may come through <vertices> too (indexed like positions).
    Source vnormal, vuv;
    bool has_vnormal = false, has_vuv = false;
    for (pugi::xml_node in : vertices.children("input")) {
      const std::string_view sem = in.attribute("semantic").value();
      if (sem == "NORMAL" && ReadSource(ById(in.attribute("source").value()), vnormal).ok() && vnormal.stride >= 3) has_vnormal = true;
      if (sem == "TEXCOORD" && ReadSource(ById(in.attribute("source").value()), vuv).ok() && vuv.stride >= 2) has_vuv = true;
    }
    for (pugi::xml_node prim : mesh.children()) {
      const std::string_view kind = prim.name();
      if (kind != "triangles" && kind != "polylist" && kind != "polygons") {
        if (kind == "lines" || kind == "linestrips" || kind == "trifans" || kind == "tristrips") {
          rig_.load_warnings.push_back({"primitive_skipped", Describe(geometry) + ": <" + std::string(kind) + "> is not read", "", 0.0, false});
        }
        continue;
      }
      // Inputs: offset -> semantic; the stride of <p> is the largest offset + 1.
      long long vertex_offset = -1, normal_offset = -1, uv_offset = -1;
      Source normal, uv;
      size_t stride = 0;
      for (pugi::xml_node in : prim.children("input")) {
        const long long off = in.attribute("offset").as_llong(-1);
        if (off < 0 || off > 64) return Bad(Describe(geometry) + ": an input's offset is invalid");
        stride = std::max(stride, static_cast<size_t>(off) + 1);
        const std::string_view sem = in.attribute("semantic").value();
        if (sem == "VERTEX") vertex_offset = off;
        if (sem == "NORMAL" && normal_offset < 0) {
          if (Status s = ReadSource(ById(in.attribute("source").value()), normal); !s.ok()) return s;
          if (normal.stride < 3) return Bad(Describe(geometry) + ": normals have fewer than 3 components");
          normal_offset = off;
        }
        if (sem == "TEXCOORD" && uv_offset < 0) {
          if (Status s = ReadSource(ById(in.attribute("source").value()), uv); !s.ok()) return s;
          if (uv.stride < 2) return Bad(Describe(geometry) + ": texture coordinates have fewer than 2 components");
          uv_offset = off;
        }
      }
      if (vertex_offset < 0) return Bad(Describe(geometry) + ": <" + std::string(kind) + "> has no VERTEX input");
      // Polygons' corner counts.
      std::vector<double> indices, counts;
      if (kind == "polygons") {
        for (pugi::xml_node p : prim.children("p")) {
          std::vector<double> one;
          if (!ParseNumbers(p.child_value(), one, kMaxValues)) return Bad(Describe(geometry) + ": a <p> holds something that is not a number");
          if (one.size() % stride) return Bad(Describe(geometry) + ": a <p> is not a whole number of corners");
          counts.push_back(static_cast<double>(one.size() / stride));
          indices.insert(indices.end(), one.begin(), one.end());
        }
        if (prim.child("ph")) rig_.load_warnings.push_back({"primitive_skipped", Describe(geometry) + ": polygons with holes (<ph>) are not read", "", 0.0, false});
      } else {
        if (!ParseNumbers(prim.child("p").child_value(), indices, kMaxValues)) return Bad(Describe(geometry) + ": <p> holds something that is not a number");
        if (kind == "polylist") {
          if (!ParseNumbers(prim.child("vcount").child_value(), counts, kMaxValues)) return Bad(Describe(geometry) + ": <vcount> is not numbers");
        } else {
          counts.assign(indices.size() / stride / 3, 3.0);
        }
      }
      size_t need = 0;
      for (double c : counts) {
        if (c < 0 || c > 4096 || c != std::floor(c)) return Bad(Describe(geometry) + ": a polygon has " + std::to_string(c) + " corners");
        need += static_cast<size_t>(c);
      }
      if (need * stride != indices.size()) {
        return Bad(Describe(geometry) + ": <p> holds " + std::to_string(indices.size()) + " indices, the polygons need " + std::to_string(need * stride));
      }
      Primitive p;
      std::vector<uint32_t> points;
      std::map<std::array<long long, 3>, uint32_t> dedupe;
      auto index_at = [&](size_t corner, long long off) -> long long {
        const double v = indices[corner * stride + static_cast<size_t>(off)];
        return v >= 0 && v < 4e9 ? static_cast<long long>(v) : -1;
      };
      size_t corner = 0;
      const bool normals = normal_offset >= 0 || has_vnormal, uvs = uv_offset >= 0 || has_vuv;
      for (double c : counts) {
        const size_t n = static_cast<size_t>(c);
        std::vector<uint32_t> poly;
        for (size_t k = 0; k < n; ++k, ++corner) {
          const long long vi = index_at(corner, vertex_offset);
          if (vi < 0 || static_cast<size_t>(vi) >= out.point_count) {
            return Bad(Describe(geometry) + ": corner " + std::to_string(corner) + " uses vertex " + std::to_string(vi) + " of " + std::to_string(out.point_count));
          }
          const long long ni = normal_offset >= 0 ? index_at(corner, normal_offset) : (has_vnormal ? vi : -1);
          const long long ti = uv_offset >= 0 ? index_at(corner, uv_offset) : (has_vuv ? vi : -1);
          const Source& ns = normal_offset >= 0 ? normal : vnormal;
          const Source& ts = uv_offset >= 0 ? uv : vuv;
          if ((normals && (ni < 0 || static_cast<size_t>(ni) >= ns.count)) || (uvs && (ti < 0 || static_cast<size_t>(ti) >= ts.count))) {
            return Bad(Describe(geometry) + ": corner " + std::to_string(corner) + " indexes a normal or texture coordinate beyond its source");
          }
          auto [it, fresh] = dedupe.emplace(std::array<long long, 3>{vi, ni, ti}, static_cast<uint32_t>(points.size()));
          if (fresh) {
            points.push_back(static_cast<uint32_t>(vi));
            for (int a = 0; a < 3; ++a) p.positions.push_back(static_cast<float>(out.points[3 * vi + a]));
            if (normals) {
              for (int a = 0; a < 3; ++a) p.normals.push_back(static_cast<float>(ns.At(static_cast<size_t>(ni))[a]));
            }
            if (uvs) {
              p.texcoords.push_back(static_cast<float>(ts.At(static_cast<size_t>(ti))[0]));
              p.texcoords.push_back(static_cast<float>(1.0 - ts.At(static_cast<size_t>(ti))[1]));  // COLLADA's V points up.
            }
          }
          poly.push_back(it->second);
        }
        for (size_t k = 1; k + 1 < n; ++k) p.indices.insert(p.indices.end(), {poly[0], poly[k], poly[k + 1]});
      }
      p.source_has_normals = normals;
      if (p.indices.empty()) continue;
      out.primitives.push_back(std::move(p));
      out.point_of_vertex.push_back(std::move(points));
      out.material_symbol.push_back(prim.attribute("material").value());
    }
    return Status::Ok();
  }

  // ---- controllers ----

  struct Morph {
    pugi::xml_node controller;
    std::string weights_source;  // Its MORPH_WEIGHT source's id (animation channels address it).
    std::vector<std::string> names;
    std::vector<std::vector<double>> targets;  // Positions per target (xyz per position index).
    std::vector<double> weights;
  };

  Status ReadMorph(pugi::xml_node controller, pugi::xml_node morph, size_t points, const std::vector<double>& base, Morph& out) {
    out.controller = controller;
    const std::string_view method = morph.attribute("method").value();
    if (!method.empty() && method != "NORMALIZED" && method != "RELATIVE") return Bad(Describe(controller) + ": unknown morph method '" + std::string(method).substr(0, 40) + "'");
    Source targets, weights;
    for (pugi::xml_node in : morph.child("targets").children("input")) {
      const std::string_view sem = in.attribute("semantic").value();
      if (sem == "MORPH_TARGET") {
        if (Status s = ReadSource(ById(in.attribute("source").value()), targets); !s.ok()) return s;
      }
      if (sem == "MORPH_WEIGHT") {
        out.weights_source = std::string(Fragment(in.attribute("source").value()));
        if (Status s = ReadSource(ById(in.attribute("source").value()), weights); !s.ok()) return s;
      }
    }
    if (targets.names.empty() && targets.count) return Bad(Describe(controller) + ": MORPH_TARGET is not a list of ids");
    for (size_t t = 0; t < targets.count; ++t) {
      const std::string& id = targets.names[t];
      pugi::xml_node g = ById(id);
      if (!g || std::strcmp(g.name(), "geometry") != 0) {
        rig_.load_warnings.push_back({"shape_skipped", Describe(controller) + ": morph target '" + id.substr(0, 60) + "' is not a geometry in the file", id, 0.0, false});
        continue;
      }
      std::vector<double> pos;
      if (Status s = Positions(g.child("mesh"), pos); !s.ok()) return s;
      if (pos.size() != 3 * points) {
        return Bad(Describe(controller) + ": target '" + id + "' has " + std::to_string(pos.size() / 3) + " positions, the base " + std::to_string(points));
      }
      // Both methods store whole target positions; NORMALIZED is (1 - sum w) base + sum w target,
      // RELATIVE base + sum w (target - base): the same deltas (README "COLLADA").
      for (size_t k = 0; k < pos.size(); ++k) pos[k] -= base[k];
      out.names.push_back(g.attribute("name").value()[0] ? g.attribute("name").value() : id);
      out.targets.push_back(std::move(pos));
      out.weights.push_back(t < weights.count && weights.numbers.size() > t * weights.stride ? weights.At(t)[0] : 0.0);
    }
    return Status::Ok();
  }

  struct SkinData {
    Mat4 bind_shape = Mat4::Identity();
    std::vector<std::string> joint_names;
    std::vector<Mat4> inverse_binds;
    bool names_are_ids = false;
    std::vector<Influences> influences;  // Per position index.
  };

  Status ReadSkin(pugi::xml_node controller, pugi::xml_node skin, size_t points, SkinData& out) {
    std::vector<double> bsm;
    if (pugi::xml_node b = skin.child("bind_shape_matrix")) {
      if (!ParseNumbers(b.child_value(), bsm, 16) || bsm.size() != 16) return Bad(Describe(controller) + ": <bind_shape_matrix> is not 16 numbers");
      out.bind_shape = RowMajor(bsm.data());
    }
    Source joints, matrices;
    for (pugi::xml_node in : skin.child("joints").children("input")) {
      const std::string_view sem = in.attribute("semantic").value();
      pugi::xml_node src = ById(in.attribute("source").value());
      if (sem == "JOINT") {
        if (Status s = ReadSource(src, joints); !s.ok()) return s;
        out.names_are_ids = src.child("IDREF_array") != nullptr;
      }
      if (sem == "INV_BIND_MATRIX") {
        if (Status s = ReadSource(src, matrices); !s.ok()) return s;
      }
    }
    if (joints.names.size() < joints.count || joints.count == 0) return Bad(Describe(controller) + ": the skin names no joints");
    if (matrices.count != joints.count || matrices.stride != 16) return Bad(Describe(controller) + ": " + std::to_string(matrices.count) + " inverse bind matrices for " + std::to_string(joints.count) + " joints");
    if (joints.count > 65535) return Bad(Describe(controller) + ": more than 65535 joints");
    for (size_t j = 0; j < joints.count; ++j) {
      out.joint_names.push_back(joints.names[j]);
      out.inverse_binds.push_back(RowMajor(matrices.At(j)));
    }
    pugi::xml_node vw = skin.child("vertex_weights");
    long long joint_off = -1, weight_off = -1;
    Source weights;
    size_t stride = 0;
    for (pugi::xml_node in : vw.children("input")) {
      const long long off = in.attribute("offset").as_llong(-1);
      if (off < 0 || off > 64) return Bad(Describe(controller) + ": a vertex_weights input's offset is invalid");
      stride = std::max(stride, static_cast<size_t>(off) + 1);
      const std::string_view sem = in.attribute("semantic").value();
      if (sem == "JOINT") joint_off = off;
      if (sem == "WEIGHT") {
        weight_off = off;
        if (Status s = ReadSource(ById(in.attribute("source").value()), weights); !s.ok()) return s;
      }
    }
    if (joint_off < 0 || weight_off < 0) return Bad(Describe(controller) + ": <vertex_weights> needs JOINT and WEIGHT inputs");
    std::vector<double> vcount, v;
    if (!ParseNumbers(vw.child("vcount").child_value(), vcount, kMaxValues) || !ParseNumbers(vw.child("v").child_value(), v, kMaxValues)) {
      return Bad(Describe(controller) + ": <vcount> or <v> holds something that is not a number");
    }
    if (vcount.size() != points) {
      return Bad(Describe(controller) + ": <vcount> has " + std::to_string(vcount.size()) + " entries, the mesh " + std::to_string(points) + " vertices");
    }
    out.influences.assign(points, {});
    size_t at = 0;
    for (size_t p = 0; p < points; ++p) {
      if (vcount[p] < 0 || vcount[p] > 1024) return Bad(Describe(controller) + ": vertex " + std::to_string(p) + " has " + Number(vcount[p]) + " influences");
      for (size_t k = 0; k < static_cast<size_t>(vcount[p]); ++k, ++at) {
        if ((at + 1) * stride > v.size()) return Bad(Describe(controller) + ": <v> ends before the influences <vcount> promises");
        const double j = v[at * stride + static_cast<size_t>(joint_off)], w = v[at * stride + static_cast<size_t>(weight_off)];
        if (w < 0 || w >= static_cast<double>(weights.count) || w != std::floor(w)) return Bad(Describe(controller) + ": a weight index is beyond its source");
        if (j == -1) continue;  // The bind shape itself: no joint.
        if (j < 0 || j >= static_cast<double>(joints.count) || j != std::floor(j)) return Bad(Describe(controller) + ": vertex " + std::to_string(p) + " names joint " + Number(j) + " of " + std::to_string(joints.count));
        const double weight = weights.At(static_cast<size_t>(w))[0];
        if (weight > 0) out.influences[p].emplace_back(static_cast<uint32_t>(j), static_cast<float>(weight));
      }
    }
    return Status::Ok();
  }

  // ---- the scene ----

  Mat4 LocalTransform(pugi::xml_node node) {
    Mat4 m = Mat4::Identity();
    for (pugi::xml_node t : node.children()) {
      const std::string_view kind = t.name();
      std::vector<double> v;
      if (kind != "matrix" && kind != "translate" && kind != "rotate" && kind != "scale" && kind != "lookat" && kind != "skew") continue;
      if (!ParseNumbers(t.child_value(), v, 16)) v.clear();
      if (kind == "matrix" && v.size() == 16) {
        m = m * RowMajor(v.data());
      } else if (kind == "translate" && v.size() == 3) {
        m = m * Eigen::Affine3d(Eigen::Translation3d(v[0], v[1], v[2])).matrix();
      } else if (kind == "rotate" && v.size() == 4 && Vec3(v[0], v[1], v[2]).norm() > 0) {
        m = m * Eigen::Affine3d(Eigen::AngleAxisd(v[3] * M_PI / 180.0, Vec3(v[0], v[1], v[2]).normalized())).matrix();
      } else if (kind == "scale" && v.size() == 3) {
        m = m * Eigen::Affine3d(Eigen::Scaling(v[0], v[1], v[2])).matrix();
      } else {
        rig_.load_warnings.push_back({"transform_skipped", Describe(node) + ": <" + std::string(kind) + "> is not read (or malformed)", "", 0.0, false});
      }
    }
    return m;
  }

  Status Scene() {
    pugi::xml_node scene = ById(root_.child("scene").child("instance_visual_scene").attribute("url").value());
    if (!scene) scene = root_.child("library_visual_scenes").child("visual_scene");
    if (!scene) return Bad("no <visual_scene>");
    // Z_UP (or X_UP) files get a root node that turns them Y-up, as glTF wants.
    const std::string_view up = root_.child("asset").child_value("up_axis");
    int parent = -1;
    if (up == "Z_UP" || up == "X_UP") {
      Node r;
      r.name = "collada_root";
      r.rotation = up == "Z_UP" ? std::array<float, 4>{-0.70710678f, 0, 0, 0.70710678f} : std::array<float, 4>{0, 0, 0.70710678f, 0.70710678f};
      rig_.nodes.push_back(r);
      rig_.scene_roots.push_back(0);
      parent = 0;
    }
    first_node_ = rig_.nodes.size();
    // Nodes first (joints must exist before skins resolve them), instances after.
    std::vector<std::pair<pugi::xml_node, int>> instances;
    struct Item { pugi::xml_node node; int parent; size_t depth; };
    std::vector<Item> stack;
    for (pugi::xml_node n = scene.last_child(); n; n = n.previous_sibling()) {
      if (std::strcmp(n.name(), "node") == 0) stack.push_back({n, parent, 0});
    }
    while (!stack.empty()) {
      const Item it = stack.back();
      stack.pop_back();
      if (it.depth >= kMaxDepth) return Bad(Describe(it.node) + ": nodes nested deeper than " + std::to_string(kMaxDepth) + " (or an <instance_node> cycle)");
      if (rig_.nodes.size() >= kMaxNodes) return Bad("more than " + std::to_string(kMaxNodes) + " nodes");
      Node n;
      n.name = it.node.attribute("name").value()[0] ? it.node.attribute("name").value() : it.node.attribute("id").value();
      n.parent = it.parent;
      SetNodeLocal(n, LocalTransform(it.node));
      const int index = static_cast<int>(rig_.nodes.size());
      if (it.parent >= 0) {
        rig_.nodes[it.parent].children.push_back(index);
      } else {
        rig_.scene_roots.push_back(index);
      }
      rig_.nodes.push_back(std::move(n));
      node_xml_.push_back(it.node);
      std::vector<pugi::xml_node> kids;
      for (pugi::xml_node c : it.node.children()) {
        const std::string_view kind = c.name();
        if (kind == "node") kids.push_back(c);
        if (kind == "instance_node") {
          pugi::xml_node target = ById(c.attribute("url").value());
          if (target && std::strcmp(target.name(), "node") == 0) kids.push_back(target);
        }
        if (kind == "instance_geometry" || kind == "instance_controller") instances.emplace_back(c, index);
      }
      for (auto k = kids.rbegin(); k != kids.rend(); ++k) stack.push_back({*k, index, it.depth + 1});
    }
    world_ = NodeWorldMatrices(rig_);
    for (const auto& [inst, node] : instances) {
      if (Status s = Instance(inst, node); !s.ok()) return s;
    }
    return Status::Ok();
  }

  // The node a skin's joint name means: a sid under the <skeleton> roots, else an id, else a name.
  int JointNode(const std::string& name, bool is_id, const std::vector<int>& skeleton_roots) const {
    auto find = [&](auto match) {
      for (size_t i = 0; i < node_xml_.size(); ++i) {
        if (match(node_xml_[i])) return static_cast<int>(first_node_ + i);
      }
      return -1;
    };
    if (!is_id && !skeleton_roots.empty()) {
      for (size_t i = 0; i < node_xml_.size(); ++i) {
        const int ni = static_cast<int>(first_node_ + i);
        if (name != node_xml_[i].attribute("sid").value()) continue;
        for (int a = ni; a >= 0; a = rig_.nodes[a].parent) {
          if (std::find(skeleton_roots.begin(), skeleton_roots.end(), a) != skeleton_roots.end()) return ni;
        }
      }
    }
    int n = find([&](pugi::xml_node x) { return name == x.attribute("id").value(); });
    if (n < 0 && !is_id) n = find([&](pugi::xml_node x) { return name == x.attribute("sid").value(); });
    if (n < 0) n = find([&](pugi::xml_node x) { return name == x.attribute("name").value(); });
    return n;
  }

  int NodeOfXml(pugi::xml_node x) const {
    for (size_t i = 0; i < node_xml_.size(); ++i) {
      if (node_xml_[i] == x) return static_cast<int>(first_node_ + i);
    }
    return -1;
  }

  Mat4 World(int node) const {
    Mat4 m;
    for (int k = 0; k < 16; ++k) m(k % 4, k / 4) = world_[node][k];
    return m;
  }

  // The file a diffuse <texture texture="NAME"> shows: NAME is a sampler2D newparam whose <source>
  // names a surface newparam whose <init_from> is an image (COLLADA 1.4), or a sampler2D with an
  // <instance_image> (1.5), or, as some exporters write, the image's id itself. The image's URI is
  // made a path relative to the model's folder ("file://" and %-escapes undone); an absolute path
  // keeps its file name only (exporters write where the image was on the author's disk; tools then
  // look beside the model). LoadImagesBeside reads it from the model's folder, never outside it.
  std::string TextureFile(pugi::xml_node profile, const std::string& name) const {
    auto param = [&](const std::string& sid) {
      for (pugi::xml_node np : profile.children("newparam")) {
        if (sid == np.attribute("sid").value()) return np;
      }
      return pugi::xml_node();
    };
    auto trim = [](std::string t) {
      const size_t a = t.find_first_not_of(" \t\r\n"), b = t.find_last_not_of(" \t\r\n");
      return a == std::string::npos ? std::string() : t.substr(a, b - a + 1);
    };
    std::string image_id = name;
    if (pugi::xml_node sampler = param(name).child("sampler2D")) {
      if (pugi::xml_node inst = sampler.child("instance_image")) image_id = std::string(Fragment(inst.attribute("url").value()));
      else if (pugi::xml_node surface = param(trim(sampler.child_value("source"))).child("surface")) image_id = trim(surface.child_value("init_from"));
    }
    pugi::xml_node image = ById(image_id);
    if (!image || std::strcmp(image.name(), "image") != 0) return "";
    pugi::xml_node init = image.child("init_from");
    std::string uri = trim(init.child("ref") ? init.child_value("ref") : init.child_value());
    if (uri.rfind("file://", 0) == 0) uri.erase(0, 7);
    const auto hex = [](char c) { return std::isxdigit(static_cast<unsigned char>(c)) ? (std::isdigit(static_cast<unsigned char>(c)) ? c - '0' : (c | 0x20) - 'a' + 10) : -1; };
    std::string path;
    for (size_t k = 0; k < uri.size(); ++k) {
      if (uri[k] == '%' && k + 2 < uri.size() && hex(uri[k + 1]) >= 0 && hex(uri[k + 2]) >= 0) {
        path += static_cast<char>(hex(uri[k + 1]) * 16 + hex(uri[k + 2]));
        k += 2;
      } else {
        path += uri[k] == '\\' ? '/' : uri[k];
      }
    }
    if (!path.empty() && (path[0] == '/' || path.find(':') != std::string::npos)) path = path.substr(path.find_last_of("/:") + 1);
    return path;
  }

  // The rig's image for a file beside the model: one per file, however many materials show it.
  int ImageNamed(const std::string& file) {
    for (size_t i = 0; i < rig_.images.size(); ++i) {
      if (rig_.images[i].name == file) return static_cast<int>(i);
    }
    return AddImageBeside(rig_, file);
  }

  int Material(pugi::xml_node inst, const std::string& symbol) {
    for (pugi::xml_node im : inst.child("bind_material").child("technique_common").children("instance_material")) {
      if (symbol != im.attribute("symbol").value()) continue;
      pugi::xml_node mat = ById(im.attribute("target").value());
      if (!mat) return -1;
      const std::string id = mat.attribute("id").value();
      if (auto it = material_of_.find(id); it != material_of_.end()) return it->second;
      facespace::Material m;
      m.name = mat.attribute("name").value()[0] ? mat.attribute("name").value() : id;
      m.metallic_factor = 0.0f;
      m.roughness_factor = 0.8f;
      pugi::xml_node effect = ById(mat.child("instance_effect").attribute("url").value());
      for (pugi::xml_node tech : effect.child("profile_COMMON").child("technique").children()) {
        pugi::xml_node diffuse = tech.child("diffuse");
        std::vector<double> c;
        if (diffuse.child("color") && ParseNumbers(diffuse.child_value("color"), c, 4) && c.size() >= 3) {
          for (size_t k = 0; k < 3; ++k) m.base_color_factor[k] = static_cast<float>(std::clamp(c[k], 0.0, 1.0));
        } else if (pugi::xml_node texture = diffuse.child("texture")) {
          const std::string file = TextureFile(effect.child("profile_COMMON"), texture.attribute("texture").value());
          if (file.empty()) {
            rig_.load_warnings.push_back({"texture_not_loaded", "material '" + m.name + "': its diffuse texture names no image", m.name, 0.0, false});
          } else {
            m.base_color_image = ImageNamed(file);
          }
        }
      }
      rig_.materials.push_back(m);
      material_of_[id] = static_cast<int>(rig_.materials.size()) - 1;
      return material_of_[id];
    }
    return -1;
  }

  Status Instance(pugi::xml_node inst, int node) {
    // Resolve the chain: controller(skin) -> controller(morph) -> geometry.
    pugi::xml_node target = ById(inst.attribute("url").value());
    pugi::xml_node skin, skin_controller, morph, morph_controller;
    for (int hops = 0; target && std::strcmp(target.name(), "controller") == 0 && hops < 4; ++hops) {
      if (pugi::xml_node s = target.child("skin"); s && !skin) {
        skin = s;
        skin_controller = target;
        target = ById(s.attribute("source").value());
      } else if (pugi::xml_node m = target.child("morph"); m && !morph) {
        morph = m;
        morph_controller = target;
        target = ById(m.attribute("source").value());
      } else {
        return Bad(Describe(target) + ": a controller chain that is not skin -> morph -> geometry");
      }
    }
    if (!target || std::strcmp(target.name(), "geometry") != 0) {
      rig_.load_warnings.push_back({"instance_skipped", Describe(inst) + " '" + std::string(inst.attribute("url").value()).substr(0, 60) + "' does not lead to a geometry", "", 0.0, false});
      return Status::Ok();
    }
    Split split;
    if (Status s = SplitGeometry(target, split); !s.ok()) return s;
    if (split.primitives.empty()) return Status::Ok();
    Mesh mesh;
    mesh.name = rig_.nodes[node].name;
    const int mesh_index = static_cast<int>(rig_.meshes.size());
    Morph m;
    if (morph) {
      if (Status s = ReadMorph(morph_controller, morph, split.point_count, split.points, m); !s.ok()) return s;
    }
    SkinData sd;
    if (skin) {
      if (Status s = ReadSkin(skin_controller, skin, split.point_count, sd); !s.ok()) return s;
    }
    const Eigen::Matrix3d linear = sd.bind_shape.block<3, 3>(0, 0);
    const Eigen::Matrix3d normal_matrix = linear.inverse().transpose();
    for (size_t p = 0; p < split.primitives.size(); ++p) {
      Primitive& prim = split.primitives[p];
      prim.mesh = mesh_index;
      prim.index_in_mesh = static_cast<int>(p);
      prim.material = Material(inst, split.material_symbol[p]);
      const std::vector<uint32_t>& points = split.point_of_vertex[p];
      if (skin) {  // The bind shape matrix goes into the vertices, as glTF has none.
        for (size_t v = 0; v < points.size(); ++v) {
          const Eigen::Vector4d q = sd.bind_shape * Eigen::Vector4d(prim.positions[3 * v], prim.positions[3 * v + 1], prim.positions[3 * v + 2], 1.0);
          for (int a = 0; a < 3; ++a) prim.positions[3 * v + a] = static_cast<float>(q[a]);
          if (!prim.normals.empty()) {
            const Vec3 n = (normal_matrix * Vec3(prim.normals[3 * v], prim.normals[3 * v + 1], prim.normals[3 * v + 2])).normalized();
            for (int a = 0; a < 3; ++a) prim.normals[3 * v + a] = static_cast<float>(n[a]);
          }
        }
      }
      for (const std::vector<double>& delta : m.targets) {
        SparseTarget t;
        for (size_t v = 0; v < points.size(); ++v) {
          const Vec3 d = linear * Vec3(&delta[3 * points[v]]);
          if (d.isZero(0)) continue;
          t.indices.push_back(static_cast<uint32_t>(v));
          for (int a = 0; a < 3; ++a) t.position_deltas.push_back(static_cast<float>(d[a]));
        }
        FinalizeTarget(t);
        prim.targets.push_back(std::move(t));
      }
    }
    for (size_t t = 0; t < m.targets.size(); ++t) {
      Shape shape;
      shape.name = m.names[t];
      for (int k = 2; FindShape(rig_, shape.name) >= 0; ++k) shape.name = mesh.name + "." + m.names[t] + (k > 2 ? "_" + std::to_string(k) : "");
      shape.default_weight = static_cast<float>(m.weights[t]);
      shape.min = std::min(0.0f, shape.default_weight);
      shape.max = std::max(1.0f, shape.default_weight);
      mesh.target_shapes.push_back(static_cast<uint32_t>(rig_.shapes.size()));
      morph_shapes_[m.weights_source].push_back(static_cast<uint32_t>(rig_.shapes.size()));
      rig_.shapes.push_back(shape);
    }
    if (!m.weights_source.empty()) morph_node_[m.weights_source] = node;
    if (skin) {
      std::vector<int> roots;
      for (pugi::xml_node s : inst.children("skeleton")) {
        const int r = NodeOfXml(ById(s.child_value()));
        if (r >= 0) roots.push_back(r);
      }
      facespace::Skin out;
      out.name = skin_controller.attribute("id").value();
      for (size_t j = 0; j < sd.joint_names.size(); ++j) {
        const int jn = JointNode(sd.joint_names[j], sd.names_are_ids, roots);
        if (jn < 0) return Bad(Describe(skin_controller) + ": joint '" + sd.joint_names[j].substr(0, 60) + "' is no node of the scene");
        out.joints.push_back(jn);
        for (int k = 0; k < 16; ++k) out.inverse_bind.push_back(static_cast<float>(sd.inverse_binds[j](k % 4, k / 4)));
      }
      // Vertices no joint weighs follow the instancing node.
      bool unweighted = false;
      for (const auto& inf : sd.influences) unweighted |= inf.empty();
      if (unweighted) {
        const uint32_t extra = static_cast<uint32_t>(out.joints.size());
        out.joints.push_back(node);
        const Mat4 ib = World(node).inverse();
        for (int k = 0; k < 16; ++k) out.inverse_bind.push_back(static_cast<float>(ib(k % 4, k / 4)));
        for (auto& inf : sd.influences) {
          if (inf.empty()) inf.emplace_back(extra, 1.0f);
        }
        rig_.load_warnings.push_back({"unweighted_vertices", Describe(skin_controller) + ": vertices without joint weights follow node '" + rig_.nodes[node].name + "'", "", 0.0, false});
      }
      for (size_t p = 0; p < split.primitives.size(); ++p) SetInfluences(split.primitives[p], split.point_of_vertex[p], sd.influences);
      mesh.skin = static_cast<int>(rig_.skins.size());
      rig_.joint_count += out.joints.size();
      rig_.skins.push_back(std::move(out));
      rig_.skin_count = rig_.skins.size();
    }
    for (Primitive& p : split.primitives) {
      FinalizePrimitive(p);
      rig_.primitives.push_back(std::move(p));
    }
    for (size_t p = 0; p < split.primitives.size(); ++p) mesh.primitives.push_back(static_cast<int>(rig_.primitives.size() - split.primitives.size() + p));
    rig_.meshes.push_back(std::move(mesh));
    if (rig_.nodes[node].mesh >= 0) {  // A second instance on one node: a child node carries it.
      Node extra;
      extra.name = rig_.nodes[node].name + "_" + std::to_string(mesh_index);
      extra.parent = node;
      extra.mesh = mesh_index;
      rig_.nodes[node].children.push_back(static_cast<int>(rig_.nodes.size()));
      rig_.nodes.push_back(extra);
      world_ = NodeWorldMatrices(rig_);
      if (!morph_node_.empty() && !m.weights_source.empty()) morph_node_[m.weights_source] = static_cast<int>(rig_.nodes.size()) - 1;
    } else {
      rig_.nodes[node].mesh = mesh_index;
    }
    return Status::Ok();
  }

  // ---- animation: morph weights ----

  // One curve of a <sampler>: keys, values, interpolation per key, BEZIER tangents (time, value).
  struct Curve {
    std::vector<double> t, v, in, out;  // in/out: 2 per key when BEZIER.
    std::vector<std::string> interp;
    double At(double x) const {
      if (x <= t.front()) return v.front();
      if (x >= t.back()) return v.back();
      const size_t k = static_cast<size_t>(std::upper_bound(t.begin(), t.end(), x) - t.begin()) - 1;
      const double u = (x - t[k]) / (t[k + 1] - t[k]);
      const std::string& mode = k < interp.size() ? interp[k] : std::string("LINEAR");
      if (mode == "STEP") return v[k];
      if (mode == "BEZIER" && out.size() >= 2 * (k + 1) && in.size() >= 2 * (k + 2)) {
        // Control points (t, v) of the segment; solve time(s) = x by bisection.
        const double x0 = t[k], x1 = out[2 * k], x2 = in[2 * (k + 1)], x3 = t[k + 1];
        const double y0 = v[k], y1 = out[2 * k + 1], y2 = in[2 * (k + 1) + 1], y3 = v[k + 1];
        return BezierYAtX(x0, x1, x2, x3, y0, y1, y2, y3, x);
      }
      return v[k] + (v[k + 1] - v[k]) * u;
    }
  };

  Status Animations() {
    // Channels whose target is "<weights source id>(<index>)": a morph weight.
    std::map<std::string, std::map<size_t, Curve>> curves;  // weights source -> target index -> curve.
    size_t skipped = 0;
    std::vector<pugi::xml_node> stack;
    for (pugi::xml_node a : root_.child("library_animations").children("animation")) stack.push_back(a);
    double start = INFINITY, end = -INFINITY;
    while (!stack.empty()) {
      pugi::xml_node anim = stack.back();
      stack.pop_back();
      for (pugi::xml_node a : anim.children("animation")) {
        if (stack.size() < kMaxNodes) stack.push_back(a);
      }
      for (pugi::xml_node ch : anim.children("channel")) {
        const std::string target = ch.attribute("target").value();
        const size_t open = target.find('(');
        const std::string src = target.substr(0, open);
        if (open == std::string::npos || target.back() != ')' || !morph_shapes_.count(src)) {
          ++skipped;
          continue;
        }
        const long long index = std::strtoll(target.c_str() + open + 1, nullptr, 10);  // Saturates where atoll is undefined.
        if (index < 0 || static_cast<size_t>(index) >= morph_shapes_[src].size()) {
          ++skipped;
          continue;
        }
        pugi::xml_node sampler = ById(ch.attribute("source").value());
        Curve c;
        Source in, out, tin, tout, interp;
        for (pugi::xml_node i : sampler.children("input")) {
          const std::string_view sem = i.attribute("semantic").value();
          Source* dst = sem == "INPUT" ? &in : sem == "OUTPUT" ? &out : sem == "IN_TANGENT" ? &tin : sem == "OUT_TANGENT" ? &tout : sem == "INTERPOLATION" ? &interp : nullptr;
          if (dst) {
            if (Status s = ReadSource(ById(i.attribute("source").value()), *dst); !s.ok()) return s;
          }
        }
        if (in.count == 0 || in.count != out.count || out.numbers.empty()) return Bad(Describe(sampler) + ": INPUT and OUTPUT differ in length (or are empty)");
        for (size_t k = 0; k < in.count; ++k) {
          c.t.push_back(in.At(k)[0]);
          c.v.push_back(out.At(k)[0]);
          if (k && !(c.t[k] > c.t[k - 1])) return Bad(Describe(sampler) + ": key times are not ascending");
        }
        c.interp.assign(interp.names.begin(), interp.names.begin() + static_cast<std::ptrdiff_t>(std::min(interp.names.size(), in.count)));
        if (tin.stride == 2 && tin.count == in.count) c.in.assign(tin.numbers.begin(), tin.numbers.begin() + static_cast<std::ptrdiff_t>(2 * in.count));
        if (tout.stride == 2 && tout.count == in.count) c.out.assign(tout.numbers.begin(), tout.numbers.begin() + static_cast<std::ptrdiff_t>(2 * in.count));
        start = std::min(start, c.t.front());
        end = std::max(end, c.t.back());
        curves[src][static_cast<size_t>(index)] = std::move(c);
      }
    }
    if (skipped) {
      rig_.load_warnings.push_back({"animation_skipped", std::to_string(skipped) + " animation channels target nodes or other properties; only morph weights are read", "",
                                    static_cast<double>(skipped), true});
    }
    if (curves.empty()) return Status::Ok();
    std::vector<float> times;
    if ((end - start) * kSampleRate + 3 > static_cast<double>(kMaxSamples)) return Bad("the animation spans too long a time");
    for (double x = start; x < end; x += 1.0 / kSampleRate) times.push_back(static_cast<float>(x));
    times.push_back(static_cast<float>(end));
    AnimationInfo clip;
    clip.name = "animation";
    for (const auto& [src, by_index] : curves) {
      const int node = morph_node_.count(src) ? morph_node_.at(src) : -1;
      if (node < 0 || rig_.nodes[node].mesh < 0) continue;
      const Mesh& mesh = rig_.meshes[rig_.nodes[node].mesh];
      AnimationSampler s;
      s.components = mesh.target_shapes.size();
      s.times = times;
      s.interpolation = Interpolation::kLinear;
      const std::vector<uint32_t>& shapes = morph_shapes_.at(src);
      for (float x : times) {
        for (uint32_t shape : mesh.target_shapes) {
          float w = rig_.shapes[shape].default_weight;
          for (size_t i = 0; i < shapes.size(); ++i) {
            if (shapes[i] == shape && by_index.count(i)) w = static_cast<float>(by_index.at(i).At(x));
          }
          s.values.push_back(w);
        }
      }
      clip.channel_data.push_back({static_cast<int>(clip.sampler_data.size()), node, ChannelPath::kWeights});
      clip.sampler_data.push_back(std::move(s));
    }
    if (clip.channel_data.empty()) return Status::Ok();
    clip.has_weights = true;
    clip.duration = times.back();
    clip.channels = clip.channel_data.size();
    rig_.animations.push_back(std::move(clip));
    return Status::Ok();
  }

  const pugi::xml_document& doc_;
  pugi::xml_node root_;
  Rig rig_;
  std::unordered_map<std::string, pugi::xml_node> ids_;
  std::vector<pugi::xml_node> node_xml_;  // Per node read from the scene: node first_node_ + i.
  size_t first_node_ = 0;
  std::vector<std::array<float, 16>> world_;
  std::map<std::string, int> material_of_;
  std::map<std::string, std::vector<uint32_t>> morph_shapes_;  // Weights source id -> shapes.
  std::map<std::string, int> morph_node_;                      // Weights source id -> node.
};

}  // namespace

Result<Rig> LoadColladaMemory(std::span<const unsigned char> bytes, const std::string& name) {
  pugi::xml_document doc;
  const pugi::xml_parse_result parsed = doc.load_buffer(bytes.data(), bytes.size(), pugi::parse_default, pugi::encoding_auto);
  if (!parsed) {
    return InvalidArgument(name + ": COLLADA: not well-formed XML at byte " + std::to_string(parsed.offset) + ": " + parsed.description());
  }
  Reader reader(doc, name);
  Result<Rig> rig = reader.Run();
  if (!rig.ok()) return Prefixed(rig.status(), name + ": ");
  return rig;
}

}  // namespace facespace
