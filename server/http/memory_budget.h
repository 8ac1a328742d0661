// The per-request memory budget (docs/api.md "Limits"): a request's peak memory is estimated from what is
// known before the work starts, and a request whose estimate exceeds --memory-budget is refused (413 before
// its body is read when the body alone would parse past it, else 422 memory_budget_exceeded) instead of
// growing the process until the kernel kills it. The estimates are upper bounds calibrated on this build
// (bench/bench_memory.sh measures them; docs/hard-points.md keeps the figures); they are deliberately simple.
#pragma once

#include <cstddef>
#include <string>

namespace lipmap::server {

// Peak bytes of parsing a body of `body_bytes` with this Content-Type (the body itself included).
std::size_t parse_cost(std::size_t body_bytes, const std::string& content_type);

// Peak bytes of the engine's table for a boundary or classify polygon of n vertices (paper 3.1: an upper
// triangle of m x m entries, with a turn mask each when rotation indices can be non-zero).
std::size_t classify_cost(std::size_t polygon_vertices);

// Peak bytes of a parametrize run: the classify table of the boundary, and the meshes, maps and refinement
// of about target_density * faces target triangles.
std::size_t parametrize_cost(std::size_t vertices, std::size_t faces, std::size_t boundary_vertices,
                             double target_density);

// What one request may be estimated to take: --memory-budget, and no more than 64 MiB + 128 bytes per byte of
// its body, so that a small request cannot make the process grow by much (a request of at most 1 MB must
// not grow the RSS by more than 200 MB).
std::size_t request_budget(std::size_t memory_budget_bytes, std::size_t body_bytes);

// "123.4 MiB"
std::string mebibytes(std::size_t bytes);

}  // namespace lipmap::server
