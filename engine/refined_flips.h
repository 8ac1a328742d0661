// Reshaping the refinement's triangulations (paper 4, Fig. 12): edge flips inside the refined faces that lower
// the conformal distortion K. Used by method extremal's relaxation (engine/extremal_relax.h).
#pragma once

#include <vector>

#include "engine/disk_mesh.h"
#include "engine/refine.h"

namespace lipmap {

// Fig. 12 asks only for some triangulation of each refined polygon with positive triangles, and refine() and
// simplify_again take the first one found, however badly shaped (on mountain / weak_fan the worst face after
// simplify_again had three boundary corners, which no vertex move can change). Two triangles of the same
// source face whose union is a strictly convex quad (both new triangles positive, exact orientation) trade
// their diagonal when that lowers the larger of their two K (relative 1e-9). The refined polygons, hence
// contract points 1-6, stay as they are; every flip lowers the descending sorted vector of K, so the flips
// end (also capped at 64 per edge). No new triangle has its three corners on one source edge (zero 3D area).
// Faces of unrefined source faces are never touched; the face count and order of map.faces are kept.
// Preconditions: map is refine()'s (or simplify_again's) map of source with every face strictly positive;
// shape holds one 3D point per map vertex (map.vertices, or rest shapes). Returns the number of flips.
int flip_refined_diagonals(const DiskMesh& source, RefinedMap& map, const std::vector<Point3>& shape);

}  // namespace lipmap
