// The shared minimizer of "untangle" and "optimize" (engine/detail/uv_descent.h).
#include "engine/detail/uv_descent.h"

#include <Eigen/CholmodSupport>
#include <Eigen/Dense>
#include <Eigen/Sparse>

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <limits>

#include "engine/detail/exact_predicates.h"
#include "engine/error.h"
#include "engine/intermediate_map.h"
#include "engine/multigrid.h"

namespace lipmap::detail {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
using Clock = std::chrono::steady_clock;
using SpMat = Eigen::SparseMatrix<double>;
using Vec2s = Eigen::MatrixX2d;  // one row per free vertex: (u, v)

// Index into m.valuePtr() of the stored entry (row, col) of a compressed column-major matrix whose pattern has
// it: lets a per-face loop add its terms into a fixed pattern without a search at every step.
int value_slot(const SpMat& m, int row, int col) {
  const int* begin = m.innerIndexPtr() + m.outerIndexPtr()[col];
  const int* end = m.innerIndexPtr() + m.outerIndexPtr()[col + 1];
  return static_cast<int>(std::lower_bound(begin, end, row) - m.innerIndexPtr());
}

// A 2 x 2 matrix [[a, b], [c, d]].
struct M2 {
  double a = 0, b = 0, c = 0, d = 0;
  double det() const { return a * d - b * c; }
  double norm2() const { return a * a + b * b + c * c + d * d; }
  M2 cof() const { return {d, -c, -b, a}; }  // d det / dJ
};
inline M2 mul(const M2& x, const M2& y) {
  return {x.a * y.a + x.b * y.c, x.a * y.b + x.b * y.d, x.c * y.a + x.d * y.c, x.c * y.b + x.d * y.d};
}
inline M2 mul_bt(const M2& x, const M2& y) {  // x * y^T
  return {x.a * y.a + x.b * y.b, x.a * y.c + x.b * y.d, x.c * y.a + x.d * y.b, x.c * y.c + x.d * y.d};
}

// The rows of a triangle's gradient operator G: d J / d u_k for its corners k = 0, 1, 2, with B the inverse
// of its rest edge matrix (J = [u1 - u0, u2 - u0] B).
using CornerGradients = std::array<std::array<double, 2>, 3>;
inline CornerGradients corner_gradients(const M2& B) {
  return {{{-(B.a + B.c), -(B.b + B.d)}, {B.a, B.b}, {B.c, B.d}}};
}
// Entry (i, j) of a triangle's Dirichlet stiffness A G G^T.
inline double stiffness(double area, const CornerGradients& g, int i, int j) {
  const auto& a = g[static_cast<std::size_t>(i)];
  const auto& b = g[static_cast<std::size_t>(j)];
  return area * (a[0] * b[0] + a[1] * b[1]);
}

// scale times the gradient of mips = |J|^2 / det J with respect to J: scale (2 J / det J - |J|^2 cof(J) / det^2 J).
M2 mips_gradient(const M2& J, double scale) {
  const double det = J.det(), n2 = J.norm2();
  const M2 C = J.cof();
  const double k1 = scale * 2 / det, k2 = scale * n2 / (det * det);
  return {k1 * J.a - k2 * C.a, k1 * J.b - k2 * C.b, k1 * J.c - k2 * C.c, k1 * J.d - k2 * C.d};
}

// Face f's power base (DescentSettings::face_base, else power_base).
inline double base_of(const DescentSettings& s, std::size_t f) { return s.face_base ? (*s.face_base)[f] : s.power_base; }

// Energy of one Jacobian and its gradient dE/dJ (when grad is not null); base: its face's power base.
double jacobian_energy(const M2& J, const DescentSettings& s, double base, M2* grad) {
  const double det = J.det(), n2 = J.norm2();
  const M2 C = J.cof();
  switch (s.energy) {
    case UvEnergy::mips: {
      if (!(det > 0)) return kInf;
      // power p, base b: (f / 2b)^p with f = mips, gradient p (f / 2b)^(p - 1) / 2b times f's.
      const double f = n2 / det, b = 2 * base;
      const double scale = s.power == 1 ? 1 : s.power / b * std::pow(f / b, s.power - 1);
      if (grad) *grad = mips_gradient(J, scale);
      return s.power == 1 ? f : std::pow(f / b, s.power);
    }
    case UvEnergy::symmetric_dirichlet: {  // |J|^2 + |J^-1|^2 = |J|^2 (1 + 1 / det^2) in 2D
      if (!(det > 0)) return kInf;
      const double inv2 = 1 / (det * det);
      if (grad) {
        const double k1 = 2 * (1 + inv2), k2 = 2 * n2 * inv2 / det;
        *grad = {k1 * J.a - k2 * C.a, k1 * J.b - k2 * C.b, k1 * J.c - k2 * C.c, k1 * J.d - k2 * C.d};
      }
      return n2 * (1 + inv2);
    }
    case UvEnergy::untangle: {
      const double root = std::sqrt(s.epsilon * s.epsilon + det * det);
      const double chi = regularized_det(det, s.epsilon);
      const double dchi = 0.5 * (1 + det / root);
      const double area = det * det + 1;
      if (grad) {
        const double k1 = (1 - s.theta) * 2 / chi;
        const double k2 = (1 - s.theta) * (-n2 * dchi / (chi * chi)) + s.theta * (2 * det / chi - area * dchi / (chi * chi));
        *grad = {k1 * J.a + k2 * C.a, k1 * J.b + k2 * C.b, k1 * J.c + k2 * C.c, k1 * J.d + k2 * C.d};
      }
      return ((1 - s.theta) * n2 + s.theta * area) / chi;
    }
  }
  return kInf;
}

// Smallest t > 0 with det(D + t E) = 0, or +inf.
double first_zero(const M2& D, const M2& E) {
  const double a = E.det();
  const double b = D.a * E.d + E.a * D.d - D.b * E.c - E.b * D.c;
  const double c = D.det();
  double t = kInf;
  auto take = [&](double r) {
    if (r > 0 && r < t) t = r;
  };
  const double scale = std::abs(b) + std::abs(c);
  if (std::abs(a) <= 1e-14 * scale) {
    if (b != 0) take(-c / b);
    return t;
  }
  const double disc = b * b - 4 * a * c;
  if (disc < 0) return t;
  const double q = -0.5 * (b + std::copysign(std::sqrt(disc), b));  // stable roots q / a and c / q
  take(q / a);
  if (q != 0) take(c / q);
  return t;
}

double dot(const Vec2s& x, const Vec2s& y) { return (x.array() * y.array()).sum(); }

}  // namespace

