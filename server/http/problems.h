// Answers of the HTTP service and its RFC 7807 problem answers (application/problem+json, as
// proto/problem.schema.json describes). Every problem's status and title come from the one error table,
// server/codec/error_table.h; this file only adds what the HTTP answer carries beyond them (pointer, element,
// index, the verdict of not_self_overlapping, the glTF pointer ...).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/error.h"
#include "server/http/job_store.h"

namespace lipmap::server {

// What a request's body is, for the JSON pointer of an engine InputError: the classify polygon, the
// parametrize request (JSON or glTF), or nothing the engine reads.
enum class InputKind { none, classify, parametrize };

// What a worker or a handler hands back: a body, or a problem (rendered with the request id at answer time).
struct Answer {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::shared_ptr<const std::string> shared_body;  // large bodies (results) are shared until written
  // Freed after the answer is written, not before: a big request's arrays (250k faces are 250k frees) and the
  // engine's result would otherwise be freed between the engine's end and the answer's first byte.
  std::shared_ptr<const void> keep_until_sent;
  std::optional<nlohmann::ordered_json> problem;
  std::vector<std::pair<std::string, std::string>> headers;
  double queue_ms = -1, work_ms = -1;  // set by Service::run_sync
  double engine_ms = -1;  // the engine's own total (the sum of its stages), when the answer ran it
};

// The problem of `code`: status and title from the error table.
nlohmann::ordered_json problem(std::string_view code, const std::string& detail,
                               const std::optional<std::string>& pointer = std::nullopt,
                               const std::string& element = {}, std::optional<long long> index = std::nullopt);

Answer problem_answer(nlohmann::ordered_json problem);
Answer problem_answer(std::string_view code, const std::string& detail,
                      const std::optional<std::string>& pointer = std::nullopt);

// An InputError of the codecs or the engine, with its pointer, element and index (and a glTF error's
// gltf_pointer, a not_self_overlapping's verdict and turning number).
nlohmann::ordered_json input_problem(const InputError& error, InputKind kind);

// The problem for the exception being handled (call inside a catch block). `reason` says why the work's
// token was cancelled, if it was.
nlohmann::ordered_json current_exception_problem(InputKind kind, CancelReason reason, double deadline_seconds);

// The 504 detail's "within the deadline of <s> s".
std::string seconds_text(double seconds);

}  // namespace lipmap::server
