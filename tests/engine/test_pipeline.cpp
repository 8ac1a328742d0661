// The whole engine (engine/pipeline.h) end to end, checked by tests/support/map_checker.h, a checker of
// docs/contract.md that shares no code with engine/verify.cpp.
//
// Suites:
//   MapPipelineChecker     the checker itself on hand-made results, valid and broken (every check fails once)
//   MapPipelineGenerators  the target generators' certificates (tests/support/target_generators.h)
//   MapPipelineTargets/... every disk mesh (tests/support/test_meshes.h) x target kind: parametrize, then the
//                          checker
//   MapPipeline            special cases: degenerate mesh refused, a fan onto a polygon with empty kernel, a
//                          snake strip (paper Fig. 9), non-self-overlapping boundaries refused, identity
//                          reproduction (paper Fig. 13), refine off.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/error.h"
#include "engine/mesh_io.h"
#include "engine/pipeline.h"
#include "engine/validate.h"
#include "server/codec/json_codec.h"
#include "tests/support/map_checker.h"
#include "tests/support/pipeline_cases.h"
#include "tests/support/target_generators.h"
#include "tests/support/test_meshes.h"

namespace lipmap {
namespace {

using mapcheck::check_map;
using mapcheck::Report;
using targetgen::Kind;

// ---- meshes -------------------------------------------------------------------------------------------

struct TestMesh {
  std::string name;
  std::vector<Point3> vertices;
  std::vector<Triangle> faces;
  std::vector<int> loop;  // boundary loop, interior on the left, starting at its lowest vertex (computed here)
};

RawMesh raw_of(const TestMesh& m) {
  RawMesh raw;
  raw.vertices = m.vertices;
  for (const Triangle& t : m.faces) raw.faces.push_back({t[0], t[1], t[2]});
  return raw;
}

using pipelinecases::boundary_loop_of;

TestMesh load_mesh(const testmeshes::MeshEntry& entry) {
  const RawMesh raw = read_mesh_file(entry.path());
  TestMesh m;
  m.name = entry.name();
  m.vertices = raw.vertices;
  for (const auto& f : raw.faces) m.faces.push_back({int(f[0]), int(f[1]), int(f[2])});
  m.loop = boundary_loop_of(m.faces, m.vertices.size());
  return m;
}

const TestMesh& mesh(const testmeshes::MeshEntry& entry) {
  static std::mutex mu;
  static std::map<std::string, std::unique_ptr<TestMesh>> cache;
  std::lock_guard<std::mutex> lock(mu);
  auto& slot = cache[entry.path()];
  if (!slot) slot = std::make_unique<TestMesh>(load_mesh(entry));
  return *slot;
}

// A file of tests/data/meshes.
const TestMesh& mesh(const std::string& file) { return mesh(testmeshes::entry(file)); }

targetgen::DiskMeshRef ref(const TestMesh& m) { return {m.vertices, m.faces, m.loop}; }

mapcheck::SourceMesh source_of(const TestMesh& m) { return {m.vertices, m.faces, m.loop}; }

// ---- MapPipelineChecker: hand-made results ------------------------------------------------------------

// Source: a square pyramid, apex 4 raised. Prescribed: the square of side 2.
struct Handmade {
  mapcheck::SourceMesh src;
  std::vector<Point2> prescribed;
  mapcheck::Result res;
};

Handmade pyramid_with_split() {
  Handmade h;
  h.src.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, 0.5}};
  h.src.faces = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  h.src.loop = {0, 1, 2, 3};
  h.prescribed = {{0, 0}, {2, 0}, {2, 2}, {0, 2}};
  // Result: interior edge (0, 4) split at t = 0.5 (vertex 5).
  h.res.vertices = h.src.vertices;
  h.res.vertices.push_back({0.25, 0.25, 0.25});
  h.res.uv = {{0, 0}, {2, 0}, {2, 2}, {0, 2}, {1, 1}, {0.5, 0.5}};
  h.res.faces = {{0, 1, 5}, {5, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 5}, {3, 5, 4}};
  h.res.inserted = {{0, 4, 0.5}};
  return h;
}

TEST(MapPipelineChecker, ValidHandmadeResultPasses) {
  const Handmade h = pyramid_with_split();
  const Report r = check_map(h.src, h.prescribed, h.res);
  // The split is not needed (the pyramid's triangles are positive without it): only `minimal` objects.
  EXPECT_EQ(r.errors.size(), 1u) << r.str();
  EXPECT_TRUE(r.has("minimal")) << r.str();
  EXPECT_EQ(r.interior_vertices_checked, 2);
  EXPECT_EQ(r.faces_checked, 6);
  EXPECT_LT(r.area_relative_error, 1e-15);
}

