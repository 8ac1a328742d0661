#include "server/app/cli.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <new>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <optional>

#include <CLI/CLI.hpp>

#include "engine/pipeline.h"

#include "engine/classify.h"
#include "engine/error.h"
#include "engine/mesh_io.h"
#include "server/codec/error_table.h"
#include "server/codec/gltf_codec.h"
#include "server/codec/json_codec.h"
#include "server/codec/request_loader.h"
#include "server/codec/svg_preview.h"
#include "server/codec/text.h"
#include "server/app/serve_command.h"

namespace lipmap::cli {

namespace {

// The CMake project version (server/CMakeLists.txt passes PROJECT_VERSION).
constexpr const char* kVersion = LIPMAP_VERSION;

// Called inside a catch (...) block: the one-line message and exit code of a failure that is not the
// input's fault (InputError is handled where it is caught, with its own pointer).
int report_failure(std::ostream& err, const char* task) {
  try {
    throw;
  } catch (const InternalError& e) {
    return fail(err, "internal_error", e.what());
  } catch (const Cancelled& e) {
    return fail(err, "cancelled", e.what());
  } catch (const std::bad_alloc&) {
    return fail(err, "out_of_memory", std::string("not enough memory to ") + task);
  } catch (const std::exception& e) {
    return fail(err, "internal_error", e.what());
  } catch (...) {
    return fail(err, "internal_error", "unexpected exception");
  }
}

// A file that cannot be read is the caller's fault; reported like any other input error.
class ReadError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

// The whole stream, 1 MB per read (a character at a time, istreambuf_iterator took about 60 ms for a 12.7 MB
// request), with room left after it for the JSON reader's padding (codec::pad_for_reading).
std::string read_stream(std::istream& in) {
  std::string text;
  constexpr std::size_t kChunk = 1 << 20;
  for (;;) {
    const std::size_t size = text.size();
    if (text.capacity() < size + kChunk + codec::kJsonReadPadding) text.reserve(2 * (size + kChunk));
    text.resize(size + kChunk);
    in.read(text.data() + size, static_cast<std::streamsize>(kChunk));
    text.resize(size + static_cast<std::size_t>(in.gcount()));
    if (!in) break;
  }
  return text;
}

std::string read_all(const std::string& file, std::istream& in) {
  if (file == "-") {
    std::string text = read_stream(in);
    if (in.bad()) throw ReadError("cannot read standard input");
    return text;
  }
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec)) throw ReadError("cannot read '" + file + "': it is a directory");
  std::ifstream stream(file, std::ios::binary);
  if (!stream) throw ReadError("cannot open '" + file + "': " + std::strerror(errno));
  std::string text = read_stream(stream);
  if (stream.bad()) throw ReadError("cannot read '" + file + "'");
  return text;
}

// "/polygon/3/1: " before the message, when the error is about one value of the request.
std::string where(const std::optional<std::string>& pointer) {
  if (!pointer || pointer->empty()) return {};
  return *pointer + ": ";
}

}  // namespace

int fail(std::ostream& err, const std::string& code, const std::string& message) {
  std::string line = "lipmap: error: " + code + ": " + message;
  for (char& c : line)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  err << line << '\n';
  err.flush();
  return codec::error_info(code).exit_code;
}

int classify_command(const std::string& file, bool pretty, std::istream& in, std::ostream& out, std::ostream& err) {
  try {
    const std::string text = read_all(file, in);
    const nlohmann::json body = codec::parse_json(text);
    const BoundaryPolygon polygon = codec::classify_request_from_json(body);
    const Classification answer = classify(polygon);
    out << codec::dump(codec::classification_to_json(answer), pretty) << '\n';
    out.flush();
    if (!out) {
      return fail(err, "output_failed", "cannot write the answer to standard output");
    }
    return kExitOk;
  } catch (const ReadError& e) {
    return fail(err, "file_unreadable", e.what());
  } catch (const InputError& e) {  // JsonError from the codec, or the engine's own validation
    return fail(err, e.code(), where(codec::classify_error_pointer(e)) + e.what());
  } catch (...) {
    return report_failure(err, "classify this polygon");
  }
}

