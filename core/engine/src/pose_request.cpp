// Pose requests: clips, then explicit joints, then explicit weights.
#include "facespace/engine/pose_request.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "facespace/engine/blend.h"
#include "facespace/engine/constraints.h"

namespace facespace {
inline namespace engine {

int FindClip(const Rig& rig, const ClipRequest& c) {
  if (c.name.empty())
    return c.index >= 0 && static_cast<size_t>(c.index) < rig.animations.size()
               ? static_cast<int>(c.index)
               : -1;
  for (size_t i = 0; i < rig.animations.size(); ++i) {
    if (rig.animations[i].name == c.name) return static_cast<int>(i);
  }
  return -1;
}

std::string UnknownClipMessage(const Rig& rig, const ClipRequest& c) {
  std::string msg =
      "unknown animation '" + (c.name.empty() ? std::to_string(c.index) : c.name) + "'";
  if (rig.animations.empty()) return msg + "; this rig has no animations";
  std::vector<std::string_view> names;
  for (const AnimationInfo& a : rig.animations) names.push_back(a.name);
  if (!c.name.empty()) msg += DidYouMean(c.name, names);
  msg += "; animations:";
  for (size_t i = 0; i < names.size() && i < 30; ++i)
    msg += (i ? ", " : " ") + std::string(names[i]);
  if (names.size() > 30) msg += ", ... (" + std::to_string(names.size()) + " in all)";
  return msg;
}

Status BuildPose(const Rig& rig, const PoseRequest& request, Pose& pose,
                 std::vector<float>& animated_weights, std::vector<uint8_t>& animated_set,
                 std::vector<Warning>& warnings, bool solve) {
  pose = RestPose(rig);
  animated_weights.assign(rig.shapes.size(), 0.0f);
  animated_set.assign(rig.shapes.size(), 0);
  Status errors = InvalidArgument("");
  std::vector<ClipLayer> layers;
  for (const ClipRequest& c : request.clips) {
    ClipLayer layer;
    layer.clip = FindClip(rig, c);
    if (layer.clip < 0) {
      errors.fields.push_back({c.pointer, UnknownClipMessage(rig, c)});
      continue;
    }
    if (!std::isfinite(c.time))
      errors.fields.push_back({c.pointer, "time must be a finite number of seconds"});
    if (!(c.weight >= 0.0f) || !std::isfinite(c.weight))
      errors.fields.push_back({c.pointer, "weight must be a finite number >= 0"});
    layer.time = c.time;
    layer.weight = c.weight;
    layer.wrap = c.loop ? ClipWrap::kLoop : ClipWrap::kClamp;
    layer.overlay = c.overlay;
    layer.fade_in = c.fade_in;
    layer.fade_out = c.fade_out;
    if (!std::isfinite(c.fade_in) || c.fade_in < 0.0f)
      errors.fields.push_back({c.pointer + "/fade_in", "must be a finite number of seconds >= 0"});
    if (!std::isfinite(c.fade_out) || c.fade_out < 0.0f)
      errors.fields.push_back({c.pointer + "/fade_out", "must be a finite number of seconds >= 0"});
    for (const std::string& j : c.mask) {
      const int node = FindNode(rig, j);
      if (node < 0)
        errors.fields.push_back({c.pointer + "/mask", "unknown joint '" + j + "'"});
      else
        layer.mask.push_back(node);
    }
    // A single motion over the rig's base layer (its own, looping at the same time), as MMD
    // players put an expression over a standing body.
    if (c.over_base && !rig.base_motion.empty() &&
        rig.animations[layer.clip].name != rig.base_motion) {
      ClipRequest base;
      base.name = rig.base_motion;
      ClipLayer under;
      under.clip = FindClip(rig, base);
      under.time = c.time;
      under.wrap = ClipWrap::kLoop;
      if (under.clip >= 0) {
        layers.push_back(std::move(under));
        layer.overlay = true;
      }
    }
    layers.push_back(std::move(layer));
  }
  for (const JointOverride& j : request.joints) {
    if (FindNode(rig, j.joint) < 0)
      errors.fields.push_back({j.pointer, "unknown joint '" + j.joint + "'"});
    if (j.has_rotation && j.has_euler)
      errors.fields.push_back({j.pointer, "give rotation or euler, not both"});
    if (j.has_rotation) {
      const auto& q = j.rotation;
      const float len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (!std::isfinite(len) || len < 1e-6f)
        errors.fields.push_back(
            {j.pointer + "/rotation", "not a rotation: zero length or not finite"});
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
                            "rotation of '" + j.joint + "' had length " + std::to_string(len) +
                                " and was normalised",
                            j.joint, len, true});
      }
      t.rotation = NormalizedQuaternion(q);
    }
  }
  // MMD's grants and IK over what the clips and overrides animate.
  if (solve && !request.empty()) SolveBoneConstraints(rig, pose);
  return Status::Ok();
}

namespace {

// The weights bone morphs act at: with MMD's flip morphs, their picks added (EffectiveWeights).
std::span<const float> WithFlips(const Rig& rig, std::span<const float> weights,
                                 std::vector<float>& scratch) {
  if (rig.flips.empty() || weights.size() != rig.shapes.size()) return weights;
  scratch.resize(weights.size());
  EffectiveWeights(rig, weights, scratch);
  return scratch;
}

}  // namespace

