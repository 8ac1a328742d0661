// The HTTP service (docs/architecture.md, docs/api.md): routes, RFC 7807 problem answers, limits, jobs,
// metrics, structured request logs. cpp-httplib stays inside server/http's .cpp files; this header is all the
// `serve` subcommand needs.
//
// Threads: cpp-httplib's connection threads only parse bodies, enqueue work and answer; every engine call
// runs on the WorkerPool (a fixed number of workers behind a bounded queue). A synchronous request waits for
// its task; an asynchronous job (POST /v1/jobs) is answered 202 at once and polled.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

namespace spdlog {
class logger;
}

namespace lipmap::server {

struct ServerConfig {
  std::string host = "127.0.0.1";
  int port = 8080;                          // 0: any free port (the bound port is logged and returned by bind())
  std::size_t workers = 0;                  // engine workers; 0: one per core
  std::size_t queue_capacity = 64;          // tasks waiting for a worker; beyond: 503 + Retry-After
  std::size_t http_threads = 0;             // connection capacity (one thread each); 0: 512. Beyond: 503 + close
  int admin_port = -1;                      // /healthz, /readyz, /metrics on their own listener and threads;
                                            // -1: none, 0: any free port (logged)
  double header_timeout_seconds = 10;       // a request's line and headers must arrive within this (then 408)
  double request_timeout_seconds = 60;      // ... and its whole body within this, both from its first byte
  std::size_t max_body_bytes = 256u << 20;  // 413 beyond
  std::size_t max_vertices = 2000000;       // mesh size limits: 422 mesh_too_large beyond
  std::size_t max_faces = 4000000;
  std::size_t max_polygon_vertices = 4000;  // boundary polygon / classify polygon: 422 polygon_too_large beyond
                                            // (the table: ~2 s and ~70 MB at 4,000; docs/hard-points.md)
  std::size_t memory_budget_bytes = 1024u << 20;  // a request's estimated peak memory; beyond: 413 / 422
  double deadline_seconds = 300;            // per request or job, from its arrival: 504 / job failed
  double result_ttl_seconds = 900;          // finished jobs are kept this long ...
  std::size_t max_results = 64;             // ... and at most this many (oldest dropped first): then 410 Gone
  double grace_seconds = 30;                // SIGTERM: in-flight work may finish for this long, then is cancelled
  int keep_alive_seconds = 2;               // idle keep-alive connections are closed after this
  bool test_hooks = false;                  // honour X-Lipmap-Test-* request headers (tests only)
  // Shared job queue (server/http/redis_jobs.h): redis://HOST[:PORT][/DB]; empty: jobs stay in this process.
  std::string queue_url;
  double queue_visibility_seconds = 30;     // a job's claim not renewed for this long is taken over
  std::size_t max_result_bytes = 256u << 20;  // shared queue: a larger result fails the job (result_too_large)
};

// Checks ranges and fills the automatic values (workers, http_threads); throws std::invalid_argument
// naming the setting.
ServerConfig resolve(ServerConfig config);

class HttpServer {
public:
  HttpServer(ServerConfig config, std::shared_ptr<spdlog::logger> logger);
  ~HttpServer();  // shutdown() when still running
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  // Binds the listening socket; returns the port. Throws std::runtime_error when it cannot.
  int bind();
  // Starts accepting on a background thread (after bind()).
  void start();
  // Graceful stop: /readyz turns 503, the listener closes, asynchronous jobs that can no longer be fetched
  // are cancelled, in-flight synchronous requests get up to grace_seconds to finish (then their work is
  // cancelled), and every thread is joined. Idempotent. Returns false when some work ignored its
  // cancellation for 10 s more (then the engine threads are left running: the caller should just exit).
  bool shutdown();
  // Cancels all remaining work at once (a second signal during shutdown).
  void cancel_all();
  bool draining() const;
  // Logs the signal that started (or, second = true, hurried) the shutdown.
  void log_signal(const std::string& name, bool second);

  struct Impl;

private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace lipmap::server
