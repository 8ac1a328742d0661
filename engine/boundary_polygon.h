// The boundary polygon P of the paper (section 3.1): the prescribed image of the mesh boundary, in order,
// interior on the left, possibly self-intersecting, optionally with full rotation indices R_i (section 3.2).
#pragma once

#include <optional>
#include <vector>

#include "engine/geometry.h"

namespace lipmap {

// Largest full rotation index accepted per vertex. Quad-meshing needs R_i = 1 (paper 3.2); a few more
// turns are allowed, the classify table stores the feasible end-rotation pairs in a small bitmask.
inline constexpr int kMaxRotationIndex = 6;

struct BoundaryPolygon {
  std::vector<Point2> vertices;
  std::optional<std::vector<int>> rotation_indices;  // R_i >= 0, one per vertex, when prescribed
};

// Checks the preconditions of classify and throws InputError with a stable code:
//   polygon_too_small (fewer than 3 vertices), polygon_non_finite (NaN/inf coordinate),
//   polygon_zero_length_edge (two consecutive vertices equal, incl. last == first),
//   rotation_indices_length (not one per vertex), rotation_index_out_of_range (R_i < 0 or too large).
void validate_polygon(const BoundaryPolygon& polygon);

}  // namespace lipmap