TEST(MapPipelineChecker, EveryCheckCanFail) {
  {  // shape
    Handmade h = pyramid_with_split();
    h.res.uv.pop_back();
    EXPECT_TRUE(check_map(h.src, h.prescribed, h.res).has("shape"));
  }
  {  // original_vertex: one ulp
    Handmade h = pyramid_with_split();
    h.res.vertices[1].x = std::nextafter(1.0, 2.0);
    const Report r = check_map(h.src, h.prescribed, h.res);
    EXPECT_TRUE(r.has("original_vertex")) << r.str();
  }
  {  // inserted_count
    Handmade h = pyramid_with_split();
    h.res.inserted.push_back({1, 4, 0.5});
    EXPECT_TRUE(check_map(h.src, h.prescribed, h.res).has("inserted_count"));
  }
  {  // inserted_edge: wrong t (the vertex is not at a + t (b - a))
    Handmade h = pyramid_with_split();
    h.res.inserted[0].t = 0.5 + 1e-9;
    const Report r = check_map(h.src, h.prescribed, h.res);
    EXPECT_TRUE(r.has("inserted_edge")) << r.str();
  }
  {  // inserted_edge: not an edge of the source
    Handmade h = pyramid_with_split();
    h.res.inserted[0] = {0, 2, 0.5};
    h.res.vertices[5] = {0.5, 0.5, 0};
    EXPECT_TRUE(check_map(h.src, h.prescribed, h.res).has("inserted_edge"));
  }
  {  // inserted_edge: (a, b) reported with a > b
    Handmade h = pyramid_with_split();
    h.res.inserted[0] = {4, 0, 0.5};
    EXPECT_TRUE(check_map(h.src, h.prescribed, h.res).has("inserted_edge"));
  }
  {  // inserted_boundary: a vertex inserted on boundary edge (0, 1)
    Handmade h = pyramid_with_split();
    h.res.vertices[5] = {0.5, 0, 0};
    h.res.uv[5] = {1, 0};
    h.res.inserted[0] = {0, 1, 0.5};
    h.res.faces = {{0, 5, 4}, {5, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
    const Report r = check_map(h.src, h.prescribed, h.res);
    EXPECT_TRUE(r.has("inserted_boundary")) << r.str();
    EXPECT_TRUE(r.has("disk")) << r.str();  // the boundary loop changed too
  }
  {  // boundary_uv: one ulp
    Handmade h = pyramid_with_split();
    h.res.uv[2].y = std::nextafter(2.0, 3.0);
    const Report r = check_map(h.src, h.prescribed, h.res);
    EXPECT_TRUE(r.has("boundary_uv")) << r.str();
    EXPECT_FALSE(r.has("positive")) << r.str();
  }
  {  // positive: the apex's uv pushed outside across edge (1, 2)
    Handmade h = pyramid_with_split();
    h.res.uv[4] = {2.5, 1};
    EXPECT_TRUE(check_map(h.src, h.prescribed, h.res).has("positive"));
  }
  {  // positive: a degenerate (collinear) uv triangle
    Handmade h = pyramid_with_split();
    h.res.uv[5] = {1, 0};  // on edge (0, 1): face (0, 1, 5) collinear
    EXPECT_TRUE(check_map(h.src, h.prescribed, h.res).has("positive"));
  }
  {  // degenerate_3d: a face with all corners on original edge (0, 4)
    Handmade h = pyramid_with_split();
    h.res.vertices.push_back({0.125, 0.125, 0.125});  // vertex 6 on (0, 4) at t = 0.25
    h.res.uv.push_back({0.25, 0.2});
    h.res.inserted.push_back({0, 4, 0.25});
    h.res.faces.push_back({0, 6, 5});
    const Report r = check_map(h.src, h.prescribed, h.res);
    EXPECT_TRUE(r.has("degenerate_3d")) << r.str();
  }
  {  // area alone: the same vertices, the quad (1, 2, 3, 0) of a non-planar mesh triangulated by the other diagonal
    Handmade h;
    h.src.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0.5}, {0, 1, 0}};
    h.src.faces = {{0, 1, 2}, {0, 2, 3}};
    h.src.loop = {0, 1, 2, 3};
    h.prescribed = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    h.res.vertices = h.src.vertices;
    h.res.uv = h.prescribed;
    h.res.faces = {{0, 1, 3}, {1, 2, 3}};
    const Report r = check_map(h.src, h.prescribed, h.res);
    ASSERT_EQ(r.errors.size(), 1u) << r.str();
    EXPECT_TRUE(r.has("area")) << r.str();
  }
  {  // disk: a face missing (boundary changes, area too)
    Handmade h = pyramid_with_split();
    h.res.faces.pop_back();
    const Report r = check_map(h.src, h.prescribed, h.res);
    EXPECT_TRUE(r.has("disk")) << r.str();
    EXPECT_TRUE(r.has("area")) << r.str();
  }
  {  // disk: two fans at a vertex (a bow tie glued at vertex 4 of two separate pieces)
    Handmade h;
    h.src.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, 0}};
    h.src.faces = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
    h.src.loop = {0, 1, 2, 3};
    h.prescribed = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    h.res.vertices = h.src.vertices;
    h.res.uv = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0.5, 0.5}};
    h.res.faces = {{0, 1, 4}, {2, 3, 4}};
    EXPECT_TRUE(check_map(h.src, h.prescribed, h.res).has("disk"));
  }
  {  // angle_sum: an interior vertex whose ring winds twice (all triangles positive, 4 pi at the centre)
    Handmade h;
    const int n = 8;
    h.src.vertices.push_back({0, 0, 1});
    for (int k = 0; k < n; ++k) {
      const double a = 2 * M_PI * k / n;
      h.src.vertices.push_back({std::cos(a), std::sin(a), 0});
    }
    for (int k = 0; k < n; ++k) h.src.faces.push_back({0, 1 + k, 1 + (k + 1) % n});
    for (int k = 0; k < n; ++k) h.src.loop.push_back(1 + k);
    for (int k = 0; k < n; ++k) {
      const double a = 4 * M_PI * k / n;  // twice around
      h.prescribed.push_back({(1 + 0.1 * k) * std::cos(a), (1 + 0.1 * k) * std::sin(a)});
    }
    h.res.vertices = h.src.vertices;
    h.res.uv.push_back({0, 0});
    for (const Point2& p : h.prescribed) h.res.uv.push_back(p);
    h.res.faces = h.src.faces;
    const Report r = check_map(h.src, h.prescribed, h.res);
    EXPECT_TRUE(r.has("angle_sum")) << r.str();
    EXPECT_FALSE(r.has("positive")) << r.str();
    EXPECT_NE(r.str().find("(2)"), std::string::npos) << r.str();  // two turns
  }
  {  // rotation_index: prescribed R = 1 at a vertex whose angle is its plain interior angle
    const Handmade h = pyramid_with_split();
    const std::vector<int> R = {1, 0, 0, 0};
    EXPECT_TRUE(check_map(h.src, h.prescribed, h.res, &R).has("rotation_index"));
    const std::vector<int> zero = {0, 0, 0, 0};
    EXPECT_FALSE(check_map(h.src, h.prescribed, h.res, &zero).has("rotation_index"));
  }
}

