// The request loader (server/codec/request_loader.h) shared by `lipmap map` and HTTP. For many generated grid
// meshes, every form of the same request gives the engine the same mesh, boundary and options as its JSON
// form: a parametrize body (HTTP and a .json file), an OBJ file with a boundary file, a bare .glb / .gltf with
// boundary=texcoord:0 or a boundary file, the JSON envelope, and multipart parts. The expected boundary of a
// texcoord boundary is built here from the documented convention ((u, v) = (s, 1 - t) along the boundary loop,
// which the test knows from its own grid), and the glTF documents come from tests/support/gltf_fixtures.h
// (a writer that shares no code with the codec). Bad inputs give their documented codes.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "server/codec/request_loader.h"
#include "tests/support/gltf_fixtures.h"
#include "tests/support/grid_cells.h"

namespace lipmap {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

struct Grid {
  std::vector<Point3> vertices;
  std::vector<Triangle> faces;
  std::vector<int> loop;       // boundary loop, interior on the left, from vertex 0
  std::vector<Point2> texcoord;  // TEXCOORD_0 written into the glTF: floats
};

// n x n vertices on float-exact coordinates (the interior jittered on a 1/1024 grid), counterclockwise faces.
Grid grid(int n, std::mt19937& rng) {
  std::uniform_int_distribution<int> jitter(-40, 40);
  Grid g;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const bool border = i == 0 || j == 0 || i == n - 1 || j == n - 1;
      const double dx = border ? 0 : jitter(rng) / 1024.0, dy = border ? 0 : jitter(rng) / 1024.0;
      g.vertices.push_back({i * 0.25 + dx, j * 0.25 + dy, (i * j % 3) / 8.0});
      g.texcoord.push_back({gltftest::f32(0.1 + i * 0.8 / (n - 1)), gltftest::f32(0.95 - j * 0.85 / (n - 1))});
    }
  g.faces = testgen::grid_triangles(n - 1, n - 1, [](int, int) { return true; });
  g.loop = testgen::grid_boundary(n - 1, n - 1);
  return g;
}

json mesh_json(const Grid& g) {
  json m = {{"vertices", json::array()}, {"faces", json::array()}};
  for (const Point3& p : g.vertices) m["vertices"].push_back({p.x, p.y, p.z});
  for (const Triangle& t : g.faces) m["faces"].push_back({t[0], t[1], t[2]});
  return m;
}

// The boundary a texcoord:0 request means, written out as a JSON boundary object.
json texcoord_boundary_json(const Grid& g) {
  json b = {{"vertices", g.loop}, {"positions", json::array()}};
  for (int v : g.loop) b["positions"].push_back({g.texcoord[v].x, 1.0 - g.texcoord[v].y});
  return b;
}

json polygon_boundary_json(const Grid& g) {
  json b = {{"positions", json::array()}, {"rotation_indices", json::array()}};
  const std::size_t n = g.loop.size();
  for (std::size_t k = 0; k < n; ++k) {
    b["positions"].push_back({std::cos(6.283185307179586 * k / n), std::sin(6.283185307179586 * k / n)});
    b["rotation_indices"].push_back(0);
  }
  return b;
}

const json kOptions = {{"method", "tutte"}, {"refine", false}, {"target_density", 2.5}};

void expect_same(const codec::ParametrizeRequest& a, const codec::ParametrizeRequest& b, const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_EQ(a.mesh.vertices.size(), b.mesh.vertices.size());
  for (std::size_t v = 0; v < a.mesh.vertices.size(); ++v) EXPECT_TRUE(a.mesh.vertices[v] == b.mesh.vertices[v]) << v;
  EXPECT_EQ(a.mesh.faces, b.mesh.faces);
  EXPECT_EQ(a.boundary.vertices, b.boundary.vertices);
  EXPECT_EQ(a.boundary.rotation_indices, b.boundary.rotation_indices);
  ASSERT_EQ(a.boundary.positions.size(), b.boundary.positions.size());
  for (std::size_t k = 0; k < a.boundary.positions.size(); ++k)
    EXPECT_TRUE(a.boundary.positions[k] == b.boundary.positions[k]) << k;
  EXPECT_EQ(a.options.method, b.options.method);
  EXPECT_EQ(a.options.refine, b.options.refine);
  EXPECT_EQ(a.options.target_density, b.options.target_density);
}

