// The direct map onto a strictly convex polygon (engine/direct_map.h) and the target mesh's size cap
// (engine/target_mesh.h, target_triangle_cap), checked end to end by tests/support/map_checker.h (no code
// shared with engine/verify.cpp).
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/direct_map.h"
#include "engine/mesh_io.h"
#include "engine/pipeline.h"
#include "engine/target_mesh.h"
#include "tests/support/map_checker.h"
#include "tests/support/pipeline_cases.h"
#include "tests/support/test_meshes.h"

namespace lipmap {
namespace {

std::vector<Point2> regular(int n, double rx = 1, double ry = 1) {
  std::vector<Point2> p;
  for (int k = 0; k < n; ++k) p.push_back({rx * std::cos(2 * M_PI * k / n), ry * std::sin(2 * M_PI * k / n)});
  return p;
}

bool convex(const std::vector<Point2>& p, std::vector<int> rotation = {}) {
  BoundaryPolygon poly;
  poly.vertices = p;
  return strictly_convex(poly, rotation);
}

TEST(DirectMap, StrictlyConvexDecision) {
  for (int n : {3, 4, 7, 100, 1000}) {
    SCOPED_TRACE(n);
    const std::vector<Point2> p = regular(n, 2.0, 0.5);
    EXPECT_TRUE(convex(p));
    EXPECT_TRUE(convex(p, std::vector<int>(n, 0)));
    std::vector<int> turn(n, 0);
    turn[n / 2] = 1;
    EXPECT_FALSE(convex(p, turn));  // a prescribed extra turn is not a convex target
    EXPECT_FALSE(convex(std::vector<Point2>(p.rbegin(), p.rend())));  // clockwise
    std::vector<Point2> dent = p;
    dent[0] = {0.25 * dent[0].x, 0.25 * dent[0].y};
    if (n >= 7) EXPECT_FALSE(convex(dent));  // (with 3 or 4 corners the moved one is still convex)
    std::vector<Point2> twice;  // all left turns, wound twice
    for (int k = 0; k < 2 * n + 1; ++k)
      twice.push_back({std::cos(4 * M_PI * k / (2 * n + 1)), std::sin(4 * M_PI * k / (2 * n + 1))});
    EXPECT_FALSE(convex(twice));
  }
  EXPECT_FALSE(convex({{0, 0}, {1, 0}, {2, 0}, {1, 1}}));  // a straight corner (exactly collinear)
  EXPECT_TRUE(convex({{0, 0}, {2, 0}, {1, 1}}));
}

// Strictly convex polygons with random corners: on an ellipse at jittered angles.
std::vector<Point2> random_convex(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-0.3, 0.3), r(0.3, 3.0);
  const double rx = r(rng), ry = r(rng), phase = u(rng);
  std::vector<Point2> p;
  for (int k = 0; k < n; ++k) {
    const double t = 2 * M_PI * (k + u(rng)) / n + phase;
    p.push_back({rx * std::cos(t), ry * std::sin(t)});
  }
  return p;
}

TEST(DirectMap, CatalogMeshesOntoRandomConvexPolygons) {
  std::mt19937 rng(13);
  int cases = 0;
  for (const testmeshes::MeshEntry& entry :
       testmeshes::disk_meshes_where([](const testmeshes::MeshEntry& e) { return e.triangles > 0 && e.triangles <= 12000; })) {
    const RawMesh raw = read_mesh_file(entry.path());
    std::vector<Triangle> faces;
    for (const auto& f : raw.faces) faces.push_back({int(f[0]), int(f[1]), int(f[2])});
    const std::vector<int> loop = pipelinecases::boundary_loop_of(faces, raw.vertices.size());
    for (MapMethod method : {MapMethod::harmonic, MapMethod::tutte}) {
      const std::vector<Point2> polygon = random_convex(static_cast<int>(loop.size()), rng);
      SCOPED_TRACE(entry.name() + (method == MapMethod::tutte ? " tutte" : " harmonic"));
      ASSERT_TRUE(convex(polygon));
      RawBoundary b;
      b.positions = polygon;
      ParametrizeOptions o;
      o.method = method;
      const ParametrizeResult r = parametrize(raw, b, o);
      ++cases;
      // The direct path: no target mesh, nothing inserted, and a valid map by the independent checker.
      EXPECT_EQ(r.target_mesh.vertices, 0);
      EXPECT_TRUE(r.map.inserted.empty());
      EXPECT_EQ(r.flipped, 0);
      mapcheck::Result res{r.map.vertices, r.map.faces, r.map.uv, {}};
      const mapcheck::Report rep = mapcheck::check_map({raw.vertices, faces, loop}, polygon, res);
      EXPECT_TRUE(rep.ok()) << rep.str();
    }
  }
  EXPECT_GE(cases, 10);
}

// A planar mesh onto its own (strictly convex) boundary: the harmonic map is the identity up to rounding
// (paper Fig. 13's reproduction property; linear functions are harmonic for cotangent weights).
TEST(DirectMap, ReproducesAPlanarMesh) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  const int rings = 12, n = 48;
  RawMesh raw;
  raw.vertices.push_back({0, 0, 0});
  for (int i = 1; i <= rings; ++i)
    for (int k = 0; k < n; ++k) {
      const double rr = (i + (i < rings ? u(rng) : 0)) / rings, t = 2 * M_PI * (k + (i < rings ? u(rng) : 0)) / n;
      raw.vertices.push_back({rr * std::cos(t), rr * std::sin(t), 0});
    }
  auto id = [&](int i, int k) { return i == 0 ? 0LL : 1LL + (i - 1) * n + (k % n); };
  for (int k = 0; k < n; ++k) raw.faces.push_back({0, id(1, k), id(1, k + 1)});
  for (int i = 1; i < rings; ++i)
    for (int k = 0; k < n; ++k) {
      raw.faces.push_back({id(i, k), id(i + 1, k), id(i + 1, k + 1)});
      raw.faces.push_back({id(i, k), id(i + 1, k + 1), id(i, k + 1)});
    }
  RawBoundary b;
  for (int k = 0; k < n; ++k) b.positions.push_back({raw.vertices[id(rings, k)].x, raw.vertices[id(rings, k)].y});
  ParametrizeOptions o;
  o.optimize = OptimizeEnergy::none;
  const ParametrizeResult r = parametrize(raw, b, o);
  EXPECT_EQ(r.target_mesh.vertices, 0);
  double worst = 0;
  for (std::size_t v = 0; v < raw.vertices.size(); ++v)
    worst = std::max({worst, std::fabs(r.map.uv[v].x - raw.vertices[v].x), std::fabs(r.map.uv[v].y - raw.vertices[v].y)});
  EXPECT_LT(worst, 1e-9);
}

