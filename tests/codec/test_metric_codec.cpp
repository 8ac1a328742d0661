// options.metric through the codecs (paper 5.2): JSON shapes and their errors with pointers, the glTF
// metric=texcoord:N parameter, the loader's --metric, and the glTF chart repair end to end:
//   MetricJson        "surface" / {"uv": [...]} parsed strictly, written back, engine errors' pointers
//   MetricGltf        metric=texcoord:N reads TEXCOORD_N as (s, 1 - t) for every vertex; bad specs, two
//                     metrics and a missing set are refused
//   MetricGltfRepair  a chart with flips injected, stored as TEXCOORD_0, mapped with boundary=texcoord:0 and
//                     metric=texcoord:0: the written TEXCOORD_0 has no flipped triangle in float32 (checked
//                     here with the test support's exact orientation on the stored floats), its boundary is
//                     the chart's, and Khronos's validator accepts the document
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/error.h"
#include "engine/pipeline.h"
#include "server/codec/json_codec.h"
#include "server/codec/request_loader.h"
#include "tests/codec/gltf_test_util.h"
#include "tests/support/flip_injection.h"
#include "tests/support/gltf_fixtures.h"
#include "tests/support/target_generators.h"

namespace lipmap {
namespace {

using namespace gltfcodectest;
using codec::JsonError;

std::string body_with(const std::string& metric) {
  return R"({"mesh": {"vertices": [[0,0,0],[1,0,0],[0,1,0]], "faces": [[0,1,2]]}, "boundary": {"positions": [[0,0],[1,0],[0,1]]}, "options": {"metric": )" +
         metric + "}}";
}

std::pair<std::string, std::string> json_error(const std::string& text) {
  try {
    codec::parametrize_request_from_json(codec::parse_json(text));
  } catch (const JsonError& e) {
    return {e.code(), e.pointer()};
  }
  return {"none", ""};
}

TEST(MetricJson, SurfaceAndUvAreRead) {
  EXPECT_FALSE(codec::parametrize_request_from_json(codec::parse_json(body_with(R"("surface")"))).options.metric);
  const auto r = codec::parametrize_request_from_json(codec::parse_json(body_with(R"({"uv": [[0,0],[2,0],[0,3.5]]})")));
  ASSERT_TRUE(r.options.metric);
  ASSERT_EQ(r.options.metric->size(), 3u);
  EXPECT_TRUE((*r.options.metric)[2] == (Point2{0, 3.5}));
  // Written back as it was read; the fast (SAX) reader gives the same request.
  const nlohmann::json back = codec::parametrize_request_to_json(r);
  EXPECT_EQ(back["options"]["metric"]["uv"][1], nlohmann::json::array({2.0, 0.0}));
  const auto fast = codec::parametrize_request_from_text(body_with(R"({"uv": [[0,0],[2,0],[0,3.5]]})"));
  ASSERT_TRUE(fast);
  EXPECT_TRUE(fast->options.metric && *fast->options.metric == *r.options.metric);
  EXPECT_EQ(codec::parametrize_request_to_json(
                codec::parametrize_request_from_json(codec::parse_json(body_with(R"("surface")"))))["options"]["metric"],
            "surface");
}

TEST(MetricJson, BadShapesAreRefusedWithTheirPointer) {
  EXPECT_EQ(json_error(body_with(R"("flat")")), std::make_pair(std::string("invalid_value"), std::string("/options/metric")));
  EXPECT_EQ(json_error(body_with("[[0,0],[1,0],[0,1]]")), std::make_pair(std::string("wrong_type"), std::string("/options/metric")));
  EXPECT_EQ(json_error(body_with("3")), std::make_pair(std::string("wrong_type"), std::string("/options/metric")));
  EXPECT_EQ(json_error(body_with(R"({"uv": 3})")), std::make_pair(std::string("wrong_type"), std::string("/options/metric/uv")));
  EXPECT_EQ(json_error(body_with(R"({"uv": [[0,0],[1],[0,1]]})")),
            std::make_pair(std::string("wrong_length"), std::string("/options/metric/uv/1")));
  EXPECT_EQ(json_error(body_with(R"({"uv": [[0,0],[1,"a"],[0,1]]})")),
            std::make_pair(std::string("wrong_type"), std::string("/options/metric/uv/1/1")));
  EXPECT_EQ(json_error(body_with(R"({"uv": [[0,0],[1,1e999],[0,1]]})")).first, "non_finite_number");
  EXPECT_EQ(json_error(body_with(R"({"uvs": []})")).first, "unknown_field");
  EXPECT_EQ(json_error(body_with(R"({})")), std::make_pair(std::string("missing_field"), std::string("/options/metric/uv")));
}

TEST(MetricJson, EngineErrorsPointIntoTheMetric) {
  const InputError length("metric_length_mismatch", "x", "metric");
  EXPECT_EQ(codec::parametrize_error_pointer(length), "/options/metric/uv");
  const InputError nan("metric_non_finite", "x", "metric", 4);
  EXPECT_EQ(codec::parametrize_error_pointer(nan), "/options/metric/uv/4");
  // A separate metric document (lipmap map --metric FILE): pointers relative to it.
  try {
    codec::metric_from_json(codec::parse_json(R"({"uv": [[0,0],[1]]})"));
    ADD_FAILURE() << "no error";
  } catch (const JsonError& e) {
    EXPECT_EQ(e.pointer(), "/uv/1");
  }
  EXPECT_FALSE(codec::metric_from_json(codec::parse_json(R"("surface")")));
}

// ---- glTF ---------------------------------------------------------------------------------------------

TEST(MetricGltf, TexcoordSetIsTheReferenceMap) {
  const Mesh g = grid(4);
  std::vector<Point2> chart(g.vertices.size());
  for (std::size_t v = 0; v < chart.size(); ++v) chart[v] = {0.25f + 0.5f * float(g.vertices[v].x), 0.75f - 0.5f * float(g.vertices[v].y)};
  FixtureOptions o;
  o.texcoord0 = &chart;
  const std::string in = make_gltf(g.vertices, g.faces, o, true);
  gltf::Params p;
  p.boundary = "texcoord:0";
  p.metric = "texcoord:0";
  const gltf::Request r = gltf::request_from_model(in, Format::glb, p);
  ASSERT_TRUE(r.request.options.metric);
  ASSERT_EQ(r.request.options.metric->size(), g.vertices.size());
  for (std::size_t v = 0; v < chart.size(); ++v)
    EXPECT_TRUE((*r.request.options.metric)[v] == (Point2{chart[v].x, 1.0 - chart[v].y})) << v;
  p.metric = "surface";
  EXPECT_FALSE(gltf::request_from_model(in, Format::glb, p).request.options.metric);
  p.metric = "texcoord:x";
  expect_gltf_error([&] { gltf::request_from_model(in, Format::glb, p); }, "gltf_invalid_request");
  p.metric = "uv";
  expect_gltf_error([&] { gltf::request_from_model(in, Format::glb, p); }, "gltf_invalid_request");
  p.metric = "texcoord:5";
  expect_gltf_error([&] { gltf::request_from_model(in, Format::glb, p); }, "gltf_texcoord_missing");
  // The parameter and options.metric together: refused.
  nlohmann::json envelope = {{"gltf_base64", gltf::base64_encode(in)},
                             {"boundary", "texcoord:0"},
                             {"options", {{"metric", {{"uv", nlohmann::json::array()}}}}}};
  p.metric = "texcoord:0";
  expect_gltf_error([&] { gltf::request_from_envelope(envelope, p); }, "gltf_invalid_request");
}

TEST(MetricGltfRepair, AChartWithFlipsComesBackWithoutThemInFloat32) {
  int cases = 0;
  for (const char* file : {"nefertiti.off", "swirl_blob.obj"}) {
    const Mesh& m = shared_mesh(file);
    std::vector<int> loop;
    {
      std::map<std::pair<int, int>, int> directed;
      for (const Triangle& t : m.faces)
        for (int c = 0; c < 3; ++c) ++directed[{t[c], t[(c + 1) % 3]}];
      std::map<int, int> next;
      for (const auto& [e, n] : directed)
        if (!directed.count({e.second, e.first})) next[e.first] = e.second;
      for (int v = next.begin()->first;;) {
        loop.push_back(v);
        v = next[v];
        if (v == loop.front()) break;
      }
    }
    // A locally injective chart: the certificate of a self-overlapping target (g o Tutte), in [0, 1]^2.
    const auto t = targetgen::make_target(targetgen::Kind::power_map, targetgen::DiskMeshRef{m.vertices, m.faces, loop});
    ASSERT_TRUE(t && t->certificate_on_source) << file;
    std::vector<Point2> uv = t->certificate_uv;
    double lo = 1e300, hi = -1e300;
    for (const Point2& p : uv) lo = std::min({lo, p.x, p.y}), hi = std::max({hi, p.x, p.y});
    for (Point2& p : uv) p = {(p.x - lo) / (hi - lo), (p.y - lo) / (hi - lo)};
    for (unsigned seed = 1; seed <= 3; ++seed) {
      std::vector<Point2> flipped = uv;
      // Flips injected, then stored as float32 in glTF's convention; the reference is what the file holds.
      const int folded = flipinject::inject_flips(flipped, m.faces, loop, 4 + 7 * static_cast<int>(seed), 50, seed);
      std::vector<Point2> chart(flipped.size());
      for (std::size_t v = 0; v < chart.size(); ++v) chart[v] = gltftest::texcoord_of_uv(flipped[v]);
      FixtureOptions o;
      o.texcoord0 = &chart;
      const std::string in = make_gltf(m.vertices, m.faces, o, true);
      gltf::Params p;
      p.boundary = "texcoord:0";
      p.metric = "texcoord:0";
      const gltf::Request req = gltf::request_from_model(in, Format::glb, p);
      const std::vector<Point2>& T = *req.request.options.metric;
      ASSERT_GT(flipinject::count_folded(T, m.faces), 0) << file << " seed " << seed << " (" << folded << " injected)";
      const ParametrizeResult r = parametrize(req.request.mesh, req.request.boundary, req.request.options);
      EXPECT_EQ(r.metric.reference_flipped, flipinject::count_folded(T, m.faces));
      const std::string bytes = gltf::write_answer(req.asset, r, Format::glb);
      const Asset back = Asset::read(bytes);
      const auto tc = back.attribute("TEXCOORD_0");
      ASSERT_TRUE(tc);
      std::vector<Point2> stored(tc->values.size() / 2);
      for (std::size_t v = 0; v < stored.size(); ++v) stored[v] = {tc->values[2 * v], 1.0 - tc->values[2 * v + 1]};
      std::vector<Triangle> faces;
      const RawMesh& out_mesh = back.mesh();
      for (const auto& f : out_mesh.faces) faces.push_back({int(f[0]), int(f[1]), int(f[2])});
      EXPECT_EQ(flipinject::count_folded(stored, faces), 0) << file << " seed " << seed;
      for (int v : loop) {
        EXPECT_EQ(tc->values[2 * v], chart[v].x);
        EXPECT_EQ(tc->values[2 * v + 1], chart[v].y);
      }
      // Close to the chart: the repair moves little (mean distance under 2% of the chart's size).
      EXPECT_LT(r.metric.distance.mean, 0.02) << file << " seed " << seed;
      khronos_validates({save(temp_dir("metric"), std::string(file) + std::to_string(seed) + ".glb", bytes)});
      ++cases;
    }
  }
  EXPECT_EQ(cases, 6);
}

}  // namespace
}  // namespace lipmap
