// Shared by the glTF importer's files (and its tests). Private to formats.
#pragma once

#include <tiny_gltf.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace::formats {

// A little-endian u32 (glb headers, index buffers).
inline uint32_t ReadU32(const unsigned char* p) {
  uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}
constexpr size_t kMaxElements = size_t{1} << 28;  // Per accessor; far beyond any real rig.

// Whether the JSON array `key` of `j` holds the string `value`.
bool ListHas(const nlohmann::json& j, const char* key, const std::string& value);

// Refuses buffers and images that point outside the file (anything but a data: URI).
Status CheckEmbedded(const nlohmann::json& j);

// Refuses an image whose bufferView runs past its buffer (tinygltf hands the image loader bytes
// beyond the buffer's end for one: a heap overflow the fuzzer found).
Status CheckImageViews(const nlohmann::json& j);

// Splits a GLB into its JSON text and binary chunk, checking every length.
Status SplitGlb(std::span<const unsigned char> bytes, std::string& json_text,
                std::span<const unsigned char>& bin);

// The scene's parts as the rig's (gltf_scene.cpp), in this order around the meshes
// (gltf_import.cpp). PNG and JPEG images kept (others dropped, warned): the rig's image of each
// glTF image, or -1.
std::vector<int> ConvertImages(const tinygltf::Model& model, Rig& rig);
// Each material's base colour texture transform (KHR_texture_transform), applied to the UVs of the
// primitives that use it: (its TEXCOORD set, the affine uv map), -1 without one.
using UvTransforms = std::vector<std::pair<int, std::array<float, 6>>>;
UvTransforms ConvertMaterials(const tinygltf::Model& model, const std::vector<int>& image_map,
                              Rig& rig);
Status ConvertNodes(const tinygltf::Model& model, Rig& rig);  // Names, meshes, transforms (finite).
Status LinkNodes(const tinygltf::Model& model,
                 Rig& rig);  // Children, no cycle, scene roots, mesh names.
Status ConvertSkins(const tinygltf::Model& model, Rig& rig);  // Skins, and the skin of each mesh.
Status ConvertAnimations(const tinygltf::Model& model,
                         Rig& rig);  // Clips: samplers and channels, checked.

// A VRM's (1.0 VRMC_vrm, or 0.x VRM) expressions (with their material colour and texture transform
// binds), look-at, meta and terms onto the rig (vrm_import.cpp), after CheckVrmExtensions; nothing
// when the model has neither.
Status ApplyVrm(const tinygltf::Model& model, Rig& rig);
// Every index and member type of the VRM extensions (VRMC_vrm or VRM, VRMC_springBone,
// VRMC_node_constraint) checked against the model (vrm_checks.cpp): InvalidArgument "invalid-vrm"
// naming the first bad member.
Status CheckVrmExtensions(const tinygltf::Model& model);
// A tinygltf value as JSON (32 levels at most; deeper is null).
nlohmann::json VrmJson(const tinygltf::Value& v);

// A GLB of a JSON text and a binary chunk (none when empty), each padded to 4 bytes.
std::vector<unsigned char> MakeGlb(const std::string& json_text,
                                   std::span<const unsigned char> bin);

// Rewrites a GLB that uses EXT_meshopt_compression into a plain one (meshopt.cpp): decoded views
// are appended to the binary chunk and the fallback buffers are removed. Other files are returned
// unchanged (out empty).
Status DecodeMeshoptGlb(std::span<const unsigned char> bytes, std::vector<unsigned char>& out);

// Bytes of one component of a glTF componentType (5120-5126), 0 for an unknown type.
int ComponentSize(int component_type);

// Reads any accessor (float, normalized or plain integers, sparse or not) as floats,
// `components` per element, checking every offset against its buffer.
Status ReadAccessor(const tinygltf::Model& m, int index, std::vector<float>& out, int& components,
                    const std::string& what);

// Reads an unsigned integer scalar accessor.
Status ReadIndices(const tinygltf::Model& m, int index, std::vector<uint32_t>& out,
                   const std::string& what);

}  // namespace facespace::formats
