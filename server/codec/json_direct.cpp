// The JSON codec's direct ways for big jobs (json_codec.h): a parametrize body read by simdjson straight into
// the engine's arrays, and the answer written from them, byte for byte what the DOM ways give.
#include <algorithm>
#include <atomic>
#include <charconv>
#include <cstdint>
#include <cmath>
#include <cstring>
#include <exception>
#include <mutex>
#include <new>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include <simdjson.h>

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
// simdjson's On Demand parser reads /mesh/vertices, /mesh/faces and /boundary/positions straight into the
// engine's arrays (its number parsing is what nlohmann's lexer spends most of a big body on); the small
// members (boundary vertices and rotation indices, options) are cut out as text and built into a small DOM by
// DomBuilder, as parse_json builds any body, then read by parametrize_request_from_json like any body. Only a
// plain, well-formed body is read this way: at the first thing the typed readers would have to judge (a
// wrong type or length, a float index, an unknown or repeated key, a syntax error) the reader gives up and
// the caller parses the whole text the ordinary way, which then names the error exactly as before. So an
// answer never depends on which way a body was read.
namespace od = simdjson::ondemand;

class RequestReader {
public:
  // threads > 1: the mesh's first big array (its vertices or its faces, whichever the body gives first) is
  // read by a helper thread with a parser of its own while this one reads the rest; each takes about half.
  RequestReader(ParametrizeRequest& out, int threads) : out_(out), threads_(threads) {}
  ~RequestReader() { wait_for_helper(); }

  // False: not a plain body (the DOM path judges it). The whole text is read: nothing may follow the object.
  bool read(std::string_view text, std::size_t padding) {
    static_assert(kJsonReadPadding >= simdjson::SIMDJSON_PADDING);
    std::optional<simdjson::padded_string> copy;
    simdjson::padded_string_view view;
    if (padding >= kJsonReadPadding) {
      view = simdjson::padded_string_view(text.data(), text.size(), text.size() + padding);
    } else {
      copy.emplace(text.data(), text.size());
      view = *copy;
    }
    buffer_end_ = view.data() + view.capacity();
    // Whichever way this function ends, the helper is done before the text it reads (`copy`) is freed.
    struct WaitForHelper {
      RequestReader& reader;
      ~WaitForHelper() { reader.wait_for_helper(); }
    } wait_for_helper_on_exit{*this};
    od::parser parser;
    od::document doc;
    od::object root;
    if (parser.iterate(view).get(doc) || doc.get_object().get(root)) return false;
    const bool ok = members(root, [&](std::string_view key, od::value value) {
      if (key == "mesh") return first(kMesh) && mesh(value);
      if (key == "boundary") return first(kBoundary) && boundary(value);
      if (key == "options") return first(kOptions) && small_member(value, od::json_type::object, rest_["options"], 1);
      return false;
    }) && at_end(doc);
    // The helper's rows count only when both readers accepted their parts.
    return join_helper() && ok;
  }

  // The members read here, as the DOM the typed readers expect: the big arrays empty (filled already).
  json& rest() { return rest_; }
  unsigned seen() const { return seen_; }

  static constexpr unsigned kMesh = 1, kBoundary = 2, kOptions = 4, kVertices = 8, kFaces = 16, kPositions = 32,
                            kBoundaryVertices = 64, kRotation = 128;

private:
  // Each member this reader fills may come once; a repeated one is for the DOM to report.
  bool first(unsigned bit) {
    if (seen_ & bit) return false;
    seen_ |= bit;
    return true;
  }

  // Each member of an object handed to take(key, value); false at the first it refuses.
  template <class Take>
  static bool members(od::object& object, Take take) {
    for (auto member : object) {
      std::string_view key;
      od::value value;
      if (member.unescaped_key().get(key) || member.value().get(value) || !take(key, value)) return false;
    }
    return true;
  }

  // Each element of an array of arrays (a value, or a document that is one) handed to take(row); false at
  // the first it refuses.
  template <class Value, class Take>
  static bool rows_of(Value&& value, Take take) {
    od::array rows;
    if (value.get_array().get(rows)) return false;
    for (auto element : rows) {
      od::array row;
      if (element.get_array().get(row) || !take(row)) return false;
    }
    return true;
  }

