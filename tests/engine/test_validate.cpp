// Stage "validate": every error code with its element and index, the test meshes (counts from
// tests/data/meshes/README.md), the boundary loop's start and orientation, and random grid disks.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/grid_cells.h"
#include "tests/support/test_meshes.h"

#include "engine/boundary_polygon.h"
#include "engine/cancel.h"
#include "engine/error.h"
#include "engine/mesh_io.h"
#include "engine/validate.h"

namespace lipmap {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using testmeshes::mesh_path;

// Runs fn and checks that it throws InputError with this code, element and index.
InputError expect_error(const std::function<void()>& fn, const std::string& code, const std::string& element = {},
                        std::optional<long long> index = std::nullopt) {
  try {
    fn();
  } catch (const InputError& e) {
    EXPECT_EQ(e.code(), code) << e.what();
    EXPECT_EQ(e.element(), element) << e.what();
    EXPECT_EQ(e.index(), index) << e.what();
    EXPECT_GT(std::string(e.what()).size(), 20u);  // a sentence, not just a code
    return e;
  }
  ADD_FAILURE() << "expected InputError " << code;
  return InputError("none", "");
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// ---- hand-made meshes ------------------------------------------------------------------------------

// w x h grid in the plane z = 0, vertex (i, j) = j * w + i, every triangle counterclockwise.
RawMesh grid(int w, int h) {
  RawMesh mesh;
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) mesh.vertices.push_back({double(i), double(j), 0.0});
  for (const auto& t : testgen::grid_triangles(w - 1, h - 1, [](int, int) { return true; }))
    mesh.faces.push_back({t[0], t[1], t[2]});
  return mesh;
}

// n x m quads wrapped in both directions onto a torus in 3D (consistently oriented, closed).
RawMesh torus(int n, int m, long long first_vertex = 0) {
  RawMesh mesh;
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) {
      double u = 2 * M_PI * i / n, v = 2 * M_PI * j / m;
      mesh.vertices.push_back({(3 + std::cos(v)) * std::cos(u), (3 + std::cos(v)) * std::sin(u), std::sin(v)});
    }
  auto id = [&](int i, int j) { return first_vertex + (j % m) * n + (i % n); };
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) {
      mesh.faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      mesh.faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return mesh;
}

// Two triangles forming the unit square 0 (0,0), 1 (1,0), 2 (1,1), 3 (0,1).
RawMesh square() { return RawMesh{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 3}}}; }

std::vector<Point2> positions(size_t n) {
  std::vector<Point2> p;
  for (size_t k = 0; k < n; ++k) p.push_back({std::cos(2 * M_PI * k / n), std::sin(2 * M_PI * k / n)});
  return p;
}

// ---- validate_mesh: one test per code, in the documented order --------------------------------------

TEST(ValidateTest, MeshEmpty) {
  expect_error([] { validate_mesh(RawMesh{}); }, "mesh_empty");
  expect_error([] { validate_mesh(RawMesh{{{0, 0, 0}}, {}}); }, "mesh_empty");
}

TEST(ValidateTest, NonFiniteCoordinateNamesTheVertex) {
  RawMesh mesh = grid(3, 3);
  mesh.vertices[5].z = kNaN;
  mesh.vertices[7].x = std::numeric_limits<double>::infinity();
  expect_error([&] { validate_mesh(mesh); }, "non_finite_coordinate", "vertex", 5);
}

TEST(ValidateTest, FaceNotTriangleNamesTheFace) {
  RawMesh mesh = grid(3, 3);
  mesh.faces.replace(3, {0, 1, 4, 3});
  mesh.faces.replace(5, {0, 1});
  expect_error([&] { validate_mesh(mesh); }, "face_not_triangle", "face", 3);
}

TEST(ValidateTest, FaceIndexOutOfRangeNamesTheFace) {
  RawMesh mesh = grid(3, 3);
  mesh.faces[2][1] = 9;  // one past the last vertex
  InputError e = expect_error([&] { validate_mesh(mesh); }, "face_index_out_of_range", "face", 2);
  EXPECT_TRUE(contains(e.what(), "vertex 9")) << e.what();
  mesh.faces[1][0] = -1;
  expect_error([&] { validate_mesh(mesh); }, "face_index_out_of_range", "face", 1);
}

TEST(ValidateTest, FaceRepeatedVertexNamesTheFace) {
  RawMesh mesh = grid(3, 3);
  mesh.faces.replace(6, {4, 8, 4});
  expect_error([&] { validate_mesh(mesh); }, "face_repeated_vertex", "face", 6);
}

