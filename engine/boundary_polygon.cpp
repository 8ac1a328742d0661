// validate_polygon: the preconditions of classify (boundary_polygon.h). Indices in the errors are polygon
// vertex indices, so a caller can point at the offending entry of the positions array.
#include "engine/boundary_polygon.h"

#include <cmath>
#include <string>

#include "engine/error.h"

namespace lipmap {
namespace {

std::string s(long long value) { return std::to_string(value); }

void check_size(const BoundaryPolygon& polygon) {
  if (polygon.vertices.size() < 3)
    throw InputError("polygon_too_small", "the polygon has " + s(polygon.vertices.size()) +
                                              " vertices; it needs at least 3", "polygon");
}

void check_finite(const std::vector<Point2>& vertices) {
  for (size_t i = 0; i < vertices.size(); ++i)
    if (!std::isfinite(vertices[i].x) || !std::isfinite(vertices[i].y))
      throw InputError("polygon_non_finite", "polygon vertex " + s(i) + " has a NaN or infinite coordinate",
                       "polygon_vertex", static_cast<long long>(i));
}

// Edge i runs from vertex i to vertex i + 1 (the last edge closes the polygon back to vertex 0); the index
// reported is i, the vertex to remove.
void check_edge_lengths(const std::vector<Point2>& vertices) {
  const size_t n = vertices.size();
  for (size_t i = 0; i < n; ++i) {
    if (vertices[i] != vertices[(i + 1) % n]) continue;
    const std::string message =
        i + 1 == n ? "the last polygon vertex " + s(i) + " repeats the first one: the polygon is closed "
                     "implicitly, so omit the repeated closing point"
                   : "polygon vertices " + s(i) + " and " + s(i + 1) + " are equal, which makes a zero-length edge";
    throw InputError("polygon_zero_length_edge", message, "polygon_vertex", static_cast<long long>(i));
  }
}

void check_rotation_indices(const BoundaryPolygon& polygon) {
  if (!polygon.rotation_indices) return;
  const std::vector<int>& r = *polygon.rotation_indices;
  if (r.size() != polygon.vertices.size())
    throw InputError("rotation_indices_length", s(r.size()) + " rotation indices for a polygon of " +
                                                    s(polygon.vertices.size()) + " vertices; give one per vertex",
                     "rotation_indices");
  for (size_t i = 0; i < r.size(); ++i)
    if (r[i] < 0 || r[i] > kMaxRotationIndex)
      throw InputError("rotation_index_out_of_range", "rotation index of polygon vertex " + s(i) + " is " + s(r[i]) +
                                                          "; it must be between 0 and " + s(kMaxRotationIndex),
                       "polygon_vertex", static_cast<long long>(i));
}

}  // namespace

void validate_polygon(const BoundaryPolygon& polygon) {
  check_size(polygon);
  check_finite(polygon.vertices);
  check_edge_lengths(polygon.vertices);
  check_rotation_indices(polygon);
}

}  // namespace lipmap
