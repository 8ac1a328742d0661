// The refinement's polygon test (engine/detail/shor_van_wyk.h: triangulate_self_overlapping with a forbidden-
// triangle predicate, ear clipping in front of the table) against a brute force written here: every
// triangulation of the polygon (Catalan many) enumerated, each checked by the independent triangulation checker
// of tests/support (exact orientations; angle sums in long double, where a triangulation with positive triangles
// has at each vertex the polygon's angle plus a whole number of turns, so rounding cannot decide between a match
// and a miss) and by the forbidden predicate.
// Polygons are made like refine's image polygons: the three corners of a source face and points on its edges,
// mapped by a random, sometimes folding, distortion; triangles with all corners on one edge are forbidden.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <utility>
#include <vector>

#include "engine/detail/shor_van_wyk.h"
#include "tests/support/triangulation_checker.h"

namespace lipmap {
namespace {

using detail::Pt;

struct ImagePolygon {
  std::vector<Point2> points;
  std::vector<unsigned> edges;  // bit i: the vertex lies on source edge i (corner i lies on edges i and i - 1)
};

// A triangulation of the polygon that the refinement may use: the project's independent triangulation checker
// (tests/support/triangulation_checker.h: n - 2 strictly positive triangles forming a disk, every angle the
// polygon's own, R_i = 0) and no triangle with all its corners on one source edge.
bool valid_triangulation(const ImagePolygon& p, const std::vector<Triangle>& tris) {
  for (const Triangle& t : tris)
    if ((p.edges[t[0]] & p.edges[t[1]] & p.edges[t[2]]) != 0) return false;
  testgen::Poly poly;
  for (const Point2& q : p.points) poly.push_back({q.x, q.y});
  const std::vector<testgen::Tri> tri(tris.begin(), tris.end());
  return testgen::check_triangulation(poly, tri, std::vector<int>(poly.size(), 0)).ok();
}

// Every triangulation of the sub-polygon i..j (base edge j -> i), as lists of triangles, passed to `visit`
// until it returns true.
using Visit = std::function<bool(std::vector<Triangle>&)>;
bool any_triangulation(int i, int j, std::vector<Triangle>& acc, const Visit& visit,
                       std::vector<std::pair<int, int>>& pending) {
  if (j - i < 2) {
    if (pending.empty()) return visit(acc);
    const auto [a, b] = pending.back();
    pending.pop_back();
    const bool found = any_triangulation(a, b, acc, visit, pending);
    pending.push_back({a, b});
    return found;
  }
  for (int k = i + 1; k < j; ++k) {
    acc.push_back({i, k, j});
    pending.push_back({k, j});
    const bool found = any_triangulation(i, k, acc, visit, pending);
    pending.pop_back();
    acc.pop_back();
    if (found) return true;
  }
  return false;
}

bool brute_force_exists(const ImagePolygon& p) {
  std::vector<Triangle> acc;
  std::vector<std::pair<int, int>> pending;
  return any_triangulation(0, static_cast<int>(p.points.size()) - 1, acc,
                           [&](std::vector<Triangle>& t) { return valid_triangulation(p, t); }, pending);
}

// A source face with points on its edges (counts 0..3 each), mapped by a smooth random distortion of random
// strength plus a jitter: mildly distorted images are triangulable, strong ones fold.
ImagePolygon make_polygon(std::mt19937_64& rng, int min_n, int max_n) {
  std::uniform_real_distribution<double> unit(0, 1);
  for (;;) {
    const int counts[3] = {static_cast<int>(rng() % 4), static_cast<int>(rng() % 4), static_cast<int>(rng() % 4)};
    const int n = 3 + counts[0] + counts[1] + counts[2];
    if (n < min_n || n > max_n) continue;
    const Point2 corner[3] = {{0, 0}, {1, 0}, {0.3 + 0.4 * unit(rng), 0.5 + 0.6 * unit(rng)}};
    ImagePolygon p;
    for (int i = 0; i < 3; ++i) {
      p.points.push_back(corner[i]);
      p.edges.push_back((1u << i) | (1u << ((i + 2) % 3)));
      std::vector<double> ts;
      for (int k = 0; k < counts[i]; ++k) ts.push_back(0.05 + 0.9 * unit(rng));
      std::sort(ts.begin(), ts.end());
      const Point2 a = corner[i], b = corner[(i + 1) % 3];
      for (double t : ts) {
        p.points.push_back({a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)});
        p.edges.push_back(1u << i);
      }
    }
    const double strength = std::pow(10.0, -2.5 + 3.0 * unit(rng));
    const double fx = 2 + 6 * unit(rng), fy = 2 + 6 * unit(rng), ph = 6.3 * unit(rng);
    const double swirl = strength * 8 * (unit(rng) - 0.5);
    for (Point2& q : p.points) {
      const double dx = strength * std::sin(fx * q.y + ph), dy = strength * std::cos(fy * q.x - ph);
      const double r = std::hypot(q.x - 0.45, q.y - 0.35), th = swirl * std::exp(-4 * r * r);
      const double x = q.x + dx - 0.45, y = q.y + dy - 0.35;
      q = {0.45 + x * std::cos(th) - y * std::sin(th) + 1e-3 * strength * (unit(rng) - 0.5),
           0.35 + x * std::sin(th) + y * std::cos(th) + 1e-3 * strength * (unit(rng) - 0.5)};
    }
    return p;
  }
}

std::optional<std::vector<Triangle>> engine_triangulation(const ImagePolygon& p) {
  std::vector<Pt> pts;
  for (const Point2& q : p.points) pts.emplace_back(q.x, q.y);
  const detail::AllowedTriangle not_flat = [&](int i, int k, int j) {
    return (p.edges[i] & p.edges[k] & p.edges[j]) == 0;
  };
  return detail::triangulate_self_overlapping(pts, &not_flat);
}

// Polygons of 7 to 11 vertices (the ear clipping runs above 6): the engine finds a triangulation exactly when the
// brute force does, and the one it returns passes the brute force's checks.
TEST(ShorVanWykRefinedPolygons, ATriangulationIsFoundExactlyWhenOneExists) {
  std::mt19937_64 rng(11);
  int found = 0, refused = 0;
  for (int c = 0; c < 2500; ++c) {
    const ImagePolygon p = make_polygon(rng, 7, 11);
    const bool exists = brute_force_exists(p);
    const auto tri = engine_triangulation(p);
    ASSERT_EQ(tri.has_value(), exists) << "case " << c << ", " << p.points.size() << " vertices";
    if (tri) ASSERT_TRUE(valid_triangulation(p, *tri)) << "case " << c;
    ++(exists ? found : refused);
  }
  // Both answers are common, so neither direction of the equality is tested vacuously.
  EXPECT_GT(found, 300);
  EXPECT_GT(refused, 300);
}

// The brute force itself: it visits every triangulation of a convex n-gon once (Catalan(n - 2) of them).
TEST(ShorVanWykRefinedPolygons, TheBruteForceVisitsEveryTriangulation) {
  const long catalan[] = {1, 1, 2, 5, 14, 42, 132, 429, 1430};
  for (int n = 3; n <= 10; ++n) {
    long count = 0;
    std::vector<Triangle> acc;
    std::vector<std::pair<int, int>> pending;
    EXPECT_FALSE(any_triangulation(0, n - 1, acc, [&](std::vector<Triangle>& t) {
      EXPECT_EQ(static_cast<int>(t.size()), n - 2);
      ++count;
      return false;
    }, pending));
    EXPECT_EQ(count, catalan[n - 2]) << n << " vertices";
  }
}

}  // namespace
}  // namespace lipmap
