// Stage "intermediate maps" (paper 4 and 5.1): a globally bijective piecewise-linear map of a disk-topology
// triangle mesh onto the unit disk, boundary vertex loop[k] pinned at angle 2*pi*k/n. The pipeline builds
// it twice, h_s for the source mesh M (3D) and h_t for the target mesh M_t (planar, z = 0), and composes
// f = h_t^-1 o h_s.
//
// Methods
//   tutte     uniform weights (graph Laplacian): bijective in exact arithmetic (Tutte 1963, Floater 2003).
//   harmonic  cotangent weights (Pinkall & Polthier 1993). Weights may be negative, so the map may fold;
//             when it does, it is re-mapped with positive mean-value weights (Floater 2003) computed on the
//             harmonic result's own 2D positions (paper 5.1).
// Both assemble the symmetric positive definite interior block L_II and solve L_II [x y] = -L_IB [x_B y_B]
// with one supernodal CHOLMOD factorization and one two-column solve. The mean-value system is not
// symmetric and is solved with UMFPACK (one LU, two columns).
//
// Checking and recovery. After every solve each triangle is tested with the exact orientation predicate
// (count_non_positive, flip_check.h). Floating point can still fold a map whose weights are all positive:
// on long thin shapes the disk images of the far end crowd exponentially and drop below the solver's
// normwise accuracy. Recovery, in this order, stops as soon as the map is flip-free:
//   1. iterative refinement of the solve: residual b - A x accumulated in long double, correction solved
//      with the same factorization (no new factorization); up to kMaxRefinementSteps steps, stopping
//      after two steps that do not lower the flip count. It removes flips caused by the solver's
//      normwise error on moderately crowded vertices;
//   2. harmonic only: the mean-value re-map (with its own refinement). This is the paper's remedy for
//      folds caused by negative cotangent weights (obtuse triangles), and it removes them;
//   3. harmonic only: a Tutte re-map (with its own refinement).
// If all fail, the candidate with the fewest non-positive triangles is returned with DiskMap::flipped > 0.
// No exception is thrown for that: the count is exact and the caller decides (the pipeline must not
// compose a non-bijective intermediate map; it reports the mesh as beyond double precision). A DiskMap
// is never flipped silently: `flipped` is always the exact count for the uv it carries.
//
// What cannot be recovered: exponential crowding past the resolution of doubles. Example: a tube of 6
// vertices per ring closed at one end, boundary at the open end; each ring's image is ~2.5x smaller than
// the previous one and sits at an offset of ~1e-16 (the rounding of the boundary positions' mean). With
// 80 rings the Tutte map is flip-free (the cotangent map shrinks faster, folds, and the Tutte re-map
// replaces it); with 120 the rings past ~75 (image radius
// ~1e-29, where the refined solve's error floor lies) fold, and a few rings further the exact map's rings
// are closer together than adjacent doubles near the offset (~1e-32 apart), so no harmonic or Tutte map
// stored in doubles can be flip-free. The stage reports it (tests: IntermediateMapCrowding).
//
// Boundary positions are written, never solved: uv[loop[k]] == disk_boundary_point(k, n) bit for bit.
#pragma once

#include <array>
#include <vector>

#include <Eigen/SparseCore>

#include "engine/cancel.h"
#include "engine/flip_check.h"
#include "engine/geometry.h"
#include "engine/parametrize_options.h"  // MapMethod

namespace lipmap {

// Which system produced DiskMap::uv.
enum class DiskMapSolution { primary, mean_value, tutte };

const char* to_string(DiskMapSolution solution);

inline constexpr int kMaxRefinementSteps = 6;

inline constexpr int kMultigridMinUnknowns = 100000;

struct DiskMapInput {
  const std::vector<Point3>* vertices = nullptr;
  const std::vector<Triangle>* faces = nullptr;       // counterclockwise seen with the interior on the left of the loop
  const std::vector<int>* boundary_loop = nullptr;    // the mesh's boundary loop, interior on the left
  // Where loop[k] goes; null: disk_boundary_point(k, n). Given, it must be a strictly convex polygon
  // (counterclockwise) for the positive-weight re-maps to be bijective (method extremal, paper 5.3).
  const std::vector<Point2>* boundary_positions = nullptr;
  // From this many interior vertices on, the SPD systems are solved by multigrid-preconditioned conjugate
  // gradients instead of a sparse Cholesky factor (engine/multigrid.h; docs/architecture.md has the
  // measurements behind the default).
  int multigrid_min_unknowns = kMultigridMinUnknowns;
};

struct DiskMap {
  std::vector<Point2> uv;            // one per input vertex; boundary vertex loop[k] at disk_boundary_point(k, n)
  int flipped = 0;                   // exact number of non-positive triangles of `uv` (0: bijective)
  int flipped_after_solve = 0;       // exact count right after the first solve, before any recovery
  bool used_mean_value_fallback = false;  // uv comes from the mean-value re-map (harmonic only)
  bool used_tutte_fallback = false;       // uv comes from the last-resort Tutte re-map (harmonic only)
  DiskMapSolution solution = DiskMapSolution::primary;
  int refinement_steps = 0;          // iterative-refinement steps applied, over all systems solved
  int factorizations = 0;            // sparse factorizations (or multigrid set-ups) done (1 unless a fallback ran)
  int multigrid_levels = 0;          // of the primary system's multigrid hierarchy (0: factored directly)
  int solver_iterations = 0;         // conjugate-gradient iterations over all multigrid solves
  bool lu_for_primary = false;       // the SPD factorization failed numerically and LU solved the primary system
  int mean_value_rows_repaired = 0;  // mean-value rows whose 2D weights were unusable (3D or uniform weights used)
  int numerically_degenerate_faces = 0;  // faces with non-finite cotangents (uniform weights used for them)
  int interior_vertices = 0;
  // Timings of the primary system: assembly (weights + matrix + right-hand side), factorization, the
  // two-column solve, the exact flip check. fallback_ms covers refinement and every re-map.
  double assemble_ms = 0, factor_ms = 0, solve_ms = 0, check_ms = 0, fallback_ms = 0, total_ms = 0;

