// Shared by the exporters' files (text.cpp, glb.cpp, export.cpp). Private to formats.
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "facespace/formats/io.h"

namespace facespace::formats::writers {

// The whole JSON, OBJ and f32 bodies (ExportMesh's).
std::string ExportJson(const Rig& rig, const BlendedRig& blended, std::span<const Warning> warnings,
                       bool mesh_space);
std::string ExportObj(const Rig& rig, const BlendedRig& blended, std::span<const Warning> warnings,
                      bool mesh_space);
std::string ExportF32(const BlendedRig& blended, bool mesh_space);
Result<std::string> ExportGlb(const Rig& rig, const BlendedRig& blended,
                              std::span<const float> weights, std::span<const Warning> warnings,
                              const ExportOptions& options);

// VRM 1.0 (vrm.cpp) and 0.x (vrm0.cpp): ExportGlb's keep_targets glb at rest with the VRM's
// members; InvalidArgument naming "/format" when the rig has no humanoid skeleton or no licence
// URL.
Result<std::string> ExportVrm(const Rig& rig, const BlendedRig& blended,
                              std::span<const float> weights, std::span<const Warning> warnings,
                              const ExportOptions& options);
Result<std::string> ExportVrm0(const Rig& rig, const BlendedRig& blended,
                               std::span<const float> weights, std::span<const Warning> warnings,
                               const ExportOptions& options);

// A primitive's node transform, or the identity in mesh space.
const std::array<float, 16>& Placement(const BlendedPrimitive& b, bool mesh_space);

// One primitive's placed positions into `at` and its placed normals into `normals_at` (text.cpp
// says more): ExportF32's and F32Blender's placement, so both write the same bits.
void WritePlaced(std::span<const float> positions, std::span<const float> normals,
                 const std::array<float, 16>& m, char* at, char* normals_at,
                 const uint64_t* unit_first = nullptr);

// An accessor's min and max: per component, over `count` elements of `comps` floats.
void FloatBounds(std::span<const float> values, int comps, size_t count, std::vector<double>& lo,
                 std::vector<double>& hi);
// glb's asset.extras: the caller's extras, the warnings and the non-zero weights by shape name.
nlohmann::json AssetExtras(const Rig& rig, std::span<const float> weights,
                           std::span<const Warning> warnings);
// What tinygltf writes for JSON that went through tinygltf's Value: integers as int, empty arrays
// and objects as null, nulls left out. False when nothing is written.
bool AsTinygltfWrites(const nlohmann::json& j, nlohmann::json& out);

// Node i's local matrix under the evaluated pose (its world matrix relative to its parent's).
std::array<double, 16> PosedLocalMatrix(const Rig& rig, const BlendedRig& blended, size_t i);

}  // namespace facespace::formats::writers
