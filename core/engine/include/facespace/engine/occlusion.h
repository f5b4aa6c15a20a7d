// Ambient and directional occlusion of a triangle mesh, baked once per rig (and level of detail) so
// a draw costs nothing more: how much of the sky each vertex sees, and from which side. A renderer
// darkens ambient light by the first and each light by the second (a soft shadow: a nose shades its
// cheek, lips the inner mouth, the chin the neck), for any light and camera.
//
// The bake renders depth maps of the whole mesh from `directions` directions spread evenly over the
// sphere (orthographic, `resolution` pixels a side) and looks up each vertex in each: a vertex sees
// a direction when nothing stands nearer to it along that direction. Cost: directions x (triangles
// + vertices + resolution^2), bounded by the settings (a 50k-vertex rig: about a second).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace facespace {
inline namespace engine {

struct Rig;
struct BlendedRig;

struct OcclusionSettings {
  int directions = 96;
  int resolution = 192;
};

// Per vertex, kOcclusionFloats floats: [0] the cosine-weighted share of the hemisphere around the
// normal that sees the sky (1 open, 0 enclosed); [1..3] `b`, 4 x the mean over the sphere of the
// visible directions (zero below the horizon), in the normal's frame (OcclusionFrame: x, y tangent,
// z the normal). An open vertex has b = (0, 0, 1). A light from direction l (unit, same frame) then
// reaches the vertex by LightVisibility's ratio.
inline constexpr size_t kOcclusionFloats = 4;
inline constexpr std::array<float, kOcclusionFloats> kOpenOcclusion{1.0f, 0.0f, 0.0f, 1.0f};

// `positions` (xyz per vertex) and `normals` (unit, xyz per vertex) in one space, `triangles` (3
// vertex indices each, all < vertex count) over them; `out` holds kOcclusionFloats per vertex. A
// vertex with no usable normal, or a mesh with no triangles, is open.
void BakeOcclusion(std::span<const float> positions, std::span<const float> normals,
                   std::span<const uint32_t> triangles, const OcclusionSettings& settings,
                   std::span<float> out);

// Every primitive of `rig` baked together at `rest` (the rig blended at its neutral weights,
// unposed), in the scene's space as a renderer places them: per primitive, kOcclusionFloats per
// vertex (empty for one that is not triangles). Blended (alpha BLEND) materials receive but do not
// occlude: an overlay floating over the skin (blush, marks) must not darken it.
using RigOcclusion = std::vector<std::vector<float>>;
RigOcclusion BakeRigOcclusion(const Rig& rig, const BlendedRig& rest,
                              const OcclusionSettings& settings);

// The tangent frame the bake stores `b` in: t and s orthogonal to the unit normal n (Duff et al.
// 2017, "Building an Orthonormal Basis, Revisited"); the shader builds the same from the drawn
// normal, so a vertex's occlusion turns with it (skinning, morphs).
void OcclusionFrame(const float n[3], float t[3], float s[3]);

// How much of a light from unit direction `l` reaches a vertex of ambient occlusion `ao` and vector
// `b` (turned out of the normal's frame: b.x t + b.y s + b.z n) with unit normal `n`: the linear
// (spherical-harmonic L1) estimate of the visible directions at l over the same estimate for an
// open vertex, in [0, 1]; 1 for an open vertex. The shader computes the same
// (render/offscreen/src/gl_context.cpp).
float LightVisibility(float ao, const float b[3], const float n[3], const float l[3]);

}  // namespace engine
}  // namespace facespace
