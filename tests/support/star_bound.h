// A lower bound on the conformal distortion K = sigma1 / sigma2 that every locally injective map of a mesh
// must reach somewhere around an interior vertex, from that vertex's star alone; and the ring distance of
// vertices from the boundary it is taken over. Shared by tests/engine/test_extremal.cpp and
// bench/bench_extremal.cpp, so that a test's verdict and the bench's column are one computation; it shares no
// code with the engine.
//
// Why it holds: an affine map of dilatation K takes the triangle (0, 1, z) (the vertex at 0, z in the upper
// half-plane) to one whose shape z' lies within hyperbolic distance log K of z (the Teichmuller distance of
// triangles), a Euclidean disk of center x + i y cosh(log K) and radius y sinh(log K); the angle at the vertex,
// arg z', then ranges over arg(center) -+ asin(radius / |center|). In the plane the star's angles add up to
// 2 pi, so max K over the star is at least the least K for which the smallest angles add up to at most 2 pi
// and the largest to at least 2 pi. (Necessary only: the faces must also agree on their shared edges.) A
// vertex whose 3D angle sum is far from 2 pi (a cone) forces such a K whatever the boundary.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <map>
#include <utility>
#include <vector>

#include "engine/geometry.h"

namespace lipmap::starbound {

// Edges from the boundary (vertices on an edge used by one face are at 0), by breadth-first search over the
// edges; -1 for a vertex no face uses.
inline std::vector<int> ring_distances(std::size_t vertex_count, const std::vector<Triangle>& faces) {
  std::vector<int> dist(vertex_count, -1);
  std::vector<std::vector<int>> nbr(vertex_count);
  std::map<std::pair<int, int>, int> uses;
  for (const Triangle& t : faces)
    for (int c = 0; c < 3; ++c) {
      const int a = t[c], b = t[(c + 1) % 3];
      nbr[static_cast<std::size_t>(a)].push_back(b);
      nbr[static_cast<std::size_t>(b)].push_back(a);
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  std::vector<int> queue;
  for (const auto& [e, n] : uses)
    if (n == 1)
      for (int v : {e.first, e.second})
        if (dist[static_cast<std::size_t>(v)] < 0) {
          dist[static_cast<std::size_t>(v)] = 0;
          queue.push_back(v);
        }
  for (std::size_t i = 0; i < queue.size(); ++i)
    for (int w : nbr[static_cast<std::size_t>(queue[i])])
      if (dist[static_cast<std::size_t>(w)] < 0) {
        dist[static_cast<std::size_t>(w)] = dist[static_cast<std::size_t>(queue[i])] + 1;
        queue.push_back(w);
      }
  return dist;
}

// The bound for one star, its faces given as (|v b| / |v a|, angle at v) for the corner (v, a, b).
inline double star_bound(const std::vector<std::array<double, 2>>& shapes) {
  constexpr double kTwoPi = 6.283185307179586477;
  constexpr double kPi = 3.141592653589793238;
  auto fits = [&](double log_k) {
    double lo = 0, hi = 0;
    for (const auto& [ratio, angle] : shapes) {
      const double x = ratio * std::cos(angle), y = ratio * std::sin(angle);
      const double cy = y * std::cosh(log_k), radius = y * std::sinh(log_k), c = std::hypot(x, cy);
      const double mid = std::atan2(cy, x), half = std::asin(std::min(1.0, radius / c));
      lo += std::max(0.0, mid - half);
      hi += std::min(kPi, mid + half);
    }
    return lo <= kTwoPi && hi >= kTwoPi;
  };
  if (fits(0)) return 1;
  double a = 0, b = 30;  // bisection on log K
  for (int i = 0; i < 60; ++i) {
    const double m = 0.5 * (a + b);
    (fits(m) ? b : a) = m;
  }
  return std::exp(b);
}

// The largest star_bound over the vertices at least min_ring edges from the boundary (dist: ring_distances).
inline double largest_star_bound(const std::vector<Point3>& vertices, const std::vector<Triangle>& faces,
                                 const std::vector<int>& dist, int min_ring) {
  std::vector<std::vector<std::array<double, 2>>> star(vertices.size());
  for (const Triangle& t : faces)
    for (int c = 0; c < 3; ++c) {
      const int v = t[c], a = t[(c + 1) % 3], b = t[(c + 2) % 3];
      if (dist[static_cast<std::size_t>(v)] < min_ring) continue;
      const Point3 &p = vertices[static_cast<std::size_t>(v)], &q = vertices[static_cast<std::size_t>(a)],
                   &w = vertices[static_cast<std::size_t>(b)];
      const double e1[3] = {q.x - p.x, q.y - p.y, q.z - p.z}, e2[3] = {w.x - p.x, w.y - p.y, w.z - p.z};
      const double l1 = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
      const double l2 = std::sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
      const double cr[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
      const double angle = std::atan2(std::sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]),
                                      e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]);
      if (l1 > 0 && l2 > 0 && angle > 0) star[static_cast<std::size_t>(v)].push_back({l2 / l1, angle});
    }
  double bound = 1;
  for (const auto& s : star)
    if (s.size() >= 3) bound = std::max(bound, star_bound(s));
  return bound;
}

}  // namespace lipmap::starbound
