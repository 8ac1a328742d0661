// Stage "refine" (paper 4, "Source mesh refinement", Fig. 10-12). Source triangles whose image under the
// vertex-wise map is not positive (or whose vertices are not locally injective) get the intersection points
// of their edges (in the disk) with h_t(M_t)'s edges inserted, computed exactly; neighbours whose image
// polygon stops being self-overlapping follow. Then inserted points are removed again, round after round,
// while both polygons they belong to stay self-overlapping and the angle sums at their neighbours are
// unchanged (Fig. 11). Finally every refined triangle and its image are triangulated compatibly (Fig. 12):
// positive in uv and with no triangle whose corners all lie on one original edge.
#pragma once

#include <vector>

#include "engine/cancel.h"
#include "engine/compose.h"
#include "engine/disk_mesh.h"
#include "engine/geometry.h"
#include "engine/target_mesh.h"

namespace lipmap {

// A vertex of the refined mesh that is not an original vertex: it lies on original edge (a, b), a < b, at
// position a + t (b - a), 0 < t < 1, never on the boundary.
struct InsertedVertex {
  int a = 0, b = 0;
  double t = 0;
};

// The contract's position of a point at t on the edge from a to b: a + t (b - a), coordinate by coordinate (verify
// and the checkers expect these very doubles).
inline Point3 point_on_edge(const Point3& a, const Point3& b, double t) {
  return {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), a.z + t * (b.z - a.z)};
}

struct RefinedMap {
  std::vector<Point3> vertices;          // original vertices first (same index, same position), then inserted
  std::vector<Triangle> faces;
  std::vector<Point2> uv;                // one per vertex
  std::vector<InsertedVertex> inserted;  // inserted[i] is vertex source.vertices.size() + i
  int flipped_before_refinement = 0;     // source faces whose vertex-wise image was not strictly positive
  int refined_faces = 0;                 // source faces that carried inserted points at some time
  int points_before_simplification = 0;  // inserted points before the rounds of Fig. 11
  int simplification_rounds = 0;
  // When refinement ran only around the folds the untangler left (engine/fold_region.h): the regions and their
  // faces; 0 when it ran on the whole mesh (or not at all).
  int regions = 0, region_faces = 0;
  double refine_ms = 0, simplify_ms = 0, triangulate_ms = 0;
};

// With refine = false only the vertex-wise map is returned (faces as in the source, possibly flipped).
// rotation[k]: the classification's full rotation index at boundary vertex loop[k]; a face's image may wrap
// around such a singular vertex by up to that many extra turns (weakly self-overlapping targets).
RefinedMap refine(const DiskMesh& source, const std::vector<int>& loop, const std::vector<int>& rotation,
                  const std::vector<Point2>& source_disk, const TargetMesh& target,
                  const std::vector<Point2>& target_disk, const Composition& composition, bool refine,
                  const CancelToken* cancel = nullptr);

// The rounds of Fig. 11 again, on a refined map whose uv moved since refine() (engine/extremal_relax.h): the
// inserted points that its polygons no longer need go, and the refined faces are triangulated again (Fig. 12)
// from the same doubles, exactly as refine() decides. Precondition: map is refine()'s map of this source, every
// face strictly positive. True when points were removed (map replaced: the same original vertices and uv, fewer
// inserted points, new faces); false leaves map as it was. Throws Cancelled.
bool simplify_again(const DiskMesh& source, const std::vector<int>& loop, const std::vector<int>& rotation,
                    RefinedMap& map, const CancelToken* cancel = nullptr);

// Per source face: whether an inserted point of map lies on one of its edges (its image is a refined polygon).
std::vector<char> refined_source_faces(const DiskMesh& source, const RefinedMap& map);

}  // namespace lipmap
