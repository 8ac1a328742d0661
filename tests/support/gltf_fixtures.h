// glTF test inputs made at test time from a triangle mesh (tests only): a writer of its own (nlohmann JSON +
// little-endian bytes), sharing no code with server/codec/gltf_codec.cpp or tinygltf, so that the codec reads
// documents it did not write itself. Also the float32 helpers the glTF tests check with.
//
// make_gltf(vertices, faces, options, binary) writes a document with:
//   mesh 0 primitive 0: POSITION (FLOAT), and as asked NORMAL (area-weighted vertex normals, unit), COLOR_0
//     (VEC4 FLOAT in [0, 1], from the position), TEXCOORD_0 (given, else a planar projection), TEXCOORD_1,
//     TANGENT (unit, w = +1 or -1 alternating), JOINTS_0 / WEIGHTS_0 (two joints; a third of the vertices
//     with the joints in the other order, so that both blending paths run) with a skin, one morph target;
//     indices UNSIGNED_INT (or none: non-indexed, every face its own 3 vertices), mode as asked;
//   a material with a base colour texture (a 1x1 PNG as a data URI) and a second mesh (one triangle) on a
//   second node, so that "the rest of the document is kept" can be checked.
// split_seam: the faces are split into two groups by the x of their centroid; every vertex used by both
// groups is duplicated (the second group's faces use the copy, which gets a different TEXCOORD_1), as glTF
// exporters split vertices at uv seams. The copies have bit-identical POSITION.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/geometry.h"

namespace lipmap::gltftest {

struct FixtureOptions {
  bool normals = true, colors = true, texcoord1 = true, tangents = false, skin = false, morph = false;
  bool indexed = true;
  int mode = 4;
  bool split_seam = false;
  bool extra_mesh = true;
  const std::vector<Point2>* texcoord0 = nullptr;  // one per vertex, written as is (glTF's s, t)
};

inline std::string base64(const std::string& bytes) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned n = (unsigned char)bytes[i] << 16 | (unsigned char)bytes[i + 1] << 8 | (unsigned char)bytes[i + 2];
    out += {table[n >> 18], table[(n >> 12) & 63], table[(n >> 6) & 63], table[n & 63]};
  }
  if (i < bytes.size()) {
    unsigned n = (unsigned char)bytes[i] << 16;
    if (i + 1 < bytes.size()) n |= (unsigned char)bytes[i + 1] << 8;
    out += {table[n >> 18], table[(n >> 12) & 63], i + 1 < bytes.size() ? table[(n >> 6) & 63] : '=', '='};
  }
  return out;
}

struct Bin {
  std::string data;
  nlohmann::json views = nlohmann::json::array(), accessors = nlohmann::json::array();

  template <class T>
  int add(const std::vector<T>& values, int components, int component_type, const char* type, int target,
          bool bounds = false) {
    while (data.size() % 4) data.push_back('\0');
    const std::size_t offset = data.size();
    data.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
    views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", values.size() * sizeof(T)}, {"target", target}});
    nlohmann::json a = {{"bufferView", views.size() - 1},
                        {"componentType", component_type},
                        {"count", values.size() / components},
                        {"type", type}};
    if (bounds) {
      std::vector<double> lo(components, 1e300), hi(components, -1e300);
      for (std::size_t i = 0; i < values.size(); ++i) {
        lo[i % components] = std::min(lo[i % components], double(values[i]));
        hi[i % components] = std::max(hi[i % components], double(values[i]));
      }
      a["min"] = lo;
      a["max"] = hi;
    }
    accessors.push_back(a);
    return static_cast<int>(accessors.size() - 1);
  }
};

inline const char* kOnePixelPng =
    "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwADhgGAWjR9awAAAABJRU5ErkJggg==";