// ---- MapPipelineGenerators ----------------------------------------------------------------------------

// The loop this file computes has the README's number of boundary vertices (small meshes of the catalog).
TEST(MapPipelineGenerators, BoundaryLoopOfTheTestMeshes) {
  for (const testmeshes::MeshEntry& e : testmeshes::catalog()) {
    if (!e.disk || e.triangles > 10000) continue;
    const TestMesh& m = mesh(e);
    ASSERT_FALSE(m.loop.empty()) << e.file;
    EXPECT_EQ(*std::min_element(m.loop.begin(), m.loop.end()), m.loop[0]) << e.file;
    EXPECT_EQ(static_cast<long long>(m.loop.size()), e.boundary_vertices) << e.file;
  }
}

// Every certificate is itself a valid answer by every check of section 2: a locally injective map whose
// boundary is exactly the generated polygon (on the source mesh, or on the generator's polar disk mesh).
void expect_certificate_valid(const TestMesh& m, const targetgen::Target& t) {
  const std::string what = m.name + " / " + targetgen::kind_name(t.kind);
  if (t.certificate_on_source) {
    const mapcheck::Result res{m.vertices, m.faces, t.certificate_uv, {}};
    const Report r = check_map(source_of(m), t.positions, res);
    EXPECT_TRUE(r.ok()) << what << " (on the source mesh)\n" << r.str();
  } else if (!t.certificate_faces.empty()) {
    mapcheck::SourceMesh polar;
    for (const Point2& p : t.certificate_domain) polar.vertices.push_back({p.x, p.y, 0});
    polar.faces = t.certificate_faces;
    for (std::size_t k = 0; k < t.positions.size(); ++k) polar.loop.push_back(static_cast<int>(k));
    const mapcheck::Result res{polar.vertices, polar.faces, t.certificate_uv, {}};
    const Report r = check_map(polar, t.positions, res);
    EXPECT_TRUE(r.ok()) << what << " (on the polar certificate mesh)\n" << r.str();
  }
}

TEST(MapPipelineGenerators, EveryKindHasItsCertificate) {
  for (const char* file : {"nefertiti.off", "swirl_blob.obj", "three_peaks.off", "cut_bowl.obj"}) {
    const TestMesh& m = mesh(file);
    int by_construction = 0;
    for (Kind kind : targetgen::all_kinds()) {
      std::string why;
      const auto t = targetgen::make_target(kind, ref(m), &why);
      if (!t) {
        // Documented in target_generators.h: the strongly anisotropic bent strip on coarse boundaries.
        const bool known = kind == Kind::bent_strip && (m.name == "nefertiti" || m.name == "three_peaks");
        EXPECT_TRUE(known) << file << " / " << targetgen::kind_name(kind) << ": " << why;
        continue;
      }
      EXPECT_EQ(t->positions.size(), m.loop.size());
      if (t->expect == "self_overlapping") ++by_construction;
      expect_certificate_valid(m, *t);
    }
    EXPECT_GE(by_construction, 3) << file;
  }
}

