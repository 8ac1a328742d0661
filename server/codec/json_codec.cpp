#include "server/codec/json_codec.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <initializer_list>
#include <utility>
#include <vector>

#include "engine/pipeline.h"
#include "server/codec/json_internal.h"

namespace lipmap::codec {

using nlohmann::json;
using nlohmann::ordered_json;

namespace {

// ---- JSON pointers, built only when an error needs one -------------------------------------------------

// A path from the document root; children live on the stack of the reader that walks into them, so a
// million-vertex body costs no string work unless something is wrong.
struct Path {
  const Path* parent = nullptr;  // nullptr only for the root
  std::string_view key;          // member name, when index < 0
  long long index = -1;          // array index

  Path operator/(std::string_view member) const { return Path{this, member, -1}; }
  Path operator/(std::size_t i) const { return Path{this, {}, static_cast<long long>(i)}; }

  std::string str() const {
    if (!parent) return {};
    std::string out = parent->str();
    out += '/';
    out += index >= 0 ? std::to_string(index) : escape_pointer_token(key);
    return out;
  }
};

[[noreturn]] void fail(const std::string& code, const std::string& message, const Path& at) {
  throw JsonError(code, message, at.str());
}

using detail::DomBuilder;
using detail::quote_key;

const char* type_phrase(const json& v) {
  switch (v.type()) {
    case json::value_t::null: return "null";
    case json::value_t::boolean: return "a boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return "a number";
    case json::value_t::string: return "a string";
    case json::value_t::array: return "an array";
    case json::value_t::object: return "an object";
    default: return "an unsupported value";
  }
}

[[noreturn]] void wrong_type(const json& v, const char* expected, const Path& at) {
  fail("wrong_type", std::string("expected ") + expected + ", got " + type_phrase(v), at);
}

// ---- typed readers -----------------------------------------------------------------------------------

const json& object(const json& v, const Path& at, std::initializer_list<std::string_view> allowed) {
  if (!v.is_object()) wrong_type(v, "an object", at);
  for (const auto& [key, value] : v.items()) {
    bool known = false;
    for (std::string_view a : allowed) known = known || a == key;
    if (!known) {
      std::string list;
      for (std::string_view a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      fail("unknown_field", "unknown field " + quote_key(key) + " (allowed: " + list + ")", at / std::string_view(key));
    }
  }
  return v;
}

const json* optional_member(const json& obj, std::string_view key) {
  auto it = obj.find(std::string(key));
  return it == obj.end() ? nullptr : &*it;
}

const json& required_member(const json& obj, std::string_view key, const Path& at) {
  const json* m = optional_member(obj, key);
  if (!m) fail("missing_field", "required field " + quote_key(key) + " is missing", at / key);
  return *m;
}

const json& array(const json& v, const Path& at, const char* expected = "an array") {
  if (!v.is_array()) wrong_type(v, expected, at);
  return v;
}

double number(const json& v, const Path& at) {
  if (!v.is_number()) wrong_type(v, "a number", at);
  double d = v.get<double>();
  // Unreachable through parse_json (it rejects 1e999), but a json built in code can hold anything.
  if (!std::isfinite(d)) fail("non_finite_number", "number is not finite", at);
  return d;
}

long long integer(const json& v, const Path& at, long long lo = LLONG_MIN, long long hi = LLONG_MAX) {
  long long value = 0;
  if (v.is_number_unsigned()) {
    auto u = v.get<json::number_unsigned_t>();
    if (u > static_cast<json::number_unsigned_t>(LLONG_MAX))
      fail("integer_out_of_range", "integer " + v.dump() + " is out of range", at);
    value = static_cast<long long>(u);
  } else if (v.is_number_integer()) {
    value = v.get<json::number_integer_t>();
  } else if (v.is_number_float()) {
    // JSON Schema's "integer" admits 2.0; so do we, and nothing with a fractional part.
    double d = v.get<double>();
    if (!std::isfinite(d)) fail("non_finite_number", "number is not finite", at);
    if (std::trunc(d) != d) fail("not_an_integer", "expected an integer, got " + v.dump(), at);
    if (d < -9223372036854775808.0 || d >= 9223372036854775808.0)
      fail("integer_out_of_range", "integer " + v.dump() + " is out of range", at);
    value = static_cast<long long>(d);
  } else {
    wrong_type(v, "an integer", at);
  }
  if (value < lo || value > hi)
    fail("integer_out_of_range",
         "integer " + std::to_string(value) + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]",
         at);
  return value;
}

int int32(const json& v, const Path& at) { return static_cast<int>(integer(v, at, INT_MIN, INT_MAX)); }

bool boolean(const json& v, const Path& at) {
  if (!v.is_boolean()) wrong_type(v, "a boolean", at);
  return v.get<bool>();
}

const std::string& string(const json& v, const Path& at) {
  if (!v.is_string()) wrong_type(v, "a string", at);
  return v.get_ref<const std::string&>();
}

// An array of exactly n numbers, e.g. a point [x, y].
const json& fixed_array(const json& v, std::size_t n, const char* shape, const Path& at) {
  if (!v.is_array()) wrong_type(v, shape, at);
  if (v.size() != n)
    fail("wrong_length", std::string("expected ") + shape + ", got an array of " + std::to_string(v.size()) +
                             (v.size() == 1 ? " element" : " elements"),
         at);
  return v;
}

Point2 point2(const json& v, const Path& at) {
  fixed_array(v, 2, "a point [x, y] of 2 numbers", at);
  return Point2{number(v[0], at / 0u), number(v[1], at / 1u)};
}

Point3 point3(const json& v, const Path& at) {
  fixed_array(v, 3, "a point [x, y, z] of 3 numbers", at);
  return Point3{number(v[0], at / 0u), number(v[1], at / 1u), number(v[2], at / 2u)};
}

std::vector<Point2> points2(const json& v, const Path& at) {
  array(v, at, "an array of points [x, y]");
  std::vector<Point2> out;
  out.reserve(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) out.push_back(point2(v[i], at / i));
  return out;
}

std::vector<int> ints(const json& v, const Path& at) {
  array(v, at, "an array of integers");
  std::vector<int> out;
  out.reserve(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) out.push_back(int32(v[i], at / i));
  return out;
}

std::vector<long long> longs(const json& v, const Path& at) {
  array(v, at, "an array of integers");
  std::vector<long long> out;
  out.reserve(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) out.push_back(integer(v[i], at / i));
  return out;
}

Triangle triangle(const json& v, const Path& at) {
  fixed_array(v, 3, "a triangle [i, j, k] of 3 integers", at);
  return Triangle{int32(v[0], at / 0u), int32(v[1], at / 1u), int32(v[2], at / 2u)};
}

double non_negative(const json& v, const Path& at) {
  double d = number(v, at);
  if (d < 0) fail("invalid_value", "expected a number >= 0, got " + v.dump(), at);
  return d;
}

ordered_json triangles_json(const std::vector<Triangle>& triangles) {
  ordered_json out = ordered_json::array();
  for (const Triangle& t : triangles) out.push_back({t[0], t[1], t[2]});
  return out;
}

}  // namespace

std::string detail::quote_key(std::string_view s) {
  // Keys come from the (UTF-8 validated) body; dump() escapes quotes and control characters so that a
  // message stays on one line.
  return json(std::string(s)).dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string escape_pointer_token(std::string_view token) {
  std::string out;
  out.reserve(token.size());
  for (char c : token) {
    if (c == '~') out += "~0";
    else if (c == '/') out += "~1";
    else out += c;
  }
  return out;
}

json parse_json(std::string_view text) {
  if (text.find_first_not_of(" \t\r\n") == std::string_view::npos)
    throw JsonError("invalid_json", "the document is empty", "", 0);
  json root;
  DomBuilder builder(root);
  bool ok = json::sax_parse(text.begin(), text.end(), &builder, json::input_format_t::json, /*strict=*/true);
  if (!ok || builder.error()) {
    if (builder.error()) throw *builder.error();
    throw JsonError("invalid_json", "the document is not valid JSON", "");
  }
  return root;
}

// ---- classify request -----------------------------------------------------------------------------------

BoundaryPolygon classify_request_from_json(const json& body) {
  const Path root;
  object(body, root, {"polygon", "rotation_indices"});
  BoundaryPolygon polygon;
  polygon.vertices = points2(required_member(body, "polygon", root), root / "polygon");
  if (const json* r = optional_member(body, "rotation_indices"))
    polygon.rotation_indices = ints(*r, root / "rotation_indices");
  return polygon;
}

ordered_json classify_request_to_json(const BoundaryPolygon& polygon) {
  ordered_json out;
  out["polygon"] = ordered_json::array();
  for (const Point2& p : polygon.vertices) out["polygon"].push_back({p.x, p.y});
  if (polygon.rotation_indices) out["rotation_indices"] = *polygon.rotation_indices;
  return out;
}

// ---- parametrize request ---------------------------------------------------------------------------------

namespace {
RawBoundary read_boundary(const json& value, const Path& boundary_at) {
  const json& boundary = object(value, boundary_at, {"vertices", "positions", "rotation_indices"});
  RawBoundary out;
  if (const json* v = optional_member(boundary, "vertices")) out.vertices = longs(*v, boundary_at / "vertices");
  out.positions = points2(required_member(boundary, "positions", boundary_at), boundary_at / "positions");
  if (const json* r = optional_member(boundary, "rotation_indices"))
    out.rotation_indices = longs(*r, boundary_at / "rotation_indices");
  return out;
}
}  // namespace

namespace {
// options.metric: "surface" (nullopt) or {"uv": [[u, v]...]} (paper 5.2). Counts and values are the engine's
// to judge (metric_length_mismatch, metric_non_finite, metric_degenerate): only the shape is checked here.
std::optional<std::vector<Point2>> metric_option(const json& m, const Path& at) {
  if (m.is_string()) {
    if (m.get_ref<const std::string&>() == "surface") return std::nullopt;
    fail("invalid_value", "metric must be \"surface\" or {\"uv\": [[u, v], ...]} (one point per vertex), got " + m.dump(), at);
  }
  if (!m.is_object())
    fail("wrong_type", "metric must be \"surface\" or {\"uv\": [[u, v], ...]} (one point per vertex), got " + m.dump().substr(0, 40), at);
  object(m, at, {"uv"});
  return points2(required_member(m, "uv", at), at / "uv");
}
}  // namespace

ParametrizeRequest parametrize_request_from_json(const json& body) {
  const Path root;
  object(body, root, {"mesh", "boundary", "options"});
  ParametrizeRequest request;

  const Path mesh_at = root / "mesh";
  const json& mesh = object(required_member(body, "mesh", root), mesh_at, {"vertices", "faces"});
  {
    const Path at = mesh_at / "vertices";
    const json& vertices = array(required_member(mesh, "vertices", mesh_at), at, "an array of points [x, y, z]");
    request.mesh.vertices.reserve(vertices.size());
    for (std::size_t i = 0; i < vertices.size(); ++i) request.mesh.vertices.push_back(point3(vertices[i], at / i));
  }
  {
    const Path at = mesh_at / "faces";
    const json& faces = array(required_member(mesh, "faces", mesh_at), at, "an array of faces [i, j, k]");
    request.mesh.faces.reserve(faces.size());
    for (std::size_t f = 0; f < faces.size(); ++f) {
      const Path face_at = at / f;
      const json& face = array(faces[f], face_at, "a face [i, j, k] of vertex indices");
      request.mesh.faces.open_face();
      for (std::size_t c = 0; c < face.size(); ++c) request.mesh.faces.add_index(integer(face[c], face_at / c));
    }
  }

  const Path boundary_at = root / "boundary";
  request.boundary = read_boundary(required_member(body, "boundary", root), boundary_at);

  if (const json* o = optional_member(body, "options")) {
    const Path at = root / "options";
    object(*o, at, {"method", "refine", "target_density", "untangle", "optimize", "max_iterations", "time_budget_ms", "metric"});
    if (const json* m = optional_member(*o, "method")) {
      const std::string& name = string(*m, at / "method");
      if (name == "tutte") request.options.method = MapMethod::tutte;
      else if (name == "harmonic") request.options.method = MapMethod::harmonic;
      else if (name == "extremal") request.options.method = MapMethod::extremal;
      else fail("invalid_value", "method must be \"tutte\", \"harmonic\" or \"extremal\", got " + m->dump(), at / "method");
    }
    if (const json* r = optional_member(*o, "refine")) request.options.refine = boolean(*r, at / "refine");
    if (const json* d = optional_member(*o, "target_density")) {
      double density = number(*d, at / "target_density");
      if (!(density > 0)) fail("invalid_value", "target_density must be > 0, got " + d->dump(), at / "target_density");
      request.options.target_density = density;
    }
    if (const json* u = optional_member(*o, "untangle")) request.options.untangle = boolean(*u, at / "untangle");
    if (const json* e = optional_member(*o, "optimize")) {
      if (!parse_optimize_energy(string(*e, at / "optimize"), request.options.optimize))
        fail("invalid_value", "optimize must be \"none\", \"mips\" or \"symmetric_dirichlet\", got " + e->dump(),
             at / "optimize");
    }
    if (const json* n = optional_member(*o, "max_iterations"))
      request.options.max_iterations = static_cast<int>(integer(*n, at / "max_iterations", 0, kMaxOptimizeIterations));
    if (const json* b = optional_member(*o, "time_budget_ms")) {
      const double ms = number(*b, at / "time_budget_ms");
      if (!(ms >= 0)) fail("invalid_value", "time_budget_ms must be >= 0, got " + b->dump(), at / "time_budget_ms");
      request.options.time_budget_ms = ms;
    }
    if (const json* m = optional_member(*o, "metric")) request.options.metric = metric_option(*m, at / "metric");
  }
  return request;
}

ordered_json parametrize_request_to_json(const ParametrizeRequest& request) {
  ordered_json out;
  ordered_json& mesh = out["mesh"];
  mesh["vertices"] = ordered_json::array();
  for (const Point3& p : request.mesh.vertices) mesh["vertices"].push_back({p.x, p.y, p.z});
  mesh["faces"] = ordered_json::array();
  for (const auto& f : request.mesh.faces) mesh["faces"].push_back(std::vector<long long>(f));
  ordered_json& boundary = out["boundary"];
  if (request.boundary.vertices) boundary["vertices"] = *request.boundary.vertices;
  boundary["positions"] = ordered_json::array();
  for (const Point2& p : request.boundary.positions) boundary["positions"].push_back({p.x, p.y});
  if (request.boundary.rotation_indices) boundary["rotation_indices"] = *request.boundary.rotation_indices;
  out["options"] = {{"method", to_string(request.options.method)},
                    {"refine", request.options.refine},
                    {"target_density", request.options.target_density},
                    {"untangle", request.options.untangle},
                    {"optimize", to_string(request.options.optimize)},
                    {"max_iterations", request.options.max_iterations},
                    {"time_budget_ms", request.options.time_budget_ms}};
  if (request.options.metric) {
    ordered_json uv = ordered_json::array();
    for (const Point2& p : *request.options.metric) uv.push_back({p.x, p.y});
    out["options"]["metric"] = {{"uv", std::move(uv)}};
  } else {
    out["options"]["metric"] = "surface";
  }
  return out;
}

// ---- classify answer -------------------------------------------------------------------------------------

const char* verdict_name(Verdict verdict) {
  switch (verdict) {
    case Verdict::simple: return "simple";
    case Verdict::self_overlapping: return "self_overlapping";
    case Verdict::weakly_self_overlapping: return "weakly_self_overlapping";
    case Verdict::not_self_overlapping: return "not_self_overlapping";
  }
  return "not_self_overlapping";
}

std::optional<Verdict> verdict_from_name(std::string_view name) {
  for (Verdict v : {Verdict::simple, Verdict::self_overlapping, Verdict::weakly_self_overlapping,
                    Verdict::not_self_overlapping})
    if (name == verdict_name(v)) return v;
  return std::nullopt;
}

ordered_json classification_to_json(const Classification& c) {
  ordered_json out;
  out["verdict"] = verdict_name(c.verdict);
  out["turning_number"] = c.turning_number;
  out["triangulation"] = triangles_json(c.triangulation);
  out["rotation_indices"] = c.rotation_indices;
  out["singular_vertices"] = c.singular_vertices;
  if (!c.reason.empty()) out["reason"] = c.reason;
  const ClassifyStats& s = c.stats;
  out["diagnostics"] = {{"input_vertices", s.input_vertices},
                        {"ears_clipped", s.ears_clipped},
                        {"reduced_vertices", s.reduced_vertices},
                        {"free_rotation_search", s.free_rotation_search},
                        {"table_bytes", s.table_bytes},
                        {"timings_ms", {{"ear_clipping", s.ear_clipping_ms}, {"table", s.table_ms}, {"total", s.total_ms}}}};
  return out;
}

Classification classification_from_json(const json& answer) {
  const Path root;
  object(answer, root,
         {"verdict", "turning_number", "triangulation", "rotation_indices", "singular_vertices", "reason", "diagnostics"});
  Classification c;
  const json& verdict = required_member(answer, "verdict", root);
  auto v = verdict_from_name(string(verdict, root / "verdict"));
  if (!v) fail("invalid_value", "unknown verdict " + verdict.dump(), root / "verdict");
  c.verdict = *v;
  c.turning_number = int32(required_member(answer, "turning_number", root), root / "turning_number");
  {
    const Path at = root / "triangulation";
    const json& t = array(required_member(answer, "triangulation", root), at, "an array of triangles [i, j, k]");
    c.triangulation.reserve(t.size());
    for (std::size_t i = 0; i < t.size(); ++i) c.triangulation.push_back(triangle(t[i], at / i));
  }
  c.rotation_indices = ints(required_member(answer, "rotation_indices", root), root / "rotation_indices");
  c.singular_vertices = ints(required_member(answer, "singular_vertices", root), root / "singular_vertices");
  if (const json* r = optional_member(answer, "reason")) c.reason = string(*r, root / "reason");

  const Path d_at = root / "diagnostics";
  const json& d = object(required_member(answer, "diagnostics", root), d_at,
                         {"input_vertices", "ears_clipped", "reduced_vertices", "free_rotation_search", "table_bytes",
                          "timings_ms"});
  ClassifyStats& s = c.stats;
  s.input_vertices = static_cast<int>(integer(required_member(d, "input_vertices", d_at), d_at / "input_vertices", 0, INT_MAX));
  s.ears_clipped = static_cast<int>(integer(required_member(d, "ears_clipped", d_at), d_at / "ears_clipped", 0, INT_MAX));
  s.reduced_vertices =
      static_cast<int>(integer(required_member(d, "reduced_vertices", d_at), d_at / "reduced_vertices", 0, INT_MAX));
  s.free_rotation_search = boolean(required_member(d, "free_rotation_search", d_at), d_at / "free_rotation_search");
  s.table_bytes = static_cast<std::size_t>(integer(required_member(d, "table_bytes", d_at), d_at / "table_bytes", 0));
  const Path t_at = d_at / "timings_ms";
  const json& t = object(required_member(d, "timings_ms", d_at), t_at, {"ear_clipping", "table", "total"});
  s.ear_clipping_ms = non_negative(required_member(t, "ear_clipping", t_at), t_at / "ear_clipping");
  s.table_ms = non_negative(required_member(t, "table", t_at), t_at / "table");
  s.total_ms = non_negative(required_member(t, "total", t_at), t_at / "total");
  return c;
}

// ---- text -------------------------------------------------------------------------------------------

void detail::dump_pretty(const ordered_json& v, int depth, std::string& out) {
  constexpr auto replace = ordered_json::error_handler_t::replace;
  const std::string indent(2 * (depth + 1), ' '), close(2 * depth, ' ');
  if (v.is_object() && !v.empty()) {
    out += "{\n";
    bool first = true;
    for (const auto& [key, value] : v.items()) {
      if (!first) out += ",\n";
      first = false;
      out += indent + ordered_json(key).dump(-1, ' ', false, replace) + ": ";
      dump_pretty(value, depth + 1, out);
    }
    out += "\n" + close + "}";
  } else if (v.is_array() && !v.empty() && std::any_of(v.begin(), v.end(), [](const ordered_json& e) {
               return e.is_structured();
             })) {
    out += "[\n";
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (i) out += ",\n";
      out += indent;
      dump_pretty(v[i], depth + 1, out);
    }
    out += "\n" + close + "]";
  } else if (v.is_array()) {
    out += "[";
    for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + v[i].dump(-1, ' ', false, replace);
    out += "]";
  } else {
    out += v.dump(-1, ' ', false, replace);
  }
}

std::string dump(const ordered_json& value, bool pretty) {
  if (!pretty) return value.dump(-1, ' ', false, ordered_json::error_handler_t::replace);
  std::string out;
  detail::dump_pretty(value, 0, out);
  return out;
}

// ---- errors ------------------------------------------------------------------------------------------

namespace {
bool starts_with(const std::string& s, std::string_view prefix) { return s.compare(0, prefix.size(), prefix) == 0; }
std::string with_index(std::string base, const std::optional<long long>& index) {
  if (index && *index >= 0) base += "/" + std::to_string(*index);
  return base;
}
}  // namespace

std::optional<std::string> classify_error_pointer(const InputError& error) {
  if (auto* j = dynamic_cast<const JsonError*>(&error)) return j->pointer();
  const std::string& code = error.code();
  if (starts_with(code, "rotation_ind")) return with_index("/rotation_indices", error.index());
  if (starts_with(code, "polygon_")) return with_index("/polygon", error.index());
  return std::nullopt;
}

std::optional<std::string> parametrize_error_pointer(const InputError& error) {
  if (auto* j = dynamic_cast<const JsonError*>(&error)) return j->pointer();
  const std::string& code = error.code();
  const std::string& element = error.element();
  if (code == "mesh_empty") return std::string("/mesh");
  if (element == "vertex" && error.index()) return with_index("/mesh/vertices", error.index());
  if (element == "face" && error.index()) return with_index("/mesh/faces", error.index());
  if (starts_with(code, "rotation_ind")) return with_index("/boundary/rotation_indices", error.index());
  if (code == "boundary_length_mismatch") return std::string("/boundary/positions");
  if (code == "boundary_position_non_finite") return with_index("/boundary/positions", error.index());
  if (element == "metric") return with_index("/options/metric/uv", error.index());
  if (starts_with(code, "boundary_vertex") || code == "boundary_not_loop_order")
    return with_index("/boundary/vertices", error.index());
  return std::nullopt;
}

std::string problem_type(const std::string& code) { return "urn:lipmap:problem:" + code; }

ordered_json problem_json(int status, const std::string& title, const std::string& code, const std::string& detail,
                          const std::optional<std::string>& pointer, const std::string& element,
                          std::optional<long long> index) {
  ordered_json out;
  out["type"] = problem_type(code);
  out["title"] = title;
  out["status"] = status;
  out["detail"] = detail;
  out["code"] = code;
  if (pointer) out["pointer"] = *pointer;
  if (!element.empty()) out["element"] = element;
  if (index) out["index"] = *index;
  return out;
}

// ---- boundary document, engine options, parametrize answer -----------------------------------------

RawBoundary boundary_from_json(const json& boundary) { return read_boundary(boundary, Path{}); }

std::optional<std::vector<Point2>> metric_from_json(const json& metric) { return metric_option(metric, Path{}); }

ordered_json boundary_to_json(const RawBoundary& boundary) {
  ordered_json out;
  if (boundary.vertices) out["vertices"] = *boundary.vertices;
  out["positions"] = ordered_json::array();
  for (const Point2& p : boundary.positions) out["positions"].push_back({p.x, p.y});
  if (boundary.rotation_indices) out["rotation_indices"] = *boundary.rotation_indices;
  return out;
}

namespace {
// A finite number, or null for +-inf / NaN (JSON has no infinity).
ordered_json finite_or_null(double v) { return std::isfinite(v) ? ordered_json(v) : ordered_json(nullptr); }

const char* solution_name(DiskMapSolution s) {
  switch (s) {
    case DiskMapSolution::primary: return "primary";
    case DiskMapSolution::mean_value: return "mean_value";
    case DiskMapSolution::tutte: return "tutte";
  }
  return "primary";
}
}  // namespace

ordered_json detail::result_json(const lipmap::ParametrizeResult& r, bool big) {
  ordered_json out;
  const Classification& c = r.classification;
  out["verdict"] = verdict_name(c.verdict);
  out["turning_number"] = c.turning_number;
  ordered_json singular = ordered_json::array();
  for (int k : c.singular_vertices)
    singular.push_back(k >= 0 && static_cast<std::size_t>(k) < r.boundary_loop.size() ? r.boundary_loop[k] : k);
  out["singular_vertices"] = std::move(singular);
  out["rotation_indices"] = c.rotation_indices;
  out["boundary_loop"] = r.boundary_loop;

  const RefinedMap& m = r.map;
  ordered_json vertices = ordered_json::array();
  ordered_json uv = ordered_json::array();
  ordered_json inserted = ordered_json::array();
  if (big) {
    vertices.get_ref<ordered_json::array_t&>().reserve(m.vertices.size());
    for (const Point3& p : m.vertices) vertices.push_back({p.x, p.y, p.z});
    uv.get_ref<ordered_json::array_t&>().reserve(m.uv.size());
    for (const Point2& p : m.uv) uv.push_back({p.x, p.y});
    for (const InsertedVertex& v : m.inserted) {
      ordered_json e;
      e["edge"] = {v.a, v.b};
      e["t"] = v.t;
      inserted.push_back(std::move(e));
    }
  }
  out["mesh"] = {{"vertices", std::move(vertices)},
                 {"faces", big ? triangles_json(m.faces) : ordered_json::array()}};
  out["uv"] = std::move(uv);
  out["inserted"] = std::move(inserted);

  ordered_json d;
  d["inserted_vertices"] = m.inserted.size();
  d["flipped_before_refinement"] = m.flipped_before_refinement;
  d["flipped"] = r.flipped;
  d["target_mesh"] = {{"vertices", r.target_mesh.vertices},
                      {"faces", r.target_mesh.faces},
                      {"pieces", r.target_mesh.pieces},
                      {"min_angle_deg", r.target_mesh.min_angle_deg}};
  d["intermediate_maps"] = {{"source", solution_name(r.source_map_solution)},
                            {"target", solution_name(r.target_map_solution)}};
  d["refinement"] = {{"relocated_vertices", r.relocation.moved},
                     {"flipped_after_relocation", r.relocation.flipped_after},
                     {"refined_faces", m.refined_faces},
                     {"points_before_simplification", m.points_before_simplification},
                     {"simplification_rounds", m.simplification_rounds},
                     {"regions", m.regions},
                     {"region_faces", m.region_faces},
                     {"points_slid", r.sliding.points_moved},
                     {"fixed_faces_split", r.fixed_faces.split}};
  d["untangling"] = {{"attempted", r.untangling.attempted},
                     {"succeeded", r.untangling.succeeded},
                     {"flipped_before", r.untangling.flipped_before},
                     {"flipped_after", r.untangling.flipped_after},
                     {"rounds", r.untangling.rounds},
                     {"iterations", r.untangling.iterations},
                     {"outcome", r.untangling.outcome}};
  // Distortion as {max, mean, histogram}; the lower edge of every bin (the last bin is open above, its
  // upper edge +inf is not written).
  auto distortion_json = [](const Distortion& q) {
    ordered_json edges = ordered_json::array();
    for (std::size_t i = 0; i < q.counts.size() && i < q.bin_edges.size(); ++i) edges.push_back(finite_or_null(q.bin_edges[i]));
    return ordered_json{{"max", finite_or_null(q.max)},
                        {"mean", finite_or_null(q.mean)},
                        {"histogram", {{"edges", std::move(edges)}, {"counts", q.counts}}}};
  };
  const Optimization& opt = r.optimization;
  d["optimization"] = {{"energy", to_string(opt.energy)},
                       {"ran", opt.ran},
                       {"outcome", opt.outcome},
                       {"iterations", opt.iterations},
                       {"free_vertices", opt.free_vertices},
                       {"points_removed", opt.points_removed},
                       {"free_descent_vertices", opt.free_descent_vertices},
                       {"energy_before", finite_or_null(opt.energy_before)},
                       {"energy_after", finite_or_null(opt.energy_after)},
                       {"distortion_before", opt.ran ? distortion_json(opt.before) : ordered_json(nullptr)}};
  if (r.extremal.ran) {
    const ExtremalReport& e = r.extremal;
    d["extremal"] = {{"conformal_boundary", e.conformal_boundary},
                     {"domain_fallback", e.domain_fallback},
                     {"closing_change", finite_or_null(e.closing_change)},
                     {"scale_factor_range", finite_or_null(e.scale_factor_range)},
                     {"k", finite_or_null(e.k)},
                     {"iterations", e.iterations},
                     {"chosen_iteration", e.chosen_iteration},
                     {"folded_iterates", e.folded_iterates},
                     {"harmonic_max_dilatation", finite_or_null(e.harmonic_max_dilatation)},
                     {"max_dilatation", finite_or_null(e.max_dilatation)},
                     {"relaxation", {{"ran", e.relaxation.ran},
                                     {"sweeps", e.relaxation.sweeps},
                                     {"moves", e.relaxation.moves},
                                     {"free_vertices", e.relaxation.free_vertices},
                                     {"max_k_before", finite_or_null(e.relaxation.max_before)},
                                     {"max_k_after", finite_or_null(e.relaxation.max_after)},
                                     {"fixed_max_k", finite_or_null(e.relaxation.fixed_max)},
                                     {"points_removed", e.relaxation.points_removed},
                                     {"edge_flips", e.relaxation.edge_flips},
                                     {"interior_polished", e.relaxation.polished},
                                     {"interior_moves", e.relaxation.interior_moves},
                                     {"start", e.relaxation.start},
                                     {"other_start_max_k", finite_or_null(e.relaxation.other_start_max)}}}};
  }
  d["distortion"] = distortion_json(r.distortion);
  if (r.metric.given) {
    const MetricReport& mr = r.metric;
    d["metric"] = {{"path", mr.path},
                   {"reproduced", mr.reproduced},
                   {"reference_flipped", mr.reference_flipped},
                   {"corrected_faces", mr.corrected_faces},
                   {"chart_size", mr.distance.chart_size},
                   {"distance_max", mr.distance.max},
                   {"distance_mean", mr.distance.mean}};
  }
  const StageTimings& t = r.timings;
  d["timings_ms"] = {{"validate", t.validate},     {"classify", t.classify}, {"target_mesh", t.target_mesh},
                     {"intermediate_maps", t.intermediate_maps}, {"compose", t.compose},
                     {"untangle", t.untangle},     {"refine", t.refine},     {"optimize", t.optimize},
                     {"verify", t.verify},         {"quality", t.quality},
                     {"total", t.total}};
  out["diagnostics"] = std::move(d);
  return out;
}

ordered_json parametrize_result_to_json(const lipmap::ParametrizeResult& r) { return detail::result_json(r, true); }

}  // namespace lipmap::codec
