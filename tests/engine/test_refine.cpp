// Stage "refine" (paper 4, "Source mesh refinement", Fig. 10-12) on small hand-built cases whose composed
// map folds: fans and small grids onto simple polygons with an empty kernel (no position of an interior
// vertex sees every corner, so some vertex-wise triangle must be non-positive). The stages before refine
// run through their public headers. Every result is checked by the independent map checker
// (tests/support/map_checker.h), and on small refined polygons the rule of Fig. 11 is checked by brute
// force here: every refined polygon is self-overlapping (some triangulation of it has only positive
// triangles, the polygon's own angles, and no triangle flat on one original edge: all triangulations are
// enumerated), and no inserted point can be removed: without it, one of its two polygons stops being
// self-overlapping or the angle sum at an end of its edge changes. simplify_again, the same rounds on a map
// whose uv moved, is checked the same way.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/map_checker.h"

#include "engine/classify.h"
#include "engine/compose.h"
#include "engine/intermediate_map.h"
#include "engine/refine.h"
#include "engine/target_mesh.h"
#include "engine/validate.h"

namespace lipmap {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
constexpr long double kTwoPi = 6.283185307179586476925286766559L;

int orient(const Point2& a, const Point2& b, const Point2& c) {
  const CGAL::Orientation o = CGAL::orientation(K::Point_2(a.x, a.y), K::Point_2(b.x, b.y), K::Point_2(c.x, c.y));
  return o == CGAL::LEFT_TURN ? 1 : (o == CGAL::RIGHT_TURN ? -1 : 0);
}

// Unsigned angle at a of triangle (a, b, c).
long double corner_angle(const Point2& a, const Point2& b, const Point2& c) {
  const long double ux = (long double)b.x - a.x, uy = (long double)b.y - a.y;
  const long double wx = (long double)c.x - a.x, wy = (long double)c.y - a.y;
  return std::fabs(std::atan2(ux * wy - uy * wx, ux * wx + uy * wy));
}

// A refined polygon: its vertices in order (ids of the refined mesh), their uv, and for each the set of
// source-face edges it lies on (bit i: edge from corner i to corner i + 1; a corner lies on two).
struct RefinedPolygon {
  std::vector<int> ids;
  std::vector<Point2> uv;
  std::vector<unsigned> on;
};

// Every triangulation of the polygon (no interior vertices), depth first; `accept` sees each one and may
// stop the search by returning true.
bool any_triangulation(int m, const std::function<bool(const std::vector<Triangle>&)>& accept) {
  // A triangulation of the chain i..j (closed by the chord j-i) is a triangle (i, k, j) plus triangulations
  // of i..k and k..j.
  std::vector<Triangle> current;
  std::function<bool(std::vector<std::pair<int, int>>&)> expand = [&](std::vector<std::pair<int, int>>& open) {
    if (open.empty()) return accept(current);
    const auto [i, j] = open.back();
    open.pop_back();
    for (int k = i + 1; k < j; ++k) {
      current.push_back({i, k, j});
      std::vector<std::pair<int, int>> next = open;
      if (k - i > 1) next.push_back({i, k});
      if (j - k > 1) next.push_back({k, j});
      if (expand(next)) return true;
      current.pop_back();
    }
    open.push_back({i, j});
    return false;
  };
  std::vector<std::pair<int, int>> open = {{0, m - 1}};
  return expand(open);
}

// Self-overlapping in the sense refine uses (R = 0 everywhere): a triangulation with strictly positive
// triangles, none with all corners on one original edge, whose angle at every vertex is below 2 pi (then it
// is the polygon's interior angle: all triangles positive makes it equal modulo 2 pi).
bool self_overlapping(const RefinedPolygon& p) {
  const int m = static_cast<int>(p.ids.size());
  if (m < 3) return false;
  return any_triangulation(m, [&](const std::vector<Triangle>& tris) {
    std::vector<long double> angle(m, 0);
    for (const Triangle& t : tris) {
      if (orient(p.uv[t[0]], p.uv[t[1]], p.uv[t[2]]) <= 0) return false;
      if (p.on[t[0]] & p.on[t[1]] & p.on[t[2]]) return false;
      for (int c = 0; c < 3; ++c) angle[t[c]] += corner_angle(p.uv[t[c]], p.uv[t[(c + 1) % 3]], p.uv[t[(c + 2) % 3]]);
    }
    for (long double a : angle)
      if (a >= kTwoPi - 1e-9L) return false;
    return true;
  });
}

// The interior angle of a self-overlapping polygon at position i: the counterclockwise angle from the next
// vertex round to the previous one, side from the exact predicate.
long double interior_angle(const RefinedPolygon& p, int i) {
  const int m = static_cast<int>(p.ids.size());
  const Point2 &v = p.uv[i], &next = p.uv[(i + 1) % m], &prev = p.uv[(i + m - 1) % m];
  const long double ux = (long double)next.x - v.x, uy = (long double)next.y - v.y;
  const long double wx = (long double)prev.x - v.x, wy = (long double)prev.y - v.y;
  const long double mag = std::fabs(std::atan2(ux * wy - uy * wx, ux * wx + uy * wy));
  const int side = orient(v, next, prev);
  return side > 0 ? mag : (side < 0 ? kTwoPi - mag : 3.14159265358979323846L);
}

RefinedPolygon without(const RefinedPolygon& p, int id) {
  RefinedPolygon q;
  for (std::size_t i = 0; i < p.ids.size(); ++i)
    if (p.ids[i] != id) {
      q.ids.push_back(p.ids[i]);
      q.uv.push_back(p.uv[i]);
      q.on.push_back(p.on[i]);
    }
  return q;
}

struct RefineRun {
  DiskMesh mesh;
  BoundaryMap boundary;
  Classification classification;
  RefinedMap map;
};

RefineRun run_to_refine(const RawMesh& raw, const std::vector<Point2>& positions) {
  RefineRun r;
  r.mesh = validate_mesh(raw);
  RawBoundary b;
  b.positions = positions;
  r.boundary = validate_boundary(r.mesh, b);
  r.classification = classify(r.boundary.polygon);
  EXPECT_NE(r.classification.verdict, Verdict::not_self_overlapping);
  TargetMeshOptions options;
  options.source_triangles = static_cast<int>(r.mesh.faces.size());
  const TargetMesh target = build_target_mesh(r.boundary.polygon, r.classification.triangulation, options);
  const DiskMap source_disk = map_to_disk({&r.mesh.vertices, &r.mesh.faces, &r.boundary.loop}, MapMethod::tutte);
  std::vector<Point3> planar;
  for (const Point2& p : target.vertices) planar.push_back({p.x, p.y, 0});
  std::vector<int> target_loop(r.boundary.polygon.vertices.size());
  for (std::size_t k = 0; k < target_loop.size(); ++k) target_loop[k] = static_cast<int>(k);
  const DiskMap target_disk = map_to_disk({&planar, &target.faces, &target_loop}, MapMethod::tutte);
  EXPECT_TRUE(source_disk.bijective() && target_disk.bijective());
  const Composition c = compose(r.mesh, r.boundary.loop, source_disk.uv, target, target_disk.uv);
  r.map = refine(r.mesh, r.boundary.loop, r.classification.rotation_indices, source_disk.uv, target, target_disk.uv,
                 c, true);
  return r;
}

// The refined polygon of source face f in the result (corners and the inserted points on its edges).
RefinedPolygon refined_polygon(const RefineRun& r, int f) {
  std::map<std::pair<int, int>, std::vector<std::pair<double, int>>> on_edge;
  const int n0 = static_cast<int>(r.mesh.vertices.size());
  for (std::size_t i = 0; i < r.map.inserted.size(); ++i)
    on_edge[{r.map.inserted[i].a, r.map.inserted[i].b}].push_back({r.map.inserted[i].t, n0 + static_cast<int>(i)});
  RefinedPolygon p;
  const Triangle& t = r.mesh.faces[f];
  for (int c = 0; c < 3; ++c) {
    const int a = t[c], b = t[(c + 1) % 3];
    p.ids.push_back(a);
    p.on.push_back((1u << c) | (1u << ((c + 2) % 3)));
    auto points = on_edge[{std::min(a, b), std::max(a, b)}];
    std::sort(points.begin(), points.end());
    if (a > b) std::reverse(points.begin(), points.end());
    for (const auto& tp : points) {
      p.ids.push_back(tp.second);
      p.on.push_back(1u << c);
    }
  }
  for (int id : p.ids) p.uv.push_back(r.map.uv[id]);
  return p;
}

// Fig. 11 on the small refined polygons of a result; returns how many polygons were small enough to check.
int check_figure_11(const RefineRun& r, std::size_t max_polygon = 9) {
  const int n0 = static_cast<int>(r.mesh.vertices.size());
  std::vector<RefinedPolygon> polygons;
  for (std::size_t f = 0; f < r.mesh.faces.size(); ++f) polygons.push_back(refined_polygon(r, static_cast<int>(f)));
  int checked = 0;
  for (std::size_t f = 0; f < polygons.size(); ++f)
    if (polygons[f].ids.size() > 3 && polygons[f].ids.size() <= max_polygon) {
      EXPECT_TRUE(self_overlapping(polygons[f])) << "refined polygon of face " << f << " is not self-overlapping";
      ++checked;
    }
  for (std::size_t i = 0; i < r.map.inserted.size(); ++i) {
    const int v = n0 + static_cast<int>(i);
    const InsertedVertex& ins = r.map.inserted[i];
    std::vector<int> sides;
    for (std::size_t f = 0; f < polygons.size(); ++f)
      if (std::count(polygons[f].ids.begin(), polygons[f].ids.end(), v)) sides.push_back(static_cast<int>(f));
    EXPECT_EQ(sides.size(), 2u) << "inserted vertex " << v;
    if (sides.size() != 2) continue;
    if (polygons[sides[0]].ids.size() > max_polygon || polygons[sides[1]].ids.size() > max_polygon) continue;
    bool removable = true;
    for (int f : sides) removable = removable && self_overlapping(without(polygons[f], v));
    if (!removable) continue;
    // Both stay self-overlapping: the point is still needed when an end of its edge changes its angle sum.
    for (int end : {ins.a, ins.b}) {
      long double before = 0, after = 0;
      for (int f : sides) {
        const RefinedPolygon& p = polygons[f];
        const RefinedPolygon q = without(p, v);
        before += interior_angle(p, static_cast<int>(std::find(p.ids.begin(), p.ids.end(), end) - p.ids.begin()));
        after += interior_angle(q, static_cast<int>(std::find(q.ids.begin(), q.ids.end(), end) - q.ids.begin()));
      }
      if (std::fabs(before - after) > 1) removable = false;
    }
    EXPECT_FALSE(removable) << "inserted vertex " << v << " on edge (" << ins.a << ", " << ins.b
                            << ") could be removed: both its refined polygons stay self-overlapping";
  }
  return checked;
}

void expect_valid(const RefineRun& r) {
  mapcheck::SourceMesh src{r.mesh.vertices, r.mesh.faces, r.boundary.loop};
  mapcheck::Result res{r.map.vertices, r.map.faces, r.map.uv, {}};
  for (const InsertedVertex& i : r.map.inserted) res.inserted.push_back({i.a, i.b, i.t});
  const mapcheck::Report rep = mapcheck::check_map(src, r.boundary.polygon.vertices, res);
  EXPECT_TRUE(rep.ok()) << rep.str();
}

// A fan: interior vertex 0 raised at (0, 0, h), m boundary vertices on a circle.
RawMesh fan(int m, double h) {
  RawMesh raw;
  raw.vertices.push_back({0, 0, h});
  for (int j = 0; j < m; ++j) raw.vertices.push_back({std::cos(2 * M_PI * j / m), std::sin(2 * M_PI * j / m), 0});
  for (int j = 0; j < m; ++j) raw.faces.push_back({0, 1 + j, 1 + (j + 1) % m});
  return raw;
}

// Simple counterclockwise polygons whose kernel is empty (no point sees every edge from its inner side).
const std::vector<std::vector<Point2>> kEmptyKernel = {
    {{0, 0}, {3, 0}, {3, 3}, {2, 3}, {2, 1}, {1, 1}, {1, 3}, {0, 3}},                      // U
    {{0, 0}, {4, 0}, {4, 1}, {1, 1}, {1, 3}, {4, 3}, {4, 4}, {0, 4}},                      // C
    {{0, 0}, {3, 0}, {3, 1}, {1, 1}, {1, 2}, {3, 2}, {3, 3}, {-1, 3}, {-1, 2}, {0, 2}},   // S-like
    {{0, 0}, {5, 0}, {5, 2}, {4, 2}, {4, 1}, {3, 1}, {3, 2}, {2, 2}, {2, 1}, {1, 1}, {1, 2}, {0, 2}},  // comb
};

// Rotate the polygon's start so that all of its vertices get their turn as loop position 0.
std::vector<Point2> rotated(const std::vector<Point2>& p, std::size_t s) {
  std::vector<Point2> q(p.begin() + s, p.end());
  q.insert(q.end(), p.begin(), p.begin() + s);
  return q;
}

TEST(Refine, FansOntoPolygonsWithEmptyKernelFoldAndAreRefinedMinimally) {
  int polygons_checked = 0, cases = 0;
  for (const auto& polygon : kEmptyKernel)
    for (std::size_t s = 0; s < polygon.size(); s += 3)
      for (double h : {0.2, 1.0}) {
        SCOPED_TRACE("polygon of " + std::to_string(polygon.size()) + " start " + std::to_string(s));
        const RefineRun r = run_to_refine(fan(static_cast<int>(polygon.size()), h), rotated(polygon, s));
        // No image of the centre sees every boundary edge from the inside: the vertex-wise map folds.
        EXPECT_GT(r.map.flipped_before_refinement, 0);
        EXPECT_GT(r.map.inserted.size(), 0u);
        expect_valid(r);
        polygons_checked += check_figure_11(r);
        ++cases;
      }
  EXPECT_GT(cases, 10);
  EXPECT_GT(polygons_checked, 10);
}

// A 4 x 4 grid (12 boundary vertices, 4 interior) onto the comb and onto a 12-gon made from the U.
TEST(Refine, SmallGridsOntoPolygonsWithEmptyKernel) {
  RawMesh raw;
  const int n = 4;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) raw.vertices.push_back({double(i), double(j), 0.1 * ((i * 7 + j * 3) % 5)});
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const long long a = j * n + i;
      raw.faces.push_back({a, a + 1, a + n + 1});
      raw.faces.push_back({a, a + n + 1, a + n});
    }
  // The U with its long edges split: 12 vertices.
  const std::vector<Point2> u12 = {{0, 0}, {1, 0}, {2, 0}, {3, 0}, {3, 1.5}, {3, 3}, {2, 3},
                                   {2, 1}, {1, 1}, {1, 3}, {0, 3}, {0, 1.5}};
  int polygons_checked = 0;
  for (const auto* polygon : {&kEmptyKernel[3], &u12})
    for (std::size_t s = 0; s < polygon->size(); s += 4) {
      const RefineRun r = run_to_refine(raw, rotated(*polygon, s));
      expect_valid(r);
      polygons_checked += check_figure_11(r);
    }
  EXPECT_GT(polygons_checked, 0);
}

