// glTF media types, format sniffing, the Accept header, and the checks of a GLB container and of the glTF JSON
// that run before tinygltf sees the bytes (see gltf_codec.h).
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
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

namespace internal {
namespace {

std::uint32_t u32(const unsigned char* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

}  // namespace

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

}  // namespace internal
}  // namespace lipmap::gltf
