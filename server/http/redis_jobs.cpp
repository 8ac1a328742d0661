#include "server/http/redis_jobs.h"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <random>

#include <nlohmann/json.hpp>

#include "server/http/handlers.h"
#include "server/http/metrics.h"
#include "server/http/redis_scripts.h"
#include "server/http/service.h"

namespace lipmap::server {

using nlohmann::json;
using nlohmann::ordered_json;
using SysClock = std::chrono::system_clock;
using namespace redis_scripts;

namespace {

const std::string kStream = "lipmap:jobs";
const std::string kGroup = "workers";
// A job started this many times without finishing (its replicas died each time) fails instead of killing
// the next one too.
constexpr long long kMaxAttempts = 5;
// How long a dropped job's id still answers 410 rather than 404.
constexpr long long kTombstoneMs = 24LL * 3600 * 1000;
// The results a replica keeps in memory (LocalResults), in all.
constexpr std::size_t kLocalBytes = 256u << 20;

std::string job_key(const std::string& id) { return "lipmap:job:" + id; }
std::string req_key(const std::string& id) { return "lipmap:req:" + id; }
std::string result_key(const std::string& id) { return "lipmap:result:" + id; }
std::string gone_key(const std::string& id) { return "lipmap:gone:" + id; }
std::string rendering_key(const std::string& id, const std::string& kind) { return "lipmap:" + kind + ":" + id; }

long long now_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(SysClock::now().time_since_epoch()).count();
}
SysClock::time_point from_ms(long long ms) { return SysClock::time_point(std::chrono::milliseconds(ms)); }

std::string replica_name() {
  char host[256] = {0};
  if (gethostname(host, sizeof host - 1) != 0) host[0] = 0;
  std::random_device device;
  return std::string(host[0] ? host : "replica") + "-" + std::to_string(getpid()) + "-" +
         std::to_string(device() % 100000);
}

}  // namespace

class RedisJobs::Lease {
public:
  explicit Lease(RedisJobs& jobs) : jobs_(jobs) {
    {
      std::lock_guard<std::mutex> lock(jobs.pool_mutex_);
      if (!jobs.idle_.empty()) {
        conn_ = std::move(jobs.idle_.back());
        jobs.idle_.pop_back();
        return;
      }
      if (std::chrono::steady_clock::now() < jobs.next_attempt_)
        throw QueueUnavailable("Redis at " + jobs.url_.host + ":" + std::to_string(jobs.url_.port) +
                               " could not be reached; the next attempt is within " +
                               std::to_string(jobs.backoff_.count()) + " ms");
    }
    try {
      conn_ = jobs.connect();
    } catch (const QueueUnavailable& e) {
      std::lock_guard<std::mutex> lock(jobs.pool_mutex_);
      jobs.backoff_ = std::clamp(jobs.backoff_ * 2, std::chrono::milliseconds(100), std::chrono::milliseconds(5000));
      jobs.next_attempt_ = std::chrono::steady_clock::now() + jobs.backoff_;
      jobs.note_error("connect", e.what());
      throw;
    }
    std::lock_guard<std::mutex> lock(jobs.pool_mutex_);
    jobs.backoff_ = std::chrono::milliseconds(0);
  }
  ~Lease() {
    if (!conn_ || conn_->broken()) return;
    std::lock_guard<std::mutex> lock(jobs_.pool_mutex_);
    if (jobs_.idle_.size() < 32) jobs_.idle_.push_back(std::move(conn_));
  }
  Reply operator()(const std::vector<std::string>& args) {
    try {
      return conn_->command(args);
    } catch (const QueueUnavailable& e) {
      jobs_.note_error(args.empty() ? "" : args[0], e.what());
      throw;
    }
  }
  RedisConnection& connection() { return *conn_; }

private:
  RedisJobs& jobs_;
  std::unique_ptr<RedisConnection> conn_;
};

// ---- RedisJobs --------------------------------------------------------------------------------------------

struct RedisJobs::Running {
  std::string entry;
  Job job;
  Running(std::string e, std::string id) : entry(std::move(e)), job(std::move(id)) {}
};

