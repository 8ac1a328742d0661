// glTF 2.0 in and out: reads one triangle primitive of a .glb / .gltf (embedded buffers only) into the
// engine's RawMesh, and writes the refined, uv-mapped mesh back into the same document. The implementation,
// by concern: gltf_format.cpp (media types, sniffing, GLB and JSON checks), gltf_read.cpp (accessors,
// Asset::read, weld, texcoord boundary), gltf_write.cpp (Asset::write, attributes of inserted vertices,
// answers), gltf_request.cpp (request forms, base64); tinygltf stays behind gltf_internal.h.
//
// Conventions (also in proto/openapi.json and README.md):
//   * uv: lipmap's uv plane has v pointing up and positive (counterclockwise) triangles; glTF's texture space
//     has its origin at the image's top-left corner and t pointing down. lipmap writes
//         TEXCOORD_0 = (fl32(u), fl32(1 - v))        (1 - v evaluated in double, then rounded once)
//     and reads TEXCOORD_N for boundary=texcoord:N back as (u, v) = (s, 1 - t). A uv triangle that is
//     counterclockwise in lipmap's plane is clockwise in (s, t); a chart drawn in [0,1]^2 stays in [0,1]^2.
//     Round trip: fl32(1 - (1 - t)) == t for every float t with |t| >= 2^-29 or t == 0.
//   * float32 (engine/float32_uv.h): the written map is checked as stored: every triangle strictly clockwise
//     in the float (s, t) AND strictly counterclockwise in (s, 1 - t) evaluated in double, both by the exact
//     orientation predicate, and the one-ring of every interior vertex turning exactly once (exact turn
//     counting); boundary TEXCOORD_0 is exactly the float32 of the targets. Where plain rounding breaks a
//     triangle, its interior corners may first move to a neighbouring float (at most 2 ulps in s and t;
//     counted in extras.lipmap.float32_adjusted_vertices) when that makes every triangle around them valid.
//     If the map still fails, write() throws Float32RoundingError (an InternalError: HTTP 500, CLI exit 3)
//     and writes nothing.
//   * seams: glTF splits vertices at seams (hard normals, uv seams). Weld::none (default) maps the primitive's
//     vertices as they are: a primitive split at seams has several boundary loops (or pieces) and is refused
//     with the validate stage's code (multiple_boundary_loops, not_connected, ...), with a hint to weld.
//     Weld::position merges vertices whose POSITION is bit-identical (as float32) before validation; each
//     merged vertex keeps the attributes of its lowest-index copy, and the output primitive is the welded
//     refined mesh (nothing is split again).
//   * vertices: vertices the primitive's triangles do not use are dropped. Without weld and with every vertex
//     used, output vertex i < N is input vertex i (same POSITION bits); inserted vertices follow.
//   * attributes of inserted vertices (on original edge (a, b) at parameter t): NORMAL lerped and
//     renormalized (endpoint a's normal if the lerp vanishes), TANGENT xyz likewise with w from a, COLOR_n,
//     TEXCOORD_n (n != 0) and float custom attributes lerped, JOINTS_n/WEIGHTS_n blended per joint (identical
//     joint sets: slot-wise lerp; else the union of both vertices' joints weighted (1 - t), t, the strongest
//     kept, renormalized), integer custom attributes from the nearer endpoint, morph target displacements
//     lerped. NORMAL, TANGENT, TEXCOORD, COLOR and WEIGHTS are written as FLOAT, JOINTS and custom attributes
//     in their own component type. Indices: UNSIGNED_SHORT up to 65535 vertices, UNSIGNED_INT beyond.
//   * the document: every other mesh, primitive, node, material, texture, image, skin, animation, extension
//     and extras is kept; all buffers are merged into one (the GLB BIN chunk, or a data URI in .gltf) to
//     which the new accessors of the primitive are appended (the old accessors stay, possibly unused).
//     Diagnostics go to the primitive's extras under "lipmap".
//   * input limits: buffers must be in the GLB BIN chunk or data URIs (external files are never read);
//     KHR_draco_mesh_compression and EXT_meshopt_compression are refused.
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/error.h"
#include "engine/geometry.h"
#include "engine/raw_mesh.h"
#include "server/codec/json_codec.h"

namespace lipmap {
struct RefinedMap;         // engine/refine.h
struct ParametrizeResult;  // engine/pipeline.h
}  // namespace lipmap

