// Polygon generators, families 1a (images of grid meshes under locally injective maps) and 1b (simple by
// construction), with the case type every family returns. See polygon_generators.h for the whole list.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "polygon_basics.h"
#include "triangulation_checker.h"

namespace lipmap::testgen {

// Largest rotation index the engine accepts (boundary_polygon.h, kMaxRotationIndex); generated R stay far
// below it.
inline constexpr int kGenMaxRotationIndex = 6;

enum class Expect {
  simple,
  self_overlapping,
  weakly_self_overlapping,
  not_self_overlapping,
  simple_or_self_overlapping,  // decided by the exact simplicity test: simple if simple, else self_overlapping
};

inline const char* expect_name(Expect e) {
  switch (e) {
    case Expect::simple: return "simple";
    case Expect::self_overlapping: return "self_overlapping";
    case Expect::weakly_self_overlapping: return "weakly_self_overlapping";
    case Expect::not_self_overlapping: return "not_self_overlapping";
    case Expect::simple_or_self_overlapping: return "simple_or_self_overlapping";
  }
  return "?";
}

struct GenCase {
  std::string family;
  std::uint64_t seed = 0;
  std::string params;
  Poly poly;
  Expect expect = Expect::not_self_overlapping;
  int turning = 0;                 // known from the construction (and re-checked by the generator)
  std::vector<Tri> certificate;    // a valid triangulation when the construction gives one
  std::vector<int> certificate_R;  // its rotation indices
  std::vector<Pt> negative_probes; // points of negative winding number (1d curls)
  std::vector<Pt> zero_probes;     // points of winding number 0 next to a pinch point (1d flowers)
  std::vector<std::vector<int>> feasible_R;  // small polygons: every realizable R vector (exhaustive oracle)
  std::string name() const { return family + "#" + std::to_string(seed) + " [n=" + std::to_string(poly.size()) + "; " + params + "]"; }
};

// No near-spike (interior angle within 1e-4 of 0 or 2 pi), no zero-length edge, finite: the float angle
// bookkeeping of the checker is then unambiguous.
inline bool well_conditioned(const Poly& p) {
  const size_t n = p.size();
  if (n < 3) return false;
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(p[i].x) || !std::isfinite(p[i].y)) return false;
    if (p[i] == p[(i + 1) % n]) return false;
  }
  for (long double a : interior_angles(p))
    if (a < 1e-4L || a > kTwoPiL - 1e-4L) return false;
  return true;
}

// The local injectivity certificate of 1a: exact positivity of every image triangle, angle sum 2 pi at
// interior vertices, in (0, 2 pi) at boundary vertices (with margins, so the float sums are unambiguous).
inline bool verify_locally_injective(const GridMesh& m, std::string* why = nullptr) {
  for (const Tri& t : m.triangles)
    if (exact::orient(m.image[t[0]], m.image[t[1]], m.image[t[2]]) <= 0) {
      if (why) *why = "non-positive image triangle";
      return false;
    }
  std::vector<long double> theta(m.image.size(), 0);
  for (const Tri& t : m.triangles)
    for (int k = 0; k < 3; ++k)
      theta[t[k]] += corner_angle(m.image[t[k]], m.image[t[(k + 1) % 3]], m.image[t[(k + 2) % 3]]);
  std::vector<char> on_boundary(m.image.size(), 0);
  for (int v : m.boundary) on_boundary[v] = 1;
  for (size_t v = 0; v < m.image.size(); ++v) {
    if (on_boundary[v]) {
      if (!(theta[v] > 1e-3L && theta[v] < kTwoPiL - 1e-3L)) {
        if (why) *why = "boundary angle sum not in (0, 2 pi)";
        return false;
      }
    } else if (std::fabs(theta[v] - kTwoPiL) > 1e-7L) {
      if (why) *why = "interior angle sum != 2 pi";
      return false;
    }
  }
  return true;
}

inline bool finish_grid_case(GenCase& c, const GridMesh& m) {
  if (!verify_locally_injective(m)) return false;
  c.poly = m.boundary_polygon();
  if (!well_conditioned(c.poly)) return false;
  c.expect = Expect::simple_or_self_overlapping;
  c.turning = 1;
  return turning_number(c.poly) == 1;
}

