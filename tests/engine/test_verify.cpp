// Stage "verify" (docs/contract.md): it accepts good maps and rejects each violation of the contract with
// its reason. The maps are built here on generated grid disks with dyadic coordinates (so that midpoints and
// a + t (b - a) are exact), and each violation is made by hand; the expected reason follows from the
// construction, not from the program's output.
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/error.h"
#include "engine/validate.h"
#include "engine/verify.h"
#include "tests/support/grid_cells.h"

namespace lipmap {
namespace {

// An n x n grid on integer (x, y), z a random multiple of 1/64; each cell split by its (i, j)-(i+1, j+1)
// diagonal, faces counterclockwise. The identity uv (x, y) is a locally injective map onto the square.
struct Case {
  DiskMesh mesh;
  BoundaryPolygon polygon;
  std::vector<int> rotation;
  RefinedMap map;
  int n = 0;
};

Case grid_case(int n, std::mt19937& rng) {
  std::uniform_int_distribution<int> z(-64, 64);
  RawMesh raw;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) raw.vertices.push_back({double(i), double(j), z(rng) / 64.0});
  for (const auto& t : testgen::grid_triangles(n - 1, n - 1, [](int, int) { return true; }))
    raw.faces.push_back({t[0], t[1], t[2]});
  Case c;
  c.n = n;
  c.mesh = validate_mesh(raw);
  for (const Point3& p : c.mesh.vertices) c.map.uv.push_back({p.x, p.y});
  c.map.vertices = c.mesh.vertices;
  c.map.faces = c.mesh.faces;
  for (int v : c.mesh.boundary_loop) c.polygon.vertices.push_back(c.map.uv[v]);
  c.rotation.assign(c.mesh.boundary_loop.size(), 0);
  return c;
}

// The reason verify gives, or "" when it accepts.
std::string verdict(const Case& c) {
  try {
    verify_map(c.mesh, c.mesh.boundary_loop, c.polygon, c.rotation, c.map);
    return "";
  } catch (const InternalError& e) {
    return e.what();
  }
}

bool is_boundary(const Case& c, int v) {
  return std::find(c.mesh.boundary_loop.begin(), c.mesh.boundary_loop.end(), v) != c.mesh.boundary_loop.end();
}

// The two faces on edge (a, b): the one with directed edge a -> b and its third corner, and the other.
struct EdgeFaces {
  int left = -1, right = -1;  // face indices
  int c = -1, d = -1;         // third corners (c left of a -> b, d right)
};

EdgeFaces faces_on(const std::vector<Triangle>& faces, int a, int b) {
  EdgeFaces e;
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int p = faces[f][k], q = faces[f][(k + 1) % 3], o = faces[f][(k + 2) % 3];
      if (p == a && q == b) e.left = static_cast<int>(f), e.c = o;
      if (p == b && q == a) e.right = static_cast<int>(f), e.d = o;
    }
  return e;
}

// A random interior original edge of the map (its ends may be on the boundary, the edge is not), a < b.
std::pair<int, int> random_interior_edge(const Case& c, std::mt19937& rng) {
  for (;;) {
    const Triangle& t = c.map.faces[rng() % c.map.faces.size()];
    const int k = static_cast<int>(rng() % 3);
    const int a = std::min(t[k], t[(k + 1) % 3]), b = std::max(t[k], t[(k + 1) % 3]);
    const EdgeFaces e = faces_on(c.map.faces, a, b);
    const int n0 = static_cast<int>(c.mesh.vertices.size());  // an original edge not split yet
    if (e.left >= 0 && e.right >= 0 && b < n0) return {a, b};
  }
}

