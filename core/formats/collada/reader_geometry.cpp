// COLLADA: ids, sources, geometry, morph and skin controllers (reader.h).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iterator>

#include "collada/reader.h"

namespace facespace::formats::collada {

Status Bad(const std::string& what) { return InvalidArgument("COLLADA: " + what); }

std::string Describe(const pugi::xml_node& n) {
  std::string s = std::string("<") + n.name();
  if (const char* id = n.attribute("id").value(); *id)
    s += std::string(" id=\"") + std::string(id).substr(0, 60) + "\"";
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
std::string_view Fragment(std::string_view url) {
  return !url.empty() && url[0] == '#' ? url.substr(1) : url;
}

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

Mat4 RowMajor(const double* v) {
  Mat4 m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m(r, c) = v[4 * r + c];
  }
  return m;
}

void Reader::IndexIds(pugi::xml_node root) {
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

pugi::xml_node Reader::ById(std::string_view url) const {
  auto it = ids_.find(std::string(Fragment(url)));
  return it == ids_.end() ? pugi::xml_node() : it->second;
}

Status Reader::ReadSource(pugi::xml_node src, Source& out) {
  if (!src || std::strcmp(src.name(), "source") != 0)
    return Bad("a referenced <source> is missing");
  pugi::xml_node accessor = src.child("technique_common").child("accessor");
  pugi::xml_node array;
  for (pugi::xml_node c : src.children()) {
    const std::string_view n = c.name();
    if (n.size() > 6 && n.substr(n.size() - 6) == "_array") array = c;
  }
  if (!array) return Bad(Describe(src) + " has no array");
  const std::string_view kind = array.name();
  if (kind == "float_array" || kind == "int_array") {
    if (!ParseNumbers(array.child_value(), out.numbers, kMaxValues))
      return Bad(Describe(array) + " holds something that is not a finite number (or too many)");
  } else {
    out.names = ParseWords(array.child_value());
    if (out.names.size() > kMaxValues) return Bad(Describe(array) + " is too long");
  }
  const size_t have =
      kind == "float_array" || kind == "int_array" ? out.numbers.size() : out.names.size();
  out.stride = 1;
  out.count = have;
  if (accessor) {
    const long long count = accessor.attribute("count").as_llong(-1),
                    stride = accessor.attribute("stride").as_llong(1);
    const long long offset = accessor.attribute("offset").as_llong(0);
    if (count < 0 || stride < 1 || stride > 64 || offset != 0)
      return Bad(Describe(src) + ": its accessor's count, stride or offset is invalid");
    // The accessor rules (SCEA's animation_morph lists more names than its accessor counts).
    if (static_cast<unsigned long long>(count) * static_cast<unsigned long long>(stride) > have) {
      return Bad(Describe(src) + ": its accessor reads " + std::to_string(count) + " x " +
                 std::to_string(stride) + " values of " + std::to_string(have));
    }
    out.count = static_cast<size_t>(count);
    out.stride = static_cast<size_t>(stride);
  }
  return Status::Ok();
}

// The <mesh>'s positions (through <vertices>).
Status Reader::Positions(pugi::xml_node mesh, std::vector<double>& out,
                         pugi::xml_node* vertices_out) {
  pugi::xml_node vertices = mesh.child("vertices");
  if (!vertices) return Bad(Describe(mesh.parent()) + " has no <vertices>");
  if (vertices_out) *vertices_out = vertices;
  for (pugi::xml_node in : vertices.children("input")) {
    if (std::string_view(in.attribute("semantic").value()) != "POSITION") continue;
    Source s;
    if (Status st = ReadSource(ById(in.attribute("source").value()), s); !st.ok()) return st;
    if (s.stride < 3)
      return Bad(Describe(mesh.parent()) + ": positions have fewer than 3 components");
    out.clear();
    for (size_t i = 0; i < s.count; ++i) out.insert(out.end(), s.At(i), s.At(i) + 3);
    return Status::Ok();
  }
  return Bad(Describe(mesh.parent()) + ": <vertices> has no POSITION input");
}

namespace {

// A <triangles>, <polylist> or <polygons> element's indices (`stride` a corner) and its polygons'
// corner counts, checked to agree.
Status Corners(pugi::xml_node prim, pugi::xml_node geometry, size_t stride,
               std::vector<double>& indices, std::vector<double>& counts,
               std::vector<Warning>& warnings) {
  const std::string_view kind = prim.name();
  if (kind == "polygons") {
    for (pugi::xml_node p : prim.children("p")) {
      std::vector<double> one;
      if (!ParseNumbers(p.child_value(), one, kMaxValues))
        return Bad(Describe(geometry) + ": a <p> holds something that is not a number");
      if (one.size() % stride)
        return Bad(Describe(geometry) + ": a <p> is not a whole number of corners");
      counts.push_back(static_cast<double>(one.size() / stride));
      indices.insert(indices.end(), one.begin(), one.end());
    }
    if (prim.child("ph"))
      warnings.push_back({"primitive_skipped",
                          Describe(geometry) + ": polygons with holes (<ph>) are not read", "", 0.0,
                          false});
  } else {
    if (!ParseNumbers(prim.child("p").child_value(), indices, kMaxValues))
      return Bad(Describe(geometry) + ": <p> holds something that is not a number");
    if (kind == "polylist") {
      if (!ParseNumbers(prim.child("vcount").child_value(), counts, kMaxValues))
        return Bad(Describe(geometry) + ": <vcount> is not numbers");
    } else {
      counts.assign(indices.size() / stride / 3, 3.0);
    }
  }
  size_t need = 0;
  for (double c : counts) {
    if (c < 0 || c > 4096 || c != std::floor(c))
      return Bad(Describe(geometry) + ": a polygon has " + std::to_string(c) + " corners");
    need += static_cast<size_t>(c);
  }
  if (need * stride != indices.size()) {
    return Bad(Describe(geometry) + ": <p> holds " + std::to_string(indices.size()) +
               " indices, the polygons need " + std::to_string(need * stride));
  }
  return Status::Ok();
}

}  // namespace

Status Reader::SplitGeometry(pugi::xml_node geometry, Split& out) {
  pugi::xml_node mesh = geometry.child("mesh");
  if (!mesh)
    return Bad(Describe(geometry) + " is not a <mesh> (splines and convex meshes are not read)");
  pugi::xml_node vertices;
  if (Status s = Positions(mesh, out.points, &vertices); !s.ok()) return s;
  out.point_count = out.points.size() / 3;
  // Normals/texcoords may come through <vertices> too (indexed like positions).
  Source vnormal, vuv;
  bool has_vnormal = false, has_vuv = false;
  for (pugi::xml_node in : vertices.children("input")) {
    const std::string_view sem = in.attribute("semantic").value();
    if (sem == "NORMAL" && ReadSource(ById(in.attribute("source").value()), vnormal).ok() &&
        vnormal.stride >= 3)
      has_vnormal = true;
    if (sem == "TEXCOORD" && ReadSource(ById(in.attribute("source").value()), vuv).ok() &&
        vuv.stride >= 2)
      has_vuv = true;
  }
  for (pugi::xml_node prim : mesh.children()) {
    const std::string_view kind = prim.name();
    if (kind != "triangles" && kind != "polylist" && kind != "polygons") {
      if (kind == "lines" || kind == "linestrips" || kind == "trifans" || kind == "tristrips") {
        rig_.load_warnings.push_back(
            {"primitive_skipped", Describe(geometry) + ": <" + std::string(kind) + "> is not read",
             "", 0.0, false});
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
        if (normal.stride < 3)
          return Bad(Describe(geometry) + ": normals have fewer than 3 components");
        normal_offset = off;
      }
      if (sem == "TEXCOORD" && uv_offset < 0) {
        if (Status s = ReadSource(ById(in.attribute("source").value()), uv); !s.ok()) return s;
        if (uv.stride < 2)
          return Bad(Describe(geometry) + ": texture coordinates have fewer than 2 components");
        uv_offset = off;
      }
    }
    if (vertex_offset < 0)
      return Bad(Describe(geometry) + ": <" + std::string(kind) + "> has no VERTEX input");
    std::vector<double> indices, counts;
    if (Status s = Corners(prim, geometry, stride, indices, counts, rig_.load_warnings); !s.ok())
      return s;
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
          return Bad(Describe(geometry) + ": corner " + std::to_string(corner) + " uses vertex " +
                     std::to_string(vi) + " of " + std::to_string(out.point_count));
        }
        const long long ni =
            normal_offset >= 0 ? index_at(corner, normal_offset) : (has_vnormal ? vi : -1);
        const long long ti = uv_offset >= 0 ? index_at(corner, uv_offset) : (has_vuv ? vi : -1);
        const Source& ns = normal_offset >= 0 ? normal : vnormal;
        const Source& ts = uv_offset >= 0 ? uv : vuv;
        if ((normals && (ni < 0 || static_cast<size_t>(ni) >= ns.count)) ||
            (uvs && (ti < 0 || static_cast<size_t>(ti) >= ts.count))) {
          return Bad(Describe(geometry) + ": corner " + std::to_string(corner) +
                     " indexes a normal or texture coordinate beyond its source");
        }
        auto [it, fresh] = dedupe.emplace(std::array<long long, 3>{vi, ni, ti},
                                          static_cast<uint32_t>(points.size()));
        if (fresh) {
          points.push_back(static_cast<uint32_t>(vi));
          for (int a = 0; a < 3; ++a)
            p.positions.push_back(static_cast<float>(out.points[3 * vi + a]));
          if (normals) {
            for (int a = 0; a < 3; ++a)
              p.normals.push_back(static_cast<float>(ns.At(static_cast<size_t>(ni))[a]));
          }
          if (uvs) {
            p.texcoords.push_back(static_cast<float>(ts.At(static_cast<size_t>(ti))[0]));
            p.texcoords.push_back(static_cast<float>(
                1.0 - ts.At(static_cast<size_t>(ti))[1]));  // COLLADA's V points up.
          }
        }
        poly.push_back(it->second);
      }
      for (size_t k = 1; k + 1 < n; ++k)
        p.indices.insert(p.indices.end(), {poly[0], poly[k], poly[k + 1]});
    }
    p.source_has_normals = normals;
    if (p.indices.empty()) continue;
    out.primitives.push_back(std::move(p));
    out.point_of_vertex.push_back(std::move(points));
    out.material_symbol.push_back(prim.attribute("material").value());
  }
  return Status::Ok();
}