RedisJobs::RedisJobs(Service& service)
    : service_(service),
      url_(parse_redis_url(service.config.queue_url)),
      consumer_(replica_name()),
      visibility_(static_cast<long long>(service.config.queue_visibility_seconds * 1000)),
      ttl_(std::max<long long>(1, static_cast<long long>(service.config.result_ttl_seconds * 1000))),
      local_(service.config.max_results, kLocalBytes, ttl_),
      handoffs_(std::max<std::size_t>(service.config.queue_capacity, 1)) {
  fetcher_ = std::thread([this] { fetch_loop(); });
  heartbeat_ = std::thread([this] { heartbeat_loop(); });
}

RedisJobs::~RedisJobs() { stop(); }

void RedisJobs::stop() {
  stopping_ = true;
  fetching_ = false;
  wake_.notify_all();
  if (fetcher_.joinable()) fetcher_.join();
  if (heartbeat_.joinable()) heartbeat_.join();
}

void RedisJobs::cancel_unfinished(CancelReason) {
  if (fetching_) {
    fetching_ = false;
    wake_.notify_all();
  } else {
    hand_back_running();
  }
}

std::unique_ptr<RedisConnection> RedisJobs::connect() {
  return std::make_unique<RedisConnection>(url_, std::chrono::milliseconds(2000));
}

void RedisJobs::note_error(const std::string& where, const std::string& what) {
  ++errors_;
  service_.event(spdlog::level::warn, {{"event", "redis_error"}, {"command", where}, {"detail", what}});
}

bool RedisJobs::local_capacity() const {
  return service_.pool.busy() + service_.pool.queue_depth() < service_.pool.workers();
}

JobQueue::Submitted RedisJobs::submit(const JobRequest& request) {
  Submitted out;
  try {
    out.snapshot.id = enqueue(request);
    out.snapshot.created_at = SysClock::now();
  } catch (const SharedQueueFull& full) {
    out.refusal = Submitted::Refusal::queue_full;
    out.full = std::to_string(full.waiting) + " jobs wait in the shared queue, its limit";
  }
  return out;
}

std::string RedisJobs::enqueue(const JobRequest& job) {
  const StoredRequest& request = job.stored;
  const std::string id = new_job_id();
  const long long created = now_ms();
  const long long deadline_ms =
      created + std::chrono::duration_cast<std::chrono::milliseconds>(job.deadline - std::chrono::steady_clock::now()).count();
  // Until it finishes a job is kept for its deadline plus the retention time (and the visibility timeout, for
  // a last run that is taken over).
  const long long keep = std::max<long long>(deadline_ms - created, 0) + ttl_.count() + visibility_.count() + 60000;
  Lease redis(*this);
  std::vector<std::string> hset{"HSET", req_key(id), "media_type", request.media_type, "body", request.body};
  auto param = [&](const char* name, const std::optional<std::string>& v) {
    if (v) {
      hset.push_back(std::string("p:") + name);
      hset.push_back(*v);
    }
  };
  param("mesh", request.params.mesh);
  param("primitive", request.params.primitive);
  param("weld", request.params.weld);
  param("boundary", request.params.boundary);
  param("metric", request.params.metric);
  for (const auto& [name, part] : request.parts)
    hset.insert(hset.end(), {"part:" + name, part.content, "ptype:" + name, part.content_type});
  // Handed over before the job is in the stream: this replica's fetcher may take it from there before the
  // answer below has come back, and must then find the parsed request rather than parse the stored one again.
  if (job.parsed) handoffs_.put(id, {job.parsed, job.asset});
  // With a free worker here, the job starts on it now: the engine runs while the request is written, and goes
  // on only if the submit script started the job on this replica (else it is dropped, the job left to the
  // stream). A job not accepted (queue full, Redis away) never went on.
  std::promise<bool> accepted;
  const std::shared_ptr<Running> local = start_on_submit(job, id, accepted.get_future().share());
  bool opened = false;
  auto drop_local = [&] {
    if (!local || opened) return;
    local->job.request_cancel(CancelReason::shutdown);  // the engine stops at its next check
    accepted.set_value(false);
    opened = true;
  };
  try {
    // One round trip: the request, its expiry, then the job (refused when the shared queue is full), and for a
    // job started here the end of the fetcher's blocking read (it would take a job from the stream for the
    // worker this one has just taken).
    std::vector<std::vector<std::string>> commands{
        std::move(hset),
        {"PEXPIRE", req_key(id), std::to_string(keep)},
        {"EVAL", kSubmit, "2", kStream, job_key(id), std::to_string(service_.config.queue_capacity), id,
         std::to_string(created), std::to_string(deadline_ms), std::to_string(job.hooks.delay_ms), job.hooks.fault,
         std::to_string(keep), local ? consumer_ : std::string(), std::to_string(now_ms())}};
    const long long fetcher = fetcher_client_;
    if (local && fetcher >= 0) commands.push_back({"CLIENT", "UNBLOCK", std::to_string(fetcher)});
    std::vector<Reply> replies = redis.connection().pipeline(commands, local && fetcher >= 0);
    const Reply& r = replies[2];
    if (!is_array(r.get(), 2)) throw QueueUnavailable("Redis: unexpected answer to the submit script");
    const long long verdict = integer(r->element[0]);
    if (verdict == 0) {
      drop_local();
      redis({"DEL", req_key(id)});
      throw SharedQueueFull(static_cast<std::size_t>(integer(r->element[1])));
    }
    if (verdict == 2 && local) {
      handoffs_.take(id);
      local->entry = str(r->element[1]);
      {
        std::lock_guard<std::mutex> lock(running_mutex_);
        running_[id] = local;  // the heartbeat keeps its claim from now on
      }
      opened = true;
      accepted.set_value(true);
      ++started_on_submit_;
      service_.event(spdlog::level::info, {{"event", "job_started"}, {"job_id", id}, {"attempt", 1},
                                           {"consumer", consumer_}, {"on_submit", true}});
      return id;
    }
    drop_local();
    // Another entry read for this consumer instead (not expected: nothing waited before this one).
    if (verdict == 3 && is_array(r.get(), 3)) dispatch(str(r->element[1]), str(r->element[2]));
  } catch (...) {
    handoffs_.take(id);  // not accepted: nothing to hand over
    drop_local();
    throw;
  }
  wake();
  return id;
}

