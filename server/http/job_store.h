// Asynchronous jobs of `lipmap serve` (POST /v1/jobs): state, progress by engine stage, cancellation, and
// the finished results, kept for a configurable time and count and then dropped. A dropped or deleted
// job leaves a tombstone so that its id answers 410 Gone rather than 404 (the tombstones are bounded too).
//
// JobQueue (at the end) is what the handlers see: one interface, two implementations chosen once at startup
// (Service::jobs): MemoryJobs (memory_jobs.h: the JobStore below and this process's worker pool) and RedisJobs
// (redis_jobs.h: the shared queue of --queue-url).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstddef>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/cancel.h"
#include "engine/pipeline.h"
#include "server/codec/request_loader.h"

namespace lipmap::server {

enum class JobState { queued, running, succeeded, failed, cancelled };
const char* to_string(JobState state);
inline bool is_final(JobState s) { return s == JobState::succeeded || s == JobState::failed || s == JobState::cancelled; }

// Why a token was cancelled by the service (the engine only sees Cancelled).
enum class CancelReason { none, client, shutdown };

// Progress of one engine stage as reported by lipmap::ProgressFn.
struct StageProgress {
  std::string stage;
  double fraction = 0;  // 0..1
  bool done = false;
  double ms = 0;        // wall time so far (final once done)
};

// What GET /v1/jobs/{id} shows: a consistent copy taken under the job's lock.
struct JobSnapshot {
  std::string id;
  JobState state = JobState::queued;
  std::chrono::system_clock::time_point created_at, started_at, finished_at;
  bool started = false, finished = false;
  bool cancel_requested = false;
  std::vector<StageProgress> stages;  // in pipeline order, only stages that started
  std::string current_stage;          // while running
  double fraction = 0;                // overall, 0..1
  std::optional<nlohmann::ordered_json> problem;  // failed / cancelled: the problem answer
  std::size_t result_bytes = 0;
};

class Job {
public:
  using SteadyClock = std::chrono::steady_clock;
  explicit Job(std::string id);

  const std::string& id() const { return id_; }
  // The token the worker passes to the engine. Its deadline is set once, before the job is queued.
  CancelToken& token() { return token_; }

  // The worker pool's ticket of the job's task (to take it out of the queue when it is cancelled).
  void set_ticket(std::uint64_t ticket) { ticket_.store(ticket); }
  std::uint64_t ticket() const { return ticket_.load(); }

  // Cancels the token; returns false when the job had already finished.
  bool request_cancel(CancelReason reason);
  CancelReason cancel_reason() const;

  // Worker side. mark_running returns false when the job was cancelled while queued (then it is final).
  bool mark_running();
  void report(Stage stage, double fraction);  // a lipmap::ProgressFn
  void succeed(std::shared_ptr<const std::string> result_json, std::shared_ptr<const ParametrizeResult> result);
  void fail(JobState final_state, nlohmann::ordered_json problem);

  JobSnapshot snapshot() const;
  JobState state() const;
  SteadyClock::time_point finished_steady() const;
  std::shared_ptr<const std::string> result_json() const;
  std::shared_ptr<const ParametrizeResult> result() const;
  // The SVG preview, rendered once on first request and kept with the result.
  void set_preview(std::shared_ptr<const std::string> svg);
  std::shared_ptr<const std::string> preview() const;
  // What the request came with besides the parametrize body (a glTF request's gltf::Asset), kept to answer
  // GET .../result in glTF; opaque here.
  void set_attachment(std::shared_ptr<const void> attachment) {
    std::lock_guard<std::mutex> lock(mutex_);
    attachment_ = std::move(attachment);
  }
  std::shared_ptr<const void> attachment() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return attachment_;
  }

private:
  const std::string id_;
  CancelToken token_;
  std::atomic<std::uint64_t> ticket_{0};
  mutable std::mutex mutex_;
  JobState state_ = JobState::queued;
  CancelReason cancel_reason_ = CancelReason::none;
  std::chrono::system_clock::time_point created_at_, started_at_, finished_at_;
  SteadyClock::time_point stage_started_{}, finished_steady_{};
  std::vector<StageProgress> stages_;
  std::optional<nlohmann::ordered_json> problem_;
  std::shared_ptr<const std::string> result_json_;
  std::shared_ptr<const ParametrizeResult> result_;
  std::shared_ptr<const std::string> preview_;
  std::shared_ptr<const void> attachment_;
};

class JobStore {
public:
  using Clock = std::chrono::steady_clock;
  struct Limits {
    std::size_t max_finished = 64;               // finished jobs kept; the oldest finished is evicted first
    std::chrono::milliseconds ttl{15 * 60 * 1000};  // how long a finished job is kept
    std::size_t max_tombstones = 100000;         // ids remembered after they were dropped (410 vs 404)
  };
  // on_dropped(reason) is called (outside the lock) for every job dropped: "expired", "evicted", "deleted".
  JobStore(Limits limits, std::function<void(const std::string&)> on_dropped = {});

  std::shared_ptr<Job> create();
  // Undoes create() for a job that was never queued (queue full): no tombstone.
  void discard(const std::string& id);

  enum class Lookup { found, gone, unknown };
  struct Found {
    Lookup lookup = Lookup::unknown;
    std::shared_ptr<Job> job;  // when found
    std::string gone_reason;   // when gone: expired, evicted or deleted
  };
  Found find(const std::string& id);

  // Drops a finished job (DELETE on a finished job); false when it is not held.
  bool remove(const std::string& id);