inline std::string make_gltf(std::vector<Point3> vertices, std::vector<Triangle> faces, const FixtureOptions& o,
                             bool binary) {
  const std::size_t n_original = vertices.size();
  std::vector<int> origin(n_original);  // primitive vertex -> original vertex
  for (std::size_t i = 0; i < n_original; ++i) origin[i] = static_cast<int>(i);
  std::vector<char> is_copy(n_original, 0);
  if (o.split_seam) {
    std::vector<double> cx;
    for (const Triangle& t : faces) cx.push_back(vertices[t[0]].x + vertices[t[1]].x + vertices[t[2]].x);
    std::vector<double> sorted = cx;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double median = sorted[sorted.size() / 2];
    std::vector<int> group_mask(n_original, 0);
    for (std::size_t f = 0; f < faces.size(); ++f)
      for (int c : faces[f]) group_mask[c] |= cx[f] < median ? 1 : 2;
    std::vector<int> copy(n_original, -1);
    for (std::size_t f = 0; f < faces.size(); ++f) {
      if (cx[f] < median) continue;
      for (int& c : faces[f]) {
        if (group_mask[c] != 3) continue;
        if (copy[c] < 0) {
          copy[c] = static_cast<int>(vertices.size());
          vertices.push_back(vertices[c]);
          origin.push_back(c);
          is_copy.push_back(1);
        }
        c = copy[c];
      }
    }
  }
  if (!o.indexed) {
    std::vector<Point3> soup;
    std::vector<int> soup_origin;
    std::vector<char> soup_copy;
    std::vector<Triangle> soup_faces;
    for (const Triangle& t : faces) {
      Triangle s;
      for (int c = 0; c < 3; ++c) {
        s[c] = static_cast<int>(soup.size());
        soup.push_back(vertices[t[c]]);
        soup_origin.push_back(origin[t[c]]);
        soup_copy.push_back(is_copy[t[c]]);
      }
      soup_faces.push_back(s);
    }
    vertices = soup;
    origin = soup_origin;
    is_copy = soup_copy;
    faces = soup_faces;
  }
  const std::size_t nv = vertices.size();
  // Normals of the original vertices (area-weighted, from the faces as given).
  std::vector<std::array<double, 3>> normal(nv, {0, 0, 0});
  for (const Triangle& t : faces) {
    const Point3 &a = vertices[t[0]], &b = vertices[t[1]], &c = vertices[t[2]];
    const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z, wx = c.x - a.x, wy = c.y - a.y, wz = c.z - a.z;
    const std::array<double, 3> n = {uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx};
    for (int k : t)
      for (int i = 0; i < 3; ++i) normal[origin[k]][i] += n[i];
  }
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (const Point3& p : vertices) {
    lo[0] = std::min(lo[0], p.x), lo[1] = std::min(lo[1], p.y), lo[2] = std::min(lo[2], p.z);
    hi[0] = std::max(hi[0], p.x), hi[1] = std::max(hi[1], p.y), hi[2] = std::max(hi[2], p.z);
  }
  auto unit = [&](int axis, double v) { return hi[axis] > lo[axis] ? (v - lo[axis]) / (hi[axis] - lo[axis]) : 0.5; };

  Bin bin;
  nlohmann::json attributes = nlohmann::json::object();
  {
    std::vector<float> p;
    for (const Point3& v : vertices) p.insert(p.end(), {float(v.x), float(v.y), float(v.z)});
    attributes["POSITION"] = bin.add(p, 3, 5126, "VEC3", 34962, true);
  }
  if (o.normals || o.tangents) {
    std::vector<float> n;
    for (std::size_t v = 0; v < nv; ++v) {
      std::array<double, 3> x = normal[origin[v]];
      const double len = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
      if (len > 0) x = {x[0] / len, x[1] / len, x[2] / len};
      else x = {0, 0, 1};
      n.insert(n.end(), {float(x[0]), float(x[1]), float(x[2])});
    }
    attributes["NORMAL"] = bin.add(n, 3, 5126, "VEC3", 34962);
  }
  if (o.tangents) {
    std::vector<float> t;
    for (std::size_t v = 0; v < nv; ++v) {
      // Any unit vector orthogonal to the normal.
      std::array<double, 3> n = normal[origin[v]];
      const double nl = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      if (nl > 0) n = {n[0] / nl, n[1] / nl, n[2] / nl};
      else n = {0, 0, 1};
      std::array<double, 3> a = std::fabs(n[0]) < 0.9 ? std::array<double, 3>{1, 0, 0} : std::array<double, 3>{0, 1, 0};
      std::array<double, 3> x = {a[1] * n[2] - a[2] * n[1], a[2] * n[0] - a[0] * n[2], a[0] * n[1] - a[1] * n[0]};
      const double len = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
      t.insert(t.end(), {float(x[0] / len), float(x[1] / len), float(x[2] / len), origin[v] % 2 ? -1.0f : 1.0f});
    }
    attributes["TANGENT"] = bin.add(t, 4, 5126, "VEC4", 34962);
  }
  if (o.colors) {
    std::vector<float> c;
    for (const Point3& v : vertices) c.insert(c.end(), {float(unit(0, v.x)), float(unit(1, v.y)), float(unit(2, v.z)), 1.0f});
    attributes["COLOR_0"] = bin.add(c, 4, 5126, "VEC4", 34962);
  }
  {
    // TEXCOORD_0: given, else a planar projection (the material's texture needs one).
    std::vector<float> t;
    for (std::size_t v = 0; v < nv; ++v) {
      if (o.texcoord0) t.insert(t.end(), {float((*o.texcoord0)[origin[v]].x), float((*o.texcoord0)[origin[v]].y)});
      else t.insert(t.end(), {float(unit(0, vertices[v].x)), float(1 - unit(1, vertices[v].y))});
    }
    attributes["TEXCOORD_0"] = bin.add(t, 2, 5126, "VEC2", 34962);
  }
  if (o.texcoord1) {
    std::vector<float> t;
    for (std::size_t v = 0; v < nv; ++v)
      t.insert(t.end(), {float(unit(0, vertices[v].x) * 0.5 + (is_copy[v] ? 0.5 : 0)), float(unit(1, vertices[v].y))});
    attributes["TEXCOORD_1"] = bin.add(t, 2, 5126, "VEC2", 34962);
  }
  if (o.skin) {
    std::vector<std::uint8_t> j;
    std::vector<float> w;
    for (std::size_t v = 0; v < nv; ++v) {
      const double x = unit(0, vertices[v].x);
      const float w0 = float(0.1 + 0.8 * x), w1 = 1.0f - w0;
      if (origin[v] % 3 == 0) {
        j.insert(j.end(), {1, 0, 0, 0});
        w.insert(w.end(), {w1, w0, 0, 0});
      } else {
        j.insert(j.end(), {0, 1, 0, 0});
        w.insert(w.end(), {w0, w1, 0, 0});
      }
    }
    attributes["JOINTS_0"] = bin.add(j, 4, 5121, "VEC4", 34962);
    attributes["WEIGHTS_0"] = bin.add(w, 4, 5126, "VEC4", 34962);
  }
  nlohmann::json primitive = {{"attributes", attributes}, {"material", 0}};
  if (o.mode != 4) primitive["mode"] = o.mode;
  if (o.indexed) {
    std::vector<std::uint32_t> idx;
    for (const Triangle& t : faces) idx.insert(idx.end(), {std::uint32_t(t[0]), std::uint32_t(t[1]), std::uint32_t(t[2])});
    primitive["indices"] = bin.add(idx, 1, 5125, "SCALAR", 34963);
  }
  nlohmann::json mesh0 = {{"name", "fixture"}, {"primitives", {primitive}}};
  if (o.morph) {
    std::vector<float> d;
    for (const Point3& v : vertices) d.insert(d.end(), {0.0f, 0.0f, float(0.1 * unit(0, v.x))});
    const int target = bin.add(d, 3, 5126, "VEC3", 34962, true);
    mesh0["primitives"][0]["targets"] = {{{"POSITION", target}}};
    mesh0["weights"] = {0.5};
  }
  nlohmann::json meshes = {mesh0};
  nlohmann::json nodes = {{{"name", "fixture"}, {"mesh", 0}}};
  nlohmann::json scene_nodes = {0};
  if (o.extra_mesh) {
    const std::vector<float> p = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const int a = bin.add(p, 3, 5126, "VEC3", 34962, true);
    meshes.push_back({{"name", "untouched"}, {"primitives", {{{"attributes", {{"POSITION", a}}}}}}});
    nodes.push_back({{"name", "untouched"}, {"mesh", 1}, {"translation", {3, 0, 0}}});
    scene_nodes.push_back(1);
  }
  nlohmann::json doc = {{"asset", {{"version", "2.0"}, {"generator", "lipmap test fixture"}}},
                        {"scene", 0},
                        {"materials", {{{"name", "fixture material"},
                                        {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}, {"metallicFactor", 0.0}}},
                                        {"extras", {{"kept", true}}}}}},
                        {"textures", {{{"source", 0}, {"sampler", 0}}}},
                        {"samplers", {{{"magFilter", 9729}, {"minFilter", 9729}}}},
                        {"images", {{{"uri", std::string("data:image/png;base64,") + kOnePixelPng}}}}};
  if (o.skin) {
    nodes[0]["skin"] = 0;
    const int j0 = static_cast<int>(nodes.size());
    nodes.push_back({{"name", "joint0"}, {"children", {j0 + 1}}});
    nodes.push_back({{"name", "joint1"}, {"translation", {0, 1, 0}}});
    scene_nodes.push_back(j0);
    doc["skins"] = {{{"joints", {j0, j0 + 1}}}};
  }
  doc["meshes"] = meshes;
  doc["nodes"] = nodes;
  doc["scenes"] = {{{"nodes", scene_nodes}}};
  while (bin.data.size() % 4) bin.data.push_back('\0');
  doc["bufferViews"] = bin.views;
  doc["accessors"] = bin.accessors;
  if (!binary) {
    doc["buffers"] = {{{"byteLength", bin.data.size()}, {"uri", "data:application/octet-stream;base64," + base64(bin.data)}}};
    return doc.dump();
  }
  doc["buffers"] = {{{"byteLength", bin.data.size()}}};
  std::string json_text = doc.dump();
  while (json_text.size() % 4) json_text.push_back(' ');
  auto u32 = [](std::uint32_t x) {
    std::string s(4, '\0');
    for (int i = 0; i < 4; ++i) s[i] = static_cast<char>((x >> (8 * i)) & 255);
    return s;
  };
  const std::uint32_t total = static_cast<std::uint32_t>(12 + 8 + json_text.size() + 8 + bin.data.size());
  return "glTF" + u32(2) + u32(total) + u32(static_cast<std::uint32_t>(json_text.size())) + u32(0x4E4F534A) + json_text +
         u32(static_cast<std::uint32_t>(bin.data.size())) + u32(0x004E4942) + bin.data;
}

