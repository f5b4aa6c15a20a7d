#include "facespace/engine/rig.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>

#include "facespace/engine/blend.h"
#include "facespace/engine/skeleton.h"
#include "facespace/engine/utf8.h"

namespace facespace {
inline namespace engine {

void FinalizeTarget(SparseTarget& target) {
  target.runs.clear();
  const std::vector<uint32_t>& idx = target.indices;
  for (size_t k = 0; k < idx.size();) {
    size_t end = k + 1;
    while (end < idx.size() && idx[end] == idx[end - 1] + 1) ++end;
    target.runs.push_back(idx[k]);
    target.runs.push_back(static_cast<uint32_t>(end - k));
    k = end;
  }
  // Scattered targets (runs shorter than 4 vertices on average) blend faster one index at
  // a time than run by run: they keep no runs (tests/bench/blend_bench.cpp).
  if (target.runs.size() / 2 * 4 > idx.size()) target.runs.clear();
  target.move_lengths.resize(std::min(idx.size(), target.position_deltas.size() / 3));
  for (size_t k = 0; k < target.move_lengths.size(); ++k) {
    const float* d = &target.position_deltas[3 * k];
    target.move_lengths[k] = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  }
}

size_t RankKeptVertices(std::span<int32_t> remap) {
  size_t kept = 0;
  for (int32_t& m : remap) {
    if (m >= 0) m = static_cast<int32_t>(kept++);
  }
  return kept;
}

SparseTarget RemapTarget(const SparseTarget& t, std::span<const int32_t> remap) {
  SparseTarget out;
  for (size_t k = 0; k < t.indices.size(); ++k) {
    const int32_t v = remap[t.indices[k]];
    if (v < 0) continue;  // Ranks keep the order, so indices stay ascending.
    out.indices.push_back(static_cast<uint32_t>(v));
    for (int c = 0; c < 3; ++c) {
      out.position_deltas.push_back(t.position_deltas[3 * k + c]);
      if (!t.normal_deltas.empty()) out.normal_deltas.push_back(t.normal_deltas[3 * k + c]);
      if (!t.tangent_deltas.empty()) out.tangent_deltas.push_back(t.tangent_deltas[3 * k + c]);
    }
  }
  for (size_t k = 0; k < t.texcoord_indices.size(); ++k) {
    const int32_t v = remap[t.texcoord_indices[k]];
    if (v < 0) continue;
    out.texcoord_indices.push_back(static_cast<uint32_t>(v));
    out.texcoord_deltas.insert(out.texcoord_deltas.end(),
                               {t.texcoord_deltas[2 * k], t.texcoord_deltas[2 * k + 1]});
  }
  FinalizeTarget(out);
  return out;
}

namespace {

// Copies of one source vertex (Primitive::source_vertices) see every face of every copy, so their
// recomputed normals agree and a UV seam does not show in the shading.
void GroupAdjacencyBySource(Primitive& p) {
  const size_t n = p.vertex_count();
  // Each vertex's group: the rank of its source number among the distinct ones.
  std::vector<uint32_t> order(n), group(n);
  for (uint32_t v = 0; v < n; ++v) order[v] = v;
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    return p.source_vertices[a] < p.source_vertices[b];
  });
  uint32_t groups = 0;
  for (size_t k = 0; k < n; ++k) {
    if (k > 0 && p.source_vertices[order[k]] != p.source_vertices[order[k - 1]]) ++groups;
    group[order[k]] = groups;
  }
  // A group's faces: those of all its copies, each once.
  std::vector<std::vector<uint32_t>> faces_of(n == 0 ? 0 : groups + 1);
  for (uint32_t v = 0; v < n; ++v) {
    std::vector<uint32_t>& f = faces_of[group[v]];
    f.insert(f.end(), p.vertex_faces.begin() + p.vertex_face_offsets[v],
             p.vertex_faces.begin() + p.vertex_face_offsets[v + 1]);
  }
  for (std::vector<uint32_t>& f : faces_of) {
    std::sort(f.begin(), f.end());
    f.erase(std::unique(f.begin(), f.end()), f.end());
  }
  std::vector<uint32_t> offsets(n + 1, 0), faces;
  for (uint32_t v = 0; v < n; ++v) {
    offsets[v] = static_cast<uint32_t>(faces.size());
    faces.insert(faces.end(), faces_of[group[v]].begin(), faces_of[group[v]].end());
  }
  offsets[n] = static_cast<uint32_t>(faces.size());
  p.vertex_faces = std::move(faces);
  p.vertex_face_offsets = std::move(offsets);
}

}  // namespace

