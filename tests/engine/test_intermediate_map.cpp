// Stage "intermediate maps" (paper 4, 5.1): bijective maps of disk meshes onto the unit disk.
//
// Every map is checked here without the engine's own predicate: orientation signs are decided with exact
// rationals (CGAL::Gmpq on the doubles), boundary positions are recomputed from the documented formula,
// angle sums are summed in long double.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/grid_cells.h"
#include "tests/support/test_meshes.h"

#include <CGAL/Gmpq.h>

#include "engine/cancel.h"
#include "engine/multigrid.h"
#include "engine/error.h"
#include "engine/intermediate_map.h"
#include "engine/mesh_io.h"
#include "engine/validate.h"

namespace lipmap {
namespace {

struct Mesh {
  std::vector<Point3> v;
  std::vector<Triangle> f;
  std::vector<int> loop;
};

// ---- independent checks --------------------------------------------------------------------------------

// Sign of the orientation of (a, b, c) with exact rationals.
int exact_orientation(const Point2& a, const Point2& b, const Point2& c) {
  const CGAL::Gmpq ax(a.x), ay(a.y), bx(b.x), by(b.y), cx(c.x), cy(c.y);
  const CGAL::Gmpq det = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
  return det.sign();
}

int independent_non_positive(const std::vector<Point2>& uv, const std::vector<Triangle>& faces) {
  int count = 0;
  for (const Triangle& t : faces)
    if (exact_orientation(uv[static_cast<std::size_t>(t[0])], uv[static_cast<std::size_t>(t[1])],
                          uv[static_cast<std::size_t>(t[2])]) <= 0)
      ++count;
  return count;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

// The documented boundary formula, written out again.
Point2 expected_boundary(int k, int n) {
  const double theta = (2.0 * M_PI * static_cast<double>(k)) / static_cast<double>(n);
  return {std::cos(theta), std::sin(theta)};
}

void expect_boundary_exact(const Mesh& m, const DiskMap& d, const std::string& label) {
  const int n = static_cast<int>(m.loop.size());
  int wrong = 0;
  for (int k = 0; k < n; ++k) {
    const Point2 e = expected_boundary(k, n);
    const Point2& p = d.uv[static_cast<std::size_t>(m.loop[static_cast<std::size_t>(k)])];
    if (!same_bits(p.x, e.x) || !same_bits(p.y, e.y)) ++wrong;
  }
  EXPECT_EQ(wrong, 0) << label << ": boundary vertices off their prescribed circle positions";
}

// Everything docs/contract.md asks of a bijective map onto the disk.
void expect_bijective_disk_map(const Mesh& m, const DiskMap& d, const std::string& label) {
  ASSERT_EQ(d.uv.size(), m.v.size()) << label;
  expect_boundary_exact(m, d, label);
  const int independent = independent_non_positive(d.uv, m.f);
  EXPECT_EQ(independent, 0) << label << ": non-positive triangles";
  EXPECT_EQ(d.flipped, independent) << label << ": the reported count is not exact";
  EXPECT_EQ(count_non_positive(d.uv, m.f), independent) << label;
  EXPECT_TRUE(d.bijective()) << label;

  std::vector<char> on_boundary(m.v.size(), 0);
  for (int b : m.loop) on_boundary[static_cast<std::size_t>(b)] = 1;
  int outside = 0;
  for (std::size_t i = 0; i < m.v.size(); ++i) {
    if (on_boundary[i]) continue;
    const long double x = d.uv[i].x, y = d.uv[i].y;
    if (!(x * x + y * y < 1.0L)) ++outside;
  }
  EXPECT_EQ(outside, 0) << label << ": interior vertices not strictly inside the unit disk";

  // One full turn around every interior vertex.
  std::vector<long double> angle(m.v.size(), 0.0L);
  for (const Triangle& t : m.f)
    for (int k = 0; k < 3; ++k) {
      const Point2& o = d.uv[static_cast<std::size_t>(t[static_cast<std::size_t>(k)])];
      const Point2& a = d.uv[static_cast<std::size_t>(t[static_cast<std::size_t>((k + 1) % 3)])];
      const Point2& b = d.uv[static_cast<std::size_t>(t[static_cast<std::size_t>((k + 2) % 3)])];
      const long double e1x = static_cast<long double>(a.x) - o.x, e1y = static_cast<long double>(a.y) - o.y;
      const long double e2x = static_cast<long double>(b.x) - o.x, e2y = static_cast<long double>(b.y) - o.y;
      angle[static_cast<std::size_t>(t[static_cast<std::size_t>(k)])] +=
          std::atan2(e1x * e2y - e1y * e2x, e1x * e2x + e1y * e2y);
    }
  const long double two_pi = 2.0L * 3.141592653589793238462643383279502884L;
  int bad_turns = 0;
  long double worst = 0;
  for (std::size_t i = 0; i < m.v.size(); ++i) {
    if (on_boundary[i]) continue;
    const long double err = std::fabs(angle[i] - two_pi);
    worst = std::max(worst, err);
    if (err > 1e-6L) ++bad_turns;
  }
  EXPECT_EQ(bad_turns, 0) << label << ": interior angle sums differ from 2 pi (worst " << static_cast<double>(worst)
                          << ")";
}

// ---- meshes --------------------------------------------------------------------------------------------

// Boundary loop from the faces: the directed edges without a twin, interior on the left, from the lowest index.
std::vector<int> boundary_loop_of(const std::vector<Triangle>& faces) {
  std::map<std::pair<int, int>, int> directed;
  for (const Triangle& t : faces)
    for (int k = 0; k < 3; ++k) directed[{t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)]}] = 1;
  std::map<int, int> next;
  for (const auto& [e, one] : directed)
    if (!directed.count({e.second, e.first})) next[e.first] = e.second;
  std::vector<int> loop;
  if (next.empty()) return loop;
  const int start = next.begin()->first;
  int v = start;
  do {
    loop.push_back(v);
    v = next.at(v);
  } while (v != start && loop.size() <= next.size());
  return loop;
}

// Deterministic jitter in [-1, 1) (splitmix64), independent of the standard library's distributions.
struct Jitter {
  std::uint64_t s;
  double operator()() {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * (2.0 / 9007199254740992.0) - 1.0;
  }
};

// nx x ny quads of the rectangle [0, nx*sx] x [0, ny*sy], each split by a diagonal; interior vertices
// jittered by up to `jitter` cells (< 0.5 keeps every triangle positive).
Mesh grid(int nx, int ny, double sx = 1.0, double sy = 1.0, double jitter = 0.0, std::uint64_t seed = 1) {
  Mesh m;
  Jitter rnd{seed};
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const bool boundary = i == 0 || j == 0 || i == nx || j == ny;
      const double dx = boundary ? 0.0 : jitter * rnd(), dy = boundary ? 0.0 : jitter * rnd();
      m.v.push_back({(i + dx) * sx, (j + dy) * sy, 0.0});
    }
  m.f = testgen::grid_triangles(nx, ny, testgen::alternating_diagonal);
  m.loop = boundary_loop_of(m.f);
  return m;
}

