// Polygon generators with answers known independently of the engine (tests and benchmarks only).
//
// Part A (always available, no CGAL): value types, a deterministic RNG, the grid-mesh builder and the raw
// polygons the benchmark uses. Part B (unless LIPMAP_TESTGEN_NO_CGAL is defined): the verified families,
// each case carrying its expected verdict and the reason it is known:
//
//  1a  images of a grid mesh of a rectangle under a locally injective map g (exp on a strip, z^k away
//      from 0, spiral strips, bent strips). Every image triangle is checked strictly positive with the
//      exact predicate, every interior vertex's angle sum is 2 pi, every boundary vertex's < 2 pi: the map
//      is locally injective, so its boundary is self-overlapping by definition (or simple).
//  1b  simple polygons by construction (star-shaped, bijective deformations of a circle, combs, zigzag
//      bands), simplicity also checked exactly; counterclockwise -> simple, reversed -> not.
//  1c  trees of strictly positive triangles (no interior vertex ever): the boundary is weakly
//      self-overlapping, the construction is a certificate triangulation with known R_i; and the
//      "double loop" with two hubs, whose hub fans are certificates.
//  1d  not self-overlapping: turning number <= 0 (figure eights, clockwise curves, negative trochoids;
//      every weakly self-overlapping polygon has T = 1 + sum R_i >= 1), curls with a region of negative
//      winding number (see gen_curls), and pinched flowers (T = 1, no negative winding; see gen_flower).
//  small polygons (n <= 10, real or lattice coordinates) answered by an exhaustive oracle that enumerates
//      every positive triangulation (exhaustive_triangulations in triangulation_checker.h).
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

#include "testgen_types.h"

namespace lipmap::testgen {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2 * kPi;

// ---------------------------------------------------------------------------------------------------
// Part A: no CGAL.

// splitmix64: the same stream on every platform (std distributions are implementation-defined).
class Rng {
public:
  explicit Rng(std::uint64_t seed) : s_(seed * 0x9E3779B97F4A7C15ULL + 0x632BE59BD9B4E019ULL) {}
  std::uint64_t next() {
    std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  int integer(int lo, int hi) { return lo + int(next() % std::uint64_t(hi - lo + 1)); }  // inclusive
  bool chance(double p) { return uniform() < p; }

private:
  std::uint64_t s_;
};

inline Poly reversed(const Poly& p) {  // same vertex 0, opposite direction
  Poly r;
  r.reserve(p.size());
  if (p.empty()) return r;
  r.push_back(p[0]);
  for (size_t i = p.size() - 1; i >= 1; --i) r.push_back(p[i]);
  return r;
}

inline Poly transformed(const Poly& p, double angle, double scale, double tx, double ty, bool mirror = false) {
  const double c = std::cos(angle) * scale, s = std::sin(angle) * scale;
  Poly r;
  r.reserve(p.size());
  for (const Pt& q : p) {
    const double y = mirror ? -q.y : q.y;
    r.push_back({c * q.x - s * y + tx, s * q.x + c * y + ty});
  }
  return r;
}

inline std::vector<double> linspace(double a, double b, int cells) {
  std::vector<double> v(cells + 1);
  for (int i = 0; i <= cells; ++i) v[i] = a + (b - a) * double(i) / double(cells);
  v[cells] = b;
  return v;
}

// A triangulated grid of a rectangle, (nx+1) x (ny+1) vertices, mapped into the plane vertex by vertex.
// Domain triangles are counterclockwise; `boundary` is the domain boundary loop, counterclockwise.
struct GridMesh {
  int nx = 0, ny = 0;
  std::vector<Pt> image;
  std::vector<Tri> triangles;
  std::vector<int> boundary;
  int id(int i, int j) const { return j * (nx + 1) + i; }
  Poly boundary_polygon() const {
    Poly p;
    p.reserve(boundary.size());
    for (int v : boundary) p.push_back(image[v]);
    return p;
  }
};

// g(i, j) gives the image of grid vertex (i, j); the diagonal of each cell is chosen at random.
inline GridMesh make_grid_mesh(int nx, int ny, const std::function<Pt(int, int)>& g, Rng& rng) {
  GridMesh m;
  m.nx = nx;
  m.ny = ny;
  m.image.resize(size_t(nx + 1) * size_t(ny + 1));
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) m.image[m.id(i, j)] = g(i, j);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = m.id(i, j), b = m.id(i + 1, j), c = m.id(i + 1, j + 1), d = m.id(i, j + 1);
      if (rng.chance(0.5)) {
        m.triangles.push_back({a, b, c});
        m.triangles.push_back({a, c, d});
      } else {
        m.triangles.push_back({a, b, d});
        m.triangles.push_back({b, c, d});
      }
    }
  for (int i = 0; i < nx; ++i) m.boundary.push_back(m.id(i, 0));
  for (int j = 0; j < ny; ++j) m.boundary.push_back(m.id(nx, j));
  for (int i = nx; i > 0; --i) m.boundary.push_back(m.id(i, ny));
  for (int j = ny; j > 0; --j) m.boundary.push_back(m.id(0, j));
  return m;
}

// Raw polygons for the benchmark (not verified here; the tests verify the same constructions).