void RedisJobs::wake() {
  {
    std::lock_guard<std::mutex> lock(wake_mutex_);
    ++wakeups_;
  }
  wake_.notify_all();
}

namespace {

JobState state_from(const std::string& s) {
  for (JobState st : {JobState::queued, JobState::running, JobState::succeeded, JobState::failed, JobState::cancelled})
    if (s == to_string(st)) return st;
  return JobState::failed;
}

// The progress member as kept in job:{id} (what Job::snapshot reports), and back.
std::string progress_text(const JobSnapshot& s) {
  ordered_json p;
  p["fraction"] = s.fraction;
  p["stage"] = s.current_stage;
  p["stages"] = ordered_json::array();
  for (const StageProgress& st : s.stages)
    p["stages"].push_back({{"stage", st.stage}, {"fraction", st.fraction}, {"done", st.done}, {"ms", st.ms}});
  return p.dump();
}

void read_progress(const std::string& text, JobSnapshot& s) {
  if (text.empty()) return;
  const json p = json::parse(text, nullptr, false);
  if (!p.is_object()) return;
  s.fraction = p.value("fraction", 0.0);
  if (s.state == JobState::running) s.current_stage = p.value("stage", "");
  if (p.contains("stages") && p["stages"].is_array())
    for (const json& st : p["stages"])
      s.stages.push_back(StageProgress{st.value("stage", ""), st.value("fraction", 0.0), st.value("done", false),
                                       st.value("ms", 0.0)});
}

std::map<std::string, std::string> hash_of(const redisReply* r) {
  std::map<std::string, std::string> out;
  if (!is_array(r)) return out;
  for (std::size_t i = 0; i + 1 < r->elements; i += 2) out[str(r->element[i])] = str(r->element[i + 1]);
  return out;
}

}  // namespace