TEST(MapPipelineGenerators, BlobHasOnlyFourBoundaryVerticesSoOnlyTheCircle) {
  // Every simple polygon with at most 5 vertices is star-shaped, and a quadrilateral cannot overlap itself
  // with turning number 1, nor turn twice: only the circle exists for blob.off.
  const TestMesh& m = mesh("blob.off");
  for (Kind kind : targetgen::all_kinds()) {
    std::string why;
    const auto t = targetgen::make_target(kind, ref(m), &why);
    EXPECT_EQ(t.has_value(), kind == Kind::circle) << targetgen::kind_name(kind) << ": " << why;
  }
}

// ---- running the pipeline and checking --------------------------------------------------------------

std::string verdict_str(Verdict v) {
  switch (v) {
    case Verdict::simple: return "simple";
    case Verdict::self_overlapping: return "self_overlapping";
    case Verdict::weakly_self_overlapping: return "weakly_self_overlapping";
    case Verdict::not_self_overlapping: return "not_self_overlapping";
  }
  return "?";
}

mapcheck::Result result_of(const ParametrizeResult& r) {
  mapcheck::Result out{r.map.vertices, r.map.faces, r.map.uv, {}};
  for (const InsertedVertex& v : r.map.inserted) out.inserted.push_back({v.a, v.b, v.t});
  return out;
}

std::string summary(const ParametrizeResult& r) {
  std::ostringstream os;
  os << "verdict " << verdict_str(r.classification.verdict) << ", " << r.map.vertices.size() << " vertices ("
     << r.map.inserted.size() << " inserted), " << r.map.faces.size() << " faces, flipped before refinement "
     << r.map.flipped_before_refinement << ", target mesh " << r.target_mesh.vertices << " vertices / "
     << r.target_mesh.pieces << " pieces, distortion max " << r.distortion.max << " mean " << r.distortion.mean
     << ", total " << r.timings.total << " ms";
  return os.str();
}

// With LIPMAP_REPRO_DIR set, a failing case leaves its whole request there as a POST /v1/parametrize body
// (`lipmap map DIR/NAME.json -o out.json` reproduces it).
std::string save_repro(const std::string& name, const TestMesh& m, const RawBoundary& b, MapMethod method) {
  const char* dir = std::getenv("LIPMAP_REPRO_DIR");
  if (!dir || !*dir) return " (set LIPMAP_REPRO_DIR to save the request)";
  codec::ParametrizeRequest request;
  request.mesh = raw_of(m);
  request.boundary = b;
  request.options.method = method;
  const std::string path = std::string(dir) + "/" + name + ".json";
  std::ofstream(path) << codec::dump(codec::parametrize_request_to_json(request)) << "\n";
  return " (request saved as " + path + ")";
}

// Runs parametrize on mesh m with the target t and checks everything; returns the result.
ParametrizeResult run_and_check(const TestMesh& m, const targetgen::Target& t, MapMethod method = MapMethod::harmonic,
                                OptimizeEnergy optimize = ParametrizeOptions{}.optimize) {
  RawBoundary b;
  b.positions = t.positions;
  if (t.rotation_indices) b.rotation_indices = std::vector<long long>(t.rotation_indices->begin(), t.rotation_indices->end());
  ParametrizeOptions o;
  o.method = method;
  o.optimize = optimize;
  ParametrizeResult r;
  const std::string name = m.name + "_" + targetgen::kind_name(t.kind) + (method == MapMethod::tutte ? "_tutte" : "");
  try {
    r = parametrize(raw_of(m), b, o);
  } catch (const InputError& e) {
    ADD_FAILURE() << m.name << " / " << targetgen::kind_name(t.kind) << ": InputError " << e.code() << ": " << e.what()
                  << save_repro(name, m, b, method);
    return r;
  } catch (const std::exception& e) {
    ADD_FAILURE() << m.name << " / " << targetgen::kind_name(t.kind) << ": exception: " << e.what()
                  << save_repro(name, m, b, method);
    return r;
  }
  const std::string where = m.name + " / " + targetgen::kind_name(t.kind) + ": " + summary(r);
  EXPECT_EQ(verdict_str(r.classification.verdict), t.expect) << where;
  EXPECT_EQ(r.boundary_loop, m.loop) << where;
  EXPECT_EQ(r.flipped, 0) << where;
  const Report rep = check_map(source_of(m), t.positions, result_of(r),
                               t.rotation_indices ? &*t.rotation_indices : nullptr);
  EXPECT_TRUE(rep.ok()) << where << "\n" << rep.str() << (rep.ok() ? "" : save_repro(name, m, b, method));
  if (t.rotation_indices) {
    EXPECT_EQ(r.classification.rotation_indices, *t.rotation_indices) << where;
    EXPECT_EQ(r.classification.singular_vertices, t.singular_positions) << where;
  }
  // Diagnostics are consistent with the map.
  EXPECT_EQ(r.distortion.per_face.size(), r.map.faces.size()) << where;
  EXPECT_GE(r.distortion.max, 1.0) << where;
  EXPECT_GE(r.timings.total, 0.0) << where;
  return r;
}

// ---- MapPipelineTargets: every disk mesh x target kind ------------------------------------------------