// Star-shaped around the origin (sorted angles, positive radii): simple and counterclockwise.
inline Poly noisy_circle(int n, double radial_noise, Rng& rng) {
  Poly p;
  p.reserve(n);
  for (int k = 0; k < n; ++k) {
    const double t = kTwoPi * (k + rng.uniform(-0.3, 0.3)) / n;
    const double r = 1.0 + radial_noise * rng.uniform(-1.0, 1.0);
    p.push_back({r * std::cos(t), r * std::sin(t)});
  }
  return p;
}

// Gently wavy star-shaped polygon: simple and counterclockwise.
inline Poly wavy_polygon(int n, Rng& rng) {
  const double p1 = rng.uniform(0, kTwoPi), p2 = rng.uniform(0, kTwoPi);
  Poly p;
  p.reserve(n);
  for (int k = 0; k < n; ++k) {
    const double t = kTwoPi * k / n;
    const double r = 1.0 + 0.15 * std::sin(5 * t + p1) + 0.05 * std::sin(11 * t + p2) + 0.002 * rng.uniform(-1, 1);
    p.push_back({r * std::cos(t), r * std::sin(t)});
  }
  return p;
}

// Spiral strip: (rho, theta) -> (r0 + c theta + rho)(cos theta, sin theta), rho in [0, w], theta in
// [0, 2 pi turns]. Locally injective (Jacobian determinant r0 + c theta + rho > 0); its layers overlap
// when w > 2 pi c. `overlap` = w / (2 pi c).
inline GridMesh spiral_strip_mesh(int n_rho, int n_theta, double turns, double r0, double c, double overlap, Rng& rng) {
  const double w = overlap * kTwoPi * c;
  const double Theta = turns * kTwoPi;
  const std::vector<double> rho = linspace(0, w, n_rho), th = linspace(0, Theta, n_theta);
  return make_grid_mesh(
      n_rho, n_theta,
      [&](int i, int j) {
        const double r = r0 + c * th[j] + rho[i];
        return Pt{r * std::cos(th[j]), r * std::sin(th[j])};
      },
      rng);
}

// Heavily overlapping spiral boundary with about n vertices (n = 2 (1 + n_theta)).
inline Poly overlapping_spiral(int n, double turns, Rng& rng) {
  const int n_theta = std::max(4, n / 2 - 1);
  return spiral_strip_mesh(1, n_theta, turns, 1.0, 0.15, 1.6, rng).boundary_polygon();
}

}  // namespace lipmap::testgen

#ifndef LIPMAP_TESTGEN_NO_CGAL
// ---------------------------------------------------------------------------------------------------
// Part B: verified families (needs CGAL and the independent checker).
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

// ---------------------------------------------------------------------------------------------------
// 1c: trees of triangles.

// A triangulation grown one positive triangle at a time, each glued onto a boundary edge with a new vertex.
struct TriangleTree {
  std::vector<Pt> pos;
  std::vector<Tri> tris;       // counterclockwise, indices into pos
  std::vector<int> boundary;   // boundary loop (vertex ids), interior on the left
  bool allow_coincident = false;  // may a new vertex sit where an old one is (never a neighbour of it)

  long double angle_sum(int v) const {
    long double s = 0;
    for (const Tri& t : tris)
      for (int k = 0; k < 3; ++k)
        if (t[k] == v) s += corner_angle(pos[t[k]], pos[t[(k + 1) % 3]], pos[t[(k + 2) % 3]]);
    return s;
  }
  long double boundary_angle_at(size_t e) const {  // interior angle of the boundary polygon at boundary[e]
    const size_t nb = boundary.size();
    return interior_angle(pos[boundary[(e + nb - 1) % nb]], pos[boundary[e]], pos[boundary[(e + 1) % nb]]);
  }
  // Glue the triangle (q, p, w) onto the boundary edge p = boundary[e] -> q = boundary[e + 1]; w must be on
  // the right of p -> q. Rejected (nothing changes) unless the triangle is strictly positive by the exact
  // predicate, its angles are all > min_angle, and the boundary keeps its angles away from 0 and 2 pi.
  bool glue(size_t e, const Pt& w, double min_angle = 0.05) {
    const size_t nb = boundary.size();
    const int p = boundary[e], q = boundary[(e + 1) % nb];
    if (exact::orient(pos[q], pos[p], w) <= 0) return false;
    if (corner_angle(pos[q], pos[p], w) < min_angle || corner_angle(pos[p], w, pos[q]) < min_angle ||
        corner_angle(w, pos[q], pos[p]) < min_angle)
      return false;
    if (!allow_coincident)
      for (const Pt& o : pos)
        if (o == w) return false;
    const int id = (int)pos.size();
    pos.push_back(w);
    tris.push_back({q, p, id});
    boundary.insert(boundary.begin() + long(e + 1), id);
    bool ok = true;
    for (size_t k = e; k <= e + 2; ++k) {
      const long double a = boundary_angle_at(k % boundary.size());
      if (a < 1e-3L || a > kTwoPiL - 1e-3L) ok = false;
    }
    if (!ok) {
      boundary.erase(boundary.begin() + long(e + 1));
      tris.pop_back();
      pos.pop_back();
    }
    return ok;
  }
};