RedisJobs::Found RedisJobs::find(const std::string& id) {
  Lease redis(*this);
  Found f;
  const auto h = hash_of(redis({"HGETALL", job_key(id)}).get());
  if (h.count("state")) {
    f.lookup = JobStore::Lookup::found;
    JobSnapshot& s = f.snapshot;
    s.id = id;
    s.state = state_from(h.at("state"));
    auto ms = [&](const char* k) -> long long { return h.count(k) ? std::atoll(h.at(k).c_str()) : 0; };
    s.created_at = from_ms(ms("created"));
    s.started = s.state != JobState::queued && ms("started") != 0;
    s.started_at = from_ms(ms("started"));
    s.finished = is_final(s.state);
    s.finished_at = from_ms(ms("finished"));
    s.cancel_requested = h.count("cancel") && h.at("cancel") == "1";
    if (h.count("progress")) read_progress(h.at("progress"), s);
    if (s.state == JobState::succeeded) s.fraction = 1;
    if (h.count("problem") && !h.at("problem").empty()) {
      ordered_json p = ordered_json::parse(h.at("problem"), nullptr, false);
      if (!p.is_discarded()) s.problem = std::move(p);
    }
    s.result_bytes = static_cast<std::size_t>(ms("result_bytes"));
    return f;
  }
  const std::string gone = str(redis({"GET", gone_key(id)}).get());
  if (!gone.empty()) {
    f.lookup = JobStore::Lookup::gone;
    f.gone_reason = gone;
  }
  return f;
}

JobQueue::Cancelled RedisJobs::cancel(const std::string& id) {
  Cancelled out;
  out.outcome = cancel_in_redis(id);
  if (out.outcome != Cancel::removed) out.job = find(id);
  return out;
}

JobQueue::Cancel RedisJobs::cancel_in_redis(const std::string& id) {
  Lease redis(*this);
  const std::string problem_json =
      problem("cancelled", "the job was cancelled at the client's request before it started").dump();
  const std::string before = str(redis({"EVAL", kCancel, "1", job_key(id), problem_json, std::to_string(now_ms())}).get());
  if (before == "missing") {
    return str(redis({"GET", gone_key(id)}).get()).empty() ? Cancel::unknown : Cancel::gone;
  }
  if (before == "queued") {
    const std::string entry = str(redis({"HGET", job_key(id), "entry"}).get());
    if (!entry.empty()) {
      redis({"XACK", kStream, kGroup, entry});
      redis({"XDEL", kStream, entry});
    }
    const std::string keep = std::to_string(ttl_.count());
    redis({"PEXPIRE", job_key(id), keep});
    redis({"PEXPIRE", req_key(id), keep});
    redis({"SET", gone_key(id), "expired", "PX", std::to_string(ttl_.count() + kTombstoneMs)});
    return Cancel::cancelled_queued;
  }
  if (before == "running") return Cancel::cancel_requested;
  // Finished: DELETE drops it.
  redis({"DEL", job_key(id), req_key(id), result_key(id), rendering_key(id, "preview"), rendering_key(id, "gltf:glb"),
         rendering_key(id, "gltf:gltf")});
  redis({"SET", gone_key(id), "deleted", "PX", std::to_string(kTombstoneMs)});
  local_.erase(id);
  return Cancel::removed;
}

std::shared_ptr<const std::string> RedisJobs::result_json(const std::string& id) {
  if (std::optional<ComputedResult> mine = local_.get(id); mine && mine->json) {
    ++local_reads_;
    return mine->json;
  }
  Lease redis(*this);
  Reply r = redis({"GET", result_key(id)});
  if (r->type != REDIS_REPLY_STRING) return nullptr;
  return std::make_shared<const std::string>(r->str, r->len);
}

std::shared_ptr<const std::string> RedisJobs::rendering(const std::string& id, const std::string& kind) {
  Lease redis(*this);
  Reply r = redis({"GET", rendering_key(id, kind)});
  if (r->type != REDIS_REPLY_STRING) return nullptr;
  return std::make_shared<const std::string>(r->str, r->len);
}

void RedisJobs::keep_rendering(const std::string& id, const std::string& kind,
                               std::shared_ptr<const std::string> body) {
  Lease redis(*this);
  // As long as the job itself is kept.
  const long long left = integer(redis({"PTTL", job_key(id)}).get());
  if (left <= 0) return;
  redis({"SET", rendering_key(id, kind), *body, "PX", std::to_string(left)});
}