double regularized_det(double det, double eps) { return 0.5 * (det + std::sqrt(eps * eps + det * det)); }

struct UvDescent::Impl {
  const std::vector<Triangle>& faces;
  std::vector<int> index;        // free index of each vertex, -1 when pinned
  std::vector<int> free_vertex;  // vertex of each free index
  std::vector<M2> rest_inverse;  // B = S^-1, S the rest triangle's edge vectors (columns) in a local frame
  std::vector<double> weight;    // rest area
  std::vector<int> active;       // faces with a free corner
  double total_weight = 0;
  // CHOLMOD chooses supernodal or simplicial by the factor's density (CHOLMOD_AUTO, Eigen's default for
  // CholmodDecomposition): at 1M triangles a simplicial factor made the optimize stage 17.4 s instead of 7.6 s,
  // while the untangler's many small local systems factor faster simplicially.
  Eigen::CholmodDecomposition<SpMat, Eigen::Lower> laplacian_factor;
  SpMat laplacian;
  // The symbolic analysis is done once, with the pattern; the numeric factor is made when first needed and
  // then only when the values change (reweight_laplacian, restore_rest_laplacian). The flip-free descents
  // factor the reweighted Laplacian first: factoring the rest one as well cost a factorization per descent
  // (about 1.6 s at 1M triangles).
  bool analyzed = false;
  bool factored = false;  // laplacian_factor holds the numeric factor of laplacian's current values
  // From kMultigridMinUnknowns free vertices on (the intermediate maps' threshold) the Laplacian is not
  // factored: the preconditioner is one multigrid V-cycle (engine/multigrid.h), an SPD approximation of its
  // inverse at linear cost (at 1M triangles a factor cost 1.3 s and each back-solve 110 ms, the cycle ~20 ms);
  // values whose hierarchy cannot be built (weights over a hundred decades) are factored after all.
  bool use_multigrid = false;
  std::unique_ptr<AggregationMultigrid> multigrid;  // set: the current values' hierarchy (else the factor)