// Converts a tree to a GenCase: polygon = boundary loop, certificate = the tree's triangles (renumbered),
// R from the angle sums. Expected: weakly_self_overlapping when T = 1 + sum R >= 2 (every triangulation
// then has sum R = T - 1 > 0), else simple or self_overlapping.
inline bool finish_tree_case(GenCase& c, const TriangleTree& tree, int max_R = kGenMaxRotationIndex) {
  std::vector<int> where(tree.pos.size(), -1);
  for (size_t k = 0; k < tree.boundary.size(); ++k) where[tree.boundary[k]] = (int)k;
  c.poly.clear();
  for (int v : tree.boundary) c.poly.push_back(tree.pos[v]);
  c.certificate.clear();
  for (const Tri& t : tree.tris) c.certificate.push_back({where[t[0]], where[t[1]], where[t[2]]});
  if (!well_conditioned(c.poly)) return false;
  std::vector<int> R;
  const CheckReport rep = check_triangulation(c.poly, c.certificate, {}, &R);
  if (!rep.ok()) return false;
  int sum = 0;
  for (int v : R) {
    if (v < 0 || v > max_R) return false;
    sum += v;
  }
  if (!check_triangulation(c.poly, c.certificate, R).ok()) return false;
  c.certificate_R = R;
  c.turning = 1 + sum;
  if (turning_number(c.poly) != c.turning) return false;
  c.expect = c.turning >= 2 ? Expect::weakly_self_overlapping : Expect::simple_or_self_overlapping;
  return true;
}

// Options of gen_tree. Default: 0 to 2 hubs of 1 or 2 turns, real coordinates.
struct TreeOptions {
  bool lattice = false;      // snap every vertex to the grid (Z/4)^2: exact collinearities, and distinct
                             // vertices at the same point (pinched polygons) are allowed
  int deep_min_turns = 0;    // > 0: exactly one hub, wrapped deep_min_turns..deep_max_turns turns
  int deep_max_turns = 0;
  const char* family = "tree";
};

// 1c: random tree of triangles; hubs around which the growth wraps until the hub's triangulation
// angle passes 2 pi * target (so R_hub = target >= 1 when target > 0).
inline std::optional<GenCase> gen_tree(std::uint64_t seed, const TreeOptions& opt = {}) {
  Rng r(seed);
  GenCase c;
  c.family = opt.family;
  c.seed = seed;
  auto snap = [&](Pt q) { return opt.lattice ? Pt{std::round(q.x * 4) / 4, std::round(q.y * 4) / 4} : q; };
  TriangleTree t;
  t.allow_coincident = opt.lattice;
  {
    const double a0 = r.uniform(0, kTwoPi);
    const double ang = r.uniform(0.5, 1.2), len = r.uniform(0.6, 1.4);
    const double sc = opt.lattice ? 2.0 : 1.0;
    const Pt A{0, 0}, B = snap({sc * std::cos(a0), sc * std::sin(a0)});
    const Pt C = snap({sc * len * std::cos(a0 + ang), sc * len * std::sin(a0 + ang)});
    if (exact::orient(A, B, C) <= 0) return std::nullopt;
    t.pos = {A, B, C};
    t.tris = {{0, 1, 2}};
    t.boundary = {0, 1, 2};
  }
  const bool deep = opt.deep_min_turns > 0;
  const int n_target = r.integer(6, 36);
  const int hubs = deep ? 1 : (r.chance(0.2) ? 0 : (r.chance(0.75) ? 1 : 2));
  std::vector<std::pair<int, long double>> hub_goal;  // vertex, angle sum to reach
  int total_target = 0;
  for (int h = 0; h < hubs; ++h) {
    const int target = deep ? r.integer(opt.deep_min_turns, opt.deep_max_turns) : (r.chance(0.8) ? 1 : 2);
    total_target += target;
    hub_goal.push_back({-1, kTwoPiL * target + (long double)r.uniform(0.4, 4.0)});
  }
  const int max_vertices = deep ? 40 + 12 * opt.deep_max_turns : 70;
  const double sc = opt.lattice ? 2.0 : 1.0;
  int guard = 0;
  size_t hub_index = 0;
  while (guard++ < 4000) {
    const bool hub_pending = hub_index < hub_goal.size();
    if (!hub_pending && (int)t.pos.size() >= n_target) break;
    if ((int)t.pos.size() >= max_vertices) return std::nullopt;
    if (hub_pending && ((int)t.pos.size() >= n_target || r.chance(0.65))) {
      auto& [hub, goal] = hub_goal[hub_index];
      if (hub < 0) {
        hub = t.boundary[size_t(r.integer(0, (int)t.boundary.size() - 1))];
        bool taken = false;
        for (size_t k = 0; k < hub_index; ++k) taken |= hub_goal[k].first == hub;
        if (taken) {
          hub = -1;
          continue;
        }
      }
      if (t.angle_sum(hub) >= goal) {
        ++hub_index;
        continue;
      }
      size_t e = 0;
      while (t.boundary[e] != hub) ++e;
      const Pt H = t.pos[hub], Q = t.pos[t.boundary[(e + 1) % t.boundary.size()]];
      const double phi = std::atan2(Q.y - H.y, Q.x - H.x), delta = r.uniform(0.35, 1.0);
      const double rho = std::clamp(std::hypot(Q.x - H.x, Q.y - H.y) * r.uniform(0.7, 1.3), 0.3 * sc, 3.0 * sc);
      t.glue(e, snap({H.x + rho * std::cos(phi - delta), H.y + rho * std::sin(phi - delta)}));
    } else {
      const size_t e = (size_t)r.integer(0, (int)t.boundary.size() - 1);
      const Pt P = t.pos[t.boundary[e]], Q = t.pos[t.boundary[(e + 1) % t.boundary.size()]];
      const double dx = Q.x - P.x, dy = Q.y - P.y;
      const double out = r.uniform(0.3, 1.0), along = r.uniform(-0.5, 0.5);
      // right normal of P -> Q is (dy, -dx)
      t.glue(e, snap({0.5 * (P.x + Q.x) + out * dy + along * dx, 0.5 * (P.y + Q.y) - out * dx + along * dy}));
    }
  }
  if (hub_index < hub_goal.size()) return std::nullopt;
  if (!finish_tree_case(c, t, std::max(kGenMaxRotationIndex, opt.deep_max_turns))) return std::nullopt;
  c.params = "hubs=" + std::to_string(hubs) + " hub_turns=" + std::to_string(total_target) +
             " T=" + std::to_string(c.turning) + (opt.lattice ? " lattice" : "");
  return c;
}

