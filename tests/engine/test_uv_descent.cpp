// The shared minimizer of untangle and optimize (engine/detail/uv_descent.h), the parts the stage tests do not
// see on their own:
//   ProjectedMipsHessian   the closed form against the test's own: the explicit Hessian of |J|^2 / det J
//                          (checked against finite differences of the energy), projected numerically with
//                          Eigen's eigensolver, over thousands of random Jacobians from conformal to 1e4:1.
//   NewtonDescent          projected Newton keeps every triangle positive (exact) and the boundary bit for bit,
//                          and with the same step cap it gets lower than L-BFGS, onto the same minimum
//                          from differently jittered starts; for mips and for a power of it.
//   ProjectedUntangleHessian  the same for the untangle energy (folded Jacobians included, eps from 1e-2 to
//                          100 times |det J|) against the test's own explicit Hessian.
//   PoweredMips            the energy with a power (method extremal's smooth max K) against the test's own K,
//                          and its flip-free descent lowers the largest K.
//   UvDescentLarge         from kMultigridMinUnknowns free vertices on (multigrid V-cycle as the preconditioner,
//                          multigrid solve in harmonic()): the same promises on a 217k-triangle grid.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "engine/detail/uv_descent.h"
#include "engine/intermediate_map.h"
#include "engine/validate.h"
#include "tests/support/pipeline_cases.h"

namespace lipmap {
namespace {

// f(J) = |J|^2 / det J for J = (a, b, c, d) row-major.
double mips(const Eigen::Vector4d& x) { return x.squaredNorm() / (x(0) * x(3) - x(1) * x(2)); }

// d2f/dJ2 by hand: with n2 = |J|^2, D = det J, C = dD/dJ = (d, -c, -b, a) and D'' the constant Hessian of D,
// f'' = 2 I / D - 2 (J C^T + C J^T) / D^2 + 2 n2 C C^T / D^3 - n2 D'' / D^2.
Eigen::Matrix4d explicit_hessian(const Eigen::Vector4d& x) {
  const double n2 = x.squaredNorm(), D = x(0) * x(3) - x(1) * x(2);
  const Eigen::Vector4d C(x(3), -x(2), -x(1), x(0));
  Eigen::Matrix4d d2D = Eigen::Matrix4d::Zero();
  d2D(0, 3) = d2D(3, 0) = 1;
  d2D(1, 2) = d2D(2, 1) = -1;
  return 2 / D * Eigen::Matrix4d::Identity() - 2 / (D * D) * (x * C.transpose() + C * x.transpose()) +
         2 * n2 / (D * D * D) * (C * C.transpose()) - n2 / (D * D) * d2D;
}

Eigen::Matrix4d numeric_projection(const Eigen::Matrix4d& H) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(H);
  return eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
}

Eigen::Vector4d random_jacobian(std::mt19937& rng) {
  // rotation * diag(s1, s2) * rotation, s1 / s2 from 1 (conformal) to 1e4, scale from 1e-3 to 1e3.
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), logk(0, 4), logs(-3, 3), pick(0, 1);
  const double k = pick(rng) < 0.1 ? 1.0 : std::pow(10.0, logk(rng)), s = std::pow(10.0, logs(rng));
  const double p = angle(rng), q = angle(rng);
  Eigen::Matrix2d U, W;
  U << std::cos(p), -std::sin(p), std::sin(p), std::cos(p);
  W << std::cos(q), -std::sin(q), std::sin(q), std::cos(q);
  const Eigen::Matrix2d J = U * Eigen::Vector2d(s * std::sqrt(k), s / std::sqrt(k)).asDiagonal() * W;
  return {J(0, 0), J(0, 1), J(1, 0), J(1, 1)};
}

TEST(ProjectedMipsHessian, TheTestsOwnHessianMatchesFiniteDifferencesOfTheEnergy) {
  std::mt19937 rng(7);
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::Vector4d x = random_jacobian(rng);
    x /= std::sqrt(std::abs(x(0) * x(3) - x(1) * x(2)));  // det 1: finite differences at a sane scale
    if (mips(x) > 50) continue;  // and K below about 50, where h = 1e-4 resolves the second derivatives
    ++checked;
    const Eigen::Matrix4d H = explicit_hessian(x);
    const double h = 1e-4, scale = H.cwiseAbs().maxCoeff();
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        Eigen::Vector4d ei = Eigen::Vector4d::Unit(i) * h, ej = Eigen::Vector4d::Unit(j) * h;
        const double fd = (mips(x + ei + ej) - mips(x + ei - ej) - mips(x - ei + ej) + mips(x - ei - ej)) / (4 * h * h);
        ASSERT_NEAR(fd, H(i, j), 1e-4 * scale) << "trial " << trial << " entry " << i << j;
      }
  }
  EXPECT_GE(checked, 80);
}

