// The JSON codec's direct ways for big jobs (json_codec.h): a parametrize body read by SAX straight into the
// engine's arrays, and the answer written from them, byte for byte what the DOM ways give.
#include <charconv>
#include <climits>
#include <cmath>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

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
        out_.mesh.faces.emplace_back().reserve(3);  // one allocation for a triangle, not three
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

// A double exactly as nlohmann's serializer writes it (null when not finite), at p; returns the end. The
// digits are nlohmann's own (nlohmann::detail::to_chars, Grisu2, the function its serializer calls), not
// std::to_chars: Grisu2 is not always the shortest or the closest round trip (3.5310992121163152e+16 where
// std::to_chars writes 3.531099212116315e+16, 237974192.66879266 for ...267), and the answer's bytes must
// not change. Needs kNumberRoom bytes at p.
constexpr std::size_t kNumberRoom = 32;  // "-", 17 digits, "0.000" or "e-308": at most 25
char* put_double(char* p, double x) {
  if (!std::isfinite(x)) {  // not reached for a verified map
    std::memcpy(p, "null", 4);
    return p + 4;
  }
  return nlohmann::detail::to_chars(p, p + kNumberRoom, x);
}

char* put_int(char* p, long long v) { return std::to_chars(p, p + kNumberRoom, v).ptr; }

char* put_text(char* p, std::string_view s) {
  std::memcpy(p, s.data(), s.size());
  return p + s.size();
}

// The big arrays at depth `depth` of dump_pretty (pretty) or on one line (compact). Each row is formatted
// into a small buffer and appended at once: one call into the string per row, not one per character.
struct BigArrays {
  const lipmap::ParametrizeResult& r;
  const ordered_json *vertices, *faces, *uv, *inserted;

  // Writes `v` when it is one of the big arrays' places; false otherwise.
  bool write(const ordered_json& v, int depth, bool pretty, std::string& out) const {
    const RefinedMap& m = r.map;
    const std::string_view sep = pretty ? ", " : ",";
    if (&v == vertices) rows(m.vertices.size(), depth, pretty, out, [&](std::size_t i, char* p) {
      const Point3& q = m.vertices[i];
      *p++ = '[';
      p = put_double(p, q.x);
      p = put_text(p, sep);
      p = put_double(p, q.y);
      p = put_text(p, sep);
      p = put_double(p, q.z);
      *p++ = ']';
      return p;
    });
    else if (&v == faces) rows(m.faces.size(), depth, pretty, out, [&](std::size_t i, char* p) {
      const Triangle& t = m.faces[i];
      *p++ = '[';
      p = put_int(p, t[0]);
      p = put_text(p, sep);
      p = put_int(p, t[1]);
      p = put_text(p, sep);
      p = put_int(p, t[2]);
      *p++ = ']';
      return p;
    });
    else if (&v == uv) rows(m.uv.size(), depth, pretty, out, [&](std::size_t i, char* p) {
      const Point2& q = m.uv[i];
      *p++ = '[';
      p = put_double(p, q.x);
      p = put_text(p, sep);
      p = put_double(p, q.y);
      *p++ = ']';
      return p;
    });
    else if (&v == inserted) {
      const std::string member(2 * (depth + 2), ' '), close(2 * (depth + 1), ' ');
      rows(m.inserted.size(), depth, pretty, out, [&](std::size_t i, char* p) {
        const InsertedVertex& iv = m.inserted[i];
        if (pretty) p = put_text(put_text(put_text(p, "{\n"), member), "\"edge\": [");
        else p = put_text(p, "{\"edge\":[");
        p = put_int(p, iv.a);
        p = put_text(p, sep);
        p = put_int(p, iv.b);
        if (pretty) p = put_text(put_text(put_text(p, "],\n"), member), "\"t\": ");
        else p = put_text(p, "],\"t\":");
        p = put_double(p, iv.t);
        if (pretty) p = put_text(put_text(p, "\n"), close);
        *p++ = '}';
        return p;
      });
    } else {
      return false;
    }
    return true;
  }

  // An array of n structured rows: one line compact, one row per line pretty (dump_pretty's layout).
  // row(i, p) writes row i at p (within the buffer sized below) and returns its end.
  template <class Row>
  static void rows(std::size_t n, int depth, bool pretty, std::string& out, Row row) {
    if (n == 0) {
      out += "[]";
      return;
    }
    // Separator and indent, then a row: three numbers and their separators, or an inserted vertex with
    // two member indents.
    const std::string lead = pretty ? ",\n" + std::string(2 * (depth + 1), ' ') : ",";
    const std::size_t room = lead.size() + 8 * kNumberRoom + 4 * lead.size() + 64;
    std::vector<char> buf(room);
    out += pretty ? "[\n" : "[";
    for (std::size_t i = 0; i < n; ++i) {
      char* p = buf.data();
      p = i ? put_text(p, lead) : put_text(p, std::string_view(lead).substr(pretty ? 2 : 1));
      p = row(i, p);
      out.append(buf.data(), static_cast<std::size_t>(p - buf.data()));
    }
    if (pretty) out += "\n" + std::string(2 * depth, ' ');
    out += ']';
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