// ---- lipmap map -------------------------------------------------------------------------------------

namespace {

std::string lower_extension(const std::string& path) {
  const std::string ext = codec::lower(std::filesystem::path(path).extension().string());
  return ext.empty() ? ext : ext.substr(1);
}

// An InputError about the boundary, when the boundary came from its own file: "/boundary/positions/3" ->
// "/positions/3" in that file.
std::string map_error_location(const InputError& e, bool boundary_from_file, const std::string& boundary_file,
                               bool mesh_from_json, const std::string& mesh_file, bool metric_from_file,
                               const std::string& metric_file) {
  const std::optional<std::string> pointer = codec::parametrize_error_pointer(e);
  if (!pointer || pointer->empty()) return {};
  const std::string prefix = "/boundary";
  if (boundary_from_file && pointer->compare(0, prefix.size(), prefix) == 0)
    return boundary_file + ": " + pointer->substr(prefix.size()) + ": ";
  if (metric_from_file && pointer->compare(0, 15, "/options/metric") == 0)
    return metric_file + ": " + pointer->substr(15) + ": ";
  if (mesh_from_json) return mesh_file + ": " + *pointer + ": ";
  return {};  // a mesh file: the engine's message names the vertex, face or edge
}

class MapFailure : public std::runtime_error {  // an error line already decided: its code and message
public:
  MapFailure(std::string code, const std::string& message) : std::runtime_error(message), code_(std::move(code)) {}
  const std::string& code() const { return code_; }

private:
  std::string code_;
};

// `text`, then `tail` (a JSON answer's final newline, without copying the answer to append it).
void write_text_file(const std::string& path, const std::string& text, std::string_view tail = {}) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw MapFailure("output_file_unwritable", "cannot create '" + path + "': " + std::strerror(errno));
  file << text << tail;
  file.flush();
  if (!file) throw MapFailure("output_file_unwritable", "cannot write '" + path + "'");
}

std::string fmt_ms(double ms) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f ms", ms);
  return buf;
}

}  // namespace

