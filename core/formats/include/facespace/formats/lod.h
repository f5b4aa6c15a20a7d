// Level of detail: a simplified rig (meshoptimizer) whose vertices are a subset of the full
// rig's, so its shapes stay consistent: every LOD vertex blends to exactly the full rig's
// position for that vertex, at any weights.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace::formats {

constexpr int kMaxLod = 4;

// What a level of detail may be, said the same by every parser: "an integer level of detail 0..4
// (0: full)".
inline std::string LodExpected() {
  return "an integer level of detail 0.." + std::to_string(kMaxLod) + " (0: full)";
}

// A level of detail as a query or a flag writes it ("0" .. "4"); false for anything else.
inline bool ParseLod(std::string_view text, int* lod) {
  if (text.size() != 1 || text[0] < '0' || text[0] - '0' > kMaxLod) return false;
  *lod = text[0] - '0';
  return true;
}

struct LodReport {
  size_t triangles_before = 0, triangles_after = 0;
  size_t vertices_before = 0, vertices_after = 0;
  float error =
      0;  // meshoptimizer's relative error of the simplification (largest over primitives).
  std::vector<std::vector<uint32_t>>
      source_vertex;  // Per primitive, per LOD vertex: its vertex in the full rig.
};

// Level 0 is the rig itself; level L aims at 1/2^L of the triangles of each triangle
// primitive (open borders kept). Vertices no triangle uses any more are dropped, with
// their attributes, skin influences and shape deltas.
Result<Rig> MakeLod(const Rig& rig, int level, LodReport* report = nullptr);

}  // namespace facespace::formats
