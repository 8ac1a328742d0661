#include "server/http/memory_jobs.h"

#include "server/http/handlers.h"
#include "server/http/metrics.h"
#include "server/http/service.h"

namespace lipmap::server {

using nlohmann::ordered_json;

MemoryJobs::MemoryJobs(Service& service)
    : service_(service),
      store_(JobStore::Limits{service.config.max_results,
                              std::chrono::milliseconds(static_cast<long long>(service.config.result_ttl_seconds * 1000)),
                              100000},
             [&service](const std::string& why) { service.metrics.count_results_dropped(why); }) {}

std::shared_ptr<Job> MemoryJobs::held(const std::string& id) {
  JobStore::Found f = store_.find(id);
  return f.lookup == JobStore::Lookup::found ? f.job : nullptr;
}

JobQueue::Submitted MemoryJobs::submit(const JobRequest& r) {
  std::shared_ptr<Job> job = store_.create();
  if (r.asset) job->set_attachment(r.asset);  // GET .../result with Accept: model/gltf-* answers in that document
  job->token().set_deadline(r.deadline);
  std::uint64_t ticket = 0;
  const std::shared_ptr<const codec::ParametrizeRequest> request = r.parsed;
  const TestHooks hooks = r.hooks;
  const WorkerPool::Submit submitted =
      service_.pool.submit([this, job, request, hooks] { run(job, *request, hooks); }, &ticket);
  job->set_ticket(ticket);
  Submitted out;
  if (submitted != WorkerPool::Submit::accepted) {
    store_.discard(job->id());
    if (submitted == WorkerPool::Submit::queue_full) {
      out.refusal = Submitted::Refusal::queue_full;
      out.full = "all " + std::to_string(service_.pool.workers()) + " workers are busy and " +
                 std::to_string(service_.pool.capacity()) + " tasks are waiting";
    } else {
      out.refusal = Submitted::Refusal::shutting_down;
    }
    return out;
  }
  out.snapshot = job->snapshot();
  return out;
}

// A queued job's task, on a worker.
void MemoryJobs::run(const std::shared_ptr<Job>& job, const codec::ParametrizeRequest& request,
                     const TestHooks& hooks) {
  if (!job->mark_running()) return;  // cancelled while it waited: already final
  const ProgressFn progress = [job](Stage stage, double fraction) { job->report(stage, fraction); };
  try {
    job->token().check();
    apply_hooks(hooks, job->token());
    MapOutcome m = run_map(request, job->token(), progress, service_.metrics);
    job->succeed(std::move(m.json), std::move(m.result));
  } catch (...) {
    const CancelReason reason = job->cancel_reason();
    ordered_json p = current_exception_problem(InputKind::parametrize, reason, service_.config.deadline_seconds);
    job->fail(reason == CancelReason::none ? JobState::failed : JobState::cancelled, std::move(p));
  }
  finished(job);
}

// Records a job that reached a final state (metrics, log line, the store's retention).
void MemoryJobs::finished(const std::shared_ptr<Job>& job) {
  const JobSnapshot s = job->snapshot();
  service_.metrics.count_job_finished(to_string(s.state));
  service_.event(spdlog::level::info, {{"event", "job_finished"},
                                       {"job_id", s.id},
                                       {"state", to_string(s.state)},
                                       {"code", s.problem ? s.problem->value("code", "") : ""},
                                       {"result_bytes", s.result_bytes}});
  store_.finished(job);
  service_.waits.notify();
}

// Ends a job that is still queued (its place in the queue is freed); a worker that took it meanwhile finds it
// final and skips it.
void MemoryJobs::end_queued(const std::shared_ptr<Job>& job, ordered_json problem) {
  service_.pool.remove(job->ticket());
  job->fail(JobState::cancelled, std::move(problem));
  if (job->state() == JobState::cancelled) finished(job);
}

JobQueue::Found MemoryJobs::find(const std::string& id) {
  JobStore::Found f = store_.find(id);
  Found out;
  out.lookup = f.lookup;
  out.gone_reason = f.gone_reason;
  if (f.job) out.snapshot = f.job->snapshot();
  return out;
}

JobQueue::Cancelled MemoryJobs::cancel(const std::string& id) {
  JobStore::Found f = store_.find(id);
  Cancelled out;
  if (f.lookup != JobStore::Lookup::found) {
    out.outcome = f.lookup == JobStore::Lookup::gone ? Cancel::gone : Cancel::unknown;
    out.job.lookup = f.lookup;
    out.job.gone_reason = f.gone_reason;
    return out;
  }
  const std::shared_ptr<Job>& job = f.job;
  const JobState state = job->state();
  if (is_final(state)) {
    store_.remove(id);
    out.outcome = Cancel::removed;
    return out;
  }
  job->request_cancel(CancelReason::client);
  out.outcome = Cancel::cancel_requested;
  if (state == JobState::queued && job->state() == JobState::queued) {
    end_queued(job, problem("cancelled", "the job was cancelled at the client's request before it started"));
    out.outcome = Cancel::cancelled_queued;
  }
  out.job.lookup = JobStore::Lookup::found;
  out.job.snapshot = job->snapshot();
  return out;
}

std::shared_ptr<const std::string> MemoryJobs::result_json(const std::string& id) {
  std::shared_ptr<Job> job = held(id);
  return job ? job->result_json() : nullptr;
}

std::optional<ComputedResult> MemoryJobs::computed(const std::string& id) {
  std::shared_ptr<Job> job = held(id);
  if (!job || !job->result()) return std::nullopt;
  return ComputedResult{job->result(), std::static_pointer_cast<const gltf::Asset>(job->attachment()),
                        job->result_json()};
}

// Only the preview is kept (with the job): a glTF answer is written again on each request, as it is small
// next to the result it is made from.
std::shared_ptr<const std::string> MemoryJobs::rendering(const std::string& id, const std::string& kind) {
  std::shared_ptr<Job> job = kind == "preview" ? held(id) : nullptr;
  return job ? job->preview() : nullptr;
}

void MemoryJobs::keep_rendering(const std::string& id, const std::string& kind,
                      std::shared_ptr<const std::string> body) {
  if (kind != "preview") return;
  if (std::shared_ptr<Job> job = held(id)) job->set_preview(std::move(body));
}

void MemoryJobs::sample(RuntimeGauges& g) {
  store_.sweep();
  g.jobs_by_state = store_.counts_by_state();
}

void MemoryJobs::cancel_unfinished(CancelReason reason) {
  for (const std::shared_ptr<Job>& job : store_.unfinished()) {
    const JobState before = job->state();
    job->request_cancel(reason);
    if (before == JobState::queued && job->state() == JobState::queued)
      end_queued(job, problem("shutting_down", "the service shut down before the job started"));
  }
}

}  // namespace lipmap::server
