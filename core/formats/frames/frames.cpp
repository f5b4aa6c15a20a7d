#include "facespace/formats/frames.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace facespace::formats {

namespace {

constexpr size_t kVertexBytes = 8;  // int16 x, y, z and a zero: meshopt's vertex size is 4k.
constexpr int32_t kMax = 32767;

void Put(std::string& out, const void* p, size_t n) { out.append(static_cast<const char*>(p), n); }

// The grid coordinates of `positions` into `q` (4 a vertex); false when one leaves the grid.
bool Quantize(std::span<const float> positions, const FrameGrid& g, std::vector<int16_t>& q) {
  const size_t n = positions.size() / 3;
  q.resize(4 * n);
  const float inv = 1.0f / g.step;
  bool inside = true;
  for (size_t v = 0; v < n; ++v) {
    for (int k = 0; k < 3; ++k) {
      const float c = std::round((positions[3 * v + k] - g.origin[k]) * inv);
      inside = inside && std::abs(c) <= kMax;
      q[4 * v + k] = static_cast<int16_t>(std::clamp(c, -float(kMax), float(kMax)));
    }
    q[4 * v + 3] = 0;
  }
  return inside;
}

}  // namespace

FrameGrid GridOf(std::span<const float> positions, float error) {
  std::array<float, 3> lo{0, 0, 0}, hi{0, 0, 0};
  for (size_t v = 0; v + 2 < positions.size(); v += 3) {
    for (int k = 0; k < 3; ++k) {
      const float c = positions[v + k];
      lo[k] = v ? std::min(lo[k], c) : c;
      hi[k] = v ? std::max(hi[k], c) : c;
    }
  }
  FrameGrid g;
  float diagonal = 0;
  for (int k = 0; k < 3; ++k) {
    g.origin[k] = 0.5f * (lo[k] + hi[k]);
    diagonal += (hi[k] - lo[k]) * (hi[k] - lo[k]);
  }
  g.step = std::max(std::sqrt(diagonal) * error, std::numeric_limits<float>::min());
  return g;
}

bool DeltaFrames::Encode(std::span<const float> positions, std::string& out) {
  const size_t n = positions.size() / 3;
  bool key = key_ || held_.size() != 4 * n;
  if (key) grid_ = GridOf(positions, error_);
  if (!Quantize(positions, grid_, next_)) {  // Left the grid: a new one, and a keyframe on it.
    grid_ = GridOf(positions, error_);
    Quantize(positions, grid_, next_);
    key = true;
  }
  send_.resize(next_.size());
  for (size_t i = 0; i < next_.size(); ++i) {
    const int32_t d = key ? next_[i] : int32_t{next_[i]} - held_[i];
    if (d < -kMax || d > kMax) {  // A jump no int16 holds: the frame whole.
      key_ = true;
      return Encode(positions, out);
    }
    send_[i] = static_cast<int16_t>(d);
  }
  packed_.resize(meshopt_encodeVertexBufferBound(n, kVertexBytes));
  const size_t packed =
      n ? meshopt_encodeVertexBuffer(packed_.data(), packed_.size(), send_.data(), n, kVertexBytes)
        : 0;
  const bool wins = packed > 0 && packed < n * kVertexBytes;
  const uint32_t head[2] = {static_cast<uint32_t>(n),
                            static_cast<uint32_t>(wins ? FrameCodec::kMeshopt : FrameCodec::kRaw)};
  Put(out, head, sizeof(head));
  Put(out, &grid_.step, 4);
  Put(out, grid_.origin.data(), 12);
  if (wins)
    Put(out, packed_.data(), packed);
  else
    Put(out, send_.data(), n * kVertexBytes);
  held_.swap(next_);
  key_ = false;
  return key;
}

Status ApplyFrame(std::string_view bytes, bool keyframe, std::vector<int16_t>& held,
                  std::vector<float>& positions) {
  if (bytes.size() < kFrameBlockBytes) return InvalidArgument("a frame's block is 24 bytes");
  uint32_t head[2];
  FrameGrid g;
  std::memcpy(head, bytes.data(), 8);
  std::memcpy(&g.step, bytes.data() + 8, 4);
  std::memcpy(g.origin.data(), bytes.data() + 12, 12);
  const size_t n = head[0];
  const std::string_view body = bytes.substr(kFrameBlockBytes);
  if (n > (size_t{1} << 26)) return InvalidArgument("too many vertices");
  if (!keyframe && held.size() != 4 * n)
    return InvalidArgument("a delta frame needs the keyframe before it");
  std::vector<int16_t> got(4 * n);
  if (head[1] == uint32_t(FrameCodec::kRaw)) {
    if (body.size() != n * kVertexBytes) return InvalidArgument("raw vertices do not fit");
    std::memcpy(got.data(), body.data(), body.size());
  } else if (head[1] == uint32_t(FrameCodec::kMeshopt)) {
    if (meshopt_decodeVertexBuffer(got.data(), n, kVertexBytes,
                                   reinterpret_cast<const unsigned char*>(body.data()),
                                   body.size()) != 0)
      return InvalidArgument("meshopt's vertex codec refuses the bytes");
  } else {
    return InvalidArgument("an unknown codec");
  }
  if (keyframe) held.assign(4 * n, 0);
  positions.resize(3 * n);
  for (size_t v = 0; v < n; ++v) {
    for (int k = 0; k < 3; ++k) {
      held[4 * v + k] = static_cast<int16_t>(held[4 * v + k] + got[4 * v + k]);
      positions[3 * v + k] = g.origin[k] + g.step * held[4 * v + k];
    }
  }
  return Status::Ok();
}

}  // namespace facespace::formats
