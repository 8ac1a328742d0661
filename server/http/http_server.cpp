#include "server/http/http_server.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <ctime>
#include <future>
#include <map>
#include <mutex>
#include <new>
#include <optional>
#include <regex>
#include <stdexcept>
#include <string>
#include <thread>
#include <unordered_set>
#include <utility>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "engine/cancel.h"
#include "engine/classify.h"
#include "engine/error.h"
#include "engine/pipeline.h"
#include "engine/validate.h"
#include "server/codec/gltf_codec.h"
#include "server/http/job_store.h"
#include "server/codec/json_codec.h"
#include "server/http/metrics.h"
#include "server/http/proto_embedded.h"
#include "server/http/worker_pool.h"

#include "server/codec/svg_preview.h"

// Last: with its OpenSSL support cpp-httplib pulls in <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>
#include <sys/socket.h>

namespace lipmap::server {

using nlohmann::json;
using nlohmann::ordered_json;
using Clock = std::chrono::steady_clock;

namespace {

// ---- small helpers ------------------------------------------------------------------------------------

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

std::string iso8601(std::chrono::system_clock::time_point t) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count();
  const std::time_t secs = static_cast<std::time_t>(ms / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  char out[48];
  std::snprintf(out, sizeof out, "%s.%03dZ", buf, static_cast<int>(ms % 1000));
  return out;
}

double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

std::string seconds_text(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", s);
  return buf;
}

// ---- routes --------------------------------------------------------------------------------------------

struct RouteInfo {
  const char* name;     // the template, used as the metrics label
  std::regex pattern;
  const char* allow;    // the Allow header of a 405
};

const std::vector<RouteInfo>& routes() {
  static const std::vector<RouteInfo> table = [] {
    std::vector<RouteInfo> t;
    auto add = [&](const char* name, const char* re, const char* allow) { t.push_back({name, std::regex(re), allow}); };
    add("/v1/parametrize", R"(/v1/parametrize)", "POST");
    add("/v1/polygons/classify", R"(/v1/polygons/classify)", "POST");
    add("/v1/jobs", R"(/v1/jobs)", "POST");
    add("/v1/jobs/{id}", R"(/v1/jobs/[^/]+)", "GET, HEAD, DELETE");
    add("/v1/jobs/{id}/result", R"(/v1/jobs/[^/]+/result)", "GET, HEAD");
    add("/v1/jobs/{id}/preview.svg", R"(/v1/jobs/[^/]+/preview\.svg)", "GET, HEAD");
    add("/healthz", R"(/healthz)", "GET, HEAD");
    add("/readyz", R"(/readyz)", "GET, HEAD");
    add("/metrics", R"(/metrics)", "GET, HEAD");
    add("/v1/openapi.json", R"(/v1/openapi\.json)", "GET, HEAD");
    add("/v1/{schema}.schema.json", R"(/v1/[a-z0-9-]+\.schema\.json)", "GET, HEAD");
    return t;
  }();
  return table;
}

const RouteInfo* route_of(const std::string& path) {
  if (path.size() > 512) return nullptr;
  for (const RouteInfo& r : routes())
    if (std::regex_match(path, r.pattern)) return &r;
  return nullptr;
}

// ---- per-request context (cpp-httplib runs a request start to finish on one thread) -----------------------

struct RequestContext {
  bool active = false;
  std::string id;
  Clock::time_point start{};
  std::string problem_code;  // the code of a problem answer, for the log line
  // Where the time went (for the log line; negative: not applicable): parsing the body on this thread,
  // waiting for a worker, the worker's work (engine and answer serialization).
  double parse_ms = -1, queue_ms = -1, work_ms = -1;
};
thread_local RequestContext tl_request;

bool acceptable_request_id(const std::string& s) {
  if (s.empty() || s.size() > 128) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' || c == ':';
  });
}

void begin_request(const httplib::Request& req, httplib::Response& res) {
  tl_request = RequestContext{};
  tl_request.active = true;
  tl_request.start = Clock::now();
  const std::string incoming = req.get_header_value("X-Request-Id");
  tl_request.id = acceptable_request_id(incoming) ? incoming : new_job_id().substr(0, 16);
  res.set_header("X-Request-Id", tl_request.id);
}

// ---- problems ------------------------------------------------------------------------------------------

bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

const char* title_for(int status, const std::string& code) {
  if (status == 400) return "Malformed request";
  if (code == "not_self_overlapping") return "Boundary not self-overlapping";
  if (code == "mesh_too_large") return "Mesh too large";
  if (code == "polygon_too_large") return "Polygon too large";
  if (status == 422) {
    if (starts_with(code, "boundary_") || starts_with(code, "rotation_ind")) return "Invalid boundary";
    if (starts_with(code, "polygon_")) return "Invalid polygon";
    return "Invalid mesh";
  }
  switch (status) {
    case 404: return "Not found";
    case 405: return "Method not allowed";
    case 406: return "Not acceptable";
    case 408: return "Request timeout";
    case 409: return "Conflict";
    case 410: return "Gone";
    case 411: return "Length required";
    case 413: return "Payload too large";
    case 414: return "URI too long";
    case 415: return "Unsupported media type";
    case 416: return "Range not satisfiable";
    case 417: return "Expectation failed";
    case 431: return "Request header fields too large";
    case 500: return "Internal error";
    case 503: return code == "queue_full" ? "Queue full" : code == "out_of_memory" ? "Out of memory" : "Shutting down";
    case 504: return "Deadline exceeded";
    default: return status < 500 ? "Bad request" : "Server error";
  }
}

ordered_json problem(int status, const std::string& code, const std::string& detail,
                     const std::optional<std::string>& pointer = std::nullopt, const std::string& element = {},
                     std::optional<long long> index = std::nullopt) {
  return codec::problem_json(status, title_for(status, code), code, detail, pointer, element, index);
}

// What a worker or a handler hands back: a body, or a problem (rendered with the request id at answer time).
struct Answer {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::shared_ptr<const std::string> shared_body;  // large bodies (results) are shared until written
  std::optional<ordered_json> problem;
  std::vector<std::pair<std::string, std::string>> headers;
  double queue_ms = -1, work_ms = -1;  // set by run_sync
};

Answer problem_answer(ordered_json p) {
  Answer a;
  a.status = p.value("status", 500);
  a.problem = std::move(p);
  return a;
}

Answer problem_answer(int status, const std::string& code, const std::string& detail,
                      const std::optional<std::string>& pointer = std::nullopt) {
  return problem_answer(problem(status, code, detail, pointer));
}

enum class WorkKind { classify, parametrize };