std::optional<StoredRequest> RedisJobs::stored_request(const std::string& id) {
  Lease redis(*this);
  auto h = hash_of(redis({"HGETALL", req_key(id)}).get());
  if (!h.count("media_type")) return std::nullopt;
  StoredRequest s;
  s.media_type = h["media_type"];
  s.body = h["body"];
  for (const auto& [k, v] : h) {
    if (k == "p:mesh") s.params.mesh = v;
    else if (k == "p:primitive") s.params.primitive = v;
    else if (k == "p:weld") s.params.weld = v;
    else if (k == "p:boundary") s.params.boundary = v;
    else if (k == "p:metric") s.params.metric = v;
    else if (k.rfind("part:", 0) == 0) s.parts[k.substr(5)].content = v;
    else if (k.rfind("ptype:", 0) == 0) s.parts[k.substr(6)].content_type = v;
  }
  return s;
}

std::optional<ComputedResult> RedisJobs::computed(const std::string& id) { return local_.get(id); }

bool RedisJobs::ready() {
  try {
    Lease redis(*this);
    return str(redis({"PING"}).get()) == "PONG";
  } catch (const QueueUnavailable&) {
    return false;
  }
}

void RedisJobs::sample(RuntimeGauges& g) {
  // Jobs are not held here: every state counts zero (the shared queue's gauges say what waits).
  for (JobState s : {JobState::queued, JobState::running, JobState::succeeded, JobState::failed, JobState::cancelled})
    g.jobs_by_state[to_string(s)] = 0;
  g.shared_queue = true;
  const long long n = waiting();
  g.redis_up = n >= 0;
  g.shared_waiting = std::max(n, 0LL);
  g.reclaimed = reclaimed_;
  g.redis_errors = errors_;
  g.local_results = local_.size();
  g.local_result_reads = local_reads_;
  g.started_on_submit = started_on_submit_;
}

long long RedisJobs::waiting() {
  try {
    Lease redis(*this);
    long long n = integer(redis({"XLEN", kStream}).get());
    try {
      Reply p = redis({"XPENDING", kStream, kGroup});
      if (is_array(p.get(), 1)) n -= integer(p->element[0]);
    } catch (const ReplyError&) {  // no group yet: nothing pending
    }
    return std::max<long long>(n, 0);
  } catch (const QueueUnavailable&) {
    return -1;
  }
}

// ---- the replica's side: taking jobs, running them, keeping their claims ----------------------------------

void RedisJobs::fetch_loop() {
  std::unique_ptr<RedisConnection> c;
  std::chrono::milliseconds backoff{0};
  bool group_ready = false;
  // Waits for d, or until a worker frees up or a job is submitted here (wake()).
  auto pause = [&](std::chrono::milliseconds d) {
    std::unique_lock<std::mutex> lock(wake_mutex_);
    const std::uint64_t seen = wakeups_;
    wake_.wait_for(lock, d, [&] { return stopping_.load() || wakeups_ != seen; });
  };
  // One entry of a stream reply ([id, [field, value ...]]): dispatched to the pool.
  auto take = [&](const redisReply* e) {
    if (!is_array(e, 2) || !is_array(e->element[1])) return;
    const std::string entry = str(e->element[0]);
    std::string id;
    const redisReply* fields = e->element[1];
    for (std::size_t i = 0; i + 1 < fields->elements; i += 2)
      if (str(fields->element[i]) == "id") id = str(fields->element[i + 1]);
    if (id.empty()) {
      c->command({"XACK", kStream, kGroup, entry});
      c->command({"XDEL", kStream, entry});
      return;
    }
    dispatch(entry, id);
  };
  while (!stopping_) {
    if (!fetching_) {
      pause(std::chrono::milliseconds(200));
      continue;
    }
    try {
      if (!c || c->broken()) {
        c.reset();
        fetcher_client_ = -1;
        group_ready = false;
        c = connect();
        // A job started on submit ends this connection's blocking read (CLIENT UNBLOCK), so that the fetcher
        // does not take a job from the stream for the worker just taken.
        try {
          fetcher_client_ = integer(c->command({"CLIENT", "ID"}).get());
        } catch (const ReplyError&) {  // CLIENT renamed away: the read ends by its own timeout
        }
        if (backoff.count() > 0)
          service_.event(spdlog::level::info, {{"event", "redis_reconnected"}, {"consumer", consumer_}});
        backoff = std::chrono::milliseconds(0);
      }
      if (!group_ready) {
        try {
          c->command({"XGROUP", "CREATE", kStream, kGroup, "0", "MKSTREAM"});
        } catch (const ReplyError&) {  // BUSYGROUP: it exists
        }
        group_ready = true;
      }
      if (!local_capacity()) {
        pause(std::chrono::milliseconds(2));  // a worker is about to be free (wake() comes just before)
        continue;
      }
      // First the entries whose replica stopped renewing its claim, then new ones.
      Reply claimed = c->command({"XAUTOCLAIM", kStream, kGroup, consumer_, std::to_string(visibility_.count()), "0-0",
                                  "COUNT", "1"});
      if (is_array(claimed.get(), 2) && is_array(claimed->element[1], 1)) {
        ++reclaimed_;
        service_.event(spdlog::level::warn, {{"event", "job_reclaimed"}, {"entry", str(claimed->element[1]->element[0]->element[0])}});
        take(claimed->element[1]->element[0]);
        continue;
      }
      Reply fresh = c->command({"XREADGROUP", "GROUP", kGroup, consumer_, "COUNT", "1", "BLOCK", "500", "STREAMS",
                                kStream, ">"});
      if (is_array(fresh.get(), 1) && is_array(fresh->element[0], 2) && is_array(fresh->element[0]->element[1], 1))
        take(fresh->element[0]->element[1]->element[0]);
    } catch (const ReplyError& e) {
      // NOGROUP after Redis lost its data (a restart without persistence): make the group again.
      group_ready = false;
      note_error("fetch", e.what());
      pause(std::chrono::milliseconds(100));
    } catch (const QueueUnavailable& e) {
      c.reset();
      note_error("fetch", e.what());
      backoff = std::clamp(backoff * 2, std::chrono::milliseconds(100), std::chrono::milliseconds(5000));
      pause(backoff);
    }
  }
}

