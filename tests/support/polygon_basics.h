// Polygon generators, part A (no CGAL; the classification benchmark uses it alone): value types, a
// deterministic RNG, the grid-mesh builder and the raw polygons. The verified families are in
// polygon_families_*.h; polygon_generators.h includes them all.
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

#include "grid_cells.h"
#include "testgen_types.h"

namespace lipmap::testgen {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2 * kPi;

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
  m.triangles = grid_triangles(nx, ny, [&rng](int, int) { return rng.chance(0.5); });
  m.boundary = grid_boundary(nx, ny);
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