// A parametrize answer in glTF (Accept: model/gltf-binary or model/gltf+json, server/gltf_codec.h): the
// request's document with the refined primitive, or a fresh document for a JSON request.
Answer gltf_answer(const std::shared_ptr<const gltf::Asset>& asset, const ParametrizeResult& result, gltf::Format f) {
  Answer a;
  a.content_type = gltf::media_type(f);
  a.shared_body = std::make_shared<const std::string>(asset ? gltf::write_answer(*asset, result, f)
                                                            : gltf::write_answer(result, f));
  return a;
}

// An InputError of the codec (400) or of the engine (422), with its pointer, element and index.
ordered_json input_problem(const InputError& e, WorkKind kind) {
  if (auto* j = dynamic_cast<const codec::JsonError*>(&e)) {
    ordered_json p = problem(400, j->code(), j->what(), j->pointer());
    if (j->byte_offset()) p["byte_offset"] = *j->byte_offset();
    return p;
  }
  const auto pointer =
      kind == WorkKind::classify ? codec::classify_error_pointer(e) : codec::parametrize_error_pointer(e);
  ordered_json p = problem(422, e.code(), e.what(), pointer, e.element(), e.index());
  if (auto* n = dynamic_cast<const NotSelfOverlapping*>(&e)) {
    const Classification& c = n->classification();
    p["verdict"] = codec::verdict_name(c.verdict);
    p["turning_number"] = c.turning_number;
    if (!c.reason.empty()) p["reason"] = c.reason;
  }
  return p;
}

// The problem for the exception being handled (call inside a catch block).
ordered_json current_exception_problem(WorkKind kind, CancelReason reason, const CancelToken& token,
                                       double deadline_seconds) {
  try {
    throw;
  } catch (const InputError& e) {
    return input_problem(e, kind);
  } catch (const Cancelled& e) {
    if (reason == CancelReason::shutdown)
      return problem(503, "shutting_down", "the service is shutting down; the work was cancelled before it finished");
    if (reason == CancelReason::client) return problem(409, "cancelled", "the job was cancelled at the client's request");
    (void)token;
    return problem(504, "deadline_exceeded",
                   "the work did not finish within the deadline of " + seconds_text(deadline_seconds) +
                       " s and was cancelled (" + e.what() + ")");
  } catch (const InternalError& e) {
    return problem(500, "internal_error", std::string("internal error: ") + e.what());
  } catch (const std::bad_alloc&) {
    return problem(503, "out_of_memory", "not enough memory for this request; try again later or send a smaller mesh");
  } catch (const std::exception& e) {
    return problem(500, "internal_error", std::string("unexpected error: ") + e.what());
  } catch (...) {
    return problem(500, "internal_error", "unexpected exception");
  }
}

// ---- test hooks (only with --test-hooks) -----------------------------------------------------------------

struct TestHooks {
  long long delay_ms = 0;
  std::string fault;  // internal, bad_alloc, exception
};

void apply_hooks(const TestHooks& hooks, const CancelToken& token) {
  if (hooks.delay_ms > 0) {
    const auto until = Clock::now() + std::chrono::milliseconds(hooks.delay_ms);
    while (Clock::now() < until) {
      token.check();
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  }
  token.check();
  if (hooks.fault == "internal") throw InternalError("injected fault (X-Lipmap-Test-Fault: internal)");
  if (hooks.fault == "bad_alloc") throw std::bad_alloc();
  if (hooks.fault == "exception") throw std::runtime_error("injected fault (X-Lipmap-Test-Fault: exception)");
}

// ---- engine work ---------------------------------------------------------------------------------------

struct MapOutcome {
  std::shared_ptr<const std::string> json;
  std::shared_ptr<const ParametrizeResult> result;
};

lipmap::ParametrizeOptions to_engine_options(const codec::ParametrizeOptions& o) {
  lipmap::ParametrizeOptions out;
  out.method = o.method == codec::MapMethod::tutte ? lipmap::MapMethod::tutte : lipmap::MapMethod::harmonic;
  out.refine = o.refine;
  out.target_density = o.target_density;
  return out;
}

MapOutcome run_map(const codec::ParametrizeRequest& request, const CancelToken& token, const ProgressFn& progress,
                   Metrics& metrics) {
  auto result = std::make_shared<ParametrizeResult>(
      parametrize(request.mesh, request.boundary, to_engine_options(request.options), &token, progress));
  const StageTimings& t = result->timings;
  const std::pair<Stage, double> stages[] = {{Stage::validate, t.validate},   {Stage::classify, t.classify},
                                             {Stage::target_mesh, t.target_mesh},
                                             {Stage::intermediate_maps, t.intermediate_maps},
                                             {Stage::compose, t.compose},     {Stage::refine, t.refine},
                                             {Stage::verify, t.verify},       {Stage::quality, t.quality}};
  for (const auto& [stage, ms] : stages) metrics.observe_stage(lipmap::to_string(stage), ms / 1000.0);
  metrics.observe_inserted_vertices(static_cast<long long>(result->map.inserted.size()));
  auto text = std::make_shared<const std::string>(codec::dump(codec::parametrize_result_to_json(*result)));
  return {std::move(text), std::move(result)};
}

}  // namespace

// ---- configuration -------------------------------------------------------------------------------------

ServerConfig resolve(ServerConfig c) {
  auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (c.port < 0 || c.port > 65535) bad("port must be between 0 and 65535");
  if (c.host.empty()) bad("host must not be empty");
  if (c.workers == 0) c.workers = std::max(1u, std::thread::hardware_concurrency());
  if (c.workers > 1024) bad("workers must be at most 1024");
  if (c.queue_capacity > 1000000) bad("queue must be at most 1000000");
  if (c.http_threads == 0) c.http_threads = std::min<std::size_t>(c.workers + c.queue_capacity + 8, 1024);
  if (c.max_body_bytes == 0) bad("max body size must be at least 1 byte");
  if (c.max_vertices < 3) bad("max vertices must be at least 3");
  if (c.max_faces < 1) bad("max faces must be at least 1");
  if (c.max_polygon_vertices < 3) bad("max polygon vertices must be at least 3");
  if (!(c.deadline_seconds > 0) || !std::isfinite(c.deadline_seconds)) bad("deadline must be a positive number of seconds");
  if (!(c.result_ttl_seconds >= 0) || !std::isfinite(c.result_ttl_seconds)) bad("result ttl must be >= 0 seconds");
  if (c.max_results < 1) bad("max results must be at least 1");
  if (!(c.grace_seconds >= 0) || !std::isfinite(c.grace_seconds)) bad("grace period must be >= 0 seconds");
  if (c.keep_alive_seconds < 1) bad("keep-alive timeout must be at least 1 second");
  return c;
}

// ---- the server ----------------------------------------------------------------------------------------

