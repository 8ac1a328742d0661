// The one route table of the HTTP service. Each route holds its path template (also the route's label in
// the metrics and the request log), and per method the handler and what the request's body is. The same
// table registers the handlers with cpp-httplib, answers 404 and 405 (with the Allow header) for requests
// no handler takes, and names the route of every request. docs/api.md lists the endpoints;
// tests/service/test_routes.cpp checks the table against proto/openapi.json.
#pragma once

#include <regex>
#include <string>
#include <string_view>
#include <vector>

#include "server/http/problems.h"

namespace httplib {
struct Request;
class Server;
}  // namespace httplib

namespace lipmap::server {

class Service;

// GET also answers HEAD (cpp-httplib runs the GET handler and sends no body).
enum class Method { get, post, del };
const char* to_string(Method method);

using Handler = Answer (*)(Service& service, const httplib::Request& req);

struct Operation {
  Method method;
  InputKind input;  // what the body is, for the pointer of an error about it
  Handler handler;
};

struct Route {
  std::string path;  // the template: "/v1/jobs/{id}"; also the label of the route's metrics and log lines
  std::vector<Operation> operations;
  std::regex pattern;  // the template with each {parameter} a capture group
  std::string allow;   // the methods, as a 405's Allow header: "GET, HEAD, DELETE"

  bool allows(std::string_view method) const;
};

// The table, in matching order.
const std::vector<Route>& routes();

// The route whose template matches `path`, or nullptr.
const Route* route_of(const std::string& path);

// The regular expression of a path template: literal text, and [^/]+ (or the parameter's narrower
// pattern) in a capture group for each {parameter}.
std::string path_pattern(std::string_view path_template);

// The 405 answer for `method` on `route`, with its Allow header.
Answer method_not_allowed(const Route& route, const std::string& method);

// Registers every operation of the table with cpp-httplib; admin_only: only /healthz, /readyz and /metrics
// (the admin listener, --admin-port).
void register_routes(httplib::Server& http, Service& service, bool admin_only = false);

}  // namespace lipmap::server