namespace lipmap::gltf {

enum class Format { glb, gltf };
const char* media_type(Format format);  // "model/gltf-binary", "model/gltf+json"
const char* extension(Format format);   // ".glb", ".gltf"
// "model/gltf-binary" / "model/gltf+json" (parameters and case ignored); nullopt otherwise.
std::optional<Format> format_from_media_type(std::string_view content_type);
// .glb / .gltf (case-insensitive); nullopt otherwise.
std::optional<Format> format_from_path(std::string_view path);
// "glTF" magic: glb; first non-blank byte '{': gltf; nullopt otherwise.
std::optional<Format> sniff_format(std::string_view bytes);
// The glTF answer asked for by an Accept header, or nullopt for JSON (absent, */*, application/json, or
// nothing lipmap writes). The highest q wins; at equal q the first listed.
std::optional<Format> accepted_format(std::string_view accept);

enum class Weld { none, position };
const char* to_string(Weld weld);  // "none", "position"

struct Selection {
  int mesh = 0;       // index into the document's meshes
  int primitive = 0;  // index into that mesh's primitives
  Weld weld = Weld::none;
};

// A glTF the codec cannot take. code() is stable (the CLI prints it, HTTP answers it as the problem code);
// its status comes from the error table (server/codec/error_table.h): 400 when the bytes are not a well-formed, self-contained glTF 2.0 document (gltf_truncated,
// gltf_bad_magic, gltf_invalid_chunk, gltf_invalid_json, gltf_unsupported_version, gltf_invalid,
// gltf_invalid_data_uri, gltf_external_uri, gltf_buffer_out_of_range, gltf_accessor_mismatch,
// gltf_index_out_of_range, gltf_index_count, gltf_invalid_base64, gltf_invalid_request) and 422 when it is
// one but cannot be mapped (gltf_mesh_not_found, gltf_primitive_not_found, gltf_unsupported_mode,
// gltf_no_position, gltf_no_triangles, gltf_texcoord_missing, gltf_unsupported_extension, gltf_non_finite).
// gltf_pointer() is the RFC 6901 pointer into the glTF JSON of the offending object ("" when none), e.g.
// "/meshes/0/primitives/0/mode" or "/accessors/3".
class GltfError : public InputError {
public:
  GltfError(std::string code, const std::string& message, std::string gltf_pointer = {});
  const std::string& gltf_pointer() const { return gltf_pointer_; }

private:
  std::string gltf_pointer_;
};

// The float32 uv would not be a locally injective map (a triangle flipped or degenerate, or a one-ring that
// does not turn once).
class Float32RoundingError : public InternalError {
public:
  Float32RoundingError(const std::string& message, int face) : InternalError(message), face_(face) {}
  int face() const { return face_; }  // output face index (-1: a one-ring)

private:
  int face_;
};

// One vertex attribute of the primitive, converted to double (normalized integers mapped to [0, 1] / [-1, 1]
// as the spec says), one row of `components` values per vertex.
struct Attribute {
  std::string name;
  int components = 0;
  int component_type = 0;  // the accessor's (5120 BYTE ... 5126 FLOAT)
  bool normalized = false;
  std::vector<double> values;
};

class Asset {
public:
  // Parses a whole .glb or .gltf. `expected` (from the media type or file extension) makes a mismatch an
  // error (gltf_bad_magic / gltf_invalid_json); without it the format is sniffed. Selects the primitive,
  // reads and checks its accessors, builds the engine mesh (welded when asked) and validates it as a disk:
  // the validate stage's InputError (code unchanged, message prefixed with the primitive and, when the
  // primitive has split vertices and no weld was asked for, a hint to weld) or GltfError.
  static Asset read(std::string_view bytes, const Selection& selection = {},
                    std::optional<Format> expected = std::nullopt);
  // A fresh one-mesh document for a mesh that did not come as glTF (a JSON request answered in glTF).
  static Asset from_mesh(const RawMesh& mesh);

  Format format() const;               // of the input (from_mesh: glb)
  const Selection& selection() const;
  const RawMesh& mesh() const;         // the engine's input
  const std::vector<int>& boundary_loop() const;  // of mesh(), interior on the left, lowest index first
  std::size_t primitive_vertices() const;         // vertices of the primitive as stored
  const std::vector<int>& source_vertex() const;  // engine vertex -> its (lowest) primitive vertex
  std::size_t welded_vertices() const;             // primitive vertices merged into another by weld
  std::size_t unused_vertices() const;             // primitive vertices no triangle uses (dropped)
  std::vector<std::string> attribute_names() const;  // the primitive's, sorted
  // An attribute per engine vertex; nullopt when the primitive has none of that name.
  std::optional<Attribute> attribute(const std::string& name) const;
  const nlohmann::json& primitive_extras() const;  // null when none

