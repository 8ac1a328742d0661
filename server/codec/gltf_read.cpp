// Reading a glTF: every accessor of the selected primitive is read and bounds-checked here (nothing of the
// primitive depends on tinygltf's own checks), then the engine mesh is built, welded when asked, and
// validated as a disk (see gltf_codec.h).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <unordered_map>
#include <utility>

#include "engine/validate.h"
#include "server/codec/gltf_internal.h"
#include "server/codec/json_codec.h"

namespace lipmap::gltf {

using nlohmann::json;
using namespace internal;

namespace {

// ---- reading accessors --------------------------------------------------------------------------------

struct Read {
  const tinygltf::Model& model;
  // Values the primitive's accessors may still decode to: a few per byte of input, and a slack for
  // sparse or zero accessors (which share one view, or none, however many attributes and targets use them).
  std::size_t budget;

  static std::size_t budget_for(std::size_t input_bytes) { return 4 * input_bytes + (std::size_t{1} << 22); }

  // Takes count * comps values from the budget before anything is sized from them.
  void spend(std::size_t count, int comps, const std::string& name, const std::string& aptr) {
    const std::size_t want = count * static_cast<std::size_t>(comps);  // count <= 2^53, comps <= 16: no overflow
    if (want > budget)
      fail("gltf_accessor_mismatch", name + " has " + std::to_string(count) + " elements: the primitive's accessors would decode to more than " +
                                         std::to_string(budget_for(0)) + " values plus 4 per byte of the document",
           aptr);
    budget -= want;
  }

  const unsigned char* view_bytes(int view_index, std::size_t offset, std::size_t need, const std::string& owner,
                                  const std::string& owner_ptr, std::size_t* stride_out = nullptr) const {
    if (view_index < 0 || static_cast<std::size_t>(view_index) >= model.bufferViews.size())
      fail("gltf_invalid", owner + " refers to bufferView " + std::to_string(view_index) + ", which does not exist", owner_ptr);
    const tinygltf::BufferView& v = model.bufferViews[view_index];
    const std::string vptr = ptr("bufferViews", view_index);
    if (v.buffer < 0 || static_cast<std::size_t>(v.buffer) >= model.buffers.size())
      fail("gltf_invalid", "bufferView " + std::to_string(view_index) + " refers to buffer " + std::to_string(v.buffer) + ", which does not exist", vptr);
    const std::size_t size = model.buffers[v.buffer].data.size();
    if (v.byteOffset > size || v.byteLength > size - v.byteOffset)
      fail("gltf_buffer_out_of_range", "bufferView " + std::to_string(view_index) + " spans bytes " + std::to_string(v.byteOffset) +
                                           ".." + std::to_string(v.byteOffset + v.byteLength) + " of buffer " +
                                           std::to_string(v.buffer) + ", which has " + std::to_string(size) + " bytes",
           vptr);
    if (stride_out) *stride_out = v.byteStride;
    if (offset > v.byteLength || need > v.byteLength - offset)
      fail("gltf_buffer_out_of_range", owner + " needs bytes " + std::to_string(offset) + ".." + std::to_string(offset + need) +
                                           " of bufferView " + std::to_string(view_index) + ", which has " +
                                           std::to_string(v.byteLength) + " bytes",
           owner_ptr);
    return model.buffers[v.buffer].data.data() + v.byteOffset + offset;
  }

