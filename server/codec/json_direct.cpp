// The JSON codec's direct ways for big jobs (json_codec.h): a parametrize body read by SAX straight into the
// engine's arrays, and the answer written from them, byte for byte what the DOM ways give.
#include <charconv>
#include <climits>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>

#include "engine/pipeline.h"
#include "server/codec/json_codec.h"
#include "server/codec/json_internal.h"

namespace lipmap::codec {

using nlohmann::json;
using nlohmann::ordered_json;

namespace {

using detail::DomBuilder;
using detail::dump_pretty;
using detail::result_json;

// ---- a parametrize body without a DOM for its big arrays ---------------------------------------------
// nlohmann's SAX events go straight into the engine's arrays for /mesh/vertices, /mesh/faces and
// /boundary/positions; the small members (boundary vertices and rotation indices, options) are built into a
// small DOM by DomBuilder and read by parametrize_request_from_json like any body. Only a plain, well-formed
// body is read this way: at the first thing the typed readers would have to judge (a wrong type or length, a
// float index, an unknown or repeated key, a syntax error) the reader gives up and the caller parses the
// whole text the ordinary way, which then names the error exactly as before. So an answer never depends on
// which way a body was read.
class RequestReader {
public:
  explicit RequestReader(ParametrizeRequest& out) : out_(out) {}

  bool null() { return capture_ ? forward([&] { return capture_->null(); }) : false; }
  bool boolean(bool b) { return capture_ ? forward([&] { return capture_->boolean(b); }) : false; }
  bool number_integer(json::number_integer_t v) {
    if (capture_) return forward([&] { return capture_->number_integer(v); });
    return number(static_cast<double>(v), static_cast<long long>(v));
  }
  bool number_unsigned(json::number_unsigned_t v) {
    if (capture_) return forward([&] { return capture_->number_unsigned(v); });
    if (v > static_cast<json::number_unsigned_t>(LLONG_MAX)) return false;
    return number(static_cast<double>(v), static_cast<long long>(v));
  }
  bool number_float(json::number_float_t v, const json::string_t& token) {
    if (capture_) return forward([&] { return capture_->number_float(v, token); });
    if (!std::isfinite(v) || state_ == State::face) return false;  // an index written as a float: the DOM judges
    return number(v, 0);
  }
  bool string(json::string_t& s) { return capture_ ? forward([&] { return capture_->string(s); }) : false; }
  bool binary(json::binary_t&) { return false; }

  bool start_object(std::size_t n) {
    if (capture_) return forward([&] { return capture_->start_object(n); });
    switch (state_) {
      case State::start: state_ = State::root; return true;
      case State::mesh_value: state_ = State::mesh; return true;
      case State::boundary_value: state_ = State::boundary; return true;
      default: return false;
    }
  }
  bool key(json::string_t& k) {
    if (capture_) return forward([&] { return capture_->key(k); });
    // Members this reader fills (bit) in the object being read; a repeated one is for the DOM to report.
    auto take = [&](unsigned bit, State next) {
      if (seen_ & bit) return false;
      seen_ |= bit;
      state_ = next;
      return true;
    };
    auto capture = [&](unsigned bit, json& into, std::size_t depth) {
      if (seen_ & bit) return false;
      seen_ |= bit;
      capture_.emplace(into, depth);
      return true;
    };
    if (state_ == State::root) {
      if (k == "mesh") return take(kMesh, State::mesh_value);
      if (k == "boundary") return take(kBoundary, State::boundary_value);
      if (k == "options") return capture(kOptions, rest_["options"], 1);
    } else if (state_ == State::mesh) {
      if (k == "vertices") return take(kVertices, State::vertices_value);
      if (k == "faces") return take(kFaces, State::faces_value);
    } else if (state_ == State::boundary) {
      if (k == "positions") return take(kPositions, State::positions_value);
      if (k == "vertices") return capture(kBoundaryVertices, rest_["boundary"]["vertices"], 2);
      if (k == "rotation_indices") return capture(kRotation, rest_["boundary"]["rotation_indices"], 2);
    }
    return false;
  }
  bool end_object() {
    if (capture_) return forward([&] { return capture_->end_object(); });
    if (state_ == State::mesh || state_ == State::boundary) {
      state_ = State::root;
      return true;
    }
    if (state_ == State::root) {
      state_ = State::end;
      return true;
    }
    return false;
  }
  bool start_array(std::size_t n) {
    if (capture_) return forward([&] { return capture_->start_array(n); });
    switch (state_) {
      case State::vertices_value: state_ = State::vertices; return true;
      case State::faces_value: state_ = State::faces; return true;
      case State::positions_value: state_ = State::positions; return true;
      case State::vertices: state_ = State::vertex; count_ = 0; return true;
      case State::positions: state_ = State::position; count_ = 0; return true;
      case State::faces:
        state_ = State::face;
        out_.mesh.faces.emplace_back();
        return true;
      default: return false;
    }
  }
  bool end_array() {
    if (capture_) return forward([&] { return capture_->end_array(); });
    switch (state_) {
      case State::vertex:
        if (count_ != 3) return false;
        out_.mesh.vertices.push_back({value_[0], value_[1], value_[2]});
        state_ = State::vertices;
        return true;
      case State::position:
        if (count_ != 2) return false;
        out_.boundary.positions.push_back({value_[0], value_[1]});
        state_ = State::positions;
        return true;
      case State::face: state_ = State::faces; return true;
      case State::vertices:
      case State::faces: state_ = State::mesh; return true;
      case State::positions: state_ = State::boundary; return true;
      default: return false;
    }
  }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) { return false; }