Status Reader::ReadMorph(pugi::xml_node controller, pugi::xml_node morph, size_t points,
                         const std::vector<double>& base, Morph& out) {
  out.controller = controller;
  const std::string_view method = morph.attribute("method").value();
  if (!method.empty() && method != "NORMALIZED" && method != "RELATIVE")
    return Bad(Describe(controller) + ": unknown morph method '" +
               std::string(method).substr(0, 40) + "'");
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
  if (targets.names.empty() && targets.count)
    return Bad(Describe(controller) + ": MORPH_TARGET is not a list of ids");
  for (size_t t = 0; t < targets.count; ++t) {
    const std::string& id = targets.names[t];
    pugi::xml_node g = ById(id);
    if (!g || std::strcmp(g.name(), "geometry") != 0) {
      rig_.load_warnings.push_back({"shape_skipped",
                                    Describe(controller) + ": morph target '" + id.substr(0, 60) +
                                        "' is not a geometry in the file",
                                    id, 0.0, false});
      continue;
    }
    std::vector<double> pos;
    if (Status s = Positions(g.child("mesh"), pos); !s.ok()) return s;
    if (pos.size() != 3 * points) {
      return Bad(Describe(controller) + ": target '" + id + "' has " +
                 std::to_string(pos.size() / 3) + " positions, the base " + std::to_string(points));
    }
    // COLLADA 1.4.1 (5-71): NORMALIZED is (1 - sum w) base + sum w target, so a shape's offset is
    // target - base; RELATIVE is base + sum w target, the targets added as given: they are the
    // offsets.
    if (method != "RELATIVE") {
      for (size_t k = 0; k < pos.size(); ++k) pos[k] -= base[k];
    }
    out.names.push_back(g.attribute("name").value()[0] ? g.attribute("name").value() : id);
    out.targets.push_back(std::move(pos));
    out.weights.push_back(
        t < weights.count && weights.numbers.size() > t * weights.stride ? weights.At(t)[0] : 0.0);
  }
  return Status::Ok();
}