void RedisJobs::dispatch(const std::string& entry, const std::string& id) {
  // Refused (a burst of synchronous work filled the pool): the entry stays pending and is taken over after
  // the visibility timeout.
  if (service_.pool.submit([this, entry, id] { run_job(entry, id); }) != WorkerPool::Submit::accepted)
    service_.event(spdlog::level::warn, {{"event", "job_not_taken"}, {"job_id", id}});
}

void RedisJobs::heartbeat_loop() {
  // Often enough that a live replica's claim never reaches the visibility timeout, and that a DELETE is seen
  // within a second.
  const auto period = std::clamp(visibility_ / 4, std::chrono::milliseconds(50), std::chrono::milliseconds(1000));
  std::unique_ptr<RedisConnection> c;
  while (!stopping_) {
    {
      std::unique_lock<std::mutex> lock(wake_mutex_);
      wake_.wait_for(lock, period, [this] { return stopping_.load(); });
    }
    std::vector<std::pair<std::string, std::shared_ptr<Running>>> jobs;
    {
      std::lock_guard<std::mutex> lock(running_mutex_);
      jobs.assign(running_.begin(), running_.end());
    }
    if (jobs.empty()) continue;
    try {
      if (!c || c->broken()) c = connect();
      for (const auto& [id, r] : jobs) {
        c->command({"XCLAIM", kStream, kGroup, consumer_, "0", r->entry, "JUSTID"});
        if (str(c->command({"EVAL", kBeat, "1", job_key(id), progress_text(r->job.snapshot())}).get()) == "1")
          r->job.request_cancel(CancelReason::client);
      }
    } catch (const QueueUnavailable& e) {
      c.reset();
      note_error("heartbeat", e.what());
    }
  }
}

void RedisJobs::ack(RedisConnection& c, const std::string& entry) {
  c.pipeline({{"XACK", kStream, kGroup, entry}, {"XDEL", kStream, entry}});
}

void RedisJobs::finish(RedisConnection& c, const std::string& entry, const std::string& id, const JobSnapshot& s,
                       const std::string* result) {
  // One round trip: the result, the job's final state, and the stream entry acknowledged and deleted.
  std::vector<std::vector<std::string>> commands;
  if (result) commands.push_back({"SET", result_key(id), *result, "PX", std::to_string(ttl_.count())});
  commands.push_back({"EVAL", kFinish, "5", job_key(id), result_key(id), req_key(id), gone_key(id), kStream, to_string(s.state),
                      s.problem ? s.problem->dump(-1, ' ', false, ordered_json::error_handler_t::replace) : std::string(),
                      result ? "1" : "", std::to_string(now_ms()), std::to_string(s.result_bytes), progress_text(s),
                      std::to_string(ttl_.count()), std::to_string(ttl_.count() + kTombstoneMs), entry});
  std::vector<Reply> replies;
  try {
    replies = c.pipeline(commands);
  } catch (const ReplyError& e) {
    // Redis refused a write (e.g. out of memory): the job stays running and its entry pending, so it is taken
    // over and finished later rather than marked succeeded without its result.
    throw QueueUnavailable(e.what());
  }
  if (str(replies.back().get()) == "no_result") throw QueueUnavailable("Redis did not keep the result");
}