inline std::string fmt(const char* name, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s=%.4g ", name, v);
  return buf;
}

// 1a: z -> exp(a z) on the strip [x0, x0 + wx] x [0, H], H = turns * 2 pi / a, turns in (1, 3], not an
// integer: an annulus wrapped more than once around the origin.
inline std::optional<GenCase> gen_exp_strip(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "exp_strip";
  c.seed = seed;
  const double a = r.uniform(0.5, 2.0);
  double turns = 0;
  do turns = r.uniform(1.1, 3.0);
  while (std::fabs(turns - std::round(turns)) < 0.08);
  const double H = turns * kTwoPi / a;
  const double x0 = r.uniform(-1.0, 0.5) / a, wx = r.uniform(0.3, 1.5) / a;
  const int nx = r.integer(1, 4);
  const int ny = (int)std::ceil(turns * r.uniform(8, 20));
  const std::vector<double> xs = linspace(x0, x0 + wx, nx), ys = linspace(0, H, ny);
  const GridMesh m = make_grid_mesh(
      nx, ny,
      [&](int i, int j) {
        const double mod = std::exp(a * xs[i]);
        return Pt{mod * std::cos(a * ys[j]), mod * std::sin(a * ys[j])};
      },
      r);
  c.params = fmt("a", a) + fmt("turns", turns) + fmt("nx", nx) + fmt("ny", ny);
  if (!finish_grid_case(c, m)) return std::nullopt;
  return c;
}

// 1a: z -> z^k (k = 3..6) on the rectangle [-xw, xw] x [y0, y0 + h] (y0 > 0, away from 0). Its argument
// range times k exceeds 2 pi + 0.2, so the image wraps over itself. The grid is graded (x = y0 sinh u,
// y = y0 e^v) so that every cell is small compared with its distance to 0.
inline std::optional<GenCase> gen_power_map(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "power_map";
  c.seed = seed;
  const int k = r.chance(0.5) ? 3 : r.integer(3, 6);
  double y0 = 0, xw = 0, h = 0;
  bool found = false;
  for (int tries = 0; tries < 100 && !found; ++tries) {
    y0 = r.uniform(0.3, 0.6);
    xw = r.uniform(0.6, 1.2);
    h = r.uniform(0.3, 0.8);
    found = k * (kPi - 2 * std::atan(y0 / xw)) > kTwoPi + 0.2;
  }
  if (!found) return std::nullopt;
  double du = r.uniform(0.45, 0.7) / k;
  for (int refine = 0; refine < 3; ++refine, du /= 1.5) {
    const double umax = std::asinh(xw / y0), vmax = std::log((y0 + h) / y0);
    const int nx = std::max(2, (int)std::ceil(2 * umax / du)), ny = std::max(1, (int)std::ceil(vmax / du));
    std::vector<double> xs(nx + 1), ys(ny + 1);
    for (int i = 0; i <= nx; ++i) xs[i] = y0 * std::sinh(-umax + 2 * umax * i / nx);
    for (int j = 0; j <= ny; ++j) ys[j] = y0 * std::exp(vmax * j / ny);
    const GridMesh m = make_grid_mesh(
        nx, ny,
        [&](int i, int j) {
          double re = xs[i], im = ys[j];
          for (int e = 1; e < k; ++e) {
            const double nr = re * xs[i] - im * ys[j], ni = re * ys[j] + im * xs[i];
            re = nr;
            im = ni;
          }
          return Pt{re, im};
        },
        r);
    c.params = fmt("k", k) + fmt("y0", y0) + fmt("xw", xw) + fmt("h", h) + fmt("nx", nx) + fmt("ny", ny);
    if (finish_grid_case(c, m)) return c;
  }
  return std::nullopt;
}

