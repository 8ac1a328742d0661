// Refinement restricted to the folds (engine/fold_region.h): the regions cut around a map's folds, and their
// maps spliced back. Checked with the test support's own boundary walk, exact orientation and the independent
// contract checker (tests/support/map_checker.h), never with the engine's verify.
//
//   FoldRegionCut       grids with interior vertices pushed across a neighbour: every folded face is in exactly
//                       one region, each region is a disk whose boundary list is its boundary loop, at the images
//                       of those vertices, and (the map being the identity outside) with rotation index 0.
//   FoldRegionSplice    the same regions each mapped by the pipeline and spliced: the whole answer passes the
//                       contract, and every vertex outside the regions keeps its uv bit for bit.
//   FoldRegionPipeline  a shared mesh onto a weakly self-overlapping target whose untangling fails: the answer is
//                       refined in regions only and passes the contract.
#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/fold_region.h"
#include "engine/pipeline.h"
#include "engine/validate.h"
#include "tests/support/grid_cells.h"
#include "tests/support/pipeline_cases.h"

namespace lipmap {
namespace {

using pipelinecases::boundary_loop_of;
using pipelinecases::count_folded_by_checker;

struct FoldedGrid {
  DiskMesh mesh;
  std::vector<Point2> polygon;  // the grid's own border: loop k at polygon[k]
  std::vector<Point2> uv;       // the identity, with some interior vertices pushed across a neighbour
  std::vector<int> pushed;
};

// An n x n grid of the unit square; `pushes` interior vertices (at least 4 cells from the border and from each
// other) moved 1.6 cells towards a neighbour, across it.
FoldedGrid folded_grid(int n, int pushes, unsigned seed) {
  RawMesh raw;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      raw.vertices.push_back({double(i) / n, double(j) / n, 0.1 * std::sin(4.0 * i / n) * std::cos(3.0 * j / n)});
  for (const auto& t : testgen::grid_triangles(n, n, testgen::alternating_diagonal)) raw.faces.push_back({t[0], t[1], t[2]});
  FoldedGrid g{validate_mesh(raw), {}, {}, {}};
  for (const Point3& p : g.mesh.vertices) g.uv.push_back({p.x, p.y});
  for (int v : g.mesh.boundary_loop) g.polygon.push_back(g.uv[v]);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> cell(4, n - 4), dir(-1, 1);
  std::vector<std::pair<int, int>> at;
  while (static_cast<int>(at.size()) < pushes) {
    const int i = cell(rng), j = cell(rng);
    if (std::any_of(at.begin(), at.end(), [&](auto p) { return std::abs(p.first - i) + std::abs(p.second - j) < 8; })) continue;
    int di = dir(rng), dj = dir(rng);
    if (di == 0 && dj == 0) di = 1;
    at.push_back({i, j});
    const int v = j * (n + 1) + i;
    g.uv[v] = {g.uv[v].x + 1.6 * di / n, g.uv[v].y + 1.6 * dj / n};
    g.pushed.push_back(v);
  }
  return g;
}

bool same_cycle(const std::vector<long long>& a, const std::vector<int>& b) {
  if (a.size() != b.size() || a.empty()) return false;
  const auto start = std::find(b.begin(), b.end(), static_cast<int>(a[0]));
  if (start == b.end()) return false;
  const std::size_t s = static_cast<std::size_t>(start - b.begin());
  for (std::size_t k = 0; k < a.size(); ++k)
    if (a[k] != b[(s + k) % b.size()]) return false;
  return true;
}

TEST(FoldRegionCut, RegionsAreDisksAroundEveryFold) {
  int cases = 0;
  for (unsigned seed = 1; seed <= 8; ++seed) {
    const FoldedGrid g = folded_grid(28, 1 + seed % 3, seed);
    const std::string where = "seed " + std::to_string(seed);
    ASSERT_GT(count_folded_by_checker(g.uv, g.mesh.faces), 0) << where;
    const std::vector<int> rotation(g.polygon.size(), 0);
    const FoldRegions r = fold_regions(g.mesh, g.mesh.boundary_loop, g.polygon, rotation, g.uv, 2);
    ASSERT_TRUE(r.failure.empty()) << where << ": " << r.failure;
    ASSERT_FALSE(r.regions.empty()) << where;
    std::vector<int> owner(g.mesh.faces.size(), -1), vertex_owner(g.mesh.vertices.size(), -1);
    for (std::size_t i = 0; i < r.regions.size(); ++i) {
      const FoldRegion& region = r.regions[i];
      for (int f : region.faces) {
        EXPECT_EQ(owner[f], -1) << where << ": face " << f << " in two regions";
        owner[f] = static_cast<int>(i);
      }
      for (int v : region.vertices) {
        EXPECT_EQ(vertex_owner[v], -1) << where << ": vertex " << v << " in two regions";
        vertex_owner[v] = static_cast<int>(i);
      }
      // A disk: one simple boundary cycle (walked here from the faces) and V - E + F = 1.
      std::vector<Triangle> faces;
      std::set<std::pair<int, int>> edges;
      for (const auto& f : region.mesh.faces) {
        faces.push_back({int(f[0]), int(f[1]), int(f[2])});
        for (int k = 0; k < 3; ++k) edges.insert(std::minmax(int(f[k]), int(f[(k + 1) % 3])));
      }
      const std::vector<int> loop = boundary_loop_of(faces, region.vertices.size());
      ASSERT_FALSE(loop.empty()) << where << ": region " << i << " has no single boundary cycle";
      EXPECT_EQ(static_cast<long>(region.vertices.size()) - static_cast<long>(edges.size()) + static_cast<long>(faces.size()), 1)
          << where << ": region " << i;
      ASSERT_TRUE(region.boundary.vertices && same_cycle(*region.boundary.vertices, loop)) << where << ": region " << i;
      for (std::size_t k = 0; k < loop.size(); ++k) {
        const int v = region.vertices[static_cast<std::size_t>((*region.boundary.vertices)[k])];
        EXPECT_TRUE(region.boundary.positions[k] == g.uv[v]) << where << ": region " << i << " position " << k;
        EXPECT_EQ((*region.boundary.rotation_indices)[k], 0) << where << ": region " << i << " position " << k;
      }
      for (std::size_t k = 0; k < faces.size(); ++k)
        for (int c = 0; c < 3; ++c)
          EXPECT_EQ(region.vertices[static_cast<std::size_t>(faces[k][c])], g.mesh.faces[region.faces[k]][c]) << where;
    }
    for (std::size_t f = 0; f < g.mesh.faces.size(); ++f) {
      const Triangle& t = g.mesh.faces[f];
      if (count_folded_by_checker(g.uv, {t}) > 0) EXPECT_GE(owner[f], 0) << where << ": folded face " << f << " outside";
    }
    for (int v : g.pushed) EXPECT_GE(vertex_owner[v], 0) << where << ": pushed vertex " << v;
    ++cases;
  }
  EXPECT_EQ(cases, 8);
}

TEST(FoldRegionSplice, SplicedMapPassesTheContract) {
  for (unsigned seed = 1; seed <= 6; ++seed) {
    const FoldedGrid g = folded_grid(24, 1 + seed % 3, 100 + seed);
    const std::string where = "seed " + std::to_string(seed);
    const std::vector<int> rotation(g.polygon.size(), 0);
    const FoldRegions r = fold_regions(g.mesh, g.mesh.boundary_loop, g.polygon, rotation, g.uv, 2);
    ASSERT_TRUE(r.failure.empty()) << where << ": " << r.failure;
    std::vector<RefinedMap> maps;
    ParametrizeOptions options;
    options.max_iterations = 0;
    for (const FoldRegion& region : r.regions) maps.push_back(parametrize(region.mesh, region.boundary, options).map);
    const RefinedMap m = splice_regions(g.mesh, g.uv, r, maps);
    mapcheck::Result res{m.vertices, m.faces, m.uv, {}};
    for (const InsertedVertex& v : m.inserted) res.inserted.push_back({v.a, v.b, v.t});
    const mapcheck::Report report = mapcheck::check_map({g.mesh.vertices, g.mesh.faces, g.mesh.boundary_loop}, g.polygon, res);
    EXPECT_TRUE(report.ok()) << where << ": " << (report.errors.empty() ? "" : report.errors[0]);
    std::vector<char> inside(g.mesh.vertices.size(), 0);
    for (const FoldRegion& region : r.regions)
      for (int v : region.vertices) inside[v] = 1;
    int kept = 0;
    for (std::size_t v = 0; v < g.uv.size(); ++v)
      if (!inside[v]) {
        EXPECT_TRUE(m.uv[v] == g.uv[v]) << where << ": vertex " << v << " outside the regions moved";
        ++kept;
      }
    EXPECT_GT(kept, static_cast<int>(g.uv.size()) / 2) << where;
  }
}

TEST(FoldRegionPipeline, UntanglingThatFailsIsRefinedInRegionsOnly) {
  const testmeshes::MeshEntry* entry = nullptr;
  for (const testmeshes::MeshEntry& e : testmeshes::disk_meshes())
    if (e.name() == "camel_head") entry = &e;
  ASSERT_NE(entry, nullptr);
  const pipelinecases::LoadedMesh& m = pipelinecases::load(*entry);
  const auto t = targetgen::make_target(targetgen::Kind::weak_fan, pipelinecases::ref(m));
  ASSERT_TRUE(t.has_value());
  // The positions only (as bench_quality gives them): classify then chooses the rotation indices.
  RawBoundary boundary;
  boundary.positions = t->positions;
  const ParametrizeResult r = parametrize(m.raw, boundary, ParametrizeOptions{});
  EXPECT_FALSE(r.untangling.succeeded) << r.untangling.outcome;
  EXPECT_GT(r.map.regions, 0) << r.map.inserted.size() << " inserted; " << r.untangling.outcome;
  EXPECT_LT(r.map.region_faces * 2, static_cast<int>(m.faces.size()));
  mapcheck::Result res{r.map.vertices, r.map.faces, r.map.uv, {}};
  for (const InsertedVertex& v : r.map.inserted) res.inserted.push_back({v.a, v.b, v.t});
  const mapcheck::Report report =
      mapcheck::check_map({m.vertices, m.faces, m.loop}, t->positions, res, &r.classification.rotation_indices);
  EXPECT_TRUE(report.ok()) << (report.errors.empty() ? "" : report.errors[0]);
}

}  // namespace
}  // namespace lipmap
