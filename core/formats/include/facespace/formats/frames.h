// Frames a home network carries (issue 64): a live face as 16-bit positions on a grid, each frame
// only what moved since the one before, packed by meshoptimizer's vertex codec where it is smaller.
// A FaceCap frame is 104,832 bytes as float32; dragging a slider moves a part of the face a little,
// and the deltas of neighbouring vertices are alike, which is what the codec's byte deltas pack.
//
// A frame's block (little-endian): u32 vertex count, u32 codec (FrameCodec), f32 step, f32 origin
// x, y, z; then the vertices, four int16 each (x, y, z, 0): the grid coordinates themselves in a
// keyframe, what to add to the ones held in a delta; raw, or meshopt_encodeVertexBuffer's bytes
// (version 0, vertex size 8). A position is origin + step x q; the grid's rounding is at most
// step x sqrt(3) / 2 a vertex, and deltas are exact integers, so the error never grows.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/engine/status.h"

namespace facespace::formats {

enum class FrameCodec : uint32_t { kRaw = 0, kMeshopt = 1 };

struct FrameGrid {
  std::array<float, 3> origin{0, 0, 0};  // The box's centre.
  float step = 1;
};

inline constexpr size_t kFrameBlockBytes = 24;

// A grid for `positions` (xyz a vertex): its box's centre, a step of `error` x the box's diagonal.
FrameGrid GridOf(std::span<const float> positions, float error);

class DeltaFrames {
 public:
  // `error`: the grid's step as a share of the face's diagonal. The next frame is a keyframe.
  explicit DeltaFrames(float error = 1e-4f) : error_(error) {}
  void Keyframe() { key_ = true; }
  // Appends the frame of `positions` (xyz a vertex) to `out`: its block and vertices. A keyframe
  // when one was asked for, at the first frame, when the vertex count changes, or when a vertex
  // leaves what the grid holds (then on a new grid). Returns whether it was one.
  bool Encode(std::span<const float> positions, std::string& out);
  const FrameGrid& grid() const { return grid_; }

 private:
  float error_;
  bool key_ = true;
  FrameGrid grid_;
  std::vector<int16_t> held_, next_, send_;  // The client's, this frame's, the frame's vertices.
  std::vector<unsigned char> packed_;
};

// The client's side (tests; a C++ client): a frame's bytes (block and vertices) applied to the grid
// coordinates `held` (4 a vertex), and the positions they make into `positions`. Errors: a block
// cut short, a count or codec that does not fit the bytes, a delta before any keyframe.
Status ApplyFrame(std::string_view bytes, bool keyframe, std::vector<int16_t>& held,
                  std::vector<float>& positions);

}  // namespace facespace::formats