// 1a: spiral strip (see spiral_strip_mesh). overlap_layers: w > 2 pi c (layers overlap) or w < 2 pi c (a
// thin spiral, usually simple).
inline std::optional<GenCase> gen_spiral_strip(std::uint64_t seed, bool overlap_layers) {
  Rng r(seed);
  GenCase c;
  c.family = overlap_layers ? "spiral_overlap" : "spiral_thin";
  c.seed = seed;
  const double cc = r.uniform(0.05, 0.25), r0 = r.uniform(0.3, 1.0), turns = r.uniform(1.05, 3.0);
  const double overlap = overlap_layers ? r.uniform(1.2, 2.5) : r.uniform(0.2, 0.8);
  const int n_rho = r.integer(1, 3);
  const int n_theta = (int)std::ceil(turns * kTwoPi / r.uniform(0.25, 0.45));
  const GridMesh m = spiral_strip_mesh(n_rho, n_theta, turns, r0, cc, overlap, r);
  c.params = fmt("c", cc) + fmt("r0", r0) + fmt("turns", turns) + fmt("w/2pic", overlap) + fmt("nrho", n_rho);
  if (!finish_grid_case(c, m)) return std::nullopt;
  return c;
}

// 1a: a strip of half width hw around a centerline whose curvature k(s) = 1 + A sin(2 pi f s / L + p) > 0
// turns it through `turns` full turns; (s, t) -> C(s) + t N(s) is locally injective for |t| k(s) < 1.
inline std::optional<GenCase> gen_bent_strip(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "bent_strip";
  c.seed = seed;
  const double turns = r.uniform(1.05, 2.8), Phi = turns * kTwoPi;
  const double A = r.uniform(0.0, 0.6), ph = r.uniform(0, kTwoPi);
  const int f = r.integer(1, 4);
  const double L = Phi;  // mean curvature 1
  auto tangent_angle = [&](double s) {
    return s + A * L / (kTwoPi * f) * (std::cos(ph) - std::cos(kTwoPi * f * s / L + ph));
  };
  const double hw = r.uniform(0.2, 0.6) / (1 + A);
  const int ns = (int)std::ceil(Phi * (1 + A) / r.uniform(0.2, 0.4));
  const int nt = r.integer(1, 3);
  // Centerline by composite Simpson integration of (cos phi, sin phi).
  std::vector<Pt> C(ns + 1);
  std::vector<double> phi(ns + 1);
  C[0] = {0, 0};
  const int sub = 32;
  for (int j = 0; j <= ns; ++j) phi[j] = tangent_angle(L * j / ns);
  for (int j = 0; j < ns; ++j) {
    const double s0 = L * j / ns, ds = L / ns / sub;
    double sx = 0, sy = 0;
    for (int q = 0; q <= sub; ++q) {
      const double wgt = (q == 0 || q == sub) ? 1 : (q % 2 ? 4 : 2);
      const double t = tangent_angle(s0 + q * ds);
      sx += wgt * std::cos(t);
      sy += wgt * std::sin(t);
    }
    C[j + 1] = {C[j].x + sx * ds / 3, C[j].y + sy * ds / 3};
  }
  const std::vector<double> ts = linspace(-hw, hw, nt);
  const GridMesh m = make_grid_mesh(
      ns, nt, [&](int i, int j) { return Pt{C[i].x - ts[j] * std::sin(phi[i]), C[i].y + ts[j] * std::cos(phi[i])}; }, r);
  c.params = fmt("turns", turns) + fmt("A", A) + fmt("f", f) + fmt("hw", hw) + fmt("ns", ns) + fmt("nt", nt);
  if (!finish_grid_case(c, m)) return std::nullopt;
  return c;
}

inline bool finish_simple_case(GenCase& c) {
  if (!well_conditioned(c.poly) || !is_simple(c.poly) || turning_number(c.poly) != 1) return false;
  c.expect = Expect::simple;
  c.turning = 1;
  return true;
}

