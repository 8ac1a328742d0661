// glTF in and out (see gltf_codec.h for the conventions). tinygltf (Debian's shared library) parses and
// serializes the document; every accessor of the selected primitive is read and bounds-checked here, and the
// refined primitive is written here, so that nothing of the primitive depends on tinygltf's own checks.
#include "server/codec/gltf_codec.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <sstream>
#include <unordered_map>
#include <utility>

#include "engine/flip_check.h"
#include "engine/pipeline.h"
#include "engine/refine.h"
#include "engine/validate.h"

namespace lipmap::gltf {

using nlohmann::json;
using nlohmann::ordered_json;

namespace {

constexpr int kByte = 5120, kUByte = 5121, kShort = 5122, kUShort = 5123, kUInt = 5125, kFloat = 5126;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

// Rounds to float32, always. GCC 12's SLP vectorizer (-O2 and up) was seen to drop the double -> float ->
// double round trip of two neighbouring values ({double(float(a)), double(float(b))} compiled to no
// conversion at all); the uv check below must see exactly the stored floats, so the float goes through memory.
float to_f32(double x) {
  volatile float f = static_cast<float>(x);
  return f;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string trim(std::string_view s) {
  std::size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return std::string(s.substr(b, e - b));
}

[[noreturn]] void fail(const std::string& code, const std::string& message, const std::string& pointer = {}) {
  throw GltfError(code, message, pointer);
}

std::string ptr(const std::string& collection, long long index) { return "/" + collection + "/" + std::to_string(index); }

int component_size(int ct) {
  switch (ct) {
    case kByte: case kUByte: return 1;
    case kShort: case kUShort: return 2;
    case kUInt: case kFloat: return 4;
    default: return 0;
  }
}

const char* component_name(int ct) {
  switch (ct) {
    case kByte: return "BYTE";
    case kUByte: return "UNSIGNED_BYTE";
    case kShort: return "SHORT";
    case kUShort: return "UNSIGNED_SHORT";
    case kUInt: return "UNSIGNED_INT";
    case kFloat: return "FLOAT";
    default: return "an unknown component type";
  }
}

// Components and, for matrices, rows (columns = components / rows); 0 for an unknown type.
int type_components(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    case TINYGLTF_TYPE_MAT2: return 4;
    case TINYGLTF_TYPE_MAT3: return 9;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
  }
}
int matrix_rows(int type) {
  switch (type) {
    case TINYGLTF_TYPE_MAT2: return 2;
    case TINYGLTF_TYPE_MAT3: return 3;
    case TINYGLTF_TYPE_MAT4: return 4;
    default: return 0;
  }
}
const char* type_name(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return "SCALAR";
    case TINYGLTF_TYPE_VEC2: return "VEC2";
    case TINYGLTF_TYPE_VEC3: return "VEC3";
    case TINYGLTF_TYPE_VEC4: return "VEC4";
    case TINYGLTF_TYPE_MAT2: return "MAT2";
    case TINYGLTF_TYPE_MAT3: return "MAT3";
    case TINYGLTF_TYPE_MAT4: return "MAT4";
    default: return "an unknown type";
  }
}
int type_for_components(int n) {
  switch (n) {
    case 1: return TINYGLTF_TYPE_SCALAR;
    case 2: return TINYGLTF_TYPE_VEC2;
    case 3: return TINYGLTF_TYPE_VEC3;
    case 4: return TINYGLTF_TYPE_VEC4;
    case 9: return TINYGLTF_TYPE_MAT3;
    case 16: return TINYGLTF_TYPE_MAT4;
    default: return TINYGLTF_TYPE_VEC4;
  }
}

// Bytes of one element, with the column padding of 1- and 2-byte matrices.
std::size_t element_size(int type, int ct) {
  const int rows = matrix_rows(type), cs = component_size(ct);
  if (rows == 0) return static_cast<std::size_t>(type_components(type) * cs);
  const std::size_t column = (static_cast<std::size_t>(rows * cs) + 3) / 4 * 4;
  return column * static_cast<std::size_t>(rows);
}
// Byte offset of component c inside an element.
std::size_t component_offset(int type, int ct, int c) {
  const int rows = matrix_rows(type), cs = component_size(ct);
  if (rows == 0) return static_cast<std::size_t>(c * cs);
  const std::size_t column = (static_cast<std::size_t>(rows * cs) + 3) / 4 * 4;
  return column * static_cast<std::size_t>(c / rows) + static_cast<std::size_t>((c % rows) * cs);
}

double read_component(const unsigned char* p, int ct, bool normalized) {
  switch (ct) {
    case kByte: {
      const double v = static_cast<std::int8_t>(p[0]);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case kUByte: return normalized ? p[0] / 255.0 : p[0];
    case kShort: {
      std::int16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case kUShort: {
      std::uint16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? v / 65535.0 : v;
    }
    case kUInt: {
      std::uint32_t v;
      std::memcpy(&v, p, 4);
      return normalized ? v / 4294967295.0 : v;
    }
    case kFloat: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
    default: return 0;
  }
}

// ---- tinygltf callbacks: never touch the file system, keep image bytes as they are ------------------------

bool no_file_exists(const std::string&, void*) { return false; }
std::string no_expand(const std::string& path, void*) { return path; }
bool no_read(std::vector<unsigned char>*, std::string* err, const std::string& path, void*) {
  if (err) *err += "external file '" + path + "' is not read (lipmap takes self-contained glTF only)\n";
  return false;
}
bool no_write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "lipmap writes no files through tinygltf\n";
  return false;
}

bool keep_image_bytes(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                      const unsigned char* bytes, int size, void*) {
  image->image.assign(bytes, bytes + size);
  image->as_is = true;
  return true;
}

std::string sniff_image_mime(const std::vector<unsigned char>& b) {
  if (b.size() >= 8 && b[0] == 0x89 && b[1] == 'P' && b[2] == 'N' && b[3] == 'G') return "image/png";
  if (b.size() >= 3 && b[0] == 0xff && b[1] == 0xd8 && b[2] == 0xff) return "image/jpeg";
  return "application/octet-stream";
}

bool embed_image_bytes(const std::string*, const std::string*, const tinygltf::Image* image, bool,
                       std::string* out_uri, void*) {
  if (!image->uri.empty() || image->bufferView >= 0) return false;  // kept as the input had it
  const std::string mime = image->mimeType.empty() ? sniff_image_mime(image->image) : image->mimeType;
  *out_uri = "data:" + mime + ";base64," +
             base64_encode(std::string_view(reinterpret_cast<const char*>(image->image.data()), image->image.size()));
  return true;
}

// ---- tinygltf::Value <-> json ------------------------------------------------------------------------

json to_json(const tinygltf::Value& v) {
  switch (v.Type()) {
    case tinygltf::BOOL_TYPE: return v.Get<bool>();
    case tinygltf::INT_TYPE: return v.Get<int>();
    case tinygltf::REAL_TYPE: return v.Get<double>();
    case tinygltf::STRING_TYPE: return v.Get<std::string>();
    case tinygltf::ARRAY_TYPE: {
      json a = json::array();
      for (std::size_t i = 0; i < v.ArrayLen(); ++i) a.push_back(to_json(v.Get(static_cast<int>(i))));
      return a;
    }
    case tinygltf::OBJECT_TYPE: {
      json o = json::object();
      for (const auto& [k, x] : v.Get<tinygltf::Value::Object>()) o[k] = to_json(x);
      return o;
    }
    default: return nullptr;
  }
}

tinygltf::Value to_value(const json& j) {
  switch (j.type()) {
    case json::value_t::boolean: return tinygltf::Value(j.get<bool>());
    case json::value_t::number_integer:
    case json::value_t::number_unsigned: {
      const double d = j.get<double>();
      if (d >= std::numeric_limits<int>::min() && d <= std::numeric_limits<int>::max())
        return tinygltf::Value(static_cast<int>(j.get<long long>()));
      return tinygltf::Value(d);
    }
    case json::value_t::number_float: {
      const double d = j.get<double>();
      return std::isfinite(d) ? tinygltf::Value(d) : tinygltf::Value();
    }
    case json::value_t::string: return tinygltf::Value(j.get<std::string>());
    case json::value_t::array: {
      tinygltf::Value::Array a;
      for (const json& x : j) a.push_back(to_value(x));
      return tinygltf::Value(std::move(a));
    }
    case json::value_t::object: {
      tinygltf::Value::Object o;
      for (auto it = j.begin(); it != j.end(); ++it) o[it.key()] = to_value(it.value());
      return tinygltf::Value(std::move(o));
    }
    default: return tinygltf::Value();
  }
}

// ---- GLB and JSON checks before tinygltf ---------------------------------------------------------------

std::uint32_t u32(const unsigned char* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

std::string hex_bytes(std::string_view b, std::size_t n) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < std::min(n, b.size()); ++i) {
    if (i) out += ' ';
    const auto c = static_cast<unsigned char>(b[i]);
    out += digits[c >> 4];
    out += digits[c & 15];
  }
  return out.empty() ? "nothing" : out;
}

// The GLB's JSON chunk; `length` is set to the GLB length the header declares (bytes past it are ignored).
std::string_view check_glb(std::string_view bytes, std::size_t& length) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  if (bytes.size() < 4 || std::memcmp(p, "glTF", 4) != 0)
    fail("gltf_bad_magic", "not a binary glTF: a .glb starts with the magic bytes 'glTF' (67 6c 54 46), this body starts with " +
                               hex_bytes(bytes, 4));
  if (bytes.size() < 12) fail("gltf_truncated", "truncated GLB: " + std::to_string(bytes.size()) + " bytes, its 12-byte header is incomplete");
  const std::uint32_t version = u32(p + 4), declared = u32(p + 8);
  if (version != 2) fail("gltf_unsupported_version", "GLB container version " + std::to_string(version) + " (lipmap reads glTF 2.0, GLB version 2)");
  if (declared > bytes.size())
    fail("gltf_truncated", "truncated GLB: its header declares " + std::to_string(declared) + " bytes, the body has " +
                               std::to_string(bytes.size()));
  if (declared < 20) fail("gltf_invalid_chunk", "GLB length " + std::to_string(declared) + " leaves no room for the JSON chunk");
  const std::uint32_t json_length = u32(p + 12), json_type = u32(p + 16);
  if (json_type != 0x4E4F534Au) fail("gltf_invalid_chunk", "the first GLB chunk must be JSON (type 0x4E4F534A), got type 0x" + [&] {
                                          std::ostringstream os;
                                          os << std::hex << json_type;
                                          return os.str();
                                        }());
  if (20ull + json_length > declared)
    fail("gltf_truncated", "truncated GLB: the JSON chunk declares " + std::to_string(json_length) + " bytes, only " +
                               std::to_string(declared - 20) + " follow its header");
  std::uint64_t at = 20ull + json_length;
  at = (at + 3) / 4 * 4;
  if (at < declared) {
    if (at + 8 > declared) fail("gltf_truncated", "truncated GLB: the BIN chunk's 8-byte header is incomplete");
    const std::uint32_t bin_length = u32(p + at), bin_type = u32(p + at + 4);
    if (bin_type != 0x004E4942u) fail("gltf_invalid_chunk", "the second GLB chunk must be BIN (type 0x004E4942)");
    if (at + 8 + bin_length > declared)
      fail("gltf_truncated", "truncated GLB: the BIN chunk declares " + std::to_string(bin_length) + " bytes, only " +
                                 std::to_string(declared - at - 8) + " follow its header");
  }
  length = declared;
  return bytes.substr(20, json_length);
}

