// The relocation step between compose and refine (engine/relocate.h), run stage by stage on the small test
// meshes with every generated target kind. Properties, each with its reason:
//   - the moved disk points still give an embedding h_s' (every source face strictly positive in the disk,
//     exact): refine's guarantee needs a bijective source map;
//   - each vertex's uv is h_t^-1 of its (new) disk point: composing again from the new disk points gives
//     the same uv, so f stays h_t^-1 o h_s';
//   - boundary vertices never move; the reported flip counts are the true ones, and never grow.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/test_meshes.h"

#include "engine/classify.h"
#include "engine/compose.h"
#include "engine/intermediate_map.h"
#include "engine/mesh_io.h"
#include "engine/relocate.h"
#include "engine/target_mesh.h"
#include "engine/validate.h"
#include "tests/support/target_generators.h"

namespace lipmap {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

int orientation(const Point2& a, const Point2& b, const Point2& c) {
  return static_cast<int>(CGAL::orientation(K::Point_2(a.x, a.y), K::Point_2(b.x, b.y), K::Point_2(c.x, c.y)));
}

int non_positive(const std::vector<Point2>& p, const std::vector<Triangle>& faces) {
  int n = 0;
  for (const Triangle& t : faces) n += orientation(p[t[0]], p[t[1]], p[t[2]]) > 0 ? 0 : 1;
  return n;
}

struct Case {
  testmeshes::MeshEntry mesh;
  targetgen::Kind kind;
};

// The small disk meshes (at most 10k triangles) with enough boundary vertices for every kind, except the
// narrow corridors (their refinement, not relocation, is what takes the time).
std::vector<Case> cases() {
  std::vector<Case> out;
  for (const auto& m : testmeshes::disk_meshes_where([](const testmeshes::MeshEntry& e) {
         return e.triangles >= 0 && e.triangles <= 10000 && e.boundary_vertices > 4 && !e.long_boundary;
       }))
    for (targetgen::Kind k : targetgen::all_kinds()) out.push_back({m, k});
  return out;
}

class Relocate : public testing::TestWithParam<Case> {};

TEST_P(Relocate, KeepsTheSourceMapBijectiveAndTheCompositionExact) {
  const Case& c = GetParam();
  const DiskMesh mesh = validate_mesh(read_mesh_file(c.mesh.path()));
  std::string why;
  const auto target_polygon =
      targetgen::make_target(c.kind, {mesh.vertices, mesh.faces, mesh.boundary_loop}, &why);
  if (!target_polygon) GTEST_SKIP() << why;
  RawBoundary raw;
  raw.positions = target_polygon->positions;
  if (target_polygon->rotation_indices)
    raw.rotation_indices.emplace(target_polygon->rotation_indices->begin(), target_polygon->rotation_indices->end());
  const BoundaryMap boundary = validate_boundary(mesh, raw);
  const Classification cls = classify(boundary.polygon);
  ASSERT_NE(cls.verdict, Verdict::not_self_overlapping);
  TargetMeshOptions options;
  options.source_triangles = static_cast<int>(mesh.faces.size());
  const TargetMesh target = build_target_mesh(boundary.polygon, cls.triangulation, options);

  const DiskMap source_map = map_to_disk({&mesh.vertices, &mesh.faces, &boundary.loop}, MapMethod::harmonic);
  ASSERT_TRUE(source_map.bijective());
  std::vector<Point3> planar;
  for (const Point2& p : target.vertices) planar.push_back({p.x, p.y, 0});
  std::vector<int> target_loop(boundary.polygon.vertices.size());
  for (std::size_t k = 0; k < target_loop.size(); ++k) target_loop[k] = static_cast<int>(k);
  const DiskMap target_map = map_to_disk({&planar, &target.faces, &target_loop}, MapMethod::harmonic);
  ASSERT_TRUE(target_map.bijective());

  std::vector<Point2> disk = source_map.uv;
  Composition composition = compose(mesh, boundary.loop, disk, target, target_map.uv);
  const int composed_flips = non_positive(composition.uv, mesh.faces);
  const Relocation r = relocate_tangled_vertices(mesh, boundary.loop, disk, composition, target);

  EXPECT_EQ(r.flipped_before, composed_flips);
  EXPECT_EQ(r.flipped_after, non_positive(composition.uv, mesh.faces));
  EXPECT_LE(r.flipped_after, r.flipped_before);
  if (r.flipped_before == 0) EXPECT_EQ(r.moved, 0);
  EXPECT_EQ(non_positive(disk, mesh.faces), 0) << "h_s' is no longer an embedding";

  int moved = 0;
  for (int v : boundary.loop) EXPECT_TRUE(disk[v].x == source_map.uv[v].x && disk[v].y == source_map.uv[v].y);
  for (std::size_t v = 0; v < disk.size(); ++v)
    moved += (disk[v].x != source_map.uv[v].x || disk[v].y != source_map.uv[v].y) ? 1 : 0;
  EXPECT_EQ(moved, r.moved);
  const Composition again = compose(mesh, boundary.loop, disk, target, target_map.uv);
  double extent = 0;
  for (const Point2& p : target.vertices) extent = std::max({extent, std::abs(p.x), std::abs(p.y)});
  for (std::size_t v = 0; v < disk.size(); ++v) {
    // Same disk point, possibly located in a neighbouring face when it lies on an edge: equal up to the
    // rounding of two barycentric evaluations.
    ASSERT_NEAR(again.uv[v].x, composition.uv[v].x, 1e-9 * extent) << "vertex " << v;
    ASSERT_NEAR(again.uv[v].y, composition.uv[v].y, 1e-9 * extent) << "vertex " << v;
  }
}

std::string case_name(const testing::TestParamInfo<Case>& info) {
  return info.param.mesh.name() + "_" + targetgen::kind_name(info.param.kind);
}

INSTANTIATE_TEST_SUITE_P(Relocate, Relocate, testing::ValuesIn(cases()), case_name);

}  // namespace
}  // namespace lipmap
