// A linear-cost solver for the large symmetric positive definite systems of the intermediate maps: conjugate
// gradients preconditioned by one V-cycle of smoothed-aggregation algebraic multigrid (Vanek, Mandel & Brezina
// 1996, "Algebraic multigrid by smoothed aggregation for second and fourth order elliptic problems").
//
// Why: a sparse Cholesky factor of a 2D mesh's Laplacian costs n^1.5 flops and fills n log n entries, so the
// maps of a 1M-triangle mesh cost 6-8x those of a 250k one; a cycle costs a few passes over each level's
// matrix, and with smoothed aggregation the number of cycles hardly grows with n (bench_ordering: 22, 23, 25
// cycles at 31k, 126k, 506k unknowns). The coarsest level (at most MultigridSettings::coarse_size unknowns) is
// factored with CHOLMOD. The maps use it from kMultigridMinUnknowns (engine/intermediate_map.h) on.
// How: the unknowns are put in breadth-first (Cuthill-McKee) order; aggregates and the smoothed prolongation
// come from A's M-matrix part, the coarse operators are P^T A P; symmetric Gauss-Seidel smoothing; every
// level's matrix is kept with float values and the two right-hand sides interleaved, because at 500k unknowns
// the cycles are bound by memory traffic (the conjugate gradients themselves run in double); for the same reason
// the cycle's passes are fused where the order of the work allows (restriction into the residual, prolongation
// into the backward sweep, the right-hand side's scaling and the conjugate gradients' r.z into the finest sweeps,
// S z into p's update); the levels are
// built for D^-1/2 A D^-1/2 (near null vector D^1/2 1), whose entries float holds whatever A's range.
//
// Preconditions (documented, not all checked): A is square, symmetric with its full pattern stored (both
// triangles), with a positive diagonal and positive definite; its near null space is the constant vector (a
// Laplacian's interior block with Dirichlet rows eliminated). compute() returns false when A is not usable
// (non-positive or non-finite diagonal, a pattern that is not symmetric, or a coarse factorization that fails);
// solve() then must not be called.
// One object solves on one thread at a time (its cycles reuse scratch vectors).
// The answer is an iterate, not an exact solve: each column's residual is driven below tolerance x |b|
// (stats() says how far it got); a right-hand side that is not finite gives an answer that is not either.
#pragma once

#include <memory>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "engine/cancel.h"

namespace lipmap {

struct MultigridSettings {
  int coarse_size = 4000;       // coarsen until a level has at most this many unknowns, then factor it
  double tolerance = 1e-13;     // relative residual of each column at which the iteration stops
  int max_iterations = 300;
  double strength = 0.08;       // -m_ij >= strength sqrt(m_ii m_jj) in A's M-matrix part: j may join i's aggregate
  int smoothing_sweeps = 1;     // symmetric Gauss-Seidel: forward before the coarse correction, backward after
};

struct MultigridStats {
  int levels = 0;               // including the finest and the factored coarsest
  long long operator_nonzeros = 0;  // over all levels (the operator complexity's numerator)
  int iterations = 0;           // of the last solve, summed over its columns' common loop
  double relative_residual = 0; // the largest column's, of the last solve (recursive residual)
};

class AggregationMultigrid {
 public:
  using Matrix = Eigen::SparseMatrix<double>;                 // column-major, int indices
  using Block = Eigen::Matrix<double, Eigen::Dynamic, 2>;     // two right-hand sides (the x and y of a map)

  explicit AggregationMultigrid(MultigridSettings settings = {});
  ~AggregationMultigrid();
  AggregationMultigrid(const AggregationMultigrid&) = delete;
  AggregationMultigrid& operator=(const AggregationMultigrid&) = delete;

  bool compute(const Matrix& A);
  // Throws Cancelled (engine/cancel.h) between iterations when the token is cancelled.
  Block solve(const Block& b, const CancelToken* cancel = nullptr) const;
  // One V-cycle from zero: a fixed symmetric positive definite approximation of A^-1 b (no iteration), for
  // use as a preconditioner (the optimizer's L-BFGS). A one-level hierarchy solves exactly.
  Block cycle(const Block& b) const;
  const MultigridStats& stats() const { return stats_; }

 private:
  struct Hierarchy;
  MultigridSettings settings_;
  std::unique_ptr<Hierarchy> hierarchy_;
  mutable MultigridStats stats_;
};

}  // namespace lipmap