// 1c: the double loop. Polygon O1 = (-eps, 0), O2 = (eps, 0), v_1..v_m on r(t) = 1 + amp cos(t / 2),
// t from pi/2 + 0.1 to pi/2 + 2 pi L - 0.1 (counterclockwise, L = loops around the hubs). Turning number:
// the curve turns 2 pi L, and the corners at O2, v_1, v_m, O1 are all left turns of about pi/2, so T = L + 1.
// Fans from O1 and from O2 are triangulations (checked exactly by the caller / generator).
struct DoubleLoop {
  Poly poly;                // [O1, O2, v_1, ..., v_m]
  int loops = 0;
  std::vector<Tri> fan_O1;  // (O1, O2, v_1), (O1, v_k, v_k+1)
  std::vector<Tri> fan_O2;  // (O2, v_k, v_k+1), (O1, O2, v_m)
  int outermost = -1;       // index of the vertex of largest radius
};

inline DoubleLoop make_double_loop(int loops, int m, double eps, double amp = 0.3, double noise = 0, Rng* rng = nullptr) {
  DoubleLoop d;
  d.loops = loops;
  d.poly.push_back({-eps, 0});
  d.poly.push_back({eps, 0});
  const double ta = kPi / 2 + 0.1, tb = kPi / 2 + kTwoPi * loops - 0.1;
  double best = -1;
  for (int k = 0; k < m; ++k) {
    const double t = ta + (tb - ta) * k / (m - 1);
    double rad = 1 + amp * std::cos(t / 2);
    if (rng && noise > 0) rad *= 1 + noise * rng->uniform(-1, 1);
    d.poly.push_back({rad * std::cos(t), rad * std::sin(t)});
    if (rad > best) {
      best = rad;
      d.outermost = 2 + k;
    }
  }
  const int n = (int)d.poly.size();
  d.fan_O1.push_back({0, 1, 2});
  for (int k = 2; k + 1 < n; ++k) d.fan_O1.push_back({0, k, k + 1});
  for (int k = 2; k + 1 < n; ++k) d.fan_O2.push_back({1, k, k + 1});
  d.fan_O2.push_back({0, 1, n - 1});
  return d;
}

inline std::optional<GenCase> gen_double_loop(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "double_loop";
  c.seed = seed;
  const int loops = r.integer(1, 2);
  const int m = r.integer(12, 30) * loops;
  const double eps = r.uniform(0.01, 0.1), amp = r.uniform(0.2, 0.35), noise = r.uniform(0, 0.02);
  const DoubleLoop d = make_double_loop(loops, m, eps, amp, noise, &r);
  const bool use_O2 = r.chance(0.5);
  c.poly = d.poly;
  c.certificate = use_O2 ? d.fan_O2 : d.fan_O1;
  if (r.chance(0.7)) {  // a random similarity keeps the certificate valid up to rounding: re-checked below
    c.poly = transformed(c.poly, r.uniform(0, kTwoPi), r.uniform(0.5, 10), r.uniform(-5, 5), r.uniform(-5, 5));
  }
  c.params = fmt("loops", loops) + fmt("eps", eps) + fmt("amp", amp) + fmt("noise", noise) + (use_O2 ? "fan=O2" : "fan=O1");
  if (!well_conditioned(c.poly)) return std::nullopt;
  std::vector<int> R;
  if (!check_triangulation(c.poly, c.certificate, {}, &R).ok()) return std::nullopt;
  if (!check_triangulation(c.poly, c.certificate, R).ok()) return std::nullopt;
  int sum = 0;
  for (int v : R) sum += v;
  c.certificate_R = R;
  c.turning = 1 + sum;
  if (c.turning != loops + 1 || turning_number(c.poly) != c.turning) return std::nullopt;
  c.expect = Expect::weakly_self_overlapping;
  return c;
}

// ---------------------------------------------------------------------------------------------------
// 1d: not self-overlapping.

// Figure eight (lemniscate of Gerono, radial noise, random similarity, possibly mirrored): T = 0.
inline std::optional<GenCase> gen_figure_eight(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "figure_eight";
  c.seed = seed;
  const int n = r.integer(8, 80);
  const double noise = r.uniform(0, 0.05), squash = r.uniform(0.3, 1.5), t0 = r.uniform(0, kTwoPi);
  Poly p;
  for (int k = 0; k < n; ++k) {
    const double t = t0 + kTwoPi * k / n;
    const double f = 1 + noise * r.uniform(-1, 1);
    p.push_back({f * std::cos(t), f * squash * std::sin(t) * std::cos(t)});
  }
  const bool mirror = r.chance(0.5);
  c.poly = transformed(p, r.uniform(0, kTwoPi), r.uniform(0.2, 8), r.uniform(-4, 4), r.uniform(-4, 4), mirror);
  c.params = fmt("noise", noise) + fmt("squash", squash) + fmt("mirror", mirror);
  c.turning = 0;
  c.expect = Expect::not_self_overlapping;
  if (!well_conditioned(c.poly) || turning_number(c.poly) != 0) return std::nullopt;
  return c;
}

