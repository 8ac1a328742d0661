// Writing a glTF: the input document with the selected primitive replaced by the refined mesh, its uv as
// float32 TEXCOORD_0 (engine/float32_uv.h) and every other attribute interpolated onto the inserted
// vertices; and the answers of a parametrize request in glTF (see gltf_codec.h).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <sstream>
#include <utility>

#include "engine/float32_uv.h"
#include "engine/pipeline.h"
#include "engine/refine.h"
#include "server/codec/gltf_internal.h"
#include "server/codec/json_codec.h"

namespace lipmap::gltf {

using nlohmann::json;
using nlohmann::ordered_json;
using namespace internal;

namespace {

struct Writer {
  tinygltf::Model& model;
  std::vector<unsigned char>& data;

  int view(const std::vector<unsigned char>& bytes, int target) {
    while (data.size() % 4) data.push_back(0);
    tinygltf::BufferView v;
    v.buffer = 0;
    v.byteOffset = data.size();
    v.byteLength = bytes.size();
    v.target = target;
    data.insert(data.end(), bytes.begin(), bytes.end());
    model.bufferViews.push_back(v);
    return static_cast<int>(model.bufferViews.size() - 1);
  }

  // values: `components` per element; written as `ct` (normalized integers rounded to their grid).
  int accessor(const std::vector<double>& values, int components, int ct, bool normalized, int target,
               bool with_bounds, const std::string& name = {}) {
    const std::size_t count = values.size() / static_cast<std::size_t>(components);
    std::vector<unsigned char> bytes(values.size() * component_size(ct));
    std::vector<double> lo(components, std::numeric_limits<double>::infinity()),
        hi(components, -std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < values.size(); ++i) {
      unsigned char* p = bytes.data() + i * component_size(ct);
      double stored = 0;
      const double v = values[i];
      switch (ct) {
        case kFloat: {
          const float f = to_float32(v);
          std::memcpy(p, &f, 4);
          stored = f;
          break;
        }
        case kUByte: {
          const double x = normalized ? std::round(std::clamp(v, 0.0, 1.0) * 255.0) : std::clamp(std::round(v), 0.0, 255.0);
          p[0] = static_cast<unsigned char>(x);
          stored = x;
          break;
        }
        case kByte: {
          const double x = normalized ? std::round(std::clamp(v, -1.0, 1.0) * 127.0) : std::clamp(std::round(v), -128.0, 127.0);
          const auto b = static_cast<std::int8_t>(x);
          std::memcpy(p, &b, 1);
          stored = x;
          break;
        }
        case kUShort: {
          const double x = normalized ? std::round(std::clamp(v, 0.0, 1.0) * 65535.0) : std::clamp(std::round(v), 0.0, 65535.0);
          const auto s = static_cast<std::uint16_t>(x);
          std::memcpy(p, &s, 2);
          stored = x;
          break;
        }
        case kShort: {
          const double x = normalized ? std::round(std::clamp(v, -1.0, 1.0) * 32767.0) : std::clamp(std::round(v), -32768.0, 32767.0);
          const auto s = static_cast<std::int16_t>(x);
          std::memcpy(p, &s, 2);
          stored = x;
          break;
        }
        case kUInt: {
          const double x = std::clamp(std::round(v), 0.0, 4294967295.0);
          const auto u = static_cast<std::uint32_t>(x);
          std::memcpy(p, &u, 4);
          stored = x;
          break;
        }
        default: break;
      }
      const int c = static_cast<int>(i % components);
      lo[c] = std::min(lo[c], stored);
      hi[c] = std::max(hi[c], stored);
    }
    tinygltf::Accessor a;
    a.bufferView = view(bytes, target);
    a.byteOffset = 0;
    a.componentType = ct;
    a.normalized = normalized;
    a.count = count;
    a.type = type_for_components(components);
    a.name = name;
    if (with_bounds && count > 0) {
      a.minValues = lo;
      a.maxValues = hi;
    }
    model.accessors.push_back(a);
    return static_cast<int>(model.accessors.size() - 1);
  }
};

std::string num(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

// Joint/weight blending of an inserted vertex. ja/wa, jb/wb: all sets' slots, in order.
void blend_skin(const std::vector<double>& ja, const std::vector<double>& wa, const std::vector<double>& jb,
                const std::vector<double>& wb, double t, std::vector<double>& jo, std::vector<double>& wo) {
  const std::size_t slots = ja.size();
  jo.assign(slots, 0);
  wo.assign(slots, 0);
  if (ja == jb) {
    double sum = 0;
    for (std::size_t i = 0; i < slots; ++i) sum += wo[i] = (1 - t) * wa[i] + t * wb[i];
    jo = ja;
    if (sum > 0)
      for (double& w : wo) w /= sum;
    return;
  }
  std::map<double, double> by_joint;
  for (std::size_t i = 0; i < slots; ++i) {
    if (wa[i] > 0) by_joint[ja[i]] += (1 - t) * wa[i];
    if (wb[i] > 0) by_joint[jb[i]] += t * wb[i];
  }
  std::vector<std::pair<double, double>> ranked(by_joint.begin(), by_joint.end());  // (joint, weight)
  std::stable_sort(ranked.begin(), ranked.end(), [](const auto& x, const auto& y) { return x.second > y.second; });
  if (ranked.size() > slots) ranked.resize(slots);
  double sum = 0;
  for (const auto& r : ranked) sum += r.second;
  for (std::size_t i = 0; i < ranked.size(); ++i) {
    jo[i] = ranked[i].first;
    wo[i] = sum > 0 ? ranked[i].second / sum : 0;
  }
}

}  // namespace

std::string Asset::write(const RefinedMap& map, const nlohmann::json& extras, Format format) const {
  const Impl& m = *impl_;
  const std::size_t n0 = m.mesh.vertices.size(), nv = map.vertices.size();
  if (nv != n0 + map.inserted.size() || map.uv.size() != nv)
    throw InternalError("glTF writer: the refined map has " + std::to_string(nv) + " vertices and " + std::to_string(map.uv.size()) +
                        " uv for " + std::to_string(n0) + " original + " + std::to_string(map.inserted.size()) + " inserted");
  for (std::size_t v = 0; v < n0; ++v)
    if (!(map.vertices[v] == m.mesh.vertices[v]))
      throw InternalError("glTF writer: original vertex " + std::to_string(v) + " moved");
  for (const InsertedVertex& ins : map.inserted)
    if (ins.a < 0 || ins.b < 0 || static_cast<std::size_t>(ins.a) >= n0 || static_cast<std::size_t>(ins.b) >= n0)
      throw InternalError("glTF writer: an inserted vertex lies on an edge that is not between original vertices");
  for (const Triangle& f : map.faces)
    for (int c : f)
      if (c < 0 || static_cast<std::size_t>(c) >= nv) throw InternalError("glTF writer: face index out of range");

  // ---- uv as stored, checked as stored (engine/float32_uv.h: the repair by an ulp or two, exact checks) ----
  const Float32Uv stored = float32_texcoords(map.uv, map.faces);
  if (stored.bad_face >= 0) {
    const Triangle& t = map.faces[stored.bad_face];
    std::string corners;
    for (int c : t)
      corners += " vertex " + std::to_string(c) + " uv (" + num(map.uv[c].x) + ", " + num(map.uv[c].y) + ") -> TEXCOORD_0 (" +
                 num(stored.st[c].x) + ", " + num(stored.st[c].y) + ");";
    throw Float32RoundingError("rounding uv to float32 for glTF would make face " + std::to_string(stored.bad_face) + " (" +
                                   std::to_string(t[0]) + ", " + std::to_string(t[1]) + ", " + std::to_string(t[2]) + ") " +
                                   (stored.bad_face_orientation == 0 ? "degenerate" : "flipped") + ":" + corners +
                                   " the double-precision map is locally injective, but glTF cannot store it; nothing was written",
                               stored.bad_face);
  }
  if (stored.bad_vertex >= 0)
    throw Float32RoundingError("rounding uv to float32 for glTF would make the uv triangles around interior vertex " +
                                   std::to_string(stored.bad_vertex) + " turn " + std::to_string(stored.bad_vertex_turns) +
                                   " times around it instead of once; nothing was written",
                               -1);
  std::vector<double> st(2 * nv);
  for (std::size_t v = 0; v < nv; ++v) {
    st[2 * v] = stored.st[v].x;
    st[2 * v + 1] = stored.st[v].y;
  }

  // ---- per output vertex: its primitive vertices and weights ----
  struct Source {
    int a, b;  // primitive vertices
    double t;  // weight of b
  };
  std::vector<Source> src(nv);
  for (std::size_t v = 0; v < n0; ++v) src[v] = {m.rep[v], m.rep[v], 0.0};
  for (std::size_t i = 0; i < map.inserted.size(); ++i) {
    const InsertedVertex& ins = map.inserted[i];
    src[n0 + i] = {m.rep[ins.a], m.rep[ins.b], ins.t};
  }

  tinygltf::Model model = m.model;
  std::vector<unsigned char> data;
  {
    std::vector<std::size_t> base(model.buffers.size());
    for (std::size_t i = 0; i < model.buffers.size(); ++i) {
      while (data.size() % 16) data.push_back(0);
      base[i] = data.size();
      data.insert(data.end(), model.buffers[i].data.begin(), model.buffers[i].data.end());
    }
    for (tinygltf::BufferView& v : model.bufferViews)
      if (v.buffer >= 0 && static_cast<std::size_t>(v.buffer) < base.size()) {
        v.byteOffset += base[v.buffer];
        v.buffer = 0;
      }
  }
  Writer w{model, data};
  tinygltf::Primitive& prim = model.meshes[m.selection.mesh].primitives[m.selection.primitive];
  std::map<std::string, int> attributes;

  // POSITION: the refined mesh's own (originals as read, inserted on their edges).
  {
    std::vector<double> p(3 * nv);
    for (std::size_t v = 0; v < nv; ++v) {
      p[3 * v] = map.vertices[v].x;
      p[3 * v + 1] = map.vertices[v].y;
      p[3 * v + 2] = map.vertices[v].z;
    }
    attributes["POSITION"] = w.accessor(p, 3, kFloat, false, kArrayBuffer, true);
  }
  attributes["TEXCOORD_0"] = w.accessor(st, 2, kFloat, false, kArrayBuffer, false);

  // Skin sets: JOINTS_k with WEIGHTS_k.
  std::vector<const Attribute*> joints, weights;
  for (int k = 0;; ++k) {
    const Attribute *j = nullptr, *wt = nullptr;
    for (const Attribute& a : m.attributes) {
      if (a.name == "JOINTS_" + std::to_string(k)) j = &a;
      if (a.name == "WEIGHTS_" + std::to_string(k)) wt = &a;
    }
    if (!j || !wt) break;
    joints.push_back(j);
    weights.push_back(wt);
  }
  auto in_skin = [&](const Attribute& a) {
    return std::find(joints.begin(), joints.end(), &a) != joints.end() ||
           std::find(weights.begin(), weights.end(), &a) != weights.end();
  };

  auto interpolate = [&](const Attribute& a, bool renormalize_xyz, bool keep_w_from_a, bool nearest) {
    const int c = a.components;
    std::vector<double> out(nv * c);
    for (std::size_t v = 0; v < nv; ++v) {
      const Source& s = src[v];
      const double* pa = &a.values[static_cast<std::size_t>(s.a) * c];
      const double* pb = &a.values[static_cast<std::size_t>(s.b) * c];
      double* o = &out[v * c];
      if (s.a == s.b || nearest) {
        const double* p = (nearest && s.t > 0.5) ? pb : pa;
        std::copy(p, p + c, o);
        continue;
      }
      for (int i = 0; i < c; ++i) o[i] = (1 - s.t) * pa[i] + s.t * pb[i];
      if (renormalize_xyz) {
        const double len = std::sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
        if (len > 1e-12) {
          for (int i = 0; i < 3; ++i) o[i] /= len;
        } else {
          std::copy(pa, pa + 3, o);
        }
      }
      if (keep_w_from_a && c == 4) o[3] = pa[3];
    }
    return out;
  };

  for (const Attribute& a : m.attributes) {
    if (a.name == "POSITION" || a.name == "TEXCOORD_0" || in_skin(a)) continue;
    if (a.name == "NORMAL") {
      attributes[a.name] = w.accessor(interpolate(a, true, false, false), 3, kFloat, false, kArrayBuffer, false);
    } else if (a.name == "TANGENT") {
      attributes[a.name] = w.accessor(interpolate(a, true, true, false), 4, kFloat, false, kArrayBuffer, false);
    } else if (is_float_semantic(a.name)) {
      attributes[a.name] = w.accessor(interpolate(a, false, false, false), a.components, kFloat, false, kArrayBuffer, false);
    } else if (starts_with(a.name, "JOINTS_")) {  // without WEIGHTS of the same set: nearer endpoint
      attributes[a.name] = w.accessor(interpolate(a, false, false, true), a.components, a.component_type, false, kArrayBuffer, false);
    } else {
      const bool integer = a.component_type != kFloat && !a.normalized;
      attributes[a.name] = w.accessor(interpolate(a, false, false, integer), a.components, a.component_type, a.normalized,
                                      kArrayBuffer, false);
    }
  }
  if (!joints.empty()) {
    const std::size_t sets = joints.size(), slots = 4 * sets;
    int joint_type = kUByte;
    for (const Attribute* j : joints) joint_type = std::max(joint_type, j->component_type);
    std::vector<std::vector<double>> jout(sets, std::vector<double>(nv * 4)), wout(sets, std::vector<double>(nv * 4));
    std::vector<double> ja(slots), wa(slots), jb(slots), wb(slots), jo, wo;
    auto gather = [&](int pv, std::vector<double>& j, std::vector<double>& wt) {
      for (std::size_t k = 0; k < sets; ++k)
        for (int i = 0; i < 4; ++i) {
          j[4 * k + i] = joints[k]->values[static_cast<std::size_t>(pv) * 4 + i];
          wt[4 * k + i] = weights[k]->values[static_cast<std::size_t>(pv) * 4 + i];
        }
    };
    for (std::size_t v = 0; v < nv; ++v) {
      gather(src[v].a, ja, wa);
      if (src[v].a == src[v].b) {
        jo = ja;
        wo = wa;
      } else {
        gather(src[v].b, jb, wb);
        blend_skin(ja, wa, jb, wb, src[v].t, jo, wo);
      }
      for (std::size_t k = 0; k < sets; ++k)
        for (int i = 0; i < 4; ++i) {
          jout[k][v * 4 + i] = jo[4 * k + i];
          wout[k][v * 4 + i] = wo[4 * k + i];
        }
    }
    for (std::size_t k = 0; k < sets; ++k) {
      attributes[joints[k]->name] = w.accessor(jout[k], 4, joint_type, false, kArrayBuffer, false);
      attributes[weights[k]->name] = w.accessor(wout[k], 4, kFloat, false, kArrayBuffer, false);
    }
  }
  // Morph targets: displacements, lerped.
  std::vector<std::map<std::string, int>> targets;
  for (const std::vector<Attribute>& target : m.targets) {
    std::map<std::string, int> t;
    for (const Attribute& a : target) {
      const bool float_type = a.component_type == kFloat || a.normalized;
      t[a.name] = w.accessor(interpolate(a, false, false, false), a.components, float_type ? kFloat : a.component_type,
                             false, kArrayBuffer, a.name == "POSITION");
    }
    targets.push_back(std::move(t));
  }
  {
    std::vector<double> idx;
    idx.reserve(map.faces.size() * 3);
    for (const Triangle& t : map.faces) idx.insert(idx.end(), {double(t[0]), double(t[1]), double(t[2])});
    prim.indices = w.accessor(idx, 1, nv <= 65535 ? kUShort : kUInt, false, kElementArrayBuffer, false);
  }
  prim.attributes = std::move(attributes);
  prim.targets = std::move(targets);
  prim.mode = 4;
  json merged = m.extras.is_object() ? m.extras : json::object();
  if (!m.extras.is_null() && !m.extras.is_object()) merged["extras_before_lipmap"] = m.extras;
  merged["lipmap"] = extras;
  merged["lipmap"]["float32_adjusted_vertices"] = stored.adjusted;
  prim.extras = to_value(merged);
  prim.extras_json_string.clear();

  tinygltf::Buffer buffer = model.buffers.empty() ? tinygltf::Buffer() : model.buffers[0];
  buffer.uri.clear();
  buffer.data = std::move(data);
  while (buffer.data.size() % 4) buffer.data.push_back(0);
  model.buffers.assign(1, std::move(buffer));

  tinygltf::TinyGLTF writer;
  writer.SetFsCallbacks(no_file_system());
  writer.SetImageWriter(&embed_image_bytes, nullptr);
  std::ostringstream out;
  if (!writer.WriteGltfSceneToStream(&model, out, false, format == Format::glb))
    throw InternalError("glTF writer: tinygltf could not serialize the document");
  return out.str();
}

// ---- answers ------------------------------------------------------------------------------------------

nlohmann::json extras_for(const ParametrizeResult& result, const Asset& asset) {
  const ordered_json answer = codec::parametrize_result_to_json(result);
  json out = json::object();
  for (const char* key : {"verdict", "turning_number", "singular_vertices", "inserted", "diagnostics"})
    if (answer.contains(key)) out[key] = json::parse(answer[key].dump());
  out["uv_convention"] = "TEXCOORD_0 = (u, 1 - v)";
  out["source"] = {{"mesh", asset.selection().mesh},
                   {"primitive", asset.selection().primitive},
                   {"weld", to_string(asset.selection().weld)},
                   {"primitive_vertices", asset.primitive_vertices()},
                   {"welded_vertices", asset.welded_vertices()},
                   {"unused_vertices", asset.unused_vertices()}};
  return out;
}

std::string write_answer(const Asset& asset, const ParametrizeResult& result, Format format) {
  return asset.write(result.map, extras_for(result, asset), format);
}

std::string write_answer(const ParametrizeResult& result, Format format) {
  RawMesh originals;
  const std::size_t n0 = result.map.vertices.size() - std::min(result.map.vertices.size(), result.map.inserted.size());
  originals.vertices.assign(result.map.vertices.begin(), result.map.vertices.begin() + static_cast<long>(n0));
  return write_answer(Asset::from_mesh(originals), result, format);
}

}  // namespace lipmap::gltf
