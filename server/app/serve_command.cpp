#include "server/app/serve_command.h"

#include <pthread.h>
#include <signal.h>

#include <atomic>
#include <cstdlib>
#include <ctime>
#include <exception>
#include <memory>
#include <ostream>
#include <stdexcept>
#include <thread>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

#include "server/app/cli.h"

namespace lipmap::cli {

namespace {

// Signals are taken by sigtimedwait on threads that block them; but libraries start threads of their own
// before main (OpenBLAS's pool) with every signal unblocked, and the kernel may hand SIGTERM to one of them.
// The handler (not the default action, which would kill the process) counts such a signal for the waiters.
std::atomic<int> g_stray_signals{0};
std::atomic<int> g_stray_signal{0};
void count_stray_signal(int sig) {
  g_stray_signal.store(sig);
  g_stray_signals.fetch_add(1);
}

// The next SIGTERM/SIGINT, whichever thread the kernel gave it to. `seen`: stray signals already taken.
int wait_for_signal(const sigset_t& signals, int& seen) {
  const timespec tick{0, 100 * 1000 * 1000};
  for (;;) {
    const int sig = sigtimedwait(&signals, nullptr, &tick);
    if (sig > 0) return sig;
    if (g_stray_signals.load() > seen) {
      ++seen;
      return g_stray_signal.load();
    }
  }
}

}  // namespace

CLI::App* add_serve_subcommand(CLI::App& app, ServeOptions& o) {
  server::ServerConfig& c = o.config;
  CLI::App* cmd = app.add_subcommand(
      "serve", "Run the HTTP service: POST /v1/parametrize, /v1/polygons/classify, /v1/jobs, ... (see /v1/openapi.json)");
  cmd->add_option("--host", c.host, "Address to listen on")->envname("LIPMAP_HOST")->capture_default_str();
  cmd->add_option("--port", c.port, "Port to listen on; 0 picks a free one (logged)")
      ->envname("LIPMAP_PORT")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  cmd->add_option("--workers", c.workers, "Engine worker threads; 0 = one per core")
      ->envname("LIPMAP_WORKERS")
      ->capture_default_str();
  cmd->add_option("--queue", c.queue_capacity, "Tasks that may wait for a worker; beyond, 503 + Retry-After")
      ->envname("LIPMAP_QUEUE")
      ->capture_default_str();
  cmd->add_option("--max-connections,--http-threads", c.http_threads,
                  "Connections served at once (one thread each; at most 900); beyond, 503 too_many_connections "
                  "and close; 0 = 512")
      ->envname("LIPMAP_MAX_CONNECTIONS")
      ->capture_default_str();
  cmd->add_option("--admin-port", c.admin_port,
                  "Also serve /healthz, /readyz and /metrics on this port, with threads of their own; 0 picks a free "
                  "one (logged); -1 = none")
      ->envname("LIPMAP_ADMIN_PORT")
      ->check(CLI::Range(-1, 65535))
      ->capture_default_str();
  cmd->add_option("--header-timeout", c.header_timeout_seconds,
                  "Seconds a request's line and headers may take to arrive, from its first byte; then 408 and close")
      ->envname("LIPMAP_HEADER_TIMEOUT")
      ->capture_default_str();
  cmd->add_option("--request-timeout", c.request_timeout_seconds,
                  "Seconds a whole request (headers and body) may take to arrive, from its first byte; then 408 and close")
      ->envname("LIPMAP_REQUEST_TIMEOUT")
      ->capture_default_str();
  cmd->add_option("--max-body-bytes", c.max_body_bytes, "Largest request body; beyond, 413")
      ->envname("LIPMAP_MAX_BODY_BYTES")
      ->capture_default_str();
  cmd->add_option("--max-vertices", c.max_vertices, "Largest mesh, in vertices; beyond, 422 mesh_too_large")
      ->envname("LIPMAP_MAX_VERTICES")
      ->capture_default_str();
  cmd->add_option("--max-faces", c.max_faces, "Largest mesh, in faces; beyond, 422 mesh_too_large")
      ->envname("LIPMAP_MAX_FACES")
      ->capture_default_str();
  cmd->add_option("--max-polygon-vertices", c.max_polygon_vertices,
                  "Largest boundary polygon; beyond, 422 polygon_too_large")
      ->envname("LIPMAP_MAX_POLYGON_VERTICES")
      ->capture_default_str();
  cmd->add_option("--memory-budget", c.memory_budget_bytes,
                  "Largest estimated peak memory of one request, in bytes; beyond, 413 (body) or 422 "
                  "memory_budget_exceeded")
      ->envname("LIPMAP_MEMORY_BUDGET")
      ->capture_default_str();
  cmd->add_option("--deadline", c.deadline_seconds,
                  "Seconds a request or job may take from its arrival; then it is cancelled (504, or job failed)")
      ->envname("LIPMAP_DEADLINE")
      ->capture_default_str();
  cmd->add_option("--result-ttl", c.result_ttl_seconds, "Seconds a finished job is kept; then 410 Gone")
      ->envname("LIPMAP_RESULT_TTL")
      ->capture_default_str();
  cmd->add_option("--max-results", c.max_results, "Finished jobs kept (oldest dropped first; then 410 Gone)")
      ->envname("LIPMAP_MAX_RESULTS")
      ->capture_default_str();
  cmd->add_option("--grace", c.grace_seconds,
                  "Seconds in-flight requests may finish after SIGTERM/SIGINT before they are cancelled")
      ->envname("LIPMAP_GRACE")
      ->capture_default_str();
  cmd->add_option("--queue-url", c.queue_url,
                  "Shared job queue redis://HOST[:PORT][/DB]: every replica serves every job; empty: jobs in this process")
      ->envname("LIPMAP_QUEUE_URL");
  cmd->add_option("--queue-visibility", c.queue_visibility_seconds,
                  "Shared queue: seconds after which a job whose replica stopped renewing its claim is run elsewhere")
      ->envname("LIPMAP_QUEUE_VISIBILITY")
      ->capture_default_str();
  cmd->add_option("--max-result-bytes", c.max_result_bytes,
                  "Shared queue: largest job result kept in Redis; beyond, the job fails (result_too_large)")
      ->envname("LIPMAP_MAX_RESULT_BYTES")
      ->capture_default_str();
  cmd->add_option("--log-level", o.log_level, "trace, debug, info, warn, error or off")
      ->envname("LIPMAP_LOG_LEVEL")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}))
      ->capture_default_str();
  cmd->add_flag("--test-hooks", c.test_hooks,
                "Tests only: honour X-Lipmap-Test-Delay-Ms and X-Lipmap-Test-Fault request headers")
      ->envname("LIPMAP_TEST_HOOKS")
      ->group("Testing");
  return cmd;
}

