// What the FBX and COLLADA readers share: their files index attributes per polygon corner, so a
// mesh is split into vertices that each remember the control point ("position index") they came
// from; shapes and skin weights, given per control point, follow through that map.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "facespace/core/rig.h"

namespace facespace {

// One joint influence: (joint index in the skin, weight).
using Influences = std::vector<std::pair<uint32_t, float>>;

// Sets `prim`'s skinning from per-control-point influences: as many slots per vertex as the most
// any point has, weights normalised to sum 1. Every point must have at least one influence.
inline void SetInfluences(Primitive& prim, const std::vector<uint32_t>& point_of_vertex, const std::vector<Influences>& per_point) {
  size_t most = 1;
  for (const Influences& inf : per_point) most = std::max(most, inf.size());
  prim.influences = most;
  prim.joints.assign(point_of_vertex.size() * most, 0);
  prim.joint_weights.assign(point_of_vertex.size() * most, 0.0f);
  for (size_t v = 0; v < point_of_vertex.size(); ++v) {
    const Influences& inf = per_point[point_of_vertex[v]];
    float total = 0.0f;
    for (const auto& [j, w] : inf) total += w;
    for (size_t i = 0; i < inf.size(); ++i) {
      prim.joints[v * most + i] = static_cast<uint16_t>(inf[i].first);
      prim.joint_weights[v * most + i] = inf[i].second / total;
    }
  }
}

}  // namespace facespace