// Splits edge (a, b), a < b, of the map at parameter t (exact for the dyadic t used here): the two faces on
// it become four. uv of the new vertex: uv_at.
int split(Case& c, int a, int b, double t, Point2 uv_at) {
  const EdgeFaces e = faces_on(c.map.faces, a, b);
  const Point3 &pa = c.mesh.vertices[a], &pb = c.mesh.vertices[b];
  const int m = static_cast<int>(c.map.vertices.size());
  c.map.vertices.push_back({pa.x + t * (pb.x - pa.x), pa.y + t * (pb.y - pa.y), pa.z + t * (pb.z - pa.z)});
  c.map.uv.push_back(uv_at);
  c.map.inserted.push_back({a, b, t});
  if (e.left >= 0) {  // a boundary edge has one of the two
    c.map.faces[e.left] = {a, m, e.c};
    c.map.faces.push_back({m, b, e.c});
  }
  if (e.right >= 0) {
    c.map.faces[e.right] = {b, m, e.d};
    c.map.faces.push_back({m, a, e.d});
  }
  return m;
}

Point2 lerp(const Point2& p, const Point2& q, double t) { return {p.x + t * (q.x - p.x), p.y + t * (q.y - p.y)}; }

class VerifyMap : public ::testing::Test {
protected:
  std::mt19937 rng{77};
  int size() { return 3 + static_cast<int>(rng() % 7); }
  int random_interior_vertex(const Case& c) {
    for (;;) {
      const int v = static_cast<int>(rng() % c.mesh.vertices.size());
      if (!is_boundary(c, v)) return v;
    }
  }
};

TEST_F(VerifyMap, AcceptsGoodMapsWithAndWithoutInsertedVertices) {
  for (int round = 0; round < 40; ++round) {
    Case c = grid_case(size(), rng);
    EXPECT_EQ(verdict(c), "");
    // Split a few interior edges at t = 1/2 with uv at the midpoint: still the same good map.
    for (int s = 0; s < 3; ++s) {
      const auto [a, b] = random_interior_edge(c, rng);
      split(c, a, b, 0.5, lerp(c.map.uv[a], c.map.uv[b], 0.5));
    }
    const VerifyReport r = verify_map(c.mesh, c.mesh.boundary_loop, c.polygon, c.rotation, c.map);
    EXPECT_EQ(r.faces_checked, static_cast<int>(c.map.faces.size()));
    EXPECT_LT(r.area_relative_error, 1e-12);
  }
}

TEST_F(VerifyMap, RejectsAFlippedTriangle) {
  for (int round = 0; round < 30; ++round) {
    Case c = grid_case(3 + static_cast<int>(rng() % 6), rng);
    const int v = random_interior_vertex(c);
    // Past its right neighbour (x + 1): the faces between v and that neighbour turn clockwise.
    c.map.uv[v].x += 1.5;
    EXPECT_NE(verdict(c).find("is not strictly positive"), std::string::npos) << verdict(c);
  }
}

TEST_F(VerifyMap, RejectsAZeroAreaUvTriangle) {
  for (int round = 0; round < 30; ++round) {
    Case c = grid_case(3 + static_cast<int>(rng() % 6), rng);
    const int v = random_interior_vertex(c);
    // Onto the midpoint of its ring edge (x + 1, y) - (x + 1, y + 1): exactly one face, (v, right, upper
    // right), has zero area; the one-ring is a convex hexagon, so every other face stays positive.
    c.map.uv[v] = {c.map.uv[v].x + 1, c.map.uv[v].y + 0.5};
    const int right = v + 1, upper_right = v + c.n + 1;
    int zero_face = -1;
    for (std::size_t f = 0; f < c.map.faces.size(); ++f) {
      const Triangle& t = c.map.faces[f];
      if (std::count(t.begin(), t.end(), v) && std::count(t.begin(), t.end(), right) &&
          std::count(t.begin(), t.end(), upper_right))
        zero_face = static_cast<int>(f);
    }
    ASSERT_GE(zero_face, 0);
    EXPECT_NE(verdict(c).find("face " + std::to_string(zero_face) + " is not strictly positive"), std::string::npos)
        << verdict(c);
  }
}