  // At the end of the text, current_location has no place to give.
  static bool at_end(od::document& doc) {
    const char* at = nullptr;
    return doc.current_location().get(at) != simdjson::SUCCESS;
  }

  bool mesh(od::value value) {
    od::object mesh;
    if (value.get_object().get(mesh)) return false;
    return members(mesh, [&](std::string_view key, od::value v) {
      if (key == "vertices")
        return first(kVertices) && big_array(v, [](auto&& d, ParametrizeRequest& into) { return vertices(d, into); });
      if (key == "faces")
        return first(kFaces) && big_array(v, [](auto&& d, ParametrizeRequest& into) { return faces(d, into); });
      return false;
    });
  }

  template <class Value>
  static bool vertices(Value&& v, ParametrizeRequest& into) {
    return points<3>(v, [&](const double* c) { into.mesh.vertices.push_back({c[0], c[1], c[2]}); });
  }

  // ---- the helper thread -------------------------------------------------------------------------------
  // A big array read by read(value or document, into): on the helper thread when it is free, else here.
  template <class Read>
  bool big_array(od::value v, Read read) {
    if (threads_ > 1 && !helper_.joinable() && !helper_failed_) return hand_off(v, read);
    return read(v, out_);
  }

  // Reads the array `text` (with `room` readable bytes from its start) as a document of its own.
  template <class Read>
  static bool read_alone(std::string_view text, std::size_t room, Read read, ParametrizeRequest& into) {
    od::parser parser;
    od::document doc;
    return !parser.iterate(simdjson::padded_string_view(text.data(), text.size(), room)).get(doc) && read(doc, into) &&
           at_end(doc);
  }

  // The array v cut out as text (the main parser skips it) and read by read(document, into) on a helper
  // thread, into a request of its own that join_helper moves into out_. The text is read in place: what
  // follows it in the buffer (the rest of the body and its padding) is the padding simdjson needs.
  template <class Read>
  bool hand_off(od::value v, Read read) {
    od::array array;
    std::string_view text;
    if (v.get_array().get(array) || array.raw_json().get(text)) return false;
    const std::size_t room = static_cast<std::size_t>(buffer_end_ - text.data());
    try {
      helper_ = std::thread([this, text, room, read] {
        try {
          helper_ok_ = read_alone(text, room, read, helper_out_);
        } catch (...) {
          helper_error_ = std::current_exception();
        }
      });
    } catch (const std::system_error&) {  // no thread to be had: read it here
      helper_failed_ = true;
    } catch (const std::bad_alloc&) {
      helper_failed_ = true;
    }
    return helper_failed_ ? read_alone(text, room, read, out_) : true;
  }

  void wait_for_helper() noexcept {
    if (helper_.joinable()) helper_.join();
  }

  // Waits for the helper (if any) and takes its rows; false when it refused its part. The helper fills only
  // the array handed to it and this reader never fills that one, so the helper's non-empty array is its part
  // (an empty one leaves out_'s empty as it is).
  bool join_helper() {
    if (!helper_.joinable()) return true;
    helper_.join();
    if (helper_error_) std::rethrow_exception(std::exchange(helper_error_, nullptr));
    if (!helper_ok_) return false;
    if (!helper_out_.mesh.vertices.empty()) out_.mesh.vertices = std::move(helper_out_.mesh.vertices);
    if (!helper_out_.mesh.faces.empty()) out_.mesh.faces = std::move(helper_out_.mesh.faces);
    return true;
  }

  bool boundary(od::value value) {
    od::object boundary;
    if (value.get_object().get(boundary)) return false;
    json& rest = rest_["boundary"];
    return members(boundary, [&](std::string_view key, od::value v) {
      if (key == "positions")
        return first(kPositions) && points<2>(v, [&](const double* c) { out_.boundary.positions.push_back({c[0], c[1]}); });
      if (key == "vertices") return first(kBoundaryVertices) && small_member(v, od::json_type::array, rest["vertices"], 2);
      if (key == "rotation_indices")
        return first(kRotation) && small_member(v, od::json_type::array, rest["rotation_indices"], 2);
      return false;
    });
  }

  // An array of rows of N coordinates, each row handed to put.
  template <int N, class Value, class Put>
  static bool points(Value&& value, Put put) {
    return rows_of(value, [&](od::array& row) {
      double c[N];
      int k = 0;
      for (auto x : row) {
        od::value v;
        if (k == N || x.get(v) || !coordinate(v, c[k++])) return false;
      }
      if (k != N) return false;
      put(c);
      return true;
    });
  }

