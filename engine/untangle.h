// Stage "untangle", between compose (with relocation) and refine: when the composed map f = h_t^-1 o h_s
// folds some source triangles, try to find a locally injective map of the UNREFINED mesh with the same
// boundary, by moving the interior vertices only (the boundary stays pinned exactly). The paper (Fig. 20)
// notes that the unrefined map is an excellent start for such an optimizer; refinement (paper 4) is then
// needed only when this fails, and the paper's guarantee is kept because refine still runs in that case.
//
// Method: Garanzha, Kaporin, Kudryavtseva, Protais, Ray & Sokolov 2021, "Foldover-free maps in 50 lines of
// code": minimize the per-triangle energy with the regularized determinant chi(det J, eps) (it is finite on
// folded triangles) for a decreasing sequence of eps chosen from the smallest det J and the energy's
// progress (their section 3), with L-BFGS (engine/detail/uv_descent.h). The energy is per triangle, so
// self-overlapping and weakly self-overlapping polygons need nothing special.
//
// Acceptance: the untangled map is returned only when every face is strictly positive (exact predicate) and
// the verify stage's checks pass on it (one full turn at every interior vertex, each boundary vertex's
// rotation index as classified), i.e. it is a valid answer without any inserted vertex.
#pragma once

#include <string>
#include <vector>

#include "engine/boundary_polygon.h"
#include "engine/cancel.h"
#include "engine/disk_mesh.h"
#include "engine/geometry.h"

namespace lipmap {

struct Untangling {
  bool attempted = false;  // the composed map had non-positive faces and some interior vertex could move
  bool succeeded = false;  // uv is a locally injective map of the unrefined mesh: no refinement needed
  int flipped_before = 0;  // non-positive faces of the map untangling started from (after relocation)
  int flipped_after = 0;   // non-positive faces when it stopped
  int rounds = 0;          // values of eps tried
  int iterations = 0;      // L-BFGS steps over all rounds
  std::string outcome;     // one line: why it was not attempted, or how it ended
  std::vector<Point2> uv;  // the untangled map (one per source vertex) when succeeded
};

// composed_uv: the vertex-wise map after relocation, boundary vertex loop[k] at polygon.vertices[k].
// rotation: the classification's R_k. rest: the triangles' rest shapes, one point per source vertex (a
// reference metric's, engine/reference_metric.h); null for the 3D mesh itself. Throws Cancelled.
Untangling untangle(const DiskMesh& source, const std::vector<int>& loop, const BoundaryPolygon& polygon,
                    const std::vector<int>& rotation, const std::vector<Point2>& composed_uv,
                    const CancelToken* cancel = nullptr, const std::vector<Point3>* rest = nullptr);

}  // namespace lipmap
