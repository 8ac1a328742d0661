// Stage "compose" (paper 4): f = h_t^-1 o h_s at every source vertex. Checked here against values computed
// independently: the containing M_t triangle found by a brute-force scan with CGAL's exact orientation, and
// barycentric coordinates in long double. Cases: source = target (the identity), disk points exactly at
// h_t's vertices and on its edges, and affine target maps (reproduced by barycentric evaluation).
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "engine/compose.h"
#include "engine/intermediate_map.h"
#include "engine/validate.h"

namespace lipmap {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

int orient(const Point2& a, const Point2& b, const Point2& c) {
  const CGAL::Orientation o = CGAL::orientation(K::Point_2(a.x, a.y), K::Point_2(b.x, b.y), K::Point_2(c.x, c.y));
  return o == CGAL::LEFT_TURN ? 1 : (o == CGAL::RIGHT_TURN ? -1 : 0);
}

// An n x n grid on [0, 1]^2; `flip` picks the other diagonal in alternate cells; z a bump unless flat;
// interior (x, y) jittered by up to a quarter cell.
RawMesh grid(int n, bool flip, bool flat, std::mt19937& rng) {
  std::uniform_real_distribution<double> jitter(-0.25, 0.25);
  RawMesh raw;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const bool inside = i > 0 && j > 0 && i < n - 1 && j < n - 1;
      const double x = (i + (inside ? jitter(rng) : 0)) / (n - 1), y = (j + (inside ? jitter(rng) : 0)) / (n - 1);
      raw.vertices.push_back({x, y, flat ? 0.0 : 0.3 * std::sin(3 * x) * std::cos(2 * y)});
    }
  auto id = [n](int i, int j) { return static_cast<long long>(j * n + i); };
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      if (flip && (i + j) % 2) {
        raw.faces.push_back({id(i, j), id(i + 1, j), id(i, j + 1)});
        raw.faces.push_back({id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)});
      } else {
        raw.faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
        raw.faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      }
    }
  return raw;
}

std::vector<Point2> disk_of(const DiskMesh& m) {
  DiskMapInput in;
  in.vertices = &m.vertices;
  in.faces = &m.faces;
  in.boundary_loop = &m.boundary_loop;
  DiskMap d = map_to_disk(in, MapMethod::tutte);
  EXPECT_TRUE(d.bijective());
  return d.uv;
}

// A planar disk mesh as M_t: vertices renumbered so that loop vertex k is vertex k (the polygon's numbering),
// uv = (x, y); its disk map renumbered the same way.
struct Target {
  TargetMesh mesh;
  std::vector<Point2> disk;
  std::vector<int> new_id;  // new_id[old vertex]
};

Target as_target(const DiskMesh& m, const std::vector<Point2>& disk) {
  Target t;
  const int n = static_cast<int>(m.vertices.size());
  t.new_id.assign(n, -1);
  int next = 0;
  for (int v : m.boundary_loop) t.new_id[v] = next++;
  for (int v = 0; v < n; ++v)
    if (t.new_id[v] < 0) t.new_id[v] = next++;
  t.mesh.vertices.resize(n);
  t.disk.resize(n);
  for (int v = 0; v < n; ++v) {
    t.mesh.vertices[t.new_id[v]] = {m.vertices[v].x, m.vertices[v].y};
    t.disk[t.new_id[v]] = disk[v];
  }
  for (const Triangle& f : m.faces) t.mesh.faces.push_back({t.new_id[f[0]], t.new_id[f[1]], t.new_id[f[2]]});
  return t;
}

