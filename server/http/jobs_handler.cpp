// The asynchronous jobs: POST /v1/jobs, GET and DELETE /v1/jobs/{id}, GET /v1/jobs/{id}/result and
// GET /v1/jobs/{id}/preview.svg. The jobs themselves (state, progress, retention) are server/http/job_store.h,
// or, with --queue-url, the shared queue of server/http/redis_jobs.h (the cluster_* functions below).
#include <cstdint>
#include <functional>
#include <string>

#include "server/codec/svg_preview.h"
#include "server/http/handlers.h"
#include "server/http/middleware.h"
#include "server/http/redis_jobs.h"

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

// ---- the shared queue (--queue-url): the same answers, from Redis ----------------------------------------

Answer queue_unavailable(const QueueUnavailable& e) {
  Answer a = problem_answer("queue_unavailable",
                            std::string("the shared job queue cannot be reached (") + e.what() + "); retry later");
  a.headers.emplace_back("Retry-After", "2");
  return a;
}

Answer gone_answer(Service& service, const std::string& id, const std::string& reason) {
  const std::string detail =
      reason == "deleted" ? "job " + id + " was deleted"
                          : "job " + id + " finished more than " + seconds_text(service.config.result_ttl_seconds) +
                                " s ago and its result was dropped";
  Answer a = problem_answer("job_gone", detail);
  (*a.problem)["reason"] = reason;
  return a;
}

std::variant<JobSnapshot, Answer> cluster_lookup(Service& service, const std::string& id) {
  if (!looks_like_job_id(id))
    return problem_answer("job_not_found",
                          "no job has the id " + json(id).dump(-1, ' ', false, json::error_handler_t::replace));
  RedisJobs::Found f = service.cluster->find(id);
  if (f.lookup == JobStore::Lookup::found) return f.snapshot;
  if (f.lookup == JobStore::Lookup::gone) return gone_answer(service, id, f.gone_reason);
  return problem_answer("job_not_found", "no job has the id " + id);
}

Answer snapshot_answer(int status, const JobSnapshot& s) {
  Answer a;
  a.status = status;
  a.body = job_json(s).dump();
  return a;
}

Answer cluster_post_job(Service& service, const httplib::Request& req) {
  auto parsed = parse_parametrize(service, req);  // a bad request is refused here, not by the worker
  if (auto* a = std::get_if<Answer>(&parsed)) return std::move(*a);
  const ParsedParametrize& p = std::get<ParsedParametrize>(parsed);
  StoredRequest stored;
  stored.media_type = req.get_header_value("Content-Type");
  if (req.files.empty()) stored.body = req.body;
  for (const auto& [name, file] : req.files) stored.parts[name] = gltf::Part{file.content, file.content_type};
  auto param = [&](const char* name) -> std::optional<std::string> {
    if (!req.has_param(name)) return std::nullopt;
    return req.get_param_value(name);
  };
  stored.params = gltf::Params{param("mesh"), param("primitive"), param("weld"), param("boundary"), param("metric")};
  const TestHooks hooks = service.hooks_of(req);
  const auto deadline = std::chrono::system_clock::now() +
                        std::chrono::duration_cast<std::chrono::system_clock::duration>(
                            service.deadline_from_arrival() - Clock::now());
  std::string id;
  try {
    id = service.cluster->submit(stored, deadline, hooks.delay_ms, hooks.fault);
  } catch (const SharedQueueFull& full) {
    service.metrics.count_rejected("queue_full");
    const int retry = service.pool.retry_after_seconds();
    Answer a = problem_answer("queue_full", std::to_string(full.waiting) +
                                                " jobs wait in the shared queue, its limit; retry after " +
                                                std::to_string(retry) + " s");
    (*a.problem)["retry_after_seconds"] = retry;
    a.headers.emplace_back("Retry-After", std::to_string(retry));
    return a;
  }
  service.event(spdlog::level::info, {{"event", "job_queued"}, {"job_id", id}, {"request_id", this_request().id},
                                      {"vertices", p.request->mesh.vertices.size()}, {"faces", p.request->mesh.faces.size()},
                                      {"queue", "shared"}});
  JobSnapshot s;
  s.id = id;
  s.created_at = std::chrono::system_clock::now();
  Answer a = snapshot_answer(202, s);
  a.headers.emplace_back("Location", "/v1/jobs/" + id);
  return a;
}

Answer cluster_delete_job(Service& service, const std::string& id) {
  if (!looks_like_job_id(id)) return std::get<Answer>(cluster_lookup(service, id));
  const std::string p =
      problem("cancelled", "the job was cancelled at the client's request before it started").dump();
  switch (service.cluster->cancel(id, p)) {
    case RedisJobs::Cancel::unknown:
    case RedisJobs::Cancel::gone: return std::get<Answer>(cluster_lookup(service, id));
    case RedisJobs::Cancel::removed: {
      Answer a;
      a.status = 204;
      a.content_type.clear();
      return a;
    }
    case RedisJobs::Cancel::cancelled_queued:
    case RedisJobs::Cancel::cancel_requested: break;
  }
  auto found = cluster_lookup(service, id);
  if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
  const JobSnapshot& s = std::get<JobSnapshot>(found);
  if (!is_final(s.state)) service.event(spdlog::level::info, {{"event", "job_cancel_requested"}, {"job_id", id}});
  return snapshot_answer(is_final(s.state) ? 200 : 202, s);
}