void FinalizePrimitive(Primitive& p) {
  const size_t n = p.vertex_count();
  const size_t faces = p.triangle_count();
  const bool grouped =
      p.source_vertices.size() == n && n > 0 && p.mode == PrimitiveMode::kTriangles;
  // Vertex -> face adjacency, CSR.
  p.vertex_face_offsets.assign(n + 1, 0);
  for (size_t f = 0; f < faces * 3; ++f) p.vertex_face_offsets[p.indices[f] + 1]++;
  for (size_t v = 0; v < n; ++v) p.vertex_face_offsets[v + 1] += p.vertex_face_offsets[v];
  p.vertex_faces.assign(p.vertex_face_offsets[n], 0);
  std::vector<uint32_t> fill(p.vertex_face_offsets.begin(), p.vertex_face_offsets.end() - 1);
  for (size_t f = 0; f < faces; ++f) {
    for (int c = 0; c < 3; ++c) {
      const uint32_t v = p.indices[3 * f + c];
      // A degenerate face naming a vertex twice is listed once for it.
      const uint32_t first = p.vertex_face_offsets[v];
      if (fill[v] > first && p.vertex_faces[fill[v] - 1] == f) continue;
      p.vertex_faces[fill[v]++] = static_cast<uint32_t>(f);
    }
  }
  // Trim the slots that degenerate faces left unused by compacting per vertex.
  {
    std::vector<uint32_t> offsets(n + 1, 0);
    size_t w = 0;
    for (size_t v = 0; v < n; ++v) {
      offsets[v] = static_cast<uint32_t>(w);
      for (uint32_t k = p.vertex_face_offsets[v]; k < fill[v]; ++k) {
        p.vertex_faces[w++] = p.vertex_faces[k];
      }
    }
    offsets[n] = static_cast<uint32_t>(w);
    p.vertex_faces.resize(w);
    p.vertex_face_offsets = std::move(offsets);
  }
  if (grouped) GroupAdjacencyBySource(p);
  p.base_smooth_normals.assign(n * 3, 0.0f);
  if (grouped) {
    // The same sum RecomputeNormalsAround makes, over each vertex's (grouped) faces.
    for (uint32_t v = 0; v < n; ++v) {
      float* o = &p.base_smooth_normals[3 * static_cast<size_t>(v)];
      VertexNormalSum(p, p.positions, v, o);
      const float len2 = o[0] * o[0] + o[1] * o[1] + o[2] * o[2];
      if (len2 > 0.0f && std::isfinite(len2)) {
        const float inv = 1.0f / std::sqrt(len2);
        for (int c = 0; c < 3; ++c) o[c] *= inv;
      } else {
        o[0] = o[1] = 0.0f, o[2] = 1.0f;
      }
    }
  } else if (p.mode == PrimitiveMode::kTriangles) {
    std::span<const uint32_t> tris(p.indices.data(), faces * 3);
    ComputeSmoothNormals(p.positions, tris, p.base_smooth_normals);
  }
  if (p.normals.size() != n * 3) {
    p.normals = p.base_smooth_normals;
    p.source_has_normals = false;
  }
  for (SparseTarget& t : p.targets) FinalizeTarget(t);
}

size_t Rig::vertex_count() const {
  size_t n = 0;
  for (const Primitive& p : primitives) n += p.vertex_count();
  return n;
}

size_t Rig::triangle_count() const {
  size_t n = 0;
  for (const Primitive& p : primitives) n += p.triangle_count();
  return n;
}

int FindShape(const Rig& rig, const std::string& name) {
  for (size_t i = 0; i < rig.shapes.size(); ++i) {
    if (rig.shapes[i].name == name) return static_cast<int>(i);
  }
  for (size_t i = 0; i < rig.shapes.size(); ++i) {
    const auto& a = rig.shapes[i].aliases;
    if (std::find(a.begin(), a.end(), name) != a.end()) return static_cast<int>(i);
  }
  return -1;
}

