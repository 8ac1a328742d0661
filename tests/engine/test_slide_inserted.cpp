// Stage "slide" (engine/slide_inserted.h): inserted points slid along their original edges, uv unchanged.
// Checked with the independent checker (tests/support/map_checker.h) and the tests' own K
// (tests/support/pipeline_cases.h), never with the engine's verify, quality or face_k.
//
//   SlideInserted.SimilarityOfAFlatGrid        a flat grid mapped by a similarity, interior edges split with the
//                                              uv point at s and the 3D point at an unrelated t: every face is
//                                              similar to its image (K = 1) exactly when t = s, so the slide
//                                              must bring every point there.
//   SlideInserted.PipelineAnswers              refined answers of the pipeline (optimize none, so not slid yet):
//                                              sliding keeps the contract, uv, faces, edges and order, and raises
//                                              neither the mean K nor the max K; the default pipeline slides.
#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "engine/pipeline.h"
#include "engine/slide_inserted.h"
#include "engine/validate.h"
#include "tests/support/map_checker.h"
#include "tests/support/pipeline_cases.h"

namespace lipmap {
namespace {

using pipelinecases::conformal_distortion_of;
using targetgen::Kind;

double max_k(const RefinedMap& m) {
  double k = 1;
  for (const Triangle& t : m.faces)
    k = std::max(k, conformal_distortion_of(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]], m.uv[t[0]], m.uv[t[1]],
                                            m.uv[t[2]]));
  return k;
}

double mean_k(const RefinedMap& m) { return pipelinecases::mean_conformal_distortion(m.vertices, m.faces, m.uv); }

mapcheck::Report check(const DiskMesh& source, const std::vector<Point2>& polygon, const RefinedMap& m,
                       const std::vector<int>* rotation = nullptr) {
  mapcheck::Result r{m.vertices, m.faces, m.uv, {}};
  for (const InsertedVertex& v : m.inserted) r.inserted.push_back({v.a, v.b, v.t});
  return mapcheck::check_map({source.vertices, source.faces, source.boundary_loop}, polygon, r, rotation);
}

// The grid's faces with the chosen edges split (one point per edge at most), triangulated here: corners in the
// source triangle's counterclockwise order, no triangle with three corners on one edge.
std::vector<Triangle> split_grid_faces(const std::vector<Triangle>& faces, const std::map<std::pair<int, int>, int>& point) {
  std::vector<Triangle> out;
  for (const Triangle& t : faces) {
    int m[3];  // m[k]: the point on edge (t[k], t[k+1]), or -1
    int count = 0;
    for (int k = 0; k < 3; ++k) {
      const auto it = point.find({std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])});
      m[k] = it == point.end() ? -1 : it->second;
      count += m[k] >= 0;
    }
    if (count == 0) {
      out.push_back(t);
    } else if (count == 1) {  // split edge k: two triangles at the opposite corner
      const int k = m[0] >= 0 ? 0 : m[1] >= 0 ? 1 : 2;
      out.push_back({t[k], m[k], t[(k + 2) % 3]});
      out.push_back({m[k], t[(k + 1) % 3], t[(k + 2) % 3]});
    } else if (count == 2) {  // edge u whole: the corner w between the split edges cut off, the quad in two
      const int u = m[0] < 0 ? 0 : m[1] < 0 ? 1 : 2;
      const int c0 = t[u], c1 = t[(u + 1) % 3], w = t[(u + 2) % 3], m1 = m[(u + 1) % 3], m2 = m[(u + 2) % 3];
      out.push_back({m1, w, m2});
      out.push_back({c0, c1, m1});
      out.push_back({c0, m1, m2});
    } else {  // every edge: three corners cut off and the middle triangle
      out.push_back({t[0], m[0], m[2]});
      out.push_back({m[0], t[1], m[1]});
      out.push_back({m[2], m[1], t[2]});
      out.push_back({m[0], m[1], m[2]});
    }
  }
  return out;
}

