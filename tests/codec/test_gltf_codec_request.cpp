// glTF requests (server/codec/gltf_codec.h):
//   GltfRequest    the HTTP/CLI request forms (bare model + texcoord:N, JSON envelope, multipart parts)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include <iomanip>

#include <gtest/gtest.h>

#include "engine/error.h"
#include "engine/flip_check.h"
#include "engine/mesh_io.h"
#include "engine/refine.h"
#include "server/codec/error_table.h"
#include "server/codec/gltf_codec.h"
#include "server/codec/json_codec.h"
#include "tests/support/gltf_fixtures.h"
#include "tests/support/map_checker.h"
#include "tests/support/target_generators.h"
#include "tests/codec/gltf_test_util.h"

namespace lipmap {
namespace {

using namespace gltfcodectest;

// ---- GltfRequest --------------------------------------------------------------------------------------

TEST(GltfRequest, BareModelNeedsTexcoordBoundary) {
  const Mesh& m = shared_mesh("nefertiti.off");
  std::vector<Point2> st;
  for (const Point3& p : m.vertices) st.push_back({p.x, p.y});
  FixtureOptions o;
  o.texcoord0 = &st;
  const std::string glb = make_gltf(m.vertices, m.faces, o, true);
  gltf::Params params;
  expect_gltf_error([&] { gltf::request_from_model(glb, Format::glb, params); }, "gltf_invalid_request");
  params.boundary = "texcoord:0";
  const gltf::Request r = gltf::request_from_model(glb, Format::glb, params);
  EXPECT_EQ(r.texcoord_set, 0);
  EXPECT_EQ(r.request.mesh.vertices.size(), m.vertices.size());
  EXPECT_EQ(r.request.boundary.positions.size(), r.asset.boundary_loop().size());
  params.boundary = "texcoord:x";
  expect_gltf_error([&] { gltf::request_from_model(glb, Format::glb, params); }, "gltf_invalid_request");
  params.boundary = "texcoord:0";
  params.weld = "sometimes";
  expect_gltf_error([&] { gltf::request_from_model(glb, Format::glb, params); }, "gltf_invalid_request");
  params.weld = "none";
  params.mesh = "-1";
  expect_gltf_error([&] { gltf::request_from_model(glb, Format::glb, params); }, "gltf_invalid_request");
}

TEST(GltfRequest, EnvelopeAndMultipart) {
  const Mesh& m = shared_mesh("blob.off");
  const std::string glb = make_gltf(m.vertices, m.faces, {}, true);
  const Asset a = Asset::read(glb);
  json boundary = {{"positions", json::array()}};
  for (std::size_t k = 0; k < a.boundary_loop().size(); ++k)
    boundary["positions"].push_back({std::cos(6.283185307179586 * k / a.boundary_loop().size()),
                                     std::sin(6.283185307179586 * k / a.boundary_loop().size())});
  json env = {{"gltf_base64", gltf::base64_encode(glb)}, {"boundary", boundary}, {"options", {{"method", "tutte"}}}};
  EXPECT_TRUE(gltf::is_envelope(env));
  gltf::Request r = gltf::request_from_envelope(env, {});
  EXPECT_EQ(r.request.boundary.positions.size(), 4u);
  EXPECT_EQ(r.request.options.method, lipmap::MapMethod::tutte);
  EXPECT_EQ(r.request.mesh.faces.size(), m.faces.size());
  // Shape errors keep their JSON pointers.
  json bad = env;
  bad["boundary"]["positions"][1] = {1, "0"};
  try {
    gltf::request_from_envelope(bad, {});
    ADD_FAILURE();
  } catch (const codec::JsonError& e) {
    EXPECT_EQ(e.pointer(), "/boundary/positions/1/1");
  }
  bad = env;
  bad["gltf_bas64"] = 1;
  EXPECT_THROW(gltf::request_from_envelope(bad, {}), codec::JsonError);
  bad = env;
  bad["gltf_base64"] = "@@@@";
  expect_gltf_error([&] { gltf::request_from_envelope(bad, {}); }, "gltf_invalid_base64");
  bad = env;
  bad["mesh"] = 0;
  gltf::Params p;
  p.mesh = "1";
  expect_gltf_error([&] { gltf::request_from_envelope(bad, p); }, "gltf_invalid_request");
  bad = env;
  bad.erase("boundary");
  expect_gltf_error([&] { gltf::request_from_envelope(bad, {}); }, "gltf_invalid_request");
  // Multipart.
  std::map<std::string, gltf::Part> parts = {{"model", {glb, "model/gltf-binary"}}, {"boundary", {boundary.dump(), "application/json"}}};
  r = gltf::request_from_parts(parts, {});
  EXPECT_EQ(r.request.boundary.positions.size(), 4u);
  parts["options"] = {"{\"refine\": 7}", "application/json"};
  try {
    gltf::request_from_parts(parts, {});
    ADD_FAILURE();
  } catch (const codec::JsonError& e) {
    EXPECT_EQ(e.pointer(), "/options/refine");
  }
  parts.erase("options");
  parts["model"].content_type = "model/gltf+json";
  expect_gltf_error([&] { gltf::request_from_parts(parts, {}); }, "gltf_invalid_json");
  parts.erase("model");
  expect_gltf_error([&] { gltf::request_from_parts(parts, {}); }, "gltf_invalid_request");
  // A well-formed glTF whose primitive cannot be mapped is 422; bytes that are no glTF are 400.
  EXPECT_EQ(codec::error_info("gltf_unsupported_mode").status, 422);
  EXPECT_EQ(codec::error_info("gltf_truncated").status, 400);
}

}  // namespace
}  // namespace lipmap