TEST(ValidateTest, UnreferencedVertexNamesTheVertex) {
  RawMesh mesh = grid(3, 3);
  mesh.vertices.push_back({5, 5, 5});
  mesh.vertices.push_back({6, 6, 6});
  expect_error([&] { validate_mesh(mesh); }, "unreferenced_vertex", "vertex", 9);
}

TEST(ValidateTest, DegenerateFaceCollinearCorners) {
  // Face 1 has three distinct corners on one line in 3D; face 0 is a proper triangle.
  RawMesh flat{{{0, 0, 0}, {1, 1, 1}, {3, 3, 3}, {0, 1, 0}}, {{0, 3, 1}, {0, 1, 2}}};
  InputError e = expect_error([&] { validate_mesh(flat); }, "degenerate_face", "face", 1);
  EXPECT_TRUE(contains(e.what(), "face 1 has zero area: its corners 0, 1, 2 are collinear")) << e.what();
}

TEST(ValidateTest, DegenerateFaceCoincidentCorners) {
  RawMesh mesh = grid(3, 3);
  mesh.vertices[8] = mesh.vertices[7];  // every face touching both 7 and 8 is flat
  int first = -1;
  for (size_t f = 0; f < mesh.faces.size() && first < 0; ++f) {
    const auto& t = mesh.faces[f];
    if (std::count(t.begin(), t.end(), 7) && std::count(t.begin(), t.end(), 8)) first = int(f);
  }
  ASSERT_GE(first, 0);
  InputError e = expect_error([&] { validate_mesh(mesh); }, "degenerate_face", "face", first);
  EXPECT_TRUE(contains(e.what(), "at the same position")) << e.what();
}

// The predicate is exact: a sliver far thinner than any tolerance is still a triangle.
TEST(ValidateTest, ThinButNotFlatTriangleIsAccepted) {
  RawMesh sliver{{{0, 0, 0}, {1, 1, 1}, {2, 2, 2 + std::ldexp(1.0, -50)}}, {{0, 1, 2}}};
  DiskMesh disk = validate_mesh(sliver);
  EXPECT_EQ(disk.boundary_loop, (std::vector<int>{0, 1, 2}));
}

TEST(ValidateTest, DuplicateFaceNamesTheLaterFace) {
  RawMesh mesh = grid(3, 3);
  mesh.faces.push_back({4, 5, 1});  // the vertex set of an existing face, listed in another order
  std::set<long long> key{4, 5, 1};
  int original = -1;
  for (size_t f = 0; f < 8; ++f)
    if (std::set<long long>(mesh.faces[f].begin(), mesh.faces[f].end()) == key) original = int(f);
  ASSERT_GE(original, 0);
  InputError e = expect_error([&] { validate_mesh(mesh); }, "duplicate_face", "face", 8);
  EXPECT_TRUE(contains(e.what(), "as face " + std::to_string(original))) << e.what();
}

// Many copies of a few faces, interleaved with the grid's own faces: the answer names the earliest face that
// repeats an earlier face's vertex set, and that earlier face (worked out here from the construction).
TEST(ValidateTest, ManyDuplicateFacesNameTheFirstRepeat) {
  for (int copies : {2, 1000, 200000}) {
    RawMesh mesh = grid(4, 4);
    const size_t n = mesh.faces.size();
    const std::vector<long long> a = mesh.faces[5], b = mesh.faces[2];
    for (int i = 0; i < copies; ++i) {
      // rotations of the corners and both orientations: the vertex set is what makes a duplicate
      std::vector<long long> f = i % 2 ? b : a;
      std::rotate(f.begin(), f.begin() + i % 3, f.end());
      if (i % 4 >= 2) std::swap(f[0], f[1]);
      mesh.faces.push_back(f);
    }
    InputError e = expect_error([&] { validate_mesh(mesh); }, "duplicate_face", "face", static_cast<long long>(n));
    EXPECT_TRUE(contains(e.what(), "as face 5")) << e.what();
  }
}