// z(t) = e^{it} + b e^{imt}, m <= -1, b |m| > 1: the derivative winds m times, so T = m <= -1.
inline std::optional<GenCase> gen_negative_trochoid(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "negative_trochoid";
  c.seed = seed;
  const int m = -r.integer(1, 4);
  const double b = r.uniform(1.0 / -m + 0.1, 1.5);
  int n = r.integer(12, 40) * (1 - m);
  for (int attempt = 0; attempt < 3; ++attempt, n *= 2) {
    c.poly.clear();
    for (int k = 0; k < n; ++k) {
      const double t = kTwoPi * k / n;
      c.poly.push_back({std::cos(t) + b * std::cos(m * t), std::sin(t) + b * std::sin(m * t)});
    }
    if (well_conditioned(c.poly) && turning_number(c.poly) == m) {
      c.params = fmt("m", m) + fmt("b", b);
      c.turning = m;
      c.expect = Expect::not_self_overlapping;
      return c;
    }
  }
  return std::nullopt;
}

// 1d: a counterclockwise unit circle with k_in >= 0 inward counterclockwise curls and k_out >= 1 outward
// clockwise curls; T = 1 + k_in - k_out (0, 1, 2 and -1 occur).
//
// A curl is a prolate trochoid x = c u + r sin u, y = +-r (1 - cos u), u in [0, 2 pi], r > c, in the frame
// "x along the circle, y towards the center", mapped by (x, y) -> (1 - y) e^{i (t0 + x)} (orientation
// preserving). With y >= 0 it loops on the left, turning left (counterclockwise); with y <= 0 on the right
// (outside), turning right (clockwise): the region enclosed by an outward clockwise curl has winding number
// 0 - 1 = -1.
//
// Why negative winding means not weakly self-overlapping: a weakly self-overlapping polygon has a
// triangulation by strictly positive triangles (Proposition 1); the piecewise-linear map from that disk has,
// at any point q off the triangle edges, degree = winding number of P around q = number of triangles
// containing q >= 0. So a point of negative winding number cannot exist. The generator checks the winding
// number of a probe point inside every outward curl exactly and keeps the case only if one is negative.
inline std::optional<GenCase> gen_curls(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "curls";
  c.seed = seed;
  const int k_out = r.integer(1, 2), k_in = r.integer(0, 2), k = k_in + k_out;
  // Slots around the circle, one curl per slot, in random order.
  std::vector<int> sign(k);  // +1 inward CCW, -1 outward CW
  for (int i = 0; i < k; ++i) sign[i] = i < k_in ? +1 : -1;
  for (int i = k - 1; i > 0; --i) std::swap(sign[i], sign[r.integer(0, i)]);
  const double slot = kTwoPi / k, start = r.uniform(0, kTwoPi);
  struct Curl { double t0, cc, rr; int s; };
  std::vector<Curl> curls;
  for (int i = 0; i < k; ++i) {
    const double cc = r.uniform(0.05, 0.12), rr = cc * r.uniform(1.5, 3.0);
    const double span = kTwoPi * cc;
    const double t0 = start + i * slot + r.uniform(0.05, std::max(0.06, slot - span - 0.05));
    curls.push_back({t0, cc, rr, sign[i]});
  }
  auto to_global = [](double t0, double x, double y) {
    return Pt{(1 - y) * std::cos(t0 + x), (1 - y) * std::sin(t0 + x)};
  };
  const int per_curl = r.integer(16, 32);
  const double arc_step = r.uniform(0.08, 0.25);
  Poly p;
  for (int i = 0; i < k; ++i) {
    const Curl& cu = curls[i];
    for (int q = 0; q <= per_curl; ++q) {
      const double u = kTwoPi * q / per_curl;
      p.push_back(to_global(cu.t0, cu.cc * u + cu.rr * std::sin(u), cu.s * cu.rr * (1 - std::cos(u))));
    }
    // arc to the next curl's start (exclusive at both ends)
    const double a0 = cu.t0 + kTwoPi * cu.cc;
    double a1 = curls[(i + 1) % k].t0;
    if (i + 1 == k) a1 += kTwoPi;
    const int steps = std::max(2, (int)std::ceil((a1 - a0) / arc_step));
    for (int q = 1; q < steps; ++q) {
      const double t = a0 + (a1 - a0) * q / steps;
      p.push_back({std::cos(t), std::sin(t)});
    }
  }
  c.poly = p;
  c.turning = 1 + k_in - k_out;
  c.expect = Expect::not_self_overlapping;
  c.params = "k_in=" + std::to_string(k_in) + " k_out=" + std::to_string(k_out) + " T=" + std::to_string(c.turning);
  if (!well_conditioned(c.poly) || turning_number(c.poly) != c.turning) return std::nullopt;
  // Probe inside each outward loop: crossing at u = pi -+ phi with r sin(phi) = c phi; the loop spans
  // |y| in (r (1 + cos phi), 2 r) at x = c pi.
  for (const Curl& cu : curls) {
    if (cu.s > 0) continue;
    double lo = 1e-9, hi = kPi;
    for (int it = 0; it < 200; ++it) {
      const double mid = 0.5 * (lo + hi);
      (cu.rr * std::sin(mid) - cu.cc * mid > 0 ? lo : hi) = mid;
    }
    const double phi = 0.5 * (lo + hi);
    const double ymid = 0.5 * (cu.rr * (1 + std::cos(phi)) + 2 * cu.rr);
    const Pt probe = to_global(cu.t0, cu.cc * kPi, -ymid);
    bool on = false;
    if (winding_number(c.poly, probe, &on) < 0 && !on) c.negative_probes.push_back(probe);
  }
  if (c.negative_probes.empty()) return std::nullopt;
  return c;
}