namespace {

std::string Lower(const std::string& s) {
  std::string r = s;
  for (char& c : r) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return r;
}

size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diag = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

// The name with its left/right marker replaced by a placeholder, and which side it was;
// side 0 when the name has no marker.
struct Sided {
  std::string key;
  int side = 0;  // -1 left, +1 right.
};

Sided SideOf(const std::string& name) {
  struct Marker {
    const char* left;
    const char* right;
    bool suffix;
  };
  static const Marker kMarkers[] = {
      {"_L", "_R", true},  {"_l", "_r", true},      {".L", ".R", true},
      {".l", ".r", true},  {"Left", "Right", true}, {"_left", "_right", true},
      {"l-", "r-", false}, {"L_", "R_", false},     {"left", "right", true},
  };
  auto ends = [](const std::string& s, const std::string& t) {
    return s.size() > t.size() && s.compare(s.size() - t.size(), t.size(), t) == 0;
  };
  auto starts = [](const std::string& s, const std::string& t) {
    return s.size() > t.size() && s.compare(0, t.size(), t) == 0;
  };
  for (const Marker& m : kMarkers) {
    for (int side : {-1, 1}) {
      const std::string tag = side < 0 ? m.left : m.right;
      if (m.suffix && ends(name, tag))
        return {name.substr(0, name.size() - tag.size()) + "\x01" + m.left, side};
      if (!m.suffix && starts(name, tag))
        return {std::string(m.left) + "\x01" + name.substr(tag.size()), side};
    }
  }
  // MakeHuman-style: "l-" / "r-" after a group prefix ("eyes/r-eye-move-in").
  const size_t slash = name.rfind('/');
  if (slash != std::string::npos && slash + 3 < name.size() &&
      (name.compare(slash + 1, 2, "l-") == 0 || name.compare(slash + 1, 2, "r-") == 0)) {
    const int side = name[slash + 1] == 'l' ? -1 : 1;
    return {name.substr(0, slash + 1) + "\x01" + name.substr(slash + 3), side};
  }
  return {};
}

}  // namespace

std::string CounterpartName(const std::string& name) {
  static const std::pair<const char*, const char*> kSuffixes[] = {
      {"_L", "_R"},        {"_l", "_r"},      {".L", ".R"},     {".l", ".r"},
      {"_left", "_right"}, {"Left", "Right"}, {"left", "right"}};
  auto ends = [&](const std::string& t) {
    return name.size() > t.size() && name.compare(name.size() - t.size(), t.size(), t) == 0;
  };
  for (const auto& [l, r] : kSuffixes) {
    if (ends(l)) return name.substr(0, name.size() - std::strlen(l)) + r;
    if (ends(r)) return name.substr(0, name.size() - std::strlen(r)) + l;
  }
  const size_t slash = name.rfind('/');
  const size_t at = slash == std::string::npos ? 0 : slash + 1;
  for (const auto& [l, r] : {std::pair<const char*, const char*>{"l-", "r-"}, {"L_", "R_"}}) {
    if (name.compare(at, 2, l) == 0 && name.size() > at + 2)
      return name.substr(0, at) + r + name.substr(at + 2);
    if (name.compare(at, 2, r) == 0 && name.size() > at + 2)
      return name.substr(0, at) + l + name.substr(at + 2);
  }
  return "";
}

