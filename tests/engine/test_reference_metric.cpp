// The variable metric (paper 5.2, engine/reference_metric.h and its path through engine/pipeline.cpp). Checked
// with the independent checker (tests/support/map_checker.h) and the test support's exact orientation, never
// with the engine's own verify.
//
//   ReferenceMetricStage    the stage alone: cotangents of T's triangles (unsigned, flips included), the 3D
//                           metric on T's degenerate triangles, T's flip count, and its input errors.
//   MetricReproduction      paper 5.2's reproduction property: a locally injective T given as the metric, with
//                           T's boundary as the polygon, comes back as T bit for bit (tolerance 0) with nothing
//                           inserted, on every shared disk mesh x target kind. T is the target's certificate
//                           (g o Tutte, on the source mesh) when it has one, else the pipeline's own answer
//                           (on its refined mesh when it inserted vertices; meshes up to 10k triangles only, to
//                           keep the run short: the certificates cover the larger ones).
//   MetricRepair            UV repair: locally injective maps with 1 to 50 flips injected (interior vertices
//                           pushed across a neighbour), 2 seeds, every shared disk mesh up to 10k triangles, the
//                           reference maps being the certificates g o Tutte that live on the source mesh (up to
//                           two kinds per mesh). Not the pipeline's own answers: with optimize none those ARE the
//                           plain harmonic map, so the comparison below would only measure the injected pushes
//                           (bench/bench_metric shows them, ratio about 2 to 10):
//                           every answer passes the contract, and its mean distance to T is at most half that
//                           of the plain harmonic answer (metric "surface", optimize none, same boundary) in
//                           >= 90% of the cases.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/error.h"
#include "engine/intermediate_map.h"
#include "engine/reference_metric.h"
#include "engine/validate.h"
#include "tests/support/flip_injection.h"
#include "tests/support/pipeline_cases.h"

namespace lipmap {
namespace {

using pipelinecases::LoadedMesh;
using targetgen::Kind;

// ---- the stage alone ---------------------------------------------------------------------------------

RawMesh fan_mesh() {  // hub 0 and 6 rim vertices, a gentle cone
  RawMesh m;
  m.vertices.push_back({0, 0, 0.3});
  for (int k = 0; k < 6; ++k) m.vertices.push_back({std::cos(k * M_PI / 3), std::sin(k * M_PI / 3), 0});
  for (int k = 0; k < 6; ++k) m.faces.push_back({0, 1 + k, 1 + (k + 1) % 6});
  return m;
}

// cot of the angle at corner o of (o, a, b) from the three edge lengths alone (law of cosines, Heron).
double cot_from_lengths(const Point2& o, const Point2& a, const Point2& b) {
  const long double la = std::hypot(a.x - o.x, a.y - o.y), lb = std::hypot(b.x - o.x, b.y - o.y),
                    lc = std::hypot(b.x - a.x, b.y - a.y);
  const long double s = (la + lb + lc) / 2;
  const long double area = std::sqrt(std::max<long double>(s * (s - la) * (s - lb) * (s - lc), 0));
  return static_cast<double>((la * la + lb * lb - lc * lc) / (4 * area));
}

TEST(ReferenceMetricStage, CotangentsComeFromTheEdgeLengthsAndFlipsAreCounted) {
  const DiskMesh mesh = validate_mesh(fan_mesh());
  std::vector<Point2> T(7);
  for (int v = 0; v < 7; ++v) T[v] = {mesh.vertices[v].x * 2 + 0.1 * v, mesh.vertices[v].y * 3};
  T[0] = {5, 0.2};  // the hub pushed past the rim: some triangles flip
  const int folded = flipinject::count_folded(T, mesh.faces);
  ASSERT_GT(folded, 0);
  const ReferenceMetric m = reference_metric(mesh, T);
  EXPECT_EQ(m.flipped, folded);
  EXPECT_EQ(m.corrected, 0);
  for (std::size_t f = 0; f < mesh.faces.size(); ++f)
    for (int c = 0; c < 3; ++c) {
      const Triangle& t = mesh.faces[f];
      const double expect = cot_from_lengths(T[t[c]], T[t[(c + 1) % 3]], T[t[(c + 2) % 3]]);
      EXPECT_NEAR(m.cotangents[f][c], expect, 1e-9 * (1 + std::abs(expect))) << f << " " << c;
    }
  for (int v = 0; v < 7; ++v) EXPECT_TRUE(m.rest[v] == (Point3{T[v].x, T[v].y, 0}));
}

TEST(ReferenceMetricStage, DegenerateTrianglesOfTTakeTheSurfaceMetric) {
  const DiskMesh mesh = validate_mesh(fan_mesh());
  std::vector<Point2> T(7);
  for (int v = 0; v < 7; ++v) T[v] = {mesh.vertices[v].x, mesh.vertices[v].y};
  T[0] = T[1];  // faces (0, 1, 2) and (0, 6, 1) get a zero-length edge: not strictly a triangle
  const std::vector<std::array<double, 3>> surface = corner_cotangents(mesh.vertices, mesh.faces);
  const ReferenceMetric m = reference_metric(mesh, T);
  int degenerate = 0;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const Triangle& t = mesh.faces[f];
    const bool flat = t[0] == 0 && (t[1] == 1 || t[2] == 1);
    if (!flat) continue;
    ++degenerate;
    for (int c = 0; c < 3; ++c) EXPECT_EQ(m.cotangents[f][c], surface[f][c]);
  }
  EXPECT_EQ(degenerate, 2);
  EXPECT_EQ(m.corrected, 2);
  EXPECT_EQ(m.flipped, flipinject::count_folded(T, mesh.faces));
  // Collinear corners (a degenerate triangle with three distinct points) too.
  for (int v = 0; v < 7; ++v) T[v] = {mesh.vertices[v].x, mesh.vertices[v].y};
  T[0] = {(T[1].x + T[2].x) / 2, (T[1].y + T[2].y) / 2};
  EXPECT_GE(reference_metric(mesh, T).corrected, 1);
}

std::string error_code(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.code();
  }
  return "none";
}

