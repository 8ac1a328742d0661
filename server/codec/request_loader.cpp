// From what arrived to the engine's request (see request_loader.h).
#include "server/codec/request_loader.h"

#include <cctype>
#include <filesystem>
#include <utility>

#include "engine/mesh_io.h"
#include "server/codec/text.h"

namespace lipmap::codec {

namespace {

// A JsonError inside a named file: the file name and the pointer before the message.
[[noreturn]] void rethrow_in_file(const JsonError& e, const std::string& file) {
  throw JsonError(e.code(), file + ": " + (e.pointer().empty() ? "" : e.pointer() + ": ") + e.what(), e.pointer(),
                  e.byte_offset());
}

std::string read(const RequestInput& input, const std::string& file) {
  if (!input.read_file) throw InternalError("request loader: no reader for the file '" + file + "'");
  return input.read_file(file);
}

// The separate boundary document, parsed as a boundary object (pointers relative to it).
RawBoundary boundary_document(const RequestInput& input) {
  if (gltf::parse_texcoord_spec(input.boundary_file))
    throw gltf::GltfError("gltf_invalid_request", "boundary " + input.boundary_file + " needs a .glb or .gltf model");
  try {
    return boundary_from_json(parse_json(read(input, input.boundary_file)));
  } catch (const JsonError& e) {
    rethrow_in_file(e, input.boundary_file);
  }
}

void apply(const OptionOverrides& o, ParametrizeOptions& options) {
  if (o.method) options.method = *o.method;
  if (o.refine) options.refine = *o.refine;
  if (o.target_density) options.target_density = *o.target_density;
  if (o.optimize) options.optimize = *o.optimize;
  if (o.max_iterations) options.max_iterations = *o.max_iterations;
  if (o.time_budget_ms) options.time_budget_ms = *o.time_budget_ms;
  if (o.untangle) options.untangle = *o.untangle;
}

LoadedRequest from_gltf(gltf::Request r, RequestForm form) {
  LoadedRequest out;
  out.form = form;
  out.request = std::move(r.request);
  out.asset = std::move(r.asset);
  out.texcoord_set = r.texcoord_set;
  return out;
}

// A .glb / .gltf file: the selected primitive, its boundary from TEXCOORD_N or from the boundary document.
LoadedRequest gltf_file(const RequestInput& input, gltf::Format format) {
  LoadedRequest out;
  out.form = RequestForm::gltf_model;
  if (!input.boundary_file.empty()) out.texcoord_set = gltf::parse_texcoord_spec(input.boundary_file);
  const gltf::Selection selection = input.gltf_selection.value_or(gltf::Selection{});
  out.asset = gltf::Asset::read(read(input, input.file), selection, format);
  out.request.mesh = out.asset->mesh();
  if (out.texcoord_set) out.request.boundary = out.asset->texcoord_boundary(*out.texcoord_set);
  else if (!input.boundary_file.empty()) out.request.boundary = boundary_document(input);
  return out;
}

// A parametrize body; from a file, its JSON errors name the file.
LoadedRequest parametrize_json(const RequestInput& input) {
  LoadedRequest out;
  out.form = RequestForm::parametrize_json;
  if (input.file.empty()) {
    // A plain body is read straight into the engine's arrays; anything else (an envelope, an error) the
    // ordinary way.
    if (auto request = parametrize_request_from_text(input.body, input.body_padding, input.read_threads)) {
      out.request = std::move(*request);
      return out;
    }
    const nlohmann::json body = parse_json(input.body);
    if (gltf::is_envelope(body)) return from_gltf(gltf::request_from_envelope(body, input.gltf_params), RequestForm::gltf_envelope);
    out.request = parametrize_request_from_json(body);
    return out;
  }
  try {
    // With a boundary document the body's boundary is still parsed (a body must be a valid request), then
    // replaced.
    std::string text = read(input, input.file);
    if (auto request = parametrize_request_from_text(text, pad_for_reading(text), input.read_threads)) out.request = std::move(*request);
    else out.request = parametrize_request_from_json(parse_json(text));
  } catch (const JsonError& e) {
    rethrow_in_file(e, input.file);
  }
  if (!input.boundary_file.empty()) out.request.boundary = boundary_document(input);
  return out;
}

// --metric: replaces options.metric (read after the main document and the boundary, like them in the order
// of the command line).
void apply_metric(const RequestInput& input, LoadedRequest& out) {
  const std::string& spec = input.metric_file;
  if (spec == "surface") {
    out.request.options.metric.reset();
  } else if (const std::optional<int> set = gltf::parse_texcoord_spec(spec)) {
    if (!out.asset) throw gltf::GltfError("gltf_invalid_request", "metric " + spec + " needs a .glb or .gltf model");
    out.request.options.metric = out.asset->texcoord_uv(*set);
  } else {
    try {
      out.request.options.metric = metric_from_json(parse_json(read(input, spec)));
    } catch (const JsonError& e) {
      rethrow_in_file(e, spec);
    }
  }
}

}  // namespace

const char* to_string(RequestForm form) {
  switch (form) {
    case RequestForm::parametrize_json: return "parametrize_json";
    case RequestForm::gltf_envelope: return "gltf_envelope";
    case RequestForm::gltf_model: return "gltf_model";
    case RequestForm::multipart: return "multipart";
    case RequestForm::mesh_file: return "mesh_file";
  }
  return "parametrize_json";
}

std::optional<RequestForm> request_form(const RequestInput& input) {
  if (!input.file.empty()) {
    if (gltf::format_from_path(input.file)) return RequestForm::gltf_model;
    if (lower(std::filesystem::path(input.file).extension().string()) == ".json") return RequestForm::parametrize_json;
    return RequestForm::mesh_file;  // read_mesh_file names an extension it does not know
  }
  const std::string media = media_type(input.media_type);
  if (gltf::format_from_media_type(media)) return RequestForm::gltf_model;
  if (media == "multipart/form-data") return RequestForm::multipart;
  if (media == "application/json") return RequestForm::parametrize_json;
  return std::nullopt;
}

LoadedRequest load_request(const RequestInput& input) {
  const std::optional<RequestForm> form = request_form(input);
  if (!form)  // the caller refuses these first (HTTP: 415 with the supported types)
    throw InternalError("request loader: no request form for the media type '" + input.media_type + "'");
  LoadedRequest out;
  switch (*form) {
    case RequestForm::parametrize_json:
    case RequestForm::gltf_envelope:
      out = parametrize_json(input);
      break;
    case RequestForm::gltf_model:
      if (!input.file.empty()) {
        out = gltf_file(input, *gltf::format_from_path(input.file));
      } else {
        const gltf::Format format = *gltf::format_from_media_type(media_type(input.media_type));
        out = from_gltf(gltf::request_from_model(input.body, format, input.gltf_params), RequestForm::gltf_model);
      }
      break;
    case RequestForm::multipart:
      out = from_gltf(gltf::request_from_parts(input.parts, input.gltf_params), RequestForm::multipart);
      break;
    case RequestForm::mesh_file:
      out.form = RequestForm::mesh_file;
      out.request.mesh = read_mesh_file(input.file);
      if (!input.boundary_file.empty()) out.request.boundary = boundary_document(input);
      break;
  }
  if (!input.metric_file.empty()) apply_metric(input, out);
  apply(input.overrides, out.request.options);
  return out;
}

}  // namespace lipmap::codec
