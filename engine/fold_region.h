// Refinement restricted to where the untangler failed (the quality issue's "refinement only where needed"):
// the regions of the source mesh around the faces that a map of the unrefined mesh still folds, each cut out
// as a disk mesh of its own whose boundary polygon is the image of the region's boundary loop under that map.
// The pipeline maps each region with the paper's own path (classify, the two harmonic maps, compose, refine:
// paper 3-4, so the guarantee holds region by region) and splices the answers back; the faces outside every
// region keep the map as it was (all strictly positive there).
//
// Why the splice is locally injective: outside the regions every face is positive and every vertex whose star
// lies outside has its full turn (those with a wrong angle sum are seeds). A region's boundary vertex v gets
// the rotation index that makes the angle inside the region equal to what v's full turn (2 pi, or the polygon
// angle plus 2 pi R_k on the mesh boundary) leaves after the positive faces outside it; the region's map has
// exactly that angle at v (verify, paper 3.2). Inserted vertices lie on interior edges of a region, never on
// its boundary (engine/refine.h), so the faces outside are not split. The spliced map is still gated by the
// pipeline's exact verify, with the whole-mesh refinement as the fallback.
#pragma once

#include <string>
#include <vector>

#include "engine/disk_mesh.h"
#include "engine/geometry.h"
#include "engine/raw_mesh.h"
#include "engine/refine.h"

namespace lipmap {

struct FoldRegion {
  std::vector<int> faces;     // source faces in the region, ascending
  std::vector<int> vertices;  // region vertex i is source vertex vertices[i], ascending (so edge order is kept)
  RawMesh mesh;               // the region's faces on region vertex indices
  RawBoundary boundary;       // its boundary loop (region indices, interior on the left), images, rotation indices
};

struct FoldRegions {
  std::vector<FoldRegion> regions;  // one per connected region, each a disk
  int seed_faces = 0;               // faces not positive
  int seed_vertices = 0;            // vertices with a positive star whose angle sum is not their full turn
  int region_faces = 0;             // faces in all regions
  std::string failure;              // when non-empty: why no regions (then `regions` is empty)
};

// Marks, in place, the vertices within `rings` rings (over `faces`) of the marked ones: each ring adds the
// corners of every face with a marked corner. (Untangling's local attempts use the same neighbourhoods.)
void grow_by_rings(const std::vector<Triangle>& faces, std::vector<char>& marked, int rings);

// The regions around the folds of uv (one point per source vertex, loop[k] at polygon[k]; rotation[k] the
// classification's R_k): the faces with a corner within `rings` rings of a seed face's corners, with holes
// filled and pinched vertices' stars added until every connected piece is a disk. Fails (with a reason) when
// the regions would hold more than half of the faces, a piece is not a disk, or a boundary vertex's rotation
// index would be negative or above kMaxRotationIndex.
FoldRegions fold_regions(const DiskMesh& source, const std::vector<int>& loop, const std::vector<Point2>& polygon,
                         const std::vector<int>& rotation, const std::vector<Point2>& uv, int rings);

// The source mesh with each region's faces replaced by its refined map (maps[i] for regions[i], a refined map of
// regions[i].mesh whose boundary is pinned at regions[i].boundary.positions), inserted vertices renumbered after
// the source's, and every other vertex at uv. Statistics of the maps' refinements are summed.
RefinedMap splice_regions(const DiskMesh& source, const std::vector<Point2>& uv, const FoldRegions& regions,
                          const std::vector<RefinedMap>& maps);

}  // namespace lipmap
