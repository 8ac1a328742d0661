#include "server/http/job_store.h"

#include <algorithm>
#include <array>
#include <random>

namespace lipmap::server {

namespace {

constexpr std::array<Stage, 10> kStages{Stage::validate,          Stage::classify, Stage::target_mesh,
                                        Stage::intermediate_maps, Stage::compose,  Stage::untangle,
                                        Stage::refine,            Stage::optimize, Stage::verify,
                                        Stage::quality};

std::size_t stage_index(Stage s) {
  return static_cast<std::size_t>(std::find(kStages.begin(), kStages.end(), s) - kStages.begin());
}

}  // namespace

const char* to_string(JobState state) {
  switch (state) {
    case JobState::queued: return "queued";
    case JobState::running: return "running";
    case JobState::succeeded: return "succeeded";
    case JobState::failed: return "failed";
    case JobState::cancelled: return "cancelled";
  }
  return "failed";
}

// ---- Job ------------------------------------------------------------------------------------------------

Job::Job(std::string id) : id_(std::move(id)), created_at_(std::chrono::system_clock::now()) {}

bool Job::request_cancel(CancelReason reason) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (is_final(state_)) return false;
  if (cancel_reason_ == CancelReason::none) cancel_reason_ = reason;
  token_.cancel();
  return true;
}

CancelReason Job::cancel_reason() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return cancel_reason_;
}

bool Job::mark_running() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_ != JobState::queued) return false;
  state_ = JobState::running;
  started_at_ = std::chrono::system_clock::now();
  return true;
}

void Job::report(Stage stage, double fraction) {
  const auto now = SteadyClock::now();
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_ != JobState::running) return;
  const std::string name = lipmap::to_string(stage);
  fraction = std::clamp(fraction, 0.0, 1.0);
  if (stages_.empty() || stages_.back().stage != name) {
    // A new stage: the ones before it are over.
    for (StageProgress& p : stages_) {
      if (!p.done) {
        p.done = true;
        p.fraction = 1;
        p.ms = std::chrono::duration<double, std::milli>(now - stage_started_).count();
      }
    }
    stages_.push_back(StageProgress{name, fraction, false, 0});
    stage_started_ = now;
  }
  StageProgress& p = stages_.back();
  p.fraction = std::max(p.fraction, fraction);
  p.ms = std::chrono::duration<double, std::milli>(now - stage_started_).count();
  if (fraction >= 1) p.done = true;
}

void Job::succeed(std::shared_ptr<const std::string> result_json, std::shared_ptr<const ParametrizeResult> result) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (is_final(state_)) return;
  state_ = JobState::succeeded;
  for (StageProgress& p : stages_) {
    p.done = true;
    p.fraction = 1;
  }
  result_json_ = std::move(result_json);
  result_ = std::move(result);
  finished_at_ = std::chrono::system_clock::now();
  finished_steady_ = SteadyClock::now();
}

void Job::fail(JobState final_state, nlohmann::ordered_json problem) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (is_final(state_)) return;
  state_ = final_state;
  problem_ = std::move(problem);
  finished_at_ = std::chrono::system_clock::now();
  finished_steady_ = SteadyClock::now();
}

JobSnapshot Job::snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  JobSnapshot s;
  s.id = id_;
  s.state = state_;
  s.created_at = created_at_;
  s.started = state_ != JobState::queued && started_at_.time_since_epoch().count() != 0;
  s.started_at = started_at_;
  s.finished = is_final(state_);
  s.finished_at = finished_at_;
  s.cancel_requested = cancel_reason_ != CancelReason::none;
  s.stages = stages_;
  s.problem = problem_;
  s.result_bytes = result_json_ ? result_json_->size() : 0;
  if (state_ == JobState::succeeded) {
    s.fraction = 1;
  } else if (!stages_.empty()) {
    const StageProgress& last = stages_.back();
    Stage last_stage = Stage::validate;
    for (Stage st : kStages)
      if (last.stage == lipmap::to_string(st)) last_stage = st;
    s.fraction = (static_cast<double>(stage_index(last_stage)) + (last.done ? 1.0 : last.fraction)) /
                 static_cast<double>(kStages.size());
    if (state_ == JobState::running) s.current_stage = last.stage;
  }
  return s;
}

JobState Job::state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_;
}

Job::SteadyClock::time_point Job::finished_steady() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return finished_steady_;
}

std::shared_ptr<const std::string> Job::result_json() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return result_json_;
}

std::shared_ptr<const ParametrizeResult> Job::result() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return result_;
}

void Job::set_preview(std::shared_ptr<const std::string> svg) {
  std::lock_guard<std::mutex> lock(mutex_);
  preview_ = std::move(svg);
}