class TempDir {
public:
  TempDir() : path_(fs::temp_directory_path() / ("lipmap_loader_" + std::to_string(::getpid()))) { fs::create_directories(path_); }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string write(const std::string& name, const std::string& bytes) const {
    const std::string file = (path_ / name).string();
    std::ofstream(file, std::ios::binary) << bytes;
    return file;
  }

private:
  fs::path path_;
};

std::string read_file(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + file);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::string obj_text(const Grid& g) {
  std::string out;
  char line[128];
  for (const Point3& p : g.vertices) {
    std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", p.x, p.y, p.z);
    out += line;
  }
  for (const Triangle& t : g.faces) out += "f " + std::to_string(t[0] + 1) + " " + std::to_string(t[1] + 1) + " " + std::to_string(t[2] + 1) + "\n";
  return out;
}

codec::LoadedRequest http(const std::string& body, const std::string& media_type, const gltf::Params& params = {}) {
  codec::RequestInput in;
  in.body = body;
  in.media_type = media_type;
  in.gltf_params = params;
  return codec::load_request(in);
}

codec::LoadedRequest cli(const std::string& file, const std::string& boundary_file = {}) {
  codec::RequestInput in;
  in.file = file;
  in.read_file = read_file;
  in.boundary_file = boundary_file;
  return codec::load_request(in);
}

TEST(RequestLoader, EveryFormGivesTheSameRequestAsItsJsonForm) {
  std::mt19937 rng(7);
  const TempDir dir;
  for (int c = 0; c < 12; ++c) {
    const Grid g = grid(3 + c % 5, rng);
    SCOPED_TRACE("grid " + std::to_string(c));
    gltftest::FixtureOptions fo;
    fo.texcoord0 = &g.texcoord;
    const std::string glb = gltftest::make_gltf(g.vertices, g.faces, fo, true);
    const std::string gltf_json = gltftest::make_gltf(g.vertices, g.faces, fo, false);

    // Polygon boundary with options: the JSON body is the reference.
    const json body = {{"mesh", mesh_json(g)}, {"boundary", polygon_boundary_json(g)}, {"options", kOptions}};
    const codec::LoadedRequest ref = http(body.dump(), "application/json; charset=utf-8");
    EXPECT_EQ(ref.form, codec::RequestForm::parametrize_json);
    EXPECT_FALSE(ref.asset);
    EXPECT_EQ(ref.request.options.method, MapMethod::tutte);

    expect_same(cli(dir.write("req.json", body.dump())).request, ref.request, "JSON file");
    const json envelope = {{"gltf_base64", gltftest::base64(glb)}, {"boundary", polygon_boundary_json(g)}, {"options", kOptions}};
    const codec::LoadedRequest env = http(envelope.dump(), "application/json");
    EXPECT_EQ(env.form, codec::RequestForm::gltf_envelope);
    EXPECT_TRUE(env.asset);
    expect_same(env.request, ref.request, "envelope");
    codec::RequestInput multipart;
    multipart.media_type = "multipart/form-data; boundary=x";
    multipart.parts["model"] = {gltf_json, "model/gltf+json"};
    multipart.parts["boundary"] = {polygon_boundary_json(g).dump(), "application/json"};
    multipart.parts["options"] = {kOptions.dump(), "application/json"};
    const codec::LoadedRequest mp = codec::load_request(multipart);
    EXPECT_EQ(mp.form, codec::RequestForm::multipart);
    expect_same(mp.request, ref.request, "multipart");

    // Default options: files with a boundary document, and the same through overrides.
    const json plain = {{"mesh", mesh_json(g)}, {"boundary", polygon_boundary_json(g)}};
    const codec::LoadedRequest plain_ref = http(plain.dump(), "application/json");
    const std::string boundary_file = dir.write("boundary.json", polygon_boundary_json(g).dump());
    const codec::LoadedRequest obj = cli(dir.write("mesh.obj", obj_text(g)), boundary_file);
    EXPECT_EQ(obj.form, codec::RequestForm::mesh_file);
    expect_same(obj.request, plain_ref.request, "OBJ file + boundary file");
    expect_same(cli(dir.write("mesh.glb", glb), boundary_file).request, plain_ref.request, ".glb file + boundary file");
    // A .json body whose boundary the boundary file replaces.
    const json other = {{"mesh", mesh_json(g)}, {"boundary", texcoord_boundary_json(g)}};
    expect_same(cli(dir.write("other.json", other.dump()), boundary_file).request, plain_ref.request, ".json + boundary file");
    codec::RequestInput overridden;
    overridden.file = dir.write("plain.json", plain.dump());
    overridden.read_file = read_file;
    overridden.overrides = {MapMethod::tutte, false, 2.5, {}, {}, {}, {}};
    expect_same(codec::load_request(overridden).request, ref.request, "overrides");

    // boundary=texcoord:0: the documented convention, written out as JSON.
    const json tc = {{"mesh", mesh_json(g)}, {"boundary", texcoord_boundary_json(g)}};
    const codec::LoadedRequest tc_ref = http(tc.dump(), "application/json");
    gltf::Params params;
    params.boundary = "texcoord:0";
    const codec::LoadedRequest bare = http(glb, "model/gltf-binary", params);
    EXPECT_EQ(bare.form, codec::RequestForm::gltf_model);
    EXPECT_EQ(bare.texcoord_set, 0);
    expect_same(bare.request, tc_ref.request, "bare .glb, texcoord:0");
    expect_same(http(gltf_json, "model/gltf+json", params).request, tc_ref.request, "bare .gltf, texcoord:0");
    expect_same(cli(dir.write("mesh.gltf", gltf_json), "texcoord:0").request, tc_ref.request, ".gltf file, texcoord:0");
    const json tc_envelope = {{"gltf_base64", gltftest::base64(glb)}, {"boundary", "texcoord:0"}};
    expect_same(http(tc_envelope.dump(), "application/json").request, tc_ref.request, "envelope, texcoord:0");
    if (HasFailure()) break;
  }
}