  Impl(const std::vector<Point3>& vertices, const std::vector<Triangle>& f, const std::vector<char>& pinned,
       double uv_area)
      : faces(f) {
    const int nv = static_cast<int>(vertices.size());
    index.assign(nv, -1);
    for (int v = 0; v < nv; ++v)
      if (!pinned[v]) {
        index[v] = static_cast<int>(free_vertex.size());
        free_vertex.push_back(v);
      }
    // Rest shapes in local frames (as engine/quality.cpp measures K): q0 = 0, q1 = (|e1|, 0), q2 above.
    const std::size_t nf = faces.size();
    std::vector<std::array<double, 3>> frame(nf);  // q1x, q2x, q2y
    std::vector<char> good(nf, 0);
    double good_area = 0;
    int good_count = 0;
    for (std::size_t i = 0; i < nf; ++i) {
      const Point3 &p0 = vertices[faces[i][0]], &p1 = vertices[faces[i][1]], &p2 = vertices[faces[i][2]];
      const double ax = p1.x - p0.x, ay = p1.y - p0.y, az = p1.z - p0.z;
      const double bx = p2.x - p0.x, by = p2.y - p0.y, bz = p2.z - p0.z;
      const double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
      const double n = std::sqrt(nx * nx + ny * ny + nz * nz);
      const double la = std::sqrt(ax * ax + ay * ay + az * az), lb = std::sqrt(bx * bx + by * by + bz * bz);
      const double longest2 = std::max({la * la, lb * lb, (bx - ax) * (bx - ax) + (by - ay) * (by - ay) + (bz - az) * (bz - az)});
      // Needle or flat triangles (area below 1e-6 of the longest edge squared) get the stand-in shape: their
      // rest Jacobian would be nearly singular and dominate the energy.
      if (!(n > 1e-6 * longest2) || !std::isfinite(n) || !(la > 0)) continue;
      frame[i] = {la, (ax * bx + ay * by + az * bz) / la, n / la};
      good[i] = 1;
      good_area += 0.5 * n;
      ++good_count;
    }
    const double mean_area = good_count > 0 ? good_area / good_count : 1.0;
    const double side = std::sqrt(4 * mean_area / std::sqrt(3.0));
    double rest_area = 0;
    for (std::size_t i = 0; i < nf; ++i) {
      if (!good[i]) frame[i] = {side, 0.5 * side, 0.5 * std::sqrt(3.0) * side};
      rest_area += 0.5 * frame[i][0] * frame[i][2];
    }
    const double s = uv_area > 0 && rest_area > 0 ? std::sqrt(uv_area / rest_area) : 1.0;
    rest_inverse.resize(nf);
    weight.resize(nf);
    for (std::size_t i = 0; i < nf; ++i) {
      const double q1x = s * frame[i][0], q2x = s * frame[i][1], q2y = s * frame[i][2];
      rest_inverse[i] = {1 / q1x, -q2x / (q1x * q2y), 0, 1 / q2y};
      weight[i] = 0.5 * q1x * q2y;
      total_weight += weight[i];
      if (index[faces[i][0]] >= 0 || index[faces[i][1]] >= 0 || index[faces[i][2]] >= 0)
        active.push_back(static_cast<int>(i));
    }
    build_laplacian();
  }

  // The Dirichlet energy's Hessian sum_t A_t |J_t|^2 on the free vertices: per triangle A G G^T with G the
  // 3 x 2 gradient operator, positive semi-definite by construction (with the cotangent weights of the rest
  // shapes), positive definite with the pinned boundary.
  void build_laplacian() {
    const int n = static_cast<int>(free_vertex.size());
    if (n == 0) return;
    std::vector<Eigen::Triplet<double>> entries;
    entries.reserve(active.size() * 9);
    for (int f : active) {
      const M2& B = rest_inverse[f];
      const CornerGradients g = corner_gradients(B);
      for (int i = 0; i < 3; ++i) {
        const int r = index[faces[f][i]];
        if (r < 0) continue;
        for (int j = 0; j < 3; ++j) {
          const int c = index[faces[f][j]];
          if (c < 0 || c > r) continue;  // lower triangle
          entries.emplace_back(r, c, stiffness(weight[f], g, i, j));
        }
      }
    }
    laplacian.resize(n, n);
    laplacian.setFromTriplets(entries.begin(), entries.end());
    laplacian.makeCompressed();
    rest_values.assign(laplacian.valuePtr(), laplacian.valuePtr() + laplacian.nonZeros());
    laplacian_factor.cholmod().print = 0;
    use_multigrid = n >= kMultigridMinUnknowns;
    analyzed = use_multigrid || analyze_pattern();  // multigrid: the pattern is analysed only if needed
  }

  // ---- the preconditioner in the metric of the current map (mips, symmetric Dirichlet) ----
  // The rest Laplacian is the Hessian of the Dirichlet energy at the rest shapes. Far from them it is badly
  // scaled: mips is scale-invariant, so its Hessian on a triangle scales as 1 / det J (the area ratio), and a
  // map onto a stretched or crowded target (exp_strip, power_map) has area ratios over orders of magnitude.
  // Reweighted, each triangle's term by the Hessian of its energy with det J frozen (mips |J|^2 / det J:
  // 1 / det J; symmetric Dirichlet |J|^2 (1 + 1 / det^2): (1 + 1 / det^2) / 2, both 1 at J = I): still a
  // Laplacian with positive weights, the same pattern, a numeric refactorization only.
  std::vector<int> laplacian_slot;  // 6 per active face: corner pairs (i, j), j <= i, in the lower triangle
  std::vector<double> rest_values;  // the rest Laplacian's values, for harmonic()
  bool reweighted = false;