// 1d: a flower: k >= 2 petals, each a star-shaped loop [O, p_1..p_m] around its own angular sector of the
// common point O, with gaps between the sectors; the polygon visits O once per petal (distinct vertices at
// the same point). T = 1 (the petals turn sum(w_i) + k pi, the k corners at O turn sum(gap_i) - k pi) and no
// winding number is negative, yet it is not weakly self-overlapping: the visit of O between petal i and
// petal i+1 has the interior angle 2 pi - gap_i (from petal i+1's start round to petal i's end), so the
// triangles at that vertex would sweep every direction except gap_i, and so cover points near O inside
// another gap j, whose winding number is 0 (checked exactly at a probe point in every gap, kept in
// zero_probes); a positive triangle covers only points of winding number >= 1.
inline std::optional<GenCase> gen_flower(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "flower";
  c.seed = seed;
  const int k = r.integer(2, 5);
  const double slot = kTwoPi / k, start = r.uniform(0, kTwoPi);
  Poly p;
  std::vector<double> gap_mid;
  double min_rad = 1e9;
  for (int i = 0; i < k; ++i) {
    const double g = slot * r.uniform(0.1, 0.5);
    const double a0 = start + i * slot + g / 2, a1 = start + (i + 1) * slot - g / 2;
    gap_mid.push_back(start + (i + 1) * slot);
    const int m = r.integer(2, 8);
    const double rad = r.uniform(0.5, 1.5);
    p.push_back({0, 0});
    for (int q = 0; q < m; ++q) {
      const double a = a0 + (a1 - a0) * q / (m - 1), rr = rad * r.uniform(0.7, 1.3);
      min_rad = std::min(min_rad, rr);
      p.push_back({rr * std::cos(a), rr * std::sin(a)});
    }
  }
  const size_t shift = (size_t)r.integer(0, (int)p.size() - 1);
  std::rotate(p.begin(), p.begin() + long(shift), p.end());
  c.poly = p;
  c.turning = 1;
  c.expect = Expect::not_self_overlapping;
  c.params = "petals=" + std::to_string(k);
  if (!well_conditioned(c.poly) || turning_number(c.poly) != 1) return std::nullopt;
  for (double a : gap_mid) {
    const Pt probe{1e-3 * min_rad * std::cos(a), 1e-3 * min_rad * std::sin(a)};
    bool on = true;
    if (winding_number(c.poly, probe, &on) != 0 || on) return std::nullopt;
    c.zero_probes.push_back(probe);
  }
  return c;
}

// Sets the expected answer of a small polygon from the exhaustive oracle (nullopt if it is too big, or
// nearly degenerate: every vertex triple must span a non-negligible area, so the float R are exact).
inline std::optional<GenCase> finish_small_case(GenCase c) {
  if (c.poly.size() < 3 || !well_conditioned(c.poly)) return std::nullopt;
  const size_t n = c.poly.size();
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j)
      for (size_t k = j + 1; k < n; ++k) {
        const Pt &A = c.poly[i], &B = c.poly[j], &C = c.poly[k];
        const double area2 = std::fabs((B.x - A.x) * (C.y - A.y) - (B.y - A.y) * (C.x - A.x));
        if (area2 < 1e-6) return std::nullopt;
      }
  const OracleResult o = exhaustive_triangulations(c.poly);
  if (!o.complete) return std::nullopt;
  for (const auto& [R, t] : o.by_R) {
    if (!check_triangulation(c.poly, t, R).ok()) return std::nullopt;
    c.feasible_R.push_back(R);
  }
  c.turning = turning_number(c.poly);
  if (c.feasible_R.empty()) {
    c.expect = Expect::not_self_overlapping;
  } else {
    c.certificate = o.by_R.begin()->second;
    c.certificate_R = o.by_R.begin()->first;
    c.expect = c.turning == 1 ? Expect::simple_or_self_overlapping : Expect::weakly_self_overlapping;
  }
  c.params += " realizable_R=" + std::to_string(c.feasible_R.size());
  return c;
}

