// Errors the engine reports. InputError is the caller's fault (bad mesh, bad polygon, bad option) and
// carries a stable code; the transport maps it to a 4xx answer or a one-line CLI message.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>

namespace lipmap {

class InputError : public std::runtime_error {
public:
  // code: stable snake_case identifier (e.g. "non_manifold_edge").
  // element: what the index refers to ("vertex", "face", "edge", "boundary", "polygon_vertex", ...).
  InputError(std::string code, const std::string& message, std::string element = {},
             std::optional<long long> index = std::nullopt)
      : std::runtime_error(message), code_(std::move(code)), element_(std::move(element)), index_(index) {}

  const std::string& code() const { return code_; }
  const std::string& element() const { return element_; }
  const std::optional<long long>& index() const { return index_; }

private:
  std::string code_;
  std::string element_;
  std::optional<long long> index_;
};

// A result failed the engine's own correctness checks: a bug, never returned as a valid answer.
class InternalError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

// Work was cancelled (explicitly or by its deadline) between stages or inside a long loop.
class Cancelled : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

}  // namespace lipmap