// A height field over a jittered grid: a curved 3D disk.
Mesh bumpy_grid(int nx, int ny) {
  Mesh m = grid(nx, ny, 1.0, 1.0, 0.3, 99);
  for (Point3& p : m.v) p.z = 2.0 * std::sin(0.4 * p.x) * std::cos(0.3 * p.y) + 0.02 * p.x * p.x;
  return m;
}

// A tube closed at one end ("sock"): k vertices per ring, `rings` rings, ring 0 is the boundary, a cap
// vertex closes the far end. The disk images of the far rings shrink geometrically: exponential crowding.
Mesh sock(int k, int rings) {
  Mesh m;
  auto id = [&](int r, int j) { return r * k + ((j % k) + k) % k; };
  for (int r = 0; r < rings; ++r)
    for (int j = 0; j < k; ++j) {
      const double a = 2.0 * M_PI * j / k;
      m.v.push_back({std::cos(a), std::sin(a), static_cast<double>(r)});
    }
  const int cap = rings * k;
  m.v.push_back({0.0, 0.0, static_cast<double>(rings)});
  for (int r = 0; r + 1 < rings; ++r)
    for (int j = 0; j < k; ++j) {
      const int a = id(r, j), b = id(r, j + 1), c = id(r + 1, j + 1), d = id(r + 1, j);
      m.f.push_back({a, d, c});
      m.f.push_back({a, c, b});
    }
  for (int j = 0; j < k; ++j) m.f.push_back({id(rings - 1, j), cap, id(rings - 1, j + 1)});
  m.loop = boundary_loop_of(m.f);
  return m;
}