TEST_F(VerifyMap, RejectsABoundaryUvMovedByOneUlp) {
  for (int round = 0; round < 30; ++round) {
    Case c = grid_case(size(), rng);
    const std::size_t k = rng() % c.mesh.boundary_loop.size();
    const int v = c.mesh.boundary_loop[k];
    double& coordinate = (round % 2) ? c.map.uv[v].x : c.map.uv[v].y;
    coordinate = std::nextafter(coordinate, (round % 4 < 2) ? 1e9 : -1e9);
    EXPECT_NE(verdict(c).find("boundary vertex " + std::to_string(v) + " is not at its target"), std::string::npos)
        << verdict(c);
  }
}

TEST_F(VerifyMap, RejectsAnOriginalVertexMovedIn3D) {
  for (int round = 0; round < 30; ++round) {
    Case c = grid_case(size(), rng);
    const int v = static_cast<int>(rng() % c.mesh.vertices.size());
    c.map.vertices[v].z = std::nextafter(c.map.vertices[v].z, 1e9);
    EXPECT_NE(verdict(c).find("original vertex " + std::to_string(v) + " moved"), std::string::npos) << verdict(c);
  }
}

TEST_F(VerifyMap, RejectsAnInsertedVertexOffItsEdgeIn3D) {
  for (int round = 0; round < 30; ++round) {
    Case c = grid_case(size(), rng);
    const auto [a, b] = random_interior_edge(c, rng);
    const int m = split(c, a, b, 0.25, lerp(c.map.uv[a], c.map.uv[b], 0.25));
    c.map.vertices[m].x = std::nextafter(c.map.vertices[m].x, 1e9);
    EXPECT_NE(verdict(c).find("inserted vertex " + std::to_string(m) + " is not at a + t (b - a)"), std::string::npos)
        << verdict(c);
  }
}

TEST_F(VerifyMap, RejectsAnInsertedVertexOnABoundaryEdge) {
  for (int round = 0; round < 30; ++round) {
    Case c = grid_case(size(), rng);
    const std::size_t k = rng() % c.mesh.boundary_loop.size();
    const int p = c.mesh.boundary_loop[k], q = c.mesh.boundary_loop[(k + 1) % c.mesh.boundary_loop.size()];
    const int m = split(c, std::min(p, q), std::max(p, q), 0.5, lerp(c.map.uv[p], c.map.uv[q], 0.5));
    EXPECT_NE(verdict(c).find("inserted vertex " + std::to_string(m) + " is on the boundary"), std::string::npos)
        << verdict(c);
  }
}

// A fan whose interior centre (vertex 0) winds twice: its m ring vertices (m odd, so no two coincide) sit at
// angles 4 pi j / m on alternating radii. Every triangle is positive; the angle sum at the centre is 4 pi.
TEST(VerifyMapFan, RejectsAnInteriorVertexWindingTwice) {
  for (int m = 7; m <= 41; m += 2) {
    RawMesh raw;
    raw.vertices.push_back({0, 0, 1});
    for (int j = 0; j < m; ++j)
      raw.vertices.push_back({std::cos(2 * M_PI * j / m), std::sin(2 * M_PI * j / m), 0});
    for (int j = 0; j < m; ++j) raw.faces.push_back({0, 1 + j, 1 + (j + 1) % m});
    Case c;
    c.mesh = validate_mesh(raw);
    c.map.vertices = c.mesh.vertices;
    c.map.faces = c.mesh.faces;
    c.map.uv.push_back({0, 0});
    for (int j = 0; j < m; ++j) {
      const double r = j % 2 ? 1.0 : 1.25;
      c.map.uv.push_back({r * std::cos(4 * M_PI * j / m), r * std::sin(4 * M_PI * j / m)});
    }
    for (int v : c.mesh.boundary_loop) c.polygon.vertices.push_back(c.map.uv[v]);
    c.rotation.assign(c.mesh.boundary_loop.size(), 0);
    EXPECT_NE(verdict(c).find("interior vertex 0 has angle sum 2 x 2 pi"), std::string::npos)
        << "m " << m << ": " << verdict(c);
  }
}