struct Case {
  testmeshes::MeshEntry mesh;
  Kind kind;
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.mesh.file << " / " << targetgen::kind_name(c.kind); }

std::string case_name(const testing::TestParamInfo<Case>& info) {
  return info.param.mesh.name() + "_" + targetgen::kind_name(info.param.kind);
}

// Every disk mesh with every kind. The narrow corridors (maze.obj: 3064 of its 6120 vertices on the
// boundary, corridors one or two triangles wide; maze_corridor.obj likewise) are by far the slowest: their
// triangles join boundary vertices far apart along the loop, and every generated target bends those
// chords, so refine inserts tens of thousands of points there (each case up to about a minute on one core).
std::vector<Case> all_cases() {
  std::vector<Case> cases;
  for (const testmeshes::MeshEntry& m : testmeshes::disk_meshes())
    for (Kind k : targetgen::all_kinds()) cases.push_back({m, k});
  return cases;
}

class MapPipelineTarget : public testing::TestWithParam<Case> {};

TEST_P(MapPipelineTarget, PassesEveryCheck) {
  const Case& c = GetParam();
  const TestMesh& m = mesh(c.mesh);
  ASSERT_FALSE(m.loop.empty()) << c.mesh.file;
  std::string why;
  const auto t = targetgen::make_target(c.kind, ref(m), &why);
  if (!t) GTEST_SKIP() << c.mesh.file << ": no " << targetgen::kind_name(c.kind) << " target: " << why;
  run_and_check(m, *t);
}

INSTANTIATE_TEST_SUITE_P(MapPipelineTargets, MapPipelineTarget, testing::ValuesIn(all_cases()), case_name);

// The maze onto the power and cubic maps: every corridor is bent, and until the untangler took Newton steps it
// left hundreds of folds and refinement inserted over 30,000 points. A face whose three corners are boundary
// vertices is fixed by the polygon; when it is not positive (counted here by the checker) one of its chords must
// be split, and one split serves at most the two faces of its chord; so must one that the polygon makes too thin
// for float32 (contract point 6; the checker's own test). Nothing else needs an insertion here: the answer is the
// untangled unrefined mesh with those chords split, such fixed faces / 2 <= inserted <= such fixed faces.
TEST(MapPipeline, MazeOntoPowerAndCubicMapsSplitsOnlyChordsOfFixedFacesThePolygonFoldsOrThins) {
  const TestMesh& m = mesh("maze.obj");
  std::vector<char> on_loop(m.vertices.size(), 0);
  for (int v : m.loop) on_loop[static_cast<std::size_t>(v)] = 1;
  for (Kind kind : {Kind::power_map, Kind::cubic_map}) {
    std::string why;
    const auto t = targetgen::make_target(kind, ref(m), &why);
    ASSERT_TRUE(t) << why;
    std::vector<Point2> at(m.vertices.size());
    for (std::size_t k = 0; k < m.loop.size(); ++k) at[static_cast<std::size_t>(m.loop[k])] = t->positions[k];
    std::vector<Triangle> fixed_faces;
    for (const Triangle& f : m.faces)
      if (on_loop[static_cast<std::size_t>(f[0])] && on_loop[static_cast<std::size_t>(f[1])] && on_loop[static_cast<std::size_t>(f[2])])
        fixed_faces.push_back(f);
    int folded_fixed = pipelinecases::count_folded_by_checker(at, fixed_faces);
    for (const Triangle& f : fixed_faces) {
      const Point2 &a = at[static_cast<std::size_t>(f[0])], &b = at[static_cast<std::size_t>(f[1])],
                   &c = at[static_cast<std::size_t>(f[2])];
      if (mapcheck::detail::orient(a, b, c) > 0 && (!mapcheck::detail::positive_in_float32(a, b, c) ||
                                                    !mapcheck::detail::clear_of_float32_rounding(a, b, c)))
        ++folded_fixed;
    }
    const ParametrizeResult r = run_and_check(m, *t);
    const std::string where = std::string(targetgen::kind_name(kind)) + ": " + r.untangling.outcome;
    ASSERT_GT(folded_fixed, 0) << where;
    EXPECT_TRUE(r.untangling.succeeded) << where;
    EXPECT_LE(static_cast<int>(r.map.inserted.size()), folded_fixed) << where;
    EXPECT_GE(2 * static_cast<int>(r.map.inserted.size()), folded_fixed) << where;
  }
}

// ---- MapPipeline: special cases -----------------------------------------------------------------------

TEST(MapPipeline, DegenerateMeshIsRefusedWithDegenerateFace) {
  const RawMesh raw = read_mesh_file(testmeshes::mesh_path("withZeroAreaTri_48.obj"));
  std::vector<Triangle> faces;
  for (const auto& f : raw.faces) faces.push_back({int(f[0]), int(f[1]), int(f[2])});
  const std::vector<int> loop = boundary_loop_of(faces, raw.vertices.size());
  ASSERT_FALSE(loop.empty());
  RawBoundary b;
  for (std::size_t k = 0; k < loop.size(); ++k)
    b.positions.push_back({std::cos(2 * M_PI * k / loop.size()), std::sin(2 * M_PI * k / loop.size())});
  try {
    parametrize(raw, b, {});
    FAIL() << "a mesh with zero-area triangles was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.code(), "degenerate_face") << e.what();
    EXPECT_EQ(e.element(), "face");
  }
}