// Planar disk: centre vertex, `rings` rings of n vertices; the outer ring is exactly the prescribed
// boundary (vertex k at expected_boundary(k, n)); inner rings rotated and jittered.
Mesh polar_disk(int n, int rings, double jitter) {
  Mesh m;
  Jitter rnd{12345};
  m.v.push_back({0.02, -0.01, 0.0});
  for (int r = 1; r <= rings; ++r)
    for (int j = 0; j < n; ++j) {
      if (r == rings) {
        const Point2 p = expected_boundary(j, n);
        m.v.push_back({p.x, p.y, 0.0});
      } else {
        const double rad = (r + jitter * rnd()) / rings;
        const double a = 2.0 * M_PI * (j + 0.5 * (r % 2)) / n + jitter * rnd() / n;
        m.v.push_back({rad * std::cos(a), rad * std::sin(a), 0.0});
      }
    }
  auto id = [&](int r, int j) { return 1 + (r - 1) * n + ((j % n) + n) % n; };
  for (int j = 0; j < n; ++j) m.f.push_back({0, id(1, j), id(1, j + 1)});
  for (int r = 1; r < rings; ++r)
    for (int j = 0; j < n; ++j) {
      const int a = id(r, j), b = id(r, j + 1), c = id(r + 1, j + 1), d = id(r + 1, j);
      m.f.push_back({a, d, c});
      m.f.push_back({a, c, b});
    }
  m.loop.clear();
  for (int j = 0; j < n; ++j) m.loop.push_back(id(rings, j));
  return m;
}

// A star-shaped quadrilateral around one interior vertex whose cotangent weight towards vertex 1 is
// negative: the harmonic image of vertex 0 lands outside the square of its neighbours' images.
Mesh harmonic_fold_fan() {
  Mesh m;
  m.v = {{0, 0, 0}, {0.372, 0, 0}, {0.062, 0.325, 0}, {-0.146, -0.074, 0}, {0.139, -0.021, 0}};
  m.f = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 1}};
  m.loop = {1, 2, 3, 4};
  return m;
}

// A 7 x 3 planar grid with strongly jittered interior vertices and mixed diagonals (all triangles
// positive), on which the cotangent map folds one triangle.
Mesh harmonic_fold_grid() {
  const double xy[][2] = {{0.000, 0.000}, {1.000, 0.000}, {2.000, 0.000}, {3.000, 0.000}, {4.000, 0.000},
                          {5.000, 0.000}, {6.000, 0.000}, {7.000, 0.000}, {0.000, 1.000}, {1.321, 1.165},
                          {1.662, 1.345}, {3.217, 0.833}, {4.473, 1.080}, {4.660, 1.292}, {5.741, 0.608},
                          {7.000, 1.000}, {0.000, 2.000}, {1.313, 2.108}, {2.422, 2.489}, {2.896, 2.039},
                          {4.270, 2.223}, {4.860, 1.525}, {5.921, 2.463}, {7.000, 2.000}, {0.000, 3.000},
                          {1.000, 3.000}, {2.000, 3.000}, {3.000, 3.000}, {4.000, 3.000}, {5.000, 3.000},
                          {6.000, 3.000}, {7.000, 3.000}};
  const char* diagonals = "110100001100000000101";
  const int nx = 7, ny = 3;
  Mesh m;
  for (const auto& p : xy) m.v.push_back({p[0], p[1], 0.0});
  // diagonals[j * nx + i] == '1': cell (i, j) split by b-d.
  m.f = testgen::grid_triangles(nx, ny, [&](int i, int j) { return diagonals[j * nx + i] != '1'; });
  m.loop = boundary_loop_of(m.f);
  return m;
}

DiskMap map(const Mesh& m, MapMethod method) {
  const DiskMapInput in{&m.v, &m.f, &m.loop};
  return map_to_disk(in, method);
}

std::string label(const std::string& name, MapMethod method) { return name + "/" + to_string(method); }

// ---- the test meshes -----------------------------------------------------------------------------------

Mesh load_shared(const testmeshes::MeshEntry& entry) {
  const DiskMesh disk = validate_mesh(read_mesh_file(entry.path()));
  return Mesh{disk.vertices, disk.faces, disk.boundary_loop};
}


// ---- tests ---------------------------------------------------------------------------------------------

TEST(IntermediateMap, BoundaryPointsFollowTheDocumentedFormulaBitForBit) {
  for (int n : {3, 4, 7, 34, 96, 1000, 3064}) {
    const std::vector<Point2> all = disk_boundary_positions(n);
    ASSERT_EQ(static_cast<int>(all.size()), n);
    for (int k = 0; k < n; ++k) {
      const Point2 e = expected_boundary(k, n);
      ASSERT_TRUE(same_bits(disk_boundary_point(k, n).x, e.x) && same_bits(disk_boundary_point(k, n).y, e.y))
          << k << "/" << n;
      ASSERT_TRUE(all[static_cast<std::size_t>(k)] == e);
    }
  }
  EXPECT_EQ(disk_boundary_point(0, 5).x, 1.0);
  EXPECT_EQ(disk_boundary_point(0, 5).y, 0.0);
}

