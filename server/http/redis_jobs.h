// The shared job queue of `lipmap serve --queue-url redis://...` (docs/cluster.md): the jobs of every replica
// live in Redis, so that any replica answers GET, DELETE, /result and /preview.svg for any job, and a job whose
// replica died is run again by another one. One of the two JobQueues (job_store.h); without --queue-url the
// other, MemoryJobs (memory_jobs.h), is used.
//
// Keys (all with the prefix "lipmap:"):
//   jobs            Stream of job ids, read by the consumer group "workers" (one consumer per replica)
//   job:{id}        hash: state, times, progress, cancel flag, problem, deadline, test hooks, attempts
//   req:{id}        hash: the request as it arrived (body, media type, glTF parameters, multipart parts)
//   result:{id}     the result JSON; preview:{id}, gltf:{fmt}:{id}: renderings, made on first request
//   gone:{id}       why a job that is no longer held answers 410 (expired, deleted)
// A finished job's keys expire after the retention time (--result-ttl). A running job's replica renews its
// claim on the stream entry (XCLAIM, every visibility/4) and polls the cancel flag; an entry whose claim
// was not renewed for the visibility timeout is taken over by another replica (XAUTOCLAIM).
//
// Redis is reached with hiredis only (redis_connection.h); a command that cannot reach Redis throws
// QueueUnavailable, which the handlers answer 503 queue_unavailable. Connections are re-made with an
// exponential backoff (0.1 s to 5 s).
//
// The replica that ran a job keeps its result in memory for a while (LocalResults: the last --max-results,
// at most the retention time, 256 MiB in all), so that GET .../result landing there reads the result from
// memory instead of Redis and a rendering is made without running the job again. Whether the job is still
// held (not deleted or expired) is always asked of Redis.
//
// A replica that accepts a job while one of its workers is free starts it there at once: the worker runs the
// engine while the request is written, and the submit script reads the new entry for this replica's consumer
// and marks the job running in the same step (the job goes on only if the script did so; the 202 is sent only
// after the write). Otherwise the job waits in the stream for any replica, and the accepting replica keeps
// the request it parsed (Handoffs) until a worker of its own starts the job, so that a job run where it came
// in neither reads the stored body back from Redis nor parses it again; a job taken by another replica, or
// reclaimed, loads the stored request.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <future>
#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "server/http/job_store.h"
#include "server/http/redis_connection.h"
#include "server/http/replica_memory.h"

namespace lipmap::server {

class Service;

// The shared queue already holds --queue jobs that wait for a worker.
class SharedQueueFull : public std::runtime_error {
public:
  SharedQueueFull(std::size_t waiting) : std::runtime_error("shared queue full"), waiting(waiting) {}
  std::size_t waiting;
};

class RedisJobs : public JobQueue {
public:
  explicit RedisJobs(Service& service);
  ~RedisJobs() override;  // stop()
  RedisJobs(const RedisJobs&) = delete;
  RedisJobs& operator=(const RedisJobs&) = delete;

  // ---- what the handlers ask (any replica) ----
  // Stores the request and queues the job, unless --queue jobs already wait (queue_full).
  Submitted submit(const JobRequest& request) override;
  Found find(const std::string& id) override;
  // A running job gets its cancel flag (its replica sees it within a heartbeat).
  Cancelled cancel(const std::string& id) override;
  // From this replica's memory when it ran the job, else from Redis.
  std::shared_ptr<const std::string> result_json(const std::string& id) override;
  std::optional<ComputedResult> computed(const std::string& id) override;
  std::optional<StoredRequest> stored_request(const std::string& id) override;
  // Renderings are kept in Redis as long as the job.
  std::shared_ptr<const std::string> rendering(const std::string& id, const std::string& kind) override;
  void keep_rendering(const std::string& id, const std::string& kind,
                      std::shared_ptr<const std::string> body) override;
  bool uses_local_pool() const override { return false; }
  bool runs_here(const std::string& id) override {
    std::lock_guard<std::mutex> lock(running_mutex_);
    return running_.count(id) != 0;
  }
  // True when Redis answers PING.
  bool ready() override;
  void sample(RuntimeGauges& gauges) override;
  void sweep() override {}  // Redis expires the keys
  // The first call (the drain) stops taking jobs and lets the running ones finish, since any replica can
  // still answer for them; a later one (grace over, second signal) hands them to another replica.
  void cancel_unfinished(CancelReason reason) override;
  void stop() override;

  // Jobs in the shared queue that wait for a worker (-1 when Redis cannot be reached).
  long long waiting();

private:
  struct Running;
  std::unique_ptr<RedisConnection> connect();
  // A connection of the handler pool (made when none is free, subject to the backoff).
  class Lease;
  std::string enqueue(const JobRequest& request);  // throws SharedQueueFull
  Cancel cancel_in_redis(const std::string& id);
  void fetch_loop();
  void heartbeat_loop();
  // Fetched from the stream (or taken over): the start script, then execute() and conclude().
  void run_job(const std::string& entry, const std::string& id);
  // A job accepted here, started on a free worker of this replica before the submit's answer (nullptr when
  // none is free); it goes on once `accepted` says the submit script started it here.
  std::shared_ptr<Running> start_on_submit(const JobRequest& request, const std::string& id,
                                           std::shared_future<bool> accepted);
  void run_on_submit(const std::shared_ptr<Running>& running, const std::shared_future<bool>& accepted,
                     const Handoffs::Parsed& parsed, const TestHooks& hooks);
  struct Outcome {
    std::shared_ptr<const std::string> text;  // the result JSON, when the job succeeded
    ComputedResult local;
  };
  Outcome execute(Job& job, long long attempts, std::optional<Handoffs::Parsed> parsed,
                  const std::optional<StoredRequest>& stored, const TestHooks& hooks);
  // The job ran: handed back (this replica stops) or finished in Redis.
  void conclude(Lease& redis, const std::shared_ptr<Running>& running, Outcome outcome);
  void dispatch(const std::string& entry, const std::string& id);  // run_job on the pool
  void leave_pending(const std::string& id, const char* why);
  void finish(RedisConnection& c, const std::string& entry, const std::string& id, const JobSnapshot& s,
              const std::string* result);
  void ack(RedisConnection& c, const std::string& entry);
  bool local_capacity() const;
  void wake();  // the fetcher looks again at once
  void note_error(const std::string& where, const std::string& what);
  void hand_back_running();  // the jobs this replica runs are cancelled and put back in the queue

  Service& service_;
  const RedisUrl url_;
  const std::string consumer_;
  const std::chrono::milliseconds visibility_, ttl_;

  std::mutex pool_mutex_;
  std::vector<std::unique_ptr<RedisConnection>> idle_;
  std::chrono::steady_clock::time_point next_attempt_{};
  std::chrono::milliseconds backoff_{0};

  std::mutex running_mutex_;
  std::map<std::string, std::shared_ptr<Running>> running_;  // by job id
  LocalResults local_;
  Handoffs handoffs_;

  std::atomic<bool> fetching_{true}, stopping_{false};
  std::atomic<std::uint64_t> reclaimed_{0}, errors_{0}, local_reads_{0}, started_on_submit_{0};
  std::mutex start_mutex_;                   // two submits never both take the last free worker
  std::atomic<long long> fetcher_client_{-1};  // the fetcher connection's CLIENT ID, to end its blocking read
  std::mutex wake_mutex_;
  std::condition_variable wake_;
  std::uint64_t wakeups_ = 0;  // with wake_mutex_
  std::thread fetcher_, heartbeat_;
};

}  // namespace lipmap::server
