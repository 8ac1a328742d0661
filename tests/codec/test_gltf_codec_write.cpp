// Writing glTF (server/codec/gltf_codec.h):
//   GltfWrite      a hand-made RefinedMap (no engine): attributes of the inserted vertex interpolated,
//                  document kept, indices widened past 65535 vertices, float32 rounding that would flip a
//                  triangle refused
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
#include "server/codec/gltf_codec.h"
#include "server/codec/json_codec.h"
#include "tests/support/gltf_fixtures.h"
#include "tests/support/map_checker.h"
#include "tests/support/target_generators.h"
#include "tests/codec/gltf_test_util.h"

namespace lipmap {
namespace {

using namespace gltfcodectest;

// ---- GltfWrite: a hand-made refined map ---------------------------------------------------------------

struct Handmade {
  Mesh mesh;
  RefinedMap map;
  int a = 0, b = 0;
  double t = 0;
};

// The grid, uv = (x, y), and one vertex inserted on the interior diagonal (a, c) of cell (1, 1), t = 0.3.
Handmade handmade(int n = 5) {
  Handmade h;
  h.mesh = grid(n);
  const Mesh& m = h.mesh;
  h.map.vertices = m.vertices;
  for (const Point3& p : m.vertices) h.map.uv.push_back({p.x, p.y});
  const int a = n + 1, c = a + n + 1;  // cell (1, 1): faces (a, b, c) and (a, c, d)
  h.a = a;
  h.b = c;
  h.t = 0.3;
  const int p = static_cast<int>(m.vertices.size());
  const Point3 &A = m.vertices[a], &C = m.vertices[c];
  h.map.vertices.push_back({A.x + h.t * (C.x - A.x), A.y + h.t * (C.y - A.y), A.z + h.t * (C.z - A.z)});
  h.map.uv.push_back({h.map.vertices.back().x, h.map.vertices.back().y});
  h.map.inserted.push_back({a, c, h.t});
  for (const Triangle& f : m.faces) {
    if (f == Triangle{a, a + 1, c}) {
      h.map.faces.push_back({a, a + 1, p});
      h.map.faces.push_back({p, a + 1, c});
    } else if (f == Triangle{a, c, a + n}) {
      h.map.faces.push_back({a, p, a + n});
      h.map.faces.push_back({p, c, a + n});
    } else {
      h.map.faces.push_back(f);
    }
  }
  return h;
}

json inserted_extras(const RefinedMap& map) {
  json ins = json::array();
  for (const InsertedVertex& v : map.inserted) ins.push_back({{"edge", {v.a, v.b}}, {"t", v.t}});
  return {{"inserted", ins}, {"verdict", "simple"}};
}


TEST(GltfWrite, HandmadeMapKeepsTheDocumentAndInterpolatesEveryAttribute) {
  const Handmade h = handmade();
  FixtureOptions o;
  o.tangents = o.skin = o.morph = true;
  const auto dir = temp_dir("out");
  std::vector<std::string> written;
  for (bool binary_in : {true, false}) {
    const Asset in = Asset::read(make_gltf(h.mesh.vertices, h.mesh.faces, o, binary_in));
    for (Format out_format : {Format::glb, Format::gltf}) {
      const std::string bytes = in.write(h.map, inserted_extras(h.map), out_format);
      written.push_back(save(dir, std::string(binary_in ? "in_glb" : "in_gltf") + gltf::extension(out_format), bytes));
      EXPECT_EQ(gltf::sniff_format(bytes), out_format);
      const Asset out = Asset::read(bytes);
      const std::size_t nv = h.map.vertices.size();
      ASSERT_EQ(out.mesh().vertices.size(), nv);
      ASSERT_EQ(out.mesh().faces.size(), h.map.faces.size());
      for (std::size_t v = 0; v < nv; ++v) EXPECT_EQ(out.mesh().vertices[v].x, gltftest::f32((h.map.vertices[v].x)));
      for (std::size_t f = 0; f < h.map.faces.size(); ++f)
        EXPECT_EQ(out.mesh().faces[f], (std::vector<long long>{h.map.faces[f][0], h.map.faces[f][1], h.map.faces[f][2]}));
      // TEXCOORD_0 = (u, 1 - v) in float32.
      const auto tc = out.attribute("TEXCOORD_0");
      ASSERT_TRUE(tc);
      for (std::size_t v = 0; v < nv; ++v) {
        EXPECT_EQ(tc->values[2 * v], gltftest::f32((h.map.uv[v].x)));
        EXPECT_EQ(tc->values[2 * v + 1], gltftest::f32((1.0 - h.map.uv[v].y)));
      }
      const std::size_t p = nv - 1;
      const int a = h.a, b = h.b;
      const double t = h.t;
      const auto src_n = in.attribute("NORMAL"), n = out.attribute("NORMAL");
      double len = 0, expect_n[3];
      for (int i = 0; i < 3; ++i) len += std::pow(expect_n[i] = lerp(src_n->values[3 * a + i], src_n->values[3 * b + i], t), 2);
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(n->values[3 * p + i], expect_n[i] / std::sqrt(len), 1e-7);
      for (int v : {a, b})
        for (int i = 0; i < 3; ++i) EXPECT_EQ(n->values[3 * v + i], src_n->values[3 * v + i]);
      const auto src_c = in.attribute("COLOR_0"), c = out.attribute("COLOR_0");
      for (int i = 0; i < 4; ++i) EXPECT_EQ(c->values[4 * p + i], gltftest::f32((lerp(src_c->values[4 * a + i], src_c->values[4 * b + i], t))));
      const auto src_t1 = in.attribute("TEXCOORD_1"), t1 = out.attribute("TEXCOORD_1");
      for (int i = 0; i < 2; ++i) EXPECT_EQ(t1->values[2 * p + i], gltftest::f32((lerp(src_t1->values[2 * a + i], src_t1->values[2 * b + i], t))));
      const auto src_tan = in.attribute("TANGENT"), tan = out.attribute("TANGENT");
      EXPECT_EQ(tan->values[4 * p + 3], src_tan->values[4 * a + 3]);
      EXPECT_NEAR(std::hypot(tan->values[4 * p], tan->values[4 * p + 1], tan->values[4 * p + 2]), 1.0, 1e-6);
      // Skin: (a, c) = (6, 18): 6 % 3 == 0 has joints (1, 0), 18 % 3 == 0 too: slot-wise lerp.
      const auto src_j = in.attribute("JOINTS_0"), j = out.attribute("JOINTS_0");
      const auto src_w = in.attribute("WEIGHTS_0"), w = out.attribute("WEIGHTS_0");
      double sum = 0;
      for (int i = 0; i < 4; ++i) sum += w->values[4 * p + i];
      EXPECT_NEAR(sum, 1.0, 1e-6);
      if (std::equal(src_j->values.begin() + 4 * a, src_j->values.begin() + 4 * a + 4, src_j->values.begin() + 4 * b)) {
        for (int i = 0; i < 4; ++i) {
          EXPECT_EQ(j->values[4 * p + i], src_j->values[4 * a + i]);
          EXPECT_NEAR(w->values[4 * p + i], lerp(src_w->values[4 * a + i], src_w->values[4 * b + i], t), 1e-6);
        }
      }
      // The document: material, texture, second mesh, skin, morph target, extras.
      const json d = gltftest::document_json(bytes);
      EXPECT_EQ(d["materials"][0]["name"], "fixture material");
      EXPECT_EQ(d["materials"][0]["extras"]["kept"], true);
      EXPECT_EQ(d["meshes"][1]["name"], "untouched");
      EXPECT_EQ(d["nodes"][1]["translation"], json({3, 0, 0}));
      EXPECT_EQ(d["skins"].size(), 1u);
      EXPECT_EQ(d["images"].size(), 1u);
      EXPECT_EQ(d["buffers"].size(), 1u);
      const json& prim = d["meshes"][0]["primitives"][0];
      EXPECT_EQ(prim["material"], 0);
      EXPECT_EQ(prim["targets"].size(), 1u);
      EXPECT_EQ(d["accessors"][prim["indices"].get<int>()]["componentType"], 5123);  // UNSIGNED_SHORT
      EXPECT_EQ(prim["extras"]["lipmap"]["verdict"], "simple");
      EXPECT_EQ(out.primitive_extras()["lipmap"]["inserted"][0]["edge"], json({a, b}));
      const json& pos = d["accessors"][prim["attributes"]["POSITION"].get<int>()];
      EXPECT_TRUE(pos.contains("min") && pos.contains("max"));
      EXPECT_EQ(pos["count"], nv);
      // The untouched second mesh reads back as before.
      gltf::Selection s;
      s.mesh = 1;
      EXPECT_EQ(Asset::read(bytes, s).mesh().vertices[1].x, 1.0);
    }
  }
  khronos_validates(written);
}

TEST(GltfWrite, JointsOfDifferentEndpointsAreBlendedPerJoint) {
  Handmade h = handmade();
  // Move the inserted vertex to edge (a, a + 1), whose endpoints have different joint orders (6 vs 7).
  const int a = h.a, b = h.a + 1;
  const int n = 5;
  h.map = RefinedMap();
  h.map.vertices = h.mesh.vertices;
  for (const Point3& q : h.mesh.vertices) h.map.uv.push_back({q.x, q.y});
  const int p = static_cast<int>(h.mesh.vertices.size());
  const double t = 0.25;
  const Point3 &A = h.mesh.vertices[a], &B = h.mesh.vertices[b];
  h.map.vertices.push_back({A.x + t * (B.x - A.x), A.y + t * (B.y - A.y), A.z + t * (B.z - A.z)});
  h.map.uv.push_back({h.map.vertices.back().x, h.map.vertices.back().y});
  h.map.inserted.push_back({a, b, t});
  // Edge (a, b) = (6, 7) is in faces (6, 7, 12) of cell (1, 1) and (1, 7, 6)... of cell (1, 0): (a - n, b, a)?
  for (const Triangle& f : h.mesh.faces) {
    int k = -1;
    for (int c = 0; c < 3; ++c)
      if (f[c] == a && f[(c + 1) % 3] == b) k = c;
      else if (f[c] == b && f[(c + 1) % 3] == a) k = c;
    if (k < 0) {
      h.map.faces.push_back(f);
      continue;
    }
    const int u = f[k], v = f[(k + 1) % 3], w = f[(k + 2) % 3];
    h.map.faces.push_back({u, p, w});
    h.map.faces.push_back({p, v, w});
  }
  (void)n;
  FixtureOptions o;
  o.skin = true;
  const Asset in = Asset::read(make_gltf(h.mesh.vertices, h.mesh.faces, o, true));
  const std::string bytes = in.write(h.map, inserted_extras(h.map), Format::glb);
  const Asset out = Asset::read(bytes);
  const auto sj = in.attribute("JOINTS_0"), sw = in.attribute("WEIGHTS_0");
  const auto j = out.attribute("JOINTS_0"), w = out.attribute("WEIGHTS_0");
  // Per joint: (1 - t) w_a(joint) + t w_b(joint).
  std::map<int, double> expect;
  for (int i = 0; i < 4; ++i) {
    expect[int(sj->values[4 * a + i])] += (1 - t) * sw->values[4 * a + i];
    expect[int(sj->values[4 * b + i])] += t * sw->values[4 * b + i];
  }
  std::map<int, double> got;
  for (int i = 0; i < 4; ++i) got[int(j->values[4 * p + i])] += w->values[4 * p + i];
  for (int joint : {0, 1}) EXPECT_NEAR(got[joint], expect[joint], 1e-6) << "joint " << joint;
  khronos_validates({save(temp_dir("out"), "skin.glb", bytes)});
}

TEST(GltfWrite, IndicesAreUnsignedIntBeyond65535Vertices) {
  const Handmade h = handmade(257);  // 66049 vertices + 1
  FixtureOptions o;
  o.normals = o.colors = o.texcoord1 = false;
  o.extra_mesh = false;
  const Asset in = Asset::read(make_gltf(h.mesh.vertices, h.mesh.faces, o, true));
  const std::string bytes = in.write(h.map, inserted_extras(h.map), Format::glb);
  const json d = gltftest::document_json(bytes);
  EXPECT_EQ(d["accessors"][d["meshes"][0]["primitives"][0]["indices"].get<int>()]["componentType"], 5125);
  const Handmade small = handmade(5);
  const Asset in2 = Asset::read(make_gltf(small.mesh.vertices, small.mesh.faces, o, true));
  const json d2 = gltftest::document_json(in2.write(small.map, json::object(), Format::glb));
  EXPECT_EQ(d2["accessors"][d2["meshes"][0]["primitives"][0]["indices"].get<int>()]["componentType"], 5123);
  khronos_validates({save(temp_dir("out"), "big.glb", bytes)});
}

TEST(GltfWrite, Float32RoundingThatWouldFlipATriangleIsRefused) {
  RawMesh tri;
  tri.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  tri.faces = {{0, 1, 2}};
  const Asset a = Asset::from_mesh(tri);
  RefinedMap map;
  map.vertices = tri.vertices;
  map.faces = {{0, 1, 2}};
  // Positive in double, degenerate after rounding 1 - v to float32.
  map.uv = {{0, 0}, {1, 0}, {0.5, 1e-12}};
  ASSERT_EQ(orientation_sign(map.uv[0], map.uv[1], map.uv[2]), 1);
  try {
    a.write(map, json::object(), Format::glb);
    ADD_FAILURE() << "a map that float32 cannot store was written";
  } catch (const gltf::Float32RoundingError& e) {
    EXPECT_EQ(e.face(), 0);
    EXPECT_NE(std::string(e.what()).find("float32"), std::string::npos) << e.what();
  }
  // An interior vertex that rounding puts on a boundary edge's line moves one float away (the boundary never).
  RawMesh fan;
  fan.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.01, 0}};
  fan.faces = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  RefinedMap fm;
  fm.vertices = fan.vertices;
  fm.faces = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  fm.uv = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0.5, 1e-9}};
  const std::string repaired = Asset::from_mesh(fan).write(fm, json::object(), Format::glb);
  const Asset back = Asset::read(repaired);
  EXPECT_EQ(back.primitive_extras()["lipmap"]["float32_adjusted_vertices"], 1);
  const auto tc = back.attribute("TEXCOORD_0");
  EXPECT_EQ(tc->values[8], 0.5);
  EXPECT_EQ(tc->values[9], double(std::nextafter(1.0f, 0.0f)));
  for (int v = 0; v < 4; ++v) EXPECT_EQ(tc->values[2 * v + 1], 1.0 - fm.uv[v].y);
  // A fine one is written, and from_mesh makes a valid document of its own.
  map.uv = {{0, 0}, {1, 0}, {0, 1}};
  const std::string bytes = a.write(map, json::object(), Format::gltf);
  EXPECT_EQ(Asset::read(bytes).mesh().faces.size(), 1u);
  khronos_validates({save(temp_dir("out"), "from_mesh.gltf", bytes)});
}

}  // namespace
}  // namespace lipmap
