// Stage "classify" (paper 3.1, 3.2, App. B, App. C): decides whether the boundary polygon P is simple,
// self-overlapping, weakly self-overlapping or not self-overlapping, and builds its coarse triangulation
// (positive triangles, no interior vertices) with the full rotation index R_i at every vertex.
#pragma once

#include <string>
#include <vector>

#include "engine/boundary_polygon.h"
#include "engine/cancel.h"
#include "engine/geometry.h"

namespace lipmap {

enum class Verdict { simple, self_overlapping, weakly_self_overlapping, not_self_overlapping };

const char* to_string(Verdict verdict);

struct ClassifyStats {
  int input_vertices = 0;
  int ears_clipped = 0;        // App. C reduction before the table is built
  int reduced_vertices = 0;    // size of the polygon the dynamic program ran on
  bool free_rotation_search = false;  // true when R_i were neither prescribed nor all zero (turning number > 1)
  std::size_t table_bytes = 0; // memory of the dynamic-programming table
  double ear_clipping_ms = 0, table_ms = 0, total_ms = 0;
};

struct Classification {
  Verdict verdict = Verdict::not_self_overlapping;
  // Turning number of P (number of full turns of its tangent); every weakly self-overlapping polygon
  // has turning number 1 + sum(R_i) >= 1.
  int turning_number = 0;
  // When verdict != not_self_overlapping: n - 2 triangles of polygon vertex indices, each strictly
  // positive (counterclockwise) by the exact predicate; every polygon edge is an edge of exactly one.
  std::vector<Triangle> triangulation;
  // Full rotation index of the triangulation at each vertex: triangulation angle = alpha_i + 2 pi R_i.
  std::vector<int> rotation_indices;
  std::vector<int> singular_vertices;  // vertices with R_i > 0, ascending
  std::string reason;                   // why, when not_self_overlapping
  ClassifyStats stats;
};

// Throws InputError (see validate_polygon) for malformed polygons and Cancelled when the token fires.
// With prescribed rotation indices the triangulation matches them exactly, or the verdict is
// not_self_overlapping (for that prescription).
Classification classify(const BoundaryPolygon& polygon, const CancelToken* cancel = nullptr);

}  // namespace lipmap
