// Reading glTF (server/codec/gltf_codec.h):
//   GltfFormat     media types, extensions, sniffing, Accept negotiation, base64
//   GltfRead       test meshes converted to .glb/.gltf at test time (tests/support/gltf_fixtures.h, a writer
//                  independent of the codec) read back exactly; weld; texcoord boundaries
//   GltfBad        every bad input refused with its code (truncated, magic, buffer out of range, accessor
//                  mismatch, no triangles, non-disk, modes, ...)
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

// ---- GltfFormat ---------------------------------------------------------------------------------------

TEST(GltfFormat, MediaTypesExtensionsAndSniffing) {
  EXPECT_EQ(gltf::format_from_media_type("model/gltf-binary"), Format::glb);
  EXPECT_EQ(gltf::format_from_media_type("Model/GLTF+JSON; charset=utf-8"), Format::gltf);
  EXPECT_EQ(gltf::format_from_media_type("application/json"), std::nullopt);
  EXPECT_EQ(gltf::format_from_path("a/b/Out.GLB"), Format::glb);
  EXPECT_EQ(gltf::format_from_path("x.gltf"), Format::gltf);
  EXPECT_EQ(gltf::format_from_path("x.obj"), std::nullopt);
  EXPECT_EQ(gltf::sniff_format("glTF\x02"), Format::glb);
  EXPECT_EQ(gltf::sniff_format("  \n{\"asset\":{}}"), Format::gltf);
  EXPECT_EQ(gltf::sniff_format("PK\x03\x04"), std::nullopt);
  EXPECT_STREQ(gltf::media_type(Format::glb), "model/gltf-binary");
  EXPECT_STREQ(gltf::media_type(Format::gltf), "model/gltf+json");
}

TEST(GltfFormat, AcceptNegotiation) {
  EXPECT_EQ(gltf::accepted_format(""), std::nullopt);
  EXPECT_EQ(gltf::accepted_format("*/*"), std::nullopt);
  EXPECT_EQ(gltf::accepted_format("application/json"), std::nullopt);
  EXPECT_EQ(gltf::accepted_format("model/gltf-binary"), Format::glb);
  EXPECT_EQ(gltf::accepted_format("model/gltf+json"), Format::gltf);
  EXPECT_EQ(gltf::accepted_format("application/json;q=0.5, model/gltf-binary"), Format::glb);
  EXPECT_EQ(gltf::accepted_format("model/gltf-binary;q=0.4, application/json;q=0.9"), std::nullopt);
  EXPECT_EQ(gltf::accepted_format("model/gltf+json, model/gltf-binary"), Format::gltf);
  EXPECT_EQ(gltf::accepted_format("text/html, model/gltf-binary;q=0"), std::nullopt);
}

TEST(GltfFormat, Base64RoundTripAndErrors) {
  for (const std::string& s : std::vector<std::string>{"", "a", "ab", "abc", "abcd", std::string("\0\xff\x10 glTF", 9)})
    EXPECT_EQ(gltf::base64_decode(gltf::base64_encode(s)), s);
  EXPECT_EQ(gltf::base64_encode("glTF"), "Z2xURg==");
  EXPECT_EQ(gltf::base64_decode("Z2xU\nRg=="), "glTF");
  expect_gltf_error([] { gltf::base64_decode("Z2x*Rg=="); }, "gltf_invalid_base64");
  expect_gltf_error([] { gltf::base64_decode("Z"); }, "gltf_invalid_base64");
}

// ---- GltfRead ------------------------------------------------------------------------------------------

TEST(GltfRead, TestMeshesAsGlbAndGltfReadBackExactly) {
  for (const char* file : {"nefertiti.off", "swirl_blob.obj", "blob.off", "cut_bowl.obj"}) {
    const Mesh& m = shared_mesh(file);
    for (bool binary : {true, false}) {
      const Asset a = Asset::read(make_gltf(m.vertices, m.faces, {}, binary));
      EXPECT_EQ(a.format(), binary ? Format::glb : Format::gltf);
      ASSERT_EQ(a.mesh().vertices.size(), m.vertices.size()) << file;
      for (std::size_t v = 0; v < m.vertices.size(); ++v) ASSERT_EQ(a.mesh().vertices[v], m.vertices[v]) << file << " vertex " << v;
      ASSERT_EQ(a.mesh().faces.size(), m.faces.size());
      for (std::size_t f = 0; f < m.faces.size(); ++f)
        ASSERT_EQ(a.mesh().faces[f], (std::vector<long long>{m.faces[f][0], m.faces[f][1], m.faces[f][2]}));
      EXPECT_EQ(a.primitive_vertices(), m.vertices.size());
      EXPECT_EQ(a.unused_vertices(), 0u);
      EXPECT_FALSE(a.boundary_loop().empty());
      EXPECT_EQ(a.attribute_names(), (std::vector<std::string>{"COLOR_0", "NORMAL", "POSITION", "TEXCOORD_0", "TEXCOORD_1"}));
      EXPECT_EQ(a.attribute("NORMAL")->components, 3);
      EXPECT_EQ(a.attribute("COLOR_0")->components, 4);
      EXPECT_FALSE(a.attribute("TANGENT").has_value());
    }
  }
}

