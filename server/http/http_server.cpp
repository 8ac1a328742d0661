// The HTTP service's wiring and lifecycle: the configuration, cpp-httplib's settings and hooks (routes from
// server/http/routes.cpp, middleware from server/http/middleware.cpp), bind, start, and the graceful
// shutdown. docs/architecture.md describes the parts.
#include "server/http/http_server.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "server/http/connection.h"
#include "server/http/handlers.h"
#include "server/http/middleware.h"
#include "server/http/redis_jobs.h"
#include "server/http/routes.h"
#include "server/http/service.h"

// Last: with its OpenSSL support cpp-httplib pulls in <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>
#include <sys/socket.h>

namespace lipmap::server {

ServerConfig resolve(ServerConfig c) {
  auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (c.port < 0 || c.port > 65535) bad("port must be between 0 and 65535");
  if (c.host.empty()) bad("host must not be empty");
  if (c.workers == 0) c.workers = std::max(1u, std::thread::hardware_concurrency());
  if (c.workers > 1024) bad("workers must be at most 1024");
  if (c.queue_capacity > 1000000) bad("queue must be at most 1000000");
  // cpp-httplib 0.11 (built with select) answers 500 on a socket numbered FD_SETSIZE (1024) or more.
  if (c.http_threads == 0) c.http_threads = 512;
  if (c.http_threads > 900) bad("max connections must be at most 900");
  if (c.admin_port < -1 || c.admin_port > 65535) bad("admin port must be between 0 and 65535 (or -1: none)");
  auto timeout_ok = [](double s) { return s >= 0.1 && s <= 86400 && std::isfinite(s); };
  if (!timeout_ok(c.header_timeout_seconds)) bad("header timeout must be between 0.1 and 86400 seconds");
  if (!timeout_ok(c.request_timeout_seconds)) bad("request timeout must be between 0.1 and 86400 seconds");
  if (c.max_body_bytes == 0) bad("max body size must be at least 1 byte");
  if (c.max_vertices < 3) bad("max vertices must be at least 3");
  if (c.max_faces < 1) bad("max faces must be at least 1");
  if (c.max_polygon_vertices < 3) bad("max polygon vertices must be at least 3");
  if (c.memory_budget_bytes < (16u << 20)) bad("memory budget must be at least 16 MiB (16777216 bytes)");
  if (!(c.deadline_seconds > 0) || !std::isfinite(c.deadline_seconds)) bad("deadline must be a positive number of seconds");
  if (!(c.result_ttl_seconds >= 0) || !std::isfinite(c.result_ttl_seconds)) bad("result ttl must be >= 0 seconds");
  if (c.max_results < 1) bad("max results must be at least 1");
  if (!(c.grace_seconds >= 0) || !std::isfinite(c.grace_seconds)) bad("grace period must be >= 0 seconds");
  if (c.keep_alive_seconds < 1) bad("keep-alive timeout must be at least 1 second");
  if (!c.queue_url.empty()) parse_redis_url(c.queue_url);  // throws naming the problem
  if (!(c.queue_visibility_seconds >= 0.2) || !std::isfinite(c.queue_visibility_seconds))
    bad("queue visibility timeout must be at least 0.2 seconds");
  if (c.max_result_bytes == 0) bad("max result size must be at least 1 byte");
  return c;
}

struct HttpServer::Impl {
  Service service;
  std::unique_ptr<httplib::Server> http_owner, admin_owner;
  httplib::Server& http;
  std::thread listener, admin_listener, housekeeper;
  std::atomic<bool> started{false}, stopped{false};
  std::mutex shutdown_mutex;
  std::mutex housekeeping_mutex;
  std::condition_variable housekeeping_cv;
  bool housekeeping_stop = false;
  int port = -1, admin_port = -1;
  bool clean = true;
  socket_t listen_socket = -1, admin_socket = -1;

  static ConnectionLimits limits_of(const ServerConfig& c, bool admin) {
    ConnectionLimits l;
    auto ms = [](double s) { return std::chrono::milliseconds(static_cast<long long>(std::llround(s * 1000))); };
    l.header_timeout = ms(c.header_timeout_seconds);
    l.request_timeout = ms(c.request_timeout_seconds);
    // The admin listener answers a few probes at a time: small, and its own threads whatever the main one does.
    l.max_connections = admin ? 8 : c.http_threads;
    return l;
  }