  bool bijective() const { return flipped == 0; }
};

// The image of boundary vertex k of n: theta = (2.0 * M_PI * double(k)) / double(n) evaluated in double in
// exactly that order, then {std::cos(theta), std::sin(theta)}.
Point2 disk_boundary_point(int k, int n);

// disk_boundary_point(k, n) for k = 0 .. n-1.
std::vector<Point2> disk_boundary_positions(int n);

// Maps the mesh onto the unit disk. Preconditions (a validated DiskMesh satisfies them; violations throw
// InternalError): loop has >= 3 distinct in-range vertices, every other vertex is used by a face, every
// face index is in range. Throws Cancelled when the token fires.
// MapMethod::extremal is not a method of this stage alone (engine/convex_domain.h, engine/teichmuller.h);
// here it builds the harmonic map, its first step.
DiskMap map_to_disk(const DiskMapInput& input, MapMethod method, const CancelToken* cancel = nullptr);

// ---- Building blocks (reused by the variable-metric stage and method extremal) ----

// Keeps a CHOLMOD factorization on the calling thread: OpenBLAS (when it is the BLAS) on one thread, and no
// OpenMP region run in parallel. Call before each CHOLMOD factorization (one engine job runs per core;
// threads of their own would only oversubscribe the cores).
void use_single_threaded_solvers();

// cot of the angle at each corner: result[f][c] is the cotangent of the angle of face f at corner
// faces[f][c], i.e. dot(e1, e2) / |e1 x e2| with e1, e2 the two edges leaving that corner. Unsigned
// (the triangle's own geometry, independent of orientation); +-inf or NaN for a numerically degenerate face.
std::vector<std::array<double, 3>> corner_cotangents(const std::vector<Point3>& vertices,
                                                     const std::vector<Triangle>& faces);
std::vector<std::array<double, 3>> corner_cotangents(const std::vector<Point2>& vertices,
                                                     const std::vector<Triangle>& faces);

// Symmetric vertex_count x vertex_count Laplacian with L_ij = -w_ij on edges, L_ii = sum_j w_ij, where
// w_ij = (cot alpha + cot beta) / 2 sums the corner cotangents opposite edge ij in its one or two faces
// (Pinkall-Polthier). A face with a non-finite cotangent contributes uniform weights 1/2 per edge
// instead; their number goes to *non_finite_faces when given.
Eigen::SparseMatrix<double> laplacian_from_cotangents(int vertex_count, const std::vector<Triangle>& faces,
                                                      const std::vector<std::array<double, 3>>& cotangents,
                                                      int* non_finite_faces = nullptr);

// The cotangent Laplacian of a 3D triangle mesh (corner_cotangents + laplacian_from_cotangents).
Eigen::SparseMatrix<double> cotan_laplacian(const std::vector<Point3>& vertices, const std::vector<Triangle>& faces,
                                            int* non_finite_faces = nullptr);

// The graph Laplacian: w_ij = 1 for every edge.
Eigen::SparseMatrix<double> uniform_laplacian(int vertex_count, const std::vector<Triangle>& faces);

// The same solve / check / recovery as map_to_disk, with a caller-supplied symmetric Laplacian (for
// instance cotangents under a per-face metric). It must make L_II positive definite. With
// mean_value_fallback the mean-value and Tutte re-maps run when the result folds; without, only
// refinement does.
DiskMap map_to_disk_with_laplacian(const DiskMapInput& input, const Eigen::SparseMatrix<double>& laplacian,
                                   bool mean_value_fallback, const CancelToken* cancel = nullptr);

}  // namespace lipmap
