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
// Faces with three boundary corners (ears, and triangles whose edges all join boundary vertices) cannot move:
// when one is not positive, no motion of the interior helps. Such a face gets one of its chords (interior
// edges joining two boundary vertices) split at its midpoint, the fewest insertions that give every such face
// a free vertex (a chord shared by two such faces first); the untangler then moves the inserted vertices too.
//
// Few folds are first untangled locally: only the free vertices within 2 (then 6) rings of the non-positive
// faces move, when they are at most a quarter of the free vertices; the whole interior moves only if that fails,
// by projected Newton steps on meshes up to 60k faces whose rotation indices are all 0 (L-BFGS stalls on thin,
// stretched ones), else by L-BFGS.
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
#include "engine/refine.h"

namespace lipmap {

struct Untangling {
  bool attempted = false;  // the composed map had non-positive faces and some interior vertex could move
  bool succeeded = false;  // uv is a locally injective map of the unrefined mesh: no refinement needed
  int flipped_before = 0;  // non-positive faces of the map untangling started from (after relocation)
  int flipped_after = 0;   // non-positive faces when it stopped
  int rounds = 0;          // values of eps tried
  int iterations = 0;      // L-BFGS steps over all rounds
  int moved_locally = 0;   // when the local attempt succeeded: the free vertices it moved (near the folds)
  bool newton = false;     // the whole interior moved by projected Newton steps (else L-BFGS)
  std::string outcome;     // one line: why it was not attempted, or how it ended
  // The mesh untangling ran on: the source faces (faces empty, inserted empty), or the source with chords of
  // fixed non-positive faces split at their midpoints (inserted[i] is vertex source.vertices.size() + i).
  std::vector<InsertedVertex> inserted;
  std::vector<Triangle> faces;
  // When succeeded: the map's rotation index R_k at each boundary vertex loop[k]. The classification's, unless
  // untangle was free to place them (any_rotation): then the extra turns may sit at other vertices.
  std::vector<int> rotation_indices;
  // The untangled map (one per vertex of that mesh) when succeeded; when attempted and failed, its last iterate
  // (engine/fold_region.h refines only around the folds left in it).
  std::vector<Point2> uv;
};

// The untangled answer as a refined map (the source mesh, or its chord splits), uv moved out of u.
RefinedMap untangled_map(const DiskMesh& source, Untangling& u);

// composed_uv: the vertex-wise map after relocation, boundary vertex loop[k] at polygon.vertices[k].
// rotation: the classification's R_k. rest: the triangles' rest shapes, one point per source vertex (a
// reference metric's, engine/reference_metric.h); null for the 3D mesh itself. any_rotation: nobody prescribed
// the R_k (the classification's free search chose them, paper 3.1): a map with every face positive and one full
// turn at every interior vertex is accepted with whatever R_k >= 0 it has at the boundary vertices (where the
// polygon's extra turns go is open, and this map needs no insertion). Throws Cancelled.
Untangling untangle(const DiskMesh& source, const std::vector<int>& loop, const BoundaryPolygon& polygon,
                    const std::vector<int>& rotation, const std::vector<Point2>& composed_uv,
                    const CancelToken* cancel = nullptr, const std::vector<Point3>* rest = nullptr,
                    bool any_rotation = false);

}  // namespace lipmap
