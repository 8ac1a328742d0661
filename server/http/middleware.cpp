#include "server/http/middleware.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>

#include "server/codec/error_table.h"
#include "server/codec/json_codec.h"
#include "server/codec/text.h"
#include "server/http/connection.h"
#include "server/http/handlers.h"
#include "server/http/job_store.h"
#include "server/http/memory_budget.h"

// Last: with its OpenSSL support cpp-httplib pulls in <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>

namespace lipmap::server {

using nlohmann::ordered_json;

namespace {

thread_local RequestContext tl_request;

bool acceptable_request_id(const std::string& s) {
  if (s.empty() || s.size() > 128) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' || c == ':';
  });
}

}  // namespace

RequestContext& this_request() { return tl_request; }

void begin_request(const httplib::Request& req, httplib::Response& res) {
  tl_request = RequestContext{};
  tl_request.active = true;
  tl_request.start = Clock::now();
  const std::string incoming = req.get_header_value("X-Request-Id");
  tl_request.id = acceptable_request_id(incoming) ? incoming : new_job_id().substr(0, 16);
  res.set_header("X-Request-Id", tl_request.id);
}

namespace {

// Server-Timing (W3C): where this request's time went on the server, for a client or a browser's network
// panel to read beside the answer: parsing the body, waiting for a worker, the engine's own total, and the
// rest of the worker's time (mostly writing the answer). Only what the request went through is named.
std::string server_timing(const RequestContext& r) {
  std::string out;
  auto add = [&](const char* name, double ms) {
    if (ms < 0) return;
    char buf[48];
    std::snprintf(buf, sizeof buf, "%s%s;dur=%.1f", out.empty() ? "" : ", ", name, ms);
    out += buf;
  };
  add("parse", r.parse_ms);
  add("queue", r.queue_ms);
  add("engine", r.engine_ms);
  if (r.work_ms >= 0 && r.engine_ms >= 0) add("answer", std::max(0.0, r.work_ms - r.engine_ms));
  else add("work", r.work_ms);
  return out;
}

}  // namespace

void send(httplib::Response& res, Answer a) {
  res.status = a.status;
  if (const std::string timing = server_timing(tl_request); !timing.empty()) res.set_header("Server-Timing", timing);
  tl_request.kept = std::move(a.keep_until_sent);
  for (auto& [k, v] : a.headers) res.set_header(k.c_str(), v);
  if (a.problem) {
    (*a.problem)["request_id"] = tl_request.id;
    tl_request.problem_code = a.problem->value("code", "");
    res.set_content(a.problem->dump(-1, ' ', false, ordered_json::error_handler_t::replace),
                    "application/problem+json");
  } else if (a.shared_body) {
    // Copied, not streamed: cpp-httplib stops content providers as soon as the server stops, which would
    // cut off the answers that SIGTERM lets finish.
    res.set_content(*a.shared_body, a.content_type);
  } else if (!a.content_type.empty()) {
    // Moved, not copied (set_content copies): a synchronous answer is its request's alone, and at 250k
    // triangles a copy is 17.8 MB written into fresh pages on the HTTP thread before the first byte goes out.
    res.body = std::move(a.body);
    res.headers.erase("Content-Type");
    res.set_header("Content-Type", a.content_type);
  }
}

void run_handler(Service& service, const Operation& operation, const httplib::Request& req, httplib::Response& res) {
  try {
    send(res, operation.handler(service, req));
  } catch (...) {
    ordered_json p = current_exception_problem(operation.input, CancelReason::none, service.config.deadline_seconds);
    service.event(spdlog::level::err, {{"event", "handler_error"}, {"request_id", tl_request.id}, {"path", req.path},
                                       {"detail", p.value("detail", "")}});
    send(res, problem_answer(std::move(p)));
  }
}

