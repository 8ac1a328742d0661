#include "server/http/memory_budget.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "server/codec/text.h"

namespace lipmap::server {

namespace {

// Saturating arithmetic: the estimates of absurd requests must stay absurd, not wrap around.
std::size_t mul(std::size_t a, double b) {
  const double r = static_cast<double>(a) * b;
  return r >= static_cast<double>(std::numeric_limits<std::size_t>::max()) ? std::numeric_limits<std::size_t>::max()
                                                                           : static_cast<std::size_t>(r);
}
std::size_t add(std::size_t a, std::size_t b) {
  return a > std::numeric_limits<std::size_t>::max() - b ? std::numeric_limits<std::size_t>::max() : a + b;
}

// Measured peak RSS growth per body byte (docs/hard-points.md "Memory"): a JSON body becomes a JSON DOM
// (nlohmann: ~48 bytes per body byte on number arrays, measured) before the flat arrays; glTF and
// multipart bodies are binary buffers copied a few times by tinygltf.
constexpr double kJsonBytesPerBodyByte = 48;
constexpr double kBinaryBytesPerBodyByte = 6;

// Measured peak RSS growth of `lipmap map` per target triangle (source faces * target_density), over the
// whole pipeline (target mesh, two harmonic maps with their factorizations, composition, refinement,
// verification, the answer's JSON): see docs/hard-points.md "Memory".
constexpr double kBytesPerTargetTriangle = 6000;
constexpr double kBytesPerVertex = 600;

}  // namespace

std::size_t parse_cost(std::size_t body_bytes, const std::string& content_type) {
  const std::string type = codec::media_type(content_type);
  return mul(body_bytes, type == "application/json" ? kJsonBytesPerBodyByte : kBinaryBytesPerBodyByte);
}

std::size_t classify_cost(std::size_t n) {
  // engine/shor_van_wyk.cpp: two m x m bit matrices and, when turns can be non-zero, one 8-byte mask per
  // entry of the upper triangle; App. C's ear reduction usually shrinks m, but not on overlapping polygons.
  const double m = static_cast<double>(n);
  return mul(1, m * m / 4 + m * (m - 1) / 2 * 8 + m * 64);
}

std::size_t parametrize_cost(std::size_t vertices, std::size_t faces, std::size_t boundary_vertices,
                             double target_density) {
  const double target = static_cast<double>(faces) * std::max(1.0, std::isfinite(target_density) ? target_density : 1.0);
  return add(classify_cost(boundary_vertices), add(mul(1, target * kBytesPerTargetTriangle), mul(vertices, kBytesPerVertex)));
}

std::size_t request_budget(std::size_t memory_budget_bytes, std::size_t body_bytes) {
  return std::min(memory_budget_bytes, add(std::size_t{64} << 20, mul(body_bytes, 128)));
}

std::string mebibytes(std::size_t bytes) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.1f MiB", static_cast<double>(bytes) / (1024.0 * 1024.0));
  return buf;
}

}  // namespace lipmap::server