// A token that has already fired stops validation with Cancelled, on a valid mesh and on a huge bad one.
TEST(ValidateTest, CancelledOrExpiredTokenThrowsCancelled) {
  RawMesh big = grid(3, 3);
  for (int i = 0; i < 250000; ++i) big.faces.push_back(big.faces[0]);
  for (const RawMesh* mesh : {&big}) {
    CancelToken cancelled;
    cancelled.cancel();
    EXPECT_THROW(validate_mesh(*mesh, &cancelled), Cancelled);
    CancelToken expired;
    expired.set_deadline(CancelToken::Clock::now() - std::chrono::seconds(1));
    EXPECT_THROW(validate_mesh(*mesh, &expired), Cancelled);
  }
  const RawMesh small = grid(3, 3);
  const DiskMesh disk = validate_mesh(small);
  RawBoundary boundary;
  for (int v : disk.boundary_loop) boundary.positions.push_back({small.vertices[v].x, small.vertices[v].y});
  CancelToken cancelled;
  cancelled.cancel();
  EXPECT_THROW(validate_mesh(small, &cancelled), Cancelled);
  EXPECT_THROW(validate_boundary(disk, boundary, &cancelled), Cancelled);
  CancelToken live;  // a live token changes nothing
  EXPECT_NO_THROW(validate_boundary(validate_mesh(small, &live), boundary, &live));
}

TEST(ValidateTest, NonManifoldEdgeNamesTheEdge) {
  // Three triangles on edge 0-1. Edges in order of first appearance: 0-1 (0), 1-2 (1), 2-0 (2), ...
  RawMesh fin{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}}, {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}}};
  InputError e = expect_error([&] { validate_mesh(fin); }, "non_manifold_edge", "edge", 0);
  EXPECT_TRUE(contains(e.what(), "edge 0-1 is shared by 3 faces (0, 1, 2)")) << e.what();

  // The edge number is the order of first appearance, not anything about vertex numbers.
  RawMesh later{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}},
                {{2, 0, 1}, {1, 0, 3}, {0, 1, 4}}};  // edges: 2-0 (0), 0-1 (1), 1-2 (2)
  expect_error([&] { validate_mesh(later); }, "non_manifold_edge", "edge", 1);
}

TEST(ValidateTest, InconsistentOrientationNamesTheEdge) {
  RawMesh mesh = square();
  // Edges of face 0 in order of first appearance: 0-1 (0), 1-2 (1), 2-0 (2). Face 1 = (0, 3, 2) runs along
  // 3->2 and 2->0, the same direction as face 0's 2->0.
  mesh.faces.replace(1, {0, 3, 2});
  InputError e = expect_error([&] { validate_mesh(mesh); }, "inconsistent_orientation", "edge", 2);
  EXPECT_TRUE(contains(e.what(), "faces 0 and 1")) << e.what();
  EXPECT_TRUE(contains(e.what(), "from vertex 2 to 0")) << e.what();
}

TEST(ValidateTest, NonManifoldVertexBowtie) {
  // Two triangles that share only vertex 2.
  RawMesh bowtie{{{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0, 2, 0}, {1, 2, 0}}, {{0, 1, 2}, {2, 4, 3}}};
  InputError e = expect_error([&] { validate_mesh(bowtie); }, "non_manifold_vertex", "vertex", 2);
  EXPECT_TRUE(contains(e.what(), "faces 0 and 1")) << e.what();
}

TEST(ValidateTest, NonManifoldVertexTwoDisksSharingACorner) {
  // Grid a's corner vertex 8 is also grid b's corner vertex 0: every edge is manifold and the orientation
  // consistent, but vertex 8 has two fans.
  RawMesh glued = grid(3, 3), b = grid(3, 3);
  const long long offset = 8;  // b's vertex v >= 1 becomes v + 8, its vertex 0 becomes 8
  for (size_t v = 1; v < b.vertices.size(); ++v)
    glued.vertices.push_back({b.vertices[v].x + 2, b.vertices[v].y + 2, 0});
  for (std::vector<long long> f : b.faces) {
    for (auto& v : f) v = v == 0 ? 8 : v + offset;
    glued.faces.push_back(f);
  }
  expect_error([&] { validate_mesh(glued); }, "non_manifold_vertex", "vertex", 8);
}

TEST(ValidateTest, DiskPlusTorusIsNotConnected) {
  RawMesh mesh = grid(4, 3);
  const long long disk_faces = static_cast<long long>(mesh.faces.size());
  RawMesh ring = torus(5, 4, static_cast<long long>(mesh.vertices.size()));
  mesh.vertices.insert(mesh.vertices.end(), ring.vertices.begin(), ring.vertices.end());
  for (const auto& f : ring.faces) mesh.faces.push_back(f);
  InputError e = expect_error([&] { validate_mesh(mesh); }, "not_connected", "face", disk_faces);
  EXPECT_TRUE(contains(e.what(), "2 separate pieces")) << e.what();
}

TEST(ValidateTest, ClosedSurfaceHasNoBoundary) {
  RawMesh tetra{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}}};
  expect_error([&] { validate_mesh(tetra); }, "no_boundary");
  expect_error([&] { validate_mesh(torus(4, 3)); }, "no_boundary");
}