  // A coordinate as nlohmann reads it: an integer through its integer value (so -0 is +0.0, as nlohmann's
  // number_integer gives), any other number as the nearest double; not finite, or an integer of 2^63 or more
  // (nlohmann's number_unsigned), is left to the DOM path.
  static bool coordinate(od::value v, double& out) {
    od::number n;
    if (v.get_number().get(n)) return false;
    switch (n.get_number_type()) {
      case od::number_type::signed_integer: out = static_cast<double>(n.get_int64()); return true;
      case od::number_type::floating_point_number: out = n.get_double(); return std::isfinite(out);
      default: return false;
    }
  }

  // Faces as written, any length (validate judges them); an index must be an integer that fits a long long.
  template <class Value>
  static bool faces(Value&& value, ParametrizeRequest& into) {
    return rows_of(value, [&](od::array& row) {
      into.mesh.faces.open_face();
      for (auto x : row) {
        std::int64_t i;
        if (x.get_int64().get(i)) return false;
        into.mesh.faces.add_index(i);
      }
      return true;
    });
  }

  // A small member of the expected type, cut out as text and built into `into` by DomBuilder (its nesting
  // counted from `depth` containers out, its duplicate keys and overflowing numbers refused as in parse_json).
  static bool small_member(od::value value, od::json_type type, json& into, std::size_t depth) {
    od::json_type t;
    if (value.type().get(t) || t != type) return false;
    std::string_view text;
    if (type == od::json_type::object) {
      od::object o;
      if (value.get_object().get(o) || o.raw_json().get(text)) return false;
    } else {
      od::array a;
      if (value.get_array().get(a) || a.raw_json().get(text)) return false;
    }
    DomBuilder builder(into, depth);
    return json::sax_parse(text.begin(), text.end(), &builder, json::input_format_t::json, /*strict=*/true) &&
           !builder.error() && builder.done();
  }

  ParametrizeRequest& out_;
  unsigned seen_ = 0;  // the reader's members seen so far (one object of each kind per body)
  json rest_ = json::object();
  const int threads_;
  const char* buffer_end_ = nullptr;  // the end of the text's padding
  std::thread helper_;
  ParametrizeRequest helper_out_;
  bool helper_ok_ = false, helper_failed_ = false;
  std::exception_ptr helper_error_;
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

char* put_vertex(char* p, const Point3& q, std::string_view sep) {
  *p++ = '[';
  p = put_double(p, q.x);
  p = put_text(p, sep);
  p = put_double(p, q.y);
  p = put_text(p, sep);
  p = put_double(p, q.z);
  *p++ = ']';
  return p;
}

char* put_uv(char* p, const Point2& q, std::string_view sep) {
  *p++ = '[';
  p = put_double(p, q.x);
  p = put_text(p, sep);
  p = put_double(p, q.y);
  *p++ = ']';
  return p;
}

template <class Index>
char* put_face(char* p, Index a, Index b, Index c, std::string_view sep) {
  *p++ = '[';
  p = put_int(p, a);
  p = put_text(p, sep);
  p = put_int(p, b);
  p = put_text(p, sep);
  p = put_int(p, c);
  *p++ = ']';
  return p;
}

// The big arrays at depth `depth` of dump_pretty (pretty) or on one line (compact). Each row is formatted
// into a small buffer and appended at once: one call into the string per row, not one per character.
struct BigArrays {
  enum Kind { kVertices, kFaces, kUv, kInserted };
  const lipmap::ParametrizeResult& r;
  const ordered_json *vertices, *faces, *uv, *inserted;

  std::optional<Kind> kind_of(const ordered_json& v) const {
    if (&v == vertices) return kVertices;
    if (&v == faces) return kFaces;
    if (&v == uv) return kUv;
    if (&v == inserted) return kInserted;
    return std::nullopt;
  }

  std::size_t rows(Kind k) const {
    switch (k) {
      case kVertices: return r.map.vertices.size();
      case kFaces: return r.map.faces.size();
      case kUv: return r.map.uv.size();
      case kInserted: return r.map.inserted.size();
    }
    return 0;
  }

