// The cubic Bezier curves animation formats key with (FBX cubic keys, COLLADA BEZIER, MMD's VMD
// interpolation, CSS's cubic-bezier transitions): a curve (x0, y0) .. (x3, y3) whose x rises
// monotonically, evaluated at an x.
#pragma once

#include <array>

namespace facespace {
inline namespace engine {

// One coordinate of the cubic Bezier a, b, c, d at parameter s in [0, 1].
inline double CubicBezier(double a, double b, double c, double d, double s) {
  const double r = 1.0 - s;
  return r * r * r * a + 3 * r * r * s * b + 3 * r * s * s * c + s * s * s * d;
}

// The parameter s where the curve's x is `x` (x(s) must rise, as it does when x1 and x2 lie
// between x0 and x3), by bisection to 2^-60.
inline double BezierParameterAtX(double x0, double x1, double x2, double x3, double x) {
  double lo = 0.0, hi = 1.0;
  for (int it = 0; it < 60; ++it) {
    const double s = 0.5 * (lo + hi);
    (CubicBezier(x0, x1, x2, x3, s) < x ? lo : hi) = s;
  }
  return 0.5 * (lo + hi);
}

// The y of the curve where its x is `x`.
inline double BezierYAtX(double x0, double x1, double x2, double x3, double y0, double y1,
                         double y2, double y3, double x) {
  return CubicBezier(y0, y1, y2, y3, BezierParameterAtX(x0, x1, x2, x3, x));
}

// The control points of the part of one coordinate's curve between parameters s0 < s1 (de
// Casteljau): the same curve, reparameterised over [0, 1].
inline std::array<double, 4> BezierPart(const std::array<double, 4>& p, double s0, double s1) {
  // Split at s1, keep the left; split that at s0 / s1, keep the right.
  const auto split = [](const std::array<double, 4>& q, double s, bool keep_left) {
    const double a = q[0] + s * (q[1] - q[0]), b = q[1] + s * (q[2] - q[1]),
                 c = q[2] + s * (q[3] - q[2]);
    const double ab = a + s * (b - a), bc = b + s * (c - b), at = ab + s * (bc - ab);
    return keep_left ? std::array<double, 4>{q[0], a, ab, at}
                     : std::array<double, 4>{at, bc, c, q[3]};
  };
  const std::array<double, 4> l = s1 < 1.0 ? split(p, s1, true) : p;
  return s0 > 0.0 && s1 > 0.0 ? split(l, s0 / s1, false) : l;
}

}  // namespace engine
}  // namespace facespace
