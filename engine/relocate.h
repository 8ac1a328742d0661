// Vertex relocation, between compose and refine (not in the paper; it only makes refine's work smaller).
// An interior source vertex whose image one-ring has a non-positive triangle is moved when some position
// makes its whole one-ring positive and winding once. The move is made in the disk: the new disk point keeps
// h_s's one-ring there positive, and the vertex's uv is h_t^-1 of it, so the map stays f = h_t^-1 o h_s' for
// a bijective h_s' and refinement's guarantee (paper 4) holds unchanged. Every flip fixed this way is a
// triangle that refine no longer has to cut into pieces.
#pragma once

#include <vector>

#include "engine/cancel.h"
#include "engine/compose.h"
#include "engine/disk_mesh.h"
#include "engine/geometry.h"
#include "engine/target_mesh.h"

namespace lipmap {

struct Relocation {
  int flipped_before = 0;  // non-positive image triangles of the composed map
  int moved = 0;           // interior vertices moved (each counted once)
  int flipped_after = 0;   // non-positive image triangles left for refine
};

// Updates source_disk (h_s), composition.uv and composition.target_face of the moved vertices in place.
Relocation relocate_tangled_vertices(const DiskMesh& source, const std::vector<int>& loop,
                                     std::vector<Point2>& source_disk, Composition& composition,
                                     const TargetMesh& target, const CancelToken* cancel = nullptr);

}  // namespace lipmap
