#include "server/http/metrics.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace lipmap::server {

namespace {

// Shortest text that reads back as the same double ("0.005", "1e+06", "+Inf").
std::string number(double v) {
  if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
  if (std::isnan(v)) return "NaN";
  char buf[64];
  for (int precision = 6; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

void header(std::string& out, const char* name, const char* type, const char* help) {
  out += "# HELP ";
  out += name;
  out += ' ';
  out += help;
  out += "\n# TYPE ";
  out += name;
  out += ' ';
  out += type;
  out += '\n';
}

void sample(std::string& out, const std::string& name, const std::string& labels, double value) {
  out += name;
  if (!labels.empty()) out += "{" + labels + "}";
  out += ' ';
  out += number(value);
  out += '\n';
}

std::string label(const char* key, const std::string& value) {
  return std::string(key) + "=\"" + prometheus_label_value(value) + "\"";
}

const std::vector<double> kLatencyBuckets{0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25,
                                          0.5,   1,      2.5,   5,    10,    30,   60,  120};
const std::vector<double> kStageBuckets{0.0001, 0.0005, 0.001, 0.005, 0.01, 0.05, 0.1,
                                        0.5,    1,      5,     10,    30,   60,   300};
const std::vector<double> kInsertedBuckets{0, 1, 10, 100, 1000, 10000, 100000, 1000000};

}  // namespace

std::string prometheus_label_value(const std::string& value) {
  std::string out;
  out.reserve(value.size());
  for (char c : value) {
    if (c == '\\') out += "\\\\";
    else if (c == '"') out += "\\\"";
    else if (c == '\n') out += "\\n";
    else out += c;
  }
  return out;
}

Histogram::Histogram(std::vector<double> upper_bounds)
    : bounds_(std::move(upper_bounds)), counts_(bounds_.size() + 1, 0) {}

void Histogram::observe(double value) {
  std::size_t i = 0;
  while (i < bounds_.size() && value > bounds_[i]) ++i;
  ++counts_[i];
  sum_ += value;
  ++count_;
}

void Histogram::render(std::string& out, const std::string& name, const std::string& labels) const {
  const std::string prefix = labels.empty() ? "" : labels + ",";
  std::uint64_t cumulative = 0;
  for (std::size_t i = 0; i < bounds_.size(); ++i) {
    cumulative += counts_[i];
    sample(out, name + "_bucket", prefix + "le=\"" + number(bounds_[i]) + "\"", static_cast<double>(cumulative));
  }
  cumulative += counts_.back();
  sample(out, name + "_bucket", prefix + "le=\"+Inf\"", static_cast<double>(cumulative));
  sample(out, name + "_sum", labels, sum_);
  sample(out, name + "_count", labels, static_cast<double>(count_));
}

Metrics::Metrics() : inserted_per_map_(kInsertedBuckets) {}

void Metrics::observe_request(const std::string& route, const std::string& method, int status, double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++requests_[{route, method, status}];
  auto it = latency_.find(route);
  if (it == latency_.end()) it = latency_.emplace(route, Histogram(kLatencyBuckets)).first;
  it->second.observe(seconds);
}

void Metrics::observe_stage(const std::string& stage, double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = stage_seconds_.find(stage);
  if (it == stage_seconds_.end()) it = stage_seconds_.emplace(stage, Histogram(kStageBuckets)).first;
  it->second.observe(seconds);
}

void Metrics::observe_inserted_vertices(long long count) {
  std::lock_guard<std::mutex> lock(mutex_);
  inserted_per_map_.observe(static_cast<double>(count));
  inserted_total_ += static_cast<std::uint64_t>(count < 0 ? 0 : count);
  ++maps_total_;
}

void Metrics::count_rejected(const std::string& reason) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++rejected_[reason];
}

void Metrics::count_job_finished(const std::string& state) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++jobs_finished_[state];
}

void Metrics::count_results_dropped(const std::string& why) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++results_dropped_[why];
}