// A fan around a boundary hub whose other vertices spiral through 3 pi: the hub's angle in the map is 3 pi and
// the polygon's interior angle there is pi, so R = 1 at the hub and 0 elsewhere, by construction. Prescribed
// zeros are refused at the hub; an empty prescription accepts the map and reports those indices.
TEST(VerifyMapFan, AnEmptyPrescriptionReportsTheMapsOwnRotationIndices) {
  for (int m = 8; m <= 40; m += 4) {
    RawMesh raw;
    raw.vertices.push_back({0, 0, 0});
    std::vector<Point2> uv{{0, 0}};
    for (int j = 0; j < m; ++j) {
      const double theta = 3 * M_PI * j / (m - 1), r = 1 + 0.5 * j / (m - 1);
      raw.vertices.push_back({r * std::cos(theta), r * std::sin(theta), theta / 8});
      uv.push_back({r * std::cos(theta), r * std::sin(theta)});
    }
    for (int j = 1; j < m; ++j) raw.faces.push_back({0, j, j + 1});
    Case c;
    c.mesh = validate_mesh(raw);
    c.map.vertices = c.mesh.vertices;
    c.map.faces = c.mesh.faces;
    c.map.uv = uv;
    for (int v : c.mesh.boundary_loop) c.polygon.vertices.push_back(c.map.uv[v]);
    std::vector<int> expected(c.mesh.boundary_loop.size(), 0);
    for (std::size_t k = 0; k < expected.size(); ++k) expected[k] = c.mesh.boundary_loop[k] == 0 ? 1 : 0;
    c.rotation.assign(c.mesh.boundary_loop.size(), 0);
    EXPECT_NE(verdict(c).find("boundary vertex 0 has rotation index 1 instead of 0"), std::string::npos)
        << "m " << m << ": " << verdict(c);
    const VerifyReport r = verify_map(c.mesh, c.mesh.boundary_loop, c.polygon, {}, c.map);
    EXPECT_EQ(r.rotation_indices, expected) << "m " << m;
    EXPECT_EQ(verify_map(c.mesh, c.mesh.boundary_loop, c.polygon, expected, c.map).rotation_indices, expected);
  }
}

// Edge (a, b) carries two inserted points, m1 (t = 1/4) and m2 (t = 1/2); face (a, m1, m2) has all three
// corners on the edge: flat in 3D. In uv, m1 is moved slightly towards d (right of a -> b) so that every
// triangle is positive and the angle sums hold: only the 3D rule is broken.
TEST_F(VerifyMap, RejectsATriangleWithAllCornersOnOneOriginalEdge) {
  for (int round = 0; round < 30; ++round) {
    Case c = grid_case(size(), rng);
    const auto [a, b] = random_interior_edge(c, rng);
    const EdgeFaces e = faces_on(c.map.faces, a, b);
    const Point2 ua = c.map.uv[a], ub = c.map.uv[b], ud = c.map.uv[e.d];
    const Point3 &pa = c.mesh.vertices[a], &pb = c.mesh.vertices[b];
    const int n0 = static_cast<int>(c.map.vertices.size()), m1 = n0, m2 = n0 + 1;
    for (double t : {0.25, 0.5}) {
      c.map.vertices.push_back({pa.x + t * (pb.x - pa.x), pa.y + t * (pb.y - pa.y), pa.z + t * (pb.z - pa.z)});
      c.map.inserted.push_back({a, b, t});
    }
    c.map.uv.push_back(lerp(lerp(ua, ub, 0.25), ud, 1.0 / 16));
    c.map.uv.push_back(lerp(ua, ub, 0.5));
    c.map.faces[e.left] = {a, m1, m2};
    c.map.faces.push_back({a, m2, e.c});
    c.map.faces.push_back({m2, b, e.c});
    c.map.faces[e.right] = {b, m2, e.d};
    c.map.faces.push_back({m2, m1, e.d});
    c.map.faces.push_back({m1, a, e.d});
    const std::string why = verdict(c);
    EXPECT_NE(why.find("original edge " + std::to_string(a) + "-" + std::to_string(b)), std::string::npos) << why;
    EXPECT_EQ(why.find("not strictly positive"), std::string::npos) << why;
  }
}

}  // namespace
}  // namespace lipmap
