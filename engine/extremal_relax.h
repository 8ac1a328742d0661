// Stage "optimize", method extremal (paper 5.3): the extremal map minimizes the largest conformal distortion
// K = sigma1 / sigma2 for the fixed boundary, so the refined map of the extremal path is finished by lowering
// max K directly rather than an average energy (MIPS would trade the worst triangles for the mean).
//
// Local minimax relaxation: a free vertex v moves to lower max K over its star (the faces around v), by a
// compass pattern search (8 directions, the step halved on failure); a move is kept only when the star's
// max K strictly drops and every star face stays strictly positive (floating point, then the engine's exact
// orientation predicate). Faces outside the star do not change, so the global max K never rises. The
// positions where every star face is positive form a convex set (an intersection of half-planes), so the
// straight motion from old to new position keeps every face positive: angle sums, hence local injectivity,
// are unchanged (the argument of the optimize stage). Sweeps visit the free corners of the worst faces,
// worst star first, until a sweep lowers max K by less than a relative 1e-3, or a cap.
//
// Free vertices are the optimize stage's: not the boundary, not inserted vertices, not the corners of source
// faces that carry inserted vertices (the refinement's minimality, paper 4 Fig. 11, is kept: moving those
// corners too lowered max K further on three_peaks / weak_fan, 2,193 -> 58, but left inserted points that
// the independent checker finds removable).
#pragma once

#include <vector>

#include "engine/cancel.h"
#include "engine/disk_mesh.h"
#include "engine/refine.h"

namespace lipmap {

struct ExtremalRelaxation {
  bool ran = false;
  int sweeps = 0, moves = 0;      // sweeps done; vertex moves kept
  int free_vertices = 0;
  double max_before = 1, max_after = 1;  // max K over the map's faces before and after
  double ms = 0;
};

struct ExtremalRelaxOptions {
  int max_sweeps = 60;
  double time_budget_ms = 0;  // 0: none (besides the sweeps' cap and the cancel token)
};

// map: a refined map at the working scale with every face strictly positive; uv changed in place. rest: the
// rest shapes (one point per map vertex; null: map.vertices). Throws Cancelled.
ExtremalRelaxation relax_max_dilatation(const DiskMesh& source, const std::vector<int>& loop, RefinedMap& map,
                                        const ExtremalRelaxOptions& options = {}, const CancelToken* cancel = nullptr,
                                        const std::vector<Point3>* rest = nullptr);

}  // namespace lipmap
