// The minimizer shared by the stages "untangle" and "optimize": a sum over triangles of an energy of each
// triangle's Jacobian J (3D triangle -> uv triangle), minimized over the uv of the free vertices while the
// pinned ones (the boundary, always) keep their uv bit for bit: they are eliminated, never soft constraints.
//
// Method: L-BFGS (Nocedal & Wright, Alg. 7.4) whose initial inverse Hessian is the inverse of a Dirichlet
// Laplacian (the "Laplacian preconditioned" quasi-Newton of Zhu, Bridson & Kaufman 2018, Blended Cured
// Quasi-Newton, and of Kovalsky, Galun & Lipman 2016, AQP): one sparse back-solve per iteration, no Hessian
// assembly. The rest mesh's Laplacian is analysed and factorized once with CHOLMOD; for mips and symmetric
// Dirichlet each minimize call refactorizes it (numerically) with every triangle's term scaled by its energy's
// Hessian with det J frozen at the starting map (mips: 1 / det J), since these energies' curvature follows the
// area ratio, which on stretched targets spans orders of magnitude (bench_quality, 14 meshes x 4 targets x 3
// seeds: median mean K ratio to the certificate 0.609 -> 0.595, in 38.0 s of optimization instead of 42.6 s).
// Or, for mips and untangle (DescentSettings::newton; the optimize stage runs it after L-BFGS, the untangler when
// L-BFGS left folds), projected Newton (Teran, Sifakis, Irving & Fedkiw 2005): the sum of the triangles'
// Hessians, each projected onto the positive semi-definite matrices in closed form, refactorized (numerically;
// its pattern is analysed once) at every step. Far costlier per step, it converges where L-BFGS crawls on
// MIPS's flat valleys and on the untangle energy of thin, strongly stretched meshes.
// Energies (per triangle, weighted by rest area):
//   mips                 tr(J^T J) / det J = K + 1/K with K = sigma1 / sigma2 (Hormann & Greiner 2000): lowers
//                        exactly the conformal distortion the quality stage reports; +inf when det J <= 0.
//                        With DescentSettings::power p > 1: (mips / (2 base))^p, a p-norm of K (method extremal).
//   symmetric_dirichlet  |J|^2 + |J^-1|^2 (Smith & Schaefer 2015, Rabinovich et al. 2017): conformal and
//                        area distortion together; +inf when det J <= 0.
//   untangle             Garanzha et al. 2021 ("Foldover-free maps in 50 lines of code"), 2D:
//                        (1 - theta) tr(J^T J) / chi(det J, eps) + theta (det^2 J + 1) / chi(det J, eps) with
//                        chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2 > 0: finite for folded triangles, and as eps
//                        decreases it tends to a barrier that keeps det J > 0.
// With flip_free (mips, symmetric_dirichlet) every accepted step keeps every triangle strictly positive:
// the step is bounded by the first t at which some det(J(t)) = 0 (Smith & Schaefer 2015, "Bijective
// parameterization with free boundaries", 4.1: a quadratic in t per triangle), then backtracked (Armijo),
// and the accepted positions are checked with the engine's exact orientation predicate.
// The rest shape of each triangle is its 3D triangle in a local frame, scaled so that the rest areas add up
// to the uv area (so det J is about 1 for an area-preserving map); a 3D triangle of (nearly) zero area gets
// an equilateral rest shape of the mean area, so that it has a Jacobian (its uv triangle is still kept
// positive).
#pragma once

#include <array>
#include <chrono>
#include <memory>
#include <vector>

#include "engine/cancel.h"
#include "engine/geometry.h"