  // Values of accessor `index` as doubles, `components` per element. `what` names it in messages.
  Attribute accessor(int index, const std::string& what) {
    const std::string aptr = ptr("accessors", index);
    if (index < 0 || static_cast<std::size_t>(index) >= model.accessors.size())
      fail("gltf_invalid", what + " refers to accessor " + std::to_string(index) + ", which does not exist");
    const tinygltf::Accessor& a = model.accessors[index];
    const std::string name = what + " (accessor " + std::to_string(index) + ")";
    const int comps = type_components(a.type), cs = component_size(a.componentType);
    if (comps == 0 || cs == 0)
      fail("gltf_accessor_mismatch", name + " has " + (comps == 0 ? std::string("an unknown type") : "component type " + std::to_string(a.componentType)), aptr);
    if (a.normalized && (a.componentType == kFloat || a.componentType == kUInt))
      fail("gltf_accessor_mismatch", name + " is normalized with component type " + component_name(a.componentType), aptr);
    Attribute out;
    out.components = comps;
    out.component_type = a.componentType;
    out.normalized = a.normalized;
    const std::size_t count = a.count;
    const std::size_t elem = element_size(a.type, a.componentType);
    if (a.bufferView >= 0) {
      // count is bounded by the view's size before anything is allocated.
      std::size_t stride = 0;
      view_bytes(a.bufferView, 0, 0, name, aptr, &stride);
      if (stride == 0) stride = elem;
      if (stride < elem) fail("gltf_accessor_mismatch", name + ": byteStride " + std::to_string(stride) + " is smaller than its " + std::to_string(elem) + "-byte elements", ptr("bufferViews", a.bufferView));
      const std::size_t view_length = model.bufferViews[a.bufferView].byteLength;
      if (count == 0 || count - 1 > view_length / stride)
        fail("gltf_buffer_out_of_range", name + " has " + std::to_string(count) + " elements of stride " + std::to_string(stride) +
                                             ", more than bufferView " + std::to_string(a.bufferView) + " (" +
                                             std::to_string(view_length) + " bytes) holds",
             aptr);
      const std::size_t need = stride * (count - 1) + elem;
      spend(count, comps, name, aptr);
      const unsigned char* base = view_bytes(a.bufferView, a.byteOffset, need, name, aptr);
      if (a.byteOffset % static_cast<std::size_t>(cs) != 0)
        fail("gltf_accessor_mismatch", name + ": byteOffset " + std::to_string(a.byteOffset) + " is not a multiple of its component size", aptr);
      out.values.resize(count * static_cast<std::size_t>(comps));
      for (std::size_t i = 0; i < count; ++i)
        for (int c = 0; c < comps; ++c)
          out.values[i * comps + c] =
              read_component(base + i * stride + component_offset(a.type, a.componentType, c), a.componentType, a.normalized);
    } else {
      if (count == 0 || count > kMaxUnbackedElements)
        fail("gltf_accessor_mismatch", name + " has no bufferView and " + std::to_string(count) + " elements (at most " +
                                           std::to_string(kMaxUnbackedElements) + " without one)",
             aptr);
      spend(count, comps, name, aptr);
      out.values.assign(count * static_cast<std::size_t>(comps), 0.0);
    }
    if (a.sparse.isSparse) {
      const std::string sptr = aptr + "/sparse";
      const long long n = a.sparse.count;
      if (n < 1 || static_cast<std::size_t>(n) > count)
        fail("gltf_accessor_mismatch", name + ": sparse count " + std::to_string(n) + " is not in 1.." + std::to_string(count), sptr);
      const int ict = a.sparse.indices.componentType;
      if (ict != kUByte && ict != kUShort && ict != kUInt)
        fail("gltf_accessor_mismatch", name + ": sparse indices have component type " + component_name(ict), sptr + "/indices");
      const unsigned char* ib = view_bytes(a.sparse.indices.bufferView, static_cast<std::size_t>(std::max(0, a.sparse.indices.byteOffset)),
                                           static_cast<std::size_t>(n) * component_size(ict), name + " sparse indices", sptr + "/indices");
      const unsigned char* vb = view_bytes(a.sparse.values.bufferView, static_cast<std::size_t>(std::max(0, a.sparse.values.byteOffset)),
                                           static_cast<std::size_t>(n) * elem, name + " sparse values", sptr + "/values");
      for (long long k = 0; k < n; ++k) {
        const auto i = static_cast<std::size_t>(read_component(ib + k * component_size(ict), ict, false));
        if (i >= count)
          fail("gltf_buffer_out_of_range", name + ": sparse index " + std::to_string(i) + " is out of range (count " + std::to_string(count) + ")", sptr + "/indices");
        for (int c = 0; c < comps; ++c)
          out.values[i * comps + c] = read_component(vb + k * elem + component_offset(a.type, a.componentType, c), a.componentType, a.normalized);
      }
    }
    return out;
  }
};

const char* mode_name(int mode) {
  switch (mode) {
    case 0: return "POINTS";
    case 1: return "LINES";
    case 2: return "LINE_LOOP";
    case 3: return "LINE_STRIP";
    case 4: return "TRIANGLES";
    case 5: return "TRIANGLE_STRIP";
    case 6: return "TRIANGLE_FAN";
    default: return nullptr;
  }
}

// Checks an attribute's accessor against what the spec allows for its semantic.
void check_semantic(const std::string& name, const tinygltf::Accessor& a, int index, const std::string& where) {
  const std::string aptr = ptr("accessors", index);
  auto want = [&](bool ok, const std::string& what) {
    if (!ok)
      fail("gltf_accessor_mismatch", where + " attribute " + name + " (accessor " + std::to_string(index) + ") is " +
                                         type_name(a.type) + " of " + component_name(a.componentType) +
                                         (a.normalized ? " (normalized)" : "") + "; glTF requires " + what,
           aptr);
  };
  const bool mat = matrix_rows(a.type) != 0;
  if (name == "POSITION") want(a.type == TINYGLTF_TYPE_VEC3, "VEC3");
  else if (name == "NORMAL") want(a.type == TINYGLTF_TYPE_VEC3 && (a.componentType == kFloat || a.normalized), "VEC3 of FLOAT");
  else if (name == "TANGENT") want(a.type == TINYGLTF_TYPE_VEC4 && (a.componentType == kFloat || a.normalized), "VEC4 of FLOAT");
  else if (starts_with(name, "TEXCOORD_")) want(a.type == TINYGLTF_TYPE_VEC2 && !mat, "VEC2");
  else if (starts_with(name, "COLOR_"))
    want((a.type == TINYGLTF_TYPE_VEC3 || a.type == TINYGLTF_TYPE_VEC4) &&
             (a.componentType == kFloat || ((a.componentType == kUByte || a.componentType == kUShort) && a.normalized)),
         "VEC3 or VEC4 of FLOAT or normalized UNSIGNED_BYTE / UNSIGNED_SHORT");
  else if (starts_with(name, "JOINTS_"))
    want(a.type == TINYGLTF_TYPE_VEC4 && (a.componentType == kUByte || a.componentType == kUShort) && !a.normalized,
         "VEC4 of UNSIGNED_BYTE or UNSIGNED_SHORT");
  else if (starts_with(name, "WEIGHTS_"))
    want(a.type == TINYGLTF_TYPE_VEC4 &&
             (a.componentType == kFloat || ((a.componentType == kUByte || a.componentType == kUShort) && a.normalized)),
         "VEC4 of FLOAT or normalized UNSIGNED_BYTE / UNSIGNED_SHORT");
}

std::uint64_t bits(double d) {
  std::uint64_t b;
  std::memcpy(&b, &d, 8);
  return b;
}

struct PositionKey {
  std::uint64_t x, y, z;
  bool operator==(const PositionKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct PositionKeyHash {
  std::size_t operator()(const PositionKey& k) const {
    return std::hash<std::uint64_t>()(k.x * 0x9E3779B97F4A7C15ull ^ (k.y + 0x632BE59BD9B4E019ull) * 31 ^ k.z);
  }
};

}  // namespace

// ---- reading ------------------------------------------------------------------------------------------

Asset Asset::read(std::string_view bytes, const Selection& selection, std::optional<Format> expected) {
  // Only GltfError and InputError leave the reader, whatever the bytes: anything else thrown on the way
  // (tinygltf's std::out_of_range on an empty BIN buffer, say) is a document the reader cannot take.
  try {
    return read_document(bytes, selection, expected);
  } catch (const InputError&) {
    throw;
  } catch (const std::bad_alloc&) {
    fail("gltf_invalid", "the document needs more memory than there is to read it");
  } catch (const std::exception& e) {
    fail("gltf_invalid", std::string("cannot read the document: ") + e.what());
  }
}

Asset Asset::read_document(std::string_view bytes, const Selection& selection, std::optional<Format> expected) {
  auto impl = std::make_shared<Impl>();
  Impl& m = *impl;
  m.selection = selection;

  std::optional<Format> format = sniff_format(bytes);
  if (expected == Format::glb && format != Format::glb)
    fail("gltf_bad_magic", "not a binary glTF: a .glb starts with the magic bytes 'glTF' (67 6c 54 46), this one starts with " + hex_bytes(bytes, 4));
  if (expected == Format::gltf && format != Format::gltf)
    fail("gltf_invalid_json", format == Format::glb ? "this is a binary glTF (GLB), not glTF JSON: send it as model/gltf-binary (.glb)"
                                                    : "not glTF JSON: a .gltf is a JSON object, this one starts with " + hex_bytes(bytes, 4));
  if (!format) fail("gltf_bad_magic", "neither a .glb (magic 'glTF') nor a .gltf (a JSON object): the body starts with " + hex_bytes(bytes, 4));
  m.format = *format;

  std::size_t glb_length = bytes.size();
  std::optional<std::size_t> bin_chunk;
  const std::string_view json_text = m.format == Format::glb ? check_glb(bytes, glb_length, bin_chunk) : bytes;
  // JSON has no NUL outside strings and none unescaped inside them; a .gltf with one (a C string's
  // terminator after the text, say) is not JSON. (A GLB's JSON chunk is left to the JSON parser.)
  if (m.format == Format::gltf)
    if (const std::size_t nul = json_text.find('\0'); nul != std::string_view::npos)
      fail("gltf_invalid_json", "the glTF JSON has a NUL byte at offset " + std::to_string(nul) + ": not JSON");
  const json doc = parse_document(json_text, bin_chunk, m.format == Format::glb);

  tinygltf::TinyGLTF loader;
  loader.SetFsCallbacks(no_file_system());
  loader.SetImageLoader(&keep_image_bytes, nullptr);
  std::string err, warn;
  bool ok = false;
  if (glb_length > std::numeric_limits<unsigned int>::max()) fail("gltf_invalid", "glTF larger than 4 GiB");
  try {
    if (m.format == Format::glb)
      ok = loader.LoadBinaryFromMemory(&m.model, &err, &warn, reinterpret_cast<const unsigned char*>(bytes.data()),
                                       static_cast<unsigned int>(glb_length), "", tinygltf::REQUIRE_VERSION);
    else
      ok = loader.LoadASCIIFromString(&m.model, &err, &warn, bytes.data(), static_cast<unsigned int>(bytes.size()), "",
                                      tinygltf::REQUIRE_VERSION);
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    // tinygltf throws on some inputs it does not check (a zero-length BIN buffer: std::out_of_range).
    err = e.what();
    ok = false;
  }
  if (!ok) {
    std::string e = trim(err.empty() ? warn : err);
    std::replace(e.begin(), e.end(), '\n', ' ');
    fail("gltf_invalid", "tinygltf cannot read the document: " + (e.empty() ? std::string("(no reason given)") : e));
  }

  // ---- the primitive ----
  if (m.model.meshes.empty()) fail("gltf_mesh_not_found", "the document has no meshes", "/meshes");
  if (selection.mesh < 0 || static_cast<std::size_t>(selection.mesh) >= m.model.meshes.size())
    fail("gltf_mesh_not_found", "mesh " + std::to_string(selection.mesh) + " does not exist: the document has " +
                                    std::to_string(m.model.meshes.size()) + " mesh(es)", "/meshes");
  const tinygltf::Mesh& gm = m.model.meshes[selection.mesh];
  const std::string mptr = ptr("meshes", selection.mesh);
  if (selection.primitive < 0 || static_cast<std::size_t>(selection.primitive) >= gm.primitives.size())
    fail("gltf_primitive_not_found", "primitive " + std::to_string(selection.primitive) + " of mesh " + std::to_string(selection.mesh) +
                                         " does not exist: it has " + std::to_string(gm.primitives.size()) + " primitive(s)",
         mptr + "/primitives");
  const tinygltf::Primitive& prim = gm.primitives[selection.primitive];
  const std::string pptr = mptr + "/primitives/" + std::to_string(selection.primitive);
  const std::string where = "mesh " + std::to_string(selection.mesh) + " primitive " + std::to_string(selection.primitive);
  const int mode = prim.mode < 0 ? 4 : prim.mode;
  if (mode != 4) {
    const char* name = mode_name(mode);
    fail("gltf_unsupported_mode", where + " has mode " + (name ? std::string(name) + " (" + std::to_string(mode) + ")" : std::to_string(mode) + " (not a glTF mode)") +
                                      ": lipmap maps TRIANGLES (mode 4) primitives only",
         pptr + "/mode");
  }
  if (prim.extensions.count("KHR_draco_mesh_compression"))
    fail("gltf_unsupported_extension", where + " is Draco-compressed (KHR_draco_mesh_compression): decompress it first", pptr + "/extensions");
  const auto pos_it = prim.attributes.find("POSITION");
  if (pos_it == prim.attributes.end()) fail("gltf_no_position", where + " has no POSITION attribute", pptr + "/attributes");

  Read read{m.model, Read::budget_for(bytes.size())};
  std::size_t nvert = 0;
  for (const auto& [name, index] : prim.attributes) {
    if (index < 0 || static_cast<std::size_t>(index) >= m.model.accessors.size())
      fail("gltf_invalid", where + " attribute " + name + " refers to accessor " + std::to_string(index) + ", which does not exist",
           pptr + "/attributes/" + codec::escape_pointer_token(name));
    check_semantic(name, m.model.accessors[index], index, where);
  }
  check_accessor_bytes(doc, bin_chunk, m.format == Format::glb);
  {
    Attribute p = read.accessor(pos_it->second, where + " POSITION");
    p.name = "POSITION";
    nvert = p.values.size() / 3;
    m.attributes.push_back(std::move(p));
  }
  for (const auto& [name, index] : prim.attributes) {
    if (name == "POSITION") continue;
    Attribute a = read.accessor(index, where + " " + name);
    a.name = name;
    if (a.values.size() / a.components != nvert)
      fail("gltf_accessor_mismatch", where + " attribute " + name + " has " + std::to_string(a.values.size() / a.components) +
                                         " elements, POSITION has " + std::to_string(nvert),
           ptr("accessors", index));
    m.attributes.push_back(std::move(a));
  }
  for (std::size_t k = 0; k < prim.targets.size(); ++k) {
    std::vector<Attribute> target;
    for (const auto& [name, index] : prim.targets[k]) {
      Attribute a = read.accessor(index, where + " morph target " + std::to_string(k) + " " + name);
      a.name = name;
      if (a.values.size() / a.components != nvert)
        fail("gltf_accessor_mismatch", where + " morph target " + std::to_string(k) + " " + name + " has " +
                                           std::to_string(a.values.size() / a.components) + " elements, POSITION has " + std::to_string(nvert),
             ptr("accessors", index));
      target.push_back(std::move(a));
    }
    m.targets.push_back(std::move(target));
  }
  for (const Attribute& a : m.attributes)
    for (std::size_t i = 0; i < a.values.size(); ++i)
      if (!std::isfinite(a.values[i]))
        fail("gltf_non_finite", where + " attribute " + a.name + " of vertex " + std::to_string(i / a.components) + " is not finite",
             ptr("accessors", prim.attributes.at(a.name)));
  m.primitive_vertices = nvert;

  // ---- triangles ----
  std::vector<std::array<long long, 3>> tris;
  if (prim.indices >= 0) {
    if (static_cast<std::size_t>(prim.indices) >= m.model.accessors.size())
      fail("gltf_invalid", where + " refers to index accessor " + std::to_string(prim.indices) + ", which does not exist", pptr + "/indices");
    const tinygltf::Accessor& ia = m.model.accessors[prim.indices];
    if (ia.type != TINYGLTF_TYPE_SCALAR || ia.normalized ||
        (ia.componentType != kUByte && ia.componentType != kUShort && ia.componentType != kUInt))
      fail("gltf_accessor_mismatch", where + " indices (accessor " + std::to_string(prim.indices) + ") are " + type_name(ia.type) +
                                         " of " + component_name(ia.componentType) +
                                         "; glTF indices are SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
           ptr("accessors", prim.indices));
    if (ia.count < 3) fail("gltf_no_triangles", where + " has " + std::to_string(ia.count) + " indices: no triangle", ptr("accessors", prim.indices));
    const Attribute idx = read.accessor(prim.indices, where + " indices");
    if (idx.values.size() % 3 != 0)
      fail("gltf_index_count", where + " has " + std::to_string(idx.values.size()) + " indices, not a multiple of 3 (mode TRIANGLES)",
           ptr("accessors", prim.indices));
    for (std::size_t i = 0; i < idx.values.size(); ++i)
      if (idx.values[i] >= static_cast<double>(nvert))
        fail("gltf_index_out_of_range", where + " index " + std::to_string(i) + " is " + std::to_string(static_cast<long long>(idx.values[i])) +
                                            ", but the primitive has " + std::to_string(nvert) + " vertices",
             ptr("accessors", prim.indices));
    tris.resize(idx.values.size() / 3);
    for (std::size_t f = 0; f < tris.size(); ++f)
      for (int c = 0; c < 3; ++c) tris[f][c] = static_cast<long long>(idx.values[3 * f + c]);
  } else {
    if (nvert < 3) fail("gltf_no_triangles", where + " is not indexed and has " + std::to_string(nvert) + " vertices: no triangle", pptr);
    if (nvert % 3 != 0)
      fail("gltf_index_count", where + " is not indexed and has " + std::to_string(nvert) + " vertices, not a multiple of 3 (mode TRIANGLES)", pptr);
    tris.resize(nvert / 3);
    for (std::size_t f = 0; f < tris.size(); ++f)
      for (int c = 0; c < 3; ++c) tris[f][c] = static_cast<long long>(3 * f + c);
  }

  // ---- engine mesh: used vertices, welded by position when asked ----
  const std::vector<double>& pos = m.attributes[0].values;
  std::vector<char> used(nvert, 0);
  for (const auto& t : tris)
    for (long long v : t) used[v] = 1;
  std::vector<int> cls(nvert, -1);
  std::unordered_map<PositionKey, int, PositionKeyHash> by_position;
  for (std::size_t v = 0; v < nvert; ++v) {
    if (!used[v]) {
      ++m.unused;
      continue;
    }
    const PositionKey key{bits(pos[3 * v]), bits(pos[3 * v + 1]), bits(pos[3 * v + 2])};
    auto [it, inserted] = by_position.emplace(key, static_cast<int>(m.rep.size()));
    if (!inserted) ++m.split_positions;
    if (selection.weld == Weld::position && !inserted) {
      cls[v] = it->second;
      ++m.welded;
      continue;
    }
    cls[v] = static_cast<int>(m.rep.size());
    m.rep.push_back(static_cast<int>(v));
  }
  m.mesh.vertices.reserve(m.rep.size());
  for (int v : m.rep) m.mesh.vertices.push_back({pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]});
  m.mesh.faces.reserve(tris.size());
  for (const auto& t : tris) m.mesh.faces.push_back({cls[t[0]], cls[t[1]], cls[t[2]]});
  m.extras = to_json(prim.extras);