TEST(ProjectedMipsHessian, ClosedFormIsTheNumericProjectionOfTheExplicitHessian) {
  std::mt19937 rng(11);
  int conformal = 0;
  for (int trial = 0; trial < 5000; ++trial) {
    const Eigen::Vector4d x = random_jacobian(rng);
    const Eigen::Matrix4d expected = numeric_projection(explicit_hessian(x));
    const std::array<double, 16> got = detail::projected_mips_hessian(x(0), x(1), x(2), x(3));
    const double scale = expected.cwiseAbs().maxCoeff();
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        ASSERT_NEAR(got[4 * i + j], expected(i, j), 1e-7 * scale) << "trial " << trial << " entry " << i << j;
    Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>> G(got.data());
    ASSERT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(G).eigenvalues().minCoeff(), -1e-9 * scale);
    if (std::abs(x(0) - x(3)) < 1e-12 * scale && std::abs(x(1) + x(2)) < 1e-12 * scale) ++conformal;
  }
  EXPECT_GT(conformal, 100);  // the degenerate SVD (s1 = s2) was exercised
}

// The untangle energy of Garanzha et al. 2021, written out here: ((1 - th) |J|^2 + th (det^2 + 1)) / chi(det, eps)
// with chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2.
double untangle_energy(const Eigen::Vector4d& x, double eps, double th) {
  const double D = x(0) * x(3) - x(1) * x(2);
  return ((1 - th) * x.squaredNorm() + th * (D * D + 1)) / (0.5 * (D + std::sqrt(eps * eps + D * D)));
}

// Its Hessian by hand, N / chi with N = (1 - th) |J|^2 + th (D^2 + 1), C = dD/dJ, D'' as above:
// N' = 2 (1 - th) J + 2 th D C, N'' = 2 (1 - th) I + 2 th (C C^T + D D''), chi' = c1 C, chi'' = c2 C C^T + c1 D'',
// (N / chi)'' = N'' / chi - (N' chi'^T + chi' N'^T) / chi^2 + 2 N chi' chi'^T / chi^3 - N chi'' / chi^2.
Eigen::Matrix4d explicit_untangle_hessian(const Eigen::Vector4d& x, double eps, double th) {
  const double D = x(0) * x(3) - x(1) * x(2), r = std::sqrt(eps * eps + D * D);
  const double chi = 0.5 * (D + r), c1 = 0.5 * (1 + D / r), c2 = eps * eps / (2 * r * r * r);
  const double N = (1 - th) * x.squaredNorm() + th * (D * D + 1);
  const Eigen::Vector4d C(x(3), -x(2), -x(1), x(0));
  Eigen::Matrix4d d2D = Eigen::Matrix4d::Zero();
  d2D(0, 3) = d2D(3, 0) = 1;
  d2D(1, 2) = d2D(2, 1) = -1;
  const Eigen::Vector4d dN = 2 * (1 - th) * x + 2 * th * D * C, dchi = c1 * C;
  const Eigen::Matrix4d d2N = 2 * (1 - th) * Eigen::Matrix4d::Identity() + 2 * th * (C * C.transpose() + D * d2D);
  const Eigen::Matrix4d d2chi = c2 * C * C.transpose() + c1 * d2D;
  return d2N / chi - (dN * dchi.transpose() + dchi * dN.transpose()) / (chi * chi) +
         2 * N * dchi * dchi.transpose() / (chi * chi * chi) - N * d2chi / (chi * chi);
}

// Folded Jacobians too: a reflection of half of random_jacobian's.
Eigen::Vector4d random_signed_jacobian(std::mt19937& rng) {
  Eigen::Vector4d x = random_jacobian(rng);
  if (std::uniform_int_distribution<int>(0, 1)(rng)) x(1) = -x(1), x(3) = -x(3);  // J diag(1, -1): det < 0
  return x;
}