// simplify_again (the rounds of Fig. 11 on a map whose uv moved, used by method extremal's relaxation). On
// refine()'s own map nothing goes (its rounds ran to the end): false, the map untouched. After every vertex
// off the boundary is jittered in uv (amounts halved until every face is strictly positive, exact), whatever
// it returns passes the contract (independent checker) and the brute-force Fig. 11 check: every refined
// polygon self-overlapping, no inserted point removable; with fewer points than before and every original
// vertex at its uv when it returns true, the map untouched when false.
TEST(RefineAgain, RemovesWhatAMovedMapNoLongerNeedsAndNothingElse) {
  std::vector<RefineRun> runs;
  for (const auto& polygon : kEmptyKernel)
    for (std::size_t s = 0; s < polygon.size(); s += 3)
      for (double h : {0.2, 1.0}) runs.push_back(run_to_refine(fan(static_cast<int>(polygon.size()), h), rotated(polygon, s)));
  int cases = 0, removing = 0, points_removed = 0;
  for (const RefineRun& r : runs) {
    ASSERT_GT(r.map.inserted.size(), 0u);
    RefinedMap same = r.map;
    EXPECT_FALSE(simplify_again(r.mesh, r.boundary.loop, r.classification.rotation_indices, same));
    EXPECT_EQ(same.uv, r.map.uv);
    EXPECT_EQ(same.faces, r.map.faces);
    std::vector<char> on_loop(r.map.uv.size(), 0);
    for (int v : r.boundary.loop) on_loop[v] = 1;
    for (unsigned seed = 0; seed < 6; ++seed) {
      std::mt19937 rng(seed);
      std::uniform_real_distribution<double> unit(-1, 1);
      RefineRun moved = r;
      for (double amount = 0.3;; amount *= 0.5) {
        moved.map.uv = r.map.uv;
        for (std::size_t v = 0; v < moved.map.uv.size(); ++v)
          if (!on_loop[v]) moved.map.uv[v] = {r.map.uv[v].x + amount * unit(rng), r.map.uv[v].y + amount * unit(rng)};
        bool positive = true;
        for (const Triangle& t : moved.map.faces)
          positive = positive && orient(moved.map.uv[t[0]], moved.map.uv[t[1]], moved.map.uv[t[2]]) > 0;
        if (positive) break;
      }
      SCOPED_TRACE("polygon of " + std::to_string(r.boundary.loop.size()) + ", seed " + std::to_string(seed));
      RefinedMap simpler = moved.map;
      ++cases;
      if (!simplify_again(moved.mesh, moved.boundary.loop, moved.classification.rotation_indices, simpler)) {
        EXPECT_EQ(simpler.uv, moved.map.uv);
        EXPECT_EQ(simpler.faces, moved.map.faces);
        continue;
      }
      ++removing;
      EXPECT_LT(simpler.inserted.size(), moved.map.inserted.size());
      points_removed += static_cast<int>(moved.map.inserted.size() - simpler.inserted.size());
      for (std::size_t v = 0; v < moved.mesh.vertices.size(); ++v) EXPECT_EQ(simpler.uv[v], moved.map.uv[v]) << v;
      moved.map = std::move(simpler);
      expect_valid(moved);
      check_figure_11(moved);
    }
  }
  std::printf("[ refine again ] %d jittered maps, points removed from %d (%d points)\n", cases, removing, points_removed);
  EXPECT_GT(cases, 50);
  EXPECT_GT(removing, 0);
}

