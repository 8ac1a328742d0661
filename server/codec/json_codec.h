// JSON <-> engine value types: the only place where JSON meets the engine (the CLI and the HTTP server
// both go through here). Parsing is strict and every failure names the offending value by its RFC 6901
// JSON pointer, so that a client can find field /mesh/faces/12/1 in a body of a million numbers.
// The shapes are those of docs/api.md and of the JSON Schemas in proto/.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "engine/boundary_polygon.h"
#include "engine/classify.h"
#include "engine/error.h"
#include "engine/parametrize_options.h"
#include "engine/raw_mesh.h"

namespace lipmap {
struct ParametrizeResult;  // engine/pipeline.h (kept out of this header: it pulls in Eigen)
}  // namespace lipmap

namespace lipmap::codec {

// Requests are read from nlohmann::json; everything the codec writes is an ordered_json, so that members
// come out in the documented order (verdict first, diagnostics last) rather than alphabetically.

// A body that is not JSON, or not of the documented shape. It is the caller's fault, so it is an
// InputError (element "field"); pointer() is the JSON pointer of the offending value ("" = the whole
// document). Codes:
//   invalid_json         not JSON at all (syntax error, bad UTF-8, empty body); byte_offset() is the
//                        number of bytes read when the parser stopped
//   non_finite_number    a number that does not fit in a double (e.g. 1e999)
//   nesting_too_deep     arrays/objects nested deeper than kMaxNesting
//   duplicate_key        the same key twice in one object
//   wrong_type           e.g. a string where a number is expected
//   missing_field        a required member is absent
//   unknown_field        a member the API does not define (catches typos such as "rotation_index")
//   wrong_length         e.g. a point [x, y, z] where [x, y] is expected
//   not_an_integer       a number with a fractional part where an index or count is expected
//   integer_out_of_range an integer too large for its field
//   invalid_value        a value outside its documented set or range (e.g. options.method)
class JsonError : public InputError {
public:
  JsonError(std::string code, const std::string& message, std::string pointer,
            std::optional<long long> byte_offset = std::nullopt)
      : InputError(std::move(code), message, "field"), pointer_(std::move(pointer)), byte_offset_(byte_offset) {}