TEST(ProjectedUntangleHessian, TheTestsOwnHessianMatchesFiniteDifferencesOfTheEnergy) {
  std::mt19937 rng(17);
  int checked = 0, folded = 0;
  for (int trial = 0; trial < 400; ++trial) {
    Eigen::Vector4d x = random_signed_jacobian(rng);
    x /= std::sqrt(std::abs(x(0) * x(3) - x(1) * x(2)));  // |det| 1
    if (x.squaredNorm() > 20) continue;  // moderate stretch, where h = 1e-4 resolves the second derivatives
    const double eps = std::pow(10.0, std::uniform_real_distribution<double>(-1, 0)(rng)), th = 1.0 / 128;
    ++checked;
    folded += x(0) * x(3) - x(1) * x(2) < 0;
    const Eigen::Matrix4d H = explicit_untangle_hessian(x, eps, th);
    const double h = 1e-4, scale = H.cwiseAbs().maxCoeff();
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        const Eigen::Vector4d ei = Eigen::Vector4d::Unit(i) * h, ej = Eigen::Vector4d::Unit(j) * h;
        const double fd = (untangle_energy(x + ei + ej, eps, th) - untangle_energy(x + ei - ej, eps, th) -
                           untangle_energy(x - ei + ej, eps, th) + untangle_energy(x - ei - ej, eps, th)) / (4 * h * h);
        ASSERT_NEAR(fd, H(i, j), 1e-4 * scale) << "trial " << trial << " entry " << i << j;
      }
  }
  EXPECT_GE(checked, 100);
  EXPECT_GE(folded, 30);
}

TEST(ProjectedUntangleHessian, ClosedFormIsTheNumericProjectionOfTheExplicitHessian) {
  std::mt19937 rng(23);
  int folded = 0, indefinite = 0;
  for (int trial = 0; trial < 5000; ++trial) {
    const Eigen::Vector4d x = random_signed_jacobian(rng);
    const double D = x(0) * x(3) - x(1) * x(2);
    // eps from 1e-2 to 1e2 times |det J|. Far below, chi = (D + sqrt(eps^2 + D^2)) / 2 of a folded face is the
    // difference of two nearly equal numbers (at 1e-4 |D|, 8 digits lost) in both forms alike.
    const double eps = std::abs(D) * std::pow(10.0, std::uniform_real_distribution<double>(-2, 2)(rng));
    const double th = trial % 2 ? 1.0 / 128 : 0.5;
    const Eigen::Matrix4d H = explicit_untangle_hessian(x, eps, th);
    const Eigen::Matrix4d expected = numeric_projection(H);
    const std::array<double, 16> got = detail::projected_untangle_hessian(x(0), x(1), x(2), x(3), eps, th);
    const double scale = H.cwiseAbs().maxCoeff();
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        ASSERT_NEAR(got[4 * i + j], expected(i, j), 1e-7 * scale) << "trial " << trial << " entry " << i << j;
    folded += D < 0;
    indefinite += Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(H).eigenvalues().minCoeff() < -1e-9 * scale;
  }
  EXPECT_GT(folded, 1000);
  EXPECT_GT(indefinite, 1000);  // the projection did something
}

// A bumpy grid with a positive but distorted start (the flat grid squeezed towards a corner, interior
// jittered), as test_optimize.cpp makes it.
struct Start {
  DiskMesh mesh;
  std::vector<Point2> uv;
  std::vector<char> pinned;
};

Start distorted_grid(int n, unsigned seed) {
  const RawMesh m = pipelinecases::bumpy_grid(n);
  Start s{validate_mesh(m), {}, {}};
  s.pinned.assign(s.mesh.vertices.size(), 0);
  for (int v : s.mesh.boundary_loop) s.pinned[v] = 1;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.3 / n, 0.3 / n);
  for (std::size_t v = 0; v < s.mesh.vertices.size(); ++v) {
    const Point3& p = s.mesh.vertices[v];
    Point2 q{p.x * p.x, std::pow(p.y, 1.7)};
    if (!s.pinned[v]) q = {q.x + jitter(rng) * q.x, q.y + jitter(rng) * q.y};
    s.uv.push_back(q);
  }
  return s;
}

