// Exact orientation checks of a planar triangle map, for the stages and the transport. The predicate is the
// engine's exact orientation test (engine/detail/exact_predicates.h: CGAL's filtered orientation_2 on the
// doubles as they are); CGAL itself stays out of this header.
#pragma once

#include <vector>

#include "engine/geometry.h"

namespace lipmap {

// Number of faces whose uv triangle is not strictly counterclockwise (negative or degenerate), decided
// exactly. Precondition: every face index is in range of uv (not checked in release builds).
int count_non_positive(const std::vector<Point2>& uv, const std::vector<Triangle>& faces);

// The indices of those faces, ascending.
std::vector<int> non_positive_faces(const std::vector<Point2>& uv, const std::vector<Triangle>& faces);

// Exact orientation of one triangle: +1 counterclockwise, -1 clockwise, 0 collinear.
int orientation_sign(const Point2& a, const Point2& b, const Point2& c);

}  // namespace lipmap
