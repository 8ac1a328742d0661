// POST /v1/parametrize, and the parsing and engine call that POST /v1/jobs shares with it.
#include <cctype>
#include <map>
#include <optional>
#include <string>

#include "server/codec/request_loader.h"
#include "server/codec/text.h"
#include "server/http/handlers.h"
#include "server/http/memory_budget.h"
#include "server/http/middleware.h"

// Last: with its OpenSSL support cpp-httplib pulls in <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>

namespace lipmap::server {

using nlohmann::json;

namespace {

std::optional<Answer> check_mesh_limits(const ServerConfig& config, const codec::ParametrizeRequest& r,
                                        std::size_t body_bytes) {
  if (r.mesh.vertices.size() > config.max_vertices)
    return problem_answer("mesh_too_large",
                          "the mesh has " + std::to_string(r.mesh.vertices.size()) +
                              " vertices; this service takes at most " + std::to_string(config.max_vertices),
                          std::string("/mesh/vertices"));
  if (r.mesh.faces.size() > config.max_faces)
    return problem_answer("mesh_too_large",
                          "the mesh has " + std::to_string(r.mesh.faces.size()) +
                              " faces; this service takes at most " + std::to_string(config.max_faces),
                          std::string("/mesh/faces"));
  if (r.boundary.positions.size() > config.max_polygon_vertices)
    return problem_answer("polygon_too_large",
                          "the boundary has " + std::to_string(r.boundary.positions.size()) +
                              " positions; this service takes at most " + std::to_string(config.max_polygon_vertices),
                          std::string("/boundary/positions"));
  const std::size_t cost = parametrize_cost(r.mesh.vertices.size(), r.mesh.faces.size(), r.boundary.positions.size(),
                                            r.options.target_density);
  if (cost > request_budget(config.memory_budget_bytes, body_bytes))
    return over_budget(config, cost, body_bytes, "mapping this mesh");
  return std::nullopt;
}

}  // namespace

Answer over_budget(const ServerConfig& config, std::size_t estimate, std::size_t body_bytes, const std::string& what) {
  const std::size_t budget = request_budget(config.memory_budget_bytes, body_bytes);
  Answer a = problem_answer("memory_budget_exceeded",
                            what + " would take about " + mebibytes(estimate) + ", more than the " + mebibytes(budget) +
                                " this service gives a request of " + std::to_string(body_bytes) +
                                " bytes (--memory-budget, and at most 64 MiB + 128 bytes per body byte)");
  (*a.problem)["estimate_bytes"] = estimate;
  (*a.problem)["budget_bytes"] = budget;
  return a;
}

std::optional<Answer> require_json(const httplib::Request& req) {
  const std::string raw = req.get_header_value("Content-Type");
  const std::string type = codec::media_type(raw);
  if (type == "application/json") return std::nullopt;
  const std::string detail =
      raw.empty() ? std::string("the request has no Content-Type; send the body as application/json")
                  : "Content-Type " + json(raw).dump(-1, ' ', false, json::error_handler_t::replace) +
                        " is not supported; send the body as application/json";
  Answer a = problem_answer("unsupported_media_type", detail);
  (*a.problem)["supported"] = {"application/json"};
  a.headers.emplace_back("Accept-Post", "application/json");
  return a;
}

std::variant<ParsedParametrize, Answer> parse_parametrize(Service& service, const httplib::Request& req) {
  if (auto a = service.refuse_when_draining()) return *a;
  // The request loader (server/codec/request_loader.h) is shared with `lipmap map`: a parametrize JSON body, a
  // glTF envelope, a glTF model (query parameters mesh, primitive, weld, boundary=texcoord:N) or multipart.
  codec::RequestInput input;
  input.body = req.body;
  // pre_routing reserved the room for it: the JSON reader reads the body in place.
  input.body_padding = codec::pad_for_reading(const_cast<std::string&>(req.body));
  input.read_threads = service.read_threads();
  input.media_type = req.get_header_value("Content-Type");
  if (!codec::request_form(input)) {
    Answer a = *require_json(req);
    (*a.problem)["supported"] = {"application/json", "model/gltf-binary", "model/gltf+json", "multipart/form-data"};
    for (auto& [k, v] : a.headers)
      if (k == "Accept-Post") v = "application/json, model/gltf-binary, model/gltf+json, multipart/form-data";
    return a;
  }
  auto param = [&](const char* name) -> std::optional<std::string> {
    if (!req.has_param(name)) return std::nullopt;
    return req.get_param_value(name);
  };
  input.gltf_params.mesh = param("mesh");
  input.gltf_params.primitive = param("primitive");
  input.gltf_params.weld = param("weld");
  input.gltf_params.boundary = param("boundary");
  input.gltf_params.metric = param("metric");
  std::optional<codec::LoadedRequest> loaded;
  try {
    for (const auto& [name, file] : req.files) {
      if (input.parts.count(name)) throw gltf::GltfError("gltf_invalid_request", "multipart part \"" + name + "\" is given twice");
      input.parts[name] = gltf::Part{file.content, file.content_type};
    }
    loaded = codec::load_request(input);
  } catch (const InputError& e) {
    // Parsing throws the codecs' errors (they carry their own pointers) or the validate stage's about a glTF
    // primitive, which has no JSON value to point at.
    return problem_answer(input_problem(e, InputKind::none));
  }
  auto request = std::make_shared<const codec::ParametrizeRequest>(std::move(loaded->request));
  if (auto a = check_mesh_limits(service.config, *request, req.body.size())) return *a;
  std::shared_ptr<const gltf::Asset> asset;
  if (loaded->asset) asset = std::make_shared<const gltf::Asset>(std::move(*loaded->asset));
  return ParsedParametrize{std::move(request), std::move(asset)};
}

std::shared_ptr<const ParametrizeResult> map_request(const codec::ParametrizeRequest& request, const CancelToken& token,
                                                   const ProgressFn& progress, Metrics& metrics) {
  auto result = std::make_shared<ParametrizeResult>(
      parametrize(request.mesh, request.boundary, request.options, &token, progress));
  const StageTimings& t = result->timings;
  const std::pair<Stage, double> stages[] = {{Stage::validate, t.validate},   {Stage::classify, t.classify},
                                             {Stage::target_mesh, t.target_mesh},
                                             {Stage::intermediate_maps, t.intermediate_maps},
                                             {Stage::compose, t.compose},     {Stage::untangle, t.untangle},
                                             {Stage::refine, t.refine},       {Stage::optimize, t.optimize},
                                             {Stage::verify, t.verify},       {Stage::quality, t.quality}};
  for (const auto& [stage, ms] : stages) metrics.observe_stage(lipmap::to_string(stage), ms / 1000.0);
  metrics.observe_inserted_vertices(static_cast<long long>(result->map.inserted.size()));
  return result;
}

MapOutcome run_map(const codec::ParametrizeRequest& request, const CancelToken& token, const ProgressFn& progress,
                   Metrics& metrics) {
  std::shared_ptr<const ParametrizeResult> result = map_request(request, token, progress, metrics);
  auto text = std::make_shared<const std::string>(codec::parametrize_result_to_text(*result));
  return {std::move(text), std::move(result)};
}

Answer gltf_answer(const std::shared_ptr<const gltf::Asset>& asset, const ParametrizeResult& result, gltf::Format f) {
  Answer a;
  a.content_type = gltf::media_type(f);
  a.body = asset ? gltf::write_answer(*asset, result, f) : gltf::write_answer(result, f);
  return a;
}

Answer post_parametrize(Service& service, const httplib::Request& req) {
  const auto parse_start = Clock::now();
  auto parsed = parse_parametrize(service, req);
  this_request().parse_ms = ms_since(parse_start);
  if (auto* a = std::get_if<Answer>(&parsed)) return std::move(*a);
  ParsedParametrize p = std::get<ParsedParametrize>(std::move(parsed));
  const TestHooks hooks = service.hooks_of(req);
  const std::optional<gltf::Format> answer_format = gltf::accepted_format(req.get_header_value("Accept"));
  Metrics& metrics = service.metrics;
  const Service& svc = service;
  return service.run_sync(InputKind::parametrize, [p, hooks, answer_format, &metrics, &svc](const CancelToken& token) {
    apply_hooks(hooks, token);
    // A job alone on the machine: the idle core formats the mesh's rows of a big JSON answer meanwhile.
    std::optional<codec::MeshRowsAhead> ahead;
    if (!answer_format && svc.answer_threads() > 1 && codec::MeshRowsAhead::pays_off(p.request->mesh))
      ahead.emplace(p.request->mesh);
    // The answer's text is this request's alone: it is moved, not copied, into the response (middleware.cpp).
    const std::shared_ptr<const ParametrizeResult> result = map_request(*p.request, token, {}, metrics);
    Answer a;
    if (answer_format) a = gltf_answer(p.asset, *result, *answer_format);
    else a.body = codec::parametrize_result_to_text(*result, false, svc.answer_threads(), ahead ? &*ahead : nullptr);
    a.engine_ms = result->timings.total;
    // The request and the result are freed once the answer is out, not before its first byte.
    a.keep_until_sent = std::make_shared<const std::pair<std::shared_ptr<const codec::ParametrizeRequest>,
                                                         std::shared_ptr<const ParametrizeResult>>>(p.request, result);
    return a;
  });
}

}  // namespace lipmap::server