  // "[" and the first line break: what comes before row 0 of a non-empty array.
  static void open(bool pretty, std::string& out) { out += pretty ? "[\n" : "["; }
  static void close(int depth, bool pretty, std::string& out) {
    if (pretty) out += "\n" + std::string(2 * depth, ' ');
    out += ']';
  }

  // Rows [begin, end) of array k, each after its separator and indent (row 0 after the indent alone).
  void span(Kind k, std::size_t begin, std::size_t end, int depth, bool pretty, std::string& out) const {
    switch (k) {
      case kVertices: return span(begin, end, depth, pretty, out, [&](std::size_t i, char* p, std::string_view sep) {
        return put_vertex(p, r.map.vertices[i], sep);
      });
      case kFaces: return span(begin, end, depth, pretty, out, [&](std::size_t i, char* p, std::string_view sep) {
        const Triangle& t = r.map.faces[i];
        return put_face(p, t[0], t[1], t[2], sep);
      });
      case kUv: return span(begin, end, depth, pretty, out, [&](std::size_t i, char* p, std::string_view sep) {
        return put_uv(p, r.map.uv[i], sep);
      });
      case kInserted: {
        const std::string member(2 * (depth + 2), ' '), close(2 * (depth + 1), ' ');
        return span(begin, end, depth, pretty, out, [&](std::size_t i, char* p, std::string_view sep) {
          const InsertedVertex& iv = r.map.inserted[i];
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
      }
    }
  }

  // row(i, p, sep) writes row i at p (within the buffer sized below) and returns its end.
  template <class Row>
  static void span(std::size_t begin, std::size_t end, int depth, bool pretty, std::string& out, Row row) {
    const std::string_view sep = pretty ? ", " : ",";
    // Separator and indent, then a row: three numbers and their separators, or an inserted vertex with
    // two member indents.
    const std::string lead = pretty ? ",\n" + std::string(2 * (depth + 1), ' ') : ",";
    const std::size_t room = lead.size() + 8 * kNumberRoom + 4 * lead.size() + 64;
    std::vector<char> buf(room);
    for (std::size_t i = begin; i < end; ++i) {
      char* p = buf.data();
      p = i ? put_text(p, lead) : put_text(p, std::string_view(lead).substr(pretty ? 2 : 1));
      p = row(i, p, sep);
      out.append(buf.data(), static_cast<std::size_t>(p - buf.data()));
    }
  }
};

// Where the walk met a big array: its rows go at offset `at` of the walk's text.
struct BigPlace {
  std::size_t at;
  BigArrays::Kind kind;
  int depth;
};

// The skeleton's text, with each non-empty big array's rows written in place (places == nullptr) or left
// out and their places noted (written later, in parallel).
void write_answer(const ordered_json& v, int depth, bool pretty, const BigArrays& big, std::string& out,
                  std::vector<BigPlace>* places) {
  if (const auto kind = big.kind_of(v)) {
    const std::size_t n = big.rows(*kind);
    if (n == 0) {
      out += "[]";
      return;
    }
    BigArrays::open(pretty, out);
    if (places) places->push_back({out.size(), *kind, depth});
    else big.span(*kind, 0, n, depth, pretty, out);
    BigArrays::close(depth, pretty, out);
    return;
  }
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
    write_answer(value, depth + 1, pretty, big, out, places);
  }
  if (pretty) out += "\n" + close;
  out += '}';
}

// Rows per span of the parallel writer, and per block of MeshRowsAhead (so that a block is a span).
constexpr std::size_t kBlockRows = 8192;

}  // namespace

// ---- the request's mesh rows formatted ahead ---------------------------------------------------------------
struct MeshRowsAhead::Impl {
  explicit Impl(const RawMesh& m) : mesh(m) {
    vertex_blocks.resize((mesh.vertices.size() + kBlockRows - 1) / kBlockRows);
    face_blocks.resize((mesh.faces.size() + kBlockRows - 1) / kBlockRows);
  }

