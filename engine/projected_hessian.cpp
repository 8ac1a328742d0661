// Per-triangle Hessians projected onto the positive semi-definite matrices in closed form, for projected Newton
// (Teran et al. 2005) in engine/uv_descent.cpp: the analytic eigensystem of an isotropic energy of the 2 x 2
// Jacobian (Smith, de Goes & Kim 2019). Declared in engine/detail/uv_descent.h.
#include <algorithm>
#include <array>
#include <cmath>

#include "engine/detail/uv_descent.h"

namespace lipmap::detail {

namespace {

// J = U diag(s1, s2) W with U = rot(phi), W = rot(theta), as cosines and sines.
struct SvdFrame {
  double s1 = 0, s2 = 0;  // s1 >= |s2|; s2 < 0 when det J < 0 (U and W are rotations)
  double cu = 1, su = 0, cw = 1, sw = 0;
};

// |(x, y)|: sqrt of the sum of squares where that neither overflows nor underflows, std::hypot (several
// times slower, and the untangler's Newton steps spent a sixth of their time in it) elsewhere.
double length(double x, double y) {
  const double r = std::sqrt(x * x + y * y);
  return r > 1e-150 && r < 1e150 ? r : std::hypot(x, y);
}

// (cos(a / 2), sin(a / 2)) for a = atan2(y, x) in (-pi, pi], r = |(x, y)| > 0: the principal square root of the
// unit complex number (x + i y) / r, without trigonometric calls. Each form divides by the larger half.
std::array<double, 2> half_angle(double x, double y, double r) {
  const double c = x / r;
  if (c >= 0) {
    const double h = std::sqrt(0.5 * (1 + c));
    return {h, y / r / (2 * h)};
  }
  const double h = std::sqrt(0.5 * (1 - c));
  return {std::abs(y) / r / (2 * h), std::copysign(h, y)};
}

// J = rot(phi) diag(s1, s2) rot(theta): the closed-form signed SVD of a 2 x 2 matrix, with phi = (a2 + a1) / 2
// and theta = (a2 - a1) / 2 for a1 = atan2(G, F), a2 = atan2(H, E) (angle 0 where the vector is zero): the
// rotations come from the half angles as products of unit complex numbers.
SvdFrame svd_frame(double a, double b, double c, double d) {
  const double E = 0.5 * (a + d), F = 0.5 * (a - d), G = 0.5 * (c + b), H = 0.5 * (c - b);
  const double Q = length(E, H), R = length(F, G);
  const std::array<double, 2> h1 = R > 0 ? half_angle(F, G, R) : std::array<double, 2>{1, 0};
  const std::array<double, 2> h2 = Q > 0 ? half_angle(E, H, Q) : std::array<double, 2>{1, 0};
  return {Q + R, Q - R, h2[0] * h1[0] - h2[1] * h1[1], h2[1] * h1[0] + h2[0] * h1[1],
          h2[0] * h1[0] + h2[1] * h1[1], h2[1] * h1[0] - h2[0] * h1[1]};
}

// The projected Hessian of an isotropic energy of J from its eigensystem (Smith, de Goes & Kim 2019): the
// twist and flip modes' eigenvalues and the 2 x 2 Hessian [[f11, f12], [f12, f22]] of the scaling modes
// U diag(e) W in (s1, s2); negative eigenvalues dropped.
std::array<double, 16> assemble_modes(const SvdFrame& m, double twist, double flip, double f11, double f12, double f22) {
  // The eigenmatrix U M W of a mode M, as a row-major 4-vector.
  auto mode = [&](double m00, double m01, double m10, double m11) {
    const double p00 = m.cu * m00 - m.su * m10, p01 = m.cu * m01 - m.su * m11;
    const double p10 = m.su * m00 + m.cu * m10, p11 = m.su * m01 + m.cu * m11;
    return std::array<double, 4>{p00 * m.cw + p01 * m.sw, p01 * m.cw - p00 * m.sw, p10 * m.cw + p11 * m.sw,
                                 p11 * m.cw - p10 * m.sw};
  };
  std::array<double, 16> out{};
  auto add = [&](double lambda, const std::array<double, 4>& q) {  // the upper triangle; mirrored at the end
    if (!(lambda > 0)) return;
    for (int i = 0; i < 4; ++i)
      for (int j = i; j < 4; ++j) out[4 * i + j] += lambda * q[i] * q[j];
  };
  const double r = std::sqrt(0.5);
  add(twist, mode(0, -r, r, 0));
  add(flip, mode(0, r, r, 0));
  const double mean = 0.5 * (f11 + f22), radius = length(0.5 * (f11 - f22), f12);
  const double l1 = mean + radius, l2 = mean - radius;
  // The eigenvector of l1: (f12, l1 - f11) or (l1 - f22, f12), whichever is the better conditioned.
  double ex = f12, ey = l1 - f11;
  if (length(l1 - f22, f12) > length(ex, ey)) ex = l1 - f22, ey = f12;
  const double n = length(ex, ey);
  if (n > 0) {
    ex /= n, ey /= n;
  } else {
    ex = 1, ey = 0;
  }
  add(l1, mode(ex, 0, 0, ey));
  add(l2, mode(-ey, 0, 0, ex));
  for (int i = 1; i < 4; ++i)
    for (int j = 0; j < i; ++j) out[4 * i + j] = out[4 * j + i];
  return out;
}

}  // namespace

std::array<double, 16> projected_mips_hessian(double a, double b, double c, double d) {
  const SvdFrame m = svd_frame(a, b, c, d);
  const double s1 = m.s1, s2 = m.s2;
  if (!(s2 > 0)) return {};
  const double p = s1 * s2, p2 = p * p;
  // f = s1 / s2 + s2 / s1: the twist's eigenvalue is -(s1 - s2)^2 / p^2 <= 0.
  const double flip = 1 / p + (s1 * s1 + s1 * s2 + s2 * s2) / p2;
  const double f11 = 2 * s2 / (s1 * s1 * s1), f22 = 2 * s1 / (s2 * s2 * s2), f12 = -1 / (s1 * s1) - 1 / (s2 * s2);
  return assemble_modes(m, 0, flip, f11, f12, f22);
}

std::array<double, 16> projected_untangle_hessian(double a, double b, double c, double d, double eps, double theta) {
  const SvdFrame m = svd_frame(a, b, c, d);
  const double s1 = m.s1, s2 = m.s2;
  // psi(I2, I3) = N / chi(I3) with I2 = |J|^2 = s1^2 + s2^2, I3 = det J = s1 s2, N = (1 - theta) I2 + theta (I3^2 + 1).
  const double i2 = s1 * s1 + s2 * s2, i3 = s1 * s2;
  const double root = std::sqrt(eps * eps + i3 * i3);
  const double chi = 0.5 * (i3 + root), chi1 = 0.5 * (1 + i3 / root), chi2 = eps * eps / (2 * root * root * root);
  const double n = (1 - theta) * i2 + theta * (i3 * i3 + 1), n3 = 2 * theta * i3;
  // Partial derivatives of psi in I2 and I3 (psi is linear in I2).
  const double p2 = (1 - theta) / chi;
  const double p3 = n3 / chi - n * chi1 / (chi * chi);
  const double p23 = -(1 - theta) * chi1 / (chi * chi);
  const double p33 = 2 * theta / chi - 2 * n3 * chi1 / (chi * chi) - n * chi2 / (chi * chi) +
                     2 * n * chi1 * chi1 / (chi * chi * chi);
  // Along a mode M, I2'' = 2 |M|^2 and I3'' = 2 det M: twist (det 1/2) 2 p2 + p3, flip (det -1/2) 2 p2 - p3; in
  // (s1, s2) the gradients of I2 and I3 are 2 (s1, s2) and (s2, s1), and I3's Hessian is [[0, 1], [1, 0]].
  const double f11 = 2 * p2 + 4 * p23 * i3 + p33 * s2 * s2, f22 = 2 * p2 + 4 * p23 * i3 + p33 * s1 * s1;
  const double f12 = 2 * p23 * i2 + p33 * i3 + p3;
  return assemble_modes(m, 2 * p2 + p3, 2 * p2 - p3, f11, f12, f22);
}

}  // namespace lipmap::detail
