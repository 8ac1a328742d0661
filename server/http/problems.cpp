#include "server/http/problems.h"

#include <cstdio>
#include <new>
#include <string>

#include "engine/pipeline.h"
#include "server/codec/error_table.h"
#include "server/codec/gltf_codec.h"
#include "server/codec/json_codec.h"

namespace lipmap::server {

using nlohmann::ordered_json;

std::string seconds_text(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", s);
  return buf;
}

ordered_json problem(std::string_view code, const std::string& detail, const std::optional<std::string>& pointer,
                     const std::string& element, std::optional<long long> index) {
  const codec::ErrorInfo& info = codec::error_info(code);
  return codec::problem_json(info.status, std::string(info.title), std::string(code), detail, pointer, element,
                             index);
}

Answer problem_answer(ordered_json p) {
  Answer a;
  a.status = p.value("status", 500);
  a.problem = std::move(p);
  return a;
}

Answer problem_answer(std::string_view code, const std::string& detail, const std::optional<std::string>& pointer) {
  return problem_answer(problem(code, detail, pointer));
}

ordered_json input_problem(const InputError& e, InputKind kind) {
  if (auto* g = dynamic_cast<const gltf::GltfError*>(&e)) {
    ordered_json p = problem(g->code(), g->what());
    if (!g->gltf_pointer().empty()) p["gltf_pointer"] = g->gltf_pointer();
    return p;
  }
  if (auto* j = dynamic_cast<const codec::JsonError*>(&e)) {
    ordered_json p = problem(j->code(), j->what(), j->pointer());
    if (j->byte_offset()) p["byte_offset"] = *j->byte_offset();
    return p;
  }
  // An engine error. Its pointer is told from the request it was read from; an error about a glTF
  // primitive (InputKind::none) has no JSON value to point at.
  std::optional<std::string> pointer;
  if (kind == InputKind::classify) pointer = codec::classify_error_pointer(e);
  if (kind == InputKind::parametrize) pointer = codec::parametrize_error_pointer(e);
  ordered_json p = problem(e.code(), e.what(), pointer, e.element(), e.index());
  if (auto* n = dynamic_cast<const NotSelfOverlapping*>(&e)) {
    const Classification& c = n->classification();
    p["verdict"] = codec::verdict_name(c.verdict);
    p["turning_number"] = c.turning_number;
    if (!c.reason.empty()) p["reason"] = c.reason;
  }
  return p;
}

ordered_json current_exception_problem(InputKind kind, CancelReason reason, double deadline_seconds) {
  try {
    throw;
  } catch (const InputError& e) {
    return input_problem(e, kind);
  } catch (const Cancelled& e) {
    if (reason == CancelReason::shutdown)
      return problem("shutting_down", "the service is shutting down; the work was cancelled before it finished");
    if (reason == CancelReason::client) return problem("cancelled", "the job was cancelled at the client's request");
    return problem("deadline_exceeded", "the work did not finish within the deadline of " +
                                            seconds_text(deadline_seconds) + " s and was cancelled (" + e.what() + ")");
  } catch (const InternalError& e) {
    return problem("internal_error", std::string("internal error: ") + e.what());
  } catch (const std::bad_alloc&) {
    return problem("out_of_memory", "not enough memory for this request; try again later or send a smaller mesh");
  } catch (const std::exception& e) {
    return problem("internal_error", std::string("unexpected error: ") + e.what());
  } catch (...) {
    return problem("internal_error", "unexpected exception");
  }
}

}  // namespace lipmap::server