TEST(IntermediateMap, CornerCotangentsOfKnownTriangles) {
  // Right isosceles triangle: 90 degrees at corner 0, 45 at the others.
  const std::vector<Point3> v3 = {{0, 0, 5}, {2, 0, 5}, {0, 2, 5}};
  const std::vector<Point2> v2 = {{0, 0}, {2, 0}, {0, 2}};
  const std::vector<Triangle> f = {{0, 1, 2}};
  for (const auto& c : {corner_cotangents(v3, f), corner_cotangents(v2, f)}) {
    ASSERT_EQ(c.size(), 1u);
    EXPECT_NEAR(c[0][0], 0.0, 1e-15);
    EXPECT_NEAR(c[0][1], 1.0, 1e-15);
    EXPECT_NEAR(c[0][2], 1.0, 1e-15);
  }
  // Unsigned: the clockwise copy has the same cotangents. 120-degree corner: cot = -1/sqrt(3).
  const std::vector<Point2> obtuse = {{0, 0}, {1, 0}, {-0.5, std::sqrt(3.0) / 2}};
  const auto c = corner_cotangents(obtuse, {{0, 2, 1}});
  EXPECT_NEAR(c[0][0], -1.0 / std::sqrt(3.0), 1e-15);
  // Tilted in 3D: same as in the plane.
  const std::vector<Point3> tilted = {{0, 0, 0}, {1, 0, 1}, {-0.5, std::sqrt(3.0) / 2, -0.5}};
  const auto t3 = corner_cotangents(tilted, {{0, 1, 2}});
  const double a = std::sqrt(2.0), b = std::sqrt(0.25 + 0.75 + 0.25);
  const double cos0 = (-0.5 - 0.5) / (a * b);
  EXPECT_NEAR(t3[0][0], cos0 / std::sqrt(1 - cos0 * cos0), 1e-14);
}

TEST(IntermediateMap, CotanLaplacianIsSymmetricWithZeroRowSumsAndLinearPrecision) {
  const Mesh m = grid(12, 9, 1.0, 0.7, 0.35, 7);
  int non_finite = -1;
  const Eigen::SparseMatrix<double> L = cotan_laplacian(m.v, m.f, &non_finite);
  EXPECT_EQ(non_finite, 0);
  const Eigen::SparseMatrix<double> Lt = L.transpose();
  EXPECT_LT((L - Lt).norm(), 1e-12);
  Eigen::VectorXd ones = Eigen::VectorXd::Ones(L.cols()), x(L.cols()), y(L.cols());
  for (Eigen::Index i = 0; i < L.cols(); ++i) {
    x[i] = m.v[static_cast<std::size_t>(i)].x;
    y[i] = m.v[static_cast<std::size_t>(i)].y;
  }
  EXPECT_LT((L * ones).cwiseAbs().maxCoeff(), 1e-12);
  // Linear functions are harmonic at interior vertices of a planar mesh (cotangent weights reproduce them).
  std::vector<char> on_boundary(m.v.size(), 0);
  for (int b : m.loop) on_boundary[static_cast<std::size_t>(b)] = 1;
  const Eigen::VectorXd Lx = L * x, Ly = L * y;
  for (Eigen::Index i = 0; i < L.cols(); ++i) {
    if (on_boundary[static_cast<std::size_t>(i)]) continue;
    EXPECT_NEAR(Lx[i], 0.0, 1e-12) << i;
    EXPECT_NEAR(Ly[i], 0.0, 1e-12) << i;
  }
  // The graph Laplacian: degree on the diagonal of interior rows, -1 per edge.
  const Eigen::SparseMatrix<double> U = uniform_laplacian(static_cast<int>(m.v.size()), m.f);
  for (int i = 0; i < U.outerSize(); ++i) {
    if (on_boundary[static_cast<std::size_t>(i)]) continue;
    int degree = 0;
    for (Eigen::SparseMatrix<double>::InnerIterator it(U, i); it; ++it)
      if (it.row() != i) {
        EXPECT_EQ(it.value(), -1.0);
        ++degree;
      }
    EXPECT_EQ(U.coeff(i, i), static_cast<double>(degree));
  }
}

TEST(IntermediateMap, DegenerateFaceGetsUniformWeightsAndIsCounted) {
  const std::vector<Triangle> f = {{0, 1, 2}, {0, 2, 3}};
  const std::vector<std::array<double, 3>> cot = {{1.0, 1.0, 0.0}, {NAN, 1.0, 1.0}};
  int non_finite = 0;
  const Eigen::SparseMatrix<double> L = laplacian_from_cotangents(4, f, cot, &non_finite);
  EXPECT_EQ(non_finite, 1);
  EXPECT_TRUE(Eigen::MatrixXd(L).allFinite());
}

