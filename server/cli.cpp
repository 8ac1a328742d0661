#include "server/cli.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <new>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>

#include "engine/classify.h"
#include "engine/error.h"
#include "server/json_codec.h"
#include "server/serve_command.h"

namespace lipmap::cli {

namespace {

// One line, whatever the message holds: control characters (a newline in an engine message, say)
// become spaces.
void error_line(std::ostream& err, const std::string& code, const std::string& message) {
  std::string line = "lipmap: error: " + code + ": " + message;
  for (char& c : line)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  err << line << '\n';
  err.flush();
}

// A file that cannot be read is the caller's fault; reported like any other input error.
class ReadError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

std::string read_all(const std::string& file, std::istream& in) {
  if (file == "-") {
    std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    if (in.bad()) throw ReadError("cannot read standard input");
    return text;
  }
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec)) throw ReadError("cannot read '" + file + "': it is a directory");
  std::ifstream stream(file, std::ios::binary);
  if (!stream) throw ReadError("cannot open '" + file + "': " + std::strerror(errno));
  std::string text{std::istreambuf_iterator<char>(stream), std::istreambuf_iterator<char>()};
  if (stream.bad()) throw ReadError("cannot read '" + file + "'");
  return text;
}

// "/polygon/3/1: " before the message, when the error is about one value of the request.
std::string where(const std::optional<std::string>& pointer) {
  if (!pointer || pointer->empty()) return {};
  return *pointer + ": ";
}

int not_implemented(const std::string& what, const std::string& coming_with, std::ostream& err) {
  error_line(err, "not_implemented", "'lipmap " + what + "' is not implemented yet (it comes with " + coming_with + ")");
  return kExitUsageError;
}

}  // namespace

int classify_command(const std::string& file, bool pretty, std::istream& in, std::ostream& out, std::ostream& err) {
  try {
    const std::string text = read_all(file, in);
    const nlohmann::json body = codec::parse_json(text);
    const BoundaryPolygon polygon = codec::classify_request_from_json(body);
    const Classification answer = classify(polygon);
    out << codec::dump(codec::classification_to_json(answer), pretty) << '\n';
    out.flush();
    if (!out) {
      error_line(err, "output_failed", "cannot write the answer to standard output");
      return kExitInputError;
    }
    return kExitOk;
  } catch (const ReadError& e) {
    error_line(err, "file_unreadable", e.what());
    return kExitInputError;
  } catch (const InputError& e) {  // JsonError from the codec, or the engine's own validation
    error_line(err, e.code(), where(codec::classify_error_pointer(e)) + e.what());
    return kExitInputError;
  } catch (const InternalError& e) {
    error_line(err, "internal_error", e.what());
    return kExitInternalError;
  } catch (const Cancelled& e) {
    error_line(err, "cancelled", e.what());
    return kExitInternalError;
  } catch (const std::bad_alloc&) {
    error_line(err, "out_of_memory", "not enough memory to classify this polygon");
    return kExitInternalError;
  } catch (const std::exception& e) {
    error_line(err, "internal_error", e.what());
    return kExitInternalError;
  } catch (...) {
    error_line(err, "internal_error", "unexpected exception");
    return kExitInternalError;
  }
}

int run(int argc, const char* const* argv, std::istream& in, std::ostream& out, std::ostream& err) {
  try {
    CLI::App app{"lipmap: locally injective parametrization of disk meshes onto self-overlapping boundaries",
                 "lipmap"};
    app.require_subcommand(1);

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

    CLI::App* map_cmd = app.add_subcommand("map", "Map a mesh onto a boundary polygon (not implemented yet)");
    map_cmd->allow_extras();
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
    } catch (const CLI::ParseError& e) {
      std::string message = e.what();
      const std::string first = argc > 1 ? argv[1] : "";
      if (!first.empty() && first[0] != '-' && first != "classify" && first != "map" && first != "serve")
        message = "unknown subcommand '" + std::string(argv[1]) + "' (expected classify, map or serve)";
      error_line(err, "usage", message + " (run 'lipmap --help')");
      return kExitUsageError;
    }

    if (classify_cmd->parsed()) return classify_command(classify_file, pretty, in, out, err);
    if (map_cmd->parsed()) return not_implemented("map", "the remapping engine", err);
    if (serve_cmd->parsed()) return serve_command(serve_options, out, err);
    error_line(err, "usage", "no subcommand given (run 'lipmap --help')");
    return kExitUsageError;
  } catch (const std::bad_alloc&) {
    error_line(err, "out_of_memory", "not enough memory");
    return kExitInternalError;
  } catch (const std::exception& e) {
    error_line(err, "internal_error", e.what());
    return kExitInternalError;
  } catch (...) {
    error_line(err, "internal_error", "unexpected exception");
    return kExitInternalError;
  }
}

}  // namespace lipmap::cli