  Impl(ServerConfig c, std::shared_ptr<spdlog::logger> logger)
      : service(std::move(c), std::move(logger)),
        http_owner(make_connection_server(limits_of(service.config, false), [this] { return connection_refusal(service); })),
        admin_owner(make_connection_server(limits_of(service.config, true), [this] { return connection_refusal(service); })),
        http(*http_owner) {
    setup(http, listen_socket);
    register_routes(http, service);
    setup(*admin_owner, admin_socket);
    register_routes(*admin_owner, service, true);
  }

  void setup(httplib::Server& srv, socket_t& bound_socket) {
    const ServerConfig& config = service.config;
    srv.set_payload_max_length(config.max_body_bytes);
    srv.set_keep_alive_timeout(config.keep_alive_seconds);
    srv.set_keep_alive_max_count(1000);
    srv.set_read_timeout(10, 0);  // per read; the whole request has its own deadline (server/http/connection.h)
    srv.set_write_timeout(30, 0);
    srv.set_tcp_nodelay(true);
    // cpp-httplib's default also sets SO_REUSEPORT, which lets a second service bind the same port and
    // silently take half of its connections: plain SO_REUSEADDR only. The socket that binds is the last
    // one this sees; bind() then widens its listen backlog (cpp-httplib 0.11 fixes it at 5).
    srv.set_socket_options([&bound_socket](socket_t sock) {
      int yes = 1;
      ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, reinterpret_cast<const char*>(&yes), sizeof yes);
      bound_socket = sock;
    });
    using Handled = httplib::Server::HandlerResponse;
    srv.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
      return pre_routing(service, req, res) ? Handled::Handled : Handled::Unhandled;
    });
    srv.set_error_handler(httplib::Server::HandlerWithResponse(
        [this](const httplib::Request& req, httplib::Response& res) {
          return error_answer(service, req, res) ? Handled::Handled : Handled::Unhandled;
        }));
    srv.set_exception_handler([this](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
      exception_answer(service, req, res, ep);
    });
    srv.set_logger([this](const httplib::Request& req, const httplib::Response& res) { log_request(service, req, res); });
  }

  void housekeeping() {
    std::unique_lock<std::mutex> lock(housekeeping_mutex);
    while (!housekeeping_stop) {
      housekeeping_cv.wait_for(lock, std::chrono::seconds(1));
      lock.unlock();
      service.jobs->sweep();
      lock.lock();
    }
  }

  void cancel_everything(CancelReason reason) {
    service.jobs->cancel_unfinished(reason);
    service.cancel_sync_work(reason);
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
  const ServerConfig& config = s.service.config;
  int port = -1;
  if (config.port == 0) {
    port = s.http.bind_to_any_port(config.host);
  } else if (s.http.bind_to_port(config.host, config.port)) {
    port = config.port;
  }
  if (port <= 0)
    throw std::runtime_error("cannot listen on " + config.host + ":" + std::to_string(config.port) +
                             " (address in use, not a local address, or not permitted)");
  s.port = port;
  if (s.listen_socket >= 0) ::listen(s.listen_socket, SOMAXCONN);  // after bind: only the backlog changes
  if (config.admin_port >= 0) {
    int admin = config.admin_port == 0 ? s.admin_owner->bind_to_any_port(config.host)
                                       : (s.admin_owner->bind_to_port(config.host, config.admin_port) ? config.admin_port : -1);
    if (admin <= 0)
      throw std::runtime_error("cannot listen on " + config.host + ":" + std::to_string(config.admin_port) +
                               " for the admin listener (address in use, not a local address, or not permitted)");
    s.admin_port = admin;
    if (s.admin_socket >= 0) ::listen(s.admin_socket, SOMAXCONN);
  }
  return port;
}

