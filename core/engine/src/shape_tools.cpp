#include "facespace/engine/shape_tools.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "facespace/engine/transform.h"

namespace facespace {
inline namespace engine {

namespace {

// Smooth 0..1 weight of a mask at position p (vertex `global` over all primitives).
float MaskWeight(const ShapeMask& m, float center, const float* p) {
  if (m.side == 0) return 1.0f;
  const float x = (p[m.axis] - center) * static_cast<float>(m.side);
  if (m.falloff <= 0.0f) return x > 0.0f ? 1.0f : 0.0f;
  const float t = std::clamp(x / m.falloff + 0.5f, 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);  // Smoothstep across [-falloff/2, +falloff/2].
}

// The middle of a mesh's bounding box along an axis (mesh space).
float MidPlane(const Rig& rig, const Mesh& mesh, int axis) {
  float lo = 1e30f, hi = -1e30f;
  for (int pi : mesh.primitives) {
    const std::vector<float>& pos = rig.primitives[pi].positions;
    for (size_t i = static_cast<size_t>(axis); i < pos.size(); i += 3) {
      lo = std::min(lo, pos[i]);
      hi = std::max(hi, pos[i]);
    }
  }
  return lo <= hi ? 0.5f * (lo + hi) : 0.0f;
}

}  // namespace

std::vector<int32_t> MirrorMap(const Primitive& primitive, int axis, float center,
                               float tolerance) {
  const size_t n = primitive.vertex_count();
  std::vector<int32_t> map(n, -1);
  const float cell = std::max(tolerance, 1e-12f) * 2.0f;
  auto key = [cell](float x, float y, float z) {
    const auto q =
        [cell](float v) {  // Clamped: a far vertex over a tiny cell would not fit in 64 bits.
          const double c = std::floor(static_cast<double>(v) / static_cast<double>(cell));
          return static_cast<int64_t>(std::isfinite(c) ? std::clamp(c, -9.0e18, 9.0e18) : 0.0);
        };
    return (static_cast<uint64_t>(q(x)) * 73856093u) ^ (static_cast<uint64_t>(q(y)) * 19349663u) ^
           (static_cast<uint64_t>(q(z)) * 83492791u);
  };
  std::unordered_multimap<uint64_t, uint32_t> grid;
  grid.reserve(n);
  const float* pos = primitive.positions.data();
  for (uint32_t v = 0; v < n; ++v) grid.emplace(key(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]), v);
  for (uint32_t v = 0; v < n; ++v) {
    float r[3] = {pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]};
    r[axis] = 2.0f * center - r[axis];
    float best = tolerance * tolerance;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          auto range = grid.equal_range(key(r[0] + dx * cell, r[1] + dy * cell, r[2] + dz * cell));
          for (auto it = range.first; it != range.second; ++it) {
            const float* q = pos + 3 * it->second;
            const float d = (q[0] - r[0]) * (q[0] - r[0]) + (q[1] - r[1]) * (q[1] - r[1]) +
                            (q[2] - r[2]) * (q[2] - r[2]);
            if (d <= best) {
              best = d;
              map[v] = static_cast<int32_t>(it->second);
            }
          }
        }
      }
    }
  }
  return map;
}