struct SyncWork {
  CancelToken token;
  std::atomic<CancelReason> reason{CancelReason::none};
  void cancel(CancelReason r) {
    CancelReason expected = CancelReason::none;
    reason.compare_exchange_strong(expected, r);
    token.cancel();
  }
};

struct HttpServer::Impl {
  ServerConfig config;
  std::shared_ptr<spdlog::logger> log;
  Metrics metrics;
  WorkerPool pool;
  JobStore store;
  httplib::Server http;
  std::thread listener, housekeeper;
  std::atomic<bool> draining{false}, started{false}, stopped{false};
  std::mutex shutdown_mutex;
  std::mutex housekeeping_mutex;
  std::condition_variable housekeeping_cv;
  bool housekeeping_stop = false;
  std::mutex sync_mutex;
  std::unordered_set<std::shared_ptr<SyncWork>> sync_work;
  const Clock::time_point started_at = Clock::now();
  int port = -1;
  bool clean = true;
  socket_t listen_socket = -1;

  Impl(ServerConfig c, std::shared_ptr<spdlog::logger> logger)
      : config(resolve(std::move(c))),
        log(std::move(logger)),
        pool(config.workers, config.queue_capacity),
        store(JobStore::Limits{config.max_results,
                               std::chrono::milliseconds(static_cast<long long>(config.result_ttl_seconds * 1000)),
                               100000},
              [this](const std::string& why) { metrics.count_results_dropped(why); }) {
    setup();
  }

  // ---- logging ----
  // lifecycle: listening, signal, draining, stopped. Written at every log level but off (an operator, or a
  // test that started the service on port 0, needs the listening line even at --log-level warn).
  void event(spdlog::level::level_enum level, ordered_json fields, bool lifecycle = false) {
    if (!log) return;
    if (lifecycle ? log->level() == spdlog::level::off : !log->should_log(level)) return;
    ordered_json line;
    line["ts"] = iso8601(std::chrono::system_clock::now());
    line["level"] = spdlog::level::to_string_view(level).data();
    for (auto& [k, v] : fields.items()) line[k] = std::move(v);
    log->log(lifecycle ? spdlog::level::critical : level, "{}",
             line.dump(-1, ' ', false, ordered_json::error_handler_t::replace));
  }