TEST(ValidateTest, AnnulusHasTwoBoundaryLoops) {
  // A 3 x 2 grid of quads with its left and right columns identified: a cylinder.
  RawMesh mesh;
  const int n = 6;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < n; ++i)
      mesh.vertices.push_back({std::cos(2 * M_PI * i / n), std::sin(2 * M_PI * i / n), double(j)});
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < n; ++i) {
      long long a = j * n + i, b = j * n + (i + 1) % n, c = b + n, d = a + n;
      mesh.faces.push_back({a, b, c});
      mesh.faces.push_back({a, c, d});
    }
  InputError e = expect_error([&] { validate_mesh(mesh); }, "multiple_boundary_loops");
  EXPECT_TRUE(contains(e.what(), "2 boundary loops")) << e.what();
}

TEST(ValidateTest, PuncturedTorusIsNotADisk) {
  RawMesh mesh = torus(5, 4);
  mesh.faces.erase(7);
  InputError e = expect_error([&] { validate_mesh(mesh); }, "not_a_disk");
  EXPECT_TRUE(contains(e.what(), "= -1")) << e.what();
}

// ---- boundary loop: start and orientation ------------------------------------------------------------

TEST(ValidateTest, BoundaryLoopFollowsFaceDirectionFromLowestVertex) {
  DiskMesh ccw = validate_mesh(square());
  EXPECT_EQ(ccw.boundary_loop, (std::vector<int>{0, 1, 2, 3}));  // counterclockwise faces: interior on the left

  RawMesh flipped = square();
  for (std::size_t f = 0; f < flipped.faces.size(); ++f) std::swap(flipped.faces[f][1], flipped.faces[f][2]);
  EXPECT_EQ(validate_mesh(flipped).boundary_loop, (std::vector<int>{0, 3, 2, 1}));

  // A hexagonal fan whose centre is vertex 0 and whose rim is numbered from 6 down; the loop starts at 1.
  RawMesh fan;
  fan.vertices.push_back({0, 0, 0});
  for (int k = 0; k < 6; ++k) fan.vertices.push_back({std::cos(M_PI * k / 3), std::sin(M_PI * k / 3), 0});
  // Rim vertex at angle k * 60 degrees has index 6 - k (clockwise numbering); faces counterclockwise.
  for (int k = 0; k < 6; ++k) {
    auto rim = [](int j) { return static_cast<long long>(6 - (j % 6)); };
    fan.faces.push_back({0, rim(k), rim(k + 1)});
  }
  std::vector<Point3> positions(7);
  positions[0] = {0, 0, 0};
  for (int k = 0; k < 6; ++k) positions[6 - k] = {std::cos(M_PI * k / 3), std::sin(M_PI * k / 3), 0};
  fan.vertices = positions;
  EXPECT_EQ(validate_mesh(fan).boundary_loop, (std::vector<int>{1, 6, 5, 4, 3, 2}));
}

TEST(ValidateTest, DiskMeshKeepsIndicesAndBuildsTheTopology) {
  RawMesh raw = grid(4, 3);
  DiskMesh disk = validate_mesh(raw);
  ASSERT_EQ(disk.topology.vertex_count(), static_cast<int>(raw.vertices.size()));
  ASSERT_EQ(disk.topology.face_count(), static_cast<int>(raw.faces.size()));
  for (size_t v = 0; v < raw.vertices.size(); ++v) EXPECT_TRUE(disk.vertices[v] == raw.vertices[v]);
  for (size_t f = 0; f < raw.faces.size(); ++f) {
    Triangle t{int(raw.faces[f][0]), int(raw.faces[f][1]), int(raw.faces[f][2])};
    EXPECT_EQ(disk.faces[f], t);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(disk.topology.from(3 * int(f) + k), t[k]);
      EXPECT_EQ(disk.topology.to(3 * int(f) + k), t[(k + 1) % 3]);
    }
  }
}

