// OBJ import: a single mesh, or a sequence of OBJ files as absolute shapes. Vertices are the
// file's `v` lines in order, so frames of one mesh correspond vertex by vertex.
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "facespace/core/io.h"

namespace facespace {

namespace {

struct ObjMesh {
  std::vector<float> positions;
  std::vector<float> uvs;                 // From vt lines.
  std::vector<std::vector<uint32_t>> faces;       // v indices (0-based) per polygon.
  std::vector<std::vector<int64_t>> face_uvs;     // vt indices per corner (-1 none).
  std::vector<size_t> face_lines;         // Source line of each face.
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
        if (!ParseFloat(tok, vals[got])) return InvalidArgument(where + "malformed number '" + tok + "'");
        ++got;
      }
      if (got < want && !(tag == "vt" && got == 1)) return InvalidArgument(where + "'" + tag + "' needs " + std::to_string(want) + " numbers");
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
        if (vi < 1 || vi > nv) return InvalidArgument(where + "face refers to vertex " + std::to_string(vi) + " of " + std::to_string(nv));
        int64_t uv = -1;
        if (slash != std::string::npos) {
          const size_t slash2 = tok.find('/', slash + 1);
          const std::string ts = tok.substr(slash + 1, slash2 == std::string::npos ? std::string::npos : slash2 - slash - 1);
          if (!ts.empty()) {
            auto rt = std::from_chars(ts.data(), ts.data() + ts.size(), ti);
            if (rt.ec != std::errc() || ti == 0) return InvalidArgument(where + "malformed face corner '" + tok + "'");
            if (ti < 0) ti = nt + ti + 1;
            if (ti < 1 || ti > nt) return InvalidArgument(where + "face refers to texture vertex " + std::to_string(ti));
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

// Builds the base primitive from the first OBJ.
Primitive BasePrimitive(const ObjMesh& m, std::vector<Warning>& warnings, const std::string& path) {
  Primitive p;
  p.positions = m.positions;
  const size_t n = p.vertex_count();
  for (const auto& face : m.faces) {
    for (size_t k = 1; k + 1 < face.size(); ++k) p.indices.insert(p.indices.end(), {face[0], face[k], face[k + 1]});
  }
  // UVs per vertex when every corner of a vertex uses the same vt; else dropped (splitting
  // vertices would break the v order that shapes rely on).
  if (!m.uvs.empty()) {
    std::vector<int64_t> uv_of(n, -2);
    bool consistent = true;
    for (size_t f = 0; f < m.faces.size() && consistent; ++f) {
      for (size_t k = 0; k < m.faces[f].size(); ++k) {
        const int64_t t = m.face_uvs[f][k];
        int64_t& slot = uv_of[m.faces[f][k]];
        if (t < 0 || (slot != -2 && slot != t)) {
          consistent = false;
          break;
        }
        slot = t;
      }
    }
    if (consistent) {
      p.texcoords.assign(2 * n, 0.0f);
      for (size_t v = 0; v < n; ++v) {
        if (uv_of[v] >= 0) {
          p.texcoords[2 * v] = m.uvs[2 * uv_of[v]];
          p.texcoords[2 * v + 1] = 1.0f - m.uvs[2 * uv_of[v] + 1];  // OBJ v is up; glTF v is down.
        }
      }
    } else {
      warnings.push_back({"uv_dropped", path + ": texture coordinates differ per face corner; they were dropped", "", 0.0, false});
    }
  }
  return p;
}

}  // namespace

Result<Rig> LoadObjSequence(std::span<const std::string> paths) {
  if (paths.empty()) return InvalidArgument("no OBJ files given");
  ObjMesh base;
  if (Status s = ParseObj(paths[0], base); !s.ok()) return s;
  Rig rig;
  rig.name = Stem(paths[0]);
  Primitive p = BasePrimitive(base, rig.load_warnings, paths[0]);
  const size_t n = p.vertex_count();
  Mesh mesh;
  mesh.name = rig.name;
  for (size_t i = 1; i < paths.size(); ++i) {
    ObjMesh shape;
    if (Status s = ParseObj(paths[i], shape); !s.ok()) return s;
    if (shape.positions.size() != base.positions.size()) {
      return InvalidArgument(paths[i] + ": has " + std::to_string(shape.positions.size() / 3) + " vertices, the base " +
                             paths[0] + " has " + std::to_string(n));
    }
    const size_t faces = std::min(shape.faces.size(), base.faces.size());
    for (size_t f = 0; f < faces; ++f) {
      if (shape.faces[f] != base.faces[f]) {
        return InvalidArgument(paths[i] + ":" + std::to_string(shape.face_lines[f]) + ": face " + std::to_string(f + 1) +
                               " differs from face " + std::to_string(f + 1) + " of the base (" + paths[0] + ":" +
                               std::to_string(base.face_lines[f]) + "): connectivity must be identical");
      }
    }
    if (shape.faces.size() != base.faces.size()) {
      return InvalidArgument(paths[i] + ": has " + std::to_string(shape.faces.size()) + " faces, the base has " +
                             std::to_string(base.faces.size()) + " (first missing or extra face: " +
                             std::to_string(faces + 1) + ")");
    }
    SparseTarget t;
    for (size_t v = 0; v < n; ++v) {
      const float d[3] = {shape.positions[3 * v] - base.positions[3 * v], shape.positions[3 * v + 1] - base.positions[3 * v + 1],
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
    p.targets.push_back(std::move(t));
  }
  FinalizePrimitive(p);
  mesh.primitives.push_back(0);
  rig.primitives.push_back(std::move(p));
  rig.meshes.push_back(std::move(mesh));
  Node node;
  node.name = rig.name;
  node.mesh = 0;
  rig.nodes.push_back(node);
  rig.scene_roots.push_back(0);
  DetectSymmetricPartners(rig);
  CountMovedVertices(rig);
  if (Status s = ValidateRig(rig); !s.ok()) return s;
  return rig;
}

}  // namespace facespace
