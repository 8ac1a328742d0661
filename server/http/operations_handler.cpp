// What operators and clients ask of the service itself: GET /healthz, /readyz, /metrics, /version, and the
// API's own documents (/v1/openapi.json, /v1/{schema}.schema.json, compiled in from proto/).
#include <algorithm>
#include <string>

#include "server/http/handlers.h"
#include "server/http/proto_embedded.h"

// Last: with its OpenSSL support cpp-httplib pulls in <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>

#ifndef LIPMAP_VERSION
#error "LIPMAP_VERSION (the project's version) is defined by server/CMakeLists.txt"
#endif

namespace lipmap::server {

namespace {

Answer text(std::string body) {
  Answer a;
  a.content_type = "text/plain; charset=utf-8";
  a.body = std::move(body);
  return a;
}

Answer proto_file(const std::string& name) {
  const EmbeddedFile* f = find_proto_file(name);
  if (!f) return problem_answer("not_found", "no schema named " + name);
  Answer a;
  a.content_type = name == "openapi.json" ? "application/json" : "application/schema+json";
  a.body = std::string(f->text());
  return a;
}

}  // namespace

// Liveness: the process answers (it does not look at the pool, which may be busy for minutes).
Answer get_healthz(Service&, const httplib::Request&) { return text("ok\n"); }

// Readiness: 503 once draining, so that a load balancer stops sending work.
Answer get_readyz(Service& service, const httplib::Request&) {
  if (service.draining) return problem_answer("shutting_down", "the service is shutting down");
  if (!service.jobs->ready()) {
    Answer a = problem_answer("queue_unavailable", "the shared job queue (Redis) cannot be reached");
    a.headers.emplace_back("Retry-After", "2");
    return a;
  }
  return text("ready\n");
}

Answer get_metrics(Service& service, const httplib::Request&) {
  RuntimeGauges g;
  g.workers = service.pool.workers();
  g.workers_busy = service.pool.busy();
  g.queue_depth = service.pool.queue_depth();
  g.queue_capacity = service.pool.capacity();
  g.draining = service.draining;
  g.uptime_seconds = std::chrono::duration<double>(Clock::now() - service.started_at).count();
  service.jobs->sample(g);
  Answer a;
  a.content_type = "text/plain; version=0.0.4; charset=utf-8";
  a.body = service.metrics.render(g);
  return a;
}

Answer get_version(Service&, const httplib::Request&) {
  nlohmann::ordered_json v;
  v["name"] = "lipmap";
  v["version"] = LIPMAP_VERSION;
  Answer a;
  a.body = v.dump();
  return a;
}

Answer get_openapi(Service&, const httplib::Request&) { return proto_file("openapi.json"); }

Answer get_schema(Service&, const httplib::Request& req) { return proto_file(std::string(req.matches[1]) + ".schema.json"); }

}  // namespace lipmap::server
