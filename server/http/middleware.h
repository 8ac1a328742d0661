// What runs around every handler of the HTTP service: the request id (X-Request-Id), the answer's
// rendering (a problem gets the request id), the problem answers of requests no handler takes (no route,
// method not allowed, no Content-Length, cpp-httplib's own refusals), the request log line and the request
// metrics. cpp-httplib runs a request from start to finish on one thread: the request's context is
// thread-local.
#pragma once

#include <string>

#include "server/http/problems.h"
#include "server/http/routes.h"
#include "server/http/service.h"

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace lipmap::server {

struct RequestContext {
  bool active = false;
  std::string id;
  Clock::time_point start{};
  std::string problem_code;  // the code of a problem answer, for the log line
  // Where the time went (for the log line; negative: not applicable): parsing the body on this thread,
  // waiting for a worker, the worker's work (engine and answer serialization), the engine alone.
  double parse_ms = -1, queue_ms = -1, work_ms = -1, engine_ms = -1;
  // What the answer kept alive (Answer::keep_until_sent), freed once the answer is out (log_request).
  std::shared_ptr<const void> kept;
};

// The context of the request this thread is answering.
RequestContext& this_request();

// Starts the request's context and sets its X-Request-Id (the client's, when it is sane).
void begin_request(const httplib::Request& req, httplib::Response& res);

// Writes an answer (a problem gets the request id).
void send(httplib::Response& res, Answer answer);

// Runs a route's handler and sends its answer; anything it lets escape is a bug or resource exhaustion,
// answered as such.
void run_handler(Service& service, const Operation& operation, const httplib::Request& req, httplib::Response& res);

// cpp-httplib's hooks. pre_routing runs before any body is read: it refuses bad framing (invalid or
// disagreeing Content-Length, a transfer coding other than chunked, a body over the limit), a body method
// without Content-Length (or chunked), and work the service cannot take now (draining, full queue); it
// makes Range ignored. True when it answered.
bool pre_routing(Service& service, const httplib::Request& req, httplib::Response& res);
// Every answer >= 400 passes here; those without a body are cpp-httplib's own and get their problem here.
// True when it wrote the answer.
bool error_answer(const Service& service, const httplib::Request& req, httplib::Response& res);
void exception_answer(const Service& service, const httplib::Request& req, httplib::Response& res,
                      std::exception_ptr error);
// The raw answer to a connection beyond the connection cap (server/http/connection.h): a whole HTTP/1.1
// 503 too_many_connections problem with Retry-After and Connection: close. Counted and logged.
std::string connection_refusal(Service& service);
// The request's log line and its metrics, after the answer was written. An answer the client did not take
// whole (a write failed) is logged with status 499 and the status it was sent with as sent_status.
void log_request(Service& service, const httplib::Request& req, const httplib::Response& res);

}  // namespace lipmap::server
