// The lipmap command line: `lipmap classify FILE`, `lipmap map MESH ...`, `lipmap serve`, and `lipmap --version`.
// Everything JSON goes through json_codec; everything else is the engine's.
#pragma once

#include <iosfwd>
#include <string>

#include "server/codec/error_table.h"

namespace lipmap::cli {

// Exit codes: 0 for every answer (every classify verdict included); a failure's code comes from the one error
// table (server/codec/error_table.h): 1 the caller's input or files, 2 usage, 3 internal.
using codec::kExitOk;

// Reports a failure: exactly one line "lipmap: error: <code>: <message>" on `err` (control characters in the
// message become spaces), and returns the exit code the error table gives <code>.
int fail(std::ostream& err, const std::string& code, const std::string& message);

// Parses argv and runs the subcommand. Never throws. Answers go to `out`; every failure is exactly one
// line on `err`: "lipmap: error: <code>: <message>".
int run(int argc, const char* const* argv, std::istream& in, std::ostream& out, std::ostream& err);

// `lipmap classify FILE [--pretty]`: FILE holds a /v1/polygons/classify body; "-" reads it from `in`.
int classify_command(const std::string& file, bool pretty, std::istream& in, std::ostream& out, std::ostream& err);

// `lipmap map MESH --boundary BOUNDARY.json -o OUT [--method tutte|harmonic|extremal] [--no-refine]
//  [--target-density D] [--optimize none|mips|symmetric_dirichlet] [--max-iterations N] [--time-budget-ms MS]
//  [--no-untangle] [--preview OUT.svg] [--progress] [--pretty]`.
// MESH is .obj/.off/.ply/.stl (read_mesh_file), or .json holding a whole POST /v1/parametrize body (mesh,
// boundary, options); then --boundary is optional and, when given, replaces the body's boundary, and the
// command-line options override the body's. BOUNDARY.json is the body's "boundary" object. OUT is .obj
// (v, vt and f v/vt lines) or .json (the HTTP answer, proto/parametrize-answer.schema.json). Method: the
// body's, else --method, else harmonic (the engine's default). Exit codes: 0 written; 1 input error
// (including not_self_overlapping, whose message names the verdict) and unwritable output; 2 usage; 3
// internal error. With --progress, one line per stage start/end and a summary go to `err`.
struct MapArgs {
  std::string mesh_file;
  std::string boundary_file;   // empty: none
  std::string output_file;
  std::string method;          // empty: not given; else "tutte", "harmonic" or "extremal"
  bool no_refine = false;
  double target_density = 0;   // <= 0: not given
  std::string optimize;        // empty: not given; else an OptimizeEnergy name
  int max_iterations = -1;     // < 0: not given
  double time_budget_ms = -1;  // < 0: not given
  bool no_untangle = false;
  // --metric: empty (the request's own), "surface", texcoord:N (glTF MESH) or METRIC.json ("surface" or
  // {"uv": [[u, v]...]}, one per vertex: paper 5.2, the reference map whose metric the map is built in).
  std::string metric;
  std::string preview_file;    // empty: none
  bool progress = false;
  bool pretty = false;
  // glTF MESH (.glb / .gltf, server/codec/gltf_codec.h): which primitive, and whether to weld split vertices.
  // BOUNDARY may then also be texcoord:N; OUT may be .glb / .gltf (for any MESH).
  int gltf_mesh = 0;
  int gltf_primitive = 0;
  std::string weld = "none";  // "none" or "position"
};
int map_command(const MapArgs& args, std::ostream& out, std::ostream& err);

}  // namespace lipmap::cli