// A fan: one interior vertex (raised) and 8 boundary vertices around it.
TestMesh fan_mesh(int n = 8) {
  TestMesh m;
  m.name = "fan";
  m.vertices.push_back({0, 0, 0.3});
  for (int k = 0; k < n; ++k) m.vertices.push_back({std::cos(2 * M_PI * k / n), std::sin(2 * M_PI * k / n), 0});
  for (int k = 0; k < n; ++k) m.faces.push_back({0, 1 + k, 1 + (k + 1) % n});
  m.loop = boundary_loop_of(m.faces, m.vertices.size());
  return m;
}

TEST(MapPipeline, FanOntoAPolygonWithEmptyKernelNeedsInsertedVertices) {
  const TestMesh m = fan_mesh(8);
  ASSERT_EQ(m.loop, (std::vector<int>{1, 2, 3, 4, 5, 6, 7, 8}));
  // A U: the half-planes of edges (2,3)->(2,1) (x >= 2) and (1,1)->(1,3) (x <= 1) do not meet, so the kernel
  // is empty and no position of the single interior vertex sees all 8 corners: refinement is mandatory.
  targetgen::Target t;
  t.kind = Kind::c_shape;
  t.positions = {{0, 0}, {3, 0}, {3, 3}, {2, 3}, {2, 1}, {1, 1}, {1, 3}, {0, 3}};
  t.expect = "simple";
  ASSERT_TRUE(targetgen::detail::kernel_is_empty(t.positions));
  const ParametrizeResult r = run_and_check(m, t);
  EXPECT_GT(r.map.inserted.size(), 0u) << summary(r);
  EXPECT_GT(r.map.flipped_before_refinement, 0) << summary(r);
}

// Paper Fig. 9: a strip of 2 x 20 (2 rows of vertices, 20 cells; every vertex on the boundary, the cell
// diagonals and rungs are chords) bent into a snake (a sine of amplitude 3 and wavelength 8 cells); the top
// row is shifted by 0.45 cells along the strip, so that in the tight bends some chords would have to leave
// the polygon: their triangles are inverted by the boundary alone (3 of them), and since no vertex is
// interior, only refinement can help. The certificate of that
// (exact orientation of the source triangles under the prescribed positions) is checked before the run.
TEST(MapPipeline, SnakeStripUnderASmallBoundaryDeformationSucceeds) {
  const int cells = 20;
  TestMesh m;
  m.name = "snake";
  for (int i = 0; i <= cells; ++i) m.vertices.push_back({double(i), 0, 0});  // bottom: 0 .. cells
  for (int i = 0; i <= cells; ++i) m.vertices.push_back({double(i), 1, 0});  // top: cells + 1 ..
  auto bot = [](int i) { return i; };
  auto top = [&](int i) { return cells + 1 + i; };
  for (int i = 0; i < cells; ++i) {
    m.faces.push_back({bot(i), bot(i + 1), top(i + 1)});
    m.faces.push_back({bot(i), top(i + 1), top(i)});
  }
  m.loop = boundary_loop_of(m.faces, m.vertices.size());
  ASSERT_EQ(m.loop.size(), std::size_t(2 * cells + 2));
  // Snake: centre line along a sine, the strip's normal offset; then the inner side of each bend pushed
  // along the strip by a fraction of a cell.
  auto centre = [&](double s) { return Point2{s, 3.0 * std::sin(s * 2 * M_PI / 8)}; };
  auto normal = [&](double s) {
    const double dy = 3.0 * 2 * M_PI / 8 * std::cos(s * 2 * M_PI / 8);
    const double len = std::hypot(1.0, dy);
    return Point2{-dy / len, 1 / len};
  };
  std::vector<Point2> image(m.vertices.size());
  for (int i = 0; i <= cells; ++i) {
    const double s = i;
    const Point2 c = centre(s), nrm = normal(s);
    image[bot(i)] = {c.x - 0.5 * nrm.x, c.y - 0.5 * nrm.y};
    // The deformation: the top row slides by 0.45 cells along the strip (less than half a cell).
    const double slide = 0.45;
    const Point2 c2 = centre(s + slide), n2 = normal(s + slide);
    image[top(i)] = {c2.x + 0.5 * n2.x, c2.y + 0.5 * n2.y};
  }
  targetgen::Target t;
  t.kind = Kind::c_shape;
  for (int v : m.loop) t.positions.push_back(image[v]);
  // Certificate: the polygon is simple, and the boundary alone inverts some triangles.
  testgen::Poly poly;
  for (const Point2& p : t.positions) poly.push_back({p.x, p.y});
  std::string why;
  ASSERT_TRUE(testgen::is_simple(poly, &why)) << why;
  ASSERT_EQ(testgen::turning_number(poly), 1);
  int inverted = 0;
  for (const Triangle& f : m.faces)
    if (testgen::exact::orient({image[f[0]].x, image[f[0]].y}, {image[f[1]].x, image[f[1]].y},
                               {image[f[2]].x, image[f[2]].y}) <= 0)
      ++inverted;
  ASSERT_GT(inverted, 0) << "the deformation does not force refinement";
  t.expect = "simple";
  const ParametrizeResult r = run_and_check(m, t);
  EXPECT_GT(r.map.inserted.size(), 0u) << summary(r);
  EXPECT_EQ(r.map.flipped_before_refinement, inverted) << summary(r);

  // The same snake with an interior row (2 cells across, 21 interior-row vertices minus the ends) under the
  // same deformation of its boundary: must succeed too.
  TestMesh m2;
  m2.name = "snake2";
  const int rows = 3;
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i <= cells; ++i) m2.vertices.push_back({double(i), 0.5 * j, 0});
  auto id = [&](int i, int j) { return j * (cells + 1) + i; };
  for (int j = 0; j + 1 < rows; ++j)
    for (int i = 0; i < cells; ++i) {
      m2.faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m2.faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  m2.loop = boundary_loop_of(m2.faces, m2.vertices.size());
  targetgen::Target t2;
  t2.kind = Kind::c_shape;
  t2.expect = "simple";
  for (int v : m2.loop) {
    const int i = v % (cells + 1), j = v / (cells + 1);
    if (j == 0) t2.positions.push_back(image[bot(i)]);
    else if (j == rows - 1) t2.positions.push_back(image[top(i)]);
    else {  // the two end vertices of the middle row: halfway between the end rungs' images
      t2.positions.push_back({0.5 * (image[bot(i)].x + image[top(i)].x), 0.5 * (image[bot(i)].y + image[top(i)].y)});
    }
  }
  run_and_check(m2, t2);
}

