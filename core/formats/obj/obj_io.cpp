// OBJ import: a single mesh, or a sequence of OBJ files as absolute shapes. Vertices are the
// file's `v` lines in order, so frames of one mesh correspond vertex by vertex.
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "common/image_file.h"
#include "facespace/formats/io.h"

namespace facespace::formats {

namespace {

struct ObjMesh {
  std::vector<float> positions;
  std::vector<float> uvs;                      // From vt lines.
  std::vector<std::vector<uint32_t>> faces;    // v indices (0-based) per polygon.
  std::vector<std::vector<int64_t>> face_uvs;  // vt indices per corner (-1 none).
  std::vector<size_t> face_lines;              // Source line of each face.
  std::vector<uint32_t> face_groups;           // Index into `groups` of each face's "g" group.
  std::vector<std::string> groups = {""};
};

bool ParseFloat(std::string_view s, float& out) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && std::isfinite(out);
}

Status ParseObj(const std::string& path, ObjMesh& mesh) {
  std::ifstream f(path);
  if (!f) return NotFound("cannot open '" + path + "'");
  std::string line;
  size_t line_no = 0;
  while (std::getline(f, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream in(line);
    std::string tag;
    in >> tag;
    const std::string where = path + ":" + std::to_string(line_no) + ": ";
    if (tag == "v" || tag == "vt") {
      const int want = tag == "v" ? 3 : 2;
      std::string tok;
      int got = 0;
      float vals[3] = {0, 0, 0};
      while (got < want && in >> tok) {
        if (!ParseFloat(tok, vals[got]))
          return InvalidArgument(where + "malformed number '" + tok + "'");
        ++got;
      }
      if (got < want && !(tag == "vt" && got == 1))
        return InvalidArgument(where + "'" + tag + "' needs " + std::to_string(want) + " numbers");
      auto& dst = tag == "v" ? mesh.positions : mesh.uvs;
      dst.insert(dst.end(), vals, vals + want);
    } else if (tag == "f") {
      std::vector<uint32_t> face;
      std::vector<int64_t> fuv;
      std::string tok;
      const int64_t nv = static_cast<int64_t>(mesh.positions.size() / 3);
      const int64_t nt = static_cast<int64_t>(mesh.uvs.size() / 2);
      while (in >> tok) {
        int64_t vi = 0, ti = 0;
        const size_t slash = tok.find('/');
        const std::string vs = tok.substr(0, slash);
        auto r = std::from_chars(vs.data(), vs.data() + vs.size(), vi);
        if (r.ec != std::errc() || r.ptr != vs.data() + vs.size() || vi == 0) {
          return InvalidArgument(where + "malformed face corner '" + tok + "'");
        }
        if (vi < 0) vi = nv + vi + 1;  // Relative index.
        if (vi < 1 || vi > nv)
          return InvalidArgument(where + "face refers to vertex " + std::to_string(vi) + " of " +
                                 std::to_string(nv));
        int64_t uv = -1;
        if (slash != std::string::npos) {
          const size_t slash2 = tok.find('/', slash + 1);
          const std::string ts = tok.substr(
              slash + 1, slash2 == std::string::npos ? std::string::npos : slash2 - slash - 1);
          if (!ts.empty()) {
            auto rt = std::from_chars(ts.data(), ts.data() + ts.size(), ti);
            if (rt.ec != std::errc() || ti == 0)
              return InvalidArgument(where + "malformed face corner '" + tok + "'");
            if (ti < 0) ti = nt + ti + 1;
            if (ti < 1 || ti > nt)
              return InvalidArgument(where + "face refers to texture vertex " + std::to_string(ti));
            uv = ti - 1;
          }
        }
        face.push_back(static_cast<uint32_t>(vi - 1));
        fuv.push_back(uv);
      }
      if (face.size() < 3) return InvalidArgument(where + "a face needs at least 3 corners");
      mesh.faces.push_back(std::move(face));
      mesh.face_uvs.push_back(std::move(fuv));
      mesh.face_lines.push_back(line_no);
      mesh.face_groups.push_back(static_cast<uint32_t>(mesh.groups.size() - 1));
    } else if (tag == "g") {
      std::string name;
      in >> name;
      mesh.groups.push_back(name);
    }
    // vn, o, g, s, usemtl, mtllib, comments: not needed (normals are recomputed).
  }
  if (mesh.positions.empty()) return InvalidArgument(path + ": no vertices");
  return Status::Ok();
}

std::string Stem(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const size_t dot = name.rfind('.');
  return dot == std::string::npos || dot == 0 ? name : name.substr(0, dot);
}

// The base primitive of an OBJ. Its vertices are the `v` lines in order, except where a vertex's
// face corners use different `vt` (a UV seam): there it has one copy per distinct `vt`, in the
// order the faces first use them, as glTF needs; `source_vertices` says which `v` each is, and
// `first_copy[v]` .. `first_copy[v + 1]` are the copies of v (ascending: targets stay sorted).
struct BaseMesh {
  Primitive primitive;
  std::vector<uint32_t> first_copy;  // Empty when no vertex was split.
};

BaseMesh BasePrimitive(const ObjMesh& m) {
  BaseMesh out;
  Primitive& p = out.primitive;
  const size_t n = m.positions.size() / 3;
  // Each vertex's distinct vt (-1: a corner without one), in first use.
  std::vector<std::vector<int64_t>> uvs_of(n);
  bool split = false;
  for (size_t f = 0; f < m.faces.size(); ++f) {
    for (size_t k = 0; k < m.faces[f].size(); ++k) {
      std::vector<int64_t>& l = uvs_of[m.faces[f][k]];
      if (std::find(l.begin(), l.end(), m.face_uvs[f][k]) == l.end()) l.push_back(m.face_uvs[f][k]);
      split |= l.size() > 1;
    }
  }
  const bool has_uvs = !m.uvs.empty();
  auto uv_of_corner = [&](int64_t t, float* uv) {
    uv[0] = t < 0 ? 0.0f : m.uvs[2 * static_cast<size_t>(t)];
    uv[1] = t < 0 ? 0.0f
                  : 1.0f - m.uvs[2 * static_cast<size_t>(t) + 1];  // OBJ v is up; glTF v is down.
  };
  if (!split || !has_uvs) {
    p.positions = m.positions;
    if (has_uvs) {
      p.texcoords.assign(2 * n, 0.0f);
      for (size_t v = 0; v < n; ++v) {
        if (!uvs_of[v].empty()) uv_of_corner(uvs_of[v][0], &p.texcoords[2 * v]);
      }
    }
    for (const auto& face : m.faces) {
      for (size_t k = 1; k + 1 < face.size(); ++k)
        p.indices.insert(p.indices.end(), {face[0], face[k], face[k + 1]});
    }
    return out;
  }
  out.first_copy.assign(n + 1, 0);
  for (size_t v = 0; v < n; ++v) {
    const size_t copies = std::max<size_t>(1, uvs_of[v].size());  // An unused vertex keeps one.
    out.first_copy[v + 1] = out.first_copy[v] + static_cast<uint32_t>(copies);
    for (size_t c = 0; c < copies; ++c) {
      p.positions.insert(p.positions.end(), &m.positions[3 * v], &m.positions[3 * v] + 3);
      float uv[2];
      uv_of_corner(uvs_of[v].empty() ? -1 : uvs_of[v][c], uv);
      p.texcoords.insert(p.texcoords.end(), uv, uv + 2);
      p.source_vertices.push_back(static_cast<uint32_t>(v));
    }
  }
  auto corner = [&](size_t f, size_t k) {
    const uint32_t v = m.faces[f][k];
    const std::vector<int64_t>& l = uvs_of[v];
    return out.first_copy[v] +
           static_cast<uint32_t>(std::find(l.begin(), l.end(), m.face_uvs[f][k]) - l.begin());
  };
  for (size_t f = 0; f < m.faces.size(); ++f) {
    for (size_t k = 1; k + 1 < m.faces[f].size(); ++k)
      p.indices.insert(p.indices.end(), {corner(f, 0), corner(f, k), corner(f, k + 1)});
  }
  return out;
}

// A target over the source's vertices as one over the split ones: each delta on every copy.
SparseTarget SplitTarget(SparseTarget t, const std::vector<uint32_t>& first_copy) {
  if (first_copy.empty()) return t;
  SparseTarget out;
  for (size_t k = 0; k < t.indices.size(); ++k) {
    for (uint32_t c = first_copy[t.indices[k]]; c < first_copy[t.indices[k] + 1]; ++c) {
      out.indices.push_back(c);
      out.position_deltas.insert(out.position_deltas.end(), &t.position_deltas[3 * k],
                                 &t.position_deltas[3 * k] + 3);
    }
  }
  FinalizeTarget(out);
  return out;
}

// Makes `primitives` the rig's, in `mesh`, shown by one root node; then the derived data.
void FinishMeshRig(Rig& rig, std::vector<Primitive> primitives, Mesh mesh) {
  for (Primitive& p : primitives) {
    p.mesh = 0;
    p.index_in_mesh = static_cast<int>(rig.primitives.size());
    FinalizePrimitive(p);
    mesh.primitives.push_back(p.index_in_mesh);
    rig.primitives.push_back(std::move(p));
  }
  rig.meshes.push_back(std::move(mesh));
  Node node;
  node.name = rig.name;
  node.mesh = 0;
  rig.nodes.push_back(node);
  rig.scene_roots.push_back(0);
  DetectSymmetricPartners(rig);
  CountMovedVertices(rig);
}

}  // namespace

Result<Rig> LoadObjSequence(std::span<const std::string> paths) {
  if (paths.empty()) return InvalidArgument("no OBJ files given");
  ObjMesh base;
  if (Status s = ParseObj(paths[0], base); !s.ok()) return s;
  Rig rig;
  rig.name = Stem(paths[0]);
  BaseMesh split = BasePrimitive(base);
  Primitive& p = split.primitive;
  const size_t n = base.positions.size() / 3;
  Mesh mesh;
  mesh.name = rig.name;
  for (size_t i = 1; i < paths.size(); ++i) {
    ObjMesh shape;
    if (Status s = ParseObj(paths[i], shape); !s.ok()) return s;
    if (shape.positions.size() != base.positions.size()) {
      return InvalidArgument(paths[i] + ": has " + std::to_string(shape.positions.size() / 3) +
                             " vertices, the base " + paths[0] + " has " + std::to_string(n));
    }
    const size_t faces = std::min(shape.faces.size(), base.faces.size());
    for (size_t f = 0; f < faces; ++f) {
      if (shape.faces[f] != base.faces[f]) {
        return InvalidArgument(paths[i] + ":" + std::to_string(shape.face_lines[f]) + ": face " +
                               std::to_string(f + 1) + " differs from face " +
                               std::to_string(f + 1) + " of the base (" + paths[0] + ":" +
                               std::to_string(base.face_lines[f]) +
                               "): connectivity must be identical");
      }
    }
    if (shape.faces.size() != base.faces.size()) {
      return InvalidArgument(paths[i] + ": has " + std::to_string(shape.faces.size()) +
                             " faces, the base has " + std::to_string(base.faces.size()) +
                             " (first missing or extra face: " + std::to_string(faces + 1) + ")");
    }
    SparseTarget t;
    for (size_t v = 0; v < n; ++v) {
      const float d[3] = {shape.positions[3 * v] - base.positions[3 * v],
                          shape.positions[3 * v + 1] - base.positions[3 * v + 1],
                          shape.positions[3 * v + 2] - base.positions[3 * v + 2]};
      if (d[0] == 0.0f && d[1] == 0.0f && d[2] == 0.0f) continue;
      t.indices.push_back(static_cast<uint32_t>(v));
      t.position_deltas.insert(t.position_deltas.end(), d, d + 3);
    }
    std::string name = Stem(paths[i]);
    if (FindShape(rig, name) >= 0) name.append("#").append(std::to_string(i));
    Shape s;
    s.name = name;
    mesh.target_shapes.push_back(static_cast<uint32_t>(rig.shapes.size()));
    rig.shapes.push_back(s);
    p.targets.push_back(SplitTarget(std::move(t), split.first_copy));
  }
  std::vector<Primitive> one;
  one.push_back(std::move(p));
  FinishMeshRig(rig, std::move(one), std::move(mesh));
  RepairNames(rig);
  if (Status s = ValidateRig(rig); !s.ok()) return s;
  return rig;
}

namespace {

// Reads one .target file: "index dx dy dz" per line, '#' comments. Sorted by index.
Status ReadTarget(const std::string& path, size_t vertex_count, float scale, SparseTarget& out) {
  std::ifstream f(path);
  if (!f) return NotFound("cannot open '" + path + "'");
  std::vector<std::pair<uint32_t, std::array<float, 3>>> rows;
  std::vector<uint32_t> seen_line(vertex_count, 0);
  std::string line;
  uint32_t line_no = 0;
  while (std::getline(f, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t start = line.find_first_not_of(" \t");
    if (start == std::string::npos || line[start] == '#') continue;
    std::istringstream in(line);
    std::string tok[5];
    int n = 0;
    while (n < 5 && in >> tok[n]) ++n;
    const std::string where = path + ":" + std::to_string(line_no) + ": ";
    long long index = -1;
    auto r = std::from_chars(tok[0].data(), tok[0].data() + tok[0].size(), index);
    float d[3];
    if (n != 4 || r.ec != std::errc() || r.ptr != tok[0].data() + tok[0].size() ||
        !ParseFloat(tok[1], d[0]) || !ParseFloat(tok[2], d[1]) || !ParseFloat(tok[3], d[2])) {
      return InvalidArgument(where + "malformed line '" + line.substr(0, 80) +
                             "' (want: vertex-index dx dy dz)");
    }
    if (index < 0 || static_cast<size_t>(index) >= vertex_count) {
      return InvalidArgument(where + "vertex index " + std::to_string(index) +
                             " is beyond the mesh's " + std::to_string(vertex_count) + " vertices");
    }
    if (seen_line[index]) {
      return InvalidArgument(where + "vertex " + std::to_string(index) +
                             " is given twice (first on line " + std::to_string(seen_line[index]) +
                             ")");
    }
    seen_line[index] = line_no;
    rows.push_back({static_cast<uint32_t>(index), {d[0] * scale, d[1] * scale, d[2] * scale}});
  }
  std::sort(rows.begin(), rows.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [i, d] : rows) {
    if (d[0] == 0.0f && d[1] == 0.0f && d[2] == 0.0f) continue;
    out.indices.push_back(i);
    out.position_deltas.insert(out.position_deltas.end(), d.begin(), d.end());
  }
  return Status::Ok();
}

// A MakeHuman proxy (.mhclo): its OBJ's vertices, each placed on the base mesh as MakeHuman's
// proxy.py places it: three base vertices by weight, plus an offset scaled per axis by the base's
// size there (|base[a][axis] - base[b][axis]| / s, from the x_scale/y_scale/z_scale lines).
struct Mhclo {
  std::string obj_file, material_file;
  std::array<uint32_t, 3> scale_a{}, scale_b{};
  std::array<float, 3> scale_by{0, 0,
                                0};  // 0: no scale line for the axis (the offset is taken as is).
  std::vector<std::array<uint32_t, 3>> refs;
  std::vector<std::array<float, 3>> weights, offsets;
};

Status ParseMhclo(const std::string& path, size_t base_vertices, Mhclo& out) {
  std::ifstream f(path);
  if (!f) return NotFound("cannot open '" + path + "'");
  std::string line;
  size_t line_no = 0;
  bool in_verts = false;
  constexpr size_t kMaxVerts = size_t{1} << 22;
  auto bad = [&](const std::string& what) {
    return InvalidArgument(path + ":" + std::to_string(line_no) + ": " + what);
  };
  auto index = [&](const std::string& s, uint32_t& v) {
    size_t at = 0;
    const auto r = std::from_chars(s.data(), s.data() + s.size(), at);
    if (r.ec != std::errc() || r.ptr != s.data() + s.size() || at >= base_vertices) return false;
    v = static_cast<uint32_t>(at);
    return true;
  };
  while (std::getline(f, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream in(line);
    std::vector<std::string> tok;
    for (std::string s; in >> s && tok.size() < 10;) tok.push_back(s);
    if (tok.empty() || tok[0][0] == '#') continue;
    const bool numeric = std::isdigit(static_cast<unsigned char>(tok[0][0]));
    if (in_verts && numeric) {
      if (out.refs.size() >= kMaxVerts)
        return bad("more than " + std::to_string(kMaxVerts) + " vertices");
      std::array<uint32_t, 3> r{};
      std::array<float, 3> w{1, 0, 0}, o{0, 0, 0};
      if (tok.size() == 1) {  // The base vertex itself.
        if (!index(tok[0], r[0]))
          return bad("a base vertex index in 0.." + std::to_string(base_vertices - 1) +
                     " expected");
        r[1] = r[2] = r[0];
      } else if (tok.size() == 9) {
        for (int k = 0; k < 3; ++k) {
          if (!index(tok[k], r[k]))
            return bad("a base vertex index in 0.." + std::to_string(base_vertices - 1) +
                       " expected");
          if (!ParseFloat(tok[3 + k], w[k]) || !ParseFloat(tok[6 + k], o[k]) ||
              !std::isfinite(w[k]) || !std::isfinite(o[k])) {
            return bad("three finite weights and an offset expected");
          }
        }
      } else {
        return bad("a vertex line is 'i' or 'i j k wi wj wk dx dy dz'");
      }
      out.refs.push_back(r);
      out.weights.push_back(w);
      out.offsets.push_back(o);
      continue;
    }
    in_verts = false;
    const std::string& key = tok[0];
    if (key == "verts") {
      in_verts = true;
    } else if (key == "obj_file" && tok.size() >= 2) {
      out.obj_file = line.substr(line.find(tok[1]));
    } else if (key == "material" && tok.size() >= 2) {
      out.material_file = line.substr(line.find(tok[1]));
    } else if (key == "x_scale" || key == "y_scale" || key == "z_scale") {
      const int axis = key[0] - 'x';
      float by = 0;
      if (tok.size() != 4 || !index(tok[1], out.scale_a[axis]) ||
          !index(tok[2], out.scale_b[axis]) || !ParseFloat(tok[3], by) || !(by > 0) ||
          !std::isfinite(by)) {
        return bad(key + " takes two base vertex indices and a positive size");
      }
      out.scale_by[axis] = by;
    }
    // uuid, basemesh, name, tag, z_depth, delete_verts, ...: not needed to place the vertices.
  }
  if (out.obj_file.empty()) return InvalidArgument(path + ": no obj_file line");
  if (out.refs.empty()) return InvalidArgument(path + ": no vertices (a 'verts 0' section)");
  return Status::Ok();
}

// The proxy's vertices over base positions `base` (3 floats per base vertex).
void PlaceProxy(const Mhclo& m, std::span<const float> base, std::vector<float>& out) {
  std::array<float, 3> scale{1, 1, 1};
  for (int a = 0; a < 3; ++a) {
    if (m.scale_by[a] > 0)
      scale[a] = std::abs(base[3 * m.scale_a[a] + a] - base[3 * m.scale_b[a] + a]) / m.scale_by[a];
  }
  out.assign(3 * m.refs.size(), 0.0f);
  for (size_t v = 0; v < m.refs.size(); ++v) {
    for (int a = 0; a < 3; ++a) {
      float x = m.offsets[v][a] * scale[a];
      for (int k = 0; k < 3; ++k) x += m.weights[v][k] * base[3 * m.refs[v][k] + a];
      out[3 * v + a] = x;
    }
  }
}

// A proxy as a primitive of the rig, with a target per base target (what the proxy's placement
// gives at the target's full weight, minus the rest): MakeHuman's eyes follow every eye target.
struct ProxyPrimitive {
  BaseMesh split;
  Mhclo fit;
};

Status LoadProxy(const std::string& path, std::span<const float> base, Rig& rig,
                 ProxyPrimitive& out) {
  namespace fs = std::filesystem;
  if (Status s = ParseMhclo(path, base.size() / 3, out.fit); !s.ok()) return s;
  const fs::path dir = fs::path(path).parent_path();
  ObjMesh obj;
  if (Status s = ParseObj((dir / out.fit.obj_file).string(), obj); !s.ok()) return s;
  if (obj.positions.size() / 3 != out.fit.refs.size()) {
    return InvalidArgument(path + ": " + std::to_string(out.fit.refs.size()) +
                           " vertices placed for the " + std::to_string(obj.positions.size() / 3) +
                           " of " + out.fit.obj_file);
  }
  PlaceProxy(out.fit, base,
             obj.positions);  // The OBJ's own positions give way to where the proxy sits.
  out.split = BasePrimitive(obj);
  // The material (.mhmat): its name, colour, texture and transparency. Its path is relative to
  // the proxy (MakeHuman's tree: ../materials/); beside the proxy when not there.
  Material mat;
  mat.name = fs::path(path).stem().string();
  mat.metallic_factor = 0.0f;
  mat.roughness_factor = 0.35f;
  auto beside = [&](const fs::path& from, const std::string& name) {
    const fs::path p = from / name;
    return fs::is_regular_file(p) ? p : dir / fs::path(name).filename();
  };
  if (!out.fit.material_file.empty()) {
    const fs::path mhmat = beside(dir, out.fit.material_file);
    std::ifstream mf(mhmat);
    if (!mf) return NotFound(path + ": cannot open its material '" + out.fit.material_file + "'");
    std::string line;
    while (std::getline(mf, line)) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      std::istringstream in(line);
      std::string key;
      in >> key;
      if (key == "name") {
        in >> mat.name;
      } else if (key == "diffuseColor") {
        std::array<float, 3> c{};
        if (in >> c[0] >> c[1] >> c[2]) {
          for (int k = 0; k < 3; ++k) mat.base_color_factor[k] = std::clamp(c[k], 0.0f, 1.0f);
        }
      } else if (key == "transparent") {
        std::string v;
        in >> v;
        if (v == "True") mat.alpha_mode = "MASK";  // MakeHuman draws it with alpha to coverage.
      } else if (key == "backfaceCull") {
        std::string v;
        in >> v;
        mat.double_sided = v == "False";
      } else if (key == "diffuseTexture") {
        std::string name;
        std::getline(in >> std::ws, name);
        const fs::path file = beside(mhmat.parent_path(), name);
        Image image;
        image.name = file.filename().string();
        if (const std::string why = ReadImageFile(file, image); !why.empty())
          return InvalidArgument(path + ": its texture '" + name + "': " + why);
        if (image.mime_type != "image/png" && image.mime_type != "image/jpeg")
          return InvalidArgument(path + ": its texture '" + name + "' is not a PNG or JPEG");
        mat.base_color_image = static_cast<int>(rig.images.size());
        rig.images.push_back(std::move(image));
      }
    }
  }
  out.split.primitive.material = static_cast<int>(rig.materials.size());
  rig.materials.push_back(std::move(mat));
  return Status::Ok();
}

// The proxy's move under a base target (`dense`: the target's deltas over every base vertex, zero
// elsewhere), exact at the target's full weight: the three weighted vertices' moves and the
// offset's change of scale.
SparseTarget ProxyTarget(const ProxyPrimitive& proxy, std::span<const float> base,
                         std::span<const float> dense) {
  const Mhclo& m = proxy.fit;
  std::array<float, 3> rescale{0, 0, 0};
  for (int a = 0; a < 3; ++a) {
    if (!(m.scale_by[a] > 0)) continue;
    const size_t i = 3 * m.scale_a[a] + a, j = 3 * m.scale_b[a] + a;
    rescale[a] = (std::abs(base[i] + dense[i] - base[j] - dense[j]) - std::abs(base[i] - base[j])) /
                 m.scale_by[a];
  }
  SparseTarget t;
  for (size_t v = 0; v < m.refs.size(); ++v) {
    float d[3];
    for (int a = 0; a < 3; ++a) {
      d[a] = m.offsets[v][a] * rescale[a];
      for (int k = 0; k < 3; ++k) d[a] += m.weights[v][k] * dense[3 * m.refs[v][k] + a];
    }
    if (d[0] == 0.0f && d[1] == 0.0f && d[2] == 0.0f) continue;
    t.indices.push_back(static_cast<uint32_t>(v));
    t.position_deltas.insert(t.position_deltas.end(), d, d + 3);
  }
  return SplitTarget(std::move(t), proxy.split.first_copy);
}

// A MakeHuman .target file and where it sits.
struct TargetFile {
  std::filesystem::path path;
  std::string group;   // First sub-folder, or the folder's own name.
  std::string folder;  // Sub-folder path relative to the folder given ("expression/units/asian").
};

// Targets: every .target under each folder, sorted by path (deterministic).
Status ListTargetFiles(std::span<const std::string> target_dirs, std::vector<TargetFile>& files) {
  namespace fs = std::filesystem;
  for (const std::string& dir : target_dirs) {
    std::vector<fs::path> found;
    std::error_code ec;
    // Linked folders are followed (a targets tree assembled from links); a cycle of links stops
    // at the depth limit.
    constexpr int kMaxDepth = 12;
    for (auto it = fs::recursive_directory_iterator(
             dir, fs::directory_options::follow_directory_symlink, ec);
         !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
      if (it.depth() >= kMaxDepth) it.disable_recursion_pending();
      if (it->is_regular_file() && it->path().extension() == ".target") found.push_back(it->path());
    }
    if (ec || !fs::is_directory(dir))
      return NotFound("cannot read the targets folder '" + dir + "'");
    if (found.empty()) return NotFound("no .target files under '" + dir + "'");
    std::sort(found.begin(), found.end());
    const std::string own = fs::path(dir).lexically_normal().filename().empty()
                                ? fs::path(dir).lexically_normal().parent_path().filename().string()
                                : fs::path(dir).lexically_normal().filename().string();
    for (const fs::path& f : found) {
      const fs::path rel = f.parent_path().lexically_relative(dir);
      const bool top = rel.empty() || rel == ".";
      files.push_back({f, top ? own : rel.begin()->string(), top ? own : rel.generic_string()});
    }
  }
  return Status::Ok();
}

}  // namespace

Result<Rig> LoadMakeHuman(const std::string& obj_path, std::span<const std::string> target_dirs,
                          const MakeHumanOptions& options) {
  namespace fs = std::filesystem;
  ObjMesh obj;
  if (Status s = ParseObj(obj_path, obj); !s.ok()) return s;
  const size_t obj_vertices = obj.positions.size() / 3;
  const float scale = options.metres ? 0.1f : 1.0f;
  // The kept faces, and the vertices they use, in OBJ order.
  const bool all =
      std::find(options.groups.begin(), options.groups.end(), "*") != options.groups.end();
  std::vector<uint8_t> keep_group(obj.groups.size(), 0);
  for (size_t g = 0; g < obj.groups.size(); ++g) {
    keep_group[g] = all || std::find(options.groups.begin(), options.groups.end(), obj.groups[g]) !=
                               options.groups.end();
  }
  std::vector<int32_t> remap(obj_vertices, -1);
  ObjMesh kept;
  for (size_t f = 0; f < obj.faces.size(); ++f) {
    if (!keep_group[obj.face_groups[f]]) continue;
    for (uint32_t v : obj.faces[f]) remap[v] = 0;
    kept.faces.push_back(obj.faces[f]);
    kept.face_uvs.push_back(obj.face_uvs[f]);
  }
  if (kept.faces.empty()) return InvalidArgument(obj_path + ": no face in the groups asked for");
  RankKeptVertices(remap);
  for (size_t v = 0; v < obj_vertices; ++v) {
    if (remap[v] < 0) continue;
    for (int c = 0; c < 3; ++c) kept.positions.push_back(obj.positions[3 * v + c] * scale);
  }
  for (auto& face : kept.faces) {
    for (uint32_t& v : face) v = static_cast<uint32_t>(remap[v]);
  }
  kept.uvs = obj.uvs;
  Rig rig;
  rig.name = "makehuman";
  std::vector<float> base(
      obj.positions.size());  // Every OBJ vertex (helpers too), scaled: where proxies sit.
  std::transform(obj.positions.begin(), obj.positions.end(), base.begin(),
                 [scale](float x) { return x * scale; });
  BaseMesh split = BasePrimitive(kept);
  Primitive& p = split.primitive;
  // No CC0 MakeHuman skin texture is in our package sources: a skin-toned dielectric instead
  // (sRGB #e3b5a1 as linear, a little glossy), which the renderer lights as it would a texture.
  Material skin;
  skin.name = "skin";
  skin.base_color_factor = {0.77f, 0.47f, 0.36f, 1.0f};
  skin.metallic_factor = 0.0f;
  skin.roughness_factor = 0.5f;
  rig.materials.push_back(skin);
  p.material = 0;
  std::vector<ProxyPrimitive> proxies(options.proxies.size());
  for (size_t k = 0; k < proxies.size(); ++k) {
    if (Status s = LoadProxy(options.proxies[k], base, rig, proxies[k]); !s.ok()) return s;
  }
  std::vector<float> dense(proxies.empty() ? 0 : base.size(), 0.0f);
  std::vector<TargetFile> files;
  if (Status s = ListTargetFiles(target_dirs, files); !s.ok()) return s;
  Mesh mesh;
  mesh.name = rig.name;
  for (const auto& [file, group, folder] : files) {
    SparseTarget full;
    if (Status s = ReadTarget(file.string(), obj_vertices, scale, full); !s.ok()) return s;
    SparseTarget t = SplitTarget(RemapTarget(full, remap),
                                 split.first_copy);  // Vertices of geometry not kept drop out.
    Shape shape;
    shape.name = file.stem().string();
    shape.group = group.empty() ? "default" : group;
    // Same stem in two folders (MakeHuman's expression units per ethnicity): the folder path says
    // which.
    if (FindShape(rig, shape.name) >= 0) shape.name = folder + "/" + shape.name;
    for (int n = 2; FindShape(rig, shape.name) >= 0; ++n)
      shape.name = folder + "/" + file.stem().string() + "#" + std::to_string(n);
    mesh.target_shapes.push_back(static_cast<uint32_t>(rig.shapes.size()));
    rig.shapes.push_back(std::move(shape));
    p.targets.push_back(std::move(t));
    if (proxies.empty()) continue;
    for (size_t k = 0; k < full.indices.size(); ++k)
      std::copy_n(&full.position_deltas[3 * k], 3, &dense[3 * full.indices[k]]);
    for (ProxyPrimitive& proxy : proxies)
      proxy.split.primitive.targets.push_back(ProxyTarget(proxy, base, dense));
    for (uint32_t v : full.indices) std::fill_n(&dense[3 * v], 3, 0.0f);
  }
  std::vector<Primitive> primitives;
  primitives.push_back(std::move(p));
  for (ProxyPrimitive& proxy : proxies) primitives.push_back(std::move(proxy.split.primitive));
  FinishMeshRig(rig, std::move(primitives), std::move(mesh));
  if (!options.modifiers.empty()) {
    std::ifstream f(options.modifiers, std::ios::binary);
    if (!f) return NotFound("cannot open '" + options.modifiers + "'");
    const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    if (Status s = ApplyMakeHumanModifiers(rig, text); !s.ok())
      return Prefixed(s, options.modifiers + ": ");
  }
  RepairNames(rig);
  if (Status s = ValidateRig(rig); !s.ok()) return s;
  return rig;
}

}  // namespace facespace::formats
