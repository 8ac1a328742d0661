#include "server/http/service.h"

#include <algorithm>
#include <ctime>
#include <future>
#include <new>
#include <stdexcept>
#include <thread>

#include "engine/error.h"
#include "server/http/memory_jobs.h"
#include "server/http/middleware.h"
#include "server/http/redis_jobs.h"

// Last: with its OpenSSL support cpp-httplib pulls in <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>

namespace lipmap::server {

using nlohmann::ordered_json;

double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

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

void apply_hooks(const TestHooks& hooks, const CancelToken& token) {
  if (hooks.fault == "ignore_cancel") {  // work that does not honour its token (the unclean shutdown's test)
    std::this_thread::sleep_for(std::chrono::milliseconds(hooks.delay_ms));
    return;
  }
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

// A synchronous request's work: its token, and why it was cancelled (the first reason wins).
struct Service::SyncWork {
  CancelToken token;
  std::atomic<CancelReason> reason{CancelReason::none};
  void cancel(CancelReason r) {
    CancelReason expected = CancelReason::none;
    reason.compare_exchange_strong(expected, r);
    token.cancel();
  }
};

Service::Service(ServerConfig c, std::shared_ptr<spdlog::logger> logger)
    : config(resolve(std::move(c))),
      log(std::move(logger)),
      pool(config.workers, config.queue_capacity),
      waits(std::max<std::size_t>(1, config.http_threads / 2)) {
  if (config.queue_url.empty())
    jobs = std::make_unique<MemoryJobs>(*this);
  else
    jobs = std::make_unique<RedisJobs>(*this);
}

Service::~Service() {
  jobs->stop();  // no more jobs taken; those on the pool end before it is joined
  pool.join();
}

void Service::event(spdlog::level::level_enum level, ordered_json fields, bool lifecycle) const {
  if (!log) return;
  if (lifecycle ? log->level() == spdlog::level::off : !log->should_log(level)) return;
  ordered_json line;
  line["ts"] = iso8601(std::chrono::system_clock::now());
  line["level"] = spdlog::level::to_string_view(level).data();
  for (auto& [k, v] : fields.items()) line[k] = std::move(v);
  log->log(lifecycle ? spdlog::level::critical : level, "{}",
           line.dump(-1, ' ', false, ordered_json::error_handler_t::replace));
}

std::optional<Answer> Service::refuse_when_draining() const {
  if (!draining) return std::nullopt;
  Answer a = problem_answer("shutting_down", "the service is shutting down and takes no new work");
  a.headers.emplace_back("Retry-After", "5");
  a.headers.emplace_back("Connection", "close");
  return a;
}

Answer Service::submit_refused(WorkerPool::Submit why) {
  if (why == WorkerPool::Submit::queue_full)
    return queue_full("all " + std::to_string(pool.workers()) + " workers are busy and " +
                      std::to_string(pool.capacity()) + " tasks are waiting");
  metrics.count_rejected("shutting_down");
  Answer a = problem_answer("shutting_down", "the service is shutting down and takes no new work");
  a.headers.emplace_back("Retry-After", "5");
  return a;
}

Answer Service::queue_full(const std::string& what) {
  metrics.count_rejected("queue_full");
  const int retry = pool.retry_after_seconds();
  Answer a = problem_answer("queue_full", what + "; retry after " + std::to_string(retry) + " s");
  (*a.problem)["retry_after_seconds"] = retry;
  a.headers.emplace_back("Retry-After", std::to_string(retry));
  return a;
}

Clock::time_point Service::deadline_from_arrival() const {
  const RequestContext& r = this_request();
  const auto start = r.active ? r.start : Clock::now();
  return start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config.deadline_seconds));
}

// 2 when the machine has a second core and the pool has at most `own` busy workers (the caller's job) and
// nothing waiting, else 1.
int Service::spare_threads(int own) const {
  static const unsigned cores = std::thread::hardware_concurrency();
  return cores >= 2 && pool.busy() <= static_cast<std::size_t>(own) && pool.queue_depth() == 0 ? 2 : 1;
}

int Service::answer_threads() const { return spare_threads(1); }

int Service::read_threads() const { return spare_threads(0); }

TestHooks Service::hooks_of(const httplib::Request& req) const {
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

Answer Service::run_sync(InputKind kind, Work work) {
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
      a = problem_answer(current_exception_problem(kind, sync->reason.load(), deadline_seconds));
    }
    a.queue_ms = std::chrono::duration<double, std::milli>(started - enqueued).count();
    a.work_ms = ms_since(started);
    promise->set_value(std::move(a));
  };
  {
    std::lock_guard<std::mutex> lock(sync_mutex_);
    sync_work_.insert(sync);
  }
  const WorkerPool::Submit submitted = pool.submit(std::move(task));
  if (submitted != WorkerPool::Submit::accepted) {
    std::lock_guard<std::mutex> lock(sync_mutex_);
    sync_work_.erase(sync);
    return submit_refused(submitted);
  }
  // The engine checks its token between stages and inside long loops; the slack covers a stage that is
  // slow to notice. After it the client gets its 504 and the work, still cancelled, ends on its own.
  const auto hard_limit = deadline + std::chrono::seconds(5);
  Answer answer;
  if (future.wait_until(hard_limit) == std::future_status::ready) {
    answer = future.get();
    this_request().queue_ms = answer.queue_ms;
    this_request().work_ms = answer.work_ms;
    this_request().engine_ms = answer.engine_ms;
  } else {
    sync->cancel(CancelReason::none);
    answer = problem_answer("deadline_exceeded", "the work did not finish within the deadline of " +
                                                     seconds_text(config.deadline_seconds) + " s and was cancelled");
  }
  std::lock_guard<std::mutex> lock(sync_mutex_);
  sync_work_.erase(sync);
  return answer;
}

void Service::cancel_sync_work(CancelReason reason) {
  std::lock_guard<std::mutex> lock(sync_mutex_);
  for (const auto& w : sync_work_) w->cancel(reason);
}

}  // namespace lipmap::server