TEST(GltfRead, SeamsAreRefusedWithTheValidateCodeUnlessWelded) {
  const Mesh& m = shared_mesh("nefertiti.off");
  FixtureOptions o;
  o.split_seam = true;
  const std::string glb = make_gltf(m.vertices, m.faces, o, true);
  try {
    Asset::read(glb);
    ADD_FAILURE() << "a primitive split at a seam was read as a disk";
  } catch (const GltfError& e) {
    ADD_FAILURE() << "GltfError " << e.code() << " instead of the validate stage's code: " << e.what();
  } catch (const InputError& e) {
    EXPECT_TRUE(e.code() == "not_connected" || e.code() == "multiple_boundary_loops" || e.code() == "not_a_disk" ||
                e.code() == "non_manifold_vertex")
        << e.code() << ": " << e.what();
    EXPECT_NE(std::string(e.what()).find("weld=position"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("mesh 0 primitive 0"), std::string::npos) << e.what();
  }
  gltf::Selection s;
  s.weld = gltf::Weld::position;
  const Asset a = Asset::read(glb, s);
  EXPECT_GT(a.welded_vertices(), 0u);
  ASSERT_EQ(a.mesh().vertices.size(), m.vertices.size());
  for (std::size_t v = 0; v < m.vertices.size(); ++v) EXPECT_EQ(a.mesh().vertices[v], m.vertices[v]);
  for (std::size_t f = 0; f < m.faces.size(); ++f)
    EXPECT_EQ(a.mesh().faces[f], (std::vector<long long>{m.faces[f][0], m.faces[f][1], m.faces[f][2]}));
  // Each welded vertex keeps the attributes of its lowest-index copy (the original here).
  EXPECT_EQ(a.source_vertex()[5], 5);
}

TEST(GltfRead, NonIndexedPrimitivesNeedWeld) {
  const Mesh& m = shared_mesh("blob.off");
  FixtureOptions o;
  o.indexed = false;
  const std::string gltf_text = make_gltf(m.vertices, m.faces, o, false);
  try {
    Asset::read(gltf_text);
    ADD_FAILURE() << "a triangle soup was read as a disk";
  } catch (const GltfError& e) {
    ADD_FAILURE() << e.code() << ": " << e.what();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("weld=position"), std::string::npos) << e.what();
  }
  gltf::Selection s;
  s.weld = gltf::Weld::position;
  const Asset a = Asset::read(gltf_text, s);
  EXPECT_EQ(a.mesh().vertices.size(), m.vertices.size());
  EXPECT_EQ(a.primitive_vertices(), 3 * m.faces.size());
}

TEST(GltfRead, TexcoordBoundaryIsTheStoredChartInLipmapsConvention) {
  const Mesh& m = shared_mesh("nefertiti.off");
  std::vector<Point2> st;
  for (const Point3& p : m.vertices) st.push_back({gltftest::f32((0.01 * p.x)), gltftest::f32((0.25 - 0.01 * p.y))});
  FixtureOptions o;
  o.texcoord0 = &st;
  const Asset a = Asset::read(make_gltf(m.vertices, m.faces, o, true));
  const RawBoundary b = a.texcoord_boundary(0);
  ASSERT_TRUE(b.vertices.has_value());
  ASSERT_EQ(b.vertices->size(), a.boundary_loop().size());
  for (std::size_t k = 0; k < b.positions.size(); ++k) {
    const int v = a.boundary_loop()[k];
    EXPECT_EQ((*b.vertices)[k], v);
    EXPECT_EQ(b.positions[k].x, st[v].x) << std::setprecision(17) << b.positions[k].x << " " << st[v].x << " v " << v;
    EXPECT_EQ(b.positions[k].y, 1.0 - st[v].y);
    // Stored back, it is the same float.
    EXPECT_EQ(float(1.0 - b.positions[k].y), float(st[v].y));
  }
  const std::string what = expect_gltf_error([&] { a.texcoord_boundary(3); }, "gltf_texcoord_missing");
  EXPECT_NE(what.find("TEXCOORD_0, TEXCOORD_1"), std::string::npos) << what;
}

// Bad documents: each refused with a GltfError naming what is wrong.
class GltfBad : public testing::Test {
protected:
  void SetUp() override {
    const Mesh& m = shared_mesh("blob.off");
    glb = make_gltf(m.vertices, m.faces, {}, true);
    doc = json::parse(make_gltf(m.vertices, m.faces, {}, false));
  }
  std::string glb;
  json doc;
};

