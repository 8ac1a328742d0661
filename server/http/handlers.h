// The handlers of the HTTP service, one file per resource:
//   parametrize_handler.cpp  POST /v1/parametrize
//   classify_handler.cpp     POST /v1/polygons/classify
//   jobs_handler.cpp         POST /v1/jobs, GET|DELETE /v1/jobs/{id}, GET /v1/jobs/{id}/result,
//                            GET /v1/jobs/{id}/preview.svg
//   operations_handler.cpp   GET /healthz, /readyz, /metrics, /version, /v1/openapi.json,
//                            /v1/{schema}.schema.json
// server/http/routes.cpp binds them to their paths. A handler parses on the connection thread and runs engine
// work on the worker pool (Service::run_sync), or hands it to a job.
#pragma once

#include <memory>
#include <optional>
#include <variant>

#include "engine/cancel.h"
#include "engine/pipeline.h"
#include "server/codec/gltf_codec.h"
#include "server/codec/json_codec.h"
#include "server/http/problems.h"
#include "server/http/service.h"

namespace httplib {
struct Request;
}

namespace lipmap::server {

Answer post_parametrize(Service& service, const httplib::Request& req);
Answer post_classify(Service& service, const httplib::Request& req);
Answer post_job(Service& service, const httplib::Request& req);
Answer get_job(Service& service, const httplib::Request& req);
Answer delete_job(Service& service, const httplib::Request& req);
Answer get_job_result(Service& service, const httplib::Request& req);
Answer get_job_preview(Service& service, const httplib::Request& req);
Answer get_healthz(Service& service, const httplib::Request& req);
Answer get_readyz(Service& service, const httplib::Request& req);
Answer get_metrics(Service& service, const httplib::Request& req);
Answer get_version(Service& service, const httplib::Request& req);
Answer get_openapi(Service& service, const httplib::Request& req);
Answer get_schema(Service& service, const httplib::Request& req);

// ---- shared by the parametrize, classify and jobs handlers (parametrize_handler.cpp) ----

// 422 memory_budget_exceeded: `what` would take about `estimate` bytes, more than a request with a body of
// `body_bytes` may (server/http/memory_budget.h).
Answer over_budget(const ServerConfig& config, std::size_t estimate, std::size_t body_bytes, const std::string& what);

// 415 unless the body is application/json.
std::optional<Answer> require_json(const httplib::Request& req);

// A parametrize body parsed on the connection thread; glTF requests also keep their document (to answer
// in it).
struct ParsedParametrize {
  std::shared_ptr<const codec::ParametrizeRequest> request;
  std::shared_ptr<const gltf::Asset> asset;  // glTF requests only
};
// The parsed request, or the answer refusing it.
std::variant<ParsedParametrize, Answer> parse_parametrize(Service& service, const httplib::Request& req);

// A job's outcome: the engine's result and its JSON answer.
struct MapOutcome {
  std::shared_ptr<const std::string> json;
  std::shared_ptr<const ParametrizeResult> result;
};
// The engine on a request, with its stage timings and inserted vertices counted in the metrics.
std::shared_ptr<const ParametrizeResult> map_request(const codec::ParametrizeRequest& request, const CancelToken& token,
                                                   const ProgressFn& progress, Metrics& metrics);
// map_request and the answer's JSON text, shared: a job's result is kept, and may be fetched many times.
MapOutcome run_map(const codec::ParametrizeRequest& request, const CancelToken& token, const ProgressFn& progress,
                   Metrics& metrics);

// A parametrize answer in glTF: the request's document with the refined primitive, or a fresh document for
// a JSON request.
Answer gltf_answer(const std::shared_ptr<const gltf::Asset>& asset, const ParametrizeResult& result, gltf::Format f);

}  // namespace lipmap::server