// Property: a grid disk with random size, random cell diagonals, random vertex numbering, random corner
// rotation and random face order always validates; its loop has the border's length, starts at its lowest
// vertex and has the interior on its left (every step is a face's half-edge, and the loop encloses the
// grid's area counterclockwise).
TEST(ValidateTestProperty, RandomGridDisksHaveTheirBorderAsLoopWithInteriorOnTheLeft) {
  std::mt19937 rng(20240611);
  auto uniform = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  for (int trial = 0; trial < 300; ++trial) {
    const int w = uniform(2, 14), h = uniform(2, 14), n = w * h;
    SCOPED_TRACE("trial " + std::to_string(trial) + ": " + std::to_string(w) + " x " + std::to_string(h));
    std::vector<long long> renumber(n);
    std::iota(renumber.begin(), renumber.end(), 0);
    std::shuffle(renumber.begin(), renumber.end(), rng);

    RawMesh raw;
    raw.vertices.resize(n);
    for (int j = 0; j < h; ++j)
      for (int i = 0; i < w; ++i) raw.vertices[renumber[j * w + i]] = {double(i), double(j), 0.0};
    std::vector<std::vector<long long>> faces;
    for (const auto& t : testgen::grid_triangles(w - 1, h - 1, [&](int, int) { return uniform(0, 1) != 0; }))
      faces.push_back({renumber[t[0]], renumber[t[1]], renumber[t[2]]});
    for (auto& f : faces) std::rotate(f.begin(), f.begin() + uniform(0, 2), f.end());
    std::shuffle(faces.begin(), faces.end(), rng);
    for (const auto& f : faces) raw.faces.push_back(f);

    DiskMesh disk = validate_mesh(raw);
    const std::vector<int>& loop = disk.boundary_loop;
    ASSERT_EQ(loop.size(), size_t(2 * (w - 1) + 2 * (h - 1)));
    EXPECT_EQ(loop.front(), *std::min_element(loop.begin(), loop.end()));
    std::set<int> border;
    for (int v = 0; v < n; ++v) {
      const Point3& p = raw.vertices[v];
      if (p.x == 0 || p.y == 0 || p.x == w - 1 || p.y == h - 1) border.insert(v);
    }
    EXPECT_EQ(std::set<int>(loop.begin(), loop.end()), border);

    std::set<std::pair<long long, long long>> halfedges;
    for (const auto& f : raw.faces)
      for (int k = 0; k < 3; ++k) halfedges.insert({f[k], f[(k + 1) % 3]});
    double twice_area = 0;
    for (size_t k = 0; k < loop.size(); ++k) {
      int a = loop[k], b = loop[(k + 1) % loop.size()];
      EXPECT_TRUE(halfedges.count({a, b})) << "loop step " << a << "->" << b << " has no face on its left";
      twice_area += raw.vertices[a].x * raw.vertices[b].y - raw.vertices[b].x * raw.vertices[a].y;
    }
    EXPECT_EQ(twice_area, 2.0 * (w - 1) * (h - 1));  // counterclockwise: interior on the left
    EXPECT_EQ(disk.topology.face_count(), static_cast<int>(raw.faces.size()));
  }
}

// ---- validate_boundary -------------------------------------------------------------------------------

class ValidateTestBoundary : public ::testing::Test {
protected:
  // 4 x 4 grid: boundary loop 0 1 2 3 7 11 15 14 13 12 8 4, interior vertices 5 6 9 10.
  DiskMesh disk = validate_mesh(grid(4, 4));
  const std::vector<int> loop{0, 1, 2, 3, 7, 11, 15, 14, 13, 12, 8, 4};
};

TEST_F(ValidateTestBoundary, LoopOfTheGrid) { EXPECT_EQ(disk.boundary_loop, loop); }

TEST_F(ValidateTestBoundary, PositionsFollowTheMeshLoopWhenNoVerticesAreGiven) {
  RawBoundary raw{std::nullopt, positions(12), std::vector<long long>(12, 0)};
  raw.rotation_indices->at(3) = 2;
  BoundaryMap map = validate_boundary(disk, raw);
  EXPECT_EQ(map.loop, loop);
  EXPECT_EQ(map.polygon.vertices, raw.positions);
  ASSERT_TRUE(map.polygon.rotation_indices);
  EXPECT_EQ(map.polygon.rotation_indices->at(3), 2);
}

TEST_F(ValidateTestBoundary, ListedVerticesMayStartAnywhereOnTheLoop) {
  std::vector<long long> listed;
  for (int k = 0; k < 12; ++k) listed.push_back(loop[(k + 5) % 12]);
  BoundaryMap map = validate_boundary(disk, RawBoundary{listed, positions(12), std::nullopt});
  EXPECT_EQ(map.loop, std::vector<int>(listed.begin(), listed.end()));
  EXPECT_EQ(map.polygon.vertices, positions(12));
  EXPECT_FALSE(map.polygon.rotation_indices);
}