int map_command(const MapArgs& args, std::ostream& out, std::ostream& err) {
  (void)out;
  const std::string mesh_ext = lower_extension(args.mesh_file);
  const bool mesh_from_json = mesh_ext == "json";
  const bool boundary_from_file = !args.boundary_file.empty();
  // Usage problems first, before any work.
  const std::string out_ext = lower_extension(args.output_file);
  if (out_ext != "obj" && out_ext != "json" && out_ext != "glb" && out_ext != "gltf") {
    return fail(err, "usage", "-o must name a .obj, .json, .glb or .gltf file, got '" + args.output_file + "' (run 'lipmap map --help')");
  }
  if (!mesh_from_json && !boundary_from_file) {
    return fail(err, "usage", "--boundary BOUNDARY.json is required unless MESH is a .json parametrize request "
                             "(run 'lipmap map --help')");
  }
  try {
    // ---- inputs (server/codec/request_loader.h) ----
    // --boundary texcoord:N pins the boundary to the glTF primitive's TEXCOORD_N: a usage error without glTF.
    if (boundary_from_file && gltf::parse_texcoord_spec(args.boundary_file) && !gltf::format_from_path(args.mesh_file))
      throw MapFailure("usage", "--boundary texcoord:N needs a .glb or .gltf MESH");
    codec::RequestInput input;
    input.file = args.mesh_file;
    input.read_file = [](const std::string& file) { return read_all(file, std::cin); };
    // One job alone: a big body is read, and a big answer formatted, on two threads when the machine has them.
    const int threads = std::thread::hardware_concurrency() >= 2 ? 2 : 1;
    input.read_threads = threads;
    input.boundary_file = args.boundary_file;
    // --metric texcoord:N reads the reference map from the glTF primitive: a usage error without glTF.
    if (gltf::parse_texcoord_spec(args.metric) && !gltf::format_from_path(args.mesh_file))
      throw MapFailure("usage", "--metric texcoord:N needs a .glb or .gltf MESH");
    input.metric_file = args.metric;
    gltf::Selection selection;
    selection.mesh = args.gltf_mesh;
    selection.primitive = args.gltf_primitive;
    selection.weld = args.weld == "position" ? gltf::Weld::position : gltf::Weld::none;
    input.gltf_selection = selection;
    if (args.method == "tutte") input.overrides.method = MapMethod::tutte;
    else if (args.method == "harmonic") input.overrides.method = MapMethod::harmonic;
    else if (args.method == "extremal") input.overrides.method = MapMethod::extremal;
    if (args.no_refine) input.overrides.refine = false;
    if (args.target_density > 0) input.overrides.target_density = args.target_density;
    if (!args.optimize.empty()) {
      OptimizeEnergy e{};
      if (parse_optimize_energy(args.optimize, e)) input.overrides.optimize = e;  // CLI11 checked the name
    }
    if (args.max_iterations >= 0) input.overrides.max_iterations = args.max_iterations;
    if (args.time_budget_ms >= 0) input.overrides.time_budget_ms = args.time_budget_ms;
    if (args.no_untangle) input.overrides.untangle = false;
    codec::LoadedRequest loaded = codec::load_request(input);
    const RawMesh& mesh = loaded.request.mesh;
    const RawBoundary& boundary = loaded.request.boundary;
    const ParametrizeOptions& options = loaded.request.options;

    // ---- the pipeline ----
    std::mutex progress_mutex;
    std::chrono::steady_clock::time_point stage_start = std::chrono::steady_clock::now();
    int last_percent = -1;
    ProgressFn progress;
    if (args.progress)
      progress = [&](Stage stage, double fraction) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        const auto now = std::chrono::steady_clock::now();
        if (fraction <= 0) {
          stage_start = now;
          last_percent = 0;
          err << "lipmap: progress: " << lipmap::to_string(stage) << " ...\n";
        } else if (fraction >= 1) {
          err << "lipmap: progress: " << lipmap::to_string(stage) << " done in "
              << fmt_ms(std::chrono::duration<double, std::milli>(now - stage_start).count()) << "\n";
        } else {
          const int percent = static_cast<int>(fraction * 100);
          if (percent < last_percent + 10) return;
          last_percent = percent;
          err << "lipmap: progress: " << lipmap::to_string(stage) << " " << percent << "%\n";
        }
        err.flush();
      };
    // The second core formats the mesh's rows of a big JSON answer while the engine maps it.
    std::optional<codec::MeshRowsAhead> ahead;
    if (out_ext == "json" && !args.pretty && threads > 1 && codec::MeshRowsAhead::pays_off(mesh))
      ahead.emplace(mesh);
    ParametrizeResult result;
    try {
      result = parametrize(mesh, boundary, options, nullptr, progress);
    } catch (const NotSelfOverlapping& e) {
      const Classification& c = e.classification();
      throw MapFailure(e.code(),
                       std::string(e.what()) + " (verdict: " + codec::verdict_name(c.verdict) + ", turning number " +
                           std::to_string(c.turning_number) + ")");
    } catch (const codec::JsonError&) {
      throw;
    } catch (const InputError& e) {
      throw MapFailure(e.code(),
                       map_error_location(e, boundary_from_file, args.boundary_file, mesh_from_json, args.mesh_file,
                                          !args.metric.empty() && args.metric != "surface" &&
                                              !gltf::parse_texcoord_spec(args.metric),
                                          args.metric) +
                           e.what());
    }

    // ---- outputs ----
    if (out_ext == "glb" || out_ext == "gltf") {
      const gltf::Asset asset = loaded.asset ? *loaded.asset : gltf::Asset::from_mesh(mesh);
      write_text_file(args.output_file,
                      gltf::write_answer(asset, result, out_ext == "glb" ? gltf::Format::glb : gltf::Format::gltf));
    } else if (out_ext == "obj") {
      std::ostringstream text;
      write_obj(text, result.map.vertices, result.map.faces, &result.map.uv);
      write_text_file(args.output_file, text.str());
    } else {
      write_text_file(args.output_file,
                      codec::parametrize_result_to_text(result, args.pretty, threads, ahead ? &*ahead : nullptr), "\n");
    }
    if (!args.preview_file.empty())
      write_text_file(args.preview_file, preview::render_svg(preview::picture_of(result, "lipmap map " + args.mesh_file)));
    if (args.progress) {
      char buf[512];
      std::snprintf(buf, sizeof buf,
                    "lipmap: done: verdict %s, %zu vertices (%zu inserted), %zu triangles, %d flipped before "
                    "refinement, %d flipped, distortion max %.4g mean %.4g (before optimization %.4g, %d "
                    "steps), total %.1f ms\n",
                    codec::verdict_name(result.classification.verdict), result.map.vertices.size(),
                    result.map.inserted.size(), result.map.faces.size(), result.map.flipped_before_refinement,
                    result.flipped, result.distortion.max, result.distortion.mean,
                    result.optimization.ran ? result.optimization.before.mean : result.distortion.mean,
                    result.optimization.iterations, result.timings.total);
      err << buf;
      err.flush();
    }
    return kExitOk;
  } catch (const MapFailure& e) {
    return fail(err, e.code(), e.what());
  } catch (const ReadError& e) {
    return fail(err, "file_unreadable", e.what());
  } catch (const InputError& e) {  // read_mesh_file, write_obj
    return fail(err, e.code(), e.what());
  } catch (...) {
    return report_failure(err, "map this mesh");
  }
}