TEST(ReferenceMetricStage, BadReferenceMapsAreInputErrors) {
  const DiskMesh mesh = validate_mesh(fan_mesh());
  std::vector<Point2> T(7, Point2{0.5, 0.5});
  EXPECT_EQ(error_code([&] { reference_metric(mesh, T); }), "metric_degenerate");
  EXPECT_EQ(error_code([&] { reference_metric(mesh, std::vector<Point2>(6)); }), "metric_length_mismatch");
  EXPECT_EQ(error_code([&] { reference_metric(mesh, std::vector<Point2>(8)); }), "metric_length_mismatch");
  T[3].x = std::nan("");
  EXPECT_EQ(error_code([&] { reference_metric(mesh, T); }), "metric_non_finite");
  T[3].x = INFINITY;
  EXPECT_EQ(error_code([&] { reference_metric(mesh, T); }), "metric_non_finite");
  // Through the pipeline: the same codes before any work.
  ParametrizeOptions o;
  o.metric = std::vector<Point2>(3);
  RawBoundary b;
  for (int k = 0; k < 6; ++k) b.positions.push_back({std::cos(k * M_PI / 3), std::sin(k * M_PI / 3)});
  EXPECT_EQ(error_code([&] { parametrize(fan_mesh(), b, o); }), "metric_length_mismatch");
  o.metric = std::vector<Point2>(7, Point2{2, 2});
  EXPECT_EQ(error_code([&] { parametrize(fan_mesh(), b, o); }), "metric_degenerate");
}

// ---- reference maps on the shared meshes --------------------------------------------------------------

struct Reference {
  std::string where;
  RawMesh mesh;
  std::vector<Point3> vertices;
  std::vector<Triangle> faces;
  std::vector<int> loop;
  std::vector<Point2> T;          // locally injective, one per vertex of mesh
  std::vector<Point2> positions;  // T on the loop
  std::optional<std::vector<int>> rotation;
};