int serve_command(const ServeOptions& options, std::ostream& out, std::ostream& err) {
  (void)out;
  server::ServerConfig config;
  try {
    config = server::resolve(options.config);
  } catch (const std::invalid_argument& e) {
    return fail(err, "usage", std::string(e.what()) + " (run 'lipmap serve --help')");
  }

  // Signals are taken by sigtimedwait below: block them before any thread of ours starts so that
  // every thread inherits the mask. A peer that closes its socket must not kill the process either.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  signal(SIGPIPE, SIG_IGN);
  struct sigaction stray {};
  stray.sa_handler = count_stray_signal;
  sigemptyset(&stray.sa_mask);
  sigaction(SIGTERM, &stray, nullptr);
  sigaction(SIGINT, &stray, nullptr);

  auto sink = std::make_shared<spdlog::sinks::stderr_sink_mt>();
  auto logger = std::make_shared<spdlog::logger>("lipmap", sink);
  logger->set_pattern("%v");
  logger->set_level(spdlog::level::from_str(options.log_level));
  logger->flush_on(spdlog::level::trace);

  std::unique_ptr<server::HttpServer> server;
  try {
    server = std::make_unique<server::HttpServer>(config, logger);
    server->bind();
    server->start();
  } catch (const std::runtime_error& e) {
    return fail(err, "listen_failed", e.what());
  }

  int seen = 0;
  const int signal_number = wait_for_signal(signals, seen);
  server->log_signal(signal_number == SIGTERM ? "SIGTERM" : "SIGINT", false);
  // A second signal while draining: stop waiting for in-flight work.
  std::thread([signals, seen, srv = server.get()]() mutable {
    const int again = wait_for_signal(signals, seen);
    srv->log_signal(again == SIGTERM ? "SIGTERM" : "SIGINT", true);
    srv->cancel_all();
  }).detach();

  const bool clean = server->shutdown();
  logger->flush();
  // Engine threads ignored their cancellation: do not wait on them, and say the stop was not clean.
  if (!clean) std::_Exit(codec::kExitInternalError);
  // The detached signal thread still waits for a signal; the server object must outlive it.
  server.release();
  return kExitOk;
}

}  // namespace lipmap::cli
