// Shor–van Wyk triangulation of a (weakly) self-overlapping polygon with prescribed triangulation angles
// (paper 3.1, 3.2, App. B). Internal to the classify stage; includes CGAL through exact_predicates.h.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <vector>

#include "engine/cancel.h"
#include "engine/detail/exact_predicates.h"
#include "engine/geometry.h"

namespace lipmap::detail {

struct ShorVanWykResult {
  std::optional<std::vector<Triangle>> triangles;  // indices into the polygon given; none: no triangulation
  std::size_t table_bytes = 0;
};

// `polygon` is the closed polygon (vertex k joined to k+1 and the last to the first), interior on the left.
// With `turns`, the triangulation angle at vertex k must be exactly sweep(k) + 2*pi*turns[k], where sweep(k)
// in [0, 2*pi) runs counterclockwise from the direction of k+1 to the direction of k-1; the table keeps, per
// sub-polygon, the set of feasible full-turn pairs at its two ends (docs/hard-points.md), so no solution is
// missed when turns > 0. Requires 0 <= turns[k] <= 7. Without `turns`, any triangulation with positive
// triangles is accepted (the weakly self-overlapping test of section 3.1).
// `allowed`, when given, can forbid triangles (i, k, j) besides the non-positive ones (the refinement uses
// it to forbid triangles whose corners all lie on one original edge).
using AllowedTriangle = std::function<bool(int i, int k, int j)>;

ShorVanWykResult shor_van_wyk(const std::vector<Pt>& polygon, const std::vector<int>* turns,
                              const CancelToken* cancel, const AllowedTriangle* allowed = nullptr);

// A triangulation of a polygon in which every angle is the polygon's own interior angle (all R_i = 0: the
// polygon is self-overlapping, section 3.1), or none: the refined triangles' image polygons (refine's test,
// called for every step of its simplification). Above 6 vertices safe ears are clipped first (App. C) and the
// table runs on what is left; with `allowed`, a failure there is decided again on the whole polygon only when
// the clipped polygon has a triangulation once every triangle is allowed (else none exists).
std::optional<std::vector<Triangle>> triangulate_self_overlapping(const std::vector<Pt>& polygon,
                                                                  const AllowedTriangle* allowed = nullptr);

// The same with prescribed full rotation indices R_k >= 0 (sum R_k must equal the turning number - 1).
std::optional<std::vector<Triangle>> triangulate_with_rotation(const std::vector<Pt>& polygon,
                                                               const std::vector<int>& rotation,
                                                               const AllowedTriangle* allowed = nullptr);

}  // namespace lipmap::detail
