// Stage "direct map": when the boundary polygon P is strictly convex, one map of the source mesh
// straight onto P replaces the paper's two maps and their composition (paper 4). Tutte's theorem (and
// Floater's for mean-value weights) makes a map with positive weights onto a strictly convex polygon a
// bijection; the composition through the disk would only add a second solve, a target mesh and rounding.
//
// Weights: the method's own (cotangent weights for harmonic, the default), because a harmonic map onto a
// convex polygon is what the dual harmonic map of paper 5.1 tends to when M_t is fine, and it reproduces a
// planar source exactly (linear functions are harmonic). Cotangent weights can be negative, so bijectivity
// is not guaranteed by the theorem: the map stage's own recovery (paper 5.1: re-map with positive mean-value
// weights, then uniform Tutte weights) runs when the exact flip count is not zero. The caller verifies the
// result exactly (engine/verify.h) and falls back to the general path when the map is not valid; this stage
// never inserts vertices.
#pragma once

#include <optional>
#include <vector>

#include "engine/boundary_polygon.h"
#include "engine/cancel.h"
#include "engine/disk_mesh.h"
#include "engine/intermediate_map.h"
#include "engine/parametrize_options.h"
#include "engine/refine.h"

namespace lipmap {

// P strictly convex and simple: every corner a strict left turn (exact orientation), turning number 1, and
// no prescribed extra rotation (rotation[k] == 0 for every k). Exact (engine/detail/exact_predicates.h).
bool strictly_convex(const BoundaryPolygon& polygon, const std::vector<int>& rotation);

struct DirectMap {
  RefinedMap map;  // the source's own vertices and faces, uv with loop[k] at polygon.vertices[k] bit for bit
  DiskMapSolution solution = DiskMapSolution::primary;
  int flipped = 0;  // exact count of non-positive faces after the map stage's recovery (0: candidate answer)
};

// The source mapped onto P with `method`'s weights (tutte or harmonic). P must be strictly convex
// (strictly_convex); throws Cancelled when the token fires.
DirectMap map_onto_convex_polygon(const DiskMesh& mesh, const std::vector<int>& loop, const BoundaryPolygon& polygon,
                                  MapMethod method, const CancelToken* cancel = nullptr);

}  // namespace lipmap
