// The asynchronous jobs: POST /v1/jobs, GET and DELETE /v1/jobs/{id}, GET /v1/jobs/{id}/result and
// GET /v1/jobs/{id}/preview.svg. The jobs themselves (state, progress, retention) are server/http/job_store.h.
#include <cstdint>
#include <string>

#include "server/codec/svg_preview.h"
#include "server/http/handlers.h"
#include "server/http/middleware.h"

// Last: with its OpenSSL support cpp-httplib pulls in <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>

namespace lipmap::server {

using nlohmann::json;
using nlohmann::ordered_json;

namespace {

ordered_json job_json(const JobSnapshot& s) {
  ordered_json out;
  out["id"] = s.id;
  out["state"] = to_string(s.state);
  out["created_at"] = iso8601(s.created_at);
  if (s.started) out["started_at"] = iso8601(s.started_at);
  if (s.finished) out["finished_at"] = iso8601(s.finished_at);
  out["cancel_requested"] = s.cancel_requested;
  ordered_json progress;
  progress["fraction"] = s.fraction;
  if (!s.current_stage.empty()) progress["stage"] = s.current_stage;
  progress["stages"] = ordered_json::array();
  for (const StageProgress& p : s.stages)
    progress["stages"].push_back({{"stage", p.stage}, {"fraction", p.fraction}, {"done", p.done}, {"ms", p.ms}});
  out["progress"] = std::move(progress);
  if (s.problem) out["error"] = *s.problem;
  const std::string self = "/v1/jobs/" + s.id;
  out["links"] = {{"self", self}, {"result", self + "/result"}, {"preview", self + "/preview.svg"}};
  return out;
}

Answer job_answer(int status, const Job& job) {
  Answer a;
  a.status = status;
  a.body = job_json(job.snapshot()).dump();
  return a;
}

// A queued job's task, on a worker.
void run_job(Service& service, const std::shared_ptr<Job>& job, const codec::ParametrizeRequest& request,
             const TestHooks& hooks) {
  if (!job->mark_running()) return;  // cancelled while it waited: already final
  const ProgressFn progress = [job](Stage stage, double fraction) { job->report(stage, fraction); };
  try {
    job->token().check();
    apply_hooks(hooks, job->token());
    MapOutcome m = run_map(request, job->token(), progress, service.metrics);
    job->succeed(std::move(m.json), std::move(m.result));
  } catch (...) {
    const CancelReason reason = job->cancel_reason();
    ordered_json p = current_exception_problem(InputKind::parametrize, reason, service.config.deadline_seconds);
    job->fail(reason == CancelReason::none ? JobState::failed : JobState::cancelled, std::move(p));
  }
  finish_job(service, job);
}

// Ends a job that is still queued (its place in the queue is freed); a worker that took it meanwhile finds it
// final and skips it.
void end_queued_job(Service& service, const std::shared_ptr<Job>& job, ordered_json problem) {
  service.pool.remove(job->ticket());
  job->fail(JobState::cancelled, std::move(problem));
  if (job->state() == JobState::cancelled) finish_job(service, job);
}

// The job named by the path, or the 404/410 answer.
std::variant<std::shared_ptr<Job>, Answer> lookup_job(Service& service, const std::string& id) {
  if (!looks_like_job_id(id))
    return problem_answer("job_not_found",
                          "no job has the id " + json(id).dump(-1, ' ', false, json::error_handler_t::replace));
  JobStore::Found f = service.store.find(id);
  if (f.lookup == JobStore::Lookup::found) return f.job;
  if (f.lookup == JobStore::Lookup::gone) {
    std::string detail;
    if (f.gone_reason == "deleted")
      detail = "job " + id + " was deleted";
    else if (f.gone_reason == "expired")
      detail = "job " + id + " finished more than " + seconds_text(service.config.result_ttl_seconds) +
               " s ago and its result was dropped";
    else
      detail = "job " + id + "'s result was dropped: the service keeps the last " +
               std::to_string(service.config.max_results) + " finished jobs";
    Answer a = problem_answer("job_gone", detail);
    (*a.problem)["reason"] = f.gone_reason;
    return a;
  }
  return problem_answer("job_not_found", "no job has the id " + id);
}

// 409 for a job without a result: not finished yet, failed, or cancelled.
Answer not_finished(const JobSnapshot& s) {
  if (s.state == JobState::failed) {
    Answer a = problem_answer("job_failed", "job " + s.id + " failed: " + (s.problem ? s.problem->value("detail", "") : ""));
    (*a.problem)["job_state"] = to_string(s.state);
    if (s.problem) (*a.problem)["cause"] = *s.problem;
    return a;
  }
  if (s.state == JobState::cancelled) {
    Answer a = problem_answer("job_cancelled", "job " + s.id + " was cancelled and has no result");
    (*a.problem)["job_state"] = to_string(s.state);
    if (s.problem) (*a.problem)["cause"] = *s.problem;
    return a;
  }
  Answer a = problem_answer("job_not_finished", "job " + s.id + " is " + to_string(s.state) + "; poll /v1/jobs/" +
                                                    s.id + " until it has succeeded");
  (*a.problem)["job_state"] = to_string(s.state);
  a.headers.emplace_back("Retry-After", "1");
  return a;
}

}  // namespace

void finish_job(Service& service, const std::shared_ptr<Job>& job) {
  const JobSnapshot s = job->snapshot();
  service.metrics.count_job_finished(to_string(s.state));
  service.event(spdlog::level::info, {{"event", "job_finished"},
                                      {"job_id", s.id},
                                      {"state", to_string(s.state)},
                                      {"code", s.problem ? s.problem->value("code", "") : ""},
                                      {"result_bytes", s.result_bytes}});
  service.store.finished(job);
}

void cancel_unfinished_jobs(Service& service, CancelReason reason) {
  for (const std::shared_ptr<Job>& job : service.store.unfinished()) {
    const JobState before = job->state();
    job->request_cancel(reason);
    if (before == JobState::queued && job->state() == JobState::queued)
      end_queued_job(service, job, problem("shutting_down", "the service shut down before the job started"));
  }
}

Answer post_job(Service& service, const httplib::Request& req) {
  auto parsed = parse_parametrize(service, req);
  if (auto* a = std::get_if<Answer>(&parsed)) return std::move(*a);
  ParsedParametrize p = std::get<ParsedParametrize>(std::move(parsed));
  const TestHooks hooks = service.hooks_of(req);
  std::shared_ptr<Job> job = service.store.create();
  if (p.asset) job->set_attachment(p.asset);  // GET .../result with Accept: model/gltf-* answers in that document
  job->token().set_deadline(service.deadline_from_arrival());
  std::uint64_t ticket = 0;
  const std::shared_ptr<const codec::ParametrizeRequest> request = p.request;
  const WorkerPool::Submit submitted =
      service.pool.submit([&service, job, request, hooks] { run_job(service, job, *request, hooks); }, &ticket);
  job->set_ticket(ticket);
  if (submitted != WorkerPool::Submit::accepted) {
    service.store.discard(job->id());
    return service.submit_refused(submitted);
  }
  service.event(spdlog::level::info, {{"event", "job_queued"}, {"job_id", job->id()}, {"request_id", this_request().id},
                                      {"vertices", request->mesh.vertices.size()}, {"faces", request->mesh.faces.size()}});
  Answer a = job_answer(202, *job);
  a.headers.emplace_back("Location", "/v1/jobs/" + job->id());
  return a;
}

Answer get_job(Service& service, const httplib::Request& req) {
  auto found = lookup_job(service, req.matches[1]);
  if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
  return job_answer(200, *std::get<std::shared_ptr<Job>>(found));
}

Answer delete_job(Service& service, const httplib::Request& req) {
  const std::string id = req.matches[1];
  auto found = lookup_job(service, id);
  if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
  std::shared_ptr<Job> job = std::get<std::shared_ptr<Job>>(found);
  const JobState state = job->state();
  if (is_final(state)) {
    service.store.remove(id);
    Answer a;
    a.status = 204;
    a.content_type.clear();
    return a;
  }
  job->request_cancel(CancelReason::client);
  if (state == JobState::queued && job->state() == JobState::queued) {
    end_queued_job(service, job, problem("cancelled", "the job was cancelled at the client's request before it started"));
    return job_answer(200, *job);
  }
  service.event(spdlog::level::info, {{"event", "job_cancel_requested"}, {"job_id", id}});
  return job_answer(202, *job);
}

Answer get_job_result(Service& service, const httplib::Request& req) {
  auto found = lookup_job(service, req.matches[1]);
  if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
  std::shared_ptr<Job> job = std::get<std::shared_ptr<Job>>(found);
  const JobSnapshot s = job->snapshot();
  if (s.state != JobState::succeeded) return not_finished(s);
  if (const std::optional<gltf::Format> f = gltf::accepted_format(req.get_header_value("Accept"))) {
    std::shared_ptr<const ParametrizeResult> result = job->result();
    auto asset = std::static_pointer_cast<const gltf::Asset>(job->attachment());
    if (result)  // writing the glTF is engine-side work: on the pool
      return service.run_sync(InputKind::none, [result, asset, f](const CancelToken& token) {
        token.check();
        return gltf_answer(asset, *result, *f);
      });
  }
  Answer a;
  a.shared_body = job->result_json();
  return a;
}

Answer get_job_preview(Service& service, const httplib::Request& req) {
  auto found = lookup_job(service, req.matches[1]);
  if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
  std::shared_ptr<Job> job = std::get<std::shared_ptr<Job>>(found);
  const JobSnapshot s = job->snapshot();
  if (s.state != JobState::succeeded) return not_finished(s);
  if (std::shared_ptr<const std::string> cached = job->preview()) {
    Answer a;
    a.content_type = "image/svg+xml";
    a.shared_body = std::move(cached);
    return a;
  }
  std::shared_ptr<const ParametrizeResult> result = job->result();
  if (!result) throw InternalError("job " + job->id() + " succeeded without a result");
  // Rendering is engine-side work: it runs on the pool like everything else, once per job.
  return service.run_sync(InputKind::none, [job, result](const CancelToken& token) {
    token.check();
    auto svg = std::make_shared<const std::string>(
        preview::render_svg(preview::picture_of(*result, "lipmap job " + job->id())));
    job->set_preview(svg);
    Answer a;
    a.content_type = "image/svg+xml";
    a.shared_body = std::move(svg);
    return a;
  });
}

}  // namespace lipmap::server
