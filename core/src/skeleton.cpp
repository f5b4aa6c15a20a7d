#include "facespace/core/skeleton.h"

#include <Eigen/Geometry>

#include "normal_matrix.h"
#include <algorithm>
#include <cmath>

namespace facespace {

namespace {

using Quat = std::array<float, 4>;

Quat Normalized(Quat q) {
  const float len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(len > 0.0f) || !std::isfinite(len)) return {0, 0, 0, 1};
  for (float& c : q) c /= len;
  return q;
}

Eigen::Matrix4f Compose(const Transform& t) {
  Eigen::Affine3f a = Eigen::Affine3f::Identity();
  a.translate(Eigen::Vector3f(t.translation[0], t.translation[1], t.translation[2]));
  a.rotate(Eigen::Quaternionf(t.rotation[3], t.rotation[0], t.rotation[1], t.rotation[2]).normalized());
  a.scale(Eigen::Vector3f(t.scale[0], t.scale[1], t.scale[2]));
  return a.matrix();
}

}  // namespace

Quat Slerp(const Quat& a, const Quat& b0, float t) {
  Quat b = b0;
  float dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  if (dot < 0.0f) {  // Shortest path.
    for (float& c : b) c = -c;
    dot = -dot;
  }
  if (dot > 0.9995f) {  // Nearly parallel: nlerp is exact enough and stable.
    Quat r;
    for (int i = 0; i < 4; ++i) r[i] = a[i] + t * (b[i] - a[i]);
    return Normalized(r);
  }
  const float theta = std::acos(std::min(dot, 1.0f));
  const float s = std::sin(theta);
  const float wa = std::sin((1.0f - t) * theta) / s, wb = std::sin(t * theta) / s;
  Quat r;
  for (int i = 0; i < 4; ++i) r[i] = wa * a[i] + wb * b[i];
  return Normalized(r);
}

Quat EulerToQuaternion(float x_deg, float y_deg, float z_deg) {
  const float k = static_cast<float>(M_PI) / 180.0f;
  const Eigen::Quaternionf q = Eigen::AngleAxisf(z_deg * k, Eigen::Vector3f::UnitZ()) *
                               Eigen::AngleAxisf(y_deg * k, Eigen::Vector3f::UnitY()) *
                               Eigen::AngleAxisf(x_deg * k, Eigen::Vector3f::UnitX());
  return {q.x(), q.y(), q.z(), q.w()};
}