// A rendering of a finished job's result (the SVG preview, a glTF document), made once on whichever replica
// is asked first and kept in Redis. The replica that ran the job still has the result; another one runs the
// stored request again on its pool (the engine is deterministic: the same result).
Answer cluster_rendering(Service& service, const std::string& id, const std::string& kind, const std::string& type,
                         std::function<std::string(const RedisJobs::Local&)> render) {
  if (std::shared_ptr<const std::string> kept = service.cluster->rendering(id, kind)) {
    Answer a;
    a.content_type = type;
    a.shared_body = std::move(kept);
    return a;
  }
  std::optional<RedisJobs::Local> local = service.cluster->local_result(id);
  std::optional<StoredRequest> stored;
  if (!local) {
    stored = service.cluster->stored_request(id);
    if (!stored) return gone_answer(service, id, "expired");
  }
  Metrics& metrics = service.metrics;
  Answer a = service.run_sync(InputKind::none, [local, stored, render, type, &metrics](const CancelToken& token) {
    token.check();
    RedisJobs::Local l;
    if (local) {
      l = *local;
    } else {
      codec::LoadedRequest loaded = codec::load_request(stored->input());
      l.result = run_map(loaded.request, token, {}, metrics).result;
      if (loaded.asset) l.asset = std::make_shared<const gltf::Asset>(std::move(*loaded.asset));
    }
    Answer out;
    out.content_type = type;
    out.shared_body = std::make_shared<const std::string>(render(l));
    return out;
  });
  if (a.status == 200 && a.shared_body) {
    try {
      service.cluster->keep_rendering(id, kind, *a.shared_body);
    } catch (const QueueUnavailable&) {  // made again next time
    }
  }
  return a;
}

Answer cluster_result(Service& service, const httplib::Request& req, bool preview) {
  const std::string id = req.matches[1];
  auto found = cluster_lookup(service, id);
  if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
  const JobSnapshot& s = std::get<JobSnapshot>(found);
  if (s.state != JobState::succeeded) return not_finished(s);
  if (preview)
    return cluster_rendering(service, id, "preview", "image/svg+xml", [id](const RedisJobs::Local& l) {
      return preview::render_svg(preview::picture_of(*l.result, "lipmap job " + id));
    });
  if (const std::optional<gltf::Format> f = gltf::accepted_format(req.get_header_value("Accept"))) {
    return cluster_rendering(service, id, std::string("gltf:") + (*f == gltf::Format::glb ? "glb" : "gltf"),
                             gltf::media_type(*f), [f](const RedisJobs::Local& l) {
                               return l.asset ? gltf::write_answer(*l.asset, *l.result, *f)
                                              : gltf::write_answer(*l.result, *f);
                             });
  }
  std::shared_ptr<const std::string> body = service.cluster->result_json(id);
  if (!body) return gone_answer(service, id, "expired");
  Answer a;
  a.shared_body = std::move(body);
  return a;
}

// Every job endpoint in shared-queue mode; Redis out of reach is 503 queue_unavailable.
Answer cluster_answer(Service&, const std::function<Answer()>& handler) {
  try {
    return handler();
  } catch (const QueueUnavailable& e) {
    return queue_unavailable(e);
  }
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
  if (service.cluster) {
    // Shared queue: the first call (the drain) stops taking jobs and lets the running ones finish, since any
    // replica can still answer for them; a later one (grace over, second signal) hands them to another
    // replica.
    if (service.cluster->fetching()) service.cluster->stop_fetching();
    else service.cluster->hand_back_running();
  }
  for (const std::shared_ptr<Job>& job : service.store.unfinished()) {
    const JobState before = job->state();
    job->request_cancel(reason);
    if (before == JobState::queued && job->state() == JobState::queued)
      end_queued_job(service, job, problem("shutting_down", "the service shut down before the job started"));
  }
}

Answer post_job(Service& service, const httplib::Request& req) {
  if (service.cluster) return cluster_answer(service, [&] { return cluster_post_job(service, req); });
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
  if (service.cluster)
    return cluster_answer(service, [&]() -> Answer {
      auto found = cluster_lookup(service, req.matches[1]);
      if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
      return snapshot_answer(200, std::get<JobSnapshot>(found));
    });
  auto found = lookup_job(service, req.matches[1]);
  if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
  return job_answer(200, *std::get<std::shared_ptr<Job>>(found));
}

Answer delete_job(Service& service, const httplib::Request& req) {
  const std::string id = req.matches[1];
  if (service.cluster) return cluster_answer(service, [&] { return cluster_delete_job(service, id); });
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
  if (service.cluster) return cluster_answer(service, [&] { return cluster_result(service, req, false); });
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
  if (service.cluster) return cluster_answer(service, [&] { return cluster_result(service, req, true); });
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