TEST(NewtonDescent, KeepsTrianglesPositiveAndTheBoundaryAndReachesTheSameMinimumFromEveryStart) {
  // mips itself (the optimize stage) and a power of it (method extremal's descent: (mips / 2b)^p, b fixed here
  // so that every start minimizes the same function).
  int cases = 0;
  for (double power : {1.0, 8.0})
  for (int n : {8, 16, 24}) {
    std::vector<double> minima;
    for (unsigned seed = 1; seed <= 4; ++seed) {
      const Start s = distorted_grid(n, seed);
      if (pipelinecases::count_folded_by_checker(s.uv, s.mesh.faces) > 0) continue;
      ++cases;
      const std::string where = "p " + std::to_string(power) + " n " + std::to_string(n) + " seed " + std::to_string(seed);
      detail::DescentSettings settings;
      settings.energy = detail::UvEnergy::mips;
      settings.power = power;
      settings.power_base = 1.5;
      settings.max_iterations = 30;
      settings.relative_tolerance = 0;
      std::vector<Point2> by_newton = s.uv, by_lbfgs = s.uv;
      detail::UvDescent newton(s.mesh.vertices, s.mesh.faces, s.pinned, 1.0);
      settings.newton = true;
      const detail::DescentOutcome a = newton.minimize(by_newton, settings);
      detail::UvDescent lbfgs(s.mesh.vertices, s.mesh.faces, s.pinned, 1.0);
      settings.newton = false;
      const detail::DescentOutcome b = lbfgs.minimize(by_lbfgs, settings);
      EXPECT_EQ(pipelinecases::count_folded_by_checker(by_newton, s.mesh.faces), 0) << where;
      for (int v : s.mesh.boundary_loop) EXPECT_TRUE(by_newton[v] == s.uv[v]) << where << ": boundary vertex " << v;
      EXPECT_LT(a.energy_after, b.energy_after) << where << ": Newton not lower than L-BFGS in the same 30 steps";
      minima.push_back(a.energy_after);
    }
    // Each seed jitters the start differently; converged, Newton lands on the same minimum from all of them
    // (L-BFGS, after as many steps, is still above it and differs from seed to seed).
    for (double e : minima) EXPECT_NEAR(e, minima.front(), 1e-6 * minima.front()) << "p " << power << " n " << n;
  }
  ASSERT_GE(cases, 16);
}

// K = sigma1 / sigma2 of a triangle's map from 3D to uv, from the eigenvalues of G^-1 H (the first fundamental
// forms of the 3D and uv triangles in one edge basis); +inf when the uv triangle is not positive.
double triangle_k(const Point3& a, const Point3& b, const Point3& c, const Point2& ua, const Point2& ub, const Point2& uc) {
  const double e1[3] = {b.x - a.x, b.y - a.y, b.z - a.z}, e2[3] = {c.x - a.x, c.y - a.y, c.z - a.z};
  const double g11 = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2], g12 = e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2],
               g22 = e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2];
  const double u1x = ub.x - ua.x, u1y = ub.y - ua.y, u2x = uc.x - ua.x, u2y = uc.y - ua.y;
  if (!(u1x * u2y - u1y * u2x > 0)) return INFINITY;
  const double h11 = u1x * u1x + u1y * u1y, h12 = u1x * u2x + u1y * u2y, h22 = u2x * u2x + u2y * u2y;
  const double dg = g11 * g22 - g12 * g12;
  const double tr = (g22 * h11 - 2 * g12 * h12 + g11 * h22) / dg, det = (h11 * h22 - h12 * h12) / dg;
  const double disc = std::sqrt(std::max(tr * tr / 4 - det, 0.0));
  return std::sqrt((tr / 2 + disc) / (tr / 2 - disc));
}

double triangle_area(const Point3& a, const Point3& b, const Point3& c) {
  const double e1[3] = {b.x - a.x, b.y - a.y, b.z - a.z}, e2[3] = {c.x - a.x, c.y - a.y, c.z - a.z};
  const double x = e1[1] * e2[2] - e1[2] * e2[1], y = e1[2] * e2[0] - e1[0] * e2[2], z = e1[0] * e2[1] - e1[1] * e2[0];
  return 0.5 * std::sqrt(x * x + y * y + z * z);
}

// Calls f(start, name, seed) on distorted_grid(n, seed) for n 8, 16 and seeds 1..3, the unfolded ones; says how many.
template <class F>
int for_unfolded_grids(F&& f) {
  int cases = 0;
  for (int n : {8, 16})
    for (unsigned seed = 1; seed <= 3; ++seed) {
      const Start s = distorted_grid(n, seed);
      if (pipelinecases::count_folded_by_checker(s.uv, s.mesh.faces) > 0) continue;
      ++cases;
      f(s, "n " + std::to_string(n) + " seed " + std::to_string(seed), seed);
    }
  return cases;
}