  void build_laplacian_slots() {
    laplacian_slot.assign(active.size() * 6, -1);
    for (std::size_t k = 0; k < active.size(); ++k) {
      int t = 0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j <= i; ++j, ++t) {
          const int r = index[faces[active[k]][i]], c = index[faces[active[k]][j]];
          if (r >= 0 && c >= 0) laplacian_slot[6 * k + t] = value_slot(laplacian, std::max(r, c), std::min(r, c));
        }
    }
  }

  void reweight_laplacian(const std::vector<Point2>& uv, const DescentSettings& s) {
    const UvEnergy energy = s.energy;
    const double power = s.power;
    if (!analyzed || free_vertex.empty()) return;
    if (laplacian_slot.empty()) build_laplacian_slots();
    double* values = laplacian.valuePtr();
    std::fill(values, values + laplacian.nonZeros(), 0.0);
    for (std::size_t k = 0; k < active.size(); ++k) {
      const int f = active[k];
      const M2& B = rest_inverse[f];
      const double det = mul(edges(uv, f), B).det();
      double c = energy == UvEnergy::mips ? 1 / det : 0.5 * (1 + 1 / (det * det));
      if (energy == UvEnergy::mips && power != 1) {
        const M2 J = mul(edges(uv, f), B);
        const double base = base_of(s, static_cast<std::size_t>(f));
        c *= power / (2 * base) * std::pow(J.norm2() / det / (2 * base), power - 1);
      }
      if (!(c > 0 && std::isfinite(c))) c = 1;
      const CornerGradients g = corner_gradients(B);
      int t = 0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j <= i; ++j, ++t)
          if (const int slot = laplacian_slot[6 * k + static_cast<std::size_t>(t)]; slot >= 0)
            values[slot] += stiffness(weight[f] * c, g, i, j);
    }
    reweighted = true;
    factored = factor_values();
    if (!factored) restore_rest_laplacian();
  }

  bool pattern_analyzed = false;
  bool analyze_pattern() {
    use_single_threaded_solvers();
    laplacian_factor.analyzePattern(laplacian);
    pattern_analyzed = true;
    return laplacian_factor.info() == Eigen::Success;
  }

  // The multigrid hierarchy of laplacian's current values, or their numeric factor.
  bool factor_values() {
    use_single_threaded_solvers();
    multigrid.reset();
    if (use_multigrid) {
      auto built = std::make_unique<AggregationMultigrid>();
      if (built->compute(SpMat(laplacian.selfadjointView<Eigen::Lower>()))) {
        multigrid = std::move(built);
        return true;
      }
    }
    if (!pattern_analyzed && !analyze_pattern()) return false;
    laplacian_factor.factorize(laplacian);
    return laplacian_factor.info() == Eigen::Success;
  }

  // Factors the rest Laplacian unless it is the one factored already.
  void restore_rest_laplacian() {
    if (!analyzed || (factored && !reweighted)) return;
    std::copy(rest_values.begin(), rest_values.end(), laplacian.valuePtr());
    factored = factor_values();
    reweighted = false;
  }

  Vec2s precondition(const Vec2s& g) const {
    if (factored) return multigrid ? Vec2s(multigrid->cycle(g)) : Vec2s(laplacian_factor.solve(g));
    // Jacobi when the factorization failed (it should not: the matrix is SPD).
    Vec2s out = g;
    for (int i = 0; i < out.rows(); ++i) {
      const double d = laplacian.coeff(i, i);
      if (d > 0) out.row(i) /= d;
    }
    return out;
  }

  // ---- projected Newton (mips) ----
  // The Hessian over the free uv, unknown 2 i (u) and 2 i + 1 (v) of free vertex i, lower triangle: its
  // pattern is built once; slot[21 k + t] is where entry t of active face k's 6 x 6 lower triangle goes (-1:
  // a pinned corner).
  SpMat hessian;
  std::vector<int> hessian_slot, hessian_diagonal;
  Eigen::CholmodDecomposition<SpMat, Eigen::Lower> hessian_factor;
  bool hessian_analyzed = false;

  int dof(int f, int a) const {
    const int i = index[faces[f][a / 2]];
    return i < 0 ? -1 : 2 * i + a % 2;
  }

  void build_hessian_pattern() {
    const int n = 2 * static_cast<int>(free_vertex.size());
    std::vector<Eigen::Triplet<double>> entries;
    entries.reserve(active.size() * 21 + static_cast<std::size_t>(n));
    for (int r = 0; r < n; ++r) entries.emplace_back(r, r, 0.0);
    for (int f : active)
      for (int a = 0; a < 6; ++a)
        for (int b = 0; b < a; ++b) {
          const int ra = dof(f, a), rb = dof(f, b);
          if (ra >= 0 && rb >= 0) entries.emplace_back(std::max(ra, rb), std::min(ra, rb), 0.0);
        }
    hessian.resize(n, n);
    hessian.setFromTriplets(entries.begin(), entries.end());
    hessian.makeCompressed();
    hessian_slot.assign(active.size() * 21, -1);
    for (std::size_t k = 0; k < active.size(); ++k) {
      int t = 0;
      for (int a = 0; a < 6; ++a)
        for (int b = 0; b <= a; ++b, ++t) {
          const int ra = dof(active[k], a), rb = dof(active[k], b);
          if (ra >= 0 && rb >= 0) hessian_slot[21 * k + t] = value_slot(hessian, std::max(ra, rb), std::min(ra, rb));
        }
    }
    hessian_diagonal.resize(static_cast<std::size_t>(n));
    for (int r = 0; r < n; ++r) hessian_diagonal[static_cast<std::size_t>(r)] = value_slot(hessian, r, r);
  }

  // p = -H^-1 g with H the sum of the faces' projected Hessians, mips or untangle (+ a tiny multiple of the
  // identity when H is only semi-definite). With power p != 1, each face's term is (f / 2b)^p of f = mips, whose Hessian
  // c1 H_f + c2 grad f grad f^T (c1, c2 > 0) is projected by projecting H_f: the rank-one term is already
  // positive semi-definite. False when no factorization succeeds.
  bool newton_direction(const std::vector<Point2>& uv, const Vec2s& g, Vec2s& p, const DescentSettings& s) {
    const double power = s.power;
    if (hessian_slot.empty() && !active.empty()) build_hessian_pattern();
    double* values = hessian.valuePtr();
    std::fill(values, values + hessian.nonZeros(), 0.0);
    for (std::size_t k = 0; k < active.size(); ++k) {
      const int f = active[k];
      const M2& B = rest_inverse[f];
      const M2 J = mul(edges(uv, f), B);
      std::array<double, 16> hj = s.energy == UvEnergy::untangle
                                      ? projected_untangle_hessian(J.a, J.b, J.c, J.d, s.epsilon, s.theta)
                                      : projected_mips_hessian(J.a, J.b, J.c, J.d);
      if (s.energy == UvEnergy::mips && power != 1) {
        const double b2 = 2 * base_of(s, static_cast<std::size_t>(f));
        const double mips = J.norm2() / J.det();
        const double c1 = power / b2 * std::pow(mips / b2, power - 1);
        const double c2 = power * (power - 1) / (b2 * b2) * std::pow(mips / b2, power - 2);
        const M2 G = mips_gradient(J, 1);
        const std::array<double, 4> gf = {G.a, G.b, G.c, G.d};
        for (std::size_t i = 0; i < 4; ++i)
          for (std::size_t j = 0; j < 4; ++j) hj[4 * i + j] = c1 * hj[4 * i + j] + c2 * gf[i] * gf[j];
      }
      // dJ / d(u0, v0, u1, v1, u2, v2) = M: J's row 0 (entries 0, 1 of hj's order) from the u's, row 1
      // (entries 2, 3) from the v's, columns through B. Unknown a = 2 c + r (corner c, r = 0: u, 1: v) has the
      // two nonzeros gk[c] in rows 2 r, 2 r + 1 of M; so each entry of M^T hj M is a sum of four products.
      const CornerGradients gk = corner_gradients(B);
      double HM[4][6];  // hj M
      for (int i = 0; i < 4; ++i)
        for (int c = 0; c < 3; ++c) {
          HM[i][2 * c] = hj[4 * i] * gk[c][0] + hj[4 * i + 1] * gk[c][1];
          HM[i][2 * c + 1] = hj[4 * i + 2] * gk[c][0] + hj[4 * i + 3] * gk[c][1];
        }
      int t = 0;
      for (int a = 0; a < 6; ++a) {
        const int ra = 2 * (a % 2);
        const double g0 = gk[a / 2][0], g1 = gk[a / 2][1];
        for (int b = 0; b <= a; ++b, ++t) {
          const int slot = hessian_slot[21 * k + static_cast<std::size_t>(t)];
          if (slot < 0) continue;
          values[slot] += weight[f] * (g0 * HM[ra][b] + g1 * HM[ra + 1][b]);
        }
      }
    }
    double trace = 0;
    for (int d : hessian_diagonal) trace += values[d];
    const double mean_diagonal = hessian_diagonal.empty() ? 1 : trace / static_cast<double>(hessian_diagonal.size());
    use_single_threaded_solvers();
    if (!hessian_analyzed) {
      hessian_factor.cholmod().print = 0;
      hessian_factor.analyzePattern(hessian);
      hessian_analyzed = true;
    }
    for (double shift : {1e-10, 1e-6, 1e-3}) {
      for (int d : hessian_diagonal) values[d] += shift * mean_diagonal;
      hessian_factor.factorize(hessian);
      if (hessian_factor.info() == Eigen::Success) break;
    }
    if (hessian_factor.info() != Eigen::Success) return false;
    const int n = static_cast<int>(free_vertex.size());
    Eigen::VectorXd rhs(2 * n);
    for (int i = 0; i < n; ++i) rhs(2 * i) = -g(i, 0), rhs(2 * i + 1) = -g(i, 1);
    const Eigen::VectorXd x = hessian_factor.solve(rhs);
    if (hessian_factor.info() != Eigen::Success || !x.allFinite()) return false;
    p.resize(n, 2);
    for (int i = 0; i < n; ++i) p(i, 0) = x(2 * i), p(i, 1) = x(2 * i + 1);
    return true;
  }

  Vec2s laplacian_times(const Vec2s& x) const {
    return laplacian.selfadjointView<Eigen::Lower>() * x;
  }

  M2 edges(const std::vector<Point2>& uv, int f) const {
    const Point2 &u0 = uv[faces[f][0]], &u1 = uv[faces[f][1]], &u2 = uv[faces[f][2]];
    return {u1.x - u0.x, u2.x - u0.x, u1.y - u0.y, u2.y - u0.y};
  }

  // Weighted energy sum over the faces f (in increasing order) for which include(f); inf when one is infinite.
  template <class Include>
  double energy_sum(const std::vector<Point2>& uv, const DescentSettings& s, Include&& include) const {
    double e = 0;
    for (std::size_t f = 0; f < faces.size(); ++f) {
      if (!include(f)) continue;
      const double ef = jacobian_energy(mul(edges(uv, static_cast<int>(f)), rest_inverse[f]), s, base_of(s, f), nullptr);
      if (!std::isfinite(ef)) return kInf;
      e += weight[f] * ef;
    }
    return e;
  }

  // The faces without a free corner: a constant of the descent (`active` is ascending).
  double inactive_energy(const std::vector<Point2>& uv, const DescentSettings& s) const {
    std::size_t k = 0;
    return energy_sum(uv, s, [&](std::size_t f) {
      if (k < active.size() && active[k] == static_cast<int>(f)) return ++k, false;
      return true;
    });
  }

  // Sum of weighted energies over the active faces (the others are constant), with the gradient.
  double evaluate(const std::vector<Point2>& uv, const DescentSettings& s, Vec2s* grad) const {
    if (grad) grad->setZero(static_cast<Eigen::Index>(free_vertex.size()), 2);
    double e = 0;
    for (int f : active) {
      const M2 D = edges(uv, f);
      const M2 J = mul(D, rest_inverse[f]);
      M2 G;
      const double ef = jacobian_energy(J, s, base_of(s, static_cast<std::size_t>(f)), grad ? &G : nullptr);
      if (!std::isfinite(ef)) return kInf;
      e += weight[f] * ef;
      if (!grad) continue;
      const M2 dD = mul_bt(G, rest_inverse[f]);  // dE/dD = dE/dJ B^T; columns: d/d(u1 - u0), d/d(u2 - u0)
      const int i0 = index[faces[f][0]], i1 = index[faces[f][1]], i2 = index[faces[f][2]];
      const double w = weight[f];
      if (i1 >= 0) { (*grad)(i1, 0) += w * dD.a; (*grad)(i1, 1) += w * dD.c; }
      if (i2 >= 0) { (*grad)(i2, 0) += w * dD.b; (*grad)(i2, 1) += w * dD.d; }
      if (i0 >= 0) { (*grad)(i0, 0) -= w * (dD.a + dD.b); (*grad)(i0, 1) -= w * (dD.c + dD.d); }
    }
    return e;
  }

  void apply(const std::vector<Point2>& from, const Vec2s& step, double t, std::vector<Point2>& to) const {
    to = from;
    for (std::size_t i = 0; i < free_vertex.size(); ++i) {
      Point2& p = to[free_vertex[i]];
      p.x += t * step(static_cast<Eigen::Index>(i), 0);
      p.y += t * step(static_cast<Eigen::Index>(i), 1);
    }
  }

  // Smith & Schaefer 2015, 4.1: the largest t for which every active triangle stays positive along the step.
  double max_flip_free_step(const std::vector<Point2>& uv, const Vec2s& step) const {
    double t = kInf;
    for (int f : active) {
      M2 E;
      double dx[3] = {0, 0, 0}, dy[3] = {0, 0, 0};
      for (int c = 0; c < 3; ++c)
        if (const int i = index[faces[f][c]]; i >= 0) {
          dx[c] = step(i, 0);
          dy[c] = step(i, 1);
        }
      E = {dx[1] - dx[0], dx[2] - dx[0], dy[1] - dy[0], dy[2] - dy[0]};
      t = std::min(t, first_zero(edges(uv, f), E));
    }
    return t;
  }

  double min_det_active(const std::vector<Point2>& uv) const {
    double d = kInf;
    for (int f : active) d = std::min(d, edges(uv, f).det());
    return d;
  }

  bool all_positive_exactly(const std::vector<Point2>& uv) const {
    for (int f : active)
      if (orient(uv[faces[f][0]], uv[faces[f][1]], uv[faces[f][2]]) <= 0) return false;
    return true;
  }
};