bool BoneMorphsActive(const Rig& rig, std::span<const float> given) {
  std::vector<float> scratch;
  const std::span<const float> weights = WithFlips(rig, given, scratch);
  for (size_t s = 0; s < rig.shapes.size() && s < weights.size(); ++s) {
    if (weights[s] != 0.0f && !rig.shapes[s].bone_morphs.empty()) return true;
  }
  return false;
}

bool ApplyBoneMorphs(const Rig& rig, std::span<const float> given, Pose& pose) {
  std::vector<float> scratch;
  const std::span<const float> weights = WithFlips(rig, given, scratch);
  bool any = false;
  for (size_t s = 0; s < rig.shapes.size() && s < weights.size(); ++s) {
    const float w = weights[s];
    if (w == 0.0f || !std::isfinite(w)) continue;
    for (const BoneMorph& m : rig.shapes[s].bone_morphs) {
      if (m.node < 0 || static_cast<size_t>(m.node) >= pose.local.size()) continue;
      Transform& t = pose.local[m.node];
      for (int a = 0; a < 3; ++a) t.translation[a] += w * m.translation[a];
      const std::array<float, 4> turn = Slerp({0, 0, 0, 1}, m.rotation, w);
      const Eigen::Quaternionf q =
          Eigen::Quaternionf(t.rotation[3], t.rotation[0], t.rotation[1], t.rotation[2]) *
          Eigen::Quaternionf(turn[3], turn[0], turn[1], turn[2]);
      t.rotation = NormalizedQuaternion({q.x(), q.y(), q.z(), q.w()});
      pose.from_matrix[m.node] = 0;
      any = true;
    }
  }
  return any;
}

void FinishPose(const Rig& rig, std::span<const float> weights, Pose& pose) {
  ApplyBoneMorphs(rig, weights, pose);
  SolveBoneConstraints(rig, pose);
}

bool PoseOfWeightsAlone(const Rig& rig, std::span<const float> weights, Pose& pose) {
  if (!BoneMorphsActive(rig, weights)) return false;
  pose = RestPose(rig);
  FinishPose(rig, weights, pose);
  return true;
}

bool PoseOfFaceAndWeights(const Rig& rig, const FaceState& face, std::span<float> weights,
                          Pose& pose, std::vector<Warning>& warnings) {
  bool posed = false;
  ApplyFace(rig, face, weights, pose, posed, warnings);
  if (!posed) return PoseOfWeightsAlone(rig, weights, pose);
  FinishPose(rig, weights, pose);
  return true;
}

namespace {

// The weights the face made are numbers: expression values each finite (1e308) can still sum or
// scale past a float's range, which is the request's fault, not the blend's.
Status FiniteFace(std::span<const float> weights) {
  for (float w : weights) {
    if (!std::isfinite(w))
      return InvalidField("/expressions",
                          "the expressions' weights are not finite numbers (a value too large?)");
  }
  return Status::Ok();
}

}  // namespace

Status ResolvePoseAndWeights(const Rig& rig, std::span<const WeightEntry> entries,
                             const PoseRequest& request, std::vector<float>& weights, Pose& pose,
                             bool& posed, std::vector<Warning>& warnings) {
  auto resolved = ResolveWeights(rig, entries);
  if (!resolved.ok()) return resolved.status();
  weights = std::move(resolved.value());
  // A dense array (indices 0..n-1 in order, no names) shorter than the rig's shapes: likely an
  // array made for another rig, or cut short. The missing weights are 0, and said so.
  const bool dense =
      !entries.empty() && std::all_of(entries.begin(), entries.end(), [&](const WeightEntry& e) {
        return e.name.empty() && e.index == &e - entries.data();
      });
  if (dense && entries.size() < rig.shapes.size()) {
    warnings.push_back({"weights_short",
                        "the weights array has " + std::to_string(entries.size()) +
                            " values for the rig's " + std::to_string(rig.shapes.size()) +
                            " shapes: the other " +
                            std::to_string(rig.shapes.size() - entries.size()) + " are 0",
                        "", static_cast<double>(entries.size()), true});
  }
  FaceState face;
  if (Status s = ResolveExpressions(rig, request.expressions, face.expressions, warnings); !s.ok())
    return s;
  face.gaze = request.gaze;
  if (request.empty()) {
    posed = request.has_face() ? PoseOfFaceAndWeights(rig, face, weights, pose, warnings)
                               : PoseOfWeightsAlone(rig, weights, pose);
    return FiniteFace(weights);
  }
  posed = true;
  std::vector<float> animated;
  std::vector<uint8_t> animated_set;
  if (Status s = BuildPose(rig, request, pose, animated, animated_set, warnings, false); !s.ok())
    return s;
  // Shapes the request names keep their explicit weight; the others take the animated one.
  std::vector<uint8_t> given(rig.shapes.size(), 0);
  for (const WeightEntry& e : entries) {
    long long i = e.name.empty() ? e.index : FindShape(rig, e.name);
    if (i < 0 && !e.name.empty() && e.name.find_first_not_of("0123456789") == std::string::npos &&
        e.name.size() < 10)
      i = std::stoll(e.name);
    if (i >= 0 && static_cast<size_t>(i) < given.size()) given[i] = 1;
  }
  for (size_t s = 0; s < weights.size(); ++s) {
    if (animated_set[s] && !given[s]) weights[s] = animated[s];
  }
  if (request.has_face()) ApplyFace(rig, face, weights, pose, posed, warnings);
  FinishPose(rig, weights, pose);
  return FiniteFace(weights);
}

}  // namespace engine
}  // namespace facespace