json parse_document(std::string_view text) {
  json doc;
  try {
    doc = codec::parse_json(text);
  } catch (const codec::JsonError& e) {
    fail("gltf_invalid_json", std::string("the glTF JSON is not valid JSON: ") + e.what() +
                                  (e.pointer().empty() ? "" : " (at " + e.pointer() + ")"));
  }
  if (!doc.is_object()) fail("gltf_invalid_json", "the glTF JSON must be an object, got " + std::string(doc.type_name()));
  const auto asset = doc.find("asset");
  if (asset == doc.end() || !asset->is_object() || !asset->contains("version") || !(*asset)["version"].is_string())
    fail("gltf_invalid", "the glTF JSON has no asset.version (a glTF 2.0 document has \"asset\": {\"version\": \"2.0\"})", "/asset");
  const std::string version = (*asset)["version"].get<std::string>();
  if (version.rfind("2.", 0) != 0)
    fail("gltf_unsupported_version", "glTF version " + version + " (lipmap reads glTF 2.x)", "/asset/version");
  for (const char* list : {"extensionsRequired", "extensionsUsed"}) {
    const auto it = doc.find(list);
    if (it == doc.end() || !it->is_array()) continue;
    for (std::size_t i = 0; i < it->size(); ++i) {
      const json& e = (*it)[i];
      if (e.is_string() && (e == "KHR_draco_mesh_compression" || e == "EXT_meshopt_compression" ||
                            e == "KHR_meshopt_compression"))
        fail("gltf_unsupported_extension",
             "the document uses " + e.get<std::string>() + ": compressed geometry is not supported; decompress it first",
             "/" + std::string(list) + "/" + std::to_string(i));
    }
  }
  if (const auto buffers = doc.find("buffers"); buffers != doc.end() && buffers->is_array())
    for (std::size_t i = 0; i < buffers->size(); ++i) {
      const json& b = (*buffers)[i];
      if (!b.is_object() || !b.contains("uri")) continue;
      if (!b["uri"].is_string()) fail("gltf_invalid", "buffer " + std::to_string(i) + " has a uri that is not a string", ptr("buffers", i) + "/uri");
      const std::string uri = b["uri"].get<std::string>();
      if (uri.rfind("data:", 0) != 0)
        fail("gltf_external_uri", "buffer " + std::to_string(i) + " refers to the external file '" + uri.substr(0, 200) +
                                      "': lipmap reads only self-contained glTF (the GLB BIN chunk or data: URIs)",
             ptr("buffers", i) + "/uri");
      if (!tinygltf::IsDataURI(uri))
        fail("gltf_invalid_data_uri", "buffer " + std::to_string(i) + " has a data URI lipmap cannot decode (use data:application/octet-stream;base64,...)",
             ptr("buffers", i) + "/uri");
    }
  return doc;
}