int run(int argc, const char* const* argv, std::istream& in, std::ostream& out, std::ostream& err) {
  try {
    CLI::App app{"lipmap: locally injective parametrization of disk meshes onto self-overlapping boundaries",
                 "lipmap"};
    app.require_subcommand(1);
    app.set_version_flag("--version", std::string("lipmap ") + kVersion, "Print the version (lipmap X.Y.Z) and exit");

    std::string classify_file;
    bool pretty = false;
    CLI::App* classify_cmd = app.add_subcommand(
        "classify", "Classify a boundary polygon (simple / self_overlapping / weakly_self_overlapping / "
                    "not_self_overlapping) and print the answer as JSON");
    classify_cmd
        ->add_option("FILE", classify_file,
                     "JSON body of POST /v1/polygons/classify: {\"polygon\": [[x, y], ...], "
                     "\"rotation_indices\": [r, ...]?}; - reads standard input")
        ->required();
    classify_cmd->add_flag("--pretty", pretty, "Indent the JSON answer");

    MapArgs map_args;
    CLI::App* map_cmd = app.add_subcommand(
        "map", "Map a disk mesh onto a boundary polygon with a locally injective map (refining the mesh where "
               "needed) and write the refined mesh with its uv");
    map_cmd
        ->add_option("MESH", map_args.mesh_file,
                     "The mesh (.obj, .off, .ply, .stl, .glb, .gltf), or a .json POST /v1/parametrize body {mesh, boundary, options}")
        ->required();
    map_cmd->add_option("--boundary,-b", map_args.boundary_file,
                        "JSON {\"vertices\": [i...]?, \"positions\": [[u, v]...], \"rotation_indices\": [r...]?}: "
                        "the image of the boundary loop (required unless MESH is .json; replaces the body's); "
                        "for a .glb/.gltf MESH also texcoord:N (each boundary vertex stays at its TEXCOORD_N)");
    map_cmd->add_option("--output,-o", map_args.output_file,
                        "OUT.obj (v, vt, f v/vt lines), OUT.json (the HTTP answer of POST /v1/parametrize), or "
                        "OUT.glb / OUT.gltf (the glTF document with the refined primitive, TEXCOORD_0 = (u, 1 - v))")
        ->required();
    map_cmd->add_option("--gltf-mesh", map_args.gltf_mesh, "glTF MESH: index of the mesh to map (default 0)")
        ->check(CLI::NonNegativeNumber);
    map_cmd->add_option("--gltf-primitive", map_args.gltf_primitive,
                        "glTF MESH: index of the primitive of that mesh (default 0)")
        ->check(CLI::NonNegativeNumber);
    map_cmd->add_option("--weld", map_args.weld,
                        "glTF MESH: none (default) or position (merge vertices with bit-identical POSITION, as glTF "
                        "splits them at seams)")
        ->check(CLI::IsMember({"none", "position"}));
    map_cmd->add_option("--method", map_args.method,
                        "Intermediate maps: harmonic (default), tutte, or extremal (paper 5.3: least worst-case distortion)")
        ->check(CLI::IsMember({"tutte", "harmonic", "extremal"}));
    map_cmd->add_flag("--no-refine", map_args.no_refine,
                      "Only the vertex-wise map: no refinement, so the result may have flipped triangles");
    map_cmd->add_option("--target-density", map_args.target_density,
                        "Target-mesh triangles relative to the source's (default 1)")
        ->check(CLI::PositiveNumber);
    map_cmd->add_option("--optimize", map_args.optimize,
                        "Distortion optimization after refinement: mips (default; conformal), symmetric_dirichlet "
                        "or none")
        ->check(CLI::IsMember({"none", "mips", "symmetric_dirichlet"}));
    map_cmd->add_option("--max-iterations", map_args.max_iterations,
                        "Optimization steps, at most (default 1000; 0: no optimization)")
        ->check(CLI::Range(0, kMaxOptimizeIterations));
    map_cmd->add_option("--time-budget-ms", map_args.time_budget_ms,
                        "Wall time of the optimization, at most (default: no budget)")
        ->check(CLI::NonNegativeNumber);
    map_cmd->add_flag("--no-untangle", map_args.no_untangle,
                      "Refine whenever the composed map folds, without trying to untangle the unrefined mesh first");
    map_cmd->add_option("--metric", map_args.metric,
                        "The metric of the map (paper 5.2): surface (default), texcoord:N (glTF MESH: TEXCOORD_N as "
                        "the reference map; with --boundary texcoord:N, repair that chart's flips), or METRIC.json "
                        "holding \"surface\" or {\"uv\": [[u, v]...]} (one per vertex). A locally injective "
                        "reference map with the same boundary comes back unchanged");
    map_cmd->add_option("--preview", map_args.preview_file,
                        "Also write an SVG picture of the uv map (distortion colours, flips in red, target outline)");
    map_cmd->add_flag("--progress", map_args.progress, "Print each stage and a summary on standard error");
    map_cmd->add_flag("--pretty", map_args.pretty, "Indent the JSON output");
    ServeOptions serve_options;
    CLI::App* serve_cmd = add_serve_subcommand(app, serve_options);

    try {
      app.parse(argc, argv);
    } catch (const CLI::CallForHelp&) {
      out << app.help();
      return kExitOk;
    } catch (const CLI::CallForAllHelp&) {
      out << app.help("", CLI::AppFormatMode::All);
      return kExitOk;
    } catch (const CLI::CallForVersion& e) {
      out << e.what() << '\n';
      return kExitOk;
    } catch (const CLI::ParseError& e) {
      std::string message = e.what();
      const std::string first = argc > 1 ? argv[1] : "";
      if (!first.empty() && first[0] != '-' && first != "classify" && first != "map" && first != "serve")
        message = "unknown subcommand '" + std::string(argv[1]) + "' (expected classify, map or serve)";
      return fail(err, "usage", message + " (run 'lipmap --help')");
    }

    if (classify_cmd->parsed()) return classify_command(classify_file, pretty, in, out, err);
    if (map_cmd->parsed()) return map_command(map_args, out, err);
    if (serve_cmd->parsed()) return serve_command(serve_options, out, err);
    return fail(err, "usage", "no subcommand given (run 'lipmap --help')");
  } catch (const std::bad_alloc&) {
    return fail(err, "out_of_memory", "not enough memory");
  } catch (const std::exception& e) {
    return fail(err, "internal_error", e.what());
  } catch (...) {
    return fail(err, "internal_error", "unexpected exception");
  }
}

}  // namespace lipmap::cli
