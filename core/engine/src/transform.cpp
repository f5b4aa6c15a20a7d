// Transforms: TRS, quaternions, column-major matrices.
#include "facespace/engine/transform.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace facespace {
inline namespace engine {

using Quat = std::array<float, 4>;

Quat NormalizedQuaternion(Quat q) {
  const float len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(len > 0.0f) || !std::isfinite(len)) return {0, 0, 0, 1};
  for (float& c : q) c /= len;
  return q;
}

std::array<float, 16> ComposeTrs(const Transform& t) {
  Eigen::Affine3f a = Eigen::Affine3f::Identity();
  a.translate(Eigen::Vector3f(t.translation[0], t.translation[1], t.translation[2]));
  a.rotate(
      Eigen::Quaternionf(t.rotation[3], t.rotation[0], t.rotation[1], t.rotation[2]).normalized());
  a.scale(Eigen::Vector3f(t.scale[0], t.scale[1], t.scale[2]));
  std::array<float, 16> m;
  std::copy(a.matrix().data(), a.matrix().data() + 16, m.begin());
  return m;
}

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
    return NormalizedQuaternion(r);
  }
  const float theta = std::acos(std::min(dot, 1.0f));
  const float s = std::sin(theta);
  const float wa = std::sin((1.0f - t) * theta) / s, wb = std::sin(t * theta) / s;
  Quat r;
  for (int i = 0; i < 4; ++i) r[i] = wa * a[i] + wb * b[i];
  return NormalizedQuaternion(r);
}

Quat EulerToQuaternion(float x_deg, float y_deg, float z_deg) {
  const float k = static_cast<float>(M_PI) / 180.0f;
  const Eigen::Quaternionf q = Eigen::AngleAxisf(z_deg * k, Eigen::Vector3f::UnitZ()) *
                               Eigen::AngleAxisf(y_deg * k, Eigen::Vector3f::UnitY()) *
                               Eigen::AngleAxisf(x_deg * k, Eigen::Vector3f::UnitX());
  return {q.x(), q.y(), q.z(), q.w()};
}

}  // namespace engine
}  // namespace facespace