namespace lipmap::detail {

enum class UvEnergy { mips, symmetric_dirichlet, untangle };

struct DescentSettings {
  UvEnergy energy = UvEnergy::mips;
  double epsilon = 0;        // untangle only: chi's regularization
  double theta = 1.0 / 128;  // untangle only: weight of the area term (Garanzha et al. 2021 use a small one)
  bool flip_free = true;     // mips / symmetric_dirichlet: every accepted step keeps every triangle positive
  // mips (any power) and untangle: projected Newton steps (the sum of the triangles' Hessians, each projected
  // onto the positive semi-definite matrices, factorized at every step) instead of L-BFGS; after a Newton step
  // that the line search cannot accept, L-BFGS goes on from there.
  bool newton = false;
  // mips only: minimize the sum of (mips / (2 power_base))^power instead (power >= 1; 1: mips itself). A
  // growing power weighs the worst triangles more and more, a smooth stand-in for the largest K (method
  // extremal); power_base (the starting map's worst mips / 2, say) keeps the terms from overflowing.
  double power = 1;
  double power_base = 1;
  // mips with power p: when given (one per face of the constructor's list, each > 0), face f's term is
  // (mips / (2 face_base[f]))^p instead, a weighted p-norm: a face whose base is its own mips / 2 starts at 1
  // and can hardly rise at a large p.
  const std::vector<double>* face_base = nullptr;
  int max_iterations = 100;
  double relative_tolerance = 1e-7;  // stop when one iteration lowers the energy by less than this fraction
  // untangle: stop as soon as every face is strictly positive (exact predicate). The untangler's job ends
  // there (optimize lowers the distortion next); minimizing each eps round to convergence cost up to 1000
  // steps on 50k-face meshes whose last fold had long been undone.
  bool stop_when_positive = false;
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
  const CancelToken* cancel = nullptr;
};

struct DescentOutcome {
  int iterations = 0;                      // accepted steps
  double energy_before = 0, energy_after = 0;  // rest-area-weighted means
  bool converged = false;                  // stopped by the tolerance (not by a cap, the deadline or a stall)
  bool positive = false;                   // stop_when_positive: stopped because every face is positive
};

class UvDescent {
public:
  // pinned[v]: vertex v keeps its uv. uv_area: the signed area of the uv domain (the boundary polygon's
  // shoelace area, the area of the immersed disk), used to scale the rest shapes.
  UvDescent(const std::vector<Point3>& vertices, const std::vector<Triangle>& faces, const std::vector<char>& pinned,
            double uv_area);
  ~UvDescent();
  UvDescent(const UvDescent&) = delete;
  UvDescent& operator=(const UvDescent&) = delete;

  int free_vertices() const;
  // Rest-area-weighted mean of the energy; +inf for mips / symmetric_dirichlet when a triangle is not positive.
  double energy(const std::vector<Point2>& uv, const DescentSettings& settings) const;
  // The smallest det J over the faces (floating point; the exact test is orientation_sign).
  double min_det(const std::vector<Point2>& uv) const;
  // Replaces the free vertices' uv by the harmonic map of the rest mesh with the pinned ones as they are (the
  // minimizer of the Dirichlet energy: one solve with the factorized Laplacian; a Tutte-type start).
  void harmonic(std::vector<Point2>& uv);
  // Lowers the energy from uv (free vertices only). With flip_free, uv must start with every face positive.
  DescentOutcome minimize(std::vector<Point2>& uv, const DescentSettings& settings);

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The two projected Hessians below are defined in engine/projected_hessian.cpp.
// The Hessian of mips, |J|^2 / det J, with respect to J = [[a, b], [c, d]] (det J > 0) as the row-major 4-vector
// (a, b, c, d), projected onto the positive semi-definite matrices (its negative eigenvalues set to 0): a
// row-major 4 x 4 matrix. Closed form from J = U diag(s1, s2) W, s1 >= s2 > 0 (the analytic eigensystem of an
// isotropic energy, Smith, de Goes & Kim 2019): with f = s1 / s2 + s2 / s1, the flip mode U [[0,1],[1,0]] W / sqrt 2
// has eigenvalue 1 / (s1 s2) + (s1^2 + s1 s2 + s2^2) / (s1 s2)^2 > 0, the twist mode U [[0,-1],[1,0]] W / sqrt 2
// has -(s1 - s2)^2 / (s1 s2)^2 <= 0 (dropped), and the scaling modes U diag(e) W are the eigenpairs e of f's
// 2 x 2 Hessian in (s1, s2), one of them never positive.
std::array<double, 16> projected_mips_hessian(double a, double b, double c, double d);

// The Hessian of the untangle energy (1 - theta) |J|^2 / chi(det J, eps) + theta (det^2 J + 1) / chi(det J, eps)
// with respect to J as above, any sign of det J, projected onto the positive semi-definite matrices: a row-major
// 4 x 4 matrix. Same eigensystem, J = U diag(s1, s2) W with rotations U, W and s2 < 0 when J is folded: for
// psi(I2, I3) with I2 = |J|^2, I3 = det J, the twist mode has eigenvalue 2 psi_2 + psi_3, the flip mode
// 2 psi_2 - psi_3, and the scaling modes are the eigenpairs of psi's Hessian in (s1, s2).
std::array<double, 16> projected_untangle_hessian(double a, double b, double c, double d, double eps, double theta);

// chi(D, eps) of Garanzha et al. 2021: a smooth positive stand-in for max(D, 0).
double regularized_det(double det, double eps);

}  // namespace lipmap::detail