void RedisJobs::run_job(const std::string& entry, const std::string& id) {
  try {
    Lease redis(*this);
    // One round trip: the start, then the job's fields (read only when it starts).
    std::vector<Reply> start = redis.connection().pipeline(
        {{"EVAL", kStart, "1", job_key(id), std::to_string(now_ms()), consumer_}, {"HGETALL", job_key(id)}});
    const Reply& started = start[0];
    const std::string verdict = is_array(started.get(), 2) ? str(started->element[0]) : "missing";
    if (verdict != "run") {  // finished, cancelled while queued, or no longer held
      ack(redis.connection(), entry);
      wake();
      return;
    }
    const long long attempts = integer(started->element[1]);
    auto h = hash_of(start[1].get());
    auto running = std::make_shared<Running>(entry, id);
    Job& job = running->job;
    job.mark_running();
    const long long deadline_ms = std::atoll(h["deadline"].c_str());
    job.token().set_deadline(std::chrono::steady_clock::now() + std::chrono::milliseconds(deadline_ms - now_ms()));
    if (h["cancel"] == "1") job.request_cancel(CancelReason::client);
    TestHooks hooks;
    hooks.delay_ms = std::atoll(h["delay_ms"].c_str());
    hooks.fault = h["fault"];
    // Accepted here: the request as parsed then; else (another replica accepted it, or this is a rerun after a
    // takeover) the stored one, loaded again.
    std::optional<Handoffs::Parsed> parsed = handoffs_.take(id);
    std::optional<StoredRequest> stored;
    if (!parsed) stored = stored_request(id);
    {
      std::lock_guard<std::mutex> lock(running_mutex_);
      running_[id] = running;
    }
    service_.event(spdlog::level::info, {{"event", "job_started"}, {"job_id", id}, {"attempt", attempts}, {"consumer", consumer_}});
    Outcome outcome = execute(job, attempts, std::move(parsed), stored, hooks);
    conclude(redis, running, std::move(outcome));
  } catch (const QueueUnavailable& e) {
    leave_pending(id, e.what());
  }
}

std::shared_ptr<RedisJobs::Running> RedisJobs::start_on_submit(const JobRequest& request, const std::string& id,
                                                               std::shared_future<bool> accepted) {
  if (!request.parsed || !fetching_ || stopping_) return nullptr;
  std::lock_guard<std::mutex> lock(start_mutex_);
  if (!local_capacity()) return nullptr;
  auto running = std::make_shared<Running>(std::string(), id);
  running->job.token().set_deadline(request.deadline);
  Handoffs::Parsed parsed{request.parsed, request.asset};
  TestHooks hooks = request.hooks;
  if (service_.pool.submit([this, running, accepted, parsed, hooks] { run_on_submit(running, accepted, parsed, hooks); }) !=
      WorkerPool::Submit::accepted)
    return nullptr;
  return running;
}

void RedisJobs::run_on_submit(const std::shared_ptr<Running>& running, const std::shared_future<bool>& accepted,
                              const Handoffs::Parsed& parsed, const TestHooks& hooks) {
  running->job.mark_running();
  Outcome outcome = execute(running->job, 1, parsed, std::nullopt, hooks);
  bool go = false;
  try {
    go = accepted.get();
  } catch (const std::future_error&) {  // the submit failed: the job was not accepted
  }
  if (!go) {  // not accepted, or left in the stream for any replica: this run is dropped
    wake();
    return;
  }
  const std::string& id = running->job.id();
  try {
    Lease redis(*this);
    conclude(redis, running, std::move(outcome));
  } catch (const QueueUnavailable& e) {
    leave_pending(id, e.what());
  }
}