std::shared_ptr<const std::string> Job::preview() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return preview_;
}

// ---- JobStore -------------------------------------------------------------------------------------------

JobStore::JobStore(Limits limits, std::function<void(const std::string&)> on_dropped)
    : limits_(limits), on_dropped_(std::move(on_dropped)) {}

std::shared_ptr<Job> JobStore::create() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string id;
  do id = new_job_id();
  while (jobs_.count(id) || tombstones_.count(id));
  auto job = std::make_shared<Job>(id);
  jobs_.emplace(id, job);
  return job;
}

void JobStore::discard(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  jobs_.erase(id);
}

JobStore::Found JobStore::find(const std::string& id) {
  Found found;
  std::vector<std::string> dropped;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    dropped = sweep_locked(Clock::now());
    if (auto it = jobs_.find(id); it != jobs_.end()) {
      found.lookup = Lookup::found;
      found.job = it->second;
    } else if (auto t = tombstones_.find(id); t != tombstones_.end()) {
      found.lookup = Lookup::gone;
      found.gone_reason = t->second;
    }
  }
  if (on_dropped_)
    for (const std::string& reason : dropped) on_dropped_(reason);
  return found;
}

bool JobStore::remove(const std::string& id) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = jobs_.find(id);
    if (it == jobs_.end() || !is_final(it->second->state())) return false;
    drop_locked(id, "deleted");
    finished_order_.erase(std::remove_if(finished_order_.begin(), finished_order_.end(),
                                         [&](const auto& e) { return e.first == id; }),
                          finished_order_.end());
  }
  if (on_dropped_) on_dropped_("deleted");
  return true;
}

void JobStore::finished(const std::shared_ptr<Job>& job) {
  std::vector<std::string> dropped;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!jobs_.count(job->id())) return;
    finished_order_.emplace_back(job->id(), Clock::now());
    dropped = sweep_locked(Clock::now());
  }
  if (on_dropped_)
    for (const std::string& reason : dropped) on_dropped_(reason);
}

void JobStore::sweep() {
  std::vector<std::string> dropped;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    dropped = sweep_locked(Clock::now());
  }
  if (on_dropped_)
    for (const std::string& reason : dropped) on_dropped_(reason);
}

std::vector<std::string> JobStore::sweep_locked(Clock::time_point now) {
  std::vector<std::string> dropped;
  while (!finished_order_.empty()) {
    const auto& [id, when] = finished_order_.front();
    std::string reason;
    if (now - when >= limits_.ttl) reason = "expired";
    else if (finished_order_.size() > limits_.max_finished) reason = "evicted";
    else break;
    if (jobs_.count(id)) {
      drop_locked(id, reason);
      dropped.push_back(reason);
    }
    finished_order_.pop_front();
  }
  return dropped;
}

void JobStore::drop_locked(const std::string& id, const std::string& reason) {
  jobs_.erase(id);
  tombstones_[id] = reason;
  tombstone_order_.push_back(id);
  while (tombstone_order_.size() > limits_.max_tombstones) {
    tombstones_.erase(tombstone_order_.front());
    tombstone_order_.pop_front();
  }
}

std::map<std::string, std::size_t> JobStore::counts_by_state() const {
  std::map<std::string, std::size_t> counts;
  for (JobState s : {JobState::queued, JobState::running, JobState::succeeded, JobState::failed, JobState::cancelled})
    counts[to_string(s)] = 0;
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [id, job] : jobs_) ++counts[to_string(job->state())];
  return counts;
}

std::vector<std::shared_ptr<Job>> JobStore::unfinished() const {
  std::vector<std::shared_ptr<Job>> out;
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [id, job] : jobs_)
    if (!is_final(job->state())) out.push_back(job);
  return out;
}

codec::RequestInput StoredRequest::input() const {
  codec::RequestInput in;
  in.body = body;
  in.media_type = media_type;
  in.parts = parts;
  in.gltf_params = params;
  return in;
}

std::string new_job_id() {
  static std::mutex mutex;
  static std::mt19937_64 generator = [] {
    std::random_device device;
    std::seed_seq seed{device(), device(), device(), device(), device(), device(), device(), device()};
    return std::mt19937_64(seed);
  }();
  std::lock_guard<std::mutex> lock(mutex);
  static const char* hex = "0123456789abcdef";
  std::string id;
  id.reserve(32);
  for (int word = 0; word < 2; ++word) {
    std::uint64_t v = generator();
    for (int i = 0; i < 16; ++i, v >>= 4) id += hex[v & 0xf];
  }
  return id;
}

bool looks_like_job_id(const std::string& s) {
  return s.size() == 32 && std::all_of(s.begin(), s.end(), [](char c) {
           return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
         });
}

}  // namespace lipmap::server