namespace {

// cpp-httplib 0.11 keeps a connection open after an answer even when the answer says "Connection: close",
// and reads whatever follows as the next request: after an answer sent before the body was read, the
// body itself. Its only way to close is a failed write, so the body goes out through a content provider
// that writes all of it and then reports failure: the client gets the whole answer, then the close.
void close_after_answer(httplib::Response& res) {
  bool has_close = false;
  for (const auto& [k, v] : res.headers) has_close |= codec::lower(k) == "connection";
  if (!has_close) res.set_header("Connection", "close");
  if (res.body.empty()) return;
  auto body = std::make_shared<const std::string>(std::move(res.body));
  res.body.clear();
  const std::string type = res.get_header_value("Content-Type");
  res.headers.erase("Content-Type");
  res.set_content_provider(body->size(), type, [body](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
    sink.write(body->data() + offset, std::min(length, body->size() - offset));
    return false;
  });
}

// A Content-Length value: digits only, no sign, no overflow.
std::optional<std::uint64_t> parse_length(const std::string& s) {
  if (s.empty() || s.size() > 19) return std::nullopt;  // 19 digits always fit in 64 bits
  std::uint64_t n = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return std::nullopt;
    n = n * 10 + static_cast<std::uint64_t>(c - '0');
  }
  return n;
}

std::string quoted(const std::string& s) {
  return ordered_json(s.size() > 64 ? s.substr(0, 64) + "..." : s)
      .dump(-1, ' ', false, ordered_json::error_handler_t::replace);
}

// The framing headers cpp-httplib would accept and misread: every Content-Length must be one valid number
// (proxies disagree on which of two differing ones counts), and no transfer coding but chunked.
std::optional<Answer> framing_problem(const Service& service, const httplib::Request& req, std::uint64_t& length) {
  std::optional<std::uint64_t> first;
  const auto [b, e] = req.headers.equal_range("Content-Length");
  for (auto it = b; it != e; ++it) {
    const auto n = parse_length(it->second);
    if (!n) return problem_answer("bad_request", "Content-Length " + quoted(it->second) + " is not a valid length");
    if (first && *first != *n)
      return problem_answer("bad_request", "the request has Content-Length headers that disagree (" +
                                               std::to_string(*first) + " and " + std::to_string(*n) + ")");
    first = n;
  }
  length = first.value_or(0);
  if (req.has_header("Transfer-Encoding")) {
    const std::string te = codec::lower(req.get_header_value("Transfer-Encoding"));
    if (te.find("chunked") == std::string::npos)
      return problem_answer("bad_request", "Transfer-Encoding " + quoted(req.get_header_value("Transfer-Encoding")) +
                                               " is not supported; send the body with a Content-Length");
  }
  if (length > service.config.max_body_bytes) {
    Answer a = problem_answer("payload_too_large", "the body is larger than this service's limit of " +
                                                       std::to_string(service.config.max_body_bytes) + " bytes");
    (*a.problem)["limit_bytes"] = service.config.max_body_bytes;
    return a;
  }
  return std::nullopt;
}

}  // namespace

