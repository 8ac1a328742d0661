// Float32 texture coordinates of a uv map (engine/float32_uv.h), on many generated maps whose triangles are a
// few float32 spacings wide, so that plain rounding often flips or flattens them. Every property is checked
// by the test's own code: CGAL's exact orientation on the stored float values and a ray-crossing winding
// number (not the engine's turn counting), and ulp distances counted with std::nextafter.
//   - every stored value is a float; boundary vertices are exactly the plain rounding (s, t) = (fl32(u),
//     fl32(1 - v)); no vertex is more than 2 ulps from it in s or in t; `adjusted` counts the moved ones;
//   - ok() holds exactly when the stored map is valid: every face clockwise in (s, t) and counterclockwise
//     in (s, 1 - t), every interior one-ring winding once; a map valid after plain rounding is not touched.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <cmath>
#include <cstddef>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/float32_uv.h"
#include "tests/support/grid_cells.h"

namespace lipmap {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

int orientation(const Point2& a, const Point2& b, const Point2& c) {
  return static_cast<int>(CGAL::orientation(K::Point_2(a.x, a.y), K::Point_2(b.x, b.y), K::Point_2(c.x, c.y)));
}

double fl32(double x) {
  volatile float f = static_cast<float>(x);
  return f;
}

struct Map {
  std::string name;
  std::vector<Point2> uv;
  std::vector<Triangle> faces;
  std::vector<char> boundary;  // known from the construction
};

bool positive_in_double(const Map& m) {
  for (const Triangle& t : m.faces)
    if (orientation(m.uv[t[0]], m.uv[t[1]], m.uv[t[2]]) <= 0) return false;
  return true;
}

// Winding number of the link of v (the edges next -> prev of its faces) around v, by signed crossings of the
// ray from v towards +x: exact, since it compares input doubles and uses the exact orientation only.
int winding(const std::vector<Point2>& p, const std::vector<Triangle>& faces, int v) {
  const Point2& c = p[v];
  int w = 0;
  for (const Triangle& t : faces)
    for (int k = 0; k < 3; ++k) {
      if (t[k] != v) continue;
      const Point2 &a = p[t[(k + 1) % 3]], &b = p[t[(k + 2) % 3]];
      if (a.y <= c.y && b.y > c.y && orientation(a, b, c) > 0) ++w;
      if (b.y <= c.y && a.y > c.y && orientation(a, b, c) < 0) --w;
    }
  return w;
}

// The stored map as a reader sees it: (s, t) clockwise, (s, 1 - t) counterclockwise, each interior ring once.
bool valid_as_stored(const Map& m, const std::vector<Point2>& st) {
  std::vector<Point2> back(st.size());
  for (std::size_t v = 0; v < st.size(); ++v) back[v] = {st[v].x, 1.0 - st[v].y};
  for (const Triangle& t : m.faces)
    if (orientation(st[t[0]], st[t[1]], st[t[2]]) >= 0 || orientation(back[t[0]], back[t[1]], back[t[2]]) <= 0) return false;
  for (std::size_t v = 0; v < st.size(); ++v)
    if (!m.boundary[v] && winding(back, m.faces, static_cast<int>(v)) != 1) return false;
  return true;
}

// Steps of std::nextafter (float) from a to b, or 99 when more than 4.
int ulps(double a, double b) {
  float x = static_cast<float>(a);
  const float target = static_cast<float>(b);
  for (int n = 0; n <= 4; ++n) {
    if (x == target) return n;
    x = std::nextafter(x, target);
  }
  return 99;
}

// Fans: an interior vertex and a convex ring of k boundary vertices a few float spacings away.
Map fan(std::mt19937& rng, int index) {
  std::uniform_real_distribution<double> unit(0, 1);
  Map m;
  m.name = "fan " + std::to_string(index);
  const double cx = 0.05 + 0.9 * unit(rng), cy = 0.05 + 0.9 * unit(rng);
  const double spacing = std::ldexp(1.0, std::ilogb(std::max(cx, cy)) - 23);  // a float's spacing there
  const int k = 3 + static_cast<int>(unit(rng) * 7);
  const double radius = spacing * (0.8 + 6 * unit(rng));
  m.uv.push_back({cx + spacing * (unit(rng) - 0.5), cy + spacing * (unit(rng) - 0.5)});
  for (int i = 0; i < k; ++i) {
    const double a = (i + 0.4 * unit(rng)) * 2 * M_PI / k;
    m.uv.push_back({cx + radius * std::cos(a), cy + radius * std::sin(a)});
  }
  for (int i = 0; i < k; ++i) m.faces.push_back({0, 1 + i, 1 + (i + 1) % k});
  m.boundary.assign(m.uv.size(), 1);
  m.boundary[0] = 0;
  return m;
}

// Jittered grids of n x n vertices spaced a few float spacings apart; the border is the boundary.
Map grid(std::mt19937& rng, int index) {
  std::uniform_real_distribution<double> unit(0, 1);
  Map m;
  m.name = "grid " + std::to_string(index);
  const int n = 3 + static_cast<int>(unit(rng) * 4);
  const double x0 = 0.05 + 0.8 * unit(rng), y0 = 0.05 + 0.8 * unit(rng);
  const double spacing = std::ldexp(1.0, std::ilogb(std::max(x0, y0)) - 23);
  const double h = spacing * (1.2 + 5 * unit(rng));
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const bool border = i == 0 || j == 0 || i == n - 1 || j == n - 1;
      const double jitter = border ? 0 : 0.35 * h;
      m.uv.push_back({x0 + i * h + jitter * (2 * unit(rng) - 1), y0 + j * h + jitter * (2 * unit(rng) - 1)});
      m.boundary.push_back(border ? 1 : 0);
    }
  m.faces = testgen::grid_triangles(n - 1, n - 1, testgen::alternating_diagonal);
  return m;
}