TEST(PoweredMips, IsTheAreaWeightedMeanOfThePowerAndItsDescentLowersTheLargestK) {
  // The energy with power p and base b is the 3D-area-weighted mean of (((K + 1/K) / 2) / b)^p (mips = K + 1/K
  // for any scale of the rest shapes), checked with this file's own K; a flip-free descent with growing p keeps
  // every triangle positive and the boundary bit for bit, and lowers the largest K of the start (over the faces
  // with a free corner).
  const int cases = for_unfolded_grids([&](const Start& s, const std::string& where, unsigned) {
    // Over the faces with a free corner (the others, e.g. at the grid's corners, cannot change).
    auto max_k = [&](const std::vector<Point2>& uv) {
      double m = 1;
      for (const Triangle& t : s.mesh.faces)
        if (!s.pinned[t[0]] || !s.pinned[t[1]] || !s.pinned[t[2]])
          m = std::max(m, triangle_k(s.mesh.vertices[t[0]], s.mesh.vertices[t[1]], s.mesh.vertices[t[2]], uv[t[0]],
                                   uv[t[1]], uv[t[2]]));
      return m;
    };
    const double k0 = max_k(s.uv), base = 0.5 * (k0 + 1 / k0);
    detail::UvDescent descent(s.mesh.vertices, s.mesh.faces, s.pinned, 1.0);
    detail::DescentSettings settings;
    settings.energy = detail::UvEnergy::mips;
    settings.power_base = base;
    for (double p : {1.0, 3.0, 8.0}) {
      settings.power = p;
      double sum = 0, area = 0;
      for (const Triangle& t : s.mesh.faces) {
        const Point3 &a = s.mesh.vertices[t[0]], &b = s.mesh.vertices[t[1]], &c = s.mesh.vertices[t[2]];
        const double k = triangle_k(a, b, c, s.uv[t[0]], s.uv[t[1]], s.uv[t[2]]);
        const double w = triangle_area(a, b, c);
        sum += w * (p == 1 ? k + 1 / k : std::pow(0.5 * (k + 1 / k) / base, p));
        area += w;
      }
      EXPECT_NEAR(descent.energy(s.uv, settings), sum / area, 1e-9 * sum / area) << where << " p " << p;
    }
    std::vector<Point2> uv = s.uv;
    settings.max_iterations = 100;
    for (double p : {2.0, 4.0, 8.0, 16.0}) {
      settings.power = p;
      const double before = descent.energy(uv, settings);
      const detail::DescentOutcome out = descent.minimize(uv, settings);
      EXPECT_LT(out.energy_after, before) << where << " p " << p << ": the descent did not lower its energy";
    }
    EXPECT_EQ(pipelinecases::count_folded_by_checker(uv, s.mesh.faces), 0) << where;
    for (int v : s.mesh.boundary_loop) EXPECT_TRUE(uv[v] == s.uv[v]) << where << ": boundary vertex " << v;
    EXPECT_LT(max_k(uv), k0) << where;
  });
  ASSERT_GE(cases, 4);
}

TEST(UvDescentOutcome, ReportsTheMeanEnergyOfTheMapBeforeAndAfterFacesWithoutAFreeCornerIncluded) {
  // minimize reports the energy at both ends from its own passes over the faces with a free corner plus the
  // constant of the others; here it is recomputed from this file's own K over every face (mips = K + 1/K,
  // 3D-area-weighted), with every fourth interior vertex pinned too so that many faces have no free corner.
  int fixed_faces = 0;
  const int cases = for_unfolded_grids([&](const Start& s, const std::string& where, unsigned) {
    std::vector<char> pinned = s.pinned;
    for (std::size_t v = 0; v < pinned.size(); v += 4) pinned[v] = 1;
    auto mean_mips = [&](const std::vector<Point2>& uv) {
      double sum = 0, area = 0;
      for (const Triangle& t : s.mesh.faces) {
        const Point3 &a = s.mesh.vertices[t[0]], &b = s.mesh.vertices[t[1]], &c = s.mesh.vertices[t[2]];
        const double k = triangle_k(a, b, c, uv[t[0]], uv[t[1]], uv[t[2]]), w = triangle_area(a, b, c);
        sum += w * (k + 1 / k);
        area += w;
      }
      return sum / area;
    };
    for (const Triangle& t : s.mesh.faces) fixed_faces += pinned[t[0]] && pinned[t[1]] && pinned[t[2]];
    for (bool newton : {false, true}) {
      detail::UvDescent descent(s.mesh.vertices, s.mesh.faces, pinned, 1.0);
      detail::DescentSettings settings;
      settings.energy = detail::UvEnergy::mips;
      settings.newton = newton;
      settings.max_iterations = 20;
      std::vector<Point2> uv = s.uv;
      const double before = mean_mips(uv);
      const detail::DescentOutcome out = descent.minimize(uv, settings);
      const std::string how = where + (newton ? " (Newton)" : " (L-BFGS)");
      ASSERT_GT(out.iterations, 0) << how;
      EXPECT_NEAR(out.energy_before, before, 1e-9 * before) << how;
      EXPECT_NEAR(out.energy_after, mean_mips(uv), 1e-9 * before) << how;
      EXPECT_LT(out.energy_after, out.energy_before) << how;
    }
  });
  ASSERT_GE(cases, 4);
  EXPECT_GT(fixed_faces, 20);  // the constant part was exercised
}