bool pre_routing(Service& service, const httplib::Request& req, httplib::Response& res) {
  begin_request(req, res);
  // The head is in: from now on the connection's deadline is the whole request's (body included).
  connection_header_received();
  // No answer is ever partial: Range is ignored. cpp-httplib parsed it into the request (a local of its
  // own, so clearing it is sound), and would cut any answer, problems included, to it.
  const_cast<httplib::Request&>(req).ranges.clear();
  // Answers go out uncompressed: cpp-httplib would compress a JSON or SVG answer for any client that accepts
  // it, on the request's thread, at fixed levels: a 17.8 MB answer (250k triangles) took 0.5 s more with
  // gzip and 40 s more with br (quality 11) for a 2.6 s job, CPU taken from the workers. Compression, where a
  // link needs it, belongs to the proxy in front (docker/nginx.conf: gzip at level 1).
  const_cast<httplib::Request&>(req).headers.erase("Accept-Encoding");
  std::uint64_t length = 0;
  if (auto a = framing_problem(service, req, length)) {
    send(res, std::move(*a));
    close_after_answer(res);
    return true;
  }
  // cpp-httplib 0.11 waits for the read timeout on a POST without Content-Length, and reads chunked
  // bodies without its size limit: answer both before any body is read.
  const bool body_method = req.method == "POST" || req.method == "PUT" || req.method == "PATCH";
  const bool chunked = req.has_header("Transfer-Encoding");  // framing_problem let only chunked through
  const Route* route = route_of(req.path);
  if (body_method && !chunked && req.has_header("Content-Length")) {
    // Work the service cannot take now is refused before its body is read, let alone parsed: a refusal
    // must stay cheap under overload.
    const Operation* op = nullptr;
    if (route)
      for (const Operation& o : route->operations)
        if (o.input != InputKind::none && req.method == to_string(o.method)) op = &o;
    if (!op) return false;
    if (auto a = service.refuse_when_draining()) {
      // Draining comes after the listener stopped, and then cpp-httplib ends the connection after this answer.
      send(res, std::move(*a));
      return true;
    }
    // A job for the shared queue does not need room in this process's pool: the cluster-wide cap decides.
    const bool needs_pool = op->handler != &post_job || service.jobs->uses_local_pool();
    if (needs_pool && service.pool.full()) {
      send(res, service.submit_refused(WorkerPool::Submit::queue_full));
      // A small body that has already arrived is dropped unread and the connection stays open: closing after
      // every refusal made each retry pay for a new connection. A larger body, or one still on its way, is
      // never waited for: the connection closes.
      constexpr std::uint64_t kDropLimit = 64 * 1024;
      if (length > 0 && !(length <= kDropLimit && connection_discard_ready(static_cast<std::size_t>(length))))
        close_after_answer(res);
      return true;
    }
    const std::size_t parse_bytes = parse_cost(length, req.get_header_value("Content-Type"));
    if (parse_bytes > request_budget(service.config.memory_budget_bytes, length)) {
      Answer a = problem_answer("payload_too_large",
                                "parsing a body of " + std::to_string(length) + " bytes would take about " +
                                    mebibytes(parse_bytes) + ", more than this service's memory budget of " +
                                    mebibytes(service.config.memory_budget_bytes) + " per request");
      (*a.problem)["limit_bytes"] = service.config.max_body_bytes;
      (*a.problem)["estimate_bytes"] = parse_bytes;
      (*a.problem)["budget_bytes"] = service.config.memory_budget_bytes;
      send(res, std::move(a));
      if (length > 0) close_after_answer(res);
      return true;
    }
    // cpp-httplib appends the body to req.body next, 4 kB at a time: room for all of it now spares the string
    // its doublings (a 12.7 MB body was copied about once more, into fresh pages). The length was checked
    // against the limits above; pages a client never sends are never touched. The padding lets the JSON
    // reader read the body in place (codec::pad_for_reading).
    const_cast<httplib::Request&>(req).body.reserve(static_cast<std::size_t>(length) + codec::kJsonReadPadding);
    return false;
  }
  if (!body_method && !chunked) return false;
  Answer a;
  if (!route) {
    a = problem_answer("not_found", "no route for " + req.method + " " + req.path.substr(0, 200));
  } else if (!route->allows(req.method)) {
    a = method_not_allowed(*route, req.method);
  } else {
    a = problem_answer("length_required", chunked
                                              ? "chunked request bodies are not accepted; send the body with a Content-Length"
                                              : "the request has no Content-Length; send the body with one");
  }
  send(res, std::move(a));
  // A chunked body that was not read cannot be followed by another request on this connection.
  if (chunked) close_after_answer(res);
  return true;
}

bool error_answer(const Service& service, const httplib::Request& req, httplib::Response& res) {
  if (!tl_request.active) begin_request(req, res);
  // A Range header cpp-httplib could not parse (its 416) would otherwise cut this problem to the ranges
  // it had parsed before the bad one; no answer is partial.
  const_cast<httplib::Request&>(req).ranges.clear();
  if (!res.has_header("X-Request-Id")) res.set_header("X-Request-Id", tl_request.id);
  if (!res.body.empty() || res.content_length_ > 0) return false;
  Answer a;
  const Route* route = route_of(req.path);
  if (connection_timed_out()) {
    // The request did not arrive whole within its deadline; cpp-httplib only saw a read that failed.
    res.status = 408;
    auto seconds = [](double s) { return nlohmann::json(s).dump(); };
    a = problem_answer("request_timeout", "the request did not arrive in time (headers within " +
                                              seconds(service.config.header_timeout_seconds) + " s, the whole request within " +
                                              seconds(service.config.request_timeout_seconds) + " s of its first byte)");
    a.headers.emplace_back("Connection", "close");
  } else if (res.status == 404 && route) {
    a = method_not_allowed(*route, req.method);
  } else if (res.status == 404) {
    std::string path = req.path.size() > 200 ? req.path.substr(0, 200) + "..." : req.path;
    a = problem_answer("not_found", "no route for " + req.method + " " + path + " (see /v1/openapi.json)");
  } else if (res.status == 413) {
    a = problem_answer("payload_too_large", "the body is larger than this service's limit of " +
                                                std::to_string(service.config.max_body_bytes) + " bytes");
    (*a.problem)["limit_bytes"] = service.config.max_body_bytes;
  } else if (res.status == 414) {
    a = problem_answer("uri_too_long", "the request target is too long");
  } else if (res.status == 400) {
    a = problem_answer("bad_request", "the request line, headers or body framing are malformed");
  } else if (res.status >= 500) {
    a = problem_answer("internal_error", "the request failed inside the HTTP layer");
  } else {
    // cpp-httplib's other refusals (416, 417): http_<status>, when the error table knows it.
    const std::string code = "http_" + std::to_string(res.status);
    if (codec::has_error_info(code))
      a = problem_answer(code, "the request was refused: " + std::string(codec::error_info(code).title));
    else
      a = problem_answer("bad_request", "the request was refused (HTTP " + std::to_string(res.status) + ")");
  }
  send(res, std::move(a));
  return true;
}