// 1b: star-shaped around a center (sorted angles with gaps < pi, positive radii): simple, counterclockwise.
inline std::optional<GenCase> gen_star(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "star";
  c.seed = seed;
  const int n = r.chance(0.3) ? r.integer(3, 8) : r.integer(5, 60);
  std::vector<double> gaps(n);
  double sum = 0;
  for (double& g : gaps) sum += (g = r.uniform(0.2, 1.0));
  for (double g : gaps)
    if (g / sum * kTwoPi > kPi - 0.05) return std::nullopt;
  const double cx = r.uniform(-5, 5), cy = r.uniform(-5, 5), scale = r.uniform(0.5, 20), t0 = r.uniform(0, kTwoPi);
  double t = t0;
  for (int k = 0; k < n; ++k) {
    const double rad = scale * r.uniform(0.15, 1.0);
    c.poly.push_back({cx + rad * std::cos(t), cy + rad * std::sin(t)});
    t += gaps[k] / sum * kTwoPi;
  }
  c.params = fmt("scale", scale);
  if (!finish_simple_case(c)) return std::nullopt;
  return c;
}

// 1b: a wavy circle r(t) = 1 + sum a_k cos(k t + p_k) (|sum a_k| < 1/2) pushed through two shears
// (x, y) -> (x + b sin(f y + p), y) and (x, y) -> (x, y + b' sin(f' x + p')), which are orientation-preserving
// bijections of the plane: usually not star-shaped; the sampled polygon's simplicity is checked exactly.
inline std::optional<GenCase> gen_deformed_circle(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "deformed_circle";
  c.seed = seed;
  double a[4], p[4];
  for (int k = 0; k < 4; ++k) {
    a[k] = r.uniform(-0.12, 0.12);
    p[k] = r.uniform(0, kTwoPi);
  }
  const double b1 = r.uniform(0.2, 1.0), f1 = r.uniform(1.0, 3.5), q1 = r.uniform(0, kTwoPi);
  const double b2 = r.uniform(0.2, 1.0), f2 = r.uniform(1.0, 3.5), q2 = r.uniform(0, kTwoPi);
  int n = r.integer(16, 100);
  for (int attempt = 0; attempt < 3; ++attempt, n *= 2) {
    c.poly.clear();
    for (int j = 0; j < n; ++j) {
      const double t = kTwoPi * j / n;
      double rad = 1;
      for (int k = 0; k < 4; ++k) rad += a[k] * std::cos((k + 2) * t + p[k]);
      double x = rad * std::cos(t), y = rad * std::sin(t);
      x += b1 * std::sin(f1 * y + q1);
      y += b2 * std::sin(f2 * x + q2);
      c.poly.push_back({x, y});
    }
    c.params = fmt("b1", b1) + fmt("f1", f1) + fmt("b2", b2) + fmt("f2", f2);
    if (finish_simple_case(c)) return c;
  }
  return std::nullopt;
}

// 1b: a comb (rectangle with trapezoidal teeth on top, sometimes also below), randomly rotated.
inline std::optional<GenCase> gen_comb(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "comb";
  c.seed = seed;
  const int teeth = r.integer(2, 16);
  const bool below = r.chance(0.5);
  const double W = teeth;
  Poly p;
  p.push_back({0, 0});
  if (below)
    for (int i = 0; i < teeth; ++i) {
      const double xl = i + r.uniform(0.1, 0.3), xr = i + 1 - r.uniform(0.1, 0.3), h = r.uniform(0.5, 4.0);
      const double j1 = r.uniform(0, 0.1), j2 = r.uniform(0, 0.1);
      p.push_back({xl, 0});
      p.push_back({xl + j1, -h});
      p.push_back({xr - j2, -h});
      p.push_back({xr, 0});
    }
  p.push_back({W, 0});
  p.push_back({W, 1});
  for (int i = teeth - 1; i >= 0; --i) {
    const double xl = i + r.uniform(0.1, 0.3), xr = i + 1 - r.uniform(0.1, 0.3), h = r.uniform(0.5, 4.0);
    const double j1 = r.uniform(0, 0.1), j2 = r.uniform(0, 0.1);
    p.push_back({xr, 1});
    p.push_back({xr - j2, 1 + h});
    p.push_back({xl + j1, 1 + h});
    p.push_back({xl, 1});
  }
  p.push_back({0, 1});
  const bool rotate = r.chance(0.7);
  c.poly = rotate ? transformed(p, r.uniform(0, kTwoPi), r.uniform(0.1, 10), r.uniform(-3, 3), r.uniform(-3, 3)) : p;
  c.params = fmt("teeth", teeth) + fmt("below", below) + fmt("rotated", rotate);
  if (!finish_simple_case(c)) return std::nullopt;
  return c;
}