  const std::string& pointer() const { return pointer_; }
  const std::optional<long long>& byte_offset() const { return byte_offset_; }

private:
  std::string pointer_;
  std::optional<long long> byte_offset_;
};

inline constexpr int kMaxNesting = 64;

// Parses a whole document. Throws JsonError (invalid_json, non_finite_number, nesting_too_deep,
// duplicate_key); for the first three the pointer is where the parser was when it stopped.
nlohmann::json parse_json(std::string_view text);

// RFC 6901: "~" -> "~0", "/" -> "~1".
std::string escape_pointer_token(std::string_view token);

// ---- POST /v1/polygons/classify: {"polygon": [[x, y]...], "rotation_indices": [r...]?} ----------------
// Shape only: too few vertices, zero-length edges, negative indices and the like are for the engine's
// validate_polygon (InputError with its own code).
BoundaryPolygon classify_request_from_json(const nlohmann::json& body);
nlohmann::ordered_json classify_request_to_json(const BoundaryPolygon& polygon);

// ---- POST /v1/parametrize and POST /v1/jobs -------------------------------------------------------------
// {"mesh": {"vertices": [[x,y,z]...], "faces": [[i,j,k]...]},
//  "boundary": {"vertices": [i...]?, "positions": [[u,v]...], "rotation_indices": [r...]?},
//  "options": {"method": "harmonic" (default) | "tutte" | "extremal", "refine": bool, "target_density": number > 0}?}
// Faces may have any number of corners and indices any integer value here: validate_mesh names those
// faults (face_not_triangle, face_index_out_of_range) with the engine's codes.
// The options are the engine's own (engine/parametrize_options.h; harmonic by default).

struct ParametrizeRequest {
  RawMesh mesh;
  RawBoundary boundary;
  ParametrizeOptions options;
};

ParametrizeRequest parametrize_request_from_json(const nlohmann::json& body);
// The same as parametrize_request_from_json(parse_json(text)) for a plain, well-formed parametrize body,
// read without a DOM for its big arrays (mesh vertices and faces, boundary positions go straight into the
// engine's arrays: a million-triangle body costs its arrays, not a tree of JSON values). nullopt when the
// text is anything else (not JSON, a glTF envelope, a member of the wrong shape, an unknown or repeated
// key): then parse the text the ordinary way, which names the error. May throw JsonError like
// parametrize_request_from_json (e.g. an invalid option).
// `padding`: how many bytes after the text may be read, all of them initialized (a std::string with room
// to spare, e.g.); from kJsonReadPadding on, the text is read where it is instead of copied into a padded
// buffer first (simdjson reads in 64-byte blocks). `threads` > 1: the mesh's first big array is read on a
// helper thread while the caller's reads the rest (for a job alone on the machine).
std::optional<ParametrizeRequest> parametrize_request_from_text(std::string_view text, std::size_t padding = 0,
                                                                int threads = 1);
inline constexpr std::size_t kJsonReadPadding = 64;
// Writes kJsonReadPadding zero bytes just past text's end, in room the string already has (its size does not
// change); returns how many, 0 when there is no such room. Then parametrize_request_from_text(text, that)
// reads the text where it is (simdjson's own iterate of a std::string reads into its capacity the same way).
std::size_t pad_for_reading(std::string& text);
nlohmann::ordered_json parametrize_request_to_json(const ParametrizeRequest& request);

// The "boundary" member alone, as a document of its own (`lipmap map --boundary FILE`):
// {"vertices": [i...]?, "positions": [[u,v]...], "rotation_indices": [r...]?}. Same rules as inside a
// parametrize request; JSON pointers are relative to this document (e.g. /positions/3/0).
RawBoundary boundary_from_json(const nlohmann::json& boundary);
nlohmann::ordered_json boundary_to_json(const RawBoundary& boundary);

// options.metric alone, as a document of its own (`lipmap map --metric FILE`): "surface" (nullopt) or
// {"uv": [[u, v]...]}, one point per mesh vertex (paper 5.2). Same rules as inside a parametrize request;
// JSON pointers are relative to this document (e.g. /uv/3/0).
std::optional<std::vector<Point2>> metric_from_json(const nlohmann::json& metric);

// ---- parametrize answer (200 of POST /v1/parametrize, GET /v1/jobs/{id}/result, `lipmap map -o X.json`) --
// proto/parametrize-answer.schema.json:
// {"verdict", "turning_number", "singular_vertices" (mesh vertex indices of boundary vertices with R > 0),
//  "rotation_indices" (one per boundary position, in the order of "boundary_loop"), "boundary_loop" (mesh
//  vertex pinned to each boundary position),
//  "mesh": {"vertices": [[x,y,z]...], "faces": [[i,j,k]...]} (the refined mesh: original vertices first, same
//  index and position, then the inserted ones), "uv": [[u,v]...] (one per vertex),
//  "inserted": [{"edge": [a, b], "t": t}...] (inserted vertex i is vertex (original count + i), at
//  a + t (b - a)),
//  "diagnostics": {"inserted_vertices", "flipped_before_refinement", "flipped",
//                  "target_mesh": {"vertices", "faces", "pieces", "min_angle_deg"},
//                  "intermediate_maps": {"source", "target"} ("primary" | "mean_value" | "tutte"),
//                  "refinement": {"relocated_vertices", "flipped_after_relocation", "refined_faces",
//                                 "points_before_simplification", "simplification_rounds", "regions",
//                                 "region_faces", "points_slid", "fixed_faces_split"},
//                  "distortion": {"max", "mean", "histogram": {"edges": [1, 1.1, ..., 10], "counts": [...]}},
//                  "timings_ms": {"validate", "classify", "target_mesh", "intermediate_maps", "compose",
//                                 "refine", "verify", "quality", "total"}}}
// Histogram: counts[i] faces with edges[i] <= K < edges[i + 1], the last bin open above. An infinite
// distortion (a degenerate uv triangle, possible only with refine off) is written as null.
nlohmann::ordered_json parametrize_result_to_json(const lipmap::ParametrizeResult& result);
// Byte for byte dump(parametrize_result_to_json(result), pretty), written without a DOM for the big
// arrays (mesh, uv, inserted): the numbers go from the engine's arrays straight into the text. `threads` > 1
// formats the rows of an answer with at least kParallelAnswerRows vertices + faces + uv on that many threads
// (the caller's included): for a job alone on the machine.
class MeshRowsAhead;
std::string parametrize_result_to_text(const lipmap::ParametrizeResult& result, bool pretty = false, int threads = 1,
                                      MeshRowsAhead* ahead = nullptr);
inline constexpr std::size_t kParallelAnswerRows = 50'000;

// The answer's text of a request's mesh rows (vertices, faces), formatted ahead on a thread of its own while
// the engine maps the mesh: a job alone on the machine leaves a core idle, and the mesh is most of a big
// answer (the refined mesh keeps the original vertices first, same index and position, and every face when
// nothing was refined). parametrize_result_to_text(result, false, threads, &ahead) takes each finished block
// of rows the answer holds unchanged (compared bit for bit) instead of formatting it again: the same bytes,
// sooner; the writer tells the thread to stop (after its block in progress) and formats the rest itself. Use
// each object for one answer. `mesh` must outlive this object; its destructor stops the thread and waits.
class MeshRowsAhead {
public:
  explicit MeshRowsAhead(const RawMesh& mesh);
  ~MeshRowsAhead();
  // Whether a job's answer is big enough for it (kParallelAnswerRows).
  static bool pays_off(const RawMesh& mesh);
  // Waits until every block is formatted (or the thread gave up).
  void wait();
  MeshRowsAhead(const MeshRowsAhead&) = delete;
  MeshRowsAhead& operator=(const MeshRowsAhead&) = delete;
  struct Impl;

private:
  friend std::string parametrize_result_to_text(const lipmap::ParametrizeResult&, bool, int, MeshRowsAhead*);
  std::unique_ptr<Impl> impl_;
};

// ---- classify answer --------------------------------------------------------------------------------
// {"verdict", "turning_number", "triangulation": [[i,j,k]...], "rotation_indices", "singular_vertices",
//  "reason"? (only when not empty), "diagnostics": {"input_vertices", "ears_clipped", "reduced_vertices",
//  "free_rotation_search", "table_bytes", "timings_ms": {"ear_clipping", "table", "total"}}}
const char* verdict_name(Verdict verdict);                    // the wire names, e.g. "self_overlapping"
std::optional<Verdict> verdict_from_name(std::string_view name);

nlohmann::ordered_json classification_to_json(const Classification& classification);
// Strict inverse of classification_to_json (for clients, tests and benchmarks); throws JsonError.
Classification classification_from_json(const nlohmann::json& answer);

// Text of an answer. Compact: one line, no spaces. Pretty: indented by 2, but an array of scalars (a
// point, a triangle, a list of indices) stays on one line, so that a triangulation reads as a list.
// Invalid UTF-8 in strings is replaced, never thrown.
std::string dump(const nlohmann::ordered_json& value, bool pretty = false);

// ---- errors -----------------------------------------------------------------------------------------
// The JSON pointer of the request value an engine InputError is about, when it can be told from the
// error's code, element and index (e.g. rotation_index_out_of_range at index 3 -> /rotation_indices/3);
// a JsonError's own pointer otherwise; nullopt when the error is about the request as a whole.
std::optional<std::string> classify_error_pointer(const InputError& error);
std::optional<std::string> parametrize_error_pointer(const InputError& error);

// RFC 7807 problem details (application/problem+json), as proto/problem.schema.json describes:
// {"type": "urn:lipmap:problem:<code>", "title", "status", "detail", "code"?, "pointer"?, "element"?,
//  "index"?}. The type is stable per error code.
nlohmann::ordered_json problem_json(int status, const std::string& title, const std::string& code,
                            const std::string& detail, const std::optional<std::string>& pointer = std::nullopt,
                            const std::string& element = {}, std::optional<long long> index = std::nullopt);
std::string problem_type(const std::string& code);

}  // namespace lipmap::codec