TEST(MapPipeline, NonSelfOverlappingBoundariesAreRefused) {
  const TestMesh& m = mesh("nefertiti.off");
  const std::size_t n = m.loop.size();
  const std::vector<double> s = targetgen::detail::arc_fractions(ref(m));
  // A figure eight (turning number 0) and the clockwise circle (turning number -1).
  for (int which = 0; which < 2; ++which) {
    RawBoundary b;
    for (std::size_t k = 0; k < n; ++k) {
      const double a = 2 * M_PI * s[k];
      b.positions.push_back(which == 0 ? Point2{std::sin(a), std::sin(a) * std::cos(a)} : Point2{std::cos(a), -std::sin(a)});
    }
    try {
      parametrize(raw_of(m), b, {});
      ADD_FAILURE() << (which == 0 ? "figure eight" : "clockwise circle") << " was accepted";
    } catch (const NotSelfOverlapping& e) {
      EXPECT_EQ(e.code(), "not_self_overlapping");
      EXPECT_EQ(e.classification().verdict, Verdict::not_self_overlapping);
      EXPECT_EQ(e.classification().turning_number, which == 0 ? 0 : -1);
    }
  }
  // The weak fan without its R = 1 at the hub (all zeros prescribed): not self-overlapping for that prescription.
  std::string why;
  auto t = targetgen::make_target(Kind::weak_fan, ref(m), &why);
  ASSERT_TRUE(t) << why;
  RawBoundary b;
  b.positions = t->positions;
  b.rotation_indices = std::vector<long long>(n, 0);
  EXPECT_THROW(parametrize(raw_of(m), b, {}), NotSelfOverlapping);
}

// Paper Fig. 13, identity reproduction, on every planar mesh of the catalog. A planar mesh mapped onto its
// own boundary: the smooth dual harmonic map is exactly the identity, the discrete one is not, because h_s
// is computed on the source's triangulation and h_t on the target mesh (a CGAL quality mesh of the same
// polygon with other vertices): two discretizations of the same harmonic map. Their difference is a
// discretization error of the order of the mesh size near the boundary's sharp features, so it is measured
// in units of the source's mean boundary edge length h. Tolerances: mean displacement < 0.1 h, max < h
// (measured, mean / max: swirl_blob 0.043 h / 0.35 h, swirl_domain 0.029 h / 0.22 h, maze_corridor
// 0.011 h / 0.17 h, wiggly_strip 0.0032 h / 0.036 h; the margin covers other target-mesh densities and
// solver round-off, not a different algorithm). Tutte weights are not a discretization of anything smooth
// that is triangulation-independent, so the two Tutte maps disagree much more (measured mean: 1.08 h,
// 2.6 h, 0.085 h, 0.27 h): its mean displacement must be at least twice and its maximum larger than the
// harmonic one.
struct Displacement {
  double max = 0, mean = 0;
};