// Rounds to float32, always (GCC 12's SLP vectorizer was seen to drop {double(float(a)), double(float(b))}
// round trips at -O2; a volatile float goes through memory).
inline double f32(double x) {
  volatile float f = static_cast<float>(x);
  return f;
}

// lipmap's uv of a stored TEXCOORD_0 (s, t): (s, 1 - t), and the stored value of a target (u, v).
inline Point2 uv_of_texcoord(double s, double t) { return {s, 1.0 - t}; }
inline Point2 texcoord_of_uv(const Point2& uv) { return {f32(uv.x), f32(1.0 - uv.y)}; }

}  // namespace lipmap::gltftest

namespace lipmap::gltftest {

// The JSON of a .glb (its first chunk) or of a .gltf.
inline nlohmann::json document_json(const std::string& bytes) {
  if (bytes.compare(0, 4, "glTF") == 0 && bytes.size() >= 20) {
    std::uint32_t n;
    std::memcpy(&n, bytes.data() + 12, 4);
    return nlohmann::json::parse(bytes.substr(20, n));
  }
  return nlohmann::json::parse(bytes);
}

// A .glb with its JSON replaced (the BIN chunk kept as it is).
inline std::string replace_glb_json(const std::string& glb, const nlohmann::json& doc) {
  std::uint32_t n;
  std::memcpy(&n, glb.data() + 12, 4);
  const std::string rest = glb.substr(20 + n);
  std::string text = doc.dump();
  while (text.size() % 4) text.push_back(' ');
  auto u32 = [](std::uint32_t x) {
    std::string s(4, '\0');
    for (int i = 0; i < 4; ++i) s[i] = static_cast<char>((x >> (8 * i)) & 255);
    return s;
  };
  return "glTF" + u32(2) + u32(static_cast<std::uint32_t>(20 + text.size() + rest.size())) +
         u32(static_cast<std::uint32_t>(text.size())) + u32(0x4E4F534A) + text + rest;
}

}  // namespace lipmap::gltftest