// The cap: a large source gets a target of max(floor, per-vertex * n) triangles, a small one its own count.
TEST(TargetMeshCap, CapsLargeSourcesOnly) {
  EXPECT_EQ(target_triangle_cap(3), kTargetCapFloor);
  EXPECT_EQ(target_triangle_cap(10000), kTargetCapPerVertex * 10000);
  BoundaryPolygon poly;
  poly.vertices = regular(40);
  std::vector<Triangle> fan;
  for (int k = 1; k + 1 < 40; ++k) fan.push_back({0, k, k + 1});
  for (int source : {500, 3000, kTargetCapFloor - 1, kTargetCapFloor + 1, 4 * kTargetCapFloor}) {
    for (double density : {0.5, 2.0}) {
      TargetMeshOptions o;
      o.source_triangles = source;
      o.density = density;
      const TargetMesh m = build_target_mesh(poly, fan, o);
      const int want = static_cast<int>(std::llround(density * std::min(source, kTargetCapFloor)));
      EXPECT_EQ(m.target_triangles, want) << source << " " << density;
      EXPECT_GT(static_cast<double>(m.faces.size()), want / 1.5);
      EXPECT_LT(static_cast<double>(m.faces.size()), want * 1.5);
    }
  }
  TargetMeshOptions o;
  o.source_triangles = 2 * kTargetCapFloor;
  o.cap_to_polygon = false;
  o.density = 0.75;
  EXPECT_EQ(build_target_mesh(poly, fan, o).target_triangles, static_cast<int>(1.5 * kTargetCapFloor));
}

}  // namespace
}  // namespace lipmap