TEST(PoweredMips, WithPerFaceBasesIsTheWeightedPNormAndItsDescentKeepsItsPromises) {
  // DescentSettings::face_base: face f's term is (((K + 1/K) / 2) / base_f)^p (method extremal's interior
  // polish). Checked with this file's own K over random per-face bases; with every base equal it is the single
  // power_base's energy; Newton and L-BFGS both lower it, keep every triangle positive and the boundary bit for bit.
  const int cases = for_unfolded_grids([&](const Start& s, const std::string& where, unsigned seed) {
    // Bases around the start's largest (K + 1/K) / 2 (as the polish's, which are near the faces' own), so that
    // the terms neither overflow nor vanish.
    double top = 1;
    for (const Triangle& t : s.mesh.faces) {
      const double k = triangle_k(s.mesh.vertices[t[0]], s.mesh.vertices[t[1]], s.mesh.vertices[t[2]], s.uv[t[0]],
                                  s.uv[t[1]], s.uv[t[2]]);
      top = std::max(top, 0.5 * (k + 1 / k));
    }
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> pick(0.7 * top, 1.3 * top);
    std::vector<double> bases(s.mesh.faces.size());
    for (double& b : bases) b = pick(rng);
    detail::UvDescent descent(s.mesh.vertices, s.mesh.faces, s.pinned, 1.0);
    detail::DescentSettings settings;
    settings.energy = detail::UvEnergy::mips;
    settings.face_base = &bases;
    for (double p : {2.0, 8.0}) {
      settings.power = p;
      double sum = 0, area = 0;
      for (std::size_t f = 0; f < s.mesh.faces.size(); ++f) {
        const Triangle& t = s.mesh.faces[f];
        const Point3 &a = s.mesh.vertices[t[0]], &b = s.mesh.vertices[t[1]], &c = s.mesh.vertices[t[2]];
        const double k = triangle_k(a, b, c, s.uv[t[0]], s.uv[t[1]], s.uv[t[2]]);
        const double w = triangle_area(a, b, c);
        sum += w * std::pow(0.5 * (k + 1 / k) / bases[f], p);
        area += w;
      }
      EXPECT_NEAR(descent.energy(s.uv, settings), sum / area, 1e-9 * sum / area) << where << " p " << p;
    }
    std::vector<double> same(s.mesh.faces.size(), 1.7);
    detail::DescentSettings uniform = settings;
    uniform.face_base = &same;
    detail::DescentSettings single = settings;
    single.face_base = nullptr;
    single.power_base = 1.7;
    EXPECT_DOUBLE_EQ(descent.energy(s.uv, uniform), descent.energy(s.uv, single)) << where;
    for (bool newton : {true, false}) {
      std::vector<Point2> uv = s.uv;
      settings.newton = newton;
      settings.max_iterations = 30;
      // Up to p = 16: beyond, energy() (the mean over every face) is ruled by the grid's corner faces, whose
      // corners are all pinned, and cannot show the drop of the free faces' terms (at p = 32 the descent still
      // lowers their sum, from about 1e-23, while the mean stays at 1e-2).
      for (double p : {2.0, 4.0, 8.0, 16.0}) {
        settings.power = p;
        const double before = descent.energy(uv, settings);
        const detail::DescentOutcome out = descent.minimize(uv, settings);
        EXPECT_LT(out.energy_after, before) << where << " newton " << newton << " p " << p;
      }
      EXPECT_EQ(pipelinecases::count_folded_by_checker(uv, s.mesh.faces), 0) << where << " newton " << newton;
      for (int v : s.mesh.boundary_loop) EXPECT_TRUE(uv[v] == s.uv[v]) << where << ": boundary vertex " << v;
    }
  });
  ASSERT_GE(cases, 4);
}

}  // namespace
}  // namespace lipmap