// Small polygons (n <= max_n <= 12) whose answer comes from the exhaustive oracle (exhaustive_triangulations):
// random points in a square, and "winding" polygons (points at increasing angles over 1 to 3 turns around
// the origin with random radii, plus 0 to 2 points near the origin), which are often weakly self-overlapping
// with several realizable rotation-index vectors.
inline std::optional<GenCase> gen_small(std::uint64_t seed, int max_n = 10) {
  Rng r(seed);
  GenCase c;
  c.family = "small";
  c.seed = seed;
  const int mode = r.integer(0, 2);
  if (mode == 0) {
    const int n = r.integer(4, max_n - 1);
    for (int k = 0; k < n; ++k) c.poly.push_back({r.uniform(-1, 1), r.uniform(-1, 1)});
    c.params = "random points";
  } else {
    const int hubs = r.integer(0, 2), loops = std::min(r.integer(1, 3 + (max_n > 10)), (max_n - hubs) / 3);
    const int m = r.integer(3 * loops, max_n - hubs);
    const double a0 = r.uniform(0, kTwoPi), total = kTwoPi * loops - r.uniform(0.3, 1.5);
    for (int h = 0; h < hubs; ++h) c.poly.push_back({r.uniform(-0.3, 0.3), r.uniform(-0.3, 0.3)});
    std::vector<double> a(m);
    for (double& x : a) x = r.uniform(0, total);
    std::sort(a.begin(), a.end());
    for (int k = 0; k < m; ++k) {
      const double rad = r.uniform(0.4, 1.6);
      c.poly.push_back({rad * std::cos(a0 + a[k]), rad * std::sin(a0 + a[k])});
    }
    if (mode == 2 && c.poly.size() > 3) {  // relabel, the hubs land anywhere in the order
      const size_t shift = (size_t)r.integer(0, (int)c.poly.size() - 1);
      std::rotate(c.poly.begin(), c.poly.begin() + long(shift), c.poly.end());
    }
    c.params = "loops=" + std::to_string(loops) + " hubs=" + std::to_string(hubs);
  }
  return finish_small_case(std::move(c));
}

// Small lattice polygons: integer coordinates in [0, 4]^2 (random points), or winding polygons snapped to
// the half-integer grid. Collinear vertices, distinct vertices at one point, vertices on other edges and
// slits (spikes, interior angle 2 pi) all occur; the oracle stays exact (strict positivity by the exact
// predicate, and on such a grid no angle is close to 0 or 2 pi without being exactly that).
inline std::optional<GenCase> gen_small_lattice(std::uint64_t seed, int max_n = 10) {
  Rng r(seed);
  GenCase c;
  c.family = "small_lattice";
  c.seed = seed;
  if (r.chance(0.5)) {
    const int n = r.integer(4, max_n - 1);
    for (int k = 0; k < n; ++k) c.poly.push_back({double(r.integer(0, 4)), double(r.integer(0, 4))});
    c.params = "lattice points";
  } else {
    const int hubs = r.integer(0, 2), loops = std::min(r.integer(1, 3), (max_n - hubs) / 3);
    const int m = r.integer(3 * loops, max_n - hubs);
    const double a0 = r.uniform(0, kTwoPi), total = kTwoPi * loops - r.uniform(0.3, 1.5);
    for (int h = 0; h < hubs; ++h) c.poly.push_back({0.5 * r.integer(-1, 1), 0.5 * r.integer(-1, 1)});
    std::vector<double> a(m);
    for (double& x : a) x = r.uniform(0, total);
    std::sort(a.begin(), a.end());
    for (int k = 0; k < m; ++k) {
      const double rad = r.uniform(1.0, 3.0);
      c.poly.push_back({0.5 * std::round(2 * rad * std::cos(a0 + a[k])), 0.5 * std::round(2 * rad * std::sin(a0 + a[k]))});
    }
    const size_t shift = (size_t)r.integer(0, (int)c.poly.size() - 1);
    std::rotate(c.poly.begin(), c.poly.begin() + long(shift), c.poly.end());
    c.params = "snapped loops=" + std::to_string(loops) + " hubs=" + std::to_string(hubs);
  }
  const size_t n = c.poly.size();
  if (n < 3) return std::nullopt;
  for (size_t i = 0; i < n; ++i)
    if (c.poly[i] == c.poly[(i + 1) % n]) return std::nullopt;
  long double raw = 0;
  c.turning = turning_number(c.poly, &raw);
  if (std::fabs(raw - c.turning) > 1e-9L) return std::nullopt;
  const OracleResult o = exhaustive_triangulations(c.poly);
  if (!o.complete) return std::nullopt;
  for (const auto& [R, t] : o.by_R) {
    if (!check_triangulation(c.poly, t, R).ok()) return std::nullopt;
    c.feasible_R.push_back(R);
  }
  if (c.feasible_R.empty()) {
    c.expect = Expect::not_self_overlapping;
  } else {
    c.certificate = o.by_R.begin()->second;
    c.certificate_R = o.by_R.begin()->first;
    c.expect = c.turning == 1 ? Expect::simple_or_self_overlapping : Expect::weakly_self_overlapping;
  }
  c.params += " realizable_R=" + std::to_string(c.feasible_R.size());
  return c;
}

// ---------------------------------------------------------------------------------------------------
// Family registry.

enum class Family {
  exp_strip, power_map, spiral_overlap, spiral_thin, bent_strip,           // 1a
  star, deformed_circle, comb, zigzag, dart,                                // 1b (+ reversed)
  tree, double_loop, lattice_tree, deep_hub_tree,                           // 1c
  figure_eight, negative_trochoid, curls, grid_reversed, tree_reversed, flower,  // 1d
  small, small_lattice,                                                     // exhaustive oracle
};