  // boundary=texcoord:N: each boundary vertex pinned to its TEXCOORD_N, (u, v) = (s, 1 - t), in the order of
  // boundary_loop() (given as `vertices`). GltfError gltf_texcoord_missing when the primitive has no such set.
  RawBoundary texcoord_boundary(int set) const;
  // metric=texcoord:N: TEXCOORD_N of every engine vertex as (u, v) = (s, 1 - t), the reference map of
  // options.metric (paper 5.2). GltfError gltf_texcoord_missing when the primitive has no such set.
  std::vector<Point2> texcoord_uv(int set) const;

  // The document with the primitive replaced by the refined mesh (see the conventions above). map.vertices
  // must start with mesh().vertices. `extras` goes to the primitive's extras under "lipmap". Throws
  // Float32RoundingError, or InternalError when map does not fit this asset.
  std::string write(const RefinedMap& map, const nlohmann::json& extras, Format format) const;

  struct Impl;

private:
  // read() without its last guard (every exception other than InputError becomes a GltfError).
  static Asset read_document(std::string_view bytes, const Selection& selection, std::optional<Format> expected);

  std::shared_ptr<const Impl> impl_;
};

// The "lipmap" extras of an answer: verdict, singular_vertices, inserted_vertices, flipped_before_refinement,
// distortion {max, mean}, timings_ms, inserted [{edge: [a, b], t}], uv_convention, source {mesh, primitive,
// weld, primitive_vertices, welded_vertices, unused_vertices}.
nlohmann::json extras_for(const ParametrizeResult& result, const Asset& asset);
// asset.write(result.map, extras_for(result, asset), format).
std::string write_answer(const Asset& asset, const ParametrizeResult& result, Format format);
// The same into a fresh one-mesh document (Asset::from_mesh of the result's original vertices): for a
// request that did not come as glTF.
std::string write_answer(const ParametrizeResult& result, Format format);

// ---- requests (HTTP bodies and the CLI) ------------------------------------------------------------------
// The parameters that come beside the model: query parameters mesh, primitive, weld, boundary (HTTP), or
// command-line options. Strings are parsed strictly (GltfError gltf_invalid_request naming the parameter).
struct Params {
  std::optional<std::string> mesh, primitive, weld, boundary;
  // metric=texcoord:N (options.metric from TEXCOORD_N; with boundary=texcoord:N on the same set: "repair this
  // chart") or metric=surface (the default).
  std::optional<std::string> metric;
};

struct Request {
  Asset asset;
  codec::ParametrizeRequest request;  // mesh = asset.mesh(), the boundary, the options (codec's shape)
  std::optional<int> texcoord_set;    // boundary=texcoord:N
};

// boundary=texcoord:N -> N; nullopt for anything not starting with "texcoord:"; GltfError for a bad N.
std::optional<int> parse_texcoord_spec(std::string_view spec);
// metric=texcoord:N -> N; metric=surface -> nullopt; GltfError gltf_invalid_request for anything else.
std::optional<int> parse_metric_spec(std::string_view spec);

// Body model/gltf-binary or model/gltf+json: the boundary must be params.boundary = texcoord:N.
Request request_from_model(std::string_view bytes, Format format, const Params& params);
// JSON envelope {"gltf_base64": "...", "boundary": {...} | "texcoord:N", "options": {...}?, "mesh": int?,
// "primitive": int?, "weld": "none"|"position"?}. A member and a parameter that disagree: gltf_invalid_request.
// The boundary object is parsed as in a parametrize body (codec::JsonError with /boundary/... pointers).
Request request_from_envelope(const nlohmann::json& body, const Params& params);
// multipart/form-data: parts "model" (required; its own Content-Type or sniffed), "boundary" (JSON boundary
// object, or the text texcoord:N), "options" (JSON options object). Other parts: gltf_invalid_request.
struct Part {
  std::string content;
  std::string content_type;
};
Request request_from_parts(const std::map<std::string, Part>& parts, const Params& params);

// True when a JSON body is a glTF envelope (has "gltf_base64").
bool is_envelope(const nlohmann::json& body);


// Base64 (RFC 4648, with padding; decoding ignores ASCII whitespace). decode throws GltfError
// gltf_invalid_base64 naming the offset of the first bad character.
std::string base64_encode(std::string_view bytes);
std::string base64_decode(std::string_view text, const std::string& what = "gltf_base64");

}  // namespace lipmap::gltf