struct Tally {
  int maps = 0, plain_invalid = 0, repaired = 0, refused = 0;
};

void check(const Map& m, Tally& tally) {
  SCOPED_TRACE(m.name);
  const Float32Uv r = float32_texcoords(m.uv, m.faces);
  ASSERT_EQ(r.st.size(), m.uv.size());
  std::vector<Point2> plain(m.uv.size());
  std::size_t moved = 0;
  for (std::size_t v = 0; v < m.uv.size(); ++v) {
    plain[v] = {fl32(m.uv[v].x), fl32(1.0 - m.uv[v].y)};
    EXPECT_EQ(fl32(r.st[v].x), r.st[v].x) << "vertex " << v;
    EXPECT_EQ(fl32(r.st[v].y), r.st[v].y) << "vertex " << v;
    if (m.boundary[v]) EXPECT_TRUE(r.st[v] == plain[v]) << "boundary vertex " << v << " moved";
    EXPECT_LE(ulps(plain[v].x, r.st[v].x), 2) << "vertex " << v;
    EXPECT_LE(ulps(plain[v].y, r.st[v].y), 2) << "vertex " << v;
    if (r.st[v] != plain[v]) ++moved;
  }
  EXPECT_EQ(r.adjusted, moved);
  const bool valid = valid_as_stored(m, r.st);
  EXPECT_EQ(r.ok(), valid) << "bad face " << r.bad_face << ", bad vertex " << r.bad_vertex;
  const bool plain_valid = valid_as_stored(m, plain);
  if (plain_valid) EXPECT_EQ(r.adjusted, 0u);
  ++tally.maps;
  if (!plain_valid) ++tally.plain_invalid;
  if (!plain_valid && valid) ++tally.repaired;
  if (!valid) ++tally.refused;
}