  // ---- answering ----
  void send(httplib::Response& res, Answer a) {
    res.status = a.status;
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
      res.set_content(a.body, a.content_type);
    }
  }

  // Runs a handler; anything it lets escape is a bug or resource exhaustion, answered as such.
  template <class F>
  void guarded(const httplib::Request& req, httplib::Response& res, WorkKind kind, F&& f) {
    try {
      send(res, f());
    } catch (...) {
      ordered_json p = current_exception_problem(kind, CancelReason::none, CancelToken{}, config.deadline_seconds);
      event(spdlog::level::err, {{"event", "handler_error"}, {"request_id", tl_request.id}, {"path", req.path},
                                 {"detail", p.value("detail", "")}});
      send(res, problem_answer(std::move(p)));
    }
  }

  std::optional<Answer> require_json(const httplib::Request& req) {
    const std::string raw = req.get_header_value("Content-Type");
    const std::string type = lower(trim(raw.substr(0, raw.find(';'))));
    if (type == "application/json") return std::nullopt;
    std::string detail;
    if (raw.empty()) detail = "the request has no Content-Type; send the body as application/json";
    else if (type == "model/gltf-binary" || type == "model/gltf+json")
      detail = "glTF bodies (" + type + ") are not supported yet; send the mesh as application/json";
    else detail = "Content-Type " + json(raw).dump(-1, ' ', false, json::error_handler_t::replace) +
                  " is not supported; send the body as application/json";
    Answer a = problem_answer(415, "unsupported_media_type", detail);
    (*a.problem)["supported"] = {"application/json"};
    a.headers.emplace_back("Accept-Post", "application/json");
    return a;
  }

  std::optional<Answer> refuse_when_draining() {
    if (!draining) return std::nullopt;
    Answer a = problem_answer(503, "shutting_down", "the service is shutting down and takes no new work");
    a.headers.emplace_back("Retry-After", "5");
    a.headers.emplace_back("Connection", "close");
    return a;
  }

  Answer submit_refused(WorkerPool::Submit why) {
    if (why == WorkerPool::Submit::queue_full) {
      metrics.count_rejected("queue_full");
      const int retry = pool.retry_after_seconds();
      Answer a = problem_answer(503, "queue_full",
                                "all " + std::to_string(pool.workers()) + " workers are busy and " +
                                    std::to_string(pool.capacity()) + " tasks are waiting; retry after " +
                                    std::to_string(retry) + " s");
      (*a.problem)["retry_after_seconds"] = retry;
      a.headers.emplace_back("Retry-After", std::to_string(retry));
      return a;
    }
    metrics.count_rejected("shutting_down");
    Answer a = problem_answer(503, "shutting_down", "the service is shutting down and takes no new work");
    a.headers.emplace_back("Retry-After", "5");
    return a;
  }

  TestHooks hooks_of(const httplib::Request& req) {
    TestHooks h;
    if (!config.test_hooks) return h;
    const std::string delay = req.get_header_value("X-Lipmap-Test-Delay-Ms");
    if (!delay.empty()) {
      try {
        h.delay_ms = std::clamp(std::stoll(delay), 0LL, 600000LL);
      } catch (...) {
        h.delay_ms = 0;
      }
    }
    h.fault = req.get_header_value("X-Lipmap-Test-Fault");
    return h;
  }

  Clock::time_point deadline_from_arrival() const {
    const auto start = tl_request.active ? tl_request.start : Clock::now();
    return start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config.deadline_seconds));
  }

  // Runs `work` on the pool and waits for its answer (synchronous endpoints).
  template <class Work>
  Answer run_sync(WorkKind kind, Work work) {
    auto sync = std::make_shared<SyncWork>();
    const auto deadline = deadline_from_arrival();
    sync->token.set_deadline(deadline);
    auto promise = std::make_shared<std::promise<Answer>>();
    std::future<Answer> future = promise->get_future();
    const double deadline_seconds = config.deadline_seconds;
    const auto enqueued = Clock::now();
    auto task = [sync, promise, work = std::move(work), kind, deadline_seconds, enqueued]() mutable {
      const auto started = Clock::now();
      Answer a;
      try {
        sync->token.check();  // the deadline may have passed while it waited in the queue
        a = work(sync->token);
      } catch (...) {
        a = problem_answer(current_exception_problem(kind, sync->reason.load(), sync->token, deadline_seconds));
      }
      a.queue_ms = std::chrono::duration<double, std::milli>(started - enqueued).count();
      a.work_ms = ms_since(started);
      promise->set_value(std::move(a));
    };
    {
      std::lock_guard<std::mutex> lock(sync_mutex);
      sync_work.insert(sync);
    }
    const WorkerPool::Submit submitted = pool.submit(std::move(task));
    if (submitted != WorkerPool::Submit::accepted) {
      std::lock_guard<std::mutex> lock(sync_mutex);
      sync_work.erase(sync);
      return submit_refused(submitted);
    }
    // The engine checks its token between stages and inside long loops; the slack covers a stage that is
    // slow to notice. After it the client gets its 504 and the work, still cancelled, ends on its own.
    const auto hard_limit = deadline + std::chrono::seconds(5);
    Answer answer;
    if (future.wait_until(hard_limit) == std::future_status::ready) {
      answer = future.get();
      tl_request.queue_ms = answer.queue_ms;
      tl_request.work_ms = answer.work_ms;
    } else {
      sync->cancel(CancelReason::none);
      answer = problem_answer(504, "deadline_exceeded",
                              "the work did not finish within the deadline of " + seconds_text(config.deadline_seconds) +
                                  " s and was cancelled");
    }
    std::lock_guard<std::mutex> lock(sync_mutex);
    sync_work.erase(sync);
    return answer;
  }

  std::optional<Answer> check_mesh_limits(const codec::ParametrizeRequest& r) {
    if (r.mesh.vertices.size() > config.max_vertices)
      return problem_answer(422, "mesh_too_large",
                            "the mesh has " + std::to_string(r.mesh.vertices.size()) + " vertices; this service takes at most " +
                                std::to_string(config.max_vertices),
                            std::string("/mesh/vertices"));
    if (r.mesh.faces.size() > config.max_faces)
      return problem_answer(422, "mesh_too_large",
                            "the mesh has " + std::to_string(r.mesh.faces.size()) + " faces; this service takes at most " +
                                std::to_string(config.max_faces),
                            std::string("/mesh/faces"));
    if (r.boundary.positions.size() > config.max_polygon_vertices)
      return problem_answer(422, "polygon_too_large",
                            "the boundary has " + std::to_string(r.boundary.positions.size()) +
                                " positions; this service takes at most " + std::to_string(config.max_polygon_vertices),
                            std::string("/boundary/positions"));
    return std::nullopt;
  }

  // ---- handlers ----
  Answer handle_classify(const httplib::Request& req) {
    if (auto a = refuse_when_draining()) return *a;
    if (auto a = require_json(req)) return *a;
    BoundaryPolygon polygon;
    const auto parse_start = Clock::now();
    try {
      polygon = codec::classify_request_from_json(codec::parse_json(req.body));
    } catch (const InputError& e) {
      return problem_answer(input_problem(e, WorkKind::classify));
    }
    tl_request.parse_ms = ms_since(parse_start);
    if (polygon.vertices.size() > config.max_polygon_vertices)
      return problem_answer(422, "polygon_too_large",
                            "the polygon has " + std::to_string(polygon.vertices.size()) +
                                " vertices; this service takes at most " + std::to_string(config.max_polygon_vertices),
                            std::string("/polygon"));
    const TestHooks hooks = hooks_of(req);
    return run_sync(WorkKind::classify, [this, polygon = std::move(polygon), hooks](const CancelToken& token) {
      apply_hooks(hooks, token);
      const auto t0 = Clock::now();
      const Classification c = classify(polygon, &token);
      metrics.observe_stage("classify", ms_since(t0) / 1000.0);
      Answer a;
      a.body = codec::dump(codec::classification_to_json(c));
      return a;
    });
  }

  // Parses a parametrize body on the connection thread; an Answer when it is refused. glTF requests
  // (server/gltf_codec.h: model/gltf-binary, model/gltf+json, multipart/form-data, or a JSON envelope with
  // gltf_base64) also hand back their document in *gltf_asset.
  std::variant<std::shared_ptr<const codec::ParametrizeRequest>, Answer> parse_parametrize(
      const httplib::Request& req, std::shared_ptr<const gltf::Asset>* gltf_asset = nullptr) {
    if (auto a = refuse_when_draining()) return *a;
    const std::string raw_type = req.get_header_value("Content-Type");
    const std::string media = lower(trim(raw_type.substr(0, raw_type.find(';'))));
    const std::optional<gltf::Format> model_format = gltf::format_from_media_type(media);
    if (model_format || media == "multipart/form-data") return parse_gltf_parametrize(req, nullptr, model_format, gltf_asset);
    if (auto a = require_json(req)) {
      (*a->problem)["supported"] = {"application/json", "model/gltf-binary", "model/gltf+json", "multipart/form-data"};
      for (auto& [k, v] : a->headers)
        if (k == "Accept-Post") v = "application/json, model/gltf-binary, model/gltf+json, multipart/form-data";
      return *a;
    }
    auto request = std::make_shared<codec::ParametrizeRequest>();
    try {
      const nlohmann::json body = codec::parse_json(req.body);
      if (gltf::is_envelope(body)) return parse_gltf_parametrize(req, &body, std::nullopt, gltf_asset);
      *request = codec::parametrize_request_from_json(body);
    } catch (const InputError& e) {
      return problem_answer(input_problem(e, WorkKind::parametrize));
    }
    if (auto a = check_mesh_limits(*request)) return *a;
    return std::shared_ptr<const codec::ParametrizeRequest>(std::move(request));
  }

  // A glTF parametrize request: query parameters mesh, primitive, weld, boundary (texcoord:N).
  std::variant<std::shared_ptr<const codec::ParametrizeRequest>, Answer> parse_gltf_parametrize(
      const httplib::Request& req, const nlohmann::json* envelope, std::optional<gltf::Format> model_format,
      std::shared_ptr<const gltf::Asset>* gltf_asset) {
    gltf::Params params;
    auto param = [&](const char* name) -> std::optional<std::string> {
      if (!req.has_param(name)) return std::nullopt;
      return req.get_param_value(name);
    };
    params.mesh = param("mesh");
    params.primitive = param("primitive");
    params.weld = param("weld");
    params.boundary = param("boundary");
    std::optional<gltf::Request> r;
    try {
      if (envelope) {
        r = gltf::request_from_envelope(*envelope, params);
      } else if (model_format) {
        r = gltf::request_from_model(req.body, *model_format, params);
      } else {
        std::map<std::string, gltf::Part> parts;
        for (const auto& [name, file] : req.files) {
          if (parts.count(name)) throw gltf::GltfError("gltf_invalid_request", "multipart part \"" + name + "\" is given twice");
          parts[name] = gltf::Part{file.content, file.content_type};
        }
        r = gltf::request_from_parts(parts, params);
      }
    } catch (const gltf::GltfError& e) {
      return problem_answer(gltf::problem_json(e));
    } catch (const codec::JsonError& e) {
      return problem_answer(input_problem(e, WorkKind::parametrize));
    } catch (const InputError& e) {  // the validate stage's code, about the glTF primitive
      return problem_answer(problem(422, e.code(), e.what(), std::nullopt, e.element(), e.index()));
    }
    auto request = std::make_shared<const codec::ParametrizeRequest>(std::move(r->request));
    if (auto a = check_mesh_limits(*request)) return *a;
    if (gltf_asset) *gltf_asset = std::make_shared<const gltf::Asset>(std::move(r->asset));
    return request;
  }

  Answer handle_parametrize(const httplib::Request& req) {
    std::shared_ptr<const gltf::Asset> asset;
    const auto parse_start = Clock::now();
    auto parsed = parse_parametrize(req, &asset);
    tl_request.parse_ms = ms_since(parse_start);
    if (auto* a = std::get_if<Answer>(&parsed)) return std::move(*a);
    auto request = std::get<std::shared_ptr<const codec::ParametrizeRequest>>(std::move(parsed));
    const TestHooks hooks = hooks_of(req);
    const std::optional<gltf::Format> answer_format = gltf::accepted_format(req.get_header_value("Accept"));
    return run_sync(WorkKind::parametrize, [this, request, hooks, asset, answer_format](const CancelToken& token) {
      apply_hooks(hooks, token);
      MapOutcome m = run_map(*request, token, {}, metrics);
      if (answer_format && m.result) return gltf_answer(asset, *m.result, *answer_format);
      Answer a;
      a.shared_body = std::move(m.json);
      return a;
    });
  }

  ordered_json job_json(const JobSnapshot& s) {
    ordered_json out;
    out["id"] = s.id;
    out["state"] = to_string(s.state);
    out["created_at"] = iso8601(s.created_at);
    if (s.started) out["started_at"] = iso8601(s.started_at);
    if (s.finished) out["finished_at"] = iso8601(s.finished_at);
    out["cancel_requested"] = s.cancel_requested;
    ordered_json progress;
    progress["fraction"] = s.fraction;
    if (!s.current_stage.empty()) progress["stage"] = s.current_stage;
    progress["stages"] = ordered_json::array();
    for (const StageProgress& p : s.stages)
      progress["stages"].push_back({{"stage", p.stage}, {"fraction", p.fraction}, {"done", p.done}, {"ms", p.ms}});
    out["progress"] = std::move(progress);
    if (s.problem) out["error"] = *s.problem;
    const std::string self = "/v1/jobs/" + s.id;
    out["links"] = {{"self", self}, {"result", self + "/result"}, {"preview", self + "/preview.svg"}};
    return out;
  }

  Answer job_answer(int status, const Job& job) {
    Answer a;
    a.status = status;
    a.body = job_json(job.snapshot()).dump();
    return a;
  }

  void run_job(const std::shared_ptr<Job>& job, const codec::ParametrizeRequest& request, const TestHooks& hooks) {
    if (!job->mark_running()) return;  // cancelled while it waited: already final
    const ProgressFn progress = [job](Stage stage, double fraction) { job->report(stage, fraction); };
    try {
      job->token().check();
      apply_hooks(hooks, job->token());
      MapOutcome m = run_map(request, job->token(), progress, metrics);
      job->succeed(std::move(m.json), std::move(m.result));
    } catch (...) {
      const CancelReason reason = job->cancel_reason();
      ordered_json p = current_exception_problem(WorkKind::parametrize, reason, job->token(), config.deadline_seconds);
      job->fail(reason == CancelReason::none ? JobState::failed : JobState::cancelled, std::move(p));
    }
    finish_job(job);
  }

  void finish_job(const std::shared_ptr<Job>& job) {
    const JobSnapshot s = job->snapshot();
    metrics.count_job_finished(to_string(s.state));
    event(spdlog::level::info, {{"event", "job_finished"},
                                {"job_id", s.id},
                                {"state", to_string(s.state)},
                                {"code", s.problem ? s.problem->value("code", "") : ""},
                                {"result_bytes", s.result_bytes}});
    store.finished(job);
  }

  Answer handle_submit_job(const httplib::Request& req) {
    std::shared_ptr<const gltf::Asset> asset;
    auto parsed = parse_parametrize(req, &asset);
    if (auto* a = std::get_if<Answer>(&parsed)) return std::move(*a);
    auto request = std::get<std::shared_ptr<const codec::ParametrizeRequest>>(std::move(parsed));
    const TestHooks hooks = hooks_of(req);
    std::shared_ptr<Job> job = store.create();
    if (asset) job->set_attachment(asset);  // GET .../result with Accept: model/gltf-* answers in that document
    job->token().set_deadline(deadline_from_arrival());
    std::uint64_t ticket = 0;
    const WorkerPool::Submit submitted =
        pool.submit([this, job, request, hooks] { run_job(job, *request, hooks); }, &ticket);
    job->set_ticket(ticket);
    if (submitted != WorkerPool::Submit::accepted) {
      store.discard(job->id());
      return submit_refused(submitted);
    }
    event(spdlog::level::info, {{"event", "job_queued"}, {"job_id", job->id()}, {"request_id", tl_request.id},
                                {"vertices", request->mesh.vertices.size()}, {"faces", request->mesh.faces.size()}});
    Answer a = job_answer(202, *job);
    a.headers.emplace_back("Location", "/v1/jobs/" + job->id());
    return a;
  }

  // The job named by the path, or the 404/410 answer.
  std::variant<std::shared_ptr<Job>, Answer> lookup_job(const std::string& id) {
    if (!looks_like_job_id(id)) return problem_answer(404, "job_not_found", "no job has the id " + json(id).dump(-1, ' ', false, json::error_handler_t::replace));
    JobStore::Found f = store.find(id);
    if (f.lookup == JobStore::Lookup::found) return f.job;
    if (f.lookup == JobStore::Lookup::gone) {
      std::string detail;
      if (f.gone_reason == "deleted") detail = "job " + id + " was deleted";
      else if (f.gone_reason == "expired")
        detail = "job " + id + " finished more than " + seconds_text(config.result_ttl_seconds) +
                 " s ago and its result was dropped";
      else
        detail = "job " + id + "'s result was dropped: the service keeps the last " +
                 std::to_string(config.max_results) + " finished jobs";
      Answer a = problem_answer(410, "job_gone", detail);
      (*a.problem)["reason"] = f.gone_reason;
      return a;
    }
    return problem_answer(404, "job_not_found", "no job has the id " + id);
  }

  Answer handle_get_job(const std::string& id) {
    auto found = lookup_job(id);
    if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
    return job_answer(200, *std::get<std::shared_ptr<Job>>(found));
  }

  Answer handle_delete_job(const std::string& id) {
    auto found = lookup_job(id);
    if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
    std::shared_ptr<Job> job = std::get<std::shared_ptr<Job>>(found);
    const JobState state = job->state();
    if (is_final(state)) {
      store.remove(id);
      Answer a;
      a.status = 204;
      a.content_type.clear();
      return a;
    }
    job->request_cancel(CancelReason::client);
    if (state == JobState::queued && job->state() == JobState::queued) {
      // Not started: it is over now, and its place in the queue is free (if a worker took it meanwhile,
      // it finds the job final and skips it).
      pool.remove(job->ticket());
      job->fail(JobState::cancelled,
                problem(409, "cancelled", "the job was cancelled at the client's request before it started"));
      if (job->state() == JobState::cancelled) finish_job(job);
      return job_answer(200, *job);
    }
    event(spdlog::level::info, {{"event", "job_cancel_requested"}, {"job_id", id}});
    return job_answer(202, *job);
  }

  Answer not_finished(const Job& job, const JobSnapshot& s) {
    (void)job;
    if (s.state == JobState::failed) {
      Answer a = problem_answer(409, "job_failed", "job " + s.id + " failed: " + (s.problem ? s.problem->value("detail", "") : ""));
      (*a.problem)["job_state"] = to_string(s.state);
      if (s.problem) (*a.problem)["cause"] = *s.problem;
      return a;
    }
    if (s.state == JobState::cancelled) {
      Answer a = problem_answer(409, "job_cancelled", "job " + s.id + " was cancelled and has no result");
      (*a.problem)["job_state"] = to_string(s.state);
      if (s.problem) (*a.problem)["cause"] = *s.problem;
      return a;
    }
    Answer a = problem_answer(409, "job_not_finished",
                              "job " + s.id + " is " + to_string(s.state) + "; poll /v1/jobs/" + s.id + " until it has succeeded");
    (*a.problem)["job_state"] = to_string(s.state);
    a.headers.emplace_back("Retry-After", "1");
    return a;
  }

  Answer handle_job_result(const std::string& id, const std::string& accept = {}) {
    auto found = lookup_job(id);
    if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
    std::shared_ptr<Job> job = std::get<std::shared_ptr<Job>>(found);
    const JobSnapshot s = job->snapshot();
    if (s.state != JobState::succeeded) return not_finished(*job, s);
    if (const std::optional<gltf::Format> f = gltf::accepted_format(accept)) {
      std::shared_ptr<const ParametrizeResult> result = job->result();
      auto asset = std::static_pointer_cast<const gltf::Asset>(job->attachment());
      if (result)  // writing the glTF is engine-side work: on the pool
        return run_sync(WorkKind::parametrize, [result, asset, f](const CancelToken& token) {
          token.check();
          return gltf_answer(asset, *result, *f);
        });
    }
    Answer a;
    a.shared_body = job->result_json();
    return a;
  }

  Answer handle_job_preview(const std::string& id) {
    auto found = lookup_job(id);
    if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
    std::shared_ptr<Job> job = std::get<std::shared_ptr<Job>>(found);
    const JobSnapshot s = job->snapshot();
    if (s.state != JobState::succeeded) return not_finished(*job, s);
    if (std::shared_ptr<const std::string> cached = job->preview()) {
      Answer a;
      a.content_type = "image/svg+xml";
      a.shared_body = std::move(cached);
      return a;
    }
    std::shared_ptr<const ParametrizeResult> result = job->result();
    if (result) {
      // Rendering is engine-side work: it runs on the pool like everything else, once per job.
      return run_sync(WorkKind::parametrize, [job, result](const CancelToken& token) {
        token.check();
        auto svg = std::make_shared<const std::string>(
            preview::render_svg(preview::picture_of(*result, "lipmap job " + job->id())));
        job->set_preview(svg);
        Answer a;
        a.content_type = "image/svg+xml";
        a.shared_body = std::move(svg);
        return a;
      });
    }
    return problem_answer(404, "preview_unavailable",
                          "this build of lipmap has no SVG preview renderer; the job's result is at /v1/jobs/" + id +
                              "/result");
  }

  Answer handle_readyz() {
    if (draining) {
      Answer a = problem_answer(503, "shutting_down", "the service is shutting down");
      return a;
    }
    Answer a;
    a.content_type = "text/plain; charset=utf-8";
    a.body = "ready\n";
    return a;
  }

  Answer handle_metrics() {
    store.sweep();
    RuntimeGauges g;
    g.workers = pool.workers();
    g.workers_busy = pool.busy();
    g.queue_depth = pool.queue_depth();
    g.queue_capacity = pool.capacity();
    g.jobs_by_state = store.counts_by_state();
    g.draining = draining;
    g.uptime_seconds = std::chrono::duration<double>(Clock::now() - started_at).count();
    Answer a;
    a.content_type = "text/plain; version=0.0.4; charset=utf-8";
    a.body = metrics.render(g);
    return a;
  }

  Answer handle_proto(const std::string& name) {
    const EmbeddedFile* f = find_proto_file(name);
    if (!f) return problem_answer(404, "not_found", "no schema named " + name);
    Answer a;
    a.content_type = name == "openapi.json" ? "application/json" : "application/schema+json";
    a.body = std::string(f->text());
    return a;
  }

  // ---- httplib wiring ----
  void setup() {
    const std::size_t threads = config.http_threads;
    http.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
    http.set_payload_max_length(config.max_body_bytes);
    http.set_keep_alive_timeout(config.keep_alive_seconds);
    http.set_keep_alive_max_count(1000);
    http.set_read_timeout(10, 0);  // per read: a slow upload is fine, a stalled one ends
    http.set_write_timeout(30, 0);
    http.set_tcp_nodelay(true);
    // cpp-httplib's default also sets SO_REUSEPORT, which lets a second service bind the same port and
    // silently take half of its connections: plain SO_REUSEADDR only. The socket that binds is the last
    // one this sees; bind() then widens its listen backlog (cpp-httplib 0.11 fixes it at 5).
    http.set_socket_options([this](socket_t sock) {
      int yes = 1;
      ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, reinterpret_cast<const char*>(&yes), sizeof yes);
      listen_socket = sock;
    });

    http.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
      begin_request(req, res);
      // cpp-httplib 0.11 waits for the read timeout on a POST without Content-Length, and reads chunked
      // bodies without its size limit: answer both before any body is read.
      const bool body_method = req.method == "POST" || req.method == "PUT" || req.method == "PATCH";
      const bool chunked = lower(req.get_header_value("Transfer-Encoding")).find("chunked") != std::string::npos;
      if (!body_method || (!chunked && req.has_header("Content-Length"))) return httplib::Server::HandlerResponse::Unhandled;
      const RouteInfo* route = route_of(req.path);
      Answer a;
      if (!route) {
        a = problem_answer(404, "not_found", "no route for " + req.method + " " + req.path.substr(0, 200));
      } else if (std::string(route->allow).find(req.method) == std::string::npos) {
        a = problem_answer(405, "method_not_allowed",
                           req.method + " is not allowed on " + route->name + " (allowed: " + route->allow + ")");
        a.headers.emplace_back("Allow", route->allow);
      } else {
        a = problem_answer(411, "length_required",
                           chunked ? "chunked request bodies are not accepted; send the body with a Content-Length"
                                   : "the request has no Content-Length; send the body with one");
      }
      // A chunked body that was not read cannot be followed by another request on this connection.
      if (chunked) a.headers.emplace_back("Connection", "close");
      send(res, std::move(a));
      return httplib::Server::HandlerResponse::Handled;
    });

    // Every answer >= 400 passes here; those without a body are cpp-httplib's own (no route, body too
    // large, malformed request line ...) and get their problem body here.
    http.set_error_handler(httplib::Server::HandlerWithResponse([this](const httplib::Request& req,
                                                                       httplib::Response& res) {
      if (!tl_request.active) begin_request(req, res);
      if (!res.has_header("X-Request-Id")) res.set_header("X-Request-Id", tl_request.id);
      if (!res.body.empty() || res.content_length_ > 0) return httplib::Server::HandlerResponse::Unhandled;
      Answer a;
      const RouteInfo* route = route_of(req.path);
      if (res.status == 404 && route) {
        a = problem_answer(405, "method_not_allowed",
                           req.method + " is not allowed on " + route->name + " (allowed: " + route->allow + ")");
        a.headers.emplace_back("Allow", route->allow);
      } else if (res.status == 404) {
        std::string path = req.path.size() > 200 ? req.path.substr(0, 200) + "..." : req.path;
        a = problem_answer(404, "not_found", "no route for " + req.method + " " + path + " (see /v1/openapi.json)");
      } else if (res.status == 413) {
        a = problem_answer(413, "payload_too_large",
                           "the body is larger than this service's limit of " + std::to_string(config.max_body_bytes) +
                               " bytes");
        (*a.problem)["limit_bytes"] = config.max_body_bytes;
      } else if (res.status == 414) {
        a = problem_answer(414, "uri_too_long", "the request target is too long");
      } else if (res.status == 400) {
        a = problem_answer(400, "bad_request", "the request line, headers or body framing are malformed");
      } else if (res.status >= 500) {
        a = problem_answer(500, "internal_error", "the request failed inside the HTTP layer");
      } else {
        a = problem_answer(res.status, "http_" + std::to_string(res.status),
                           std::string("the request was refused: ") + title_for(res.status, ""));
      }
      send(res, std::move(a));
      return httplib::Server::HandlerResponse::Handled;
    }));

    http.set_exception_handler([this](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
      if (!tl_request.active) begin_request(req, res);
      ordered_json p;
      try {
        std::rethrow_exception(ep);
      } catch (...) {
        p = current_exception_problem(WorkKind::parametrize, CancelReason::none, CancelToken{}, config.deadline_seconds);
      }
      send(res, problem_answer(std::move(p)));
    });

    http.set_logger([this](const httplib::Request& req, const httplib::Response& res) {
      if (!tl_request.active) {  // cpp-httplib answered before routing and without an error body
        tl_request.active = true;
        tl_request.start = Clock::now();
        tl_request.id = res.get_header_value("X-Request-Id");
      }
      const double ms = ms_since(tl_request.start);
      const RouteInfo* route = route_of(req.path);
      const std::string route_name = route ? route->name : "unmatched";
      metrics.observe_request(route_name, req.method, res.status, ms / 1000.0);
      const auto level = res.status >= 500 ? (res.status == 500 ? spdlog::level::err : spdlog::level::warn)
                                           : spdlog::level::info;
      std::string path = req.path.size() > 256 ? req.path.substr(0, 256) + "..." : req.path;
      ordered_json fields{{"event", "request"},
                          {"request_id", tl_request.id},
                          {"method", req.method},
                          {"path", path},
                          {"route", route_name},
                          {"status", res.status},
                          {"ms", std::round(ms * 1000) / 1000},
                          {"bytes_in", req.body.size()},
                          {"bytes_out", res.body.empty() ? res.content_length_ : res.body.size()},
                          {"remote", req.remote_addr}};
      if (!tl_request.problem_code.empty()) fields["code"] = tl_request.problem_code;
      auto rounded = [](double v) { return std::round(v * 1000) / 1000; };
      if (tl_request.parse_ms >= 0) fields["parse_ms"] = rounded(tl_request.parse_ms);
      if (tl_request.queue_ms >= 0) fields["queue_ms"] = rounded(tl_request.queue_ms);
      if (tl_request.work_ms >= 0) fields["work_ms"] = rounded(tl_request.work_ms);
      event(level, std::move(fields));
      tl_request = RequestContext{};
    });

    using Req = httplib::Request;
    using Res = httplib::Response;
    http.Post("/v1/parametrize", [this](const Req& req, Res& res) {
      guarded(req, res, WorkKind::parametrize, [&] { return handle_parametrize(req); });
    });
    http.Post("/v1/polygons/classify", [this](const Req& req, Res& res) {
      guarded(req, res, WorkKind::classify, [&] { return handle_classify(req); });
    });
    http.Post("/v1/jobs", [this](const Req& req, Res& res) {
      guarded(req, res, WorkKind::parametrize, [&] { return handle_submit_job(req); });
    });
    http.Get(R"(/v1/jobs/([^/]+))", [this](const Req& req, Res& res) {
      guarded(req, res, WorkKind::parametrize, [&] { return handle_get_job(req.matches[1]); });
    });
    http.Delete(R"(/v1/jobs/([^/]+))", [this](const Req& req, Res& res) {
      guarded(req, res, WorkKind::parametrize, [&] { return handle_delete_job(req.matches[1]); });
    });
    http.Get(R"(/v1/jobs/([^/]+)/result)", [this](const Req& req, Res& res) {
      guarded(req, res, WorkKind::parametrize, [&] { return handle_job_result(req.matches[1], req.get_header_value("Accept")); });
    });
    http.Get(R"(/v1/jobs/([^/]+)/preview\.svg)", [this](const Req& req, Res& res) {
      guarded(req, res, WorkKind::parametrize, [&] { return handle_job_preview(req.matches[1]); });
    });
    http.Get("/healthz", [this](const Req& req, Res& res) {
      guarded(req, res, WorkKind::parametrize, [&] {
        Answer a;
        a.content_type = "text/plain; charset=utf-8";
        a.body = "ok\n";
        return a;
      });
    });
    http.Get("/readyz", [this](const Req& req, Res& res) {
      guarded(req, res, WorkKind::parametrize, [&] { return handle_readyz(); });
    });
    http.Get("/metrics", [this](const Req& req, Res& res) {
      guarded(req, res, WorkKind::parametrize, [&] { return handle_metrics(); });
    });
    http.Get("/v1/openapi.json", [this](const Req& req, Res& res) {
      guarded(req, res, WorkKind::parametrize, [&] { return handle_proto("openapi.json"); });
    });
    http.Get(R"(/v1/([a-z0-9-]+\.schema\.json))", [this](const Req& req, Res& res) {
      guarded(req, res, WorkKind::parametrize, [&] { return handle_proto(req.matches[1]); });
    });
  }

  void housekeeping() {
    std::unique_lock<std::mutex> lock(housekeeping_mutex);
    while (!housekeeping_stop) {
      housekeeping_cv.wait_for(lock, std::chrono::seconds(1));
      lock.unlock();
      store.sweep();
      lock.lock();
    }
  }

  void cancel_everything(CancelReason reason) {
    for (const std::shared_ptr<Job>& job : store.unfinished()) {
      const JobState before = job->state();
      job->request_cancel(reason);
      if (before == JobState::queued && job->state() == JobState::queued) {
        pool.remove(job->ticket());
        job->fail(JobState::cancelled, problem(503, "shutting_down", "the service shut down before the job started"));
        if (job->state() == JobState::cancelled) finish_job(job);
      }
    }
    std::lock_guard<std::mutex> lock(sync_mutex);
    for (const auto& w : sync_work) w->cancel(reason);
  }
};

