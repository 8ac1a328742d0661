// glTF media types, format sniffing, the Accept header, and the checks of a GLB container and of the glTF JSON
// that run before tinygltf sees the bytes (see gltf_codec.h).
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <optional>
#include <sstream>

#include "server/codec/gltf_internal.h"
#include "server/codec/json_codec.h"

namespace lipmap::gltf {

using nlohmann::json;
using namespace internal;

GltfError::GltfError(std::string code, const std::string& message, std::string gltf_pointer)
    : InputError(std::move(code), message, "gltf"), gltf_pointer_(std::move(gltf_pointer)) {}

const char* media_type(Format format) { return format == Format::glb ? "model/gltf-binary" : "model/gltf+json"; }
const char* extension(Format format) { return format == Format::glb ? ".glb" : ".gltf"; }
const char* to_string(Weld weld) { return weld == Weld::position ? "position" : "none"; }

std::optional<Format> format_from_media_type(std::string_view content_type) {
  const std::string t = codec::media_type(content_type);
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
    const std::string type = codec::media_type(item);
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

namespace internal {
namespace {

std::uint32_t u32(const unsigned char* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

}  // namespace

// The GLB's JSON chunk; `length` is set to the GLB length the header declares (bytes past it are ignored).
std::string_view check_glb(std::string_view bytes, std::size_t& length, std::optional<std::size_t>& bin_chunk) {
  bin_chunk.reset();
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
    bin_chunk = bin_length;
  }
  length = declared;
  return bytes.substr(20, json_length);
}

namespace {

// JSON numbers above 2^53 are not exact in every reader; no size or index of a document is that large.
constexpr std::uint64_t kMaxInteger = std::uint64_t{1} << 53;

// The extensions a document may require: lipmap reads geometry of any component type
// (KHR_mesh_quantization) and keeps materials, textures and lights as they are, so the meaning of the
// primitive it maps does not depend on them. Any other required extension is refused, as the spec asks.
bool supported_required_extension(const std::string& name) {
  return name == "KHR_mesh_quantization" || name == "KHR_texture_transform" || name == "KHR_texture_basisu" ||
         name == "KHR_lights_punctual" || name == "EXT_texture_webp" || name == "EXT_texture_avif" ||
         name.rfind("KHR_materials_", 0) == 0;
}

// The schema ranges of the integer fields tinygltf reads (it takes a negative or non-integer value as
// absent, or keeps it), and every size against the bytes that back it: an accessor within its bufferView,
// a bufferView within its buffer, a buffer within the bytes present. Done on the JSON, before tinygltf or
// the reader size anything from a count.
struct Structure {
  const json& doc;
  std::optional<std::size_t> bin_chunk;  // GLB: the BIN chunk's length (nullopt: a .gltf, or a GLB without one)
  bool glb;

  const json& array(const char* name) const {
    static const json empty = json::array();
    const auto it = doc.find(name);
    if (it == doc.end()) return empty;
    if (!it->is_array()) fail("gltf_invalid", std::string(name) + " is " + it->type_name() + ", not an array", "/" + std::string(name));
    return *it;
  }

  static const json& object(const json& j, const std::string& what, const std::string& pointer) {
    if (!j.is_object()) fail("gltf_invalid", what + " is " + j.type_name() + ", not an object", pointer);
    return j;
  }

  // An integer field in lo..hi; `fallback` when absent and optional (nullopt: required).
  static std::uint64_t integer(const json& o, const char* key, const std::string& what, const std::string& pointer,
                               std::uint64_t lo, std::uint64_t hi, std::optional<std::uint64_t> fallback) {
    const auto it = o.find(key);
    const std::string at = pointer + "/" + key;
    if (it == o.end()) {
      if (!fallback) fail("gltf_invalid", what + " has no " + key, pointer);
      return *fallback;
    }
    // nlohmann keeps a non-negative integer as unsigned; negatives, fractions and non-numbers are out.
    const bool in_range = it->is_number_unsigned() && it->get<std::uint64_t>() >= lo && it->get<std::uint64_t>() <= hi;
    if (!in_range)
      fail("gltf_invalid", what + " " + key + " is " + it->dump().substr(0, 40) + ": glTF requires an integer in " +
                               std::to_string(lo) + ".." + std::to_string(hi),
           at);
    return it->get<std::uint64_t>();
  }
  static std::uint64_t index(const json& o, const char* key, const std::string& what, const std::string& pointer,
                             std::size_t count, const char* collection) {
    if (count == 0) {
      if (o.contains(key)) fail("gltf_invalid", what + " " + key + " refers to " + collection + ", and the document has none", pointer + "/" + key);
      return 0;
    }
    return integer(o, key, what, pointer, 0, count - 1, std::nullopt);
  }

  // bytes: also every accessor against the bytes of its bufferView (after the reader's checks of the
  // selected primitive's semantics, which name the problem better).
  void check(bool bytes) const {
    const json& buffers = array("buffers");
    const json& views = array("bufferViews");
    const json& accessors = array("accessors");
    std::vector<std::uint64_t> buffer_length(buffers.size()), view_length(views.size()), view_stride(views.size());
    for (std::size_t i = 0; i < buffers.size(); ++i) {
      const std::string bp = ptr("buffers", i), what = "buffer " + std::to_string(i);
      const json& b = object(buffers[i], what, bp);
      const std::uint64_t length = buffer_length[i] = integer(b, "byteLength", what, bp, 1, kMaxInteger, std::nullopt);
      std::uint64_t present = 0;
      if (const auto uri = b.find("uri"); uri != b.end() && uri->is_string()) {
        // A base64 data URI (parse_document checked the form): 3 bytes per 4 characters after the comma.
        const std::string& u = uri->get_ref<const std::string&>();
        const std::size_t comma = u.find(',');
        present = comma == std::string::npos ? 0 : (u.size() - comma - 1) / 4 * 3 + 2;
      } else if (glb && i == 0 && bin_chunk) {
        present = *bin_chunk;
      } else {
        fail("gltf_invalid", what + " has no uri" + (glb && i == 0 ? ", and the GLB has no BIN chunk" : std::string(glb ? " (only buffer 0 may be the GLB's BIN chunk)" : " (a .gltf buffer is a data: URI)")), bp);
      }
      if (length > present)
        fail("gltf_buffer_out_of_range", what + " declares byteLength " + std::to_string(length) + ", but only " +
                                             std::to_string(present) + " bytes back it",
             bp + "/byteLength");
    }
    for (std::size_t i = 0; i < views.size(); ++i) {
      const std::string vp = ptr("bufferViews", i), what = "bufferView " + std::to_string(i);
      const json& v = object(views[i], what, vp);
      const std::uint64_t buffer = index(v, "buffer", what, vp, buffers.size(), "buffers");
      if (buffers.empty()) fail("gltf_invalid", what + " refers to a buffer, and the document has none", vp);
      const std::uint64_t offset = integer(v, "byteOffset", what, vp, 0, kMaxInteger, 0);
      const std::uint64_t length = view_length[i] = integer(v, "byteLength", what, vp, 1, kMaxInteger, std::nullopt);
      view_stride[i] = integer(v, "byteStride", what, vp, 4, 252, 0);
      if (view_stride[i] % 4 != 0)
        fail("gltf_invalid", what + " byteStride " + std::to_string(view_stride[i]) + " is not a multiple of 4", vp + "/byteStride");
      if (v.contains("target")) {
        const std::uint64_t target = integer(v, "target", what, vp, kArrayBuffer, kElementArrayBuffer, std::nullopt);
        if (target != static_cast<std::uint64_t>(kArrayBuffer) && target != static_cast<std::uint64_t>(kElementArrayBuffer))
          fail("gltf_invalid", what + " target " + std::to_string(target) + " is neither 34962 nor 34963", vp + "/target");
      }
      if (offset + length > buffer_length[buffer])
        fail("gltf_buffer_out_of_range", what + " spans bytes " + std::to_string(offset) + ".." + std::to_string(offset + length) +
                                             " of buffer " + std::to_string(buffer) + ", which has " +
                                             std::to_string(buffer_length[buffer]) + " bytes",
             vp);
    }
    // What uses each accessor first, to name it in messages ("mesh 0 primitive 0 attribute NORMAL").
    std::vector<std::string> label(accessors.size());
    const json& meshes = array("meshes");
    for (std::size_t m = 0; m < meshes.size(); ++m) {
      const std::string mp = ptr("meshes", m);
      const json& mesh = object(meshes[m], "mesh " + std::to_string(m), mp);
      const auto prims = mesh.find("primitives");
      if (prims == mesh.end() || !prims->is_array())
        fail("gltf_invalid", "mesh " + std::to_string(m) + " has no primitives array", mp);
      for (std::size_t p = 0; p < prims->size(); ++p) {
        const std::string pp = mp + "/primitives/" + std::to_string(p);
        const std::string what = "mesh " + std::to_string(m) + " primitive " + std::to_string(p);
        const json& prim = object((*prims)[p], what, pp);
        integer(prim, "mode", what, pp, 0, 6, 4);
        if (prim.contains("indices")) {
          const std::uint64_t a = index(prim, "indices", what, pp, accessors.size(), "accessors");
          if (label[a].empty()) label[a] = what + " indices";
        }
        auto attribute_map = [&](const json& map, const std::string& name, const std::string& pointer) {
          object(map, name, pointer);
          for (const auto& [semantic, value] : map.items()) {
            if (accessors.empty()) fail("gltf_invalid", name + " " + semantic + " refers to an accessor, and the document has none", pointer);
            const std::uint64_t a = integer(map, semantic.c_str(), name, pointer, 0, accessors.size() - 1, std::nullopt);
            if (label[a].empty()) label[a] = name + " " + semantic;
          }
        };
        if (!prim.contains("attributes")) fail("gltf_invalid", what + " has no attributes", pp);
        attribute_map(prim["attributes"], what + " attribute", pp + "/attributes");
        if (const auto targets = prim.find("targets"); targets != prim.end()) {
          if (!targets->is_array()) fail("gltf_invalid", what + " targets is not an array", pp + "/targets");
          for (std::size_t t = 0; t < targets->size(); ++t)
            attribute_map((*targets)[t], what + " morph target " + std::to_string(t), pp + "/targets/" + std::to_string(t));
        }
      }
    }
    // Bytes [offset, offset + size) of a bufferView, or a refusal.
    auto within_view = [&](std::uint64_t view, std::uint64_t offset, std::uint64_t size, const std::string& what, const std::string& pointer) {
      if (offset > view_length[view] || size > view_length[view] - offset)
        fail("gltf_buffer_out_of_range", what + " needs bytes " + std::to_string(offset) + ".." + std::to_string(offset + size) +
                                             " of bufferView " + std::to_string(view) + ", which has " +
                                             std::to_string(view_length[view]) + " bytes",
             pointer);
    };
    for (std::size_t i = 0; i < accessors.size(); ++i) {
      const std::string ap = ptr("accessors", i);
      const std::string what = "accessor " + std::to_string(i) + (label[i].empty() ? "" : " (" + label[i] + ")");
      const json& a = object(accessors[i], what, ap);
      const std::uint64_t ct = integer(a, "componentType", what, ap, kByte, kFloat, std::nullopt);
      if (component_size(static_cast<int>(ct)) == 0)
        fail("gltf_accessor_mismatch", what + " componentType " + std::to_string(ct) + " is not a glTF component type", ap + "/componentType");
      const std::uint64_t count = integer(a, "count", what, ap, 1, kMaxInteger, std::nullopt);
      const auto type_it = a.find("type");
      static const char* const kTypes[] = {"SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4"};
      static const int kTypeCodes[] = {TINYGLTF_TYPE_SCALAR, TINYGLTF_TYPE_VEC2, TINYGLTF_TYPE_VEC3, TINYGLTF_TYPE_VEC4,
                                       TINYGLTF_TYPE_MAT2,   TINYGLTF_TYPE_MAT3, TINYGLTF_TYPE_MAT4};
      int type = 0;
      for (int k = 0; k < 7 && type_it != a.end() && type_it->is_string(); ++k)
        if (*type_it == kTypes[k]) type = kTypeCodes[k];
      if (type == 0) fail("gltf_accessor_mismatch", what + " has no glTF type (SCALAR, VEC2..4, MAT2..4)", ap + "/type");
      if (a.contains("normalized") && !a["normalized"].is_boolean())
        fail("gltf_invalid", what + " normalized is not a boolean", ap + "/normalized");
      const std::uint64_t elem = element_size(type, static_cast<int>(ct));
      const std::uint64_t offset = integer(a, "byteOffset", what, ap, 0, kMaxInteger, 0);
      if (a.contains("bufferView")) {
        const std::uint64_t view = index(a, "bufferView", what, ap, views.size(), "bufferViews");
        if (views.empty()) fail("gltf_invalid", what + " refers to a bufferView, and the document has none", ap);
        const std::uint64_t stride = view_stride[view] ? view_stride[view] : elem;
        if (stride < elem)
          fail("gltf_accessor_mismatch", what + ": byteStride " + std::to_string(stride) + " is smaller than its " +
                                             std::to_string(elem) + "-byte elements",
               ptr("bufferViews", view));
        // count <= 2^53 and stride <= 252: no overflow.
        if (bytes) within_view(view, offset, stride * (count - 1) + elem, what + ", " + std::to_string(count) + " elements,", ap);
      } else {
        if (a.contains("byteOffset")) fail("gltf_invalid", what + " has a byteOffset but no bufferView", ap + "/byteOffset");
        // All zeros (or sparse): no bytes back the count, so it is bounded by the largest mesh lipmap maps.
        if (count > kMaxUnbackedElements)
          fail("gltf_accessor_mismatch", what + " has no bufferView and " + std::to_string(count) + " elements; without one it may have at most " +
                                             std::to_string(kMaxUnbackedElements),
               ap + "/count");
      }
      if (const auto sparse_it = a.find("sparse"); sparse_it != a.end()) {
        const std::string sp = ap + "/sparse";
        const json& sparse = object(*sparse_it, what + " sparse", sp);
        const std::uint64_t n = integer(sparse, "count", what + " sparse", sp, 1, count, std::nullopt);
        if (!sparse.contains("indices") || !sparse.contains("values"))
          fail("gltf_invalid", what + " sparse needs indices and values", sp);
        const json& indices = object(sparse["indices"], what + " sparse indices", sp + "/indices");
        const json& values = object(sparse["values"], what + " sparse values", sp + "/values");
        const std::uint64_t iv = index(indices, "bufferView", what + " sparse indices", sp + "/indices", views.size(), "bufferViews");
        const std::uint64_t ict = integer(indices, "componentType", what + " sparse indices", sp + "/indices", kUByte, kUInt, std::nullopt);
        if (ict != static_cast<std::uint64_t>(kUByte) && ict != static_cast<std::uint64_t>(kUShort) && ict != static_cast<std::uint64_t>(kUInt))
          fail("gltf_accessor_mismatch", what + " sparse indices componentType " + std::to_string(ict) + " is not an unsigned integer type", sp + "/indices/componentType");
        const std::uint64_t io = integer(indices, "byteOffset", what + " sparse indices", sp + "/indices", 0, kMaxInteger, 0);
        const std::uint64_t vv = index(values, "bufferView", what + " sparse values", sp + "/values", views.size(), "bufferViews");
        const std::uint64_t vo = integer(values, "byteOffset", what + " sparse values", sp + "/values", 0, kMaxInteger, 0);
        if (views.empty()) fail("gltf_invalid", what + " is sparse, and the document has no bufferViews", sp);
        if (bytes) {
          within_view(iv, io, n * component_size(static_cast<int>(ict)), what + " sparse indices", sp + "/indices");
          within_view(vv, vo, n * elem, what + " sparse values", sp + "/values");
        }
      }
    }
  }
};

}  // namespace

json parse_document(std::string_view text, std::optional<std::size_t> bin_chunk, bool glb) {
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
  if (const auto required = doc.find("extensionsRequired"); required != doc.end()) {
    if (!required->is_array()) fail("gltf_invalid", "extensionsRequired is not an array", "/extensionsRequired");
    for (std::size_t i = 0; i < required->size(); ++i) {
      const json& e = (*required)[i];
      if (!e.is_string()) fail("gltf_invalid", "extensionsRequired has an entry that is not a string", "/extensionsRequired/" + std::to_string(i));
      if (!supported_required_extension(e.get<std::string>()))
        fail("gltf_unsupported_extension", "the document requires the extension " + e.get<std::string>().substr(0, 100) +
                                               ", which lipmap does not support (a loader must refuse an asset whose required extension it does not support)",
             "/extensionsRequired/" + std::to_string(i));
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
  Structure{doc, bin_chunk, glb}.check(false);
  return doc;
}

void check_accessor_bytes(const json& doc, std::optional<std::size_t> bin_chunk, bool glb) {
  Structure{doc, bin_chunk, glb}.check(true);
}

}  // namespace internal
}  // namespace lipmap::gltf
