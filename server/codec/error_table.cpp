#include "server/codec/error_table.h"

#include <algorithm>
#include <string>
#include <unordered_map>

namespace lipmap::codec {

namespace {

// Titles shared by groups of codes (RFC 7807: the title is the same for every occurrence of a type; several
// codes may share one).
constexpr std::string_view kMalformed = "Malformed request";
constexpr std::string_view kInvalidMesh = "Invalid mesh";
constexpr std::string_view kInvalidBoundary = "Invalid boundary";
constexpr std::string_view kInvalidPolygon = "Invalid polygon";
constexpr std::string_view kMalformedGltf = "Malformed glTF";
constexpr std::string_view kGltfNotMappable = "glTF not mappable";
constexpr std::string_view kConflict = "Conflict";

constexpr int kIn = kExitInputError;
constexpr int kUsage = kExitUsageError;
constexpr int kInternal = kExitInternalError;

const std::vector<ErrorInfo> kTable = {
    // ---- the request document (codec::JsonError): 400 --------------------------------------------------
    {"invalid_json", 400, kMalformed, kIn},
    {"non_finite_number", 400, kMalformed, kIn},
    {"nesting_too_deep", 400, kMalformed, kIn},
    {"duplicate_key", 400, kMalformed, kIn},
    {"wrong_type", 400, kMalformed, kIn},
    {"missing_field", 400, kMalformed, kIn},
    {"unknown_field", 400, kMalformed, kIn},
    {"wrong_length", 400, kMalformed, kIn},
    {"not_an_integer", 400, kMalformed, kIn},
    {"integer_out_of_range", 400, kMalformed, kIn},
    {"invalid_value", 400, kMalformed, kIn},

    // ---- the mesh (engine validate stage, mesh files): 422 ---------------------------------------------
    {"mesh_empty", 422, kInvalidMesh, kIn},
    {"face_not_triangle", 422, kInvalidMesh, kIn},
    {"face_index_out_of_range", 422, kInvalidMesh, kIn},
    {"face_repeated_vertex", 422, kInvalidMesh, kIn},
    {"non_finite_coordinate", 422, kInvalidMesh, kIn},
    {"degenerate_face", 422, kInvalidMesh, kIn},
    {"duplicate_face", 422, kInvalidMesh, kIn},
    {"unreferenced_vertex", 422, kInvalidMesh, kIn},
    {"non_manifold_edge", 422, kInvalidMesh, kIn},
    {"non_manifold_vertex", 422, kInvalidMesh, kIn},
    {"inconsistent_orientation", 422, kInvalidMesh, kIn},
    {"not_connected", 422, kInvalidMesh, kIn},
    {"no_boundary", 422, kInvalidMesh, kIn},
    {"multiple_boundary_loops", 422, kInvalidMesh, kIn},
    {"not_a_disk", 422, kInvalidMesh, kIn},
    {"mesh_file_unreadable", 422, kInvalidMesh, kIn},
    {"mesh_too_large", 422, "Mesh too large", kIn},
    {"memory_budget_exceeded", 422, "Request too costly", kIn},
    // Engine options that pass the codec's shape checks but not the engine's (e.g. a target density
    // that would need more than the engine's triangle budget).
    {"invalid_option", 422, kInvalidMesh, kIn},
    {"target_density_invalid", 422, kInvalidMesh, kIn},
    {"source_triangles_invalid", 422, kInvalidMesh, kIn},
    {"min_angle_invalid", 422, kInvalidMesh, kIn},

    // ---- the boundary (its positions and the mesh vertices they belong to): 422 -------------------------
    {"boundary_length_mismatch", 422, kInvalidBoundary, kIn},
    {"boundary_position_non_finite", 422, kInvalidBoundary, kIn},
    // Positions so small that the map's interior uv would be subnormal doubles at the caller's scale.
    {"coordinate_out_of_range", 422, kInvalidBoundary, kIn},
    {"boundary_vertex_out_of_range", 422, kInvalidBoundary, kIn},
    {"boundary_vertex_not_on_boundary", 422, kInvalidBoundary, kIn},
    {"boundary_vertex_repeated", 422, kInvalidBoundary, kIn},
    {"boundary_not_loop_order", 422, kInvalidBoundary, kIn},
    {"rotation_indices_length", 422, kInvalidBoundary, kIn},
    {"rotation_index_out_of_range", 422, kInvalidBoundary, kIn},
    {"not_self_overlapping", 422, "Boundary not self-overlapping", kIn},

    // ---- options.metric, the reference map of the variable metric (paper 5.2): 422 ----------------------
    {"metric_length_mismatch", 422, "Invalid metric", kIn},
    {"metric_non_finite", 422, "Invalid metric", kIn},
    {"metric_degenerate", 422, "Invalid metric", kIn},

    // ---- the polygon (classify, and the boundary as a polygon): 422 -------------------------------------
    {"polygon_too_small", 422, kInvalidPolygon, kIn},
    {"polygon_non_finite", 422, kInvalidPolygon, kIn},
    {"polygon_zero_length_edge", 422, kInvalidPolygon, kIn},
    {"polygon_too_large", 422, "Polygon too large", kIn},

    // ---- glTF documents (codec gltf::GltfError): 400 when not a well-formed glTF 2.0, 422 when not mappable --
    {"gltf_truncated", 400, kMalformedGltf, kIn},
    {"gltf_bad_magic", 400, kMalformedGltf, kIn},
    {"gltf_invalid_chunk", 400, kMalformedGltf, kIn},
    {"gltf_invalid_json", 400, kMalformedGltf, kIn},
    {"gltf_unsupported_version", 400, kMalformedGltf, kIn},
    {"gltf_invalid", 400, kMalformedGltf, kIn},
    {"gltf_invalid_data_uri", 400, kMalformedGltf, kIn},
    {"gltf_external_uri", 400, kMalformedGltf, kIn},
    {"gltf_buffer_out_of_range", 400, kMalformedGltf, kIn},
    {"gltf_accessor_mismatch", 400, kMalformedGltf, kIn},
    {"gltf_index_out_of_range", 400, kMalformedGltf, kIn},
    {"gltf_index_count", 400, kMalformedGltf, kIn},
    {"gltf_invalid_base64", 400, kMalformedGltf, kIn},
    {"gltf_invalid_request", 400, kMalformedGltf, kIn},
    {"gltf_mesh_not_found", 422, kGltfNotMappable, kIn},
    {"gltf_primitive_not_found", 422, kGltfNotMappable, kIn},
    {"gltf_unsupported_mode", 422, kGltfNotMappable, kIn},
    {"gltf_no_position", 422, kGltfNotMappable, kIn},
    {"gltf_no_triangles", 422, kGltfNotMappable, kIn},
    {"gltf_texcoord_missing", 422, kGltfNotMappable, kIn},
    {"gltf_unsupported_extension", 422, kGltfNotMappable, kIn},
    {"gltf_non_finite", 422, kGltfNotMappable, kIn},

    // ---- HTTP: routing, framing, media types, jobs ------------------------------------------------------
    {"bad_request", 400, kMalformed, kIn},
    {"invalid_query_parameter", 400, kMalformed, kIn},
    {"not_found", 404, "Not found", kIn},
    {"job_not_found", 404, "Not found", kIn},
    {"method_not_allowed", 405, "Method not allowed", kIn},
    {"job_not_finished", 409, kConflict, kIn},
    {"job_failed", 409, kConflict, kIn},
    {"job_cancelled", 409, kConflict, kIn},
    {"job_gone", 410, "Gone", kIn},
    {"request_timeout", 408, "Request timeout", kIn},
    {"length_required", 411, "Length required", kIn},
    {"payload_too_large", 413, "Payload too large", kIn},
    {"uri_too_long", 414, "URI too long", kIn},
    {"unsupported_media_type", 415, "Unsupported media type", kIn},
    // cpp-httplib's own refusals without a code of ours: http_<status>.
    {"http_416", 416, "Range not satisfiable", kIn},
    {"http_417", 417, "Expectation failed", kIn},

    // ---- the command line's own ----------------------------------------------------------------------
    {"usage", 400, kMalformed, kUsage},
    {"file_unreadable", 422, "Unreadable file", kIn},
    {"output_file_unwritable", 422, "Output not writable", kIn},
    {"output_failed", 422, "Output not writable", kIn},
    {"listen_failed", 422, "Cannot listen", kIn},

    // ---- not the caller's fault ----------------------------------------------------------------------
    // A client's DELETE cancelled the work: 409 for HTTP (the job's own state); the command line reports a
    // cancelled run like any other failure that is not the input's.
    {"cancelled", 409, kConflict, kInternal},
    {"internal_error", 500, "Internal error", kInternal},
    {"queue_full", 503, "Queue full", kInternal},
    {"shutting_down", 503, "Shutting down", kInternal},
    {"too_many_connections", 503, "Too many connections", kInternal},
    // The shared job queue (Redis) cannot be reached: job endpoints and /readyz answer this until it is back.
    {"queue_unavailable", 503, "Queue unavailable", kInternal},
    // A job's result is larger than the shared queue keeps (--max-result-bytes).
    {"result_too_large", 507, "Result too large", kInternal},
    {"out_of_memory", 503, "Out of memory", kInternal},
    {"deadline_exceeded", 504, "Deadline exceeded", kInternal},
};

const std::unordered_map<std::string_view, const ErrorInfo*>& index() {
  static const auto map = [] {
    std::unordered_map<std::string_view, const ErrorInfo*> m;
    for (const ErrorInfo& e : kTable) m.emplace(e.code, &e);
    return m;
  }();
  return map;
}

}  // namespace

const ErrorInfo& error_info(std::string_view code) {
  const auto& m = index();
  const auto it = m.find(code);
  if (it != m.end()) return *it->second;
  return *m.at("internal_error");
}

bool has_error_info(std::string_view code) { return index().count(code) != 0; }

const std::vector<ErrorInfo>& error_table() { return kTable; }

}  // namespace lipmap::codec
