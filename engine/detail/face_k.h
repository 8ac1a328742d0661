// Conformal distortion K = sigma1 / sigma2 of the affine map from a 3D triangle to its uv triangle, in the
// form the inner loops want: the rest triangle's inverse edge matrix once per face, then K per uv position.
// (The quality stage, engine/quality.h, reports K with its own, independent formula.)
#pragma once

#include <cmath>
#include <limits>

#include "engine/geometry.h"

namespace lipmap::detail {

// The inverse of a face's rest edge matrix S = [[q1x, q2x], [0, q2y]] (quality.cpp's frame), or !ok for a
// rest triangle of zero area (no Jacobian: such a face is only kept positive).
struct RestInverse {
  double s00 = 0, s01 = 0, s11 = 0;
  bool ok = false;
};

inline RestInverse rest_inverse(const Point3& p0, const Point3& p1, const Point3& p2) {
  const double ax = p1.x - p0.x, ay = p1.y - p0.y, az = p1.z - p0.z;
  const double bx = p2.x - p0.x, by = p2.y - p0.y, bz = p2.z - p0.z;
  const double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
  const double n = std::sqrt(nx * nx + ny * ny + nz * nz), la = std::sqrt(ax * ax + ay * ay + az * az);
  RestInverse r;
  if (!(n > 0) || !(la > 0) || !std::isfinite(n)) return r;
  const double q1x = la, q2x = (ax * bx + ay * by + az * bz) / la, q2y = n / la;
  r = {1.0 / q1x, -q2x / (q1x * q2y), 1.0 / q2y, true};
  return r;
}

// K of the affine map on one face; +inf unless the uv triangle is positive (floating point). A face without
// a rest Jacobian counts 1 when positive.
inline double face_k(const RestInverse& s, const Point2& u0, const Point2& u1, const Point2& u2) {
  const double dux1 = u1.x - u0.x, duy1 = u1.y - u0.y, dux2 = u2.x - u0.x, duy2 = u2.y - u0.y;
  if (!(dux1 * duy2 - dux2 * duy1 > 0)) return std::numeric_limits<double>::infinity();
  if (!s.ok) return 1;
  const double a = dux1 * s.s00, b = dux1 * s.s01 + dux2 * s.s11, c = duy1 * s.s00, d = duy1 * s.s01 + duy2 * s.s11;
  // sqrt rather than hypot (a tenth of the relaxation's time in libm): these are Jacobian entries of a
  // positive triangle, far from overflow.
  const double q1 = 0.5 * (a + d), q2 = 0.5 * (c - b), r1 = 0.5 * (a - d), r2 = 0.5 * (c + b);
  const double Q = std::sqrt(q1 * q1 + q2 * q2), R = std::sqrt(r1 * r1 + r2 * r2);
  if (!(Q > R)) return std::numeric_limits<double>::infinity();
  return (Q + R) / (Q - R);
}

}  // namespace lipmap::detail