RawBoundary boundary_of(const Reference& r) {
  RawBoundary b;
  b.positions = r.positions;
  if (r.rotation) b.rotation_indices = std::vector<long long>(r.rotation->begin(), r.rotation->end());
  return b;
}

mapcheck::Report check(const Reference& ref, const ParametrizeResult& r) {
  mapcheck::Result res{r.map.vertices, r.map.faces, r.map.uv, {}};
  for (const InsertedVertex& v : r.map.inserted) res.inserted.push_back({v.a, v.b, v.t});
  return mapcheck::check_map({ref.vertices, ref.faces, ref.loop}, ref.positions, res, ref.rotation ? &*ref.rotation : nullptr);
}

// A locally injective map of the mesh (or of the pipeline's refined mesh) with the target's boundary.
std::optional<Reference> reference_map(const LoadedMesh& m, Kind kind, std::string* why, bool certificate_only = false,
                                       long long max_pipeline_triangles = 10000) {
  const auto t = targetgen::make_target(kind, pipelinecases::ref(m), why);
  if (!t) return std::nullopt;
  if (!t->certificate_on_source && (certificate_only || static_cast<long long>(m.faces.size()) > max_pipeline_triangles))
    return std::nullopt;
  Reference r;
  r.where = m.name + " / " + targetgen::kind_name(kind);
  r.rotation = t->rotation_indices;
  if (t->certificate_on_source) {
    r.mesh = m.raw;
    r.vertices = m.vertices;
    r.faces = m.faces;
    r.loop = m.loop;
    r.T = t->certificate_uv;
  } else {
    ParametrizeOptions o;
    o.optimize = OptimizeEnergy::none;
    const ParametrizeResult p = parametrize(m.raw, pipelinecases::boundary_of(*t), o);
    r.vertices = p.map.vertices;
    r.faces = p.map.faces;
    r.mesh.vertices = r.vertices;
    for (const Triangle& f : r.faces) r.mesh.faces.push_back({f[0], f[1], f[2]});
    r.loop = pipelinecases::boundary_loop_of(r.faces, r.vertices.size());
    r.T = p.map.uv;
  }
  for (int v : r.loop) r.positions.push_back(r.T[v]);
  if (flipinject::count_folded(r.T, r.faces) != 0) {
    if (why) *why = "the reference map folds";
    return std::nullopt;
  }
  return r;
}

TEST(MetricReproduction, ALocallyInjectiveReferenceComesBackUnchanged) {
  int cases = 0;
  for (const testmeshes::MeshEntry& e : testmeshes::disk_meshes()) {
    if (e.extra) continue;
    const LoadedMesh& m = pipelinecases::load(e);
    ASSERT_FALSE(m.loop.empty()) << e.file;
    for (Kind kind : targetgen::all_kinds()) {
      std::string why;
      std::optional<Reference> ref;
      try {
        // Pipeline-made references only on meshes of at most 3,000 triangles: making them is the slow part (maze's
        // refinement takes tens of seconds per kind); certificates (g o Tutte) on every mesh.
        ref = reference_map(m, kind, &why, false, 3000);
      } catch (const std::exception& ex) {
        ADD_FAILURE() << m.name << " / " << targetgen::kind_name(kind) << ": " << ex.what();
        continue;
      }
      if (!ref) continue;
      ParametrizeOptions o;
      o.metric = ref->T;
      ParametrizeResult r;
      try {
        r = parametrize(ref->mesh, boundary_of(*ref), o);
      } catch (const std::exception& ex) {
        ADD_FAILURE() << ref->where << ": " << ex.what();
        continue;
      }
      ++cases;
      EXPECT_TRUE(r.map.inserted.empty()) << ref->where;
      ASSERT_EQ(r.map.uv.size(), ref->T.size()) << ref->where;
      int moved = 0;
      for (std::size_t v = 0; v < ref->T.size(); ++v) moved += r.map.uv[v] == ref->T[v] ? 0 : 1;
      EXPECT_EQ(moved, 0) << ref->where << ": vertices not at T bit for bit";
      EXPECT_EQ(r.metric.path, "reference") << ref->where;
      EXPECT_TRUE(r.metric.reproduced) << ref->where;
      EXPECT_EQ(r.metric.reference_flipped, 0) << ref->where;
      EXPECT_EQ(r.metric.distance.max, 0) << ref->where;
      const mapcheck::Report rep = check(*ref, r);
      EXPECT_TRUE(rep.ok()) << ref->where << "\n" << rep.str();
    }
  }
  std::printf("[ metric ] %d reproduction cases\n", cases);
  ASSERT_GE(cases, 40);
}