int FindNode(const Rig& rig, const std::string& name) {
  for (size_t i = 0; i < rig.nodes.size(); ++i) {
    if (rig.nodes[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

Pose RestPose(const Rig& rig) {
  Pose p;
  p.local.resize(rig.nodes.size());
  p.from_matrix.resize(rig.nodes.size(), 0);
  for (size_t i = 0; i < rig.nodes.size(); ++i) {
    const Node& n = rig.nodes[i];
    p.local[i] = {n.translation, Normalized(n.rotation), n.scale};
    p.from_matrix[i] = n.has_matrix ? 1 : 0;
  }
  return p;
}

std::vector<std::array<float, 16>> WorldMatrices(const Rig& rig, const Pose& pose) {
  const size_t n = rig.nodes.size();
  std::vector<Eigen::Matrix4f> world(n, Eigen::Matrix4f::Identity());
  std::vector<int> queue;
  for (size_t i = 0; i < n; ++i) {
    if (rig.nodes[i].parent < 0) queue.push_back(static_cast<int>(i));
  }
  for (size_t q = 0; q < queue.size(); ++q) {
    const int i = queue[q];
    const Node& node = rig.nodes[i];
    const Eigen::Matrix4f local = pose.from_matrix[i] ? Eigen::Matrix4f(Eigen::Map<const Eigen::Matrix4f>(node.matrix.data()))
                                                      : Compose(pose.local[i]);
    world[i] = node.parent < 0 ? local : Eigen::Matrix4f(world[node.parent] * local);
    for (int c : node.children) queue.push_back(c);
  }
  std::vector<std::array<float, 16>> out(n);
  for (size_t i = 0; i < n; ++i) std::copy(world[i].data(), world[i].data() + 16, out[i].begin());
  return out;
}

void JointMatrices(const Rig& rig, int skin, std::span<const std::array<float, 16>> world, std::vector<float>& out) {
  const Skin& s = rig.skins[skin];
  out.resize(16 * s.joints.size());
  for (size_t j = 0; j < s.joints.size(); ++j) {
    const Eigen::Map<const Eigen::Matrix4f> w(world[s.joints[j]].data());
    const Eigen::Map<const Eigen::Matrix4f> ibm(&s.inverse_bind[16 * j]);
    Eigen::Map<Eigen::Matrix4f> joint(&out[16 * j]);
    joint = w * ibm;
  }
}

bool SkinningJob::Validate() const {
  const size_t n = in_positions.size() / 3;
  if (in_positions.size() % 3 || out_positions.size() != in_positions.size()) return false;
  if (influences == 0 || joints.size() != n * influences || weights.size() != n * influences) return false;
  if (joint_matrices.size() % 16) return false;
  if (!in_normals.empty() && (in_normals.size() != 3 * n || out_normals.size() != in_normals.size())) return false;
  if (!in_tangents.empty() && (in_tangents.size() != 4 * n || out_tangents.size() != in_tangents.size())) return false;
  const size_t joint_count = joint_matrices.size() / 16;
  if (!joint_dual_quaternions.empty() && joint_dual_quaternions.size() != 8 * joint_count) return false;
  for (uint16_t j : joints) {
    if (j >= joint_count) return false;
  }
  return true;
}

void DualQuaternions(std::span<const float> joint_matrices, std::vector<float>& out) {
  const size_t joints = joint_matrices.size() / 16;
  out.resize(8 * joints);
  for (size_t j = 0; j < joints; ++j) {
    const Eigen::Map<const Eigen::Matrix4f> m(&joint_matrices[16 * j]);
    Eigen::Matrix3f rot, scale;
    Eigen::Affine3f(m).computeRotationScaling(&rot, &scale);
    const Eigen::Quaternionf r(rot);
    const Eigen::Vector3f t = m.block<3, 1>(0, 3);
    // Dual part: 0.5 * (t, 0) * r.
    const Eigen::Quaternionf tq(0.0f, t.x(), t.y(), t.z());
    const Eigen::Quaternionf d = tq * r;
    float* o = &out[8 * j];
    o[0] = r.x(); o[1] = r.y(); o[2] = r.z(); o[3] = r.w();
    o[4] = 0.5f * d.x(); o[5] = 0.5f * d.y(); o[6] = 0.5f * d.z(); o[7] = 0.5f * d.w();
  }
}

namespace {

// Dual-quaternion skinning of one vertex.
void SkinVertexDq(const SkinningJob& job, size_t v) {
  const size_t K = job.influences;
  float real[4] = {0, 0, 0, 0}, dual[4] = {0, 0, 0, 0};
  const float* first = nullptr;
  for (size_t k = 0; k < K; ++k) {
    const float w = job.weights[v * K + k];
    if (w == 0.0f) continue;
    const float* q = &job.joint_dual_quaternions[8 * static_cast<size_t>(job.joints[v * K + k])];
    if (!first) first = q;
    // Blend in the hemisphere of the first influence (antipodality).
    const float sign = (q[0] * first[0] + q[1] * first[1] + q[2] * first[2] + q[3] * first[3]) < 0.0f ? -w : w;
    for (int i = 0; i < 4; ++i) {
      real[i] += sign * q[i];
      dual[i] += sign * q[4 + i];
    }
  }
  const float len = std::sqrt(real[0] * real[0] + real[1] * real[1] + real[2] * real[2] + real[3] * real[3]);
  if (!(len > 0.0f)) {
    real[3] = 1.0f;
  } else {
    for (int i = 0; i < 4; ++i) {
      real[i] /= len;
      dual[i] /= len;
    }
  }
  const Eigen::Quaternionf r(real[3], real[0], real[1], real[2]);
  const Eigen::Quaternionf d(dual[3], dual[0], dual[1], dual[2]);
  const Eigen::Quaternionf tq = d * r.conjugate();  // t = 2 * d * conj(r).
  const Eigen::Vector3f t = 2.0f * tq.vec();
  const float* p = &job.in_positions[3 * v];
  const Eigen::Vector3f q = r * Eigen::Vector3f(p[0], p[1], p[2]) + t;
  for (int i = 0; i < 3; ++i) job.out_positions[3 * v + i] = q[i];
  if (!job.in_normals.empty()) {
    const float* nn = &job.in_normals[3 * v];
    const Eigen::Vector3f n = r * Eigen::Vector3f(nn[0], nn[1], nn[2]);
    for (int i = 0; i < 3; ++i) job.out_normals[3 * v + i] = n[i];
  }
  if (!job.in_tangents.empty()) {
    const float* tt = &job.in_tangents[4 * v];
    const Eigen::Vector3f tv = r * Eigen::Vector3f(tt[0], tt[1], tt[2]);
    for (int i = 0; i < 3; ++i) job.out_tangents[4 * v + i] = tv[i];
    job.out_tangents[4 * v + 3] = tt[3];
  }
}

}  // namespace

bool SkinningJob::Run() const {
  if (!Validate()) return false;
  const size_t n = in_positions.size() / 3;
  if (!joint_dual_quaternions.empty()) {
    for (size_t v = 0; v < n; ++v) SkinVertexDq(*this, v);
    return true;
  }
  for (size_t v = 0; v < n; ++v) {
    // Blended matrix (upper 3x4, column-major).
    float m[12] = {0};
    for (size_t k = 0; k < influences; ++k) {
      const float w = weights[v * influences + k];
      if (w == 0.0f) continue;
      const float* jm = &joint_matrices[16 * static_cast<size_t>(joints[v * influences + k])];
      for (int c = 0; c < 4; ++c) {
        m[3 * c] += w * jm[4 * c];
        m[3 * c + 1] += w * jm[4 * c + 1];
        m[3 * c + 2] += w * jm[4 * c + 2];
      }
    }
    const float* p = &in_positions[3 * v];
    for (int r = 0; r < 3; ++r) out_positions[3 * v + r] = m[r] * p[0] + m[3 + r] * p[1] + m[6 + r] * p[2] + m[9 + r];
    if (!in_normals.empty()) TransformNormal(m, 3, &in_normals[3 * v], &out_normals[3 * v]);
    if (!in_tangents.empty()) {
      const float* t = &in_tangents[4 * v];
      float o[3];
      for (int r = 0; r < 3; ++r) o[r] = m[r] * t[0] + m[3 + r] * t[1] + m[6 + r] * t[2];
      const float len = std::sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
      for (int r = 0; r < 3; ++r) out_tangents[4 * v + r] = len > 0.0f ? o[r] / len : t[r];
      out_tangents[4 * v + 3] = t[3];
    }
  }
  return true;
}

namespace {

// The keys around `time` and the fraction between them.
void Locate(const std::vector<float>& times, float time, size_t& k0, size_t& k1, float& u, float& dt) {
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
  const size_t stride = cubic ? 3 * c : c;
  const float* v0 = &s.values[k0 * stride + (cubic ? c : 0)];
  const float* v1 = &s.values[k1 * stride + (cubic ? c : 0)];
  if (s.interpolation == Interpolation::kStep || k0 == k1) {
    std::copy(v0, v0 + c, out);
  } else if (!cubic) {
    if (rotation) {
      const Quat q = Slerp({v0[0], v0[1], v0[2], v0[3]}, {v1[0], v1[1], v1[2], v1[3]}, u);
      std::copy(q.begin(), q.end(), out);
      return;
    }
    for (size_t i = 0; i < c; ++i) out[i] = v0[i] + u * (v1[i] - v0[i]);
  } else {
    // Hermite with the out-tangent of k0 and the in-tangent of k1, scaled by the key gap.
    const float* b0 = &s.values[k0 * stride + 2 * c];
    const float* a1 = &s.values[k1 * stride];
    const float u2 = u * u, u3 = u2 * u;
    const float h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
    for (size_t i = 0; i < c; ++i) out[i] = h00 * v0[i] + h10 * dt * b0[i] + h01 * v1[i] + h11 * dt * a1[i];
  }
  if (rotation) {
    const Quat q = Normalized({out[0], out[1], out[2], out[3]});
    std::copy(q.begin(), q.end(), out);
  }
}

}  // namespace

Status SampleClip(const Rig& rig, int clip, float time, ClipWrap wrap, Pose& pose, std::vector<float>& shape_weights,
                  std::vector<uint8_t>& shape_set) {
  if (clip < 0 || static_cast<size_t>(clip) >= rig.animations.size()) return InvalidArgument("no animation " + std::to_string(clip));
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

Status BlendClips(const Rig& rig, std::span<const ClipLayer> layers, Pose& pose, std::vector<float>& shape_weights,
                  std::vector<uint8_t>& shape_set) {
  const size_t n = rig.nodes.size();
  const Pose rest = RestPose(rig);
  std::vector<float> total(n, 0.0f);
  std::vector<Transform> acc(n);
  for (Transform& t : acc) t = {{0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0}};
  std::vector<float> wsum(rig.shapes.size(), 0.0f), wtotal(rig.shapes.size(), 0.0f);
  for (const ClipLayer& layer : layers) {
    if (!(layer.weight >= 0.0f) || !std::isfinite(layer.weight)) return InvalidArgument("blend weights must be finite and >= 0");
    Pose sampled = rest;
    std::vector<float> sw;
    std::vector<uint8_t> ss;
    if (Status s = SampleClip(rig, layer.clip, layer.time, layer.wrap, sampled, sw, ss); !s.ok()) return s;
    // Nodes in the mask's subtrees (every node when there is no mask).
    std::vector<uint8_t> in(n, layer.mask.empty() ? 1 : 0);
    for (int root : layer.mask) {
      std::vector<int> stack = {root};
      while (!stack.empty()) {
        const int i = stack.back();
        stack.pop_back();
        in[i] = 1;
        for (int c : rig.nodes[i].children) stack.push_back(c);
      }
    }
    for (size_t i = 0; i < n; ++i) {
      if (!in[i] || layer.weight == 0.0f) continue;
      const Transform& t = sampled.local[i];
      Transform& a = acc[i];
      // Align the quaternion with the first one accumulated (same hemisphere).
      const float dot = a.rotation[0] * t.rotation[0] + a.rotation[1] * t.rotation[1] + a.rotation[2] * t.rotation[2] +
                        a.rotation[3] * t.rotation[3];
      const float sign = dot < 0.0f ? -1.0f : 1.0f;
      for (int c = 0; c < 3; ++c) {
        a.translation[c] += layer.weight * t.translation[c];
        a.scale[c] += layer.weight * t.scale[c];
      }
      for (int c = 0; c < 4; ++c) a.rotation[c] += sign * layer.weight * t.rotation[c];
      total[i] += layer.weight;
      if (sampled.from_matrix[i] == 0) pose.from_matrix[i] = 0;
    }
    for (size_t s = 0; s < ss.size(); ++s) {
      if (!ss[s]) continue;
      wsum[s] += layer.weight * sw[s];
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
    t.rotation = Normalized(acc[i].rotation);
  }
  shape_weights.resize(rig.shapes.size(), 0.0f);
  shape_set.resize(rig.shapes.size(), 0);
  for (size_t s = 0; s < wsum.size(); ++s) {
    if (wtotal[s] > 0.0f) {
      shape_weights[s] = wsum[s] / wtotal[s];
      shape_set[s] = 1;
    }
  }
  return Status::Ok();
}

namespace {

int FindClip(const Rig& rig, const ClipRequest& c) {
  if (c.name.empty()) return c.index >= 0 && static_cast<size_t>(c.index) < rig.animations.size() ? static_cast<int>(c.index) : -1;
  for (size_t i = 0; i < rig.animations.size(); ++i) {
    if (rig.animations[i].name == c.name) return static_cast<int>(i);
  }
  return -1;
}

std::string ClipNames(const Rig& rig) {
  std::string s;
  for (size_t i = 0; i < rig.animations.size() && i < 30; ++i) s += (i ? ", " : "") + rig.animations[i].name;
  return s.empty() ? "(none: this rig has no animations)" : s;
}

}  // namespace

Status BuildPose(const Rig& rig, const PoseRequest& request, Pose& pose, std::vector<float>& animated_weights,
                 std::vector<uint8_t>& animated_set, std::vector<Warning>& warnings) {
  pose = RestPose(rig);
  animated_weights.assign(rig.shapes.size(), 0.0f);
  animated_set.assign(rig.shapes.size(), 0);
  Status errors = InvalidArgument("");
  std::vector<ClipLayer> layers;
  for (const ClipRequest& c : request.clips) {
    ClipLayer layer;
    layer.clip = FindClip(rig, c);
    if (layer.clip < 0) {
      errors.fields.push_back({c.pointer, "unknown animation '" + (c.name.empty() ? std::to_string(c.index) : c.name) +
                                              "'; animations: " + ClipNames(rig)});
      continue;
    }
    if (!std::isfinite(c.time)) errors.fields.push_back({c.pointer, "time must be a finite number of seconds"});
    if (!(c.weight >= 0.0f) || !std::isfinite(c.weight)) errors.fields.push_back({c.pointer, "weight must be a finite number >= 0"});
    layer.time = c.time;
    layer.weight = c.weight;
    layer.wrap = c.loop ? ClipWrap::kLoop : ClipWrap::kClamp;
    for (const std::string& j : c.mask) {
      const int node = FindNode(rig, j);
      if (node < 0) errors.fields.push_back({c.pointer + "/mask", "unknown joint '" + j + "'"});
      else layer.mask.push_back(node);
    }
    layers.push_back(std::move(layer));
  }
  for (const JointOverride& j : request.joints) {
    if (FindNode(rig, j.joint) < 0) errors.fields.push_back({j.pointer, "unknown joint '" + j.joint + "'"});
    if (j.has_rotation && j.has_euler) errors.fields.push_back({j.pointer, "give rotation or euler, not both"});
    if (j.has_rotation) {
      const auto& q = j.rotation;
      const float len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (!std::isfinite(len) || len < 1e-6f) errors.fields.push_back({j.pointer + "/rotation", "not a rotation: zero length or not finite"});
    }
  }
  if (!errors.fields.empty()) {
    errors.message = errors.fields[0].pointer + ": " + errors.fields[0].message;
    return errors;
  }
  if (!layers.empty()) {
    if (Status s = BlendClips(rig, layers, pose, animated_weights, animated_set); !s.ok()) return s;
  }
  for (const JointOverride& j : request.joints) {
    const int node = FindNode(rig, j.joint);
    Transform& t = pose.local[node];
    if (pose.from_matrix[node]) {
      // A matrix node overridden in part: start from its decomposition.
      const Eigen::Matrix4f m = Eigen::Map<const Eigen::Matrix4f>(rig.nodes[node].matrix.data());
      Eigen::Matrix3f rot, scale;
      Eigen::Affine3f(m).computeRotationScaling(&rot, &scale);
      const Eigen::Quaternionf q(rot);
      t.translation = {m(0, 3), m(1, 3), m(2, 3)};
      t.rotation = {q.x(), q.y(), q.z(), q.w()};
      t.scale = {scale(0, 0), scale(1, 1), scale(2, 2)};
      pose.from_matrix[node] = 0;
    }
    if (j.has_translation) t.translation = j.translation;
    if (j.has_scale) t.scale = j.scale;
    if (j.has_euler) t.rotation = EulerToQuaternion(j.euler[0], j.euler[1], j.euler[2]);
    if (j.has_rotation) {
      const auto& q = j.rotation;
      const float len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (std::fabs(len - 1.0f) > 1e-3f) {
        warnings.push_back({"quaternion_normalised",
                            "rotation of '" + j.joint + "' had length " + std::to_string(len) + " and was normalised", j.joint,
                            len, true});
      }
      t.rotation = Normalized(q);
    }
  }
  return Status::Ok();
}

Status ResolvePoseAndWeights(const Rig& rig, std::span<const WeightEntry> entries, const PoseRequest& request,
                             std::vector<float>& weights, Pose& pose, bool& posed, std::vector<Warning>& warnings) {
  auto resolved = ResolveWeights(rig, entries);
  if (!resolved.ok()) return resolved.status();
  weights = std::move(resolved.value());
  posed = !request.empty();
  if (!posed) return Status::Ok();
  std::vector<float> animated;
  std::vector<uint8_t> animated_set;
  if (Status s = BuildPose(rig, request, pose, animated, animated_set, warnings); !s.ok()) return s;
  // Shapes the request names keep their explicit weight; the others take the animated one.
  std::vector<uint8_t> given(rig.shapes.size(), 0);
  for (const WeightEntry& e : entries) {
    long long i = e.name.empty() ? e.index : FindShape(rig, e.name);
    if (i < 0 && !e.name.empty() && e.name.find_first_not_of("0123456789") == std::string::npos && e.name.size() < 10) i = std::stoll(e.name);
    if (i >= 0 && static_cast<size_t>(i) < given.size()) given[i] = 1;
  }
  for (size_t s = 0; s < weights.size(); ++s) {
    if (animated_set[s] && !given[s]) weights[s] = animated[s];
  }
  return Status::Ok();
}

}  // namespace facespace