TEST_F(GltfBad, TruncatedGlb) {
  for (std::size_t keep : {std::size_t(0), std::size_t(3), std::size_t(11), std::size_t(19), glb.size() / 2, glb.size() - 1}) {
    const std::string what = expect_gltf_error([&] { Asset::read(glb.substr(0, keep), {}, Format::glb); },
                                               keep < 4 ? "gltf_bad_magic" : "gltf_truncated");
    EXPECT_FALSE(what.empty());
  }
  const std::string what = expect_gltf_error([&] { Asset::read(glb.substr(0, glb.size() - 8)); }, "gltf_truncated");
  EXPECT_NE(what.find("declares"), std::string::npos) << what;
}

TEST_F(GltfBad, WrongMagicAndVersion) {
  std::string bad = glb;
  bad[0] = 'X';
  const std::string what = expect_gltf_error([&] { Asset::read(bad, {}, Format::glb); }, "gltf_bad_magic");
  EXPECT_NE(what.find("58 6c 54 46"), std::string::npos) << what;
  expect_gltf_error([&] { Asset::read(bad); }, "gltf_bad_magic");
  expect_gltf_error([&] { Asset::read("PK\x03\x04 not a model"); }, "gltf_bad_magic");
  std::string v1 = glb;
  v1[4] = 1;
  expect_gltf_error([&] { Asset::read(v1); }, "gltf_unsupported_version");
  json d = doc;
  d["asset"]["version"] = "1.0";
  expect_gltf_error([&] { Asset::read(d.dump()); }, "gltf_unsupported_version");
  expect_gltf_error([&] { Asset::read(doc.dump(), {}, Format::glb); }, "gltf_bad_magic");
  expect_gltf_error([&] { Asset::read(glb, {}, Format::gltf); }, "gltf_invalid_json");
  expect_gltf_error([&] { Asset::read("{\"asset\": {\"version\": \"2.0\"}, "); }, "gltf_invalid_json");
}

TEST_F(GltfBad, BufferOutOfRange) {
  json d = doc;
  const int view = d["accessors"][d["meshes"][0]["primitives"][0]["attributes"]["POSITION"].get<int>()]["bufferView"];
  d["bufferViews"][view]["byteOffset"] = d["buffers"][0]["byteLength"].get<int>() - 8;
  GltfError* unused = nullptr;
  (void)unused;
  try {
    Asset::read(d.dump());
    ADD_FAILURE() << "no error";
  } catch (const GltfError& e) {
    // tinygltf may notice first (gltf_invalid); either way the message names the bufferView.
    EXPECT_TRUE(e.code() == "gltf_buffer_out_of_range" || e.code() == "gltf_invalid") << e.code() << ": " << e.what();
    if (e.code() == "gltf_buffer_out_of_range") EXPECT_EQ(e.gltf_pointer(), "/bufferViews/" + std::to_string(view));
    EXPECT_EQ(codec::error_info(e.code()).status, 400);  // not a well-formed glTF
  }
  // An accessor reaching past its bufferView.
  json d2 = doc;
  const int acc = d2["meshes"][0]["primitives"][0]["attributes"]["NORMAL"];
  d2["accessors"][acc]["byteOffset"] = 4;
  const std::string what = expect_gltf_error([&] { Asset::read(d2.dump()); }, "gltf_buffer_out_of_range");
  EXPECT_NE(what.find("NORMAL"), std::string::npos) << what;
  // And the same in a .glb.
  json d3 = gltftest::document_json(glb);
  d3["accessors"][acc]["count"] = d3["accessors"][acc]["count"].get<int>() + 1;
  expect_gltf_error([&] { Asset::read(gltftest::replace_glb_json(glb, d3)); }, "gltf_buffer_out_of_range");
}

TEST_F(GltfBad, AccessorTypeMismatch) {
  json d = doc;
  const int pos = d["meshes"][0]["primitives"][0]["attributes"]["POSITION"];
  d["accessors"][pos]["type"] = "VEC2";
  std::string what = expect_gltf_error([&] { Asset::read(d.dump()); }, "gltf_accessor_mismatch");
  EXPECT_NE(what.find("POSITION"), std::string::npos) << what;
  EXPECT_NE(what.find("VEC2"), std::string::npos) << what;
  json d2 = doc;
  const int idx = d2["meshes"][0]["primitives"][0]["indices"];
  d2["accessors"][idx]["componentType"] = 5126;
  what = expect_gltf_error([&] { Asset::read(d2.dump()); }, "gltf_accessor_mismatch");
  EXPECT_NE(what.find("indices"), std::string::npos) << what;
  json d3 = doc;
  d3["accessors"][d3["meshes"][0]["primitives"][0]["attributes"]["NORMAL"].get<int>()]["type"] = "VEC4";
  expect_gltf_error([&] { Asset::read(d3.dump()); }, "gltf_accessor_mismatch");
}

