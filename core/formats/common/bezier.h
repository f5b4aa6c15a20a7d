// The cubic Bezier curves animation formats key with (FBX cubic keys, COLLADA BEZIER, MMD's VMD
// interpolation): a curve (x0, y0) .. (x3, y3) whose x rises monotonically, evaluated at an x.
#pragma once

namespace facespace {

// One coordinate of the cubic Bezier a, b, c, d at parameter s in [0, 1].
inline double CubicBezier(double a, double b, double c, double d, double s) {
  const double r = 1.0 - s;
  return r * r * r * a + 3 * r * r * s * b + 3 * r * s * s * c + s * s * s * d;
}

// The y of the curve where its x is `x`: the parameter found by bisection (x(s) must rise, as it
// does when x1 and x2 lie between x0 and x3), to 2^-60.
inline double BezierYAtX(double x0, double x1, double x2, double x3, double y0, double y1, double y2, double y3, double x) {
  double lo = 0.0, hi = 1.0, s = 0.5;
  for (int it = 0; it < 60; ++it) {
    s = 0.5 * (lo + hi);
    (CubicBezier(x0, x1, x2, x3, s) < x ? lo : hi) = s;
  }
  return CubicBezier(y0, y1, y2, y3, s);
}

}  // namespace facespace
