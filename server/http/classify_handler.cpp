// POST /v1/polygons/classify: the engine's classify stage alone (is the polygon self-overlapping, and how).
#include "engine/classify.h"
#include "server/http/handlers.h"
#include "server/http/memory_budget.h"
#include "server/http/middleware.h"

// Last: with its OpenSSL support cpp-httplib pulls in <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>

namespace lipmap::server {

Answer post_classify(Service& service, const httplib::Request& req) {
  if (auto a = service.refuse_when_draining()) return *a;
  if (auto a = require_json(req)) return *a;
  BoundaryPolygon polygon;
  const auto parse_start = Clock::now();
  try {
    polygon = codec::classify_request_from_json(codec::parse_json(req.body));
  } catch (const InputError& e) {
    return problem_answer(input_problem(e, InputKind::classify));
  }
  this_request().parse_ms = ms_since(parse_start);
  const std::size_t limit = service.config.max_polygon_vertices;
  if (polygon.vertices.size() > limit)
    return problem_answer("polygon_too_large",
                          "the polygon has " + std::to_string(polygon.vertices.size()) +
                              " vertices; this service takes at most " + std::to_string(limit),
                          std::string("/polygon"));
  const std::size_t cost = classify_cost(polygon.vertices.size());
  if (cost > request_budget(service.config.memory_budget_bytes, req.body.size()))
    return over_budget(service.config, cost, req.body.size(), "classifying this polygon");
  const TestHooks hooks = service.hooks_of(req);
  Metrics& metrics = service.metrics;
  return service.run_sync(InputKind::classify, [polygon = std::move(polygon), hooks, &metrics](const CancelToken& token) {
    apply_hooks(hooks, token);
    const auto t0 = Clock::now();
    const Classification c = classify(polygon, &token);
    metrics.observe_stage("classify", ms_since(t0) / 1000.0);
    Answer a;
    a.body = codec::dump(codec::classification_to_json(c));
    return a;
  });
}

}  // namespace lipmap::server