class IntermediateMapGrids : public ::testing::TestWithParam<MapMethod> {};

TEST_P(IntermediateMapGrids, GeneratedGridsMapBijectively) {
  const MapMethod method = GetParam();
  struct Case {
    const char* name;
    Mesh mesh;
  };
  const Case cases[] = {{"grid1x1", grid(1, 1)},
                        {"grid2x2", grid(2, 2)},
                        {"grid10x10", grid(10, 10)},
                        {"grid40x25-jitter", grid(40, 25, 1.0, 1.0, 0.3, 3)},
                        {"grid30x30-anisotropic", grid(30, 30, 1.0, 0.05, 0.2, 5)},
                        {"bumpy60x40", bumpy_grid(60, 40)},
                        {"grid200x2", grid(200, 2)},
                        {"sock6x40", sock(6, 40)}};
  for (const Case& c : cases) {
    const DiskMap d = map(c.mesh, method);
    expect_bijective_disk_map(c.mesh, d, label(c.name, method));
    EXPECT_EQ(d.factorizations, d.interior_vertices > 0 ? 1 : 0) << c.name;
  }
}

INSTANTIATE_TEST_SUITE_P(IntermediateMap, IntermediateMapGrids,
                         ::testing::Values(MapMethod::tutte, MapMethod::harmonic),
                         [](const auto& info) { return std::string(to_string(info.param)); });

// Every disk mesh of the catalog (tests/support/test_meshes.h), extra meshes included.
class IntermediateMapShared : public ::testing::TestWithParam<testmeshes::MeshEntry> {};

TEST_P(IntermediateMapShared, BothMethodsMapBijectively) {
  const Mesh m = load_shared(GetParam());
  const std::string name = GetParam().name();
  ASSERT_GE(m.loop.size(), 3u);
  for (MapMethod method : {MapMethod::tutte, MapMethod::harmonic}) {
    const DiskMap d = map(m, method);
    expect_bijective_disk_map(m, d, label(name, method));
    EXPECT_EQ(d.interior_vertices, static_cast<int>(m.v.size() - m.loop.size()));
    if (method == MapMethod::tutte) EXPECT_EQ(d.flipped_after_solve, 0) << name;
  }
}

// Above kMultigridMinUnknowns interior vertices the systems are solved by multigrid-preconditioned conjugate
// gradients. Forced on every catalog mesh, the maps are as bijective as the factor's and the same map to
// within 1e-9 (the solver stops at a relative residual of 1e-13; the factor's map is the reference here).
TEST_P(IntermediateMapShared, MultigridSolvesGiveTheFactorsMap) {
  const Mesh m = load_shared(GetParam());
  const std::string name = GetParam().name();
  for (MapMethod method : {MapMethod::tutte, MapMethod::harmonic}) {
    const DiskMap direct = map(m, method);
    DiskMapInput in{&m.v, &m.f, &m.loop};
    in.multigrid_min_unknowns = 1;
    const DiskMap iterative = map_to_disk(in, method);
    expect_bijective_disk_map(m, iterative, label(name, method) + "/multigrid");
    ASSERT_EQ(iterative.uv.size(), direct.uv.size());
    double largest = 0;
    for (std::size_t i = 0; i < direct.uv.size(); ++i)
      largest = std::max({largest, std::fabs(iterative.uv[i].x - direct.uv[i].x),
                          std::fabs(iterative.uv[i].y - direct.uv[i].y)});
    EXPECT_LE(largest, 1e-9) << label(name, method);
    // Up to coarse_size unknowns the hierarchy is one factored level and no iteration runs.
    const bool iterated = iterative.interior_vertices > MultigridSettings{}.coarse_size;
    EXPECT_EQ(iterative.multigrid_levels > 1, iterated) << label(name, method);
    EXPECT_EQ(iterative.solver_iterations > 0, iterated) << label(name, method);
    EXPECT_EQ(direct.multigrid_levels, 0) << label(name, method);
    EXPECT_EQ(direct.solver_iterations, 0) << label(name, method);
  }
}

INSTANTIATE_TEST_SUITE_P(IntermediateMap, IntermediateMapShared, ::testing::ValuesIn(testmeshes::disk_meshes()),
                         [](const auto& info) { return info.param.name(); });