Displacement displacement(const TestMesh& m, const ParametrizeResult& r, bool mirrored) {
  double h = 0;
  for (std::size_t k = 0; k < m.loop.size(); ++k) {
    const Point3 &a = m.vertices[m.loop[k]], &b = m.vertices[m.loop[(k + 1) % m.loop.size()]];
    h += std::hypot(b.x - a.x, b.y - a.y);
  }
  h /= double(m.loop.size());
  Displacement d;
  for (std::size_t v = 0; v < m.vertices.size(); ++v) {
    const double ex = m.vertices[v].x, ey = mirrored ? -m.vertices[v].y : m.vertices[v].y;
    const double e = std::hypot(r.map.uv[v].x - ex, r.map.uv[v].y - ey) / h;
    d.max = std::max(d.max, e);
    d.mean += e;
  }
  d.mean /= double(m.vertices.size());
  return d;
}

TEST(MapPipeline, IdentityReproductionOfPlanarMeshes) {
  int planar = 0;
  for (const testmeshes::MeshEntry& e : testmeshes::catalog()) {
    if (!e.planar) continue;
    ++planar;
    const std::string file = e.file;
    const TestMesh& m = mesh(e);
    // Positions: the boundary where it is. If the faces are clockwise in the plane the boundary would be a
    // clockwise polygon (not self-overlapping): then mirror y (the identity becomes the mirror map).
    long double signed_area = 0;
    for (const Triangle& f : m.faces) {
      const Point3 &a = m.vertices[f[0]], &b = m.vertices[f[1]], &c = m.vertices[f[2]];
      signed_area += (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    }
    const bool mirrored = signed_area < 0;
    targetgen::Target t;
    t.kind = Kind::circle;
    t.expect = "simple";
    for (int v : m.loop) t.positions.push_back({m.vertices[v].x, mirrored ? -m.vertices[v].y : m.vertices[v].y});
    // The intermediate maps compared as they come: optimization would move both towards the identity.
    const ParametrizeResult harmonic = run_and_check(m, t, MapMethod::harmonic, OptimizeEnergy::none);
    const ParametrizeResult tutte = run_and_check(m, t, MapMethod::tutte, OptimizeEnergy::none);
    if (harmonic.map.uv.size() < m.vertices.size() || tutte.map.uv.size() < m.vertices.size()) continue;
    const Displacement dh = displacement(m, harmonic, mirrored), dt = displacement(m, tutte, mirrored);
    RecordProperty(std::string(file) + "_harmonic_mean", std::to_string(dh.mean));
    RecordProperty(std::string(file) + "_tutte_mean", std::to_string(dt.mean));
    std::printf("[ identity ] %s: harmonic max %.4g mean %.4g, tutte max %.4g mean %.4g (of h)\n", file.c_str(),
                dh.max, dh.mean, dt.max, dt.mean);
    EXPECT_LT(dh.mean, 0.1) << file;
    EXPECT_LT(dh.max, 1.0) << file;
    EXPECT_GT(dt.mean, 2 * dh.mean) << file << ": tutte is not farther from the identity than harmonic";
    EXPECT_GT(dt.max, dh.max) << file;
  }
  EXPECT_GE(planar, 4);
}

TEST(MapPipeline, RefineOffReturnsTheVertexWiseMapWithItsFlipsCounted) {
  const TestMesh m = fan_mesh(8);
  RawBoundary b;
  b.positions = {{0, 0}, {3, 0}, {3, 3}, {2, 3}, {2, 1}, {1, 1}, {1, 3}, {0, 3}};
  ParametrizeOptions o;
  o.refine = false;
  const ParametrizeResult r = parametrize(raw_of(m), b, o);
  EXPECT_EQ(r.map.inserted.size(), 0u);
  EXPECT_EQ(r.map.faces, m.faces);
  int non_positive = 0;
  for (const Triangle& f : r.map.faces)
    if (testgen::exact::orient({r.map.uv[f[0]].x, r.map.uv[f[0]].y}, {r.map.uv[f[1]].x, r.map.uv[f[1]].y},
                               {r.map.uv[f[2]].x, r.map.uv[f[2]].y}) <= 0)
      ++non_positive;
  EXPECT_EQ(r.flipped, non_positive);
  EXPECT_GT(non_positive, 0);
}

TEST(MapPipeline, ExplicitBoundaryVerticesStartingElsewhere) {
  // boundary.vertices given, starting at the loop's 5th vertex: positions follow that order.
  const TestMesh& m = mesh("nefertiti.off");
  const auto t = targetgen::make_target(Kind::circle, ref(m));
  ASSERT_TRUE(t);
  const std::size_t n = m.loop.size(), shift = 5;
  RawBoundary b;
  b.vertices = std::vector<long long>();
  for (std::size_t k = 0; k < n; ++k) {
    b.vertices->push_back(m.loop[(k + shift) % n]);
    b.positions.push_back(t->positions[(k + shift) % n]);
  }
  const ParametrizeResult r = parametrize(raw_of(m), b, {});
  std::vector<int> rotated(n);
  for (std::size_t k = 0; k < n; ++k) rotated[k] = m.loop[(k + shift) % n];
  EXPECT_EQ(r.boundary_loop, rotated);
  mapcheck::SourceMesh src{m.vertices, m.faces, rotated};
  const Report rep = check_map(src, b.positions, result_of(r));
  EXPECT_TRUE(rep.ok()) << rep.str();
}

}  // namespace
}  // namespace lipmap