// The code of the InputError `load` throws ("" when none), and its message.
std::pair<std::string, std::string> error_of(const std::function<void()>& load) {
  try {
    load();
  } catch (const InputError& e) {
    return {e.code(), e.what()};
  }
  return {};
}

TEST(RequestLoader, BadInputsGiveTheirDocumentedCodes) {
  std::mt19937 rng(11);
  const Grid g = grid(4, rng);
  const TempDir dir;
  gltftest::FixtureOptions fo;
  fo.texcoord0 = &g.texcoord;
  const std::string glb = gltftest::make_gltf(g.vertices, g.faces, fo, true);

  codec::RequestInput text;
  text.media_type = "text/plain";
  EXPECT_FALSE(codec::request_form(text));  // the caller's to refuse (HTTP: 415)
  EXPECT_THROW(codec::load_request(text), InternalError);
  EXPECT_EQ(error_of([&] { http("{", "application/json"); }).first, "invalid_json");
  // A named file's JSON errors name the file, then the pointer.
  const std::string broken = dir.write("broken.json", "{\"mesh\": 3}");
  const auto [code, message] = error_of([&] { cli(broken); });
  EXPECT_EQ(code, "wrong_type");
  EXPECT_EQ(message.rfind(broken + ": /mesh: ", 0), 0u) << message;
  const std::string bad_boundary = dir.write("bad_boundary.json", "{\"positions\": 1}");
  const auto [bcode, bmessage] = error_of([&] { cli(dir.write("m.obj", obj_text(g)), bad_boundary); });
  EXPECT_EQ(bcode, "wrong_type");
  EXPECT_EQ(bmessage.rfind(bad_boundary + ": /positions: ", 0), 0u) << bmessage;
  // glTF: no boundary, a missing TEXCOORD set, texcoord:N without glTF, bad base64, not a glTF at all.
  EXPECT_EQ(error_of([&] { http(glb, "model/gltf-binary"); }).first, "gltf_invalid_request");
  gltf::Params tc1;
  tc1.boundary = "texcoord:1";
  fo.texcoord1 = false;
  EXPECT_EQ(error_of([&] { http(gltftest::make_gltf(g.vertices, g.faces, fo, true), "model/gltf-binary", tc1); }).first,
            "gltf_texcoord_missing");
  EXPECT_EQ(error_of([&] { cli(dir.write("m2.obj", obj_text(g)), "texcoord:0"); }).first, "gltf_invalid_request");
  EXPECT_EQ(error_of([&] { http(R"({"gltf_base64": "!!!", "boundary": "texcoord:0"})", "application/json"); }).first,
            "gltf_invalid_base64");
  EXPECT_EQ(error_of([&] { cli(dir.write("x.glb", "not a glb"), "texcoord:0"); }).first, "gltf_bad_magic");
  EXPECT_EQ(error_of([&] { cli(dir.write("x.xyz", "v 0 0 0\n"), dir.write("b.json", "{\"positions\": []}")); }).first,
            "mesh_file_unreadable");
}

}  // namespace
}  // namespace lipmap