// 1b: a zigzag band: an x-monotone zigzag and its vertical translate by 2w; x-monotone, so simple.
inline std::optional<GenCase> gen_zigzag(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "zigzag";
  c.seed = seed;
  const int m = r.integer(3, 30);
  const double dx = r.uniform(0.3, 1.0), amp = r.uniform(0.5, 3.0), w = r.uniform(0.1, 0.45) * dx;
  std::vector<double> xs(m + 1), ys(m + 1);
  for (int k = 0; k <= m; ++k) {
    xs[k] = k * dx + r.uniform(-0.2, 0.2) * dx;
    ys[k] = (k % 2 ? amp : -amp) * r.uniform(0.5, 1.0);
  }
  Poly p;
  for (int k = 0; k <= m; ++k) p.push_back({xs[k], ys[k] - w});
  for (int k = m; k >= 0; --k) p.push_back({xs[k], ys[k] + w});
  c.poly = transformed(p, r.uniform(0, kTwoPi), r.uniform(0.2, 5), r.uniform(-3, 3), r.uniform(-3, 3));
  c.params = fmt("m", m) + fmt("amp", amp) + fmt("w", w);
  if (!finish_simple_case(c)) return std::nullopt;
  return c;
}

// 1b: a dart. B = (0, 0), A on the positive x axis, C below it (so (A, B, C) is counterclockwise), then a
// chain D_1..D_k from C back to A strictly inside the triangle ABC, at increasing angles around B. The
// polygon [A, B, C, D_1, .., D_k] is star-shaped from B, hence simple and counterclockwise; but B is a
// false ear: its triangle ABC contains the whole chain, which touches the ear's sides only at A and C.
// Randomly rotated / scaled and cyclically relabeled.
inline std::optional<GenCase> gen_dart(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "dart";
  c.seed = seed;
  const double la = r.uniform(1, 3), lc = r.uniform(1, 3), thc = r.uniform(0.4, 2.6);
  const Pt A{la, 0}, B{0, 0}, C{lc * std::cos(-thc), lc * std::sin(-thc)};
  const int k = r.integer(1, 10);
  std::vector<double> ang(k);
  for (double& a : ang) a = -thc + thc * r.uniform(0.02, 0.98);
  std::sort(ang.begin(), ang.end());
  Poly p{A, B, C};
  for (double a : ang) {
    // distance from B to the chord AC along direction a
    const double dx = std::cos(a), dy = std::sin(a);
    const double ex = C.x - A.x, ey = C.y - A.y;
    const double den = dx * ey - dy * ex;
    if (std::fabs(den) < 1e-12) return std::nullopt;
    const double t = (A.x * ey - A.y * ex) / den;
    const double rad = t * r.uniform(0.15, 0.95);
    p.push_back({rad * dx, rad * dy});
  }
  const size_t shift = (size_t)r.integer(0, (int)p.size() - 1);
  std::rotate(p.begin(), p.begin() + long(shift), p.end());
  c.poly = r.chance(0.5) ? transformed(p, r.uniform(0, kTwoPi), r.uniform(0.1, 10), r.uniform(-3, 3), r.uniform(-3, 3)) : p;
  c.params = "k=" + std::to_string(k) + " B_at=" + std::to_string((p.size() + 1 - shift) % p.size());
  if (!finish_simple_case(c)) return std::nullopt;
  return c;
}

// The opposite orientation of a case: turning number -T <= -1, so never weakly self-overlapping.
inline GenCase reversed_case(const GenCase& c) {
  GenCase r;
  r.family = c.family + "_reversed";
  r.seed = c.seed;
  r.params = c.params;
  r.poly = reversed(c.poly);
  r.turning = -c.turning;
  r.expect = Expect::not_self_overlapping;
  return r;
}

}  // namespace lipmap::testgen