// The brute-force test itself: a convex polygon is self-overlapping, a clockwise one is not, three points
// of one original edge are not (flat in 3D), a point on its edge's segment is not needed.
TEST(RefineBruteForce, SelfOverlappingTestSeesWhatItShould) {
  RefinedPolygon square{{0, 1, 2, 3}, {{0, 0}, {1, 0}, {1, 1}, {0, 1}}, {9, 3, 6, 12}};
  EXPECT_TRUE(self_overlapping(square));
  RefinedPolygon cw = square;
  std::reverse(cw.uv.begin(), cw.uv.end());
  EXPECT_FALSE(self_overlapping(cw));
  // Three points of one original edge (a, an inserted point, b): positive in uv, but flat in 3D.
  RefinedPolygon on_one_edge{{0, 3, 1}, {{0, 0}, {1, -1}, {2, 0}}, {5, 1, 3}};
  EXPECT_FALSE(self_overlapping(on_one_edge));
  // A point on its edge's segment in a convex triangle: self-overlapping with and without it.
  RefinedPolygon flat{{0, 3, 1, 2}, {{0, 0}, {1, 0}, {2, 0}, {1, 1}}, {5, 1, 3, 6}};
  EXPECT_TRUE(self_overlapping(flat));
  EXPECT_TRUE(self_overlapping(without(flat, 3)));
}

}  // namespace
}  // namespace lipmap
