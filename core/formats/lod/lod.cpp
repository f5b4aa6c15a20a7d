#include "facespace/formats/lod.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>

namespace facespace::formats {

namespace {

template <typename T>
std::vector<T> Compact(const std::vector<T>& in, const std::vector<int32_t>& remap,
                       size_t per_vertex, size_t kept) {
  if (in.empty()) return {};
  std::vector<T> out(kept * per_vertex);
  for (size_t v = 0; v < remap.size(); ++v) {
    if (remap[v] < 0) continue;
    std::copy_n(in.begin() + v * per_vertex, per_vertex,
                out.begin() + static_cast<size_t>(remap[v]) * per_vertex);
  }
  return out;
}

}  // namespace

Result<Rig> MakeLod(const Rig& rig, int level, LodReport* report) {
  if (level < 0 || level > kMaxLod)
    return InvalidArgument("lod must be 0.." + std::to_string(kMaxLod));
  LodReport r;
  r.triangles_before = rig.triangle_count();
  r.vertices_before = rig.vertex_count();
  Rig out = rig;
  r.source_vertex.resize(rig.primitives.size());
  for (size_t pi = 0; pi < rig.primitives.size(); ++pi) {
    r.source_vertex[pi].resize(rig.primitives[pi].vertex_count());
    for (uint32_t v = 0; v < r.source_vertex[pi].size(); ++v) r.source_vertex[pi][v] = v;
  }
  if (level > 0) {
    const double ratio = std::ldexp(1.0, -level);
    for (size_t pi = 0; pi < out.primitives.size(); ++pi) {
      Primitive& p = out.primitives[pi];
      if (p.mode != PrimitiveMode::kTriangles || p.indices.size() < 3 * 8) continue;
      const size_t target =
          std::max<size_t>(3, static_cast<size_t>(std::llround(p.indices.size() / 3 * ratio)) * 3);
      std::vector<uint32_t> simplified(p.indices.size());
      float error = 0;
      const size_t count = meshopt_simplify(simplified.data(), p.indices.data(), p.indices.size(),
                                            p.positions.data(), p.vertex_count(), 3 * sizeof(float),
                                            target, 0.05f, meshopt_SimplifyLockBorder, &error);
      simplified.resize(count);
      r.error = std::max(r.error, error);
      // Keep the used vertices in their original order.
      std::vector<int32_t> remap(p.vertex_count(), -1);
      for (uint32_t v : simplified) remap[v] = 0;
      const size_t kept = RankKeptVertices(remap);
      for (uint32_t& v : simplified) v = static_cast<uint32_t>(remap[v]);
      r.source_vertex[pi].resize(kept);
      for (uint32_t v = 0; v < remap.size(); ++v) {
        if (remap[v] >= 0) r.source_vertex[pi][static_cast<size_t>(remap[v])] = v;
      }
      Primitive q;
      q.mesh = p.mesh;
      q.index_in_mesh = p.index_in_mesh;
      q.mode = p.mode;
      q.material = p.material;
      q.source_has_normals = p.source_has_normals;
      q.positions = Compact(p.positions, remap, 3, kept);
      q.normals = Compact(p.normals, remap, 3, kept);
      q.tangents = Compact(p.tangents, remap, 4, kept);
      q.texcoords = Compact(p.texcoords, remap, 2, kept);
      q.colors = Compact(p.colors, remap, 4, kept);
      q.source_vertices = Compact(p.source_vertices, remap, 1, kept);
      q.influences = p.influences;
      q.joints = Compact(p.joints, remap, p.influences, kept);
      q.joint_weights = Compact(p.joint_weights, remap, p.influences, kept);
      q.indices = std::move(simplified);
      for (const SparseTarget& t : p.targets) q.targets.push_back(RemapTarget(t, remap));
      FinalizePrimitive(q);
      p = std::move(q);
    }
    CountMovedVertices(out);
  }
  r.triangles_after = out.triangle_count();
  r.vertices_after = out.vertex_count();
  if (Status s = ValidateRig(out); !s.ok()) return Internal("lod: " + s.message);
  if (report) *report = std::move(r);
  return out;
}

}  // namespace facespace::formats