void exception_answer(const Service& service, const httplib::Request& req, httplib::Response& res,
                      std::exception_ptr error) {
  if (!tl_request.active) begin_request(req, res);
  ordered_json p;
  try {
    std::rethrow_exception(error);
  } catch (...) {
    p = current_exception_problem(InputKind::none, CancelReason::none, service.config.deadline_seconds);
  }
  send(res, problem_answer(std::move(p)));
}

void log_request(Service& service, const httplib::Request& req, const httplib::Response& res) {
  if (!tl_request.active) {  // cpp-httplib answered before routing and without an error body
    tl_request.active = true;
    tl_request.start = Clock::now();
    tl_request.id = res.get_header_value("X-Request-Id");
  }
  const double ms = ms_since(tl_request.start);
  const Route* route = route_of(req.path);
  const std::string route_name = route ? route->path : "unmatched";
  // 499 (as nginx logs it): the client closed the connection before it had the whole answer.
  const bool cut_off = connection_write_failed();
  const int status = cut_off ? 499 : res.status;
  service.metrics.observe_request(route_name, req.method, status, ms / 1000.0);
  const auto level = status >= 500 ? (status == 500 ? spdlog::level::err : spdlog::level::warn)
                                   : (cut_off ? spdlog::level::warn : spdlog::level::info);
  auto rounded = [](double v) { return std::round(v * 1000) / 1000; };
  std::string path = req.path.size() > 256 ? req.path.substr(0, 256) + "..." : req.path;
  ordered_json fields{{"event", "request"},
                      {"request_id", tl_request.id},
                      {"method", req.method},
                      {"path", path},
                      {"route", route_name},
                      {"status", status},
                      {"ms", rounded(ms)},
                      {"bytes_in", req.body.size()},
                      {"bytes_out", res.body.empty() ? res.content_length_ : res.body.size()},
                      {"remote", req.remote_addr}};
  if (cut_off) fields["sent_status"] = res.status;
  if (!tl_request.problem_code.empty()) fields["code"] = tl_request.problem_code;
  if (tl_request.parse_ms >= 0) fields["parse_ms"] = rounded(tl_request.parse_ms);
  if (tl_request.queue_ms >= 0) fields["queue_ms"] = rounded(tl_request.queue_ms);
  if (tl_request.work_ms >= 0) fields["work_ms"] = rounded(tl_request.work_ms);
  if (tl_request.engine_ms >= 0) fields["engine_ms"] = rounded(tl_request.engine_ms);
  service.event(level, std::move(fields));
  tl_request = RequestContext{};
}

std::string connection_refusal(Service& service) {
  const std::string id = new_job_id().substr(0, 16);
  ordered_json p = problem_answer("too_many_connections",
                                  "the service is serving its maximum of " + std::to_string(service.config.http_threads) +
                                      " connections; retry later")
                       .problem.value();
  p["request_id"] = id;
  const std::string body = p.dump(-1, ' ', false, ordered_json::error_handler_t::replace);
  service.metrics.count_rejected("too_many_connections");
  service.event(spdlog::level::warn, {{"event", "connection_refused"}, {"request_id", id}, {"code", "too_many_connections"}});
  return "HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/problem+json\r\nContent-Length: " +
         std::to_string(body.size()) + "\r\nRetry-After: 1\r\nConnection: close\r\nX-Request-Id: " + id + "\r\n\r\n" + body;
}

}  // namespace lipmap::server