TEST(Float32Uv, GeneratedFansAndGridsNearFloatSpacing) {
  std::mt19937 rng(20240611);
  Tally tally;
  for (int i = 0; i < 3000; ++i) {
    const Map m = i % 3 == 2 ? grid(rng, i) : fan(rng, i);
    if (!positive_in_double(m)) continue;  // the function's precondition: a valid map in double
    check(m, tally);
    if (HasFailure()) break;
  }
  std::cout << "[ float32 ] " << tally.maps << " maps, " << tally.plain_invalid << " broken by plain rounding, "
            << tally.repaired << " repaired, " << tally.refused << " refused\n";
  // The generators must reach the cases the repair exists for, or the test shows nothing.
  EXPECT_GT(tally.maps, 2000);
  EXPECT_GT(tally.plain_invalid, 50);
  EXPECT_GT(tally.repaired, 20);
}

TEST(Float32Uv, InteriorVertexRoundedOntoABoundaryEdgeMovesOneFloat) {
  // Unit square with its centre vertex at v = 1e-9: t = fl32(1 - 1e-9) = 1, on the edge t = 1.
  Map m;
  m.name = "square";
  m.uv = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0.5, 1e-9}};
  m.faces = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  m.boundary = {1, 1, 1, 1, 0};
  ASSERT_TRUE(positive_in_double(m));
  Tally tally;
  check(m, tally);
  const Float32Uv r = float32_texcoords(m.uv, m.faces);
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.adjusted, 1u);
  EXPECT_EQ(r.st[4].x, 0.5);
  EXPECT_EQ(r.st[4].y, double(std::nextafter(1.0f, 0.0f)));  // one ulp, the smallest move that works
}

TEST(Float32Uv, PositiveTrianglesWindingTwiceAreReported) {
  // Paper Fig. 1a: ten positive triangles around a vertex whose ring goes round twice. Coordinates are
  // multiples of 1/64, so rounding changes nothing and only the turn count can object.
  Map m;
  m.name = "double winding";
  m.uv.push_back({0.5, 0.5});
  const int k = 10;
  for (int i = 0; i < k; ++i) {
    const double a = 4 * M_PI * i / k;
    m.uv.push_back({0.5 + std::round(16 * std::cos(a)) / 64, 0.5 + std::round(16 * std::sin(a)) / 64});
  }
  for (int i = 0; i < k; ++i) m.faces.push_back({0, 1 + i, 1 + (i + 1) % k});
  m.boundary.assign(m.uv.size(), 1);
  m.boundary[0] = 0;
  ASSERT_TRUE(positive_in_double(m));
  std::vector<Point2> back(m.uv.size());
  for (std::size_t v = 0; v < back.size(); ++v) back[v] = {m.uv[v].x, 1.0 - fl32(1.0 - m.uv[v].y)};
  ASSERT_EQ(winding(back, m.faces, 0), 2);
  const Float32Uv r = float32_texcoords(m.uv, m.faces);
  EXPECT_EQ(r.bad_face, -1);
  EXPECT_EQ(r.bad_vertex, 0);
  EXPECT_EQ(r.bad_vertex_turns, 2);
  EXPECT_FALSE(r.ok());
}

TEST(Float32Uv, ADegenerateTriangleNoMoveCanSaveIsReported) {
  // All three corners on the boundary: nothing may move; v = 1e-12 rounds t to 1 and flattens the triangle.
  Map m;
  m.name = "flat";
  m.uv = {{0, 0}, {1, 0}, {0.5, 1e-12}};
  m.faces = {{0, 1, 2}};
  m.boundary = {1, 1, 1};
  ASSERT_TRUE(positive_in_double(m));
  const Float32Uv r = float32_texcoords(m.uv, m.faces);
  EXPECT_EQ(r.bad_face, 0);
  EXPECT_EQ(r.bad_face_orientation, 0);
  EXPECT_EQ(r.adjusted, 0u);
  EXPECT_FALSE(r.ok());
}

}  // namespace
}  // namespace lipmap