  // The members read here, as the DOM the typed readers expect: the big arrays empty (filled already).
  json& rest() { return rest_; }
  unsigned seen() const { return seen_; }
  bool finished() const { return state_ == State::end; }

  static constexpr unsigned kMesh = 1, kBoundary = 2, kOptions = 4, kVertices = 8, kFaces = 16, kPositions = 32,
                            kBoundaryVertices = 64, kRotation = 128;

private:
  enum class State {
    start, root, end, mesh_value, mesh, boundary_value, boundary, vertices_value, vertices, vertex, faces_value,
    faces, face, positions_value, positions, position
  };

  bool number(double d, long long i) {
    switch (state_) {
      case State::vertex:
      case State::position:
        if (count_ >= 3) return false;
        value_[count_++] = d;
        return true;
      case State::face: out_.mesh.faces.back().push_back(i); return true;
      default: return false;
    }
  }
  // A captured member: its events go to the DOM builder until its value is complete.
  template <class Event>
  bool forward(Event event) {
    if (!event() || capture_->error()) return false;
    if (capture_->done()) capture_.reset();
    return true;
  }

  ParametrizeRequest& out_;
  State state_ = State::start;
  unsigned seen_ = 0;  // the reader's members seen so far (one object of each kind per body)
  int count_ = 0;
  double value_[3] = {0, 0, 0};
  json rest_ = json::object();
  std::optional<DomBuilder> capture_;
};

// ---- the answer's text without a DOM for its big arrays ------------------------------------------------
// Byte for byte what dump(parametrize_result_to_json(r), pretty) writes (tests/codec/test_json_codec.cpp
// compares them): the small members through dump / dump_pretty, the big arrays written here.

// A double exactly as nlohmann's serializer writes it (null when not finite). The digits are nlohmann's own
// (nlohmann::detail::to_chars, Grisu2, the function its serializer calls), not std::to_chars: Grisu2 is not
// always the shortest or the closest round trip (3.5310992121163152e+16 where std::to_chars writes
// 3.531099212116315e+16, 237974192.66879266 for ...267), and the answer's bytes must not change.
void append_double(std::string& out, double x) {
  if (!std::isfinite(x)) {  // not reached for a verified map
    out += "null";
    return;
  }
  char buf[64];
  out.append(buf, nlohmann::detail::to_chars(buf, buf + sizeof buf, x));
}

void append_int(std::string& out, long long v) {
  char buf[24];
  out.append(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}

// The big arrays at depth `depth` of dump_pretty (pretty) or on one line (compact).
struct BigArrays {
  const lipmap::ParametrizeResult& r;
  const ordered_json *vertices, *faces, *uv, *inserted;

  // Writes `v` when it is one of the big arrays' places; false otherwise.
  bool write(const ordered_json& v, int depth, bool pretty, std::string& out) const {
    const RefinedMap& m = r.map;
    if (&v == vertices) rows(m.vertices.size(), depth, pretty, out, [&](std::size_t i, const char* sep) {
      const Point3& p = m.vertices[i];
      out += '[';
      append_double(out, p.x);
      out += sep;
      append_double(out, p.y);
      out += sep;
      append_double(out, p.z);
      out += ']';
    });
    else if (&v == faces) rows(m.faces.size(), depth, pretty, out, [&](std::size_t i, const char* sep) {
      const Triangle& t = m.faces[i];
      out += '[';
      append_int(out, t[0]);
      out += sep;
      append_int(out, t[1]);
      out += sep;
      append_int(out, t[2]);
      out += ']';
    });
    else if (&v == uv) rows(m.uv.size(), depth, pretty, out, [&](std::size_t i, const char* sep) {
      const Point2& p = m.uv[i];
      out += '[';
      append_double(out, p.x);
      out += sep;
      append_double(out, p.y);
      out += ']';
    });
    else if (&v == inserted) {
      const std::string member(2 * (depth + 2), ' '), close(2 * (depth + 1), ' ');
      rows(m.inserted.size(), depth, pretty, out, [&](std::size_t i, const char* sep) {
        const InsertedVertex& iv = m.inserted[i];
        if (pretty) out += "{\n" + member + "\"edge\": [";
        else out += "{\"edge\":[";
        append_int(out, iv.a);
        out += sep;
        append_int(out, iv.b);
        if (pretty) out += "],\n" + member + "\"t\": ";
        else out += "],\"t\":";
        append_double(out, iv.t);
        if (pretty) out += "\n" + close;
        out += '}';
      });
    } else {
      return false;
    }
    return true;
  }

  // An array of n structured rows: one line compact, one row per line pretty (dump_pretty's layout).
  template <class Row>
  static void rows(std::size_t n, int depth, bool pretty, std::string& out, Row row) {
    if (n == 0) {
      out += "[]";
      return;
    }
    const char* sep = pretty ? ", " : ",";
    if (!pretty) {
      out += '[';
      for (std::size_t i = 0; i < n; ++i) {
        if (i) out += ',';
        row(i, sep);
      }
      out += ']';
      return;
    }
    const std::string indent(2 * (depth + 1), ' '), close(2 * depth, ' ');
    out += "[\n";
    for (std::size_t i = 0; i < n; ++i) {
      if (i) out += ",\n";
      out += indent;
      row(i, sep);
    }
    out += "\n" + close + "]";
  }
};

void write_answer(const ordered_json& v, int depth, bool pretty, const BigArrays& big, std::string& out) {
  if (big.write(v, depth, pretty, out)) return;
  constexpr auto replace = ordered_json::error_handler_t::replace;
  // Only the root and "mesh" hold big arrays; every other value is written by dump / dump_pretty.
  if (!v.is_object() || v.empty() || (depth > 0 && !v.contains("vertices"))) {
    if (pretty) dump_pretty(v, depth, out);
    else out += v.dump(-1, ' ', false, replace);
    return;
  }
  const std::string indent(2 * (depth + 1), ' '), close(2 * depth, ' ');
  out += pretty ? "{\n" : "{";
  bool first = true;
  for (const auto& [key, value] : v.items()) {
    if (!first) out += pretty ? ",\n" : ",";
    first = false;
    if (pretty) out += indent;
    out += ordered_json(key).dump(-1, ' ', false, replace);
    out += pretty ? ": " : ":";
    write_answer(value, depth + 1, pretty, big, out);
  }
  if (pretty) out += "\n" + close;
  out += '}';
}

}  // namespace

std::optional<ParametrizeRequest> parametrize_request_from_text(std::string_view text) {
  ParametrizeRequest big;
  RequestReader reader(big);
  if (!json::sax_parse(text.begin(), text.end(), &reader, json::input_format_t::json, /*strict=*/true) ||
      !reader.finished())
    return std::nullopt;
  // The small members through the typed readers, with empty big arrays where the body had them, so that
  // a missing member is reported as before.
  json& rest = reader.rest();
  const unsigned seen = reader.seen();
  if (seen & RequestReader::kMesh) {
    json& mesh = rest["mesh"];
    mesh = json::object();
    if (seen & RequestReader::kVertices) mesh["vertices"] = json::array();
    if (seen & RequestReader::kFaces) mesh["faces"] = json::array();
  }
  if (seen & RequestReader::kBoundary) {
    json& boundary = rest["boundary"];
    if (boundary.is_null()) boundary = json::object();
    if (seen & RequestReader::kPositions) boundary["positions"] = json::array();
  }
  ParametrizeRequest request = parametrize_request_from_json(rest);
  request.mesh.vertices = std::move(big.mesh.vertices);
  request.mesh.faces = std::move(big.mesh.faces);
  request.boundary.positions = std::move(big.boundary.positions);
  return request;
}

std::string parametrize_result_to_text(const lipmap::ParametrizeResult& r, bool pretty) {
  const ordered_json skeleton = result_json(r, false);
  const ordered_json& mesh = skeleton["mesh"];
  const BigArrays big{r, &mesh["vertices"], &mesh["faces"], &skeleton["uv"], &skeleton["inserted"]};
  std::string out;
  // About what the numbers take (shortest doubles are mostly 17 to 20 characters), to grow the text once
  // or twice rather than many times.
  out.reserve(64 * r.map.vertices.size() + 24 * r.map.faces.size() + 44 * r.map.uv.size() +
              64 * r.map.inserted.size() + 4096);
  write_answer(skeleton, 0, pretty, big, out);
  return out;
}

}  // namespace lipmap::codec
