#include "server/http/routes.h"

#include <algorithm>

#include "server/http/handlers.h"
#include "server/http/middleware.h"
#include "server/http/service.h"

// Last: with its OpenSSL support cpp-httplib pulls in <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>

namespace lipmap::server {

namespace {

constexpr InputKind kNone = InputKind::none;

Route route(std::string path, std::vector<Operation> operations) {
  Route r;
  r.path = std::move(path);
  r.operations = std::move(operations);
  r.pattern = std::regex(path_pattern(r.path));
  for (const Operation& op : r.operations) {
    if (!r.allow.empty()) r.allow += ", ";
    r.allow += to_string(op.method);
    if (op.method == Method::get) r.allow += ", HEAD";
  }
  return r;
}

// A parameter's pattern: job ids are anything up to the next slash (a malformed one is the handler's 404
// job_not_found); schema names are what proto/ names its files.
std::string parameter_pattern(std::string_view name) {
  if (name == "schema") return "[a-z0-9-]+";
  return "[^/]+";
}

}  // namespace

const char* to_string(Method method) {
  switch (method) {
    case Method::get: return "GET";
    case Method::post: return "POST";
    case Method::del: return "DELETE";
  }
  return "GET";
}

bool Route::allows(std::string_view method) const {
  for (const Operation& op : operations) {
    if (method == to_string(op.method)) return true;
    if (op.method == Method::get && method == "HEAD") return true;
  }
  return false;
}

const std::vector<Route>& routes() {
  static const std::vector<Route> table = {
      route("/v1/parametrize", {{Method::post, InputKind::parametrize, post_parametrize}}),
      route("/v1/polygons/classify", {{Method::post, InputKind::classify, post_classify}}),
      route("/v1/jobs", {{Method::post, InputKind::parametrize, post_job}}),
      route("/v1/jobs/{id}", {{Method::get, kNone, get_job}, {Method::del, kNone, delete_job}}),
      route("/v1/jobs/{id}/result", {{Method::get, kNone, get_job_result}}),
      route("/v1/jobs/{id}/preview.svg", {{Method::get, kNone, get_job_preview}}),
      route("/healthz", {{Method::get, kNone, get_healthz}}),
      route("/readyz", {{Method::get, kNone, get_readyz}}),
      route("/metrics", {{Method::get, kNone, get_metrics}}),
      route("/version", {{Method::get, kNone, get_version}}),
      route("/v1/openapi.json", {{Method::get, kNone, get_openapi}}),
      route("/v1/{schema}.schema.json", {{Method::get, kNone, get_schema}}),
  };
  return table;
}

std::string path_pattern(std::string_view t) {
  std::string out;
  for (std::size_t i = 0; i < t.size();) {
    if (t[i] == '{') {
      const std::size_t close = t.find('}', i);
      out += "(" + parameter_pattern(t.substr(i + 1, close - i - 1)) + ")";
      i = close + 1;
      continue;
    }
    if (std::string_view(".^$|()[]*+?\\").find(t[i]) != std::string_view::npos) out += '\\';
    out += t[i++];
  }
  return out;
}

const Route* route_of(const std::string& path) {
  if (path.size() > 512) return nullptr;
  for (const Route& r : routes())
    if (std::regex_match(path, r.pattern)) return &r;
  return nullptr;
}

Answer method_not_allowed(const Route& route, const std::string& method) {
  Answer a = problem_answer("method_not_allowed",
                            method + " is not allowed on " + route.path + " (allowed: " + route.allow + ")");
  a.headers.emplace_back("Allow", route.allow);
  return a;
}

void register_routes(httplib::Server& http, Service& service, bool admin_only) {
  for (const Route& r : routes()) {
    if (admin_only && r.path != "/healthz" && r.path != "/readyz" && r.path != "/metrics") continue;
    const std::string pattern = path_pattern(r.path);
    for (const Operation& op : r.operations) {
      auto handler = [&service, &op](const httplib::Request& req, httplib::Response& res) {
        run_handler(service, op, req, res);
      };
      switch (op.method) {
        case Method::get: http.Get(pattern, handler); break;
        case Method::post: http.Post(pattern, handler); break;
        case Method::del: http.Delete(pattern, handler); break;
      }
    }
  }
}

}  // namespace lipmap::server