UvDescent::UvDescent(const std::vector<Point3>& vertices, const std::vector<Triangle>& faces,
                     const std::vector<char>& pinned, double uv_area)
    : impl_(std::make_unique<Impl>(vertices, faces, pinned, uv_area)) {}
UvDescent::~UvDescent() = default;

void UvDescent::harmonic(std::vector<Point2>& uv) {
  Impl& m = *impl_;
  const int n = static_cast<int>(m.free_vertex.size());
  m.restore_rest_laplacian();
  if (n == 0 || !m.factored) return;
  // The Dirichlet energy sum_t A_t |J_t|^2 is quadratic with Hessian 2 L: one Newton step from any uv is its
  // minimizer. Its gradient is 2 sum_t A_t J_t B_t^T scattered to the corners.
  Vec2s grad = Vec2s::Zero(n, 2);
  for (int f : m.active) {
    const M2 dD = mul_bt(mul(m.edges(uv, f), m.rest_inverse[f]), m.rest_inverse[f]);
    const int i0 = m.index[m.faces[f][0]], i1 = m.index[m.faces[f][1]], i2 = m.index[m.faces[f][2]];
    const double w = m.weight[f];
    if (i1 >= 0) { grad(i1, 0) += w * dD.a; grad(i1, 1) += w * dD.c; }
    if (i2 >= 0) { grad(i2, 0) += w * dD.b; grad(i2, 1) += w * dD.d; }
    if (i0 >= 0) { grad(i0, 0) -= w * (dD.a + dD.b); grad(i0, 1) -= w * (dD.c + dD.d); }
  }
  // grad holds half the gradient, L is half the Hessian: the step is -L^-1 grad.
  const Vec2s step = m.multigrid ? Vec2s(m.multigrid->solve(grad)) : Vec2s(m.laplacian_factor.solve(grad));
  // A multigrid solve that did not converge leaves uv as it is (the factor's solve is exact).
  if (m.multigrid && !(m.multigrid->stats().relative_residual <= 1e-10 && step.allFinite())) return;
  m.apply(std::vector<Point2>(uv), step, -1.0, uv);
}