// Redis went away while the job ended here: its entry stays pending and is taken over (run again) later.
void RedisJobs::leave_pending(const std::string& id, const char* why) {
  {
    std::lock_guard<std::mutex> lock(running_mutex_);
    running_.erase(id);
  }
  wake();
  note_error("job", why);
  service_.event(spdlog::level::warn, {{"event", "job_left_pending"}, {"job_id", id}, {"detail", why}});
}

RedisJobs::Outcome RedisJobs::execute(Job& job, long long attempts, std::optional<Handoffs::Parsed> parsed,
                                      const std::optional<StoredRequest>& stored, const TestHooks& hooks) {
  Outcome out;
  try {
    if (attempts > kMaxAttempts)
      throw InternalError("the job was started " + std::to_string(attempts - 1) +
                          " times and its replica stopped each time before it finished");
    if (!parsed && !stored) throw InternalError("the job's request is no longer held by the shared queue");
    job.token().check();
    apply_hooks(hooks, job.token());
    if (!parsed) {
      codec::LoadedRequest loaded = codec::load_request(stored->input());
      parsed.emplace();
      parsed->request = std::make_shared<const codec::ParametrizeRequest>(std::move(loaded.request));
      if (loaded.asset) parsed->asset = std::make_shared<const gltf::Asset>(std::move(*loaded.asset));
    }
    MapOutcome m = run_map(*parsed->request, job.token(), [&job](Stage st, double f) { job.report(st, f); },
                           service_.metrics);
    if (m.json->size() > service_.config.max_result_bytes) {
      job.fail(JobState::failed,
               problem("result_too_large", "the result has " + std::to_string(m.json->size()) +
                                               " bytes; the shared queue keeps at most " +
                                               std::to_string(service_.config.max_result_bytes)));
    } else {
      out.text = m.json;
      out.local.result = m.result;
      out.local.asset = parsed->asset;
      job.succeed(m.json, m.result);
    }
  } catch (...) {
    const CancelReason reason = job.cancel_reason();
    ordered_json p = current_exception_problem(InputKind::parametrize, reason, service_.config.deadline_seconds);
    job.fail(reason == CancelReason::none ? JobState::failed : JobState::cancelled, std::move(p));
  }
  return out;
}

void RedisJobs::conclude(Lease& redis, const std::shared_ptr<Running>& running, Outcome outcome) {
  const std::string& id = running->job.id();
  const std::string& entry = running->entry;
  Job& job = running->job;
  {
    std::lock_guard<std::mutex> lock(running_mutex_);
    running_.erase(id);
  }
  if (job.cancel_reason() == CancelReason::shutdown) {
    // This replica stops: another one runs the job.
    redis({"EVAL", kHandBack, "2", kStream, job_key(id), entry, id});
    service_.event(spdlog::level::info, {{"event", "job_handed_back"}, {"job_id", id}});
    wake();
    return;
  }
  const JobSnapshot s = job.snapshot();
  // Redis may be restarting: a few tries, then the entry stays pending and is taken over (and run again)
  // once Redis is back.
  for (int attempt = 0;; ++attempt) {
    try {
      if (attempt == 0) {
        finish(redis.connection(), entry, id, s, outcome.text.get());
      } else {
        Lease again(*this);
        finish(again.connection(), entry, id, s, outcome.text.get());
      }
      break;
    } catch (const ReplyError&) {
      throw;
    } catch (const QueueUnavailable& e) {
      if (attempt >= 8 || stopping_) throw;
      std::this_thread::sleep_for(std::chrono::milliseconds(250LL << std::min(attempt, 3)));
    }
  }
  if (outcome.text) {
    outcome.local.json = outcome.text;
    local_.put(id, std::move(outcome.local));
  }
  service_.waits.notify();  // the polls waiting here for this job answer now
  wake();  // this worker is free: the fetcher may take the next job now
  service_.metrics.count_job_finished(to_string(s.state));
  service_.event(spdlog::level::info, {{"event", "job_finished"},
                                       {"job_id", id},
                                       {"state", to_string(s.state)},
                                       {"code", s.problem ? s.problem->value("code", "") : ""},
                                       {"result_bytes", s.result_bytes}});
}

void RedisJobs::hand_back_running() {
  std::lock_guard<std::mutex> lock(running_mutex_);
  for (auto& [id, r] : running_) r->job.request_cancel(CancelReason::shutdown);
}

}  // namespace lipmap::server