TEST(SlideInserted, SimilarityOfAFlatGridBringsEveryPointToWhereItsFacesAreSimilar) {
  int cases = 0, points = 0;
  double worst_gap = 0, worst_k = 1;
  for (int n : {4, 7, 10})
    for (unsigned seed = 1; seed <= 4; ++seed) {
      std::mt19937 rng(seed * 31 + n);
      RawMesh raw = pipelinecases::bumpy_grid(n);
      for (Point3& p : raw.vertices) p.z = 0;
      const DiskMesh mesh = validate_mesh(raw);
      const std::size_t nv = mesh.vertices.size();
      // uv: a similarity of the plane (rotation, scale, shift) of (x, y).
      std::uniform_real_distribution<double> angle(0, 6.283185307179586), unit(0, 1);
      const double th = angle(rng), sc = 0.5 + 2 * unit(rng), c = sc * std::cos(th), s = sc * std::sin(th);
      RefinedMap m;
      m.vertices = mesh.vertices;
      for (const Point3& p : mesh.vertices) m.uv.push_back({c * p.x - s * p.y + 0.3, s * p.x + c * p.y - 0.1});
      // Split about a third of the interior edges: uv point at s_e, 3D point at an unrelated t_e.
      std::map<std::pair<int, int>, int> point;
      std::vector<double> where;  // s_e per inserted point
      std::vector<char> on_loop(nv, 0);
      for (int v : mesh.boundary_loop) on_loop[v] = 1;
      for (const Triangle& t : mesh.faces)
        for (int k = 0; k < 3; ++k) {
          const int a = std::min(t[k], t[(k + 1) % 3]), b = std::max(t[k], t[(k + 1) % 3]);
          if (point.count({a, b}) || (on_loop[a] && on_loop[b] && mesh.topology.is_boundary_edge(mesh.topology.find_edge(a, b))))
            continue;
          if (unit(rng) > 0.33) {
            point[{a, b}] = -1;  // looked at, not split
            continue;
          }
          const double se = 0.2 + 0.6 * unit(rng), te = 0.05 + 0.9 * unit(rng);
          point[{a, b}] = static_cast<int>(nv + m.inserted.size());
          m.inserted.push_back({a, b, te});
          where.push_back(se);
          const Point3 &pa = mesh.vertices[a], &pb = mesh.vertices[b];
          m.vertices.push_back({pa.x + te * (pb.x - pa.x), pa.y + te * (pb.y - pa.y), 0});
          m.uv.push_back({m.uv[a].x + se * (m.uv[b].x - m.uv[a].x), m.uv[a].y + se * (m.uv[b].y - m.uv[a].y)});
        }
      for (auto it = point.begin(); it != point.end();) it = it->second < 0 ? point.erase(it) : std::next(it);
      m.faces = split_grid_faces(mesh.faces, point);
      std::vector<Point2> polygon;
      for (int v : mesh.boundary_loop) polygon.push_back(m.uv[v]);
      // The map is valid (its points are removable: the grid needs none, so "minimal" is not asked for).
      auto errors_but_minimal = [&](const RefinedMap& r) {
        std::vector<std::string> e;
        for (const std::string& line : check(mesh, polygon, r).errors)
          if (line.rfind("minimal:", 0) != 0) e.push_back(line);
        return e;
      };
      ASSERT_TRUE(errors_but_minimal(m).empty()) << errors_but_minimal(m).front();
      const double before = max_k(m);
      RefinedMap slid = m;
      const Sliding report = slide_inserted_points(mesh, slid, SlideObjective::mean_k);
      EXPECT_TRUE(errors_but_minimal(slid).empty()) << n << " seed " << seed;
      EXPECT_EQ(slid.uv, m.uv);
      EXPECT_EQ(slid.faces, m.faces);
      EXPECT_TRUE(report.ran);
      for (std::size_t i = 0; i < slid.inserted.size(); ++i) {
        worst_gap = std::max(worst_gap, std::abs(slid.inserted[i].t - where[i]));
        EXPECT_NEAR(slid.inserted[i].t, where[i], 1e-3) << n << " seed " << seed << " point " << i << " started at " << m.inserted[i].t;
      }
      const double after = max_k(slid);
      worst_k = std::max(worst_k, after);
      EXPECT_LT(after, 1.01) << n << " seed " << seed << " (before " << before << ")";
      EXPECT_LE(after, before);
      ++cases;
      points += static_cast<int>(slid.inserted.size());
    }
  EXPECT_EQ(cases, 12);
  EXPECT_GT(points, 100);
  std::printf("[ slide    ] %d grids, %d points: largest |t - s| %.2e, largest K after %.6f\n", cases, points, worst_gap,
              worst_k);
}

