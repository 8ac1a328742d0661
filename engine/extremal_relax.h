// Stage "optimize", method extremal (paper 5.3): the extremal map minimizes the largest conformal distortion
// K = sigma1 / sigma2 for the fixed boundary, so the refined map of the extremal path is finished by lowering
// max K directly rather than an average energy (MIPS would trade the worst triangles for the mean).
//
// First a flip-free descent (engine/detail/uv_descent.h: projected Newton, every step bounded before a triangle
// turns over and checked exactly) on the area-weighted sum of ((K + 1/K) / 2)^p relative to the worst movable
// face's, for p = 2, 4, ..., 256: a smooth stand-in for max K that moves many vertices at once and, as p grows,
// evens K out over the interior as a Teichmuller map's constant K would. On a refined map it first moves every
// vertex off the boundary until an inserted point would become removable (see below); given the rotation
// indices, those points are then removed (refine.h's simplify_again, the rounds of Fig. 11 on the moved map)
// and the relaxation starts over on the smaller refinement, up to 12 rounds, the result kept when its max K is
// not above that of the map relaxed without removing points; else only the freely movable vertices move.
// Before each relaxation and after the last, the refined faces' triangulations are reshaped by edge flips that
// lower K (engine/refined_flips.h: Fig. 12 allows any). The descent is kept only when it lowers max K over
// the faces it can change. bench_extremal, against the L-BFGS descent to p = 16 of before: max K / mean K two rings in <= 1.5 in 41 of 50 cases
// instead of 27 of 51, median 1.065 instead of 1.482 (docs/testing.md). Then:
//
// Local minimax relaxation: a free vertex v moves to lower max K over its star (the faces around v), by a
// compass pattern search (8 directions, the step halved on failure); a move is kept only when the star's
// max K strictly drops and every star face stays strictly positive (floating point, then the engine's exact
// orientation predicate). Faces outside the star do not change, so the global max K never rises. The
// positions where every star face is positive form a convex set (an intersection of half-planes), so the
// straight motion from old to new position keeps every face positive: angle sums, hence local injectivity,
// are unchanged (the argument of the optimize stage).
//
// Lexicographic minimax (extremal_relax.cpp): sweeps visit the free corners of the worst faces, worst star
// first; when the worst level stops dropping (less than a relative 1e-3 per sweep) its faces are frozen (no
// later move may raise them) and the next level down is treated, so the worst faces away from a stuck spot
// (often next to the boundary) are lowered too. Capped by sweeps and about 2,000 face evaluations per face.
// After it the interior is polished (a flip-free descent on a weighted p-norm of K over the freely movable
// vertices) and, where its K is still uneven, the minimax runs again with the faces touching the boundary
// frozen, so that the interior's worst faces get moves of their own; there inserted points may also slide along
// their source edges (t changes, the point stays on its edge between its neighbours there): that reshapes the
// refined faces' 3D triangles, and neither local injectivity nor minimality depends on it.
//
// Free vertices: every vertex but the boundary (the descent moves only those that move freely, below). An inserted vertex moves in uv only (its 3D point stays on its
// edge, contract point 1). The refinement's minimality (contract point 6, paper 4 Fig. 11) is kept: whether an
// inserted point is removable depends only on its two refined polygons without it, so an inserted point alone
// on both source faces of its edge moves freely; a corner of a refined face, or an inserted point sharing a
// face with another, moves only when every inserted point whose polygons it belongs to stays certainly needed
// (one polygon without it crosses itself properly or has negative area, exact orientation tests). Moving those
// vertices without that check lowered max K further on three_peaks / weak_fan, 2,193 -> 58, but left inserted
// points that the independent checker finds removable.
#pragma once

#include <string>
#include <vector>

#include "engine/cancel.h"
#include "engine/disk_mesh.h"
#include "engine/refine.h"

namespace lipmap {

// Whether every corner of t is on the boundary loop (on_loop[v] != 0): such a face is pinned by the polygon and
// is the same in every map with that boundary, so no relaxation can change its K.
inline bool pinned_by_boundary(const Triangle& t, const std::vector<char>& on_loop) {
  return on_loop[static_cast<std::size_t>(t[0])] && on_loop[static_cast<std::size_t>(t[1])] &&
         on_loop[static_cast<std::size_t>(t[2])];
}

struct ExtremalRelaxation {
  bool ran = false;
  int sweeps = 0, moves = 0;      // sweeps done; vertex moves kept
  int levels = 0;                 // levels frozen (lexicographic minimax, see extremal_relax.cpp)
  int free_vertices = 0;
  double max_before = 1, max_after = 1;  // max K over the map's faces before and after
  // max K over the faces whose three corners are boundary vertices: their uv is the polygon's and their 3D
  // shape the mesh's, so no vertex move (and no other map with this boundary and no insertion) changes them.
  double fixed_max = 1;
  // Inserted points the relaxation's descent made unnecessary, removed again (refine.h's simplify_again).
  int points_removed = 0;
  // Diagonals flipped inside refined faces to lower K (engine/refined_flips.h), over all rounds of the kept map.
  int edge_flips = 0;
  // The interior polish (extremal_relax.cpp) was kept on the answer's last relaxation round or on one of the
  // relaxations of it that followed (ExtremalRelaxOptions::relax_again).
  bool polished = false;
  // Vertex moves kept by the interior minimax after the polish (faces touching the boundary frozen; uv moves
  // and inserted points slid along their source edges), on the answer's last round; counted in moves too.
  int interior_moves = 0;
  double ms = 0;
  // The pipeline relaxes two starts and keeps the one with the lower max K (engine/pipeline.cpp):
  // "teichmuller" (the paper's composed map) or "harmonic" (the harmonic method's refined map).
  std::string start = "teichmuller";
  double other_start_max = 1;  // max K of the start not kept, after its own relaxation
  double other_start_ms = 0;   // its time (whole pipeline run)
};

struct ExtremalRelaxOptions {
  int max_sweeps = 400;
  // After the minimax, even out the interior's K (a weighted p-norm descent, then the minimax again over the
  // faces off the boundary; see extremal_relax.cpp).
  bool polish_interior = true;
  double time_budget_ms = 0;  // 0: none (besides the sweeps' cap and the cancel token)
  // The relaxed map relaxed again, up to this many times, while its worst face is one a move can change and each
  // time lowers max K by 1 % (the sweeps' and evaluations' caps stop a relaxation before a minimum).
  int relax_again = 3;
  // The classification's full rotation index per boundary loop vertex (refine()'s rotation). Given, the
  // inserted points a descent would make removable are removed (simplify_again) and the relaxation goes on;
  // empty, such a descent is given up.
  std::vector<int> rotation;
};

// map: a refined map at the working scale with every face strictly positive; uv changed in place. rest: the
// rest shapes (one point per map vertex; null: map.vertices). Throws Cancelled.
ExtremalRelaxation relax_max_dilatation(const DiskMesh& source, const std::vector<int>& loop, RefinedMap& map,
                                        const ExtremalRelaxOptions& options = {}, const CancelToken* cancel = nullptr,
                                        const std::vector<Point3>* rest = nullptr);

}  // namespace lipmap