  try {
    m.loop = validate_mesh(m.mesh).boundary_loop;
  } catch (const InputError& e) {
    std::string message = where + ": " + e.what();
    if (e.element() == "vertex" && e.index() && *e.index() >= 0 && static_cast<std::size_t>(*e.index()) < m.rep.size() &&
        m.rep[*e.index()] != *e.index())
      message += " (vertex " + std::to_string(*e.index()) + " is the primitive's vertex " + std::to_string(m.rep[*e.index()]) + ")";
    if (selection.weld == Weld::none && m.split_positions > 0)
      message += "; the primitive has " + std::to_string(m.split_positions) +
                 " vertices at the same POSITION as another (glTF splits vertices at seams): weld=position merges them";
    throw InputError(e.code(), message, e.element(), e.index());
  }

  Asset asset;
  asset.impl_ = std::move(impl);
  return asset;
}

Asset Asset::from_mesh(const RawMesh& mesh) {
  auto impl = std::make_shared<Impl>();
  Impl& m = *impl;
  m.format = Format::glb;
  m.mesh = mesh;
  m.primitive_vertices = mesh.vertices.size();
  m.rep.resize(mesh.vertices.size());
  std::iota(m.rep.begin(), m.rep.end(), 0);
  Attribute p;
  p.name = "POSITION";
  p.components = 3;
  p.component_type = kFloat;
  for (const Point3& v : mesh.vertices) p.values.insert(p.values.end(), {v.x, v.y, v.z});
  m.attributes.push_back(std::move(p));
  m.model.asset.version = "2.0";
  m.model.asset.generator = "lipmap";
  tinygltf::Mesh gm;
  gm.name = "lipmap";
  tinygltf::Primitive prim;
  prim.mode = 4;
  gm.primitives.push_back(prim);
  m.model.meshes.push_back(gm);
  tinygltf::Node node;
  node.mesh = 0;
  m.model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  m.model.scenes.push_back(scene);
  m.model.defaultScene = 0;
  m.extras = nullptr;
  Asset asset;
  asset.impl_ = std::move(impl);
  return asset;
}

Format Asset::format() const { return impl_->format; }
const Selection& Asset::selection() const { return impl_->selection; }
const RawMesh& Asset::mesh() const { return impl_->mesh; }
const std::vector<int>& Asset::boundary_loop() const { return impl_->loop; }
std::size_t Asset::primitive_vertices() const { return impl_->primitive_vertices; }
const std::vector<int>& Asset::source_vertex() const { return impl_->rep; }
std::size_t Asset::welded_vertices() const { return impl_->welded; }
std::size_t Asset::unused_vertices() const { return impl_->unused; }
const nlohmann::json& Asset::primitive_extras() const { return impl_->extras; }

std::vector<std::string> Asset::attribute_names() const {
  std::vector<std::string> names;
  for (const Attribute& a : impl_->attributes) names.push_back(a.name);
  std::sort(names.begin(), names.end());
  return names;
}

std::optional<Attribute> Asset::attribute(const std::string& name) const {
  for (const Attribute& a : impl_->attributes) {
    if (a.name != name) continue;
    Attribute out = a;
    out.values.clear();
    out.values.reserve(impl_->rep.size() * a.components);
    for (int v : impl_->rep)
      out.values.insert(out.values.end(), a.values.begin() + static_cast<long>(v) * a.components,
                        a.values.begin() + static_cast<long>(v + 1) * a.components);
    return out;
  }
  return std::nullopt;
}

namespace {
// TEXCOORD_N of the primitive, or GltfError gltf_texcoord_missing naming the parameter (what=texcoord:N).
Attribute texcoord_set(const Asset& asset, int set, const char* what) {
  const std::string name = "TEXCOORD_" + std::to_string(set);
  std::optional<Attribute> tc = asset.attribute(name);
  if (!tc) {
    std::string have;
    for (const std::string& n : asset.attribute_names())
      if (starts_with(n, "TEXCOORD_")) have += (have.empty() ? "" : ", ") + n;
    fail("gltf_texcoord_missing", std::string(what) + "=texcoord:" + std::to_string(set) + ": the primitive has no " + name +
                                      (have.empty() ? " (it has no TEXCOORD set)" : " (it has " + have + ")"));
  }
  return std::move(*tc);
}
}  // namespace

std::vector<Point2> Asset::texcoord_uv(int set) const {
  const Attribute tc = texcoord_set(*this, set, "metric");
  std::vector<Point2> uv(tc.values.size() / 2);
  for (std::size_t v = 0; v < uv.size(); ++v) uv[v] = {tc.values[2 * v], 1.0 - tc.values[2 * v + 1]};
  return uv;
}

RawBoundary Asset::texcoord_boundary(int set) const {
  const Attribute tc = texcoord_set(*this, set, "boundary");
  RawBoundary b;
  b.vertices = std::vector<long long>();
  for (int v : impl_->loop) {
    b.vertices->push_back(v);
    b.positions.push_back({tc.values[2 * v], 1.0 - tc.values[2 * v + 1]});
  }
  return b;
}

}  // namespace lipmap::gltf
