// One way from what arrived to the engine's request, shared by `lipmap map` and the HTTP parametrize routes.
//
// The forms, decided by the media type (HTTP) or the file name's extension (command line):
//   parametrize_json  application/json or .json: {"mesh", "boundary", "options"?} (json_codec.h)
//   gltf_envelope     application/json holding {"gltf_base64", ...} (gltf_codec.h)
//   gltf_model        model/gltf-binary, model/gltf+json, .glb or .gltf: boundary=texcoord:N, or (command line)
//                     a separate boundary document
//   multipart         multipart/form-data: parts model, boundary, options (gltf_codec.h)
//   mesh_file         .obj, .off, .ply, .stl (engine/mesh_io.h), with a separate boundary document
// A separate boundary document (`lipmap map --boundary FILE`) is a JSON boundary object; it replaces the
// boundary of a parametrize_json body (which must still be a valid request). It is read after the main
// document, so that errors come in the order of the command line. Option overrides apply last.
//
// Errors: codec::JsonError (with the file name before the pointer when the document is a named file),
// gltf::GltfError, the validate stage's InputError about a glTF primitive, read_mesh_file's InputError, and
// whatever read_file throws. The loader decides no HTTP status or exit code.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "engine/parametrize_options.h"
#include "server/codec/gltf_codec.h"
#include "server/codec/json_codec.h"

namespace lipmap::codec {

enum class RequestForm { parametrize_json, gltf_envelope, gltf_model, multipart, mesh_file };
const char* to_string(RequestForm form);

// Options given beside the request (command-line flags); each replaces the request's own when set.
struct OptionOverrides {
  std::optional<MapMethod> method;
  std::optional<bool> refine;
  std::optional<double> target_density;
  std::optional<OptimizeEnergy> optimize;
  std::optional<int> max_iterations;
  std::optional<double> time_budget_ms;
  std::optional<bool> untangle;
};

struct RequestInput {
  // HTTP: the body and its Content-Type (parameters ignored); multipart bodies come as their parts.
  std::string_view body;
  std::size_t body_padding = 0;  // initialized bytes readable after body (parametrize_request_from_text)
  int read_threads = 1;          // threads that may read a big JSON body (parametrize_request_from_text)
  std::string media_type;
  std::map<std::string, gltf::Part> parts;
  // Command line: the MESH file (its extension names the form) and the reader of a file's bytes; a mesh file
  // (.obj ...) is read by the engine's reader from its path.
  std::string file;
  std::function<std::string(const std::string& file)> read_file;
  // A separate boundary: a JSON boundary object in this file, or "texcoord:N" for a glTF model.
  std::string boundary_file;
  // A metric given beside the request (command line --metric): "surface", "texcoord:N" for a glTF model, or
  // a JSON metric document in this file ("surface" or {"uv": [[u, v]...]}); it replaces the request's own.
  std::string metric_file;
  // glTF selection: parameters as they came (strings, parsed strictly), or already typed (command line).
  gltf::Params gltf_params;
  std::optional<gltf::Selection> gltf_selection;
  OptionOverrides overrides;
};

struct LoadedRequest {
  RequestForm form = RequestForm::parametrize_json;
  ParametrizeRequest request;        // the engine's input: mesh, boundary, options
  std::optional<gltf::Asset> asset;  // the document, when the input was glTF
  std::optional<int> texcoord_set;   // boundary=texcoord:N
};

// The form of a request, or nullopt for a media type the loader does not take (a file always has a form:
// an unknown extension is a mesh file that read_mesh_file refuses).
std::optional<RequestForm> request_form(const RequestInput& input);

// Precondition: request_form(input) has a value (the caller refuses other media types; else InternalError).
LoadedRequest load_request(const RequestInput& input);

}  // namespace lipmap::codec
