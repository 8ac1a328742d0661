// Stage "optimize", after refine (or after a successful untangle): lower the distortion of a locally
// injective map while every step keeps every triangle strictly positive, so the map stays locally injective
// (a continuous motion through positive triangles cannot change an angle sum, which is a whole number of
// turns) and verify checks the final answer exactly as before.
//
// Energy (ParametrizeOptions::optimize): MIPS tr(J^T J) / det J = K + 1/K (the default: it lowers the
// conformal distortion K = sigma1 / sigma2 that the quality stage reports) or the symmetric Dirichlet energy;
// minimized with the flip-free line search of Smith & Schaefer 2015 (engine/detail/uv_descent.h), the accepted
// positions checked with the exact orientation predicate: by L-BFGS preconditioned with the Laplacian in the
// metric of the starting map (engine/detail/uv_descent.h), then, for MIPS on
// maps of up to kNewtonMaxFaces triangles, by projected Newton steps from where it stopped.
//
// What moves: the interior vertices. The boundary is pinned exactly. On a refined map (given the rotation
// indices, without a reference metric) every vertex off the boundary moves first, inserted ones in uv only
// (their 3D points stay on their edges): that undoes folds some points were inserted for, and the points it
// leaves removable are removed (refine.h's simplify_again, the rounds of Fig. 11 on the moved map; contract
// point 6 holds again); where the stage's step budget is at its floor (see kOptimizeFaceSteps: maps of about 67k
// triangles and more, without a time budget) only the vertices within a few rings of the inserted ones move in
// this first way. Then, and on every refined map otherwise, the inserted vertices and the original
// corners of the source faces that carry them stay: those faces' refined polygons are the ones the refinement
// minimized (paper 4, Fig. 11: no inserted point removable), and moving their corners could make a point
// removable after the fact. Every other vertex of a refined mesh moves freely. The first way is kept when
// neither the mean K nor the energy ends above the start's; else the second runs from the map as it came.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "engine/cancel.h"
#include "engine/disk_mesh.h"
#include "engine/parametrize_options.h"
#include "engine/quality.h"
#include "engine/refine.h"

namespace lipmap {

// The stage's default cost bound: steps x triangles at most kOptimizeFaceSteps (one step is a few passes over
// the triangles and one back-solve with the factorized Laplacian: about 6-9 ms at 50k triangles on the
// reference machine), at least kMinOptimizeSteps, and never more than options.max_iterations. So a mesh up to
// 2k triangles gets the full 1000 default steps, where they are cheap, a 10k one 200 and a 50k one 40: the whole
// pipeline stays within about 2x a plain Tutte map on large meshes (bench/bench_pipeline). A caller who gives
// options.time_budget_ms gets max_iterations within that time instead. On a refined map above kNewtonMaxFaces
// triangles the polish (see "What moves") gets what the free descents left of that budget, so one inserted point
// does not double the stage's time (bench_pipeline mountain / exp_strip: optimize 676 -> 359 ms, mean K 2.874 ->
// 2.903); a free round after one that removed points still has a budget of its own (points are worth it:
// max_registration_partial / weak_fan keeps 120 points, 158 if the rounds shared it too). Below it every descent
// has its own.
inline constexpr double kOptimizeFaceSteps = 2e6;
inline constexpr int kMinOptimizeSteps = 30;
int step_budget(const ParametrizeOptions& options, std::size_t faces);

// Then, for MIPS on maps of up to kNewtonMaxFaces triangles, projected Newton from where L-BFGS stopped, at most
// kNewtonFaceSteps / #triangles more steps (at least kMinOptimizeSteps, within max_iterations in all; a time
// budget lifts it as above). A Newton step factorizes the Hessian (about 20 L-BFGS steps' time at 8k triangles)
// but converges where L-BFGS crawls: on the bench's 5k-8k-triangle meshes (bench/bench_quality) the mean K went
// from 0.88 to 0.79 (wiggly_strip) and from 0.66 to 0.57 (swirl_domain) of the certificate's. Above the bound
// (the 30k+ meshes, 1M) a factorization per step would cost more than the pipeline's budget of about 2x a
// Tutte map (docs/architecture.md), and L-BFGS alone keeps them there.
inline constexpr std::size_t kNewtonMaxFaces = 30000;
inline constexpr double kNewtonFaceSteps = 4e5;
int newton_step_budget(const ParametrizeOptions& options, std::size_t faces);

struct Optimization {
  OptimizeEnergy energy = OptimizeEnergy::none;
  bool ran = false;
  std::string outcome;       // one line: why it did not run, or why it stopped
  int iterations = 0;        // accepted steps
  int free_vertices = 0;     // vertices that could move
  double energy_before = 0, energy_after = 0;  // rest-area-weighted mean of the energy
  Distortion before;         // conformal distortion of the map it started from (after: the quality stage's)
  int points_removed = 0;    // inserted points the free descent left removable, removed (see "What moves")
  int free_descent_vertices = 0;  // vertices the kept free descents could move (0: none ran, or not kept)
};

// map: a refined map at the working scale with every face strictly positive; its uv is changed in place.
// loop: the source boundary loop; source: the validated source mesh (its topology locates inserted
// vertices' faces). rest: the rest shapes, one point per vertex of map (a reference metric's: the energy and
// the distortion it promises to lower are then measured against T's triangles, so the map moves towards T's
// shape); null for map.vertices (the surface). rotation: the classification's R_k per loop position; null or
// empty keeps a refined map's polygons pinned throughout. Throws Cancelled.
Optimization optimize_map(const DiskMesh& source, const std::vector<int>& loop, double uv_area, RefinedMap& map,
                          const ParametrizeOptions& options, const CancelToken* cancel = nullptr,
                          const std::vector<Point3>* rest = nullptr, const std::vector<int>* rotation = nullptr);

}  // namespace lipmap
