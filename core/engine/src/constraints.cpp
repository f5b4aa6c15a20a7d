// MMD's grants and IK, following MMD's own order of updates (as the open MMD players reproduce it):
// per bone in deform order, its grant then its IK chain, each followed by its subtree's world
// transforms. IK: per iteration, each link rotates the effector towards the IK bone by at most the
// chain's angle; a link limited to one axis (a knee) turns in that plane; other limited links clamp
// their Euler angles (X, then Y, then Z), continuous with the last step's. The iteration that gets
// no closer is undone and ends the solve.
#include "facespace/engine/constraints.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace facespace {
inline namespace engine {

namespace {

using Quat = Eigen::Quaternionf;
using Vec3 = Eigen::Vector3f;

constexpr float kPi = 3.14159265358979f;

Quat ToQuat(const std::array<float, 4>& q) { return Quat(q[3], q[0], q[1], q[2]); }

float NormalizeAngle(float a) {
  a = std::fmod(a, 2 * kPi);
  return a < 0 ? a + 2 * kPi : a;
}

float DiffAngle(float a, float b) {
  const float d = NormalizeAngle(a) - NormalizeAngle(b);
  return d > kPi ? d - 2 * kPi : d < -kPi ? d + 2 * kPi : d;
}

// Euler angles (R = Rz Ry Rx) of `m`, of the equivalent sets the one nearest `before`.
Vec3 Decompose(const Eigen::Matrix3f& m, const Vec3& before) {
  Vec3 r;
  const float sy = -m(2, 0);
  if (1.0f - std::fabs(sy) < 1e-6f) {
    r.y() = std::asin(std::clamp(sy, -1.0f, 1.0f));
    if (std::fabs(std::sin(before.x())) < std::fabs(std::sin(before.z()))) {
      const bool c = std::cos(before.x()) > 0;
      r.x() = c ? 0.0f : kPi;
      r.z() = std::asin(std::clamp(c ? -m(0, 1) : m(0, 1), -1.0f, 1.0f));
    } else {
      const bool c = std::cos(before.z()) > 0;
      r.z() = c ? 0.0f : kPi;
      r.x() = std::asin(std::clamp(c ? -m(1, 2) : m(1, 2), -1.0f, 1.0f));
    }
  } else {
    r.x() = std::atan2(m(2, 1), m(2, 2));
    r.y() = std::asin(std::clamp(-m(2, 0), -1.0f, 1.0f));
    r.z() = std::atan2(m(1, 0), m(0, 0));
  }
  const auto err = [&](const Vec3& v) {
    return std::fabs(DiffAngle(v.x(), before.x())) + std::fabs(DiffAngle(v.y(), before.y())) +
           std::fabs(DiffAngle(v.z(), before.z()));
  };
  float best = err(r);
  Vec3 out = r;
  for (float sx : {kPi, -kPi}) {
    for (float ty : {kPi, -kPi}) {
      for (float sz : {kPi, -kPi}) {
        const Vec3 t(r.x() + sx, ty - r.y(), r.z() + sz);
        if (const float e = err(t); e < best) {
          best = e;
          out = t;
        }
      }
    }
  }
  return out;
}

Quat EulerXyz(const Vec3& a) {
  return Quat(Eigen::AngleAxisf(a.z(), Vec3::UnitZ())) *
         Quat(Eigen::AngleAxisf(a.y(), Vec3::UnitY())) *
         Quat(Eigen::AngleAxisf(a.x(), Vec3::UnitX()));
}

class Solver {
 public:
  Solver(const Rig& rig, Pose& pose) : rig_(rig), pose_(pose) {
    const size_t n = rig.nodes.size();
    anim_rot_.resize(n);
    anim_t_.resize(n);
    for (size_t i = 0; i < n; ++i) {
      anim_rot_[i] = ToQuat(pose.local[i].rotation).normalized();
      anim_t_[i] = Vec3(pose.local[i].translation.data());
    }
    ik_rot_.assign(n, Quat::Identity());
    grant_rot_.assign(n, Quat::Identity());
    grant_t_.assign(n, Vec3::Zero());
    granted_.assign(n, 0);
    touched_.assign(n, 0);
    world_.resize(n);
    for (int root = 0; root < static_cast<int>(n); ++root) {
      if (rig.nodes[root].parent < 0) UpdateWorld(root);
    }
  }

  void Grant(const facespace::Grant& g) {
    const int s = g.source;
    if (g.rotation) {
      Quat q = g.local || !granted_[s] ? anim_rot_[s] : grant_rot_[s];
      q = ik_rot_[s] * q;
      grant_rot_[g.node] = Quat::Identity().slerp(g.ratio, q);
    }
    if (g.translation) {
      const Vec3 t = g.local || !granted_[s]
                         ? Vec3(anim_t_[s] - Vec3(rig_.nodes[s].translation.data()))
                         : grant_t_[s];
      grant_t_[g.node] = t * g.ratio;
    }
    granted_[g.node] = 1;
    touched_[g.node] = 1;
    UpdateWorld(g.node);
  }

  void Ik(const IkChain& c) {
    std::vector<Vec3> prev(c.links.size(), Vec3::Zero());
    std::vector<float> plane(c.links.size(), 0.0f);
    std::vector<Quat> saved(c.links.size());
    for (const IkLink& l : c.links) {
      ik_rot_[l.node] = Quat::Identity();
      touched_[l.node] = 1;
      UpdateWorld(l.node);
    }
    float best = INFINITY;
    for (int it = 0; it < c.loops; ++it) {
      Step(c, it, prev, plane);
      const float d = (Position(c.effector) - Position(c.node)).norm();
      if (d < best) {
        best = d;
        for (size_t k = 0; k < c.links.size(); ++k) saved[k] = ik_rot_[c.links[k].node];
      } else {
        for (size_t k = 0; k < c.links.size(); ++k) {
          ik_rot_[c.links[k].node] = saved[k];
          UpdateWorld(c.links[k].node);
        }
        break;
      }
    }
  }

  void Write() {
    for (size_t i = 0; i < touched_.size(); ++i) {
      if (!touched_[i]) continue;
      const Quat r = (ik_rot_[i] * anim_rot_[i] * grant_rot_[i]).normalized();
      const Vec3 t = anim_t_[i] + grant_t_[i];
      Transform& l = pose_.local[i];
      l.rotation = {r.x(), r.y(), r.z(), r.w()};
      l.translation = {t.x(), t.y(), t.z()};
      pose_.from_matrix[i] = 0;
    }
  }

 private:
  Vec3 Position(int node) const { return world_[node].translation(); }

  Eigen::Affine3f Local(int i) const {
    if (pose_.from_matrix[i])
      return Eigen::Affine3f(Eigen::Map<const Eigen::Matrix4f>(rig_.nodes[i].matrix.data()));
    const Transform& l = pose_.local[i];
    Eigen::Affine3f m = Eigen::Affine3f::Identity();
    m.translate(anim_t_[i] + grant_t_[i]);
    m.rotate((ik_rot_[i] * anim_rot_[i] * grant_rot_[i]).normalized());
    m.scale(Vec3(l.scale.data()));
    return m;
  }

  // World transforms of `node` and everything under it.
  void UpdateWorld(int node) {
    stack_.assign(1, node);
    while (!stack_.empty()) {
      const int i = stack_.back();
      stack_.pop_back();
      const int p = rig_.nodes[i].parent;
      world_[i] = p < 0 ? Local(i) : world_[p] * Local(i);
      for (int c : rig_.nodes[i].children) stack_.push_back(c);
    }
  }

  void Step(const IkChain& c, int it, std::vector<Vec3>& prev, std::vector<float>& plane) {
    const Vec3 goal = Position(c.node);
    for (size_t k = 0; k < c.links.size(); ++k) {
      const IkLink& l = c.links[k];
      if (l.node == c.effector) continue;
      const Eigen::Affine3f inv = world_[l.node].inverse();
      const Vec3 to_goal = (inv * goal).normalized(),
                 to_effector = (inv * Position(c.effector)).normalized();
      if (!to_goal.allFinite() || !to_effector.allFinite()) continue;
      const float angle =
          std::min(std::acos(std::clamp(to_effector.dot(to_goal), -1.0f, 1.0f)), c.max_angle);
      int axis = -1;  // A link limited to one axis turns in its plane.
      if (l.limited) {
        for (int a = 0; a < 3 && axis < 0; ++a) {
          const int b = (a + 1) % 3, d = (a + 2) % 3;
          if ((l.lower[a] != 0 || l.upper[a] != 0) && (l.lower[b] == 0 || l.upper[b] == 0) &&
              (l.lower[d] == 0 || l.upper[d] == 0))
            axis = a;
        }
      }
      if (axis >= 0) {
        const Vec3 ax = Vec3::Unit(axis);
        const float d1 = (Eigen::AngleAxisf(angle, ax) * to_effector).dot(to_goal),
                    d2 = (Eigen::AngleAxisf(-angle, ax) * to_effector).dot(to_goal);
        float a = plane[k] + (d1 > d2 ? angle : -angle);
        const float lo = l.lower[axis], hi = l.upper[axis];
        if (it == 0 && (a < lo || a > hi)) {
          if (-a > lo && -a < hi)
            a = -a;
          else if (std::fabs(0.5f * (lo + hi) - a) > std::fabs(0.5f * (lo + hi) + a))
            a = -a;
        }
        a = std::clamp(a, lo, hi);
        plane[k] = a;
        ik_rot_[l.node] = Quat(Eigen::AngleAxisf(a, ax)) * anim_rot_[l.node].inverse();
        UpdateWorld(l.node);
        continue;
      }
      if (angle * 180.0f / kPi < 1e-3f) continue;
      const Vec3 cross = to_effector.cross(to_goal);
      if (cross.norm() < 1e-12f) continue;
      Quat r =
          ik_rot_[l.node] * anim_rot_[l.node] * Quat(Eigen::AngleAxisf(angle, cross.normalized()));
      if (l.limited) {
        const Vec3 e = Decompose(r.normalized().toRotationMatrix(), prev[k]);
        Vec3 clamped = e.cwiseMax(Vec3(l.lower.data())).cwiseMin(Vec3(l.upper.data()));
        clamped = (clamped - prev[k])
                      .cwiseMax(Vec3::Constant(-c.max_angle))
                      .cwiseMin(Vec3::Constant(c.max_angle)) +
                  prev[k];
        prev[k] = clamped;
        r = EulerXyz(clamped);
      }
      ik_rot_[l.node] = (r * anim_rot_[l.node].inverse()).normalized();
      UpdateWorld(l.node);
    }
  }

  const Rig& rig_;
  Pose& pose_;
  std::vector<Quat> anim_rot_, ik_rot_, grant_rot_;
  std::vector<Vec3> anim_t_, grant_t_;
  std::vector<uint8_t> granted_, touched_;  // Inherits already; its transform is the solver's.
  std::vector<Eigen::Affine3f> world_;
  std::vector<int> stack_;
};

}  // namespace

void SolveBoneConstraints(const Rig& rig, Pose& pose) {
  const BoneConstraints& bc = rig.constraints;
  if (bc.empty() || pose.local.size() != rig.nodes.size()) return;
  std::vector<int> grant_of(rig.nodes.size(), -1), chain_of(rig.nodes.size(), -1);
  for (size_t g = 0; g < bc.grants.size(); ++g) grant_of[bc.grants[g].node] = static_cast<int>(g);
  for (size_t c = 0; c < bc.chains.size(); ++c) chain_of[bc.chains[c].node] = static_cast<int>(c);
  Solver solver(rig, pose);
  for (int node : bc.order) {
    if (grant_of[node] >= 0) solver.Grant(bc.grants[grant_of[node]]);
    if (chain_of[node] >= 0) solver.Ik(bc.chains[chain_of[node]]);
  }
  solver.Write();
}

AnimationInfo ClipWithConstraintsSolved(const Rig& rig, int clip, float per_second) {
  const AnimationInfo& a = rig.animations[clip];
  // A clip that keys the body at rest stays so: as an overlay it leaves the body to the layers
  // below, whose solved pose then holds (solving a pose at rest is not always the rest).
  if (rig.constraints.empty() || !ClipMovesJoints(rig, clip)) return a;
  // The bones the constraints move: granted bones and IK links.
  std::vector<uint8_t> moved(rig.nodes.size(), 0);
  for (const Grant& g : rig.constraints.grants) moved[g.node] = 1;
  for (const IkChain& c : rig.constraints.chains) {
    for (const IkLink& l : c.links) moved[l.node] = 1;
  }
  AnimationInfo out;
  out.name = a.name;
  out.duration = a.duration;
  out.has_weights = a.has_weights;
  for (const AnimationChannel& ch : a.channel_data) {
    if (ch.path != ChannelPath::kWeights && ch.path != ChannelPath::kScale && moved[ch.node])
      continue;
    out.channel_data.push_back({static_cast<int>(out.sampler_data.size()), ch.node, ch.path});
    out.sampler_data.push_back(a.sampler_data[ch.sampler]);
  }
  const size_t frames = static_cast<size_t>(std::ceil(a.duration * per_second - 1e-4f)) + 1;
  std::vector<int> nodes;
  for (size_t n = 0; n < moved.size(); ++n) {
    if (moved[n]) nodes.push_back(static_cast<int>(n));
  }
  std::vector<AnimationSampler> t(nodes.size()), r(nodes.size());
  std::vector<float> w;
  std::vector<uint8_t> set;
  for (size_t f = 0; f < frames; ++f) {
    const float time = std::min(a.duration, static_cast<float>(f) / per_second);
    Pose pose = RestPose(rig);
    if (!SampleClip(rig, clip, time, ClipWrap::kClamp, pose, w, set).ok()) break;
    SolveBoneConstraints(rig, pose);
    for (size_t k = 0; k < nodes.size(); ++k) {
      const Transform& l = pose.local[nodes[k]];
      t[k].times.push_back(time);
      r[k].times.push_back(time);
      t[k].values.insert(t[k].values.end(), l.translation.begin(), l.translation.end());
      r[k].values.insert(r[k].values.end(), l.rotation.begin(), l.rotation.end());
    }
  }
  for (size_t k = 0; k < nodes.size(); ++k) {
    t[k].components = 3;
    r[k].components = 4;
    out.channel_data.push_back(
        {static_cast<int>(out.sampler_data.size()), nodes[k], ChannelPath::kTranslation});
    out.sampler_data.push_back(std::move(t[k]));
    out.channel_data.push_back(
        {static_cast<int>(out.sampler_data.size()), nodes[k], ChannelPath::kRotation});
    out.sampler_data.push_back(std::move(r[k]));
  }
  out.channels = out.channel_data.size();
  return out;
}

}  // namespace engine
}  // namespace facespace