  // Block after block, the vertices' then the faces' (compact text, as the answer's spans), until told to stop.
  void run() {
    try {
      const auto any_rows = [](std::size_t, std::size_t) { return true; };
      const bool all_vertices = blocks(vertex_blocks, mesh.vertices.size(), 64, vertices_done, any_rows,
                                       [&](std::size_t i, char* p, std::string_view sep) {
                                         return put_vertex(p, mesh.vertices[i], sep);
                                       });
      if (!all_vertices) return;
      const auto triangles = [&](std::size_t b, std::size_t e) {  // else not a mesh the engine maps
        for (std::size_t f = b; f < e; ++f)
          if (mesh.faces[f].size() != 3) return false;
        return true;
      };
      blocks(face_blocks, mesh.faces.size(), 24, faces_done, triangles, [&](std::size_t i, char* p, std::string_view sep) {
        const FaceList::ConstFace f = mesh.faces[i];
        return put_face(p, f[0], f[1], f[2], sep);
      });
    } catch (...) {  // out of memory: the answer formats what is missing itself
    }
  }

  // The blocks of an array of `rows` rows (about `row_bytes` each) in order, each published in `done` once
  // written; false at the first block `usable` refuses, or when told to stop.
  template <class Usable, class Row>
  bool blocks(std::vector<std::string>& texts, std::size_t rows, std::size_t row_bytes, std::atomic<std::size_t>& done,
              Usable usable, Row row) {
    for (std::size_t k = 0; k < texts.size(); ++k) {
      const std::size_t b = k * kBlockRows, e = std::min(rows, b + kBlockRows);
      if (stop.load(std::memory_order_relaxed) || !usable(b, e)) return false;
      texts[k].reserve(row_bytes * (e - b));
      BigArrays::span(b, e, 0, false, texts[k], row);
      done.store(k + 1, std::memory_order_release);
    }
    return true;
  }

  // The text of rows [begin, end) of the answer's array `kind` moved into `out`, when a finished block holds
  // exactly those rows and the answer's rows are the request's, bit for bit; false otherwise.
  bool take(BigArrays::Kind kind, std::size_t begin, std::size_t end, const ParametrizeResult& r, std::string& out) {
    if (begin % kBlockRows != 0) return false;
    const std::size_t k = begin / kBlockRows;
    if (kind == BigArrays::kVertices) {
      if (k >= vertices_done.load(std::memory_order_acquire) || end != std::min(mesh.vertices.size(), begin + kBlockRows))
        return false;
      if (std::memcmp(&r.map.vertices[begin], &mesh.vertices[begin], (end - begin) * sizeof(Point3)) != 0) return false;
      out = std::move(vertex_blocks[k]);
      return true;
    }
    if (kind == BigArrays::kFaces) {
      if (k >= faces_done.load(std::memory_order_acquire) || end != std::min(mesh.faces.size(), begin + kBlockRows))
        return false;
      const long long* raw = mesh.faces.indices().data() + 3 * begin;  // every face up to `end` is a triangle
      for (std::size_t f = begin; f < end; ++f, raw += 3)
        if (r.map.faces[f][0] != raw[0] || r.map.faces[f][1] != raw[1] || r.map.faces[f][2] != raw[2]) return false;
      out = std::move(face_blocks[k]);
      return true;
    }
    return false;
  }