namespace lipmap {
namespace {

TEST(UvDescentLarge, AboveTheMultigridThresholdTheDescentKeepsItsPromises) {
  Start s = distorted_grid(330, 1);
  for (unsigned seed = 2; seed <= 4 && pipelinecases::count_folded_by_checker(s.uv, s.mesh.faces) > 0; ++seed)
    s = distorted_grid(330, seed);
  ASSERT_EQ(pipelinecases::count_folded_by_checker(s.uv, s.mesh.faces), 0);
  detail::UvDescent descent(s.mesh.vertices, s.mesh.faces, s.pinned, 1.0);
  ASSERT_GE(descent.free_vertices(), kMultigridMinUnknowns);
  detail::DescentSettings settings;
  settings.energy = detail::UvEnergy::mips;
  settings.max_iterations = 15;
  settings.relative_tolerance = 0;
  std::vector<Point2> uv = s.uv;
  const detail::DescentOutcome out = descent.minimize(uv, settings);
  EXPECT_EQ(pipelinecases::count_folded_by_checker(uv, s.mesh.faces), 0);
  for (int v : s.mesh.boundary_loop) EXPECT_TRUE(uv[v] == s.uv[v]) << "boundary vertex " << v;
  EXPECT_LT(out.energy_after, out.energy_before);
  EXPECT_GE(out.iterations, 10);  // the preconditioned directions keep descending, not one lucky step

  // A high power of mips (method extremal's smooth max K runs p up to 256): the reweighted Laplacian's weights
  // (mips / 2b)^(p - 1) span tens of decades, beyond float's range; the preconditioner must stay usable (a
  // hierarchy built for the scaled matrix, or the factor when none can be built), never NaN.
  {
    detail::UvDescent powered(s.mesh.vertices, s.mesh.faces, s.pinned, 1.0);
    detail::DescentSettings p = settings;
    p.power = 64;
    // The base at the start's largest (K + 1/K) / 2 (= mips / 2), as method extremal sets it: every face's term
    // at most 1, the smallest ones (and their weights) near 1e-60 and below.
    double base = 1;
    for (const Triangle& t : s.mesh.faces) {
      const double k = triangle_k(s.mesh.vertices[t[0]], s.mesh.vertices[t[1]], s.mesh.vertices[t[2]], s.uv[t[0]],
                                  s.uv[t[1]], s.uv[t[2]]);
      base = std::max(base, 0.5 * (k + 1 / k));
    }
    p.power_base = 1.01 * base;
    std::printf("[ large ] base %g, smallest weight about %g\n", base, std::pow(1 / p.power_base, 63));
    p.max_iterations = 8;
    std::vector<Point2> q = s.uv;
    const detail::DescentOutcome o = powered.minimize(q, p);
    EXPECT_EQ(pipelinecases::count_folded_by_checker(q, s.mesh.faces), 0);
    EXPECT_TRUE(std::isfinite(o.energy_after));
    EXPECT_LT(o.energy_after, o.energy_before);
    EXPECT_GE(o.iterations, 4);
  }

  // harmonic() is one exact Newton step on the (quadratic) Dirichlet energy: from its own answer it moves
  // nothing but rounding.
  std::vector<Point2> once = s.uv;
  descent.harmonic(once);
  std::vector<Point2> twice = once;
  descent.harmonic(twice);
  double moved = 0, extent = 0;
  for (std::size_t v = 0; v < once.size(); ++v) {
    moved = std::max({moved, std::fabs(twice[v].x - once[v].x), std::fabs(twice[v].y - once[v].y)});
    extent = std::max({extent, std::fabs(once[v].x - s.uv[v].x), std::fabs(once[v].y - s.uv[v].y)});
  }
  EXPECT_GT(extent, 1e-6);  // the first step did move the jittered start
  EXPECT_LE(moved, 1e-9);
}

}  // namespace
}  // namespace lipmap