TEST(IntermediateMapCrowding, LongThinStripIsFlipFreeOrReportsItsFlipsExactly) {
  for (const auto& [name, m] : {std::pair<const char*, Mesh>{"grid200x2", grid(200, 2)},
                                {"grid200x2-thin", grid(200, 2, 1.0, 0.01)},
                                {"grid2000x2", grid(2000, 2)}}) {
    for (MapMethod method : {MapMethod::tutte, MapMethod::harmonic}) {
      const DiskMap d = map(m, method);
      expect_boundary_exact(m, d, label(name, method));
      EXPECT_EQ(d.flipped, independent_non_positive(d.uv, m.f)) << label(name, method);
      if (d.flipped == 0) expect_bijective_disk_map(m, d, label(name, method));
    }
  }
}

TEST(IntermediateMapCrowding, CrowdedSockReportsItsFlipsExactly) {
  // 1000 rings: the far rings' images shrink by a constant factor per ring, far below what a double can
  // resolve (below 1e-308 even without the boundary's rounding offset), so no fixed-precision map can be
  // flip-free. The stage must say so exactly, keep the boundary exact, and not throw.
  const Mesh deep = sock(6, 1000);
  for (MapMethod method : {MapMethod::tutte, MapMethod::harmonic}) {
    const DiskMap d = map(deep, method);
    EXPECT_GT(d.flipped, 0) << to_string(method);
    EXPECT_FALSE(d.bijective());
    EXPECT_EQ(d.flipped, independent_non_positive(d.uv, deep.f)) << to_string(method);
    EXPECT_GE(d.flipped_after_solve, d.flipped) << to_string(method);
    EXPECT_GT(d.refinement_steps, 0) << to_string(method);
    expect_boundary_exact(deep, d, label("sock6x1000", method));
    for (const Point2& p : d.uv) ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y));
  }
  // Moderate depth: every ring still resolvable, flip-free. At 80 rings the cotangent map (it shrinks
  // faster than the uniform one) folds on this platform, refinement and the mean-value re-map do not
  // help, and the Tutte re-map is flip-free: the last recovery step is exercised.
  for (int rings : {20, 60, 80}) {
    const Mesh m = sock(6, rings);
    for (MapMethod method : {MapMethod::tutte, MapMethod::harmonic}) {
      const DiskMap d = map(m, method);
      expect_bijective_disk_map(m, d, label("sock6x" + std::to_string(rings), method));
      if (d.used_tutte_fallback) {
        EXPECT_GT(d.flipped_after_solve, 0);
        EXPECT_EQ(d.factorizations, 3);
      }
      if (method == MapMethod::tutte) EXPECT_EQ(d.solution, DiskMapSolution::primary);
    }
  }
}

TEST(IntermediateMapFold, ObtuseFanForcesHarmonicFlipsAndTheMeanValueRemapRemovesThem) {
  const Mesh m = harmonic_fold_fan();
  // The input itself is a valid planar embedding.
  std::vector<Point2> xy;
  for (const Point3& p : m.v) xy.push_back({p.x, p.y});
  ASSERT_EQ(independent_non_positive(xy, m.f), 0);
  // A negative cotangent weight on edge (0, 1).
  const Eigen::SparseMatrix<double> L = cotan_laplacian(m.v, m.f);
  ASSERT_GT(L.coeff(0, 1), 0.0);  // L_01 = -w_01 > 0

  const DiskMap h = map(m, MapMethod::harmonic);
  EXPECT_GT(h.flipped_after_solve, 0);
  EXPECT_TRUE(h.used_mean_value_fallback);
  EXPECT_EQ(h.solution, DiskMapSolution::mean_value);
  EXPECT_EQ(h.factorizations, 2);
  expect_bijective_disk_map(m, h, "fold-fan/harmonic");

  const DiskMap t = map(m, MapMethod::tutte);
  EXPECT_EQ(t.flipped_after_solve, 0);
  EXPECT_FALSE(t.used_mean_value_fallback);
  expect_bijective_disk_map(m, t, "fold-fan/tutte");
}

TEST(IntermediateMapFold, JitteredGridWithObtuseTrianglesFallsBackToMeanValue) {
  const Mesh m = harmonic_fold_grid();
  std::vector<Point2> xy;
  for (const Point3& p : m.v) xy.push_back({p.x, p.y});
  ASSERT_EQ(independent_non_positive(xy, m.f), 0);
  const DiskMap h = map(m, MapMethod::harmonic);
  EXPECT_GT(h.flipped_after_solve, 0);
  EXPECT_TRUE(h.used_mean_value_fallback);
  expect_bijective_disk_map(m, h, "fold-grid/harmonic");
  // The plain cotangent solution, recomputed without fallback, folds exactly as reported.
  const DiskMapInput in{&m.v, &m.f, &m.loop};
  const DiskMap raw = map_to_disk_with_laplacian(in, cotan_laplacian(m.v, m.f), false);
  EXPECT_EQ(raw.flipped, independent_non_positive(raw.uv, m.f));
  EXPECT_EQ(raw.flipped, h.flipped_after_solve);
  EXPECT_EQ(raw.solution, DiskMapSolution::primary);
}