TEST(MetricRepair, FlippedReferenceMapsAreRepairedCloseToThem) {
  int cases = 0, closer = 0, no_insertion = 0;
  std::vector<double> ratios;
  std::string report;
  int kind_turn = 0;
  for (const testmeshes::MeshEntry& e : testmeshes::disk_meshes()) {
    if (e.extra || e.triangles > 10000) continue;
    const LoadedMesh& m = pipelinecases::load(e);
    // Up to two reference maps per mesh, the kinds taken in turn over the meshes.
    const std::vector<Kind> kinds = {Kind::exp_strip, Kind::power_map, Kind::cubic_map, Kind::bent_strip};
    int taken = 0;
    for (std::size_t i = 0; i < kinds.size() && taken < 2; ++i) {
    const std::optional<Reference> ref = reference_map(m, kinds[(kind_turn + i) % kinds.size()], nullptr, true);
    if (!ref) continue;
    ++taken;
    ParametrizeOptions plain_options;
    plain_options.optimize = OptimizeEnergy::none;
    const ParametrizeResult plain = parametrize(ref->mesh, boundary_of(*ref), plain_options);
    for (unsigned seed = 1; seed <= 2; ++seed) {
      std::vector<Point2> T = ref->T;
      const int want = 1 + static_cast<int>((seed * 2654435761u + static_cast<unsigned>(cases)) % 50);
      const int folded = flipinject::inject_flips(T, ref->faces, ref->loop, want, 50, seed);
      if (folded == 0) continue;
      const std::string where = ref->where + " seed " + std::to_string(seed) + " (" + std::to_string(folded) + " flips)";
      ParametrizeOptions o;
      o.metric = T;
      ParametrizeResult r;
      try {
        r = parametrize(ref->mesh, boundary_of(*ref), o);
      } catch (const std::exception& ex) {
        ADD_FAILURE() << where << ": " << ex.what();
        continue;
      }
      ++cases;
      const mapcheck::Report rep = check(*ref, r);
      EXPECT_TRUE(rep.ok()) << where << "\n" << rep.str();
      EXPECT_EQ(r.metric.reference_flipped, folded) << where;
      EXPECT_NE(r.metric.path, "reference") << where;
      const double ours = flipinject::distance(r.map.uv, T, ref->positions).mean;
      const double theirs = flipinject::distance(plain.map.uv, T, ref->positions).mean;
      EXPECT_NEAR(r.metric.distance.mean, ours, 1e-9) << where;
      const double ratio = ours / theirs;
      ratios.push_back(ratio);
      if (ratio <= 0.5) ++closer;
      if (r.map.inserted.empty()) ++no_insertion;
      char line[256];
      std::snprintf(line, sizeof line, "  %s: %s, inserted %zu, mean distance %.3g vs plain %.3g (ratio %.3f)\n",
                    where.c_str(), r.metric.path.c_str(), r.map.inserted.size(), ours, theirs, ratio);
      report += line;
    }
    }
    ++kind_turn;
  }
  std::sort(ratios.begin(), ratios.end());
  std::printf("[ metric ] %d repair cases, %d with ratio <= 0.5, %d without insertion, median ratio %.3f\n%s", cases,
              closer, no_insertion, ratios.empty() ? 0.0 : ratios[ratios.size() / 2], report.c_str());
  ASSERT_GE(cases, 12);
  EXPECT_GE(closer * 10, cases * 9) << report;
}

}  // namespace
}  // namespace lipmap
