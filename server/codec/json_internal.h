// What json_codec.cpp (the typed readers, the DOM writer) and json_direct.cpp (the SAX reader and the direct
// answer writer of big jobs) share; internal to server/codec.
#pragma once

#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/codec/json_codec.h"

namespace lipmap::codec::detail {

using nlohmann::json;
using nlohmann::ordered_json;

// A key quoted for a message, control characters escaped.
std::string quote_key(std::string_view s);

// dump(value, true) of a value at `depth`, appended to out.
void dump_pretty(const ordered_json& v, int depth, std::string& out);

// The answer as a DOM; with big = false its four big arrays (mesh vertices and faces, uv, inserted) are left
// empty, for parametrize_result_to_text to write straight from the engine's arrays.
ordered_json result_json(const lipmap::ParametrizeResult& r, bool big);

// ---- the parser's output: a DOM built through nlohmann's SAX interface ---------------------------------
// nlohmann does all the lexing and parsing; this only builds the tree while keeping track of where it
// is, so that errors the parser finds (overflow, syntax) still come with a JSON pointer, and so that
// duplicate keys and absurd nesting are refused instead of silently accepted.
class DomBuilder {
public:
  // outer: containers already open around root_ (a subtree read by RequestReader), for the nesting limit.
  explicit DomBuilder(json& root, std::size_t outer = 0) : root_(root), outer_(outer) {}
  // True once the value at the root is complete (a scalar, or its container closed).
  bool done() const { return started_ && stack_.empty(); }

  bool null() { return put(nullptr); }
  bool boolean(bool b) { return put(b); }
  bool number_integer(json::number_integer_t v) { return put(v); }
  bool number_unsigned(json::number_unsigned_t v) { return put(v); }
  bool number_float(json::number_float_t v, const json::string_t& token) {
    if (!std::isfinite(v)) return stop("non_finite_number", "number " + token + " does not fit in a double");
    return put(v);
  }
  bool string(json::string_t& s) { return put(std::move(s)); }
  bool binary(json::binary_t& b) { return put(std::move(b)); }

  bool start_object(std::size_t) { return open(json::value_t::object); }
  bool key(json::string_t& k) {
    Frame& f = stack_.back();
    if (f.value->contains(k)) {
      f.key = k;
      return stop("duplicate_key", "key " + quote_key(k) + " appears more than once in the same object");
    }
    f.key = std::move(k);
    return true;
  }
  bool end_object() { stack_.pop_back(); return true; }
  bool start_array(std::size_t) { return open(json::value_t::array); }
  bool end_array() { stack_.pop_back(); return true; }

  bool parse_error(std::size_t position, const std::string& last_token, const nlohmann::detail::exception& ex) {
    if (ex.id == 406) {  // out_of_range.406: a number literal that overflows a double
      std::string token = last_token.size() > 40 ? last_token.substr(0, 40) + "..." : last_token;
      return stop("non_finite_number", "number " + token + " does not fit in a double");
    }
    // "[json.exception.parse_error.101] parse error at line 1, column 5: syntax error ..." -> the part
    // after the bracketed id, cut to a sane length (the last token of a huge string is huge).
    std::string what = ex.what();
    if (auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    if (what.size() > 200) what = what.substr(0, 200) + "...";
    for (char& c : what)
      if (static_cast<unsigned char>(c) < 0x20) c = ' ';
    error_.emplace("invalid_json", what, pointer(), static_cast<long long>(position));
    return false;
  }

  std::optional<JsonError>& error() { return error_; }

private:
  struct Frame {
    json* value;
    std::string key;  // objects: the member being read
  };

  json* slot() {
    started_ = true;
    if (stack_.empty()) return &root_;
    Frame& f = stack_.back();
    if (f.value->is_array()) {
      f.value->push_back(nullptr);
      return &f.value->back();
    }
    return &(*f.value)[f.key];
  }
  bool put(json v) {
    *slot() = std::move(v);
    return true;
  }
  bool open(json::value_t type) {
    if (stack_.size() + outer_ >= static_cast<std::size_t>(kMaxNesting))
      return stop("nesting_too_deep", "arrays and objects are nested deeper than " + std::to_string(kMaxNesting));
    json* s = slot();
    *s = json(type);
    stack_.push_back(Frame{s, {}});
    return true;
  }
  bool stop(const char* code, const std::string& message) {
    error_.emplace(code, message, pointer());
    return false;
  }
  // Where the parser is: the member or element being read in every open container.
  std::string pointer() const {
    // An open array's last element is the open container below it; the innermost array's next element
    // is the value being read.
    std::string out;
    for (std::size_t i = 0; i < stack_.size(); ++i) {
      const Frame& f = stack_[i];
      out += '/';
      if (f.value->is_array()) {
        std::size_t n = f.value->size();
        out += std::to_string(i + 1 < stack_.size() && n > 0 ? n - 1 : n);
      } else {
        out += escape_pointer_token(f.key);
      }
    }
    return out;
  }

  json& root_;
  std::size_t outer_ = 0;
  bool started_ = false;
  std::vector<Frame> stack_;
  std::optional<JsonError> error_;
};

}  // namespace lipmap::codec::detail
