// The asynchronous jobs: POST /v1/jobs, GET and DELETE /v1/jobs/{id}, GET /v1/jobs/{id}/result and
// GET /v1/jobs/{id}/preview.svg. Where the jobs are kept and run is Service::jobs, a JobQueue (job_store.h):
// the in-memory store (memory_jobs.h) or the shared queue of --queue-url (redis_jobs.h); these handlers only
// speak to that interface.
#include <algorithm>
#include <charconv>
#include <cstdint>
#include <functional>
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

Answer job_answer(int status, const JobSnapshot& s) {
  Answer a;
  a.status = status;
  a.body = job_json(s).dump();
  return a;
}

Answer not_found(const std::string& id) {
  return problem_answer("job_not_found",
                        "no job has the id " + json(id).dump(-1, ' ', false, json::error_handler_t::replace));
}

Answer gone_answer(Service& service, const std::string& id, const std::string& reason) {
  std::string detail;
  if (reason == "deleted")
    detail = "job " + id + " was deleted";
  else if (reason == "expired")
    detail = "job " + id + " finished more than " + seconds_text(service.config.result_ttl_seconds) +
             " s ago and its result was dropped";
  else
    detail = "job " + id + "'s result was dropped: the service keeps the last " +
             std::to_string(service.config.max_results) + " finished jobs";
  Answer a = problem_answer("job_gone", detail);
  (*a.problem)["reason"] = reason;
  return a;
}

// The job's snapshot, or the 404/410 answer.
std::variant<JobSnapshot, Answer> found_or_answer(Service& service, const std::string& id, JobQueue::Found f) {
  if (f.lookup == JobStore::Lookup::found) return std::move(f.snapshot);
  if (f.lookup == JobStore::Lookup::gone) return gone_answer(service, id, f.gone_reason);
  return problem_answer("job_not_found", "no job has the id " + id);
}

// The job named by the path, or the 404/410 answer.
std::variant<JobSnapshot, Answer> lookup_job(Service& service, const std::string& id) {
  if (!looks_like_job_id(id)) return not_found(id);
  return found_or_answer(service, id, service.jobs->find(id));
}

// The `wait` query parameter of GET /v1/jobs/{id}: seconds (a decimal number, 0 to kMaxWaitSeconds) to wait
// for the job to end; 0 when absent.
constexpr double kMaxWaitSeconds = 30;  // below the 60 s read timeout of common proxies (nginx's default)

std::variant<Clock::duration, Answer> wait_of(const httplib::Request& req) {
  if (!req.has_param("wait")) return Clock::duration::zero();
  const std::string text = req.get_param_value("wait");
  double seconds = -1;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), seconds);
  if (ec != std::errc() || end != text.data() + text.size() || !(seconds >= 0 && seconds <= kMaxWaitSeconds)) {
    Answer a = problem_answer("invalid_query_parameter",
                              "wait must be a number of seconds from 0 to " + seconds_text(kMaxWaitSeconds) + ", not " +
                                  json(text).dump(-1, ' ', false, json::error_handler_t::replace));
    (*a.problem)["parameter"] = "wait";
    return a;
  }
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
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

// Every job endpoint: a job store out of reach (the shared queue's Redis) is 503 queue_unavailable.
Answer guarded(const std::function<Answer()>& handler) {
  try {
    return handler();
  } catch (const QueueUnavailable& e) {
    Answer a = problem_answer("queue_unavailable",
                              std::string("the shared job queue cannot be reached (") + e.what() + "); retry later");
    a.headers.emplace_back("Retry-After", "2");
    return a;
  }
}

// A rendering of a succeeded job's result (the SVG preview, a glTF document): kept by the job store once made
// (the in-memory store keeps the preview). Made from the result this process holds, or, on a replica of the
// shared queue that did not run the job, by running the stored request again on the pool (the engine is
// deterministic: the same result). Rendering is engine-side work: it runs on the pool.
Answer rendering(Service& service, const std::string& id, const std::string& kind, const std::string& type,
                 std::function<std::string(const ComputedResult&)> render) {
  if (std::shared_ptr<const std::string> kept = service.jobs->rendering(id, kind)) {
    Answer a;
    a.content_type = type;
    a.shared_body = std::move(kept);
    return a;
  }
  std::optional<ComputedResult> computed = service.jobs->computed(id);
  std::optional<StoredRequest> stored;
  if (!computed) {
    stored = service.jobs->stored_request(id);
    if (!stored) return gone_answer(service, id, "expired");
  }
  Metrics& metrics = service.metrics;
  Answer a = service.run_sync(InputKind::none, [computed, stored, render, type, &metrics](const CancelToken& token) {
    token.check();
    ComputedResult c;
    if (computed) {
      c = *computed;
    } else {
      codec::LoadedRequest loaded = codec::load_request(stored->input());
      c.result = map_request(loaded.request, token, {}, metrics);
      if (loaded.asset) c.asset = std::make_shared<const gltf::Asset>(std::move(*loaded.asset));
    }
    Answer out;
    out.content_type = type;
    out.shared_body = std::make_shared<const std::string>(render(c));
    return out;
  });
  if (a.status == 200 && a.shared_body) {
    try {
      service.jobs->keep_rendering(id, kind, a.shared_body);
    } catch (const QueueUnavailable&) {  // made again next time
    }
  }
  return a;
}