TEST(IntermediateMapIdentity, HarmonicReproducesAPlanarDiskWhoseBoundaryIsAlreadyInPlace) {
  const Mesh m = polar_disk(48, 10, 0.15);
  std::vector<Point2> xy;
  for (const Point3& p : m.v) xy.push_back({p.x, p.y});
  ASSERT_EQ(independent_non_positive(xy, m.f), 0);

  const DiskMap h = map(m, MapMethod::harmonic);
  expect_bijective_disk_map(m, h, "polar/harmonic");
  EXPECT_EQ(h.solution, DiskMapSolution::primary);
  double harmonic_error = 0;
  for (std::size_t i = 0; i < m.v.size(); ++i)
    harmonic_error = std::max(harmonic_error, std::hypot(h.uv[i].x - m.v[i].x, h.uv[i].y - m.v[i].y));
  EXPECT_LT(harmonic_error, 1e-9);

  // Uniform weights do not reproduce the jittered interior.
  const DiskMap t = map(m, MapMethod::tutte);
  expect_bijective_disk_map(m, t, "polar/tutte");
  double tutte_error = 0;
  for (std::size_t i = 0; i < m.v.size(); ++i)
    tutte_error = std::max(tutte_error, std::hypot(t.uv[i].x - m.v[i].x, t.uv[i].y - m.v[i].y));
  EXPECT_GT(tutte_error, 1e-3);
}

TEST(IntermediateMap, CustomLaplacianEntryPointMatchesHarmonic) {
  const Mesh m = bumpy_grid(20, 15);
  const DiskMapInput in{&m.v, &m.f, &m.loop};
  const DiskMap a = map_to_disk(in, MapMethod::harmonic);
  const DiskMap b = map_to_disk_with_laplacian(in, cotan_laplacian(m.v, m.f), true);
  ASSERT_EQ(a.uv.size(), b.uv.size());
  // Same operator, assembled in a different summation order: equal up to rounding.
  for (std::size_t i = 0; i < a.uv.size(); ++i) {
    EXPECT_NEAR(a.uv[i].x, b.uv[i].x, 1e-12);
    EXPECT_NEAR(a.uv[i].y, b.uv[i].y, 1e-12);
  }
  expect_bijective_disk_map(m, b, "bumpy/custom-laplacian");
  // And the graph Laplacian through the same entry point is the Tutte map.
  const DiskMap t = map_to_disk(in, MapMethod::tutte);
  const DiskMap u = map_to_disk_with_laplacian(in, uniform_laplacian(static_cast<int>(m.v.size()), m.f), false);
  for (std::size_t i = 0; i < t.uv.size(); ++i) {
    EXPECT_NEAR(t.uv[i].x, u.uv[i].x, 1e-12);
    EXPECT_NEAR(t.uv[i].y, u.uv[i].y, 1e-12);
  }
}

// A system the multigrid solver cannot handle (here: indefinite with a positive diagonal; its coarse factor or
// its iterations fail) is factored after all: the map is the one of the factorization path (LU, since the
// supernodal LLT fails too), bit for bit, and no multigrid hierarchy is reported.
TEST(IntermediateMap, IndefiniteSystemFallsBackFromMultigridToTheFactorization) {
  const Mesh m = grid(80, 80);
  Eigen::SparseMatrix<double> L = uniform_laplacian(static_cast<int>(m.v.size()), m.f);
  // Every 7th interior edge of the mesh gets a positive off-diagonal entry larger than its endpoints'
  // diagonal: x_i = 1, x_j = -1 then has a negative energy.
  int changed = 0, edge = 0;
  std::vector<char> boundary(m.v.size(), 0);
  for (int v : m.loop) boundary[static_cast<std::size_t>(v)] = 1;
  for (const Triangle& t : m.f) {
    const int i = t[0], j = t[1];
    if (boundary[static_cast<std::size_t>(i)] || boundary[static_cast<std::size_t>(j)] || i > j) continue;
    if (++edge % 7) continue;
    L.coeffRef(i, j) += 20.0;
    L.coeffRef(j, i) += 20.0;
    ++changed;
  }
  ASSERT_GT(changed, 100);
  DiskMapInput in{&m.v, &m.f, &m.loop};
  const DiskMap factored = map_to_disk_with_laplacian(in, L, false);
  in.multigrid_min_unknowns = 1;
  const DiskMap fallback = map_to_disk_with_laplacian(in, L, false);
  EXPECT_TRUE(factored.lu_for_primary);
  EXPECT_TRUE(fallback.lu_for_primary);
  EXPECT_EQ(fallback.multigrid_levels, 0);
  ASSERT_EQ(fallback.uv.size(), factored.uv.size());
  int differing = 0;
  for (std::size_t i = 0; i < factored.uv.size(); ++i)
    if (fallback.uv[i].x != factored.uv[i].x || fallback.uv[i].y != factored.uv[i].y) ++differing;
  EXPECT_EQ(differing, 0);
  EXPECT_EQ(fallback.flipped, factored.flipped);
}