TEST_F(ValidateTestBoundary, LengthMismatch) {
  expect_error([&] { validate_boundary(disk, RawBoundary{std::nullopt, positions(11), std::nullopt}); },
               "boundary_length_mismatch");
  expect_error(
      [&] { validate_boundary(disk, RawBoundary{std::nullopt, positions(12), std::vector<long long>(13, 0)}); },
      "boundary_length_mismatch");
  // A listed loop that misses a vertex: positions agree with the list, but the list is not the boundary.
  std::vector<long long> listed(loop.begin(), loop.end() - 1);
  InputError e = expect_error([&] { validate_boundary(disk, RawBoundary{listed, positions(11), std::nullopt}); },
                              "boundary_length_mismatch");
  EXPECT_TRUE(contains(e.what(), "vertex 4 is missing")) << e.what();
}

TEST_F(ValidateTestBoundary, NonFinitePosition) {
  std::vector<Point2> p = positions(12);
  p[7].y = kNaN;
  expect_error([&] { validate_boundary(disk, RawBoundary{std::nullopt, p, std::nullopt}); },
               "boundary_position_non_finite", "boundary", 7);
}

TEST_F(ValidateTestBoundary, VertexOutOfRange) {
  std::vector<long long> listed(loop.begin(), loop.end());
  listed[4] = 16;
  expect_error([&] { validate_boundary(disk, RawBoundary{listed, positions(12), std::nullopt}); },
               "boundary_vertex_out_of_range", "boundary", 4);
  listed[4] = -3;
  expect_error([&] { validate_boundary(disk, RawBoundary{listed, positions(12), std::nullopt}); },
               "boundary_vertex_out_of_range", "boundary", 4);
}

TEST_F(ValidateTestBoundary, InteriorVertexIsNotOnBoundary) {
  std::vector<long long> listed(loop.begin(), loop.end());
  listed[6] = 9;
  InputError e = expect_error([&] { validate_boundary(disk, RawBoundary{listed, positions(12), std::nullopt}); },
                              "boundary_vertex_not_on_boundary", "boundary", 6);
  EXPECT_TRUE(contains(e.what(), "vertex 9")) << e.what();
}

TEST_F(ValidateTestBoundary, RepeatedVertex) {
  std::vector<long long> listed(loop.begin(), loop.end());
  listed[9] = listed[2];
  expect_error([&] { validate_boundary(disk, RawBoundary{listed, positions(12), std::nullopt}); },
               "boundary_vertex_repeated", "boundary", 9);
}

TEST_F(ValidateTestBoundary, ReversedLoopMustHaveInteriorOnTheLeft) {
  std::vector<long long> listed(loop.rbegin(), loop.rend());
  InputError e = expect_error([&] { validate_boundary(disk, RawBoundary{listed, positions(12), std::nullopt}); },
                              "boundary_not_loop_order", "boundary", 1);
  EXPECT_TRUE(contains(e.what(), "reverse")) << e.what();
  EXPECT_TRUE(contains(e.what(), "interior must be on the left")) << e.what();
}

TEST_F(ValidateTestBoundary, ScrambledLoopIsNotInLoopOrder) {
  std::vector<long long> listed(loop.begin(), loop.end());
  std::swap(listed[5], listed[6]);
  InputError e = expect_error([&] { validate_boundary(disk, RawBoundary{listed, positions(12), std::nullopt}); },
                              "boundary_not_loop_order", "boundary", 5);
  EXPECT_FALSE(contains(e.what(), "reverse")) << e.what();
}

TEST_F(ValidateTestBoundary, RotationIndexOutOfRange) {
  std::vector<long long> r(12, 0);
  r[10] = kMaxRotationIndex + 1;
  expect_error([&] { validate_boundary(disk, RawBoundary{std::nullopt, positions(12), r}); },
               "rotation_index_out_of_range", "boundary", 10);
  r[10] = kMaxRotationIndex;
  r[2] = -1;
  expect_error([&] { validate_boundary(disk, RawBoundary{std::nullopt, positions(12), r}); },
               "rotation_index_out_of_range", "boundary", 2);
}

TEST_F(ValidateTestBoundary, PolygonIsCheckedToo) {
  std::vector<Point2> p = positions(12);
  p[4] = p[3];
  expect_error([&] { validate_boundary(disk, RawBoundary{std::nullopt, p, std::nullopt}); },
               "polygon_zero_length_edge", "polygon_vertex", 3);
}

// ---- validate_polygon --------------------------------------------------------------------------------

TEST(ValidateTestPolygon, AcceptsAValidPolygon) {
  validate_polygon(BoundaryPolygon{positions(5), std::vector<int>{0, 1, 0, kMaxRotationIndex, 0}});
}