Answer result_or_preview(Service& service, const httplib::Request& req, bool preview) {
  const std::string id = req.matches[1];
  auto found = lookup_job(service, id);
  if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
  const JobSnapshot& s = std::get<JobSnapshot>(found);
  if (s.state != JobState::succeeded) return not_finished(s);
  if (preview)
    return rendering(service, id, "preview", "image/svg+xml", [id](const ComputedResult& c) {
      return preview::render_svg(preview::picture_of(*c.result, "lipmap job " + id));
    });
  if (const std::optional<gltf::Format> f = gltf::accepted_format(req.get_header_value("Accept"))) {
    return rendering(service, id, std::string("gltf:") + (*f == gltf::Format::glb ? "glb" : "gltf"),
                     gltf::media_type(*f), [f](const ComputedResult& c) {
                       return c.asset ? gltf::write_answer(*c.asset, *c.result, *f) : gltf::write_answer(*c.result, *f);
                     });
  }
  std::shared_ptr<const std::string> body = service.jobs->result_json(id);
  if (!body) return gone_answer(service, id, "expired");
  Answer a;
  a.shared_body = std::move(body);
  return a;
}

}  // namespace

Answer post_job(Service& service, const httplib::Request& req) {
  return guarded([&]() -> Answer {
    auto parsed = parse_parametrize(service, req);  // a bad request is refused here, not by the worker
    if (auto* a = std::get_if<Answer>(&parsed)) return std::move(*a);
    ParsedParametrize& p = std::get<ParsedParametrize>(parsed);
    JobRequest job;
    job.parsed = p.request;
    job.asset = p.asset;
    if (!service.jobs->uses_local_pool()) {  // the shared queue stores the request as it came
      job.stored.media_type = req.get_header_value("Content-Type");
      if (req.files.empty()) job.stored.body = req.body;
      for (const auto& [name, file] : req.files) job.stored.parts[name] = gltf::Part{file.content, file.content_type};
      auto param = [&](const char* name) -> std::optional<std::string> {
        if (!req.has_param(name)) return std::nullopt;
        return req.get_param_value(name);
      };
      job.stored.params =
          gltf::Params{param("mesh"), param("primitive"), param("weld"), param("boundary"), param("metric")};
    }
    job.hooks = service.hooks_of(req);
    job.deadline = service.deadline_from_arrival();
    const JobQueue::Submitted submitted = service.jobs->submit(job);
    switch (submitted.refusal) {
      case JobQueue::Submitted::Refusal::none: break;
      case JobQueue::Submitted::Refusal::queue_full: return service.queue_full(submitted.full);
      case JobQueue::Submitted::Refusal::shutting_down: return service.submit_refused(WorkerPool::Submit::closed);
    }
    const JobSnapshot& s = submitted.snapshot;
    ordered_json event{{"event", "job_queued"},
                       {"job_id", s.id},
                       {"request_id", this_request().id},
                       {"vertices", p.request->mesh.vertices.size()},
                       {"faces", p.request->mesh.faces.size()}};
    if (!service.jobs->uses_local_pool()) event["queue"] = "shared";
    service.event(spdlog::level::info, std::move(event));
    Answer a = job_answer(202, s);
    a.headers.emplace_back("Location", "/v1/jobs/" + s.id);
    return a;
  });
}

Answer get_job(Service& service, const httplib::Request& req) {
  return guarded([&]() -> Answer {
    auto wait = wait_of(req);
    if (auto* a = std::get_if<Answer>(&wait)) return std::move(*a);
    const Clock::time_point start = Clock::now();
    const Clock::time_point until = start + std::get<Clock::duration>(wait);
    const JobWaits::Place place = until > start ? service.waits.enter() : JobWaits::Place();
    for (;;) {
      const std::uint64_t seen = service.waits.generation();
      auto found = lookup_job(service, req.matches[1]);
      if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
      const JobSnapshot& s = std::get<JobSnapshot>(found);
      const Clock::time_point now = Clock::now();
      if (is_final(s.state) || !place || service.waits.closed() || now >= until) return job_answer(200, s);
      // A job of this process wakes its waiters when it ends (then it is looked at again every 250 ms only: on
      // the shared queue each look is a Redis read, taking CPU from the job); one run by another replica of the
      // shared queue does not, so the job is looked at again after a twentieth of the time waited so far (the
      // end is learnt at most 5 % late, and a long wait costs few reads), between 5 and 250 ms.
      const Clock::duration recheck =
          service.jobs->runs_here(s.id) ? Clock::duration(std::chrono::milliseconds(250))
                                        : std::clamp<Clock::duration>((now - start) / 20, std::chrono::milliseconds(5),
                                                                      std::chrono::milliseconds(250));
      service.waits.sleep(seen, std::min(until, now + recheck));
    }
  });
}

Answer delete_job(Service& service, const httplib::Request& req) {
  const std::string id = req.matches[1];
  return guarded([&]() -> Answer {
    if (!looks_like_job_id(id)) return not_found(id);
    JobQueue::Cancelled c = service.jobs->cancel(id);
    if (c.outcome == JobQueue::Cancel::removed) {
      Answer a;
      a.status = 204;
      a.content_type.clear();
      return a;
    }
    auto found = found_or_answer(service, id, std::move(c.job));
    if (auto* a = std::get_if<Answer>(&found)) return std::move(*a);
    const JobSnapshot& s = std::get<JobSnapshot>(found);
    if (!is_final(s.state)) service.event(spdlog::level::info, {{"event", "job_cancel_requested"}, {"job_id", id}});
    return job_answer(is_final(s.state) ? 200 : 202, s);
  });
}

Answer get_job_result(Service& service, const httplib::Request& req) {
  return guarded([&] { return result_or_preview(service, req, false); });
}

Answer get_job_preview(Service& service, const httplib::Request& req) {
  return guarded([&] { return result_or_preview(service, req, true); });
}

}  // namespace lipmap::server