// f at disk point q by brute force: a target face whose disk triangle contains q (exact test), then
// barycentric coordinates in long double. Returns the face, or -1.
int evaluate(const Target& t, const Point2& q, Point2* f) {
  for (std::size_t k = 0; k < t.mesh.faces.size(); ++k) {
    const Triangle& tri = t.mesh.faces[k];
    const Point2 &a = t.disk[tri[0]], &b = t.disk[tri[1]], &c = t.disk[tri[2]];
    if (orient(a, b, q) < 0 || orient(b, c, q) < 0 || orient(c, a, q) < 0) continue;
    const long double det = ((long double)b.x - a.x) * ((long double)c.y - a.y) - ((long double)c.x - a.x) * ((long double)b.y - a.y);
    const long double l1 = (((long double)q.x - a.x) * ((long double)c.y - a.y) - ((long double)c.x - a.x) * ((long double)q.y - a.y)) / det;
    const long double l2 = (((long double)b.x - a.x) * ((long double)q.y - a.y) - ((long double)q.x - a.x) * ((long double)b.y - a.y)) / det;
    const long double l0 = 1 - l1 - l2;
    const Point2 &ua = t.mesh.vertices[tri[0]], &ub = t.mesh.vertices[tri[1]], &uc = t.mesh.vertices[tri[2]];
    *f = {static_cast<double>(l0 * ua.x + l1 * ub.x + l2 * uc.x), static_cast<double>(l0 * ua.y + l1 * ub.y + l2 * uc.y)};
    return static_cast<int>(k);
  }
  return -1;
}

bool contains(const Target& t, int face, const Point2& q) {
  const Triangle& tri = t.mesh.faces[face];
  return orient(t.disk[tri[0]], t.disk[tri[1]], q) >= 0 && orient(t.disk[tri[1]], t.disk[tri[2]], q) >= 0 &&
         orient(t.disk[tri[2]], t.disk[tri[0]], q) >= 0;
}

void expect_boundary_pinned(const DiskMesh& source, const Target& t, const Composition& c) {
  for (std::size_t k = 0; k < source.boundary_loop.size(); ++k) {
    const int v = source.boundary_loop[k];
    EXPECT_EQ(c.uv[v], t.mesh.vertices[k]) << "loop position " << k;
    EXPECT_EQ(c.target_face[v], -1);
  }
}

TEST(Compose, SourceEqualToTargetGivesTheIdentity) {
  std::mt19937 rng(5);
  for (int round = 0; round < 12; ++round) {
    const DiskMesh m = validate_mesh(grid(4 + round % 8, round % 2, true, rng));
    const std::vector<Point2> disk = disk_of(m);
    const Target t = as_target(m, disk);
    const Composition c = compose(m, m.boundary_loop, disk, t.mesh, t.disk);
    expect_boundary_pinned(m, t, c);
    for (std::size_t v = 0; v < m.vertices.size(); ++v) {
      // h_s(v) is exactly the disk image of target vertex new_id[v]: f(v) is that vertex, (x, y).
      EXPECT_NEAR(c.uv[v].x, m.vertices[v].x, 1e-14) << "vertex " << v;
      EXPECT_NEAR(c.uv[v].y, m.vertices[v].y, 1e-14) << "vertex " << v;
      if (c.target_face[v] >= 0) {
        const Triangle& f = t.mesh.faces[c.target_face[v]];
        EXPECT_TRUE(std::count(f.begin(), f.end(), t.new_id[v])) << "vertex " << v << " located in a face not at it";
      }
    }
  }
}