// ---- reading accessors --------------------------------------------------------------------------------

struct Read {
  const tinygltf::Model& model;

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
  Attribute accessor(int index, const std::string& what) const {
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
      const unsigned char* base = view_bytes(a.bufferView, a.byteOffset, need, name, aptr);
      if (a.byteOffset % static_cast<std::size_t>(cs) != 0)
        fail("gltf_accessor_mismatch", name + ": byteOffset " + std::to_string(a.byteOffset) + " is not a multiple of its component size", aptr);
      out.values.resize(count * static_cast<std::size_t>(comps));
      for (std::size_t i = 0; i < count; ++i)
        for (int c = 0; c < comps; ++c)
          out.values[i * comps + c] =
              read_component(base + i * stride + component_offset(a.type, a.componentType, c), a.componentType, a.normalized);
    } else {
      if (count == 0 || count > (std::size_t{1} << 28))
        fail("gltf_accessor_mismatch", name + " has no bufferView and " + std::to_string(count) + " elements", aptr);
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

bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

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

bool is_float_semantic(const std::string& name) {
  return name == "POSITION" || name == "NORMAL" || name == "TANGENT" || starts_with(name, "TEXCOORD_") ||
         starts_with(name, "COLOR_") || starts_with(name, "WEIGHTS_");
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

// ---- Impl ---------------------------------------------------------------------------------------------

struct Asset::Impl {
  tinygltf::Model model;
  Format format = Format::glb;
  Selection selection;
  RawMesh mesh;
  std::vector<int> loop;
  std::size_t primitive_vertices = 0, welded = 0, unused = 0, split_positions = 0;
  std::vector<int> rep;  // engine vertex -> primitive vertex
  std::vector<Attribute> attributes;                 // per primitive vertex, POSITION included
  std::vector<std::vector<Attribute>> targets;       // morph targets, per primitive vertex
  json extras;
};

GltfError::GltfError(std::string code, const std::string& message, std::string gltf_pointer)
    : InputError(std::move(code), message, "gltf"), gltf_pointer_(std::move(gltf_pointer)) {}

int GltfError::status() const {
  static const char* unprocessable[] = {"gltf_mesh_not_found",      "gltf_primitive_not_found", "gltf_unsupported_mode",
                                        "gltf_no_position",         "gltf_no_triangles",        "gltf_texcoord_missing",
                                        "gltf_unsupported_extension", "gltf_non_finite"};
  for (const char* c : unprocessable)
    if (code() == c) return 422;
  return 400;
}

const char* media_type(Format format) { return format == Format::glb ? "model/gltf-binary" : "model/gltf+json"; }
const char* extension(Format format) { return format == Format::glb ? ".glb" : ".gltf"; }
const char* to_string(Weld weld) { return weld == Weld::position ? "position" : "none"; }

std::optional<Format> format_from_media_type(std::string_view content_type) {
  const std::string t = lower(trim(content_type.substr(0, content_type.find(';'))));
  if (t == "model/gltf-binary") return Format::glb;
  if (t == "model/gltf+json") return Format::gltf;
  return std::nullopt;
}

std::optional<Format> format_from_path(std::string_view path) {
  const std::string p = lower(path);
  auto ends = [&](const char* e) { return p.size() >= std::strlen(e) && p.compare(p.size() - std::strlen(e), std::string::npos, e) == 0; };
  if (ends(".glb")) return Format::glb;
  if (ends(".gltf")) return Format::gltf;
  return std::nullopt;
}

std::optional<Format> sniff_format(std::string_view bytes) {
  if (bytes.size() >= 4 && bytes.substr(0, 4) == "glTF") return Format::glb;
  for (char c : bytes) {
    if (std::isspace(static_cast<unsigned char>(c))) continue;
    if (c == '{') return Format::gltf;
    break;
  }
  // A UTF-8 byte order mark before the JSON.
  if (bytes.size() >= 4 && bytes.substr(0, 3) == "\xEF\xBB\xBF" && bytes[3] == '{') return Format::gltf;
  return std::nullopt;
}

std::optional<Format> accepted_format(std::string_view accept) {
  struct Choice {
    std::optional<Format> format;
    double q;
    std::size_t order;
  };
  std::optional<Choice> best;
  std::size_t order = 0;
  std::size_t start = 0;
  while (start <= accept.size()) {
    std::size_t end = accept.find(',', start);
    if (end == std::string_view::npos) end = accept.size();
    const std::string_view item = accept.substr(start, end - start);
    start = end + 1;
    const std::string type = lower(trim(item.substr(0, item.find(';'))));
    if (type.empty()) continue;
    double q = 1;
    for (std::size_t at = item.find(';'); at != std::string_view::npos; at = item.find(';', at + 1)) {
      std::string param = lower(trim(item.substr(at + 1, item.find(';', at + 1) - at - 1)));
      if (param.rfind("q=", 0) == 0) {
        try {
          q = std::stod(param.substr(2));
        } catch (...) {
          q = 0;
        }
      }
    }
    if (q <= 0) continue;
    std::optional<Format> f;
    if (type == "model/gltf-binary") f = Format::glb;
    else if (type == "model/gltf+json") f = Format::gltf;
    else if (type != "application/json" && type != "*/*" && type != "application/*") continue;
    if (!best || q > best->q) best = Choice{f, q, order};
    ++order;
  }
  return best ? best->format : std::nullopt;
}

// ---- reading ------------------------------------------------------------------------------------------

Asset Asset::read(std::string_view bytes, const Selection& selection, std::optional<Format> expected) {
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
  const std::string_view json_text = m.format == Format::glb ? check_glb(bytes, glb_length) : bytes;
  parse_document(json_text);

  tinygltf::TinyGLTF loader;
  tinygltf::FsCallbacks fs{&no_file_exists, &no_expand, &no_read, &no_write, nullptr};
  loader.SetFsCallbacks(fs);
  loader.SetImageLoader(&keep_image_bytes, nullptr);
  std::string err, warn;
  bool ok;
  if (glb_length > std::numeric_limits<unsigned int>::max()) fail("gltf_invalid", "glTF larger than 4 GiB");
  if (m.format == Format::glb)
    ok = loader.LoadBinaryFromMemory(&m.model, &err, &warn, reinterpret_cast<const unsigned char*>(bytes.data()),
                                     static_cast<unsigned int>(glb_length), "", tinygltf::REQUIRE_VERSION);
  else
    ok = loader.LoadASCIIFromString(&m.model, &err, &warn, bytes.data(), static_cast<unsigned int>(bytes.size()), "",
                                    tinygltf::REQUIRE_VERSION);
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

  Read read{m.model};
  std::size_t nvert = 0;
  for (const auto& [name, index] : prim.attributes) {
    if (index < 0 || static_cast<std::size_t>(index) >= m.model.accessors.size())
      fail("gltf_invalid", where + " attribute " + name + " refers to accessor " + std::to_string(index) + ", which does not exist",
           pptr + "/attributes/" + codec::escape_pointer_token(name));
    check_semantic(name, m.model.accessors[index], index, where);
  }
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

RawBoundary Asset::texcoord_boundary(int set) const {
  const std::string name = "TEXCOORD_" + std::to_string(set);
  const std::optional<Attribute> tc = attribute(name);
  if (!tc) {
    std::string have;
    for (const std::string& n : attribute_names())
      if (starts_with(n, "TEXCOORD_")) have += (have.empty() ? "" : ", ") + n;
    fail("gltf_texcoord_missing", "boundary=texcoord:" + std::to_string(set) + ": the primitive has no " + name +
                                      (have.empty() ? " (it has no TEXCOORD set)" : " (it has " + have + ")"));
  }
  RawBoundary b;
  b.vertices = std::vector<long long>();
  for (int v : impl_->loop) {
    b.vertices->push_back(v);
    b.positions.push_back({tc->values[2 * v], 1.0 - tc->values[2 * v + 1]});
  }
  return b;
}

// ---- writing ------------------------------------------------------------------------------------------

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
          const float f = to_f32(v);
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

long double corner_angle(const Point2& a, const Point2& b, const Point2& c) {
  const long double ux = (long double)b.x - a.x, uy = (long double)b.y - a.y;
  const long double wx = (long double)c.x - a.x, wy = (long double)c.y - a.y;
  return std::fabs(std::atan2(ux * wy - uy * wx, ux * wx + uy * wy));
}

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

bool face_valid(const Triangle& t, const std::vector<Point2>& stored, const std::vector<Point2>& back) {
  return orientation_sign(stored[t[0]], stored[t[1]], stored[t[2]]) == -1 &&
         orientation_sign(back[t[0]], back[t[1]], back[t[2]]) == 1;
}

// See Asset::write. Returns the number of vertices moved.
std::size_t repair_float32_rounding(const std::vector<Triangle>& faces, std::vector<Point2>& stored, std::vector<Point2>& back) {
  std::vector<int> bad;
  for (std::size_t f = 0; f < faces.size(); ++f)
    if (!face_valid(faces[f], stored, back)) bad.push_back(static_cast<int>(f));
  if (bad.empty()) return 0;
  const std::size_t nv = stored.size();
  std::vector<std::vector<int>> faces_of(nv);
  std::unordered_map<std::uint64_t, int> edge_count;
  auto key = [](int a, int b) {
    if (a > b) std::swap(a, b);
    return static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32 | static_cast<std::uint32_t>(b);
  };
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (int c = 0; c < 3; ++c) {
      faces_of[faces[f][c]].push_back(static_cast<int>(f));
      ++edge_count[key(faces[f][c], faces[f][(c + 1) % 3])];
    }
  std::vector<char> boundary(nv, 0);
  for (const auto& [k, n] : edge_count)
    if (n == 1) boundary[k >> 32] = boundary[k & 0xffffffffu] = 1;
  std::vector<char> moved(nv, 0);
  auto step = [](float x, int n) {
    for (; n > 0; --n) x = std::nextafter(x, std::numeric_limits<float>::infinity());
    for (; n < 0; ++n) x = std::nextafter(x, -std::numeric_limits<float>::infinity());
    return x;
  };
  // Smallest moves first: one coordinate by one ulp, then both, then two ulps.
  std::vector<std::pair<int, int>> offsets;
  for (int ds = -2; ds <= 2; ++ds)
    for (int dt = -2; dt <= 2; ++dt)
      if (ds || dt) offsets.push_back({ds, dt});
  std::stable_sort(offsets.begin(), offsets.end(), [](const auto& x, const auto& y) {
    const auto cost = [](const std::pair<int, int>& o) {
      return std::max(std::abs(o.first), std::abs(o.second)) * 10 + std::abs(o.first) + std::abs(o.second);
    };
    return cost(x) < cost(y);
  });
  for (int round = 0; round < 4 && !bad.empty(); ++round) {
    for (int f : bad) {
      if (face_valid(faces[f], stored, back)) continue;
      for (int v : faces[f]) {
        if (boundary[v]) continue;
        const Point2 s0 = stored[v], b0 = back[v];
        bool fixed = false;
        for (const auto& [ds, dt] : offsets) {
          const float s = step(static_cast<float>(s0.x), ds), t = step(static_cast<float>(s0.y), dt);
          stored[v] = {s, t};
          back[v] = {s, 1.0 - static_cast<double>(t)};
          fixed = std::all_of(faces_of[v].begin(), faces_of[v].end(),
                              [&](int g) { return face_valid(faces[g], stored, back); });
          if (fixed) break;
        }
        if (fixed) {
          moved[v] = 1;
          break;
        }
        stored[v] = s0;
        back[v] = b0;
      }
    }
    std::vector<int> still;
    for (int f : bad)
      if (!face_valid(faces[f], stored, back)) still.push_back(f);
    bad.swap(still);
  }
  return static_cast<std::size_t>(std::count(moved.begin(), moved.end(), 1));
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

  // ---- uv as stored, checked as stored ----
  std::vector<double> st(2 * nv);
  std::vector<Point2> stored(nv), back(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const float s = to_f32(map.uv[v].x), t = to_f32(1.0 - map.uv[v].y);
    st[2 * v] = s;
    st[2 * v + 1] = t;
    stored[v] = {s, t};
    back[v] = {s, 1.0 - static_cast<double>(t)};
  }
  // Where rounding to float32 breaks a triangle, its interior corners may move to a neighbouring float (up to
  // 2 ulps in s and t) when that makes every triangle around them valid again; boundary vertices never move
  // (they stay the float32 of their targets). Whatever comes out is checked in full below.
  const std::size_t adjusted = repair_float32_rounding(map.faces, stored, back);
  for (std::size_t v = 0; v < nv; ++v) {
    st[2 * v] = stored[v].x;
    st[2 * v + 1] = stored[v].y;
  }
  for (std::size_t f = 0; f < map.faces.size(); ++f) {
    const Triangle& t = map.faces[f];
    const int in_st = orientation_sign(stored[t[0]], stored[t[1]], stored[t[2]]);
    const int in_uv = orientation_sign(back[t[0]], back[t[1]], back[t[2]]);
    if (in_st != -1 || in_uv != 1) {
      std::string corners;
      for (int c : t)
        corners += " vertex " + std::to_string(c) + " uv (" + num(map.uv[c].x) + ", " + num(map.uv[c].y) + ") -> TEXCOORD_0 (" +
                   num(stored[c].x) + ", " + num(stored[c].y) + ");";
      throw Float32RoundingError("rounding uv to float32 for glTF would make face " + std::to_string(f) + " (" +
                                     std::to_string(t[0]) + ", " + std::to_string(t[1]) + ", " + std::to_string(t[2]) + ") " +
                                     (in_uv == 0 ? "degenerate" : "flipped") + ":" + corners +
                                     " the double-precision map is locally injective, but glTF cannot store it; nothing was written",
                                 static_cast<int>(f));
    }
  }
  {
    std::unordered_map<std::uint64_t, int> edge_count;
    auto key = [](int a, int b) {
      if (a > b) std::swap(a, b);
      return static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32 | static_cast<std::uint32_t>(b);
    };
    for (const Triangle& t : map.faces)
      for (int c = 0; c < 3; ++c) ++edge_count[key(t[c], t[(c + 1) % 3])];
    std::vector<char> boundary(nv, 0);
    for (const auto& [k, n] : edge_count)
      if (n == 1) boundary[k >> 32] = boundary[k & 0xffffffffu] = 1;
    std::vector<long double> theta(nv, 0);
    for (const Triangle& t : map.faces)
      for (int c = 0; c < 3; ++c) theta[t[c]] += corner_angle(back[t[c]], back[t[(c + 1) % 3]], back[t[(c + 2) % 3]]);
    constexpr long double kTwoPi = 6.283185307179586476925286766559L;
    for (std::size_t v = 0; v < nv; ++v)
      if (!boundary[v] && std::fabs(theta[v] - kTwoPi) > 1e-6L)
        throw Float32RoundingError("rounding uv to float32 for glTF would make the uv angles around interior vertex " +
                                       std::to_string(v) + " sum to " + num(static_cast<double>(theta[v])) +
                                       " instead of 2 pi; nothing was written",
                                   -1);
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
  merged["lipmap"]["float32_adjusted_vertices"] = adjusted;
  prim.extras = to_value(merged);
  prim.extras_json_string.clear();

  tinygltf::Buffer buffer = model.buffers.empty() ? tinygltf::Buffer() : model.buffers[0];
  buffer.uri.clear();
  buffer.data = std::move(data);
  while (buffer.data.size() % 4) buffer.data.push_back(0);
  model.buffers.assign(1, std::move(buffer));

  tinygltf::TinyGLTF writer;
  tinygltf::FsCallbacks fs{&no_file_exists, &no_expand, &no_read, &no_write, nullptr};
  writer.SetFsCallbacks(fs);
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

// ---- requests -----------------------------------------------------------------------------------------

namespace {

int parse_index(const std::string& text, const char* what) {
  const std::string t = trim(text);
  if (t.empty() || t.size() > 9 || !std::all_of(t.begin(), t.end(), [](char c) { return c >= '0' && c <= '9'; }))
    fail("gltf_invalid_request", std::string(what) + " must be a non-negative integer, got '" + text.substr(0, 40) + "'");
  return std::stoi(t);
}

Weld parse_weld(const std::string& text) {
  if (text == "none") return Weld::none;
  if (text == "position") return Weld::position;
  fail("gltf_invalid_request", "weld must be \"none\" or \"position\", got '" + text.substr(0, 40) + "'");
}

// Merges an envelope member and a parameter that must agree.
template <class T>
std::optional<T> agree(const std::optional<T>& member, const std::optional<T>& param, const char* what) {
  if (member && param && !(*member == *param))
    fail("gltf_invalid_request", std::string(what) + " is given both in the body and as a parameter, with different values");
  return member ? member : param;
}

Selection selection_of(const Params& p, std::optional<int> mesh, std::optional<int> primitive, std::optional<Weld> weld) {
  Selection s;
  std::optional<int> pm, pp;
  std::optional<Weld> pw;
  if (p.mesh) pm = parse_index(*p.mesh, "mesh");
  if (p.primitive) pp = parse_index(*p.primitive, "primitive");
  if (p.weld) pw = parse_weld(*p.weld);
  s.mesh = agree(mesh, pm, "mesh").value_or(0);
  s.primitive = agree(primitive, pp, "primitive").value_or(0);
  s.weld = agree(weld, pw, "weld").value_or(Weld::none);
  return s;
}

// Boundary and options through the parametrize codec (same rules and pointers as a parametrize body).
codec::ParametrizeRequest parse_rest(const json* boundary, const json* options) {
  json body = {{"mesh", {{"vertices", json::array()}, {"faces", json::array()}}},
               {"boundary", boundary ? *boundary : json{{"positions", json::array()}}}};
  if (options) body["options"] = *options;
  return codec::parametrize_request_from_json(body);
}

Request finish(Asset asset, const std::optional<int>& texcoord, const json* boundary, const json* options) {
  if (!texcoord && !boundary)
    fail("gltf_invalid_request", "no boundary: send it as JSON (a \"boundary\" member or multipart part) or ask for boundary=texcoord:N");
  if (texcoord && boundary)
    fail("gltf_invalid_request", "two boundaries: boundary=texcoord:N and a boundary object; send one");
  Request r{std::move(asset), parse_rest(boundary, options), texcoord};
  r.request.mesh = r.asset.mesh();
  if (texcoord) r.request.boundary = r.asset.texcoord_boundary(*texcoord);
  return r;
}

}  // namespace

std::optional<int> parse_texcoord_spec(std::string_view spec) {
  const std::string s = trim(spec);
  if (s.rfind("texcoord:", 0) != 0) return std::nullopt;
  return parse_index(s.substr(9), "the N of boundary=texcoord:N");
}

bool is_envelope(const nlohmann::json& body) { return body.is_object() && body.contains("gltf_base64"); }

Request request_from_model(std::string_view bytes, Format format, const Params& params) {
  std::optional<int> texcoord;
  if (params.boundary) {
    texcoord = parse_texcoord_spec(*params.boundary);
    if (!texcoord)
      fail("gltf_invalid_request", "the boundary parameter must be texcoord:N; a boundary polygon comes as JSON (multipart part "
                                   "\"boundary\" or the JSON envelope)");
  } else {
    fail("gltf_invalid_request", "a bare glTF body needs boundary=texcoord:N; a boundary polygon comes as JSON (multipart/form-data "
                                 "with parts \"model\" and \"boundary\", or the JSON envelope {\"gltf_base64\", \"boundary\"})");
  }
  Asset asset = Asset::read(bytes, selection_of(params, std::nullopt, std::nullopt, std::nullopt), format);
  return finish(std::move(asset), texcoord, nullptr, nullptr);
}

Request request_from_envelope(const nlohmann::json& body, const Params& params) {
  if (!body.is_object()) fail("gltf_invalid_request", "the glTF envelope must be a JSON object");
  for (auto it = body.begin(); it != body.end(); ++it) {
    static const char* known[] = {"gltf_base64", "boundary", "options", "mesh", "primitive", "weld"};
    if (std::find_if(std::begin(known), std::end(known), [&](const char* k) { return it.key() == k; }) == std::end(known))
      throw codec::JsonError("unknown_field", "unknown member \"" + it.key() + "\" (the glTF envelope has gltf_base64, boundary, options, mesh, primitive, weld)",
                             "/" + codec::escape_pointer_token(it.key()));
  }
  const json& b64 = body["gltf_base64"];
  if (!b64.is_string()) throw codec::JsonError("wrong_type", "gltf_base64 must be a string (the .glb or .gltf, base64)", "/gltf_base64");
  auto index_member = [&](const char* key) -> std::optional<int> {
    const auto it = body.find(key);
    if (it == body.end()) return std::nullopt;
    if (!it->is_number_integer() || it->get<long long>() < 0 || it->get<long long>() > 999999999)
      throw codec::JsonError("wrong_type", std::string(key) + " must be a non-negative integer", std::string("/") + key);
    return it->get<int>();
  };
  std::optional<Weld> weld;
  if (const auto it = body.find("weld"); it != body.end()) {
    if (!it->is_string()) throw codec::JsonError("wrong_type", "weld must be \"none\" or \"position\"", "/weld");
    weld = parse_weld(it->get<std::string>());
  }
  const Selection sel = selection_of(params, index_member("mesh"), index_member("primitive"), weld);
  const std::string bytes = base64_decode(b64.get<std::string>());
  const json* boundary = nullptr;
  std::optional<int> texcoord;
  if (const auto it = body.find("boundary"); it != body.end()) {
    if (it->is_string()) {
      texcoord = parse_texcoord_spec(it->get<std::string>());
      if (!texcoord) throw codec::JsonError("invalid_value", "boundary must be an object or \"texcoord:N\"", "/boundary");
    } else {
      boundary = &*it;
    }
  }
  if (params.boundary) {
    const std::optional<int> p = parse_texcoord_spec(*params.boundary);
    if (!p) fail("gltf_invalid_request", "the boundary parameter must be texcoord:N");
    texcoord = agree(texcoord, p, "boundary");
  }
  const json* options = body.contains("options") ? &body["options"] : nullptr;
  // Shape errors of boundary/options before the (possibly large) model is read.
  parse_rest(boundary, options);
  Asset asset = Asset::read(bytes, sel);
  return finish(std::move(asset), texcoord, boundary, options);
}

Request request_from_parts(const std::map<std::string, Part>& parts, const Params& params) {
  for (const auto& [name, part] : parts)
    if (name != "model" && name != "boundary" && name != "options")
      fail("gltf_invalid_request", "unknown multipart part \"" + name.substr(0, 40) + "\" (parts: model, boundary, options)");
  const auto model = parts.find("model");
  if (model == parts.end()) fail("gltf_invalid_request", "the multipart body has no \"model\" part (the .glb or .gltf)");
  std::optional<Format> format = format_from_media_type(model->second.content_type);
  json boundary_json, options_json;
  const json* boundary = nullptr;
  const json* options = nullptr;
  std::optional<int> texcoord;
  if (const auto b = parts.find("boundary"); b != parts.end()) {
    if (const auto t = parse_texcoord_spec(b->second.content)) {
      texcoord = t;
    } else {
      try {
        boundary_json = codec::parse_json(b->second.content);
      } catch (const codec::JsonError& e) {
        throw codec::JsonError(e.code(), std::string("multipart part \"boundary\": ") + e.what(), "/boundary" + e.pointer(), e.byte_offset());
      }
      boundary = &boundary_json;
    }
  }
  if (params.boundary) {
    const std::optional<int> p = parse_texcoord_spec(*params.boundary);
    if (!p) fail("gltf_invalid_request", "the boundary parameter must be texcoord:N");
    texcoord = agree(texcoord, p, "boundary");
  }
  if (const auto o = parts.find("options"); o != parts.end()) {
    try {
      options_json = codec::parse_json(o->second.content);
    } catch (const codec::JsonError& e) {
      throw codec::JsonError(e.code(), std::string("multipart part \"options\": ") + e.what(), "/options" + e.pointer(), e.byte_offset());
    }
    options = &options_json;
  }
  parse_rest(boundary, options);
  Asset asset = Asset::read(model->second.content, selection_of(params, std::nullopt, std::nullopt, std::nullopt), format);
  return finish(std::move(asset), texcoord, boundary, options);
}

nlohmann::ordered_json problem_json(const GltfError& error) {
  const int status = error.status();
  ordered_json p = codec::problem_json(status, status == 400 ? "Malformed glTF" : "glTF not mappable", error.code(), error.what());
  if (!error.gltf_pointer().empty()) p["gltf_pointer"] = error.gltf_pointer();
  return p;
}

// ---- base64 -------------------------------------------------------------------------------------------

std::string base64_encode(std::string_view bytes) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const std::uint32_t n = static_cast<unsigned char>(bytes[i]) << 16 | static_cast<unsigned char>(bytes[i + 1]) << 8 |
                            static_cast<unsigned char>(bytes[i + 2]);
    out += table[n >> 18];
    out += table[(n >> 12) & 63];
    out += table[(n >> 6) & 63];
    out += table[n & 63];
  }
  if (i < bytes.size()) {
    std::uint32_t n = static_cast<unsigned char>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) n |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    out += table[n >> 18];
    out += table[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? table[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string base64_decode(std::string_view text, const std::string& what) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+' || c == '-') return 62;
    if (c == '/' || c == '_') return 63;
    return -1;
  };
  std::string out;
  out.reserve(text.size() / 4 * 3);
  std::uint32_t acc = 0;
  int n = 0, pad = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == ' ' || c == '\n' || c == '\r' || c == '\t') continue;
    if (c == '=') {
      ++pad;
      continue;
    }
    const int v = value(c);
    if (v < 0 || pad > 0)
      fail("gltf_invalid_base64", what + " is not base64: " + (pad > 0 ? "data after '=' padding" : "character " + hex_bytes(text.substr(i, 1), 1)) +
                                      " at offset " + std::to_string(i));
    acc = acc << 6 | static_cast<std::uint32_t>(v);
    if (++n == 4) {
      out += static_cast<char>(acc >> 16);
      out += static_cast<char>((acc >> 8) & 255);
      out += static_cast<char>(acc & 255);
      acc = 0;
      n = 0;
    }
  }
  if (n == 1 || pad > 2) fail("gltf_invalid_base64", what + " is not base64: its length does not fit the encoding");
  if (n == 2) out += static_cast<char>(acc >> 4);
  if (n == 3) {
    out += static_cast<char>(acc >> 10);
    out += static_cast<char>((acc >> 2) & 255);
  }
  return out;
}

}  // namespace lipmap::gltf