  const RawMesh& mesh;
  std::vector<std::string> vertex_blocks, face_blocks;
  std::atomic<std::size_t> vertices_done{0}, faces_done{0};
  std::atomic<bool> stop{false};
  std::thread thread;
};

bool MeshRowsAhead::pays_off(const RawMesh& mesh) {
  return mesh.vertices.size() + mesh.faces.size() >= kParallelAnswerRows;
}

MeshRowsAhead::MeshRowsAhead(const RawMesh& mesh) : impl_(std::make_unique<Impl>(mesh)) {
  try {
    impl_->thread = std::thread([impl = impl_.get()] { impl->run(); });
  } catch (const std::system_error&) {  // no thread to be had: nothing is formatted ahead
  } catch (const std::bad_alloc&) {
  }
}

void MeshRowsAhead::wait() {
  if (impl_->thread.joinable()) impl_->thread.join();
}

MeshRowsAhead::~MeshRowsAhead() {
  impl_->stop.store(true, std::memory_order_relaxed);
  if (impl_->thread.joinable()) impl_->thread.join();
}

namespace {

// The answer with its big arrays cut into spans of kBlockRows rows, formatted by `threads` threads (this one
// and threads - 1 more), then joined in order: the same bytes as one thread writes, sooner. Spans of the
// mesh's rows that `ahead` has formatted already are taken from it.
std::string write_answer_in_parallel(const ordered_json& skeleton, bool pretty, const BigArrays& big, int threads,
                                     MeshRowsAhead::Impl* ahead) {
  std::string frame;
  std::vector<BigPlace> places;
  write_answer(skeleton, 0, pretty, big, frame, &places);
  struct Span {
    const BigPlace* place;
    std::size_t begin, end;
    std::string text;
  };
  // Many spans per thread, so that threads finishing early take more.
  std::vector<Span> spans;
  for (const BigPlace& p : places)
    for (std::size_t b = 0, n = big.rows(p.kind); b < n; b += kBlockRows) spans.push_back({&p, b, std::min(n, b + kBlockRows), {}});
  std::atomic<std::size_t> next{0};
  std::mutex error_mutex;
  std::exception_ptr error;
  auto work = [&] {
    try {
      for (std::size_t i; (i = next.fetch_add(1)) < spans.size();) {
        Span& s = spans[i];
        if (ahead && !pretty && ahead->take(s.place->kind, s.begin, s.end, big.r, s.text)) continue;
        s.text.reserve(64 * (s.end - s.begin));
        big.span(s.place->kind, s.begin, s.end, s.place->depth, pretty, s.text);
      }
    } catch (...) {  // out of memory: the others stop at their next span, and the caller gets the error
      next = spans.size();
      const std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
    }
  };
  std::vector<std::thread> helpers;
  try {
    for (int t = 1; t < threads; ++t) helpers.emplace_back(work);
  } catch (const std::exception&) {  // no more threads to be had: those started and this one do the work
  }
  work();
  for (std::thread& t : helpers) t.join();
  if (error) std::rethrow_exception(error);
  std::size_t size = frame.size();
  for (const Span& s : spans) size += s.text.size();
  std::string out;
  out.reserve(size);
  std::size_t copied = 0;
  for (const Span& s : spans) {
    out.append(frame, copied, s.place->at - copied);
    copied = s.place->at;
    out += s.text;
  }
  out.append(frame, copied, std::string::npos);
  return out;
}

}  // namespace

std::size_t pad_for_reading(std::string& text) {
  if (text.capacity() - text.size() < kJsonReadPadding) return 0;
  const std::size_t size = text.size();
  text.append(kJsonReadPadding, '\0');
  text.resize(size);
  return kJsonReadPadding;
}

std::optional<ParametrizeRequest> parametrize_request_from_text(std::string_view text, std::size_t padding,
                                                                int threads) {
  ParametrizeRequest big;
  // A thread's start pays off only for a big body.
  constexpr std::size_t kParallelReadBytes = std::size_t(1) << 20;
  RequestReader reader(big, text.size() >= kParallelReadBytes ? threads : 1);
  if (!reader.read(text, padding)) return std::nullopt;
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

std::string parametrize_result_to_text(const lipmap::ParametrizeResult& r, bool pretty, int threads,
                                      MeshRowsAhead* ahead) {
  const ordered_json skeleton = result_json(r, false);
  const ordered_json& mesh = skeleton["mesh"];
  const BigArrays big{r, &mesh["vertices"], &mesh["faces"], &skeleton["uv"], &skeleton["inserted"]};
  // More threads pay off only for big answers (a thread's start and the join's copy cost about 0.1 ms + 1 ms
  // per 5 MB of text).
  // What the ahead thread has not formatted yet, the writer formats itself: the thread stops at its block.
  if (ahead) ahead->impl_->stop.store(true, std::memory_order_relaxed);
  if ((threads > 1 || ahead) && r.map.vertices.size() + r.map.faces.size() + r.map.uv.size() >= kParallelAnswerRows)
    return write_answer_in_parallel(skeleton, pretty, big, threads, ahead ? ahead->impl_.get() : nullptr);
  std::string out;
  // About what the numbers take (shortest doubles are mostly 17 to 20 characters), to grow the text once
  // or twice rather than many times.
  out.reserve(64 * r.map.vertices.size() + 24 * r.map.faces.size() + 44 * r.map.uv.size() +
              64 * r.map.inserted.size() + 4096);
  write_answer(skeleton, 0, pretty, big, out, nullptr);
  return out;
}

}  // namespace lipmap::codec
