// The shared job queue of `lipmap serve --queue-url redis://...` (docs/cluster.md): the jobs of every replica
// live in Redis, so that any replica answers GET, DELETE, /result and /preview.svg for any job, and a job whose
// replica died is run again by another one. Without --queue-url the in-memory JobStore (job_store.h) is used.
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
// Redis is reached with hiredis only (redisCommandArgv); a command that cannot reach Redis throws
// QueueUnavailable, which the handlers answer 503 queue_unavailable. Connections are re-made with an
// exponential backoff (0.1 s to 5 s).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "server/codec/request_loader.h"
#include "server/http/job_store.h"

namespace lipmap::server {

class Service;

struct RedisUrl {
  std::string host;
  int port = 6379;
  int db = 0;
};
// redis://HOST[:PORT][/DB]; throws std::invalid_argument naming what is wrong.
RedisUrl parse_redis_url(const std::string& url);

// Redis cannot be reached (or answered an error where it should not): 503 queue_unavailable.
class QueueUnavailable : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

// The shared queue already holds --queue jobs that wait for a worker.
class SharedQueueFull : public std::runtime_error {
public:
  SharedQueueFull(std::size_t waiting) : std::runtime_error("shared queue full"), waiting(waiting) {}
  std::size_t waiting;
};

// What POST /v1/jobs received, as stored in req:{id}: enough to load the request again on any replica.
struct StoredRequest {
  std::string body;
  std::string media_type;
  gltf::Params params;
  std::map<std::string, gltf::Part> parts;
  codec::RequestInput input() const;  // views into this object
};

class RedisConnection;

class RedisJobs {
public:
  explicit RedisJobs(Service& service);
  ~RedisJobs();  // stop()
  RedisJobs(const RedisJobs&) = delete;
  RedisJobs& operator=(const RedisJobs&) = delete;

  // ---- what the handlers ask (any replica) ----
  // Stores the request and queues the job; returns its id. Throws SharedQueueFull, QueueUnavailable.
  std::string submit(const StoredRequest& request, std::chrono::system_clock::time_point deadline,
                     long long delay_ms, const std::string& fault);
  struct Found {
    JobStore::Lookup lookup = JobStore::Lookup::unknown;
    JobSnapshot snapshot;     // when found
    std::string gone_reason;  // when gone
  };
  Found find(const std::string& id);
  enum class Cancel { unknown, gone, removed, cancelled_queued, cancel_requested };
  // DELETE: a finished job is removed (its keys dropped, the id answers 410 deleted), a queued one ends at
  // once (cancelled), a running one gets its cancel flag (its replica sees it within a heartbeat).
  Cancel cancel(const std::string& id, const std::string& problem_json);
  std::shared_ptr<const std::string> result_json(const std::string& id);
  // A rendering of the result (kind: "preview", "gltf:glb", "gltf:gltf"), kept as long as the job.
  std::shared_ptr<const std::string> rendering(const std::string& id, const std::string& kind);
  void keep_rendering(const std::string& id, const std::string& kind, const std::string& body);
  // The job's request, loaded again (for renderings on a replica that did not run the job); nullopt when
  // Redis no longer holds it.
  std::optional<StoredRequest> stored_request(const std::string& id);
  // The result this replica computed, while it is in its small local cache.
  struct Local {
    std::shared_ptr<const ParametrizeResult> result;
    std::shared_ptr<const gltf::Asset> asset;
  };
  std::optional<Local> local_result(const std::string& id);

  // /readyz: true when Redis answers PING.
  bool ready();
  // Jobs in the shared queue that wait for a worker (-1 when Redis cannot be reached).
  long long waiting();
  std::uint64_t reclaimed() const { return reclaimed_; }
  std::uint64_t errors() const { return errors_; }

  // ---- shutdown ----
  // No new jobs are taken from the queue; running ones go on.
  void stop_fetching();
  bool fetching() const { return fetching_; }
  // The jobs this replica still runs are cancelled and put back in the queue for another replica.
  void hand_back_running();
  void stop();

private:
  struct Running;
  std::unique_ptr<RedisConnection> connect();
  // A connection of the handler pool (made when none is free, subject to the backoff).
  class Lease;
  void fetch_loop();
  void heartbeat_loop();
  void run_job(const std::string& entry, const std::string& id);
  void finish(RedisConnection& c, const std::string& entry, const std::string& id, const JobSnapshot& s,
              const std::string* result);
  void ack(RedisConnection& c, const std::string& entry);
  bool local_capacity() const;
  void wake();  // the fetcher looks again at once
  void note_error(const std::string& where, const std::string& what);

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
  std::mutex cache_mutex_;
  std::vector<std::pair<std::string, Local>> cache_;  // last few results computed here, newest last

  std::atomic<bool> fetching_{true}, stopping_{false};
  std::atomic<std::uint64_t> reclaimed_{0}, errors_{0};
  std::mutex wake_mutex_;
  std::condition_variable wake_;
  std::uint64_t wakeups_ = 0;  // with wake_mutex_
  std::thread fetcher_, heartbeat_;
};

}  // namespace lipmap::server