TEST(ValidateTestPolygon, TooSmall) {
  expect_error([] { validate_polygon(BoundaryPolygon{positions(2), std::nullopt}); }, "polygon_too_small", "polygon");
}

TEST(ValidateTestPolygon, NonFinite) {
  std::vector<Point2> p = positions(5);
  p[3].x = -std::numeric_limits<double>::infinity();
  expect_error([&] { validate_polygon(BoundaryPolygon{p, std::nullopt}); }, "polygon_non_finite", "polygon_vertex", 3);
}

TEST(ValidateTestPolygon, ZeroLengthEdge) {
  std::vector<Point2> p = positions(5);
  p[2] = p[1];
  expect_error([&] { validate_polygon(BoundaryPolygon{p, std::nullopt}); }, "polygon_zero_length_edge",
               "polygon_vertex", 1);
}

TEST(ValidateTestPolygon, RepeatedClosingPoint) {
  std::vector<Point2> p = positions(5);
  p.push_back(p.front());
  InputError e = expect_error([&] { validate_polygon(BoundaryPolygon{p, std::nullopt}); },
                              "polygon_zero_length_edge", "polygon_vertex", 5);
  EXPECT_TRUE(contains(e.what(), "omit the repeated closing point")) << e.what();
}

TEST(ValidateTestPolygon, RotationIndicesLength) {
  expect_error([] { validate_polygon(BoundaryPolygon{positions(5), std::vector<int>(4, 0)}); },
               "rotation_indices_length", "rotation_indices");
}

TEST(ValidateTestPolygon, RotationIndexOutOfRange) {
  expect_error([] { validate_polygon(BoundaryPolygon{positions(5), std::vector<int>{0, 0, 0, 0, -1}}); },
               "rotation_index_out_of_range", "polygon_vertex", 4);
  expect_error(
      [] { validate_polygon(BoundaryPolygon{positions(5), std::vector<int>{0, kMaxRotationIndex + 1, 0, 0, 0}}); },
      "rotation_index_out_of_range", "polygon_vertex", 1);
}

// ---- the shared meshes ---------------------------------------------------------------------------------

class ValidateTestShared : public ::testing::TestWithParam<testmeshes::MeshEntry> {};

TEST_P(ValidateTestShared, ValidatesWithReadmeCounts) {
  const testmeshes::MeshEntry& expected = GetParam();
  RawMesh raw = read_mesh_file(expected.path());
  auto start = std::chrono::steady_clock::now();
  DiskMesh disk = validate_mesh(raw);
  double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  RecordProperty("validate_ms", std::to_string(ms));
  if (!expected.extra) {  // the README's counts
    EXPECT_EQ(static_cast<long long>(disk.vertices.size()), expected.vertices);
    EXPECT_EQ(static_cast<long long>(disk.faces.size()), expected.triangles);
    EXPECT_EQ(static_cast<long long>(disk.boundary_loop.size()), expected.boundary_vertices);
  }
  EXPECT_EQ(disk.topology.vertex_count(), static_cast<int>(disk.vertices.size()));
  EXPECT_EQ(disk.topology.face_count(), static_cast<int>(disk.faces.size()));

  // Independent of validate's own walk: every step of the loop is a directed edge of a face (the faces on
  // its left) whose reverse no face has.
  std::set<std::pair<int, int>> directed;
  for (const Triangle& t : disk.faces)
    for (int c = 0; c < 3; ++c) directed.insert({t[c], t[(c + 1) % 3]});
  const auto& loop = disk.boundary_loop;
  EXPECT_EQ(*std::min_element(loop.begin(), loop.end()), loop.front());
  for (size_t k = 0; k < loop.size(); ++k) {
    const int a = loop[k], b = loop[(k + 1) % loop.size()];
    ASSERT_TRUE(directed.count({a, b})) << "step " << k << " has no face on its left";
    ASSERT_FALSE(directed.count({b, a})) << "step " << k << " is not a boundary edge";
  }
  size_t boundary_vertices = 0;
  std::set<int> on_boundary;
  for (const auto& [a, b] : directed)
    if (!directed.count({b, a})) on_boundary.insert(a);
  boundary_vertices = on_boundary.size();
  EXPECT_EQ(boundary_vertices, disk.boundary_loop.size());
}

INSTANTIATE_TEST_SUITE_P(Readme, ValidateTestShared, ::testing::ValuesIn(testmeshes::disk_meshes()),
                         [](const ::testing::TestParamInfo<testmeshes::MeshEntry>& info) { return info.param.name(); });

