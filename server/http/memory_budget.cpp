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

// The constants are upper bounds on peak RSS growth (VmHWM after the request, reset before it, minus VmRSS
// before) measured by bench/bench_memory.sh on this build (Release, 2 cores, glibc malloc); the figures are in
// docs/hard-points.md "Memory per request".
//
// Parsing, per body byte (the body itself included: cpp-httplib's copy and the request loader's). A plain
// parametrize body goes by SAX straight into the engine's arrays: 2.3 B/B on 17-digit numbers, 4.3 on "[1,2,3]"
// (26 MB bodies). But any body the SAX reader gives up on (a wrong type anywhere) is parsed again into a DOM to
// name the error, and classify bodies are always a DOM: 4.8 to 11 B/B on numbers, and 37 to 38 B/B (8 and 32
// MB) on a body of empty objects ("{}," makes a map of its own), the most a DOM costs per byte. A client
// chooses its body, so the bound is that worst case with a quarter more: 48. glTF and multipart bodies are
// binary buffers copied a few times by tinygltf (not measured again).
constexpr double kJsonBytesPerBodyByte = 48;
constexpr double kBinaryBytesPerBodyByte = 6;

// The whole pipeline per target triangle (source faces * target_density: target mesh, two harmonic maps with
// their factorizations, composition, refinement, verification, the answer's JSON), and per source vertex.
// Measured on grids mapped onto a spiral, parse included: 1,196 B per triangle at 10k triangles (fixed costs
// weigh most there), 866 at 51k, 824 at 124k. 3,000 leaves about 2.5x for meshes that refine more than these
// (inserted vertices grow the refined mesh, not the target mesh).
constexpr double kBytesPerTargetTriangle = 3000;
constexpr double kBytesPerVertex = 600;

}  // namespace

std::size_t parse_cost(std::size_t body_bytes, const std::string& content_type) {
  const std::string type = codec::media_type(content_type);
  return mul(body_bytes, type == "application/json" ? kJsonBytesPerBodyByte : kBinaryBytesPerBodyByte);
}

std::size_t classify_cost(std::size_t n) {
  // engine/shor_van_wyk.cpp: two m x m bit matrices and, when turns can be non-zero, one 8-byte mask per
  // entry of the upper triangle; App. C's ear reduction usually shrinks m, but not on overlapping polygons.
  // Measured (bench/bench_memory.sh, double loop, no prescribed turns): 3.7 MB at 4,000 vertices = 0.24 n^2,
  // the bit matrices' 0.25 n^2; the masks' 4 n^2 are the layout's, not measured.
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
