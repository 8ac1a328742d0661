// flip_refined_diagonals (engine/refined_flips.h): edge flips inside the refined faces that lower K. On the
// harmonic method's refined answers for the shared meshes onto generated targets, the flipped map passes the
// contract (independent checker), keeps every vertex, uv and inserted point and the face count, and its K,
// computed here by the tests' own formula, sorted from the worst face down, is lower at the first face where
// it differs (each flip lowers the larger K of its two faces); a second pass finds nothing left to flip.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "engine/refined_flips.h"
#include "engine/validate.h"
#include "tests/support/pipeline_cases.h"

namespace lipmap {
namespace {

using pipelinecases::LoadedMesh;
using targetgen::Kind;

std::vector<double> sorted_k(const RefinedMap& m) {
  std::vector<double> k;
  for (const Triangle& t : m.faces)
    k.push_back(pipelinecases::conformal_distortion_of(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]], m.uv[t[0]],
                                                       m.uv[t[1]], m.uv[t[2]]));
  std::sort(k.begin(), k.end(), std::greater<>());
  return k;
}

TEST(RefinedFlips, LowerTheSortedKOfRefinedAnswersAndKeepTheContract) {
  int refined = 0, flipped = 0, lower_max = 0;
  long long flips = 0;
  for (const testmeshes::MeshEntry& entry : testmeshes::disk_meshes()) {
    if (entry.extra || entry.long_boundary || entry.triangles > 20000) continue;
    const LoadedMesh& m = pipelinecases::load(entry);
    const DiskMesh source = validate_mesh(m.raw);
    for (Kind kind : {Kind::c_shape, Kind::exp_strip, Kind::bent_strip, Kind::weak_fan}) {
      const auto t = targetgen::make_target(kind, pipelinecases::ref(m));
      if (!t) continue;
      const std::string name = m.name + " / " + targetgen::kind_name(kind);
      ParametrizeOptions o;
      o.optimize = OptimizeEnergy::none;  // the refinement's triangulations as refine() made them
      const ParametrizeResult r = parametrize(m.raw, pipelinecases::boundary_of(*t), o);
      if (r.map.inserted.empty()) continue;
      ++refined;
      ParametrizeResult after = r;
      const int n = flip_refined_diagonals(source, after.map, after.map.vertices);
      EXPECT_GE(n, 0) << name;
      flips += n;
      flipped += n > 0;
      EXPECT_EQ(after.map.vertices, r.map.vertices) << name;
      EXPECT_EQ(after.map.uv, r.map.uv) << name;
      EXPECT_EQ(after.map.inserted.size(), r.map.inserted.size()) << name;
      EXPECT_EQ(after.map.faces.size(), r.map.faces.size()) << name;
      const mapcheck::Report rep = pipelinecases::check(m, *t, after);
      EXPECT_TRUE(rep.ok()) << name << "\n" << rep.str();
      const std::vector<double> k0 = sorted_k(r.map), k1 = sorted_k(after.map);
      ASSERT_EQ(k0.size(), k1.size());
      EXPECT_LE(k1.front(), k0.front() * (1 + 1e-9)) << name;
      lower_max += k1.front() < k0.front() * (1 - 1e-9);
      // Lexicographically lower: the first face (worst first) whose K differs beyond rounding is lower.
      for (std::size_t i = 0; i < k0.size(); ++i) {
        if (std::fabs(k1[i] - k0[i]) <= 1e-9 * k0[i]) continue;
        EXPECT_LT(k1[i], k0[i]) << name << ": face " << i << " of the sorted K";
        break;
      }
      if (n == 0) EXPECT_EQ(after.map.faces, r.map.faces) << name;
      RefinedMap again = after.map;
      EXPECT_EQ(flip_refined_diagonals(source, again, again.vertices), 0) << name;
    }
  }
  std::printf("[ refined flips ] %d refined answers, flips in %d (%lld flips), max K lower in %d\n", refined, flipped,
              flips, lower_max);
  EXPECT_GE(refined, 5);
  EXPECT_GT(flipped, 0);
}

// An unrefined map has nothing to flip.
TEST(RefinedFlips, LeaveAMapWithoutInsertedPointsAsItIs) {
  const RawMesh raw = pipelinecases::bumpy_grid(6);
  const DiskMesh source = validate_mesh(raw);
  RefinedMap map;
  map.vertices = source.vertices;
  map.faces = source.faces;
  for (const Point3& p : source.vertices) map.uv.push_back({p.x, p.y});
  const std::vector<Triangle> faces = map.faces;
  EXPECT_EQ(flip_refined_diagonals(source, map, map.vertices), 0);
  EXPECT_EQ(map.faces, faces);
}

}  // namespace
}  // namespace lipmap