// Interior source vertices are sent (through an arbitrary h_s) to disk points chosen on h_t's vertices, on
// the midpoints of its edges and inside its triangles: each is located in a triangle that contains it and
// evaluated as the brute-force barycentric value.
TEST(Compose, PointsAtVerticesOnEdgesAndInsideFacesAreLocatedAndEvaluated) {
  std::mt19937 rng(11);
  for (int round = 0; round < 20; ++round) {
    const int n = 5 + round % 6;
    const DiskMesh target_source = validate_mesh(grid(n, true, true, rng));
    const Target t = as_target(target_source, disk_of(target_source));
    const DiskMesh source = validate_mesh(grid(n, false, false, rng));
    std::vector<Point2> source_disk = disk_of(source);
    std::vector<char> boundary(source.vertices.size(), 0);
    for (int v : source.boundary_loop) boundary[v] = 1;
    std::uniform_real_distribution<double> u(0, 1);
    for (std::size_t v = 0; v < source.vertices.size(); ++v) {
      if (boundary[v]) continue;
      // Strictly inside the disk (as h_s puts interior vertices): an interior vertex of M_t, the midpoint of an
      // edge with an interior end, or a point well inside a triangle.
      const int nb = static_cast<int>(source.boundary_loop.size());  // M_t's polygon vertices are 0 .. nb - 1
      const Triangle& tri = t.mesh.faces[rng() % t.mesh.faces.size()];
      const int k = static_cast<int>(rng() % 3);
      const int i0 = tri[k], i1 = tri[(k + 1) % 3], i2 = tri[(k + 2) % 3];
      const Point2 &a = t.disk[i0], &b = t.disk[i1], &c = t.disk[i2];
      const int kind = static_cast<int>(rng() % 3);
      if (kind == 0 && i0 >= nb) {
        source_disk[v] = a;
      } else if (kind == 1 && (i0 >= nb || i1 >= nb)) {
        source_disk[v] = {(a.x + b.x) / 2, (a.y + b.y) / 2};
      } else {
        const double l1 = 0.01 + 0.48 * u(rng), l2 = 0.01 + 0.48 * u(rng);
        source_disk[v] = {a.x + l1 * (b.x - a.x) + l2 * (c.x - a.x), a.y + l1 * (b.y - a.y) + l2 * (c.y - a.y)};
      }
    }
    const Composition c = compose(source, source.boundary_loop, source_disk, t.mesh, t.disk);
    expect_boundary_pinned(source, t, c);
    for (std::size_t v = 0; v < source.vertices.size(); ++v) {
      if (boundary[v]) continue;
      Point2 expected;
      ASSERT_GE(evaluate(t, source_disk[v], &expected), 0) << "disk point outside h_t(M_t)";
      ASSERT_GE(c.target_face[v], 0);
      EXPECT_TRUE(contains(t, c.target_face[v], source_disk[v])) << "vertex " << v;
      EXPECT_NEAR(c.uv[v].x, expected.x, 1e-12) << "vertex " << v;
      EXPECT_NEAR(c.uv[v].y, expected.y, 1e-12) << "vertex " << v;
    }
  }
}

// When M_t's vertices are an affine image of their disk positions, f = h_t^-1 o h_s is that affine map on
// every interior source vertex (barycentric evaluation reproduces affine functions).
TEST(Compose, AffineTargetMapsAreReproduced) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> coef(-3, 3);
  for (int round = 0; round < 20; ++round) {
    const int n = 4 + round % 7;
    const DiskMesh target_source = validate_mesh(grid(n, round % 2 == 0, true, rng));
    Target t = as_target(target_source, disk_of(target_source));
    double a11 = coef(rng), a12 = coef(rng), a21 = coef(rng), a22 = coef(rng);
    if (std::fabs(a11 * a22 - a12 * a21) < 0.5) a11 += 2, a22 += 2;
    const double bx = coef(rng) * 100, by = coef(rng);
    auto affine = [&](const Point2& p) { return Point2{a11 * p.x + a12 * p.y + bx, a21 * p.x + a22 * p.y + by}; };
    for (std::size_t i = 0; i < t.mesh.vertices.size(); ++i) t.mesh.vertices[i] = affine(t.disk[i]);
    const DiskMesh source = validate_mesh(grid(n, round % 2 == 1, false, rng));
    const std::vector<Point2> source_disk = disk_of(source);
    const Composition c = compose(source, source.boundary_loop, source_disk, t.mesh, t.disk);
    expect_boundary_pinned(source, t, c);
    for (std::size_t v = 0; v < source.vertices.size(); ++v) {
      const Point2 expected = affine(source_disk[v]);
      const double scale = 1 + std::fabs(bx) + std::fabs(by);
      EXPECT_NEAR(c.uv[v].x, expected.x, 1e-13 * scale) << "vertex " << v;
      EXPECT_NEAR(c.uv[v].y, expected.y, 1e-13 * scale) << "vertex " << v;
    }
  }
}

}  // namespace
}  // namespace lipmap