inline const char* family_name(Family f) {
  switch (f) {
    case Family::exp_strip: return "exp_strip";
    case Family::power_map: return "power_map";
    case Family::spiral_overlap: return "spiral_overlap";
    case Family::spiral_thin: return "spiral_thin";
    case Family::bent_strip: return "bent_strip";
    case Family::star: return "star";
    case Family::deformed_circle: return "deformed_circle";
    case Family::comb: return "comb";
    case Family::zigzag: return "zigzag";
    case Family::dart: return "dart";
    case Family::flower: return "flower";
    case Family::small: return "small";
    case Family::small_lattice: return "small_lattice";
    case Family::tree: return "tree";
    case Family::double_loop: return "double_loop";
    case Family::lattice_tree: return "lattice_tree";
    case Family::deep_hub_tree: return "deep_hub_tree";
    case Family::figure_eight: return "figure_eight";
    case Family::negative_trochoid: return "negative_trochoid";
    case Family::curls: return "curls";
    case Family::grid_reversed: return "grid_reversed";
    case Family::tree_reversed: return "tree_reversed";
  }
  return "?";
}

inline std::optional<GenCase> generate_one(Family f, std::uint64_t seed) {
  switch (f) {
    case Family::exp_strip: return gen_exp_strip(seed);
    case Family::power_map: return gen_power_map(seed);
    case Family::spiral_overlap: return gen_spiral_strip(seed, true);
    case Family::spiral_thin: return gen_spiral_strip(seed, false);
    case Family::bent_strip: return gen_bent_strip(seed);
    case Family::star: return gen_star(seed);
    case Family::deformed_circle: return gen_deformed_circle(seed);
    case Family::comb: return gen_comb(seed);
    case Family::zigzag: return gen_zigzag(seed);
    case Family::dart: return gen_dart(seed);
    case Family::flower: return gen_flower(seed);
    case Family::small: return gen_small(seed);
    case Family::small_lattice: return gen_small_lattice(seed);
    case Family::tree: return gen_tree(seed);
    case Family::double_loop: return gen_double_loop(seed);
    case Family::lattice_tree: {
      TreeOptions o;
      o.lattice = true;
      o.family = "lattice_tree";
      return gen_tree(seed, o);
    }
    case Family::deep_hub_tree: {
      TreeOptions o;
      o.deep_min_turns = 3;
      o.deep_max_turns = kGenMaxRotationIndex;
      o.family = "deep_hub_tree";
      return gen_tree(seed, o);
    }
    case Family::figure_eight: return gen_figure_eight(seed);
    case Family::negative_trochoid: return gen_negative_trochoid(seed);
    case Family::curls: return gen_curls(seed);
    case Family::grid_reversed: {
      std::optional<GenCase> g;
      switch (seed % 3) {
        case 0: g = gen_exp_strip(seed); break;
        case 1: g = gen_spiral_strip(seed, true); break;
        default: g = gen_bent_strip(seed); break;
      }
      if (!g) return std::nullopt;
      return reversed_case(*g);
    }
    case Family::tree_reversed: {
      std::optional<GenCase> g = gen_tree(seed);
      if (!g) return std::nullopt;
      return reversed_case(*g);
    }
  }
  return std::nullopt;
}

// Default number of cases per family in the test suite (1b families are also run reversed).
inline int default_count(Family f) {
  switch (f) {
    case Family::exp_strip: return 50;
    case Family::power_map: return 40;
    case Family::spiral_overlap: return 50;
    case Family::spiral_thin: return 30;
    case Family::bent_strip: return 40;
    case Family::star: return 120;
    case Family::deformed_circle: return 50;
    case Family::comb: return 30;
    case Family::zigzag: return 30;
    case Family::dart: return 60;
    case Family::flower: return 40;
    case Family::small: return 400;
    case Family::small_lattice: return 400;
    case Family::tree: return 250;
    case Family::double_loop: return 40;
    case Family::lattice_tree: return 120;
    case Family::deep_hub_tree: return 30;
    case Family::figure_eight: return 50;
    case Family::negative_trochoid: return 40;
    case Family::curls: return 100;
    case Family::grid_reversed: return 30;
    case Family::tree_reversed: return 30;
  }
  return 0;
}

inline bool is_simple_family(Family f) {
  return f == Family::star || f == Family::deformed_circle || f == Family::comb || f == Family::zigzag ||
         f == Family::dart;
}

inline const std::vector<Family>& all_families() {
  static const std::vector<Family> all = {
      Family::exp_strip, Family::power_map, Family::spiral_overlap, Family::spiral_thin, Family::bent_strip,
      Family::star, Family::deformed_circle, Family::comb, Family::zigzag, Family::dart, Family::tree, Family::double_loop,
      Family::lattice_tree, Family::deep_hub_tree,
      Family::figure_eight, Family::negative_trochoid, Family::curls, Family::grid_reversed, Family::tree_reversed,
      Family::flower, Family::small, Family::small_lattice};
  return all;
}

// `count` cases of a family from seeds base, base + 1, ... (generators may reject a seed; at most
// 20 * count seeds are tried). Deterministic.
inline std::vector<GenCase> generate(Family f, int count, std::uint64_t base = 0) {
  std::vector<GenCase> out;
  const std::uint64_t family_base = (std::uint64_t(f) + 1) * 1000003ULL + base * 7919ULL;
  for (std::uint64_t s = 0; (int)out.size() < count && s < std::uint64_t(20 * count); ++s)
    if (auto g = generate_one(f, family_base + s)) out.push_back(std::move(*g));
  return out;
}

}  // namespace lipmap::testgen
#endif  // LIPMAP_TESTGEN_NO_CGAL