std::string Metrics::render(const RuntimeGauges& g) const {
  std::string out;
  out.reserve(8192);
  std::lock_guard<std::mutex> lock(mutex_);

  header(out, "lipmap_http_requests_total", "counter", "HTTP requests answered, by route template, method and status.");
  for (const auto& [key, n] : requests_) {
    const auto& [route, method, status] = key;
    sample(out, "lipmap_http_requests_total",
           label("route", route) + "," + label("method", method) + "," + label("status", std::to_string(status)),
           static_cast<double>(n));
  }
  header(out, "lipmap_http_request_duration_seconds", "histogram",
         "Time from the start of routing to the answer, by route template.");
  for (const auto& [route, h] : latency_) h.render(out, "lipmap_http_request_duration_seconds", label("route", route));

  header(out, "lipmap_workers", "gauge", "Engine worker threads.");
  sample(out, "lipmap_workers", "", static_cast<double>(g.workers));
  header(out, "lipmap_workers_busy", "gauge", "Engine worker threads running a task.");
  sample(out, "lipmap_workers_busy", "", static_cast<double>(g.workers_busy));
  header(out, "lipmap_queue_depth", "gauge", "Tasks waiting for a worker.");
  sample(out, "lipmap_queue_depth", "", static_cast<double>(g.queue_depth));
  header(out, "lipmap_queue_capacity", "gauge", "Bound of the task queue; a full queue answers 503.");
  sample(out, "lipmap_queue_capacity", "", static_cast<double>(g.queue_capacity));
  header(out, "lipmap_rejected_total", "counter", "Requests refused before any work, by reason.");
  for (const char* reason : {"queue_full", "shutting_down", "too_many_connections"}) {
    auto it = rejected_.find(reason);
    sample(out, "lipmap_rejected_total", label("reason", reason),
           it == rejected_.end() ? 0.0 : static_cast<double>(it->second));
  }

  header(out, "lipmap_jobs", "gauge", "Asynchronous jobs held by the job store, by state.");
  for (const auto& [state, n] : g.jobs_by_state) sample(out, "lipmap_jobs", label("state", state), static_cast<double>(n));
  header(out, "lipmap_jobs_finished_total", "counter", "Asynchronous jobs that reached a final state, by state.");
  for (const char* state : {"succeeded", "failed", "cancelled"}) {
    auto it = jobs_finished_.find(state);
    sample(out, "lipmap_jobs_finished_total", label("state", state),
           it == jobs_finished_.end() ? 0.0 : static_cast<double>(it->second));
  }
  header(out, "lipmap_job_results_dropped_total", "counter",
         "Finished jobs dropped from the store: expired (time), evicted (count), deleted (DELETE).");
  for (const char* why : {"expired", "evicted", "deleted"}) {
    auto it = results_dropped_.find(why);
    sample(out, "lipmap_job_results_dropped_total", label("reason", why),
           it == results_dropped_.end() ? 0.0 : static_cast<double>(it->second));
  }

  if (g.shared_queue) {
    header(out, "lipmap_shared_queue_up", "gauge", "1 when the shared job queue (Redis) answers.");
    sample(out, "lipmap_shared_queue_up", "", g.redis_up ? 1 : 0);
    header(out, "lipmap_shared_queue_depth", "gauge", "Jobs in the shared queue waiting for a worker of any replica.");
    sample(out, "lipmap_shared_queue_depth", "", static_cast<double>(g.shared_waiting));
    header(out, "lipmap_jobs_reclaimed_total", "counter",
           "Jobs this replica took over from a replica that stopped renewing its claim.");
    sample(out, "lipmap_jobs_reclaimed_total", "", static_cast<double>(g.reclaimed));
    header(out, "lipmap_redis_errors_total", "counter", "Redis commands or connections that failed.");
    sample(out, "lipmap_redis_errors_total", "", static_cast<double>(g.redis_errors));
    header(out, "lipmap_local_results", "gauge", "Results this replica computed and keeps in memory.");
    sample(out, "lipmap_local_results", "", static_cast<double>(g.local_results));
    header(out, "lipmap_local_result_reads_total", "counter",
           "GET .../result answered from this replica's memory instead of a Redis read of the result.");
    sample(out, "lipmap_local_result_reads_total", "", static_cast<double>(g.local_result_reads));
    header(out, "lipmap_jobs_started_on_submit_total", "counter",
           "Jobs accepted by this replica and started at once on its free worker (not through the stream's fetcher).");
    sample(out, "lipmap_jobs_started_on_submit_total", "", static_cast<double>(g.started_on_submit));
  }

  header(out, "lipmap_engine_stage_seconds", "histogram", "Engine wall time per stage of finished work.");
  for (const auto& [stage, h] : stage_seconds_) h.render(out, "lipmap_engine_stage_seconds", label("stage", stage));

  header(out, "lipmap_inserted_vertices_total", "counter", "Vertices inserted by refinement, over all maps returned.");
  sample(out, "lipmap_inserted_vertices_total", "", static_cast<double>(inserted_total_));
  header(out, "lipmap_maps_total", "counter", "Maps returned (synchronous answers and finished jobs).");
  sample(out, "lipmap_maps_total", "", static_cast<double>(maps_total_));
  header(out, "lipmap_inserted_vertices", "histogram", "Vertices inserted by refinement, per map returned.");
  inserted_per_map_.render(out, "lipmap_inserted_vertices", "");

  header(out, "lipmap_draining", "gauge", "1 after SIGTERM/SIGINT while in-flight work finishes.");
  sample(out, "lipmap_draining", "", g.draining ? 1 : 0);
  header(out, "lipmap_uptime_seconds", "gauge", "Seconds since the service started.");
  sample(out, "lipmap_uptime_seconds", "", g.uptime_seconds);
  return out;
}

}  // namespace lipmap::server