std::string ClosestName(std::string_view name, std::span<const std::string_view> candidates) {
  std::string best;
  size_t best_d = static_cast<size_t>(-1);
  const std::string lname = Lower(std::string(name));
  for (std::string_view c : candidates) {
    const size_t d = EditDistance(lname, Lower(std::string(c)));
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  // Suggest only when it is plausibly a typo: at most a third of the name differs.
  if (best_d > std::max<size_t>(2, name.size() / 3)) return "";
  return best;
}

std::string DidYouMean(std::string_view name, std::span<const std::string_view> candidates) {
  const std::string c = ClosestName(name, candidates);
  return c.empty() ? "" : " (did you mean '" + c + "'?)";
}

std::string ClosestShapeName(const Rig& rig, const std::string& name) {
  std::vector<std::string_view> names;
  names.reserve(rig.shapes.size());
  for (const Shape& s : rig.shapes) names.push_back(s.name);
  return ClosestName(name, names);
}

void DetectSymmetricPartners(Rig& rig) {
  std::vector<Sided> sided(rig.shapes.size());
  for (size_t i = 0; i < rig.shapes.size(); ++i) sided[i] = SideOf(rig.shapes[i].name);
  for (size_t i = 0; i < rig.shapes.size(); ++i) {
    if (sided[i].side != -1 || rig.shapes[i].partner >= 0) continue;
    for (size_t j = 0; j < rig.shapes.size(); ++j) {
      if (sided[j].side == 1 && sided[j].key == sided[i].key && rig.shapes[j].partner < 0) {
        rig.shapes[i].partner = static_cast<int>(j);
        rig.shapes[j].partner = static_cast<int>(i);
        break;
      }
    }
  }
}

void CountMovedVertices(Rig& rig) {
  for (Shape& s : rig.shapes) s.vertices_moved = 0;
  for (const Mesh& m : rig.meshes) {
    for (int pi : m.primitives) {
      const Primitive& p = rig.primitives[pi];
      for (size_t t = 0; t < p.targets.size() && t < m.target_shapes.size(); ++t) {
        // The vertices whose position or UV moves: both lists ascending, counted once.
        const SparseTarget& st = p.targets[t];
        size_t both = 0;
        for (size_t a = 0, b = 0; a < st.indices.size() && b < st.texcoord_indices.size();) {
          if (st.indices[a] == st.texcoord_indices[b])
            ++both, ++a, ++b;
          else if (st.indices[a] < st.texcoord_indices[b])
            ++a;
          else
            ++b;
        }
        rig.shapes[m.target_shapes[t]].vertices_moved +=
            st.indices.size() + st.texcoord_indices.size() - both;
      }
    }
  }
}

std::vector<std::array<float, 16>> NodeWorldMatrices(const Rig& rig) {
  std::vector<std::array<float, 16>> world;
  std::vector<int> order;
  WorldMatricesInto(rig, nullptr, world, order);
  return world;
}

std::vector<std::array<float, 16>> PrimitiveWorldMatrices(const Rig& rig) {
  const std::array<float, 16> identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  std::vector<std::array<float, 16>> out(rig.primitives.size(), identity);
  const auto world = NodeWorldMatrices(rig);
  std::vector<uint8_t> placed(rig.meshes.size(), 0);
  for (size_t i = 0; i < rig.nodes.size(); ++i) {
    const int m = rig.nodes[i].mesh;
    if (m < 0 || placed[m]) continue;
    placed[m] = 1;
    for (int p : rig.meshes[m].primitives) out[p] = world[i];
  }
  return out;
}

void WorldToMeshSpace(const Rig& rig, std::span<std::vector<float>> positions) {
  const auto world = PrimitiveWorldMatrices(rig);
  for (size_t p = 0; p < std::min(positions.size(), world.size()); ++p) {
    const Eigen::Matrix4d inv =
        Eigen::Map<const Eigen::Matrix4f>(world[p].data()).cast<double>().inverse();
    std::vector<float>& xyz = positions[p];
    for (size_t v = 0; v + 2 < xyz.size(); v += 3) {
      const Eigen::Vector4d q = inv * Eigen::Vector4d(xyz[v], xyz[v + 1], xyz[v + 2], 1.0);
      for (int c = 0; c < 3; ++c) xyz[v + c] = static_cast<float>(q[c]);
    }
  }
}

bool RepairUtf8(std::string& s) {
  const size_t n = s.size();
  auto valid = [&](size_t i) {
    char32_t cp;
    return DecodeUtf8(s, i, cp);
  };
  size_t i = 0;
  while (i < n) {
    const size_t len = valid(i);
    if (len == 0) break;
    i += len;
  }
  if (i == n) return false;
  std::string out(s, 0, i);
  while (i < n) {
    const size_t len = valid(i);
    if (len == 0) {
      out += "\xEF\xBF\xBD";
      ++i;
    } else {
      out.append(s, i, len);
      i += len;
    }
  }
  s = std::move(out);
  return true;
}

void RepairNames(Rig& rig) {
  size_t repaired = 0;
  auto fix = [&repaired](std::initializer_list<std::string*> texts) {
    for (std::string* s : texts) repaired += RepairUtf8(*s);
  };
  fix({&rig.name, &rig.credit});
  for (Mesh& m : rig.meshes) fix({&m.name});
  for (Shape& shape : rig.shapes) {
    fix({&shape.name, &shape.group});
    for (std::string& a : shape.aliases) fix({&a});
  }
  for (Control& c : rig.controls) fix({&c.name, &c.group});
  for (Node& node : rig.nodes) fix({&node.name});
  for (Material& m : rig.materials) fix({&m.name, &m.alpha_mode});
  for (Image& image : rig.images) fix({&image.name, &image.mime_type});
  for (Skin& skin : rig.skins) fix({&skin.name});
  for (AnimationInfo& a : rig.animations) fix({&a.name});
  for (Warning& w : rig.load_warnings) fix({&w.code, &w.message, &w.shape});
  if (repaired > 0) {
    rig.load_warnings.push_back(
        CountWarning("names_repaired", repaired,
                     "name(s) in the file were not valid UTF-8; the bytes that were not "
                     "were replaced with U+FFFD"));
  }
}

namespace {

// One morph target of a primitive of `n` vertices: its deltas' counts, its vertices ascending and
// within the primitive, its UV deltas only where the primitive has UVs. `at` names it in errors.
Status ValidateTarget(const SparseTarget& st, size_t n, bool has_uvs, const std::string& at) {
  const size_t k = st.indices.size();
  if (st.position_deltas.size() != 3 * k ||
      (!st.normal_deltas.empty() && st.normal_deltas.size() != 3 * k) ||
      (!st.tangent_deltas.empty() && st.tangent_deltas.size() != 3 * k)) {
    return InvalidArgument(at + " delta count mismatch");
  }
  for (size_t j = 0; j < k; ++j) {
    if (st.indices[j] >= n || (j > 0 && st.indices[j] <= st.indices[j - 1])) {
      return InvalidArgument(at + " has a bad vertex index");
    }
  }
  const size_t u = st.texcoord_indices.size();
  if (st.texcoord_deltas.size() != 2 * u || (u && !has_uvs)) {
    return InvalidArgument(at + " has UV deltas that do not match its UVs");
  }
  for (size_t j = 0; j < u; ++j) {
    if (st.texcoord_indices[j] >= n ||
        (j > 0 && st.texcoord_indices[j] <= st.texcoord_indices[j - 1])) {
      return InvalidArgument(at + " has a bad UV vertex index");
    }
  }
  return Status::Ok();
}

}  // namespace

Status ValidateRig(const Rig& rig) {
  const size_t shapes = rig.shapes.size();
  for (const InBetweens& ib : rig.inbetweens) {
    if (ib.slider >= shapes || !std::isfinite(ib.full) || ib.full == 0.0f)
      return InvalidArgument("in-betweens: bad slider");
    for (size_t k = 0; k < ib.keys.size(); ++k) {
      const auto& [w, s] = ib.keys[k];
      if (s >= shapes || !std::isfinite(w) || w == 0.0f || w == ib.full ||
          (k && !(w > ib.keys[k - 1].first))) {
        return InvalidArgument("in-betweens of '" + rig.shapes[ib.slider].name +
                               "': keys must be distinct non-zero weights, ascending");
      }
    }
  }
  for (const Flip& f : rig.flips) {
    if (f.shape >= shapes) return InvalidArgument("flip morph: bad shape");
    for (const auto& [s, w] : f.entries) {
      if (s >= shapes || !std::isfinite(w))
        return InvalidArgument("flip morph '" + rig.shapes[f.shape].name +
                               "': an entry names no shape or has a weight that is not finite");
    }
  }
  for (size_t pi = 0; pi < rig.primitives.size(); ++pi) {
    const Primitive& p = rig.primitives[pi];
    const size_t n = p.vertex_count();
    const std::string where = "primitive " + std::to_string(pi) + ": ";
    if (p.positions.size() % 3 != 0) return InvalidArgument(where + "positions not xyz");
    if (p.mesh < 0 || static_cast<size_t>(p.mesh) >= rig.meshes.size()) {
      return InvalidArgument(where + "mesh index out of range");
    }
    if (p.normals.size() != 3 * n)
      return InvalidArgument(where + "normal count differs from vertex count");
    if (!p.tangents.empty() && p.tangents.size() != 4 * n)
      return InvalidArgument(where + "tangent count differs from vertex count");
    if (!p.texcoords.empty() && p.texcoords.size() != 2 * n)
      return InvalidArgument(where + "texcoord count differs from vertex count");
    if (!p.colors.empty() && p.colors.size() != 4 * n)
      return InvalidArgument(where + "color count differs from vertex count");
    if (!p.source_vertices.empty() && p.source_vertices.size() != n)
      return InvalidArgument(where +
                             "source vertex count (_SOURCE_VERTEX) differs from vertex count");
    for (uint32_t s : p.source_vertices) {
      if (s >= Primitive::kMaxSourceVertex)
        return InvalidArgument(where + "source vertex " + std::to_string(s) + " is beyond " +
                               std::to_string(Primitive::kMaxSourceVertex));
    }
    for (uint32_t i : p.indices) {
      if (i >= n) {
        return InvalidArgument(where + "index " + std::to_string(i) + " beyond vertex count " +
                               std::to_string(n));
      }
    }
    if (p.mode == PrimitiveMode::kTriangles && p.indices.size() % 3 != 0) {
      return InvalidArgument(where + "triangle index count not a multiple of 3");
    }
    if (p.material >= static_cast<int>(rig.materials.size()))
      return InvalidArgument(where + "material out of range");
    if (p.targets.size() != rig.meshes[p.mesh].target_shapes.size()) {
      return InvalidArgument(where + "target count differs from its mesh's");
    }
    for (size_t t = 0; t < p.targets.size(); ++t) {
      const std::string at = where + "target " + std::to_string(t);
      if (Status s = ValidateTarget(p.targets[t], n, !p.texcoords.empty(), at); !s.ok()) return s;
    }
  }
  for (const Mesh& m : rig.meshes) {
    for (uint32_t s : m.target_shapes) {
      if (s >= shapes) return InvalidArgument("mesh target maps to a missing shape");
    }
    for (int p : m.primitives) {
      if (p < 0 || static_cast<size_t>(p) >= rig.primitives.size())
        return InvalidArgument("mesh primitive out of range");
    }
  }
  for (const Shape& s : rig.shapes) {
    if (s.partner >= static_cast<int>(shapes)) return InvalidArgument("shape partner out of range");
  }
  for (size_t i = 0; i < rig.nodes.size(); ++i) {
    const Node& node = rig.nodes[i];
    if (node.mesh >= static_cast<int>(rig.meshes.size()))
      return InvalidArgument("node mesh out of range");
    if (node.parent >= static_cast<int>(rig.nodes.size()))
      return InvalidArgument("node parent out of range");
    for (int c : node.children) {
      if (c < 0 || static_cast<size_t>(c) >= rig.nodes.size() ||
          rig.nodes[c].parent != static_cast<int>(i)) {
        return InvalidArgument("node " + std::to_string(i) + " has an invalid child");
      }
    }
  }
  for (int r : rig.scene_roots) {
    if (r < 0 || static_cast<size_t>(r) >= rig.nodes.size())
      return InvalidArgument("scene root out of range");
  }
  for (const Material& m : rig.materials) {
    for (int image : {m.base_color_image, m.metallic_roughness_image, m.normal_image,
                      m.occlusion_image, m.emissive_image}) {
      if (image < -1 || image >= static_cast<int>(rig.images.size()))
        return InvalidArgument("material image out of range");
    }
  }
  return Status::Ok();
}

double RigDiagonal(const Rig& rig) {
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (const Primitive& p : rig.primitives) {
    for (size_t i = 0; i < p.positions.size(); ++i) {
      lo[i % 3] = std::min(lo[i % 3], static_cast<double>(p.positions[i]));
      hi[i % 3] = std::max(hi[i % 3], static_cast<double>(p.positions[i]));
    }
  }
  if (lo[0] > hi[0]) return 0.0;
  return std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                   (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

}  // namespace engine
}  // namespace facespace