void HttpServer::start() {
  Impl& s = *impl_;
  const ServerConfig& c = s.service.config;
  if (s.port < 0) bind();
  s.started = true;
  s.listener = std::thread([&s] { s.http.listen_after_bind(); });
  if (s.admin_port > 0) s.admin_listener = std::thread([&s] { s.admin_owner->listen_after_bind(); });
  s.housekeeper = std::thread([&s] { s.housekeeping(); });
  s.service.event(spdlog::level::info, {{"event", "listening"},
                                        {"host", c.host},
                                        {"port", s.port},
                                        {"url", "http://" + c.host + ":" + std::to_string(s.port)},
                                        {"workers", c.workers},
                                        {"queue", c.queue_capacity},
                                        {"max_connections", c.http_threads},
                                        {"admin_port", s.admin_port},
                                        {"header_timeout_seconds", c.header_timeout_seconds},
                                        {"request_timeout_seconds", c.request_timeout_seconds},
                                        {"max_body_bytes", c.max_body_bytes},
                                        {"max_vertices", c.max_vertices},
                                        {"max_faces", c.max_faces},
                                        {"max_polygon_vertices", c.max_polygon_vertices},
                                        {"memory_budget_bytes", c.memory_budget_bytes},
                                        {"deadline_seconds", c.deadline_seconds},
                                        {"result_ttl_seconds", c.result_ttl_seconds},
                                        {"max_results", c.max_results},
                                        {"grace_seconds", c.grace_seconds},
                                        {"remapping_engine", true},
                                        {"test_hooks", c.test_hooks},
                                        {"queue_url", c.queue_url}}, true);
  if (c.test_hooks)
    s.service.event(spdlog::level::warn, {{"event", "test_hooks_enabled"},
                                          {"detail", "X-Lipmap-Test-* headers are honoured: never run like this in production"}});
}

bool HttpServer::draining() const { return impl_->service.draining; }

void HttpServer::log_signal(const std::string& name, bool second) {
  impl_->service.event(spdlog::level::info,
                       {{"event", "signal"}, {"signal", name}, {"action", second ? "cancel_all" : "drain"}}, true);
}

void HttpServer::cancel_all() { impl_->cancel_everything(CancelReason::shutdown); }

bool HttpServer::shutdown() {
  Impl& s = *impl_;
  Service& service = s.service;
  std::lock_guard<std::mutex> lock(s.shutdown_mutex);
  if (s.stopped) return s.clean;
  s.stopped = true;
  if (!s.started) {  // never served (bind failed): nothing to drain
    service.pool.join();
    return true;
  }
  const auto t0 = Clock::now();
  service.event(spdlog::level::info, {{"event", "draining"},
                                      {"grace_seconds", service.config.grace_seconds},
                                      {"queued", service.pool.queue_depth()},
                                      {"running", service.pool.busy()}}, true);
  // 1. No new connections. Requests already being read still run (and are refused new work with 503).
  // Draining starts after the stop: a request refused for it, before its body was read, is then the last
  // on its connection (cpp-httplib ends a connection once the listener is stopped).
  s.http.stop();
  service.draining = true;
  service.waits.close();  // waiting polls answer now, with the job as it is
  // 2. Asynchronous jobs: once the listener is closed nobody can fetch their results, so they end now.
  service.jobs->cancel_unfinished(CancelReason::shutdown);
  // 3. Synchronous requests in flight: their clients are waiting; they get the grace period.
  service.pool.close();
  const auto grace_end =
      t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(service.config.grace_seconds));
  bool idle = service.pool.wait_idle(grace_end);
  if (!idle) {
    service.event(spdlog::level::warn, {{"event", "grace_period_over"},
                                        {"running", service.pool.busy()},
                                        {"queued", service.pool.queue_depth()}});
    s.cancel_everything(CancelReason::shutdown);
    idle = service.pool.wait_idle(Clock::now() + std::chrono::seconds(10));
  }
  // 4. Join: connection threads end once their answers are written.
  if (s.listener.joinable()) s.listener.join();
  // The admin listener answers until here: /readyz says 503 while draining.
  if (s.admin_port > 0) s.admin_owner->stop();
  if (s.admin_listener.joinable()) s.admin_listener.join();
  {
    std::lock_guard<std::mutex> hk(s.housekeeping_mutex);
    s.housekeeping_stop = true;
  }
  s.housekeeping_cv.notify_all();
  if (s.housekeeper.joinable()) s.housekeeper.join();
  if (idle) service.pool.join();
  s.clean = idle;
  service.event(spdlog::level::info, {{"event", "stopped"}, {"ms", std::round(ms_since(t0))}, {"clean", idle}}, true);
  return idle;
}

}  // namespace lipmap::server