HttpServer::HttpServer(ServerConfig config, std::shared_ptr<spdlog::logger> logger)
    : impl_(std::make_unique<Impl>(std::move(config), std::move(logger))) {}

HttpServer::~HttpServer() {
  try {
    if (!shutdown()) impl_.release();  // threads still run inside it: leak it rather than block or crash
  } catch (...) {
  }
}

int HttpServer::bind() {
  Impl& s = *impl_;
  int port = -1;
  if (s.config.port == 0) {
    port = s.http.bind_to_any_port(s.config.host);
  } else if (s.http.bind_to_port(s.config.host, s.config.port)) {
    port = s.config.port;
  }
  if (port <= 0)
    throw std::runtime_error("cannot listen on " + s.config.host + ":" + std::to_string(s.config.port) +
                             " (address in use, not a local address, or not permitted)");
  s.port = port;
  if (s.listen_socket >= 0) ::listen(s.listen_socket, SOMAXCONN);  // after bind: only the backlog changes
  return port;
}

void HttpServer::start() {
  Impl& s = *impl_;
  if (s.port < 0) bind();
  s.started = true;
  s.listener = std::thread([&s] { s.http.listen_after_bind(); });
  s.housekeeper = std::thread([&s] { s.housekeeping(); });
  s.event(spdlog::level::info, {{"event", "listening"},
                                {"host", s.config.host},
                                {"port", s.port},
                                {"url", "http://" + s.config.host + ":" + std::to_string(s.port)},
                                {"workers", s.config.workers},
                                {"queue", s.config.queue_capacity},
                                {"http_threads", s.config.http_threads},
                                {"max_body_bytes", s.config.max_body_bytes},
                                {"max_vertices", s.config.max_vertices},
                                {"max_faces", s.config.max_faces},
                                {"max_polygon_vertices", s.config.max_polygon_vertices},
                                {"deadline_seconds", s.config.deadline_seconds},
                                {"result_ttl_seconds", s.config.result_ttl_seconds},
                                {"max_results", s.config.max_results},
                                {"grace_seconds", s.config.grace_seconds},
                                {"remapping_engine", true},
                                {"test_hooks", s.config.test_hooks}}, true);
  if (s.config.test_hooks)
    s.event(spdlog::level::warn, {{"event", "test_hooks_enabled"},
                                  {"detail", "X-Lipmap-Test-* headers are honoured: never run like this in production"}});
}