namespace {

// The shapes the focus follows: those the rig's expressions bind (the face: eyes, brows, mouth; not
// an ear or a skirt a shape also moves) when it has any, else every shape.
std::vector<uint8_t> FocusShapes(const Rig& rig) {
  std::vector<uint8_t> in(rig.shapes.size(), rig.expressions.empty() ? 1 : 0);
  for (const Expression& e : rig.expressions) {
    for (const auto& [shape, weight] : e.binds) {
      if (shape < in.size() && weight != 0.0f) in[shape] = 1;
    }
  }
  return in;
}

// The vertices of `p` some focus shape moves noticeably: over 5% of that shape's largest move.
void MovedVertices(const Rig& rig, const Primitive& p, std::span<const uint8_t> focus,
                   std::vector<uint8_t>& moved) {
  moved.assign(p.vertex_count(), 0);
  const Mesh* mesh = p.mesh >= 0 && static_cast<size_t>(p.mesh) < rig.meshes.size()
                         ? &rig.meshes[static_cast<size_t>(p.mesh)]
                         : nullptr;
  for (size_t ti = 0; ti < p.targets.size(); ++ti) {
    const SparseTarget& t = p.targets[ti];
    const size_t shape =
        mesh && ti < mesh->target_shapes.size() ? mesh->target_shapes[ti] : SIZE_MAX;
    if (shape < focus.size() && !focus[shape]) continue;
    float largest = 0.0f;
    for (size_t k = 0; k < t.indices.size(); ++k) {
      const float* d = &t.position_deltas[3 * k];
      largest = std::max(largest, d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    }
    for (size_t k = 0; k < t.indices.size(); ++k) {
      const float* d = &t.position_deltas[3 * k];
      if (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > 0.0025f * largest) moved[t.indices[k]] = 1;
    }
  }
}

}  // namespace

bool ShapeFocusBox(const Rig& rig, std::array<float, 3>& lo, std::array<float, 3>& hi) {
  const auto world = PrimitiveWorldMatrices(rig);
  const std::vector<uint8_t> focus = FocusShapes(rig);
  std::vector<float> points;
  std::vector<uint8_t> moved;
  for (size_t pi = 0; pi < rig.primitives.size(); ++pi) {
    const Primitive& p = rig.primitives[pi];
    MovedVertices(rig, p, focus, moved);
    const auto& m = world[pi];
    for (size_t v = 0; v < moved.size(); ++v) {
      if (!moved[v]) continue;
      float q[3];
      TransformPoint(m, &p.positions[3 * v], q);
      points.insert(points.end(), q, q + 3);
    }
  }
  const size_t n = points.size() / 3;
  if (n == 0) return false;
  std::vector<float> axis(n);
  for (int a = 0; a < 3; ++a) {
    for (size_t i = 0; i < n; ++i) axis[i] = points[3 * i + a];
    const size_t i_lo = n / 100, i_hi = n - 1 - n / 100;
    std::nth_element(axis.begin(), axis.begin() + i_lo, axis.end());
    lo[a] = axis[i_lo];
    std::nth_element(axis.begin(), axis.begin() + i_hi, axis.end());
    hi[a] = axis[i_hi];
  }
  return true;
}

bool FrameShapesByDefault(const Rig& rig, const std::array<float, 3>& lo,
                          const std::array<float, 3>& hi) {
  const auto world = PrimitiveWorldMatrices(rig);
  std::array<float, 3> all_lo{INFINITY, INFINITY, INFINITY},
      all_hi{-INFINITY, -INFINITY, -INFINITY};
  for (size_t pi = 0; pi < rig.primitives.size(); ++pi) {
    const Primitive& p = rig.primitives[pi];
    for (size_t v = 0; v < p.vertex_count(); ++v) {
      float q[3];
      TransformPoint(world[pi], &p.positions[3 * v], q);
      for (int a = 0; a < 3; ++a) {
        all_lo[a] = std::min(all_lo[a], q[a]);
        all_hi[a] = std::max(all_hi[a], q[a]);
      }
    }
  }
  double focus = 0.0, whole = 0.0;
  for (int a = 0; a < 3; ++a) {
    focus += static_cast<double>(hi[a] - lo[a]) * (hi[a] - lo[a]);
    whole += static_cast<double>(all_hi[a] - all_lo[a]) * (all_hi[a] - all_lo[a]);
  }
  return whole > 0.0 && focus * 9.0 < whole;  // Diagonal under a third.
}

int ShapeFocusJoint(const Rig& rig) {
  std::vector<double> carried(rig.nodes.size(), 0.0);
  const std::vector<uint8_t> focus = FocusShapes(rig);
  std::vector<uint8_t> moved;
  for (const Primitive& p : rig.primitives) {
    const int skin = p.mesh >= 0 && static_cast<size_t>(p.mesh) < rig.meshes.size()
                         ? rig.meshes[static_cast<size_t>(p.mesh)].skin
                         : -1;
    if (skin < 0 || static_cast<size_t>(skin) >= rig.skins.size() || p.influences == 0) continue;
    const std::vector<int>& joints = rig.skins[static_cast<size_t>(skin)].joints;
    MovedVertices(rig, p, focus, moved);
    for (size_t v = 0; v < moved.size(); ++v) {
      if (!moved[v]) continue;
      for (size_t k = 0; k < p.influences; ++k) {
        const size_t j = p.joints[v * p.influences + k];
        const int node = j < joints.size() ? joints[j] : -1;
        if (node >= 0 && static_cast<size_t>(node) < carried.size())
          carried[static_cast<size_t>(node)] += p.joint_weights[v * p.influences + k];
      }
    }
  }
  const auto most = std::max_element(carried.begin(), carried.end());
  return most == carried.end() || *most <= 0.0 ? -1 : static_cast<int>(most - carried.begin());
}

Result<DeriveReport> DeriveShape(Rig& rig, const std::string& name, const std::string& from,
                                 const DeriveOptions& options) {
  const int source = FindShape(rig, from);
  if (source < 0) return InvalidArgument("unknown shape '" + from + "'");
  if (name.empty() || FindShape(rig, name) >= 0)
    return InvalidArgument("shape name '" + name + "' is empty or taken");
  if (options.axis < 0 || options.axis > 2 || options.mask.axis < 0 || options.mask.axis > 2)
    return InvalidArgument("axis must be x, y or z");
  // Mask vertices are numbered as the source numbers them (Primitive::source_vertices: one number
  // for every copy of a vertex split at a UV seam), primitive after primitive.
  std::vector<size_t> first(rig.primitives.size() + 1, 0);
  for (size_t p = 0; p < rig.primitives.size(); ++p) {
    const Primitive& prim = rig.primitives[p];
    const size_t sources =
        prim.source_vertices.empty()
            ? prim.vertex_count()
            : *std::max_element(prim.source_vertices.begin(), prim.source_vertices.end()) +
                  size_t{1};
    first[p + 1] = first[p] + sources;
  }
  std::vector<uint8_t> keep;
  if (options.masked && !options.mask.vertices.empty()) {
    keep.assign(first.back(), 0);
    for (uint32_t v : options.mask.vertices) {
      if (v >= keep.size())
        return InvalidArgument("mask vertex " + std::to_string(v) + " is beyond the rig's " +
                               std::to_string(keep.size()) + " vertices");
      keep[v] = 1;
    }
  }

  DeriveReport report;
  report.shape = static_cast<int>(rig.shapes.size());
  const double size = RigDiagonal(rig);
  const float tolerance = options.tolerance * static_cast<float>(size > 0.0 ? size : 1.0);
  for (Mesh& mesh : rig.meshes) {
    const auto it = std::find(mesh.target_shapes.begin(), mesh.target_shapes.end(),
                              static_cast<uint32_t>(source));
    if (it == mesh.target_shapes.end()) continue;
    const float center = options.auto_center ? MidPlane(rig, mesh, options.axis) : options.center;
    const float mask_center =
        options.mask.auto_center ? MidPlane(rig, mesh, options.mask.axis) : options.mask.center;
    const size_t t = static_cast<size_t>(it - mesh.target_shapes.begin());
    for (int pi : mesh.primitives) {
      Primitive& prim = rig.primitives[pi];
      const SparseTarget& src = prim.targets[t];
      SparseTarget out;
      const size_t n = prim.vertex_count();
      // Dense view of the source deltas by vertex (position, normal, tangent).
      std::vector<int32_t> slot(n, -1);
      for (size_t k = 0; k < src.indices.size(); ++k)
        slot[src.indices[k]] = static_cast<int32_t>(k);
      std::vector<int32_t> mirror;
      if (options.mirror) {
        mirror = MirrorMap(prim, options.axis, center, tolerance);
        for (uint32_t v : src.indices) report.unmatched += mirror[v] < 0;
      }
      const bool has_n = !src.normal_deltas.empty(), has_t = !src.tangent_deltas.empty();
      for (uint32_t v = 0; v < n; ++v) {
        const int32_t from_v = options.mirror ? mirror[v] : static_cast<int32_t>(v);
        if (from_v < 0 || slot[from_v] < 0) continue;
        float w = 1.0f;
        if (options.masked) {
          if (!keep.empty() &&
              !keep[first[pi] + (prim.source_vertices.empty() ? v : prim.source_vertices[v])])
            continue;
          w = MaskWeight(options.mask, mask_center, &prim.positions[3 * v]);
          if (w == 0.0f) continue;
        }
        const size_t k = static_cast<size_t>(slot[from_v]);
        auto push = [&](const std::vector<float>& in, std::vector<float>& dst) {
          for (int c = 0; c < 3; ++c) {
            float d = in[3 * k + c] * w;
            if (options.mirror && c == options.axis) d = -d;
            dst.push_back(d);
          }
        };
        out.indices.push_back(v);
        push(src.position_deltas, out.position_deltas);
        if (has_n) push(src.normal_deltas, out.normal_deltas);
        if (has_t) push(src.tangent_deltas, out.tangent_deltas);
      }
      FinalizeTarget(out);
      report.vertices_moved += out.indices.size();
      prim.targets.push_back(std::move(out));
    }
    mesh.target_shapes.push_back(static_cast<uint32_t>(report.shape));
  }
  Shape shape = rig.shapes[source];
  shape.name = name;
  shape.aliases.clear();
  shape.partner = -1;
  rig.shapes.push_back(std::move(shape));
  CountMovedVertices(rig);
  if (options.mirror && rig.shapes[source].partner < 0) {
    rig.shapes[source].partner = report.shape;
    rig.shapes[report.shape].partner = source;
  }
  return report;
}

}  // namespace engine
}  // namespace facespace
