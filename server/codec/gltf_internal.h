// The tinygltf side of the glTF codec, shared by gltf_format.cpp, gltf_read.cpp, gltf_write.cpp and
// gltf_request.cpp; private to server/codec (it includes tinygltf: Debian's libtinygltf is a shared library
// with the implementation, so never define TINYGLTF_IMPLEMENTATION).
#pragma once

#include <tiny_gltf.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/raw_mesh.h"
#include "server/codec/gltf_codec.h"
#include "server/codec/text.h"

namespace lipmap::gltf {

// The document as read, the primitive's attributes and the engine mesh made of it.
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
  nlohmann::json extras;
};

namespace internal {

inline constexpr int kByte = 5120, kUByte = 5121, kShort = 5122, kUShort = 5123, kUInt = 5125, kFloat = 5126;
inline constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

using codec::lower;
using codec::trim;
bool starts_with(const std::string& s, const char* prefix);
// The first n bytes in hex ("67 6c 54 46"), "nothing" when there are none.
std::string hex_bytes(std::string_view b, std::size_t n);

[[noreturn]] void fail(const std::string& code, const std::string& message, const std::string& pointer = {});
std::string ptr(const std::string& collection, long long index);  // "/accessors/3"

// ---- accessor layout ----
int component_size(int ct);
const char* component_name(int ct);
int type_components(int type);  // components (matrices: all of them); 0 for an unknown type
int matrix_rows(int type);      // 0 unless a matrix
const char* type_name(int type);
int type_for_components(int n);
std::size_t element_size(int type, int ct);               // with the column padding of small matrices
std::size_t component_offset(int type, int ct, int c);    // of component c inside an element
double read_component(const unsigned char* p, int ct, bool normalized);
// The semantics written as FLOAT whatever they came as.
bool is_float_semantic(const std::string& name);

// ---- tinygltf callbacks: never touch the file system, keep image bytes as they are ----
tinygltf::FsCallbacks no_file_system();
bool keep_image_bytes(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                      const unsigned char* bytes, int size, void*);
bool embed_image_bytes(const std::string*, const std::string*, const tinygltf::Image* image, bool,
                       std::string* out_uri, void*);

// ---- tinygltf::Value <-> json ----
nlohmann::json to_json(const tinygltf::Value& v);
tinygltf::Value to_value(const nlohmann::json& j);

// ---- before tinygltf (gltf_format.cpp) ----
// An accessor without a bufferView (all zeros, or sparse) has no bytes to bound its count: it may have at
// most this many elements, a little above the service's default --max-vertices (2,000,000).
inline constexpr std::uint64_t kMaxUnbackedElements = std::uint64_t{1} << 21;

// The GLB's JSON chunk; `length` is set to the GLB length the header declares (bytes past it are ignored),
// `bin_chunk` to the BIN chunk's length (nullopt without one).
std::string_view check_glb(std::string_view bytes, std::size_t& length, std::optional<std::size_t>& bin_chunk);
// The glTF JSON checked for what tinygltf would accept silently or read from outside (version, compressed
// geometry, external buffers, required extensions), and the integer fields of buffers, bufferViews,
// accessors and mesh primitives against the schema's ranges and the bytes present (bin_chunk: see
// check_glb; glb: the document is a GLB's JSON chunk).
nlohmann::json parse_document(std::string_view text, std::optional<std::size_t> bin_chunk, bool glb);
// Every accessor (and sparse accessor) of a document parse_document took against the bytes of its
// bufferView.
void check_accessor_bytes(const nlohmann::json& doc, std::optional<std::size_t> bin_chunk, bool glb);

}  // namespace internal
}  // namespace lipmap::gltf
