// Animation clips: sampling and blending.
#include "facespace/engine/animation.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "facespace/engine/bezier.h"

namespace facespace {
inline namespace engine {

namespace {

// The keys around `time` and the fraction between them.
void Locate(const std::vector<float>& times, float time, size_t& k0, size_t& k1, float& u,
            float& dt) {
  if (times.size() == 1 || time <= times.front()) {
    k0 = k1 = 0;
    u = 0.0f;
    dt = 0.0f;
    return;
  }
  if (time >= times.back()) {
    k0 = k1 = times.size() - 1;
    u = 0.0f;
    dt = 0.0f;
    return;
  }
  k1 = static_cast<size_t>(std::upper_bound(times.begin(), times.end(), time) - times.begin());
  k0 = k1 - 1;
  dt = times[k1] - times[k0];
  u = dt > 0.0f ? (time - times[k0]) / dt : 0.0f;
}

// Samples a sampler into `out` (components floats).
void Sample(const AnimationSampler& s, float time, bool rotation, float* out) {
  size_t k0, k1;
  float u, dt;
  Locate(s.times, time, k0, k1, u, dt);
  const size_t c = s.components;
  const bool cubic = s.interpolation == Interpolation::kCubicSpline;
  const size_t stride = s.key_stride();
  const float* v0 = &s.values[k0 * stride + s.value_offset()];
  const float* v1 = &s.values[k1 * stride + s.value_offset()];
  if (s.interpolation == Interpolation::kStep || k0 == k1) {
    std::copy(v0, v0 + c, out);
  } else if (s.interpolation == Interpolation::kBezier) {
    const float* seg = &s.values[k0 * stride];
    for (size_t i = 0; i < c; ++i) {
      out[i] = static_cast<float>(BezierYAtX(0.0, seg[c + i], seg[3 * c + i], 1.0, v0[i],
                                             seg[2 * c + i], seg[4 * c + i], seg[5 * c + i], u));
    }
  } else if (!cubic) {
    if (rotation) {
      const std::array<float, 4> q =
          Slerp({v0[0], v0[1], v0[2], v0[3]}, {v1[0], v1[1], v1[2], v1[3]}, u);
      std::copy(q.begin(), q.end(), out);
      return;
    }
    for (size_t i = 0; i < c; ++i) out[i] = v0[i] + u * (v1[i] - v0[i]);
  } else {
    // Hermite with the out-tangent of k0 and the in-tangent of k1, scaled by the key gap.
    const float* b0 = &s.values[k0 * stride + 2 * c];
    const float* a1 = &s.values[k1 * stride];
    const float u2 = u * u, u3 = u2 * u;
    const float h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2,
                h11 = u3 - u2;
    for (size_t i = 0; i < c; ++i)
      out[i] = h00 * v0[i] + h10 * dt * b0[i] + h01 * v1[i] + h11 * dt * a1[i];
  }
  if (rotation) {
    const std::array<float, 4> q = NormalizedQuaternion({out[0], out[1], out[2], out[3]});
    std::copy(q.begin(), q.end(), out);
  }
}

}  // namespace

AnimationSampler LinearSampler(const AnimationSampler& s, float per_second) {
  if (s.interpolation != Interpolation::kBezier || s.times.empty()) return s;
  AnimationSampler out;
  out.components = s.components;
  out.interpolation = Interpolation::kLinear;
  std::vector<float> value(s.components);
  for (size_t k = 0; k < s.times.size(); ++k) {
    const size_t steps =
        k + 1 < s.times.size()
            ? std::max<size_t>(
                  1, static_cast<size_t>(std::ceil((s.times[k + 1] - s.times[k]) * per_second)))
            : 1;
    for (size_t i = 0; i < steps; ++i) {
      const float t = i == 0 ? s.times[k]
                             : s.times[k] + (s.times[k + 1] - s.times[k]) * static_cast<float>(i) /
                                                static_cast<float>(steps);
      Sample(s, t, false, value.data());  // kBezier drives weights.
      out.times.push_back(t);
      out.values.insert(out.values.end(), value.begin(), value.end());
    }
  }
  return out;
}

Status SampleClip(const Rig& rig, int clip, float time, ClipWrap wrap, Pose& pose,
                  std::vector<float>& shape_weights, std::vector<uint8_t>& shape_set) {
  if (clip < 0 || static_cast<size_t>(clip) >= rig.animations.size())
    return InvalidArgument("no animation " + std::to_string(clip));
  if (!std::isfinite(time)) return InvalidArgument("time must be finite");
  const AnimationInfo& a = rig.animations[clip];
  if (wrap == ClipWrap::kLoop && a.duration > 0.0f) {
    time = std::fmod(time, a.duration);
    if (time < 0.0f) time += a.duration;
  }
  shape_weights.resize(rig.shapes.size(), 0.0f);
  shape_set.resize(rig.shapes.size(), 0);
  std::vector<float> value;
  for (const AnimationChannel& ch : a.channel_data) {
    const AnimationSampler& s = a.sampler_data[ch.sampler];
    value.resize(s.components);
    Sample(s, time, ch.path == ChannelPath::kRotation, value.data());
    Transform& t = pose.local[ch.node];
    switch (ch.path) {
      case ChannelPath::kTranslation: std::copy_n(value.begin(), 3, t.translation.begin()); break;
      case ChannelPath::kRotation: std::copy_n(value.begin(), 4, t.rotation.begin()); break;
      case ChannelPath::kScale: std::copy_n(value.begin(), 3, t.scale.begin()); break;
      case ChannelPath::kWeights: {
        const Mesh& mesh = rig.meshes[rig.nodes[ch.node].mesh];
        for (size_t k = 0; k < mesh.target_shapes.size() && k < value.size(); ++k) {
          shape_weights[mesh.target_shapes[k]] = value[k];
          shape_set[mesh.target_shapes[k]] = 1;
        }
        break;
      }
    }
    if (ch.path != ChannelPath::kWeights) pose.from_matrix[ch.node] = 0;
  }
  return Status::Ok();
}

float LayerWeight(const Rig& rig, const ClipLayer& layer) {
  float w = layer.weight;
  if (layer.clip < 0 || static_cast<size_t>(layer.clip) >= rig.animations.size()) return 0.0f;
  const float t = layer.time, duration = rig.animations[layer.clip].duration;
  if (layer.wrap == ClipWrap::kClamp && t < 0.0f) return 0.0f;  // Not started.
  if (layer.fade_in > 0.0f) w *= std::clamp(t / layer.fade_in, 0.0f, 1.0f);
  if (layer.wrap == ClipWrap::kClamp && layer.fade_out > 0.0f)
    w *= std::clamp((duration - t) / layer.fade_out, 0.0f, 1.0f);
  return w;
}

namespace {

// True when every key of the sampler's component `c` holds `rest` (a shape's weight at rest).
bool ComponentAtRest(const AnimationSampler& s, size_t c, float rest) {
  const size_t n = s.components;
  const bool bezier = s.interpolation == Interpolation::kBezier;
  for (size_t k = 0; k < s.times.size(); ++k) {
    const float* key = &s.values[k * s.key_stride()];
    if (key[s.value_offset() + c] != rest) return false;
    if (bezier && (key[2 * n + c] != rest || key[4 * n + c] != rest || key[5 * n + c] != rest))
      return false;
  }
  return true;
}

// True when every key of a TRS channel holds the node's rest value.
bool ChannelAtRest(const AnimationSampler& s, const Transform& rest, ChannelPath path) {
  const size_t n = s.components;
  const float* want = path == ChannelPath::kTranslation ? rest.translation.data()
                      : path == ChannelPath::kScale     ? rest.scale.data()
                                                        : rest.rotation.data();
  if (s.interpolation == Interpolation::kBezier || (path == ChannelPath::kRotation) != (n == 4))
    return false;
  for (size_t k = 0; k < s.times.size(); ++k) {
    const float* v = &s.values[k * s.key_stride() + s.value_offset()];
    if (path == ChannelPath::kRotation) {
      const float dot = v[0] * want[0] + v[1] * want[1] + v[2] * want[2] + v[3] * want[3];
      if (std::fabs(dot) < 1.0f - 1e-6f) return false;
    } else {
      for (size_t c = 0; c < 3; ++c) {
        if (std::fabs(v[c] - want[c]) > 1e-6f * std::max(1.0f, std::fabs(want[c]))) return false;
      }
    }
  }
  return true;
}

// The nodes in the subtrees of `mask` (every node when it is empty).
std::vector<uint8_t> MaskedNodes(const Rig& rig, const std::vector<int>& mask) {
  std::vector<uint8_t> in(rig.nodes.size(), mask.empty() ? 1 : 0);
  std::vector<int> stack(mask.begin(), mask.end());
  while (!stack.empty()) {
    const int i = stack.back();
    stack.pop_back();
    in[i] = 1;
    for (int c : rig.nodes[i].children) stack.push_back(c);
  }
  return in;
}

// A layer's clip sampled at its time over the rest pose, and the nodes its mask lets through.
struct SampledLayer {
  Pose pose;
  std::vector<float> weights;
  std::vector<uint8_t> set;
  std::vector<uint8_t> in;
};

Status SampleLayer(const Rig& rig, const Pose& rest, const ClipLayer& layer, SampledLayer& out) {
  out.pose = rest;
  if (Status s =
          SampleClip(rig, layer.clip, layer.time, layer.wrap, out.pose, out.weights, out.set);
      !s.ok())
    return s;
  out.in = MaskedNodes(rig, layer.mask);
  return Status::Ok();
}

// Puts an overlay over `pose` and the weights: what its clip moves, towards the clip by its weight.
Status Overlay(const Rig& rig, const Pose& rest, const ClipLayer& layer, Pose& pose,
               std::vector<float>& shape_weights, std::vector<uint8_t>& shape_set) {
  const float w = LayerWeight(rig, layer);
  if (w <= 0.0f) return Status::Ok();
  SampledLayer l;
  if (Status s = SampleLayer(rig, rest, layer, l); !s.ok()) return s;
  const AnimationInfo& a = rig.animations[layer.clip];
  for (const AnimationChannel& ch : a.channel_data) {
    const AnimationSampler& smp = a.sampler_data[ch.sampler];
    if (ch.path == ChannelPath::kWeights) {
      const Mesh& mesh = rig.meshes[rig.nodes[ch.node].mesh];
      for (size_t k = 0; k < mesh.target_shapes.size() && k < smp.components; ++k) {
        const uint32_t shape = mesh.target_shapes[k];
        if (ComponentAtRest(smp, k, 0.0f)) continue;
        const float below = shape_set[shape] ? shape_weights[shape] : 0.0f;
        shape_weights[shape] = below + w * (l.weights[shape] - below);
        shape_set[shape] = 1;
      }
      continue;
    }
    if (!l.in[ch.node] || ChannelAtRest(smp, rest.local[ch.node], ch.path)) continue;
    Transform& t = pose.local[ch.node];
    const Transform& o = l.pose.local[ch.node];
    if (pose.from_matrix[ch.node]) t = rest.local[ch.node];
    pose.from_matrix[ch.node] = 0;
    switch (ch.path) {
      case ChannelPath::kTranslation:
        for (int c = 0; c < 3; ++c) t.translation[c] += w * (o.translation[c] - t.translation[c]);
        break;
      case ChannelPath::kScale:
        for (int c = 0; c < 3; ++c) t.scale[c] += w * (o.scale[c] - t.scale[c]);
        break;
      case ChannelPath::kRotation: t.rotation = Slerp(t.rotation, o.rotation, w); break;
      case ChannelPath::kWeights: break;
    }
  }
  return Status::Ok();
}

}  // namespace

bool ClipMovesJoints(const Rig& rig, int clip) {
  const AnimationInfo& a = rig.animations[clip];
  const Pose rest = RestPose(rig);
  for (const AnimationChannel& ch : a.channel_data) {
    if (ch.path != ChannelPath::kWeights &&
        !ChannelAtRest(a.sampler_data[ch.sampler], rest.local[ch.node], ch.path))
      return true;
  }
  return false;
}

Status BlendClips(const Rig& rig, std::span<const ClipLayer> layers, Pose& pose,
                  std::vector<float>& shape_weights, std::vector<uint8_t>& shape_set) {
  const size_t n = rig.nodes.size();
  const Pose rest = RestPose(rig);
  std::vector<float> total(n, 0.0f);
  std::vector<Transform> acc(n);
  for (Transform& t : acc) t = {{0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0}};
  std::vector<float> wsum(rig.shapes.size(), 0.0f), wtotal(rig.shapes.size(), 0.0f);
  for (const ClipLayer& layer : layers) {
    if (!(layer.weight >= 0.0f) || !std::isfinite(layer.weight))
      return InvalidArgument("blend weights must be finite and >= 0");
    if (!std::isfinite(layer.fade_in) || !std::isfinite(layer.fade_out) || layer.fade_in < 0.0f ||
        layer.fade_out < 0.0f) {
      return InvalidArgument("fades must be finite and >= 0");
    }
    if (layer.overlay) continue;
    SampledLayer l;
    if (Status s = SampleLayer(rig, rest, layer, l); !s.ok()) return s;
    for (size_t i = 0; i < n; ++i) {
      if (!l.in[i] || layer.weight == 0.0f) continue;
      const Transform& t = l.pose.local[i];
      Transform& a = acc[i];
      // Align the quaternion with the first one accumulated (same hemisphere).
      const float dot = a.rotation[0] * t.rotation[0] + a.rotation[1] * t.rotation[1] +
                        a.rotation[2] * t.rotation[2] + a.rotation[3] * t.rotation[3];
      const float sign = dot < 0.0f ? -1.0f : 1.0f;
      for (int c = 0; c < 3; ++c) {
        a.translation[c] += layer.weight * t.translation[c];
        a.scale[c] += layer.weight * t.scale[c];
      }
      for (int c = 0; c < 4; ++c) a.rotation[c] += sign * layer.weight * t.rotation[c];
      total[i] += layer.weight;
      if (l.pose.from_matrix[i] == 0) pose.from_matrix[i] = 0;
    }
    for (size_t s = 0; s < l.set.size(); ++s) {
      if (!l.set[s]) continue;
      wsum[s] += layer.weight * l.weights[s];
      wtotal[s] += layer.weight;
    }
  }
  for (size_t i = 0; i < n; ++i) {
    if (total[i] <= 0.0f) continue;
    Transform& t = pose.local[i];
    for (int c = 0; c < 3; ++c) {
      t.translation[c] = acc[i].translation[c] / total[i];
      t.scale[c] = acc[i].scale[c] / total[i];
    }
    t.rotation = NormalizedQuaternion(acc[i].rotation);
  }
  shape_weights.resize(rig.shapes.size(), 0.0f);
  shape_set.resize(rig.shapes.size(), 0);
  for (size_t s = 0; s < wsum.size(); ++s) {
    if (wtotal[s] > 0.0f) {
      shape_weights[s] = wsum[s] / wtotal[s];
      shape_set[s] = 1;
    }
  }
  for (const ClipLayer& layer : layers) {
    if (!layer.overlay) continue;
    if (Status s = Overlay(rig, rest, layer, pose, shape_weights, shape_set); !s.ok()) return s;
  }
  return Status::Ok();
}

}  // namespace engine
}  // namespace facespace