// Runs validate on a mesh file and returns the error, or fails when it validates.
InputError validate_file_error(const std::string& name) {
  RawMesh raw = read_mesh_file(mesh_path(name));
  try {
    validate_mesh(raw);
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << name << " validated";
  return InputError("none", "");
}

// Every catalog mesh that is not a disk is refused with the code its README line gives.
TEST(ValidateTestInvalidMeshes, EveryNonDiskOfTheCatalogIsRefusedWithItsCode) {
  int refused = 0;
  for (const testmeshes::MeshEntry& e : testmeshes::catalog()) {
    if (e.disk) continue;
    EXPECT_EQ(validate_file_error(e.file).code(), e.error) << e.file;
    ++refused;
  }
  EXPECT_EQ(refused, 5);
}

TEST(ValidateTestInvalidMeshes, ZeroAreaTriangleNamesAFaceOnTheCoincidentVertices) {
  RawMesh raw = read_mesh_file(mesh_path("withZeroAreaTri_48.obj"));
  ASSERT_EQ(raw.vertices[15970], raw.vertices[16103]);
  InputError e = validate_file_error("withZeroAreaTri_48.obj");
  ASSERT_EQ(e.code(), "degenerate_face") << e.what();
  ASSERT_EQ(e.element(), "face");
  ASSERT_TRUE(e.index());
  ASSERT_LT(*e.index(), raw.faces.size());
  const std::vector<long long> named = raw.faces[*e.index()];
  EXPECT_EQ(std::count(named.begin(), named.end(), 15970), 1) << e.what();
  EXPECT_EQ(std::count(named.begin(), named.end(), 16103), 1) << e.what();
  EXPECT_TRUE(contains(e.what(), "same position")) << e.what();
}

// The README lists 20 edges with more than two faces. The earlier checks (degenerate or duplicate faces)
// do not fire on this file, so non_manifold_edge is the first error; the named edge is checked here by
// brute force: number the edges by first appearance, and count the faces on the named one.
TEST(ValidateTestInvalidMeshes, TripleVierbeinIsNonManifold) {
  RawMesh raw = read_mesh_file(mesh_path("invalid/triple_vierbein.obj"));
  InputError e = validate_file_error("invalid/triple_vierbein.obj");
  ASSERT_EQ(e.code(), "non_manifold_edge") << e.what();
  ASSERT_EQ(e.element(), "edge");
  ASSERT_TRUE(e.index());
  std::vector<std::pair<long long, long long>> edges;  // in order of first appearance
  for (const auto& f : raw.faces)
    for (int k = 0; k < 3; ++k) {
      auto edge = std::minmax(f[k], f[(k + 1) % 3]);
      std::pair<long long, long long> key(edge.first, edge.second);
      if (std::find(edges.begin(), edges.end(), key) == edges.end()) edges.push_back(key);
    }
  auto faces_on = [&](const std::pair<long long, long long>& edge) {
    return std::count_if(raw.faces.begin(), raw.faces.end(), [&](const std::vector<long long>& f) {
      return std::count(f.begin(), f.end(), edge.first) && std::count(f.begin(), f.end(), edge.second);
    });
  };
  ASSERT_LT(*e.index(), static_cast<long long>(edges.size()));
  EXPECT_GT(faces_on(edges[*e.index()]), 2) << e.what();
  for (long long i = 0; i < *e.index(); ++i) EXPECT_LE(faces_on(edges[i]), 2) << "edge " << i;
  const std::string name = "edge " + std::to_string(edges[*e.index()].first) + "-" +
                           std::to_string(edges[*e.index()].second);
  EXPECT_TRUE(contains(e.what(), name)) << e.what();
}

TEST(ValidateTestInvalidMeshes, HolesHasSevenBoundaryLoops) {
  InputError e = validate_file_error("invalid/holes.off");
  EXPECT_EQ(e.code(), "multiple_boundary_loops") << e.what();
  EXPECT_TRUE(contains(e.what(), "7 boundary loops")) << e.what();
}

TEST(ValidateTestInvalidMeshes, BlobClosedHasNoBoundary) {
  EXPECT_EQ(validate_file_error("invalid/blob-closed.off").code(), "no_boundary");
}

TEST(ValidateTestInvalidMeshes, PuncturedTorusIsNotADisk) {
  InputError e = validate_file_error("invalid/punctured-torus.obj");
  EXPECT_EQ(e.code(), "not_a_disk") << e.what();
  EXPECT_TRUE(contains(e.what(), "= -1")) << e.what();
}

}  // namespace
}  // namespace lipmap
