// Prometheus metrics of `lipmap serve` (text exposition format 0.0.4), kept in memory and rendered on
// GET /metrics. Thread-safe; every observation is a short critical section (the engine, not this, is what
// takes time).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <tuple>
#include <vector>

namespace lipmap::server {

// A cumulative histogram with fixed upper bounds (the +Inf bucket is implicit).
class Histogram {
public:
  explicit Histogram(std::vector<double> upper_bounds);
  void observe(double value);
  // Appends "<name>_bucket{<labels>,le=...} n", "_sum", "_count" lines; labels may be empty.
  void render(std::string& out, const std::string& name, const std::string& labels) const;

private:
  std::vector<double> bounds_;
  std::vector<std::uint64_t> counts_;  // per bucket, not cumulative; last = +Inf
  double sum_ = 0;
  std::uint64_t count_ = 0;
};

// Values that live elsewhere (pool, job store), sampled when /metrics is rendered.
struct RuntimeGauges {
  std::size_t workers = 0, workers_busy = 0, queue_depth = 0, queue_capacity = 0;
  std::map<std::string, std::size_t> jobs_by_state;  // every state, including zeros
  bool draining = false;
  double uptime_seconds = 0;
  // The shared job queue (--queue-url), when there is one.
  bool shared_queue = false;
  bool redis_up = false;
  long long shared_waiting = 0;  // jobs in the shared queue waiting for a worker of any replica
  std::uint64_t reclaimed = 0, redis_errors = 0;
  std::size_t local_results = 0;          // results this replica computed and keeps in memory
  std::uint64_t local_result_reads = 0;   // GET .../result answered from them (no Redis read of the result)
  std::uint64_t started_on_submit = 0;    // jobs accepted here and started at once on this replica's free worker
};

class Metrics {
public:
  Metrics();

  // route: the route template ("/v1/jobs/{id}", "unmatched" for unknown paths) so that label values stay few.
  void observe_request(const std::string& route, const std::string& method, int status, double seconds);
  // One engine stage's wall time (pipeline stages, and "classify" for the classify endpoint).
  void observe_stage(const std::string& stage, double seconds);
  void observe_inserted_vertices(long long count);
  void count_rejected(const std::string& reason);      // queue_full, shutting_down, too_many_connections
  void count_job_finished(const std::string& state);   // succeeded, failed, cancelled
  void count_results_dropped(const std::string& why);  // expired, evicted, deleted

  std::string render(const RuntimeGauges& gauges) const;

private:
  mutable std::mutex mutex_;
  std::map<std::tuple<std::string, std::string, int>, std::uint64_t> requests_;
  std::map<std::string, Histogram> latency_;       // by route
  std::map<std::string, Histogram> stage_seconds_; // by stage
  Histogram inserted_per_map_;
  std::uint64_t inserted_total_ = 0;
  std::uint64_t maps_total_ = 0;
  std::map<std::string, std::uint64_t> rejected_, jobs_finished_, results_dropped_;
};

// Escapes a label value for the exposition format (backslash, quote, newline).
std::string prometheus_label_value(const std::string& value);

}  // namespace lipmap::server