TEST_F(GltfBad, NoTrianglesAndIndexProblems) {
  json d = doc;
  const int idx = d["meshes"][0]["primitives"][0]["indices"];
  d["accessors"][idx]["count"] = 2;
  std::string what = expect_gltf_error([&] { Asset::read(d.dump()); }, "gltf_no_triangles");
  EXPECT_NE(what.find("no triangle"), std::string::npos) << what;
  d["accessors"][idx]["count"] = 7;
  expect_gltf_error([&] { Asset::read(d.dump()); }, "gltf_index_count");
  json d2 = doc;
  const int pos = d2["meshes"][0]["primitives"][0]["attributes"]["POSITION"];
  for (auto& [name, a] : d2["meshes"][0]["primitives"][0]["attributes"].items()) {
    (void)name;
    d2["accessors"][a.get<int>()]["count"] = 10;
  }
  d2["accessors"][pos].erase("min");
  d2["accessors"][pos].erase("max");
  expect_gltf_error([&] { Asset::read(d2.dump()); }, "gltf_index_out_of_range");
  json d3 = doc;
  d3["meshes"][0]["primitives"][0]["attributes"].erase("POSITION");
  expect_gltf_error([&] { Asset::read(d3.dump()); }, "gltf_no_position");
}

TEST_F(GltfBad, ModesOtherThanTrianglesAreNamed) {
  const std::pair<int, const char*> modes[] = {{0, "POINTS"}, {1, "LINES"}, {2, "LINE_LOOP"}, {3, "LINE_STRIP"},
                                               {5, "TRIANGLE_STRIP"}, {6, "TRIANGLE_FAN"}};
  for (const auto& [mode, name] : modes) {
    json d = doc;
    d["meshes"][0]["primitives"][0]["mode"] = mode;
    const std::string what = expect_gltf_error([&] { Asset::read(d.dump()); }, "gltf_unsupported_mode");
    EXPECT_NE(what.find(name), std::string::npos) << what;
  }
  json d = doc;
  d["meshes"][0]["primitives"][0]["mode"] = 4;
  EXPECT_NO_THROW(Asset::read(d.dump()));
}

TEST_F(GltfBad, SelectionExternalFilesAndCompression) {
  gltf::Selection s;
  s.mesh = 7;
  expect_gltf_error([&] { Asset::read(glb, s); }, "gltf_mesh_not_found");
  s.mesh = 0;
  s.primitive = 1;
  expect_gltf_error([&] { Asset::read(glb, s); }, "gltf_primitive_not_found");
  s.mesh = 1;  // the fixture's second mesh: one triangle, a disk
  s.primitive = 0;
  EXPECT_EQ(Asset::read(glb, s).mesh().faces.size(), 1u);
  json d = doc;
  d["buffers"][0]["uri"] = "../../etc/passwd";
  std::string what = expect_gltf_error([&] { Asset::read(d.dump()); }, "gltf_external_uri");
  EXPECT_NE(what.find("passwd"), std::string::npos);
  json d2 = doc;
  d2["extensionsUsed"] = {"KHR_draco_mesh_compression"};
  expect_gltf_error([&] { Asset::read(d2.dump()); }, "gltf_unsupported_extension");
  json d3 = doc;
  d3["meshes"].clear();
  d3["nodes"] = json::array();
  d3["scenes"] = {{{"nodes", json::array()}}};
  expect_gltf_error([&] { Asset::read(d3.dump()); }, "gltf_mesh_not_found");
}

TEST_F(GltfBad, NonDiskPrimitivesGetTheValidateCode) {
  // The invalid shared meshes, as glTF.
  const std::pair<const char*, const char*> cases[] = {{"invalid/holes.off", "multiple_boundary_loops"},
                                                       {"invalid/blob-closed.off", "no_boundary"},
                                                       {"invalid/punctured-torus.obj", "not_a_disk"}};
  for (const auto& [file, code] : cases) {
    const Mesh& m = shared_mesh(file);
    try {
      Asset::read(make_gltf(m.vertices, m.faces, {}, true));
      ADD_FAILURE() << file << " read as a disk";
    } catch (const GltfError& e) {
      ADD_FAILURE() << file << ": GltfError " << e.code() << ": " << e.what();
    } catch (const InputError& e) {
      EXPECT_EQ(e.code(), code) << file << ": " << e.what();
      EXPECT_EQ(std::string(e.what()).rfind("mesh 0 primitive 0: ", 0), 0u) << e.what();
    }
  }
}

}  // namespace
}  // namespace lipmap