  // Call when a job reached a final state: starts its retention clock and enforces the count limit.
  void finished(const std::shared_ptr<Job>& job);
  // Drops finished jobs older than the ttl. Called on every lookup and by the server's housekeeping.
  void sweep();

  std::map<std::string, std::size_t> counts_by_state() const;
  // Every job not yet final (for shutdown).
  std::vector<std::shared_ptr<Job>> unfinished() const;
  const Limits& limits() const { return limits_; }

private:
  std::vector<std::string> sweep_locked(Clock::time_point now);  // returns the reasons of the drops
  void drop_locked(const std::string& id, const std::string& reason);

  const Limits limits_;
  std::function<void(const std::string&)> on_dropped_;
  mutable std::mutex mutex_;
  std::unordered_map<std::string, std::shared_ptr<Job>> jobs_;
  std::deque<std::pair<std::string, Clock::time_point>> finished_order_;  // (id, finished), oldest first
  std::unordered_map<std::string, std::string> tombstones_;               // id -> reason
  std::deque<std::string> tombstone_order_;
};


// ---- what the handlers see ------------------------------------------------------------------------------

// The job store cannot be reached (the shared queue's Redis is away): 503 queue_unavailable.
class QueueUnavailable : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

// Test hooks (only with --test-hooks): X-Lipmap-Test-Delay-Ms and X-Lipmap-Test-Fault (internal, bad_alloc,
// exception) make a task slow or make it fail, for the tests of deadlines, queueing and error answers.
struct TestHooks {
  long long delay_ms = 0;
  std::string fault;
};

// A request as it arrived (body, media type, glTF parameters, multipart parts): what the shared queue stores,
// enough to load the request again on any replica.
struct StoredRequest {
  std::string body;
  std::string media_type;
  gltf::Params params;
  std::map<std::string, gltf::Part> parts;
  codec::RequestInput input() const;  // views into this object
};

// What POST /v1/jobs hands over: the request parsed (the in-memory queue runs it) and as it arrived (the shared
// queue stores it), its test hooks and deadline.
struct JobRequest {
  std::shared_ptr<const codec::ParametrizeRequest> parsed;
  std::shared_ptr<const gltf::Asset> asset;  // glTF requests only
  StoredRequest stored;
  TestHooks hooks;
  std::chrono::steady_clock::time_point deadline;
};

// A finished job's result as computed (to render it: preview, glTF), with the request's glTF document.
struct ComputedResult {
  std::shared_ptr<const ParametrizeResult> result;
  std::shared_ptr<const gltf::Asset> asset;
  std::shared_ptr<const std::string> json;  // the result JSON, when kept
};

struct RuntimeGauges;

class JobQueue {
public:
  virtual ~JobQueue() = default;

  struct Submitted {
    enum class Refusal { none, queue_full, shutting_down } refusal = Refusal::none;
    JobSnapshot snapshot;  // accepted: the job, queued
    std::string full;      // queue_full: what is full ("all 2 workers are busy and 64 tasks are waiting")
  };
  // POST /v1/jobs.
  virtual Submitted submit(const JobRequest& request) = 0;

  struct Found {
    JobStore::Lookup lookup = JobStore::Lookup::unknown;
    JobSnapshot snapshot;     // when found
    std::string gone_reason;  // when gone: expired, evicted or deleted
  };
  virtual Found find(const std::string& id) = 0;

  // DELETE: a finished job is removed (its id answers 410 deleted), a queued one ends at once (cancelled), a
  // running one is asked to stop.
  enum class Cancel { unknown, gone, removed, cancelled_queued, cancel_requested };
  struct Cancelled {
    Cancel outcome = Cancel::unknown;
    Found job;  // the job as it is now (not for removed)
  };
  virtual Cancelled cancel(const std::string& id) = 0;

  // A succeeded job's result JSON; null when it is no longer held.
  virtual std::shared_ptr<const std::string> result_json(const std::string& id) = 0;
  // The computed result, while this process holds it.
  virtual std::optional<ComputedResult> computed(const std::string& id) = 0;
  // The job's request as it arrived, to compute the result again (the shared queue); nullopt when not held.
  virtual std::optional<StoredRequest> stored_request(const std::string& id) = 0;
  // A rendering of the result (kind: "preview", "gltf:glb", "gltf:gltf") made earlier, and keeping one.
  virtual std::shared_ptr<const std::string> rendering(const std::string& id, const std::string& kind) = 0;
  virtual void keep_rendering(const std::string& id, const std::string& kind,
                      std::shared_ptr<const std::string> body) = 0;

  // Whether POST /v1/jobs needs room in this process's worker pool (the shared queue has its own cap).
  virtual bool uses_local_pool() const = 0;
  // Whether the job runs in this process, which then wakes the waits (JobWaits) when it ends: a long poll need
  // not look it up again meanwhile.
  virtual bool runs_here(const std::string& id) = 0;
  // /readyz.
  virtual bool ready() = 0;
  // /metrics: the jobs by state and the queue's own gauges; drops what expired.
  virtual void sample(RuntimeGauges& gauges) = 0;
  // Housekeeping: drops finished jobs past their retention.
  virtual void sweep() = 0;
  // Shutdown: the jobs not yet final are cancelled (or, with the shared queue, left to other replicas).
  virtual void cancel_unfinished(CancelReason reason) = 0;
  // No more jobs taken; called before the worker pool is joined.
  virtual void stop() = 0;
};

// 32 lowercase hex digits from a CSPRNG-seeded generator: unguessable enough that job ids are capabilities.
std::string new_job_id();
bool looks_like_job_id(const std::string& s);

}  // namespace lipmap::server
