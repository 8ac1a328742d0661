// What every handler of the HTTP service shares: the configuration, the worker pool, the job store, the
// metrics and the structured log; running work on the pool and waiting for it (synchronous endpoints);
// refusing work while draining or when the queue is full. docs/architecture.md shows how the parts fit.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_set>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "engine/cancel.h"
#include "server/http/http_server.h"
#include "server/http/job_store.h"
#include "server/http/job_waits.h"
#include "server/http/metrics.h"
#include "server/http/problems.h"
#include "server/http/worker_pool.h"

namespace httplib {
struct Request;
}

namespace lipmap::server {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t);
std::string iso8601(std::chrono::system_clock::time_point t);

// Runs inside a task (TestHooks: job_store.h), before its work.
void apply_hooks(const TestHooks& hooks, const CancelToken& token);

class Service {
public:
  Service(ServerConfig config, std::shared_ptr<spdlog::logger> logger);
  ~Service();

  const ServerConfig config;
  const std::shared_ptr<spdlog::logger> log;
  Metrics metrics;
  WorkerPool pool;
  // The asynchronous jobs, chosen once: in memory on this process's pool (MemoryJobs), or the shared queue of
  // --queue-url (RedisJobs). Declared after the pool and stopped before it is joined (~Service).
  std::unique_ptr<JobQueue> jobs;
  // The polls waiting for a job to end (GET /v1/jobs/{id}?wait=): at most half the connections.
  JobWaits waits;
  std::atomic<bool> draining{false};
  const Clock::time_point started_at = Clock::now();

  // One JSON log line. Lifecycle events (listening, signal, draining, stopped) are written at every log
  // level but off: an operator, or a test that started the service on port 0, needs the listening line
  // even at --log-level warn.
  void event(spdlog::level::level_enum level, nlohmann::ordered_json fields, bool lifecycle = false) const;

  // 503 shutting_down while draining.
  std::optional<Answer> refuse_when_draining() const;
  // The answer to a task the pool did not take.
  Answer submit_refused(WorkerPool::Submit why);
  // 503 queue_full: `what` is full ("all 2 workers are busy and 64 tasks are waiting").
  Answer queue_full(const std::string& what);
  // The request's deadline, counted from its arrival.
  Clock::time_point deadline_from_arrival() const;
  // Threads for writing an answer's text on a worker: 2 when that job is the pool's only work and the
  // machine has a second core (the request's HTTP thread only waits meanwhile), else 1: under load the
  // workers are the parallelism.
  int answer_threads() const;
  // Threads for reading a request's body on its HTTP thread: 2 when the pool is idle and the machine has a
  // second core, else 1.
  int read_threads() const;
  int spare_threads(int own) const;
  TestHooks hooks_of(const httplib::Request& req) const;

  // Runs `work` on the pool and waits for its answer (synchronous endpoints); 504 when the deadline
  // passes, 503 when the pool refuses it. `kind` says what an InputError escaping the work is about.
  using Work = std::function<Answer(const CancelToken&)>;
  Answer run_sync(InputKind kind, Work work);
  // Cancels the work of every synchronous request in flight.
  void cancel_sync_work(CancelReason reason);

private:
  struct SyncWork;
  std::mutex sync_mutex_;
  std::unordered_set<std::shared_ptr<SyncWork>> sync_work_;
};

}  // namespace lipmap::server