Status Reader::ReadSkin(pugi::xml_node controller, pugi::xml_node skin, size_t points,
                        SkinData& out) {
  std::vector<double> bsm;
  if (pugi::xml_node b = skin.child("bind_shape_matrix")) {
    if (!ParseNumbers(b.child_value(), bsm, 16) || bsm.size() != 16)
      return Bad(Describe(controller) + ": <bind_shape_matrix> is not 16 numbers");
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
  if (joints.names.size() < joints.count || joints.count == 0)
    return Bad(Describe(controller) + ": the skin names no joints");
  if (matrices.count != joints.count || matrices.stride != 16)
    return Bad(Describe(controller) + ": " + std::to_string(matrices.count) +
               " inverse bind matrices for " + std::to_string(joints.count) + " joints");
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
    if (off < 0 || off > 64)
      return Bad(Describe(controller) + ": a vertex_weights input's offset is invalid");
    stride = std::max(stride, static_cast<size_t>(off) + 1);
    const std::string_view sem = in.attribute("semantic").value();
    if (sem == "JOINT") joint_off = off;
    if (sem == "WEIGHT") {
      weight_off = off;
      if (Status s = ReadSource(ById(in.attribute("source").value()), weights); !s.ok()) return s;
    }
  }
  if (joint_off < 0 || weight_off < 0)
    return Bad(Describe(controller) + ": <vertex_weights> needs JOINT and WEIGHT inputs");
  std::vector<double> vcount, v;
  if (!ParseNumbers(vw.child("vcount").child_value(), vcount, kMaxValues) ||
      !ParseNumbers(vw.child("v").child_value(), v, kMaxValues)) {
    return Bad(Describe(controller) + ": <vcount> or <v> holds something that is not a number");
  }
  if (vcount.size() != points) {
    return Bad(Describe(controller) + ": <vcount> has " + std::to_string(vcount.size()) +
               " entries, the mesh " + std::to_string(points) + " vertices");
  }
  out.influences.assign(points, {});
  size_t at = 0;
  for (size_t p = 0; p < points; ++p) {
    if (vcount[p] < 0 || vcount[p] > 1024)
      return Bad(Describe(controller) + ": vertex " + std::to_string(p) + " has " +
                 Number(vcount[p]) + " influences");
    for (size_t k = 0; k < static_cast<size_t>(vcount[p]); ++k, ++at) {
      if ((at + 1) * stride > v.size())
        return Bad(Describe(controller) + ": <v> ends before the influences <vcount> promises");
      const double j = v[at * stride + static_cast<size_t>(joint_off)],
                   w = v[at * stride + static_cast<size_t>(weight_off)];
      if (w < 0 || w >= static_cast<double>(weights.count) || w != std::floor(w))
        return Bad(Describe(controller) + ": a weight index is beyond its source");
      if (j == -1) continue;  // The bind shape itself: no joint.
      if (j < 0 || j >= static_cast<double>(joints.count) || j != std::floor(j))
        return Bad(Describe(controller) + ": vertex " + std::to_string(p) + " names joint " +
                   Number(j) + " of " + std::to_string(joints.count));
      const double weight = weights.At(static_cast<size_t>(w))[0];
      if (weight > 0)
        out.influences[p].emplace_back(static_cast<uint32_t>(j), static_cast<float>(weight));
    }
  }
  return Status::Ok();
}

}  // namespace facespace::formats::collada