int UvDescent::free_vertices() const { return static_cast<int>(impl_->free_vertex.size()); }

double UvDescent::energy(const std::vector<Point2>& uv, const DescentSettings& settings) const {
  const double e = impl_->energy_sum(uv, settings, [](std::size_t) { return true; });
  return impl_->total_weight > 0 ? e / impl_->total_weight : 0;
}

double UvDescent::min_det(const std::vector<Point2>& uv) const {
  double m = kInf;
  for (std::size_t f = 0; f < impl_->faces.size(); ++f)
    m = std::min(m, mul(impl_->edges(uv, static_cast<int>(f)), impl_->rest_inverse[f]).det());
  return m;
}

DescentOutcome UvDescent::minimize(std::vector<Point2>& uv, const DescentSettings& s) {
  Impl& m = *impl_;
  DescentOutcome out;
  if (m.free_vertex.empty() || s.max_iterations <= 0) {
    out.energy_before = out.energy_after = energy(uv, s);
    return out;
  }
  // The faces without a free corner add a constant: summed once, so that the energy at both ends comes from
  // the descent's own passes over the active faces.
  const double fixed = m.inactive_energy(uv, s);
  auto mean_energy = [&](double active_sum) {
    const double sum = std::isfinite(active_sum) && std::isfinite(fixed) ? active_sum + fixed : kInf;
    return m.total_weight > 0 ? sum / m.total_weight : 0;
  };
  const bool flip_free = s.flip_free && s.energy != UvEnergy::untangle;
  bool newton = s.newton && s.energy != UvEnergy::symmetric_dirichlet;
  const int n = static_cast<int>(m.free_vertex.size());
  // L-BFGS memory (Nocedal & Wright Alg. 7.4), vectors as n x 2 blocks.
  constexpr std::size_t kMemory = 8;
  // The preconditioner in the metric of the starting map (once: refreshing it every 5 or 10 steps cost more
  // time for the same mean K and a worse max K on bench_quality).
  if (flip_free) m.reweight_laplacian(uv, s);
  else m.restore_rest_laplacian();  // the untangle energy's curvature is the rest one's
  std::deque<Vec2s> S, Y;
  std::deque<double> rho;
  double gamma = 0.5;  // H0 = gamma L^-1; 0.5: mips and the untangle energy are about 2 |J|^2 near J = I
  Vec2s g(n, 2), g_new(n, 2), p(n, 2);
  double e = m.evaluate(uv, s, &g);
  out.energy_before = out.energy_after = mean_energy(e);
  if (!std::isfinite(out.energy_before)) return out;
  std::vector<Point2> trial;
  constexpr double kArmijo = 1e-4;
  int small_steps = 0;
  for (int it = 0; it < s.max_iterations; ++it) {
    check_cancel(s.cancel);
    if (Clock::now() >= s.deadline) break;
    double slope = 0;
    const bool newton_step = newton && m.newton_direction(uv, g, p, s) && (slope = dot(g, p)) < 0;
    if (!newton_step) {
      // Two-loop recursion.
      Vec2s q = g;
      std::vector<double> alpha(S.size());
      for (std::size_t k = S.size(); k-- > 0;) {
        alpha[k] = rho[k] * dot(S[k], q);
        q -= alpha[k] * Y[k];
      }
      Vec2s r = gamma * m.precondition(q);
      for (std::size_t k = 0; k < S.size(); ++k) {
        const double beta = rho[k] * dot(Y[k], r);
        r += (alpha[k] - beta) * S[k];
      }
      p = -r;
      slope = dot(g, p);
      if (!(slope < 0)) {  // not a descent direction: forget the curvature pairs
        S.clear(), Y.clear(), rho.clear();
        p = -gamma * m.precondition(g);
        slope = dot(g, p);
        if (!(slope < 0)) break;
      }
    }
    double t = 1;
    if (flip_free) t = std::min(1.0, 0.9 * m.max_flip_free_step(uv, p));
    bool accepted = false, have_gradient = false;
    double e_new = e;
    for (int back = 0; back < 40 && t > 0; ++back, t *= 0.5) {
      check_cancel(s.cancel);
      m.apply(uv, p, t, trial);
      // The full step is usually accepted: its gradient comes with the energy (one pass over the faces
      // instead of two); backtracked trials evaluate the energy alone.
      have_gradient = back == 0;
      e_new = m.evaluate(trial, s, have_gradient ? &g_new : nullptr);
      if (!(e_new <= e + kArmijo * t * slope)) continue;
      if (flip_free && !m.all_positive_exactly(trial)) continue;
      accepted = true;
      break;
    }
    if (!accepted) {
      // A stall: retry once along the preconditioned gradient with a fresh memory, else stop (uv keeps the
      // last accepted positions). A Newton step that failed hands over to L-BFGS.
      if (newton_step) {
        newton = false;
        continue;
      }
      if (S.empty()) break;
      S.clear(), Y.clear(), rho.clear();
      continue;
    }
    if (!have_gradient) m.evaluate(trial, s, &g_new);
    Vec2s step = t * p, dg = g_new - g;
    const double sy = dot(step, dg);
    if (sy > 1e-300) {
      S.push_back(step), Y.push_back(dg), rho.push_back(1 / sy);
      if (S.size() > kMemory) S.pop_front(), Y.pop_front(), rho.pop_front();
      // Barzilai-Borwein scale in the metric of L: s^T L s / s^T y.
      const double sls = dot(step, m.laplacian_times(step));
      if (sls > 0) gamma = sls / sy;
    }
    uv.swap(trial);
    g.swap(g_new);
    const double drop = e - e_new;
    e = e_new;
    ++out.iterations;
    // Converged: three steps in a row that each lower the energy by less than the tolerance (one short
    // step after heavy backtracking is not convergence).
    if (s.stop_when_positive && m.min_det_active(uv) > 0 && m.all_positive_exactly(uv)) {
      out.positive = true;
      break;
    }
    small_steps = drop <= s.relative_tolerance * std::abs(e) ? small_steps + 1 : 0;
    if (small_steps >= 3) {
      out.converged = true;
      break;
    }
  }
  out.energy_after = mean_energy(e);
  return out;
}

}  // namespace lipmap::detail
