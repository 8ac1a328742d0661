// Where the extra turn of a weakly self-overlapping boundary polygon may go when the caller prescribed no
// rotation indices (paper 3.1 leaves the choice open). classify's free search keeps the first triangulation
// its table finds; its vertex with R = 1 can have too few faces in the mesh for its angle, since a boundary
// vertex with d faces spans less than d pi while alpha + 2 pi is asked of it (alpha: the polygon's angle there).
// The pipeline classifies each candidate exactly with that prescription and keeps the placement whose
// composed map folds least (engine/pipeline.cpp).
#pragma once

#include <vector>

#include "engine/boundary_polygon.h"
#include "engine/classify.h"
#include "engine/disk_mesh.h"

namespace lipmap {

// At most this many candidates.
inline constexpr int kRotationPlacementCandidates = 3;

// Room for one extra turn at loop position k: d pi - alpha_k - 2 pi, d the faces at vertex loop[k] (floating
// point: a ranking only, every candidate is classified exactly).
double rotation_room(const DiskMesh& mesh, const std::vector<int>& loop, const BoundaryPolygon& polygon, int k);

// Loop positions to try R = 1 at, most room first, each with more room than the found placement's vertex.
// Empty unless `found` came from the free search (polygon.rotation_indices not given) with turning number 2
// (one vertex with R = 1) and that vertex has less than pi of room (one face's worth).
std::vector<int> rotation_placement_candidates(const DiskMesh& mesh, const std::vector<int>& loop,
                                               const BoundaryPolygon& polygon, const Classification& found);

}  // namespace lipmap