bool HttpServer::draining() const { return impl_->draining; }

void HttpServer::log_signal(const std::string& name, bool second) {
  impl_->event(spdlog::level::info,
               {{"event", "signal"}, {"signal", name}, {"action", second ? "cancel_all" : "drain"}}, true);
}

void HttpServer::cancel_all() { impl_->cancel_everything(CancelReason::shutdown); }

bool HttpServer::shutdown() {
  Impl& s = *impl_;
  std::lock_guard<std::mutex> lock(s.shutdown_mutex);
  if (s.stopped) return s.clean;
  s.stopped = true;
  if (!s.started) {  // never served (bind failed): nothing to drain
    s.pool.join();
    return true;
  }
  const auto t0 = Clock::now();
  s.draining = true;
  s.event(spdlog::level::info, {{"event", "draining"},
                                {"grace_seconds", s.config.grace_seconds},
                                {"queued", s.pool.queue_depth()},
                                {"running", s.pool.busy()}}, true);
  // 1. No new connections. Requests already being read still run (and are refused new work with 503).
  if (s.started) s.http.stop();
  // 2. Asynchronous jobs: once the listener is closed nobody can fetch their results, so they end now.
  for (const std::shared_ptr<Job>& job : s.store.unfinished()) {
    const JobState before = job->state();
    job->request_cancel(CancelReason::shutdown);
    if (before == JobState::queued && job->state() == JobState::queued) {
      s.pool.remove(job->ticket());
      job->fail(JobState::cancelled, problem(503, "shutting_down", "the service shut down before the job started"));
      if (job->state() == JobState::cancelled) s.finish_job(job);
    }
  }
  // 3. Synchronous requests in flight: their clients are waiting; they get the grace period.
  s.pool.close();
  const auto grace_end = t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s.config.grace_seconds));
  bool idle = s.pool.wait_idle(grace_end);
  if (!idle) {
    s.event(spdlog::level::warn, {{"event", "grace_period_over"}, {"running", s.pool.busy()}, {"queued", s.pool.queue_depth()}});
    s.cancel_everything(CancelReason::shutdown);
    idle = s.pool.wait_idle(Clock::now() + std::chrono::seconds(10));
  }
  // 4. Join: connection threads end once their answers are written.
  if (s.listener.joinable()) s.listener.join();
  {
    std::lock_guard<std::mutex> hk(s.housekeeping_mutex);
    s.housekeeping_stop = true;
  }
  s.housekeeping_cv.notify_all();
  if (s.housekeeper.joinable()) s.housekeeper.join();
  if (idle) s.pool.join();
  s.clean = idle;
  s.event(spdlog::level::info, {{"event", "stopped"}, {"ms", std::round(ms_since(t0))}, {"clean", idle}}, true);
  return idle;
}

}  // namespace lipmap::server