TEST(IntermediateMap, AllBoundaryMeshNeedsNoSolve) {
  // A fan of triangles without interior vertex.
  Mesh m;
  m.v = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {-0.5, 0.5, 0}};
  m.f = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}};
  m.loop = boundary_loop_of(m.f);
  ASSERT_EQ(m.loop.size(), 5u);
  for (MapMethod method : {MapMethod::tutte, MapMethod::harmonic}) {
    const DiskMap d = map(m, method);
    EXPECT_EQ(d.factorizations, 0);
    expect_bijective_disk_map(m, d, label("fan", method));
  }
}

TEST(IntermediateMap, ConcurrentCallsGiveIdenticalMaps) {
  // The service maps on several workers at once: CHOLMOD, UMFPACK and BLAS must not share state.
  const Mesh m = bumpy_grid(80, 60);
  const Mesh fold = harmonic_fold_grid();
  const DiskMap ref = map(m, MapMethod::harmonic);
  const DiskMap ref_fold = map(fold, MapMethod::harmonic);
  std::vector<DiskMap> out(8), out_fold(8);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (int r = 0; r < 2; ++r) {
        out[static_cast<std::size_t>(2 * t + r)] = map(m, MapMethod::harmonic);
        out_fold[static_cast<std::size_t>(2 * t + r)] = map(fold, MapMethod::harmonic);
      }
    });
  for (std::thread& t : threads) t.join();
  // BLAS may block its work differently under load: equal up to rounding, and each map checked exactly.
  auto max_diff = [](const DiskMap& a, const DiskMap& b) {
    double d = 0;
    for (std::size_t i = 0; i < a.uv.size(); ++i)
      d = std::max(d, std::max(std::fabs(a.uv[i].x - b.uv[i].x), std::fabs(a.uv[i].y - b.uv[i].y)));
    return d;
  };
  for (std::size_t i = 0; i < out.size(); ++i) {
    ASSERT_EQ(out[i].uv.size(), ref.uv.size());
    EXPECT_LT(max_diff(out[i], ref), 1e-12) << i;
    EXPECT_LT(max_diff(out_fold[i], ref_fold), 1e-12) << i;
    EXPECT_EQ(out[i].flipped, 0);
    EXPECT_EQ(out[i].flipped, independent_non_positive(out[i].uv, m.f));
    EXPECT_TRUE(out_fold[i].used_mean_value_fallback);
    EXPECT_EQ(out_fold[i].flipped, 0);
  }
}

TEST(IntermediateMap, BrokenPreconditionsThrowInternalError) {
  const Mesh m = grid(3, 3);
  const std::vector<int> short_loop = {0, 1};
  const std::vector<int> repeated = {0, 1, 1, 2};
  const std::vector<int> out_of_range = {0, 1, 99};
  for (const std::vector<int>* loop : {&short_loop, &repeated, &out_of_range}) {
    const DiskMapInput in{&m.v, &m.f, loop};
    EXPECT_THROW(map_to_disk(in, MapMethod::tutte), InternalError);
  }
  std::vector<Point3> extra = m.v;
  extra.push_back({9, 9, 9});  // used by no face
  const DiskMapInput unused{&extra, &m.f, &m.loop};
  EXPECT_THROW(map_to_disk(unused, MapMethod::harmonic), InternalError);
  const DiskMapInput missing{&m.v, nullptr, &m.loop};
  EXPECT_THROW(map_to_disk(missing, MapMethod::harmonic), InternalError);
}

TEST(IntermediateMap, CancelledTokenStopsTheStage) {
  const Mesh m = grid(20, 20);
  CancelToken token;
  token.cancel();
  const DiskMapInput in{&m.v, &m.f, &m.loop};
  EXPECT_THROW(map_to_disk(in, MapMethod::harmonic, &token), Cancelled);
}

}  // namespace
}  // namespace lipmap