TEST(SlideInserted, PipelineAnswersKeepTheContractAndNeverGetMoreDistorted) {
  struct Case { const char* mesh; Kind kind; };
  const Case cases[] = {{"nefertiti", Kind::weak_fan},   {"swirl_blob", Kind::weak_fan}, {"three_peaks", Kind::weak_fan},
                        {"three_peaks", Kind::c_shape}, {"cut_bowl", Kind::weak_fan}};
  int ran = 0, lowered = 0;
  for (const Case& c : cases) {
    const testmeshes::MeshEntry* entry = nullptr;
    for (const testmeshes::MeshEntry& e : testmeshes::disk_meshes())
      if (e.name() == c.mesh) entry = &e;
    ASSERT_NE(entry, nullptr) << c.mesh;
    const pipelinecases::LoadedMesh& lm = pipelinecases::load(*entry);
    std::string why;
    const auto target = targetgen::make_target(c.kind, pipelinecases::ref(lm), &why);
    ASSERT_TRUE(target) << why;
    const DiskMesh source = validate_mesh(lm.raw);
    ParametrizeOptions plain;
    plain.optimize = OptimizeEnergy::none;
    const ParametrizeResult r = parametrize(lm.raw, pipelinecases::boundary_of(*target), plain);
    std::printf("[ slide    ] %s %s: %zu points inserted (optimize none)\n", c.mesh, targetgen::kind_name(c.kind),
                r.map.inserted.size());
    if (r.map.inserted.empty()) continue;
    EXPECT_FALSE(r.sliding.ran) << "optimize none: the map is the method's own";
    const std::vector<int>* rotation = target->rotation_indices ? &*target->rotation_indices : nullptr;
    for (SlideObjective objective : {SlideObjective::mean_k, SlideObjective::max_k}) {
      RefinedMap slid = r.map;
      slide_inserted_points(source, slid, objective);
      const std::string what = std::string(c.mesh) + " " + targetgen::kind_name(c.kind) +
                               (objective == SlideObjective::mean_k ? " mean" : " max");
      const mapcheck::Report rep = check(source, target->positions, slid, rotation);
      EXPECT_TRUE(rep.ok()) << what << "\n" << rep.str();
      EXPECT_EQ(slid.uv, r.map.uv) << what;
      EXPECT_EQ(slid.faces, r.map.faces) << what;
      ASSERT_EQ(slid.inserted.size(), r.map.inserted.size()) << what;
      std::map<std::pair<int, int>, std::vector<std::pair<double, double>>> order;  // per edge: (t before, t after)
      for (std::size_t i = 0; i < slid.inserted.size(); ++i) {
        EXPECT_EQ(slid.inserted[i].a, r.map.inserted[i].a);
        EXPECT_EQ(slid.inserted[i].b, r.map.inserted[i].b);
        order[{slid.inserted[i].a, slid.inserted[i].b}].push_back({r.map.inserted[i].t, slid.inserted[i].t});
      }
      for (auto& [edge, ts] : order) {
        std::sort(ts.begin(), ts.end());
        for (std::size_t k = 1; k < ts.size(); ++k) EXPECT_LT(ts[k - 1].second, ts[k].second) << what << ": order on an edge";
      }
      const double mean_before = mean_k(r.map), mean_after = mean_k(slid);
      const double max_before = max_k(r.map), max_after = max_k(slid);
      EXPECT_LE(max_after, max_before * (1 + 1e-9)) << what;
      if (objective == SlideObjective::mean_k) {
        EXPECT_LE(mean_after, mean_before * (1 + 1e-9)) << what;
        lowered += mean_after < mean_before * (1 - 1e-6);
      }
      std::printf("[ slide    ] %s: %zu points, mean K %.4f -> %.4f, max K %.4g -> %.4g\n", what.c_str(),
                  slid.inserted.size(), mean_before, mean_after, max_before, max_after);
      ++ran;
    }
    // The default pipeline (optimize mips) slides its refined answers, and they pass the contract.
    const ParametrizeResult d = parametrize(lm.raw, pipelinecases::boundary_of(*target), ParametrizeOptions{});
    EXPECT_EQ(d.sliding.ran, !d.map.inserted.empty());
    const mapcheck::Report rep = pipelinecases::check(lm, *target, d);
    EXPECT_TRUE(rep.ok()) << c.mesh << "\n" << rep.str();
  }
  EXPECT_GE(ran, 6) << "fewer than 3 answers with inserted points: the test would look at too little";
  EXPECT_GE(lowered, 2) << "sliding lowered the mean K of too few answers to be doing anything";
}

}  // namespace
}  // namespace lipmap
