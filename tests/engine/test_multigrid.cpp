// engine/multigrid.h: conjugate gradients preconditioned by smoothed-aggregation multigrid.
//
// Checked without the solver's own kernels: the residual b - A x is formed with Eigen's sparse product, and
// the answer is compared with Eigen's SimplicialLDLT factorization of the same matrix. The matrices are
// generated: Dirichlet Laplacians of grids with random positive edge weights spanning four decades, and
// cotangent Laplacians of jittered triangulations, whose obtuse corners give positive off-diagonal entries.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/SparseCholesky>

#include "engine/cancel.h"
#include "engine/multigrid.h"
#include "engine/error.h"

namespace lipmap {
namespace {

using Matrix = AggregationMultigrid::Matrix;
using Block = AggregationMultigrid::Block;

// The interior block of a graph Laplacian on an (nx+1) x (ny+1) vertex grid whose outer ring is fixed
// (Dirichlet): weights w(edge) > 0, diagonal = the sum of all edge weights at the vertex (boundary included).
Matrix grid_laplacian(int nx, int ny, std::uint64_t seed, double decades) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> exponent(-decades / 2, decades / 2);
  auto id = [&](int i, int j) { return (j - 1) * (nx - 1) + (i - 1); };  // interior vertices only
  auto interior = [&](int i, int j) { return i > 0 && j > 0 && i < nx && j < ny; };
  const int n = (nx - 1) * (ny - 1);
  std::vector<Eigen::Triplet<double>> trip;
  std::vector<double> diag(static_cast<std::size_t>(n), 0.0);
  auto edge = [&](int i0, int j0, int i1, int j1) {
    const double w = std::pow(10.0, exponent(rng));
    const bool a = interior(i0, j0), b = interior(i1, j1);
    if (a) diag[static_cast<std::size_t>(id(i0, j0))] += w;
    if (b) diag[static_cast<std::size_t>(id(i1, j1))] += w;
    if (a && b) {
      trip.emplace_back(id(i0, j0), id(i1, j1), -w);
      trip.emplace_back(id(i1, j1), id(i0, j0), -w);
    }
  };
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      if (i < nx) edge(i, j, i + 1, j);
      if (j < ny) edge(i, j, i, j + 1);
    }
  for (int k = 0; k < n; ++k) trip.emplace_back(k, k, diag[static_cast<std::size_t>(k)]);
  Matrix A(n, n);
  A.setFromTriplets(trip.begin(), trip.end());
  A.makeCompressed();
  return A;
}

// The interior block of the cotangent Laplacian of a jittered, diagonally split grid (jitter up to 0.4 of a
// cell: many obtuse triangles, so positive off-diagonal entries). Positive definite: the Dirichlet energy of
// a piecewise-linear function vanishing on the boundary of a valid triangulation.
Matrix cotangent_laplacian(int nx, int ny, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.4, 0.4);
  const int nv = (nx + 1) * (ny + 1);
  std::vector<double> x(static_cast<std::size_t>(nv)), y(static_cast<std::size_t>(nv));
  auto v = [&](int i, int j) { return j * (nx + 1) + i; };
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const bool boundary = i == 0 || j == 0 || i == nx || j == ny;
      x[static_cast<std::size_t>(v(i, j))] = i + (boundary ? 0 : jitter(rng));
      y[static_cast<std::size_t>(v(i, j))] = j + (boundary ? 0 : jitter(rng));
    }
  std::vector<int> row(static_cast<std::size_t>(nv), -1);
  int n = 0;
  for (int j = 1; j < ny; ++j)
    for (int i = 1; i < nx; ++i) row[static_cast<std::size_t>(v(i, j))] = n++;
  std::vector<Eigen::Triplet<double>> trip;
  auto triangle = [&](int a, int b, int c) {
    const int t[3] = {a, b, c};
    for (int k = 0; k < 3; ++k) {
      const int o = t[k], p = t[(k + 1) % 3], q = t[(k + 2) % 3];
      const double e1x = x[p] - x[o], e1y = y[p] - y[o], e2x = x[q] - x[o], e2y = y[q] - y[o];
      const double w = 0.5 * (e1x * e2x + e1y * e2y) / std::fabs(e1x * e2y - e1y * e2x);
      const int rp = row[static_cast<std::size_t>(p)], rq = row[static_cast<std::size_t>(q)];
      if (rp >= 0) trip.emplace_back(rp, rp, w);
      if (rq >= 0) trip.emplace_back(rq, rq, w);
      if (rp >= 0 && rq >= 0) {
        trip.emplace_back(rp, rq, -w);
        trip.emplace_back(rq, rp, -w);
      }
    }
  };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      if ((i + j) % 2 == 0) {
        triangle(v(i, j), v(i + 1, j), v(i + 1, j + 1));
        triangle(v(i, j), v(i + 1, j + 1), v(i, j + 1));
      } else {
        triangle(v(i, j), v(i + 1, j), v(i, j + 1));
        triangle(v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
      }
    }
  Matrix A(n, n);
  A.setFromTriplets(trip.begin(), trip.end());
  A.makeCompressed();
  return A;
}

int positive_off_diagonals(const Matrix& A) {
  int count = 0;
  for (int c = 0; c < A.outerSize(); ++c)
    for (Matrix::InnerIterator it(A, c); it; ++it)
      if (it.row() != c && it.value() > 0) ++count;
  return count;
}

Block random_rhs(Eigen::Index n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  Block b(n, 2);
  for (Eigen::Index i = 0; i < n; ++i) b.row(i) << normal(rng), normal(rng);
  return b;
}

// Solves A x = b with the multigrid solver and checks x against the residual and an LDLT factor.
// Returns the number of levels.
int expect_solves(const Matrix& A, const Block& b, const MultigridSettings& settings, const std::string& name) {
  AggregationMultigrid multigrid(settings);
  if (!multigrid.compute(A)) {
    ADD_FAILURE() << name << ": set-up failed";
    return 0;
  }
  EXPECT_EQ(multigrid.stats().levels > 1, A.rows() > settings.coarse_size) << name;
  const Block x = multigrid.solve(b);
  EXPECT_TRUE(x.allFinite()) << name;
  for (int c = 0; c < 2; ++c) {
    const double relative = (b.col(c) - A * x.col(c)).norm() / b.col(c).norm();
    EXPECT_LE(relative, 1e-11) << name << " column " << c;
  }
  Eigen::SimplicialLDLT<Matrix> ldlt(A);
  EXPECT_EQ(ldlt.info(), Eigen::Success) << name;
  const Eigen::MatrixXd reference = ldlt.solve(Eigen::MatrixXd(b));
  const double scale = reference.cwiseAbs().maxCoeff();
  EXPECT_LE((x - reference).cwiseAbs().maxCoeff(), 1e-8 * scale) << name;
  if (multigrid.stats().levels > 1) EXPECT_LE(multigrid.stats().iterations, 120) << name;
  return multigrid.stats().levels;
}

TEST(Multigrid, GridLaplaciansWithWeightsOverFourDecades) {
  MultigridSettings settings;
  settings.coarse_size = 60;  // several levels even on small grids
  int deep = 0;
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    const int nx = 8 + static_cast<int>(seed * 7 % 41), ny = 5 + static_cast<int>(seed * 13 % 37);
    const Matrix A = grid_laplacian(nx, ny, seed, seed % 3 == 0 ? 0.0 : 4.0);
    if (expect_solves(A, random_rhs(A.rows(), seed), settings,
                      "grid " + std::to_string(nx) + "x" + std::to_string(ny) + " seed " + std::to_string(seed)) >= 3)
      ++deep;
  }
  EXPECT_GE(deep, 4);  // cycles through three levels or more are exercised
}

// Values beyond float's range (a Laplacian scaled by 1e+-60; the optimizer's powered-mips weights reach such
// values): the levels are kept in float, so they are built for the diagonally scaled matrix. And 0, 1 and 2
// smoothing sweeps (0 is taken as 1: without a sweep the cycle would be singular; 2 takes the full residual
// instead of the half pass after the first sweep).
TEST(Multigrid, ValuesBeyondFloatsRangeAndOtherSweepCounts) {
  for (std::uint64_t seed = 1; seed <= 4; ++seed)
    for (double factor : {1e60, 1e-60}) {
      const Matrix A = factor * grid_laplacian(25 + static_cast<int>(seed), 30, seed, 4.0);
      for (int sweeps : {0, 1, 2}) {
        MultigridSettings settings;
        settings.coarse_size = 60;
        settings.smoothing_sweeps = sweeps;
        expect_solves(A, random_rhs(A.rows(), seed), settings,
                      "seed " + std::to_string(seed) + " x " + std::to_string(factor) + ", " +
                          std::to_string(sweeps) + " sweeps");
      }
    }
}

// Edge weights over a hundred decades: the coarse operators' diagonals (an aggregate's energy) cancel to noise
// in double. The set-up may refuse such a matrix (the callers then factor it), but what it accepts it solves,
// and nothing it returns is NaN.
TEST(Multigrid, ExtremeContrastIsRefusedOrSolved) {
  int refused = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const Matrix A = grid_laplacian(25 + static_cast<int>(seed), 30, seed, 100.0);
    MultigridSettings settings;
    settings.coarse_size = 60;
    AggregationMultigrid multigrid(settings);
    if (!multigrid.compute(A)) {
      ++refused;
      continue;
    }
    const Block b = random_rhs(A.rows(), seed);
    const Block x = multigrid.solve(b);
    const Block once = multigrid.cycle(b);
    EXPECT_TRUE(once.allFinite()) << "seed " << seed;
    if (multigrid.stats().relative_residual <= 1e-10) {
      for (int c = 0; c < 2; ++c)
        EXPECT_LE((b.col(c) - A * x.col(c)).norm() / b.col(c).norm(), 1e-9) << "seed " << seed;
    }
  }
  std::printf("[ multigrid ] weights over 1e+-50: %d of 4 refused at set-up\n", refused);
}

TEST(Multigrid, CotangentLaplaciansWithObtuseTriangles) {
  MultigridSettings settings;
  settings.coarse_size = 80;
  int with_positive_entries = 0;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const int nx = 10 + static_cast<int>(seed * 11 % 50), ny = 10 + static_cast<int>(seed * 5 % 30);
    const Matrix A = cotangent_laplacian(nx, ny, seed);
    if (positive_off_diagonals(A) > 0) ++with_positive_entries;
    expect_solves(A, random_rhs(A.rows(), 100 + seed), settings, "cotangent seed " + std::to_string(seed));
  }
  EXPECT_GE(with_positive_entries, 8);  // the generator does make the case this test is about
}

// cycle() is the optimizer's preconditioner: L-BFGS needs a fixed symmetric positive definite operator M, and
// a useful one reduces the error of any guess (in A's energy norm: |A^-1 b - M b|_A < |A^-1 b|_A).
TEST(Multigrid, OneCycleIsASymmetricPositiveDefiniteContraction) {
  MultigridSettings settings;
  settings.coarse_size = 60;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const Matrix A = seed % 2 ? cotangent_laplacian(30 + static_cast<int>(seed), 25, seed)
                              : grid_laplacian(35, 28 + static_cast<int>(seed), seed, 3.0);
    AggregationMultigrid multigrid(settings);
    ASSERT_TRUE(multigrid.compute(A));
    ASSERT_GE(multigrid.stats().levels, 3);
    const Block u = random_rhs(A.rows(), 10 * seed), v = random_rhs(A.rows(), 10 * seed + 1);
    const Block Mu = multigrid.cycle(u), Mv = multigrid.cycle(v);
    for (int c = 0; c < 2; ++c) {
      const double uMv = u.col(c).dot(Mv.col(c)), vMu = v.col(c).dot(Mu.col(c));
      EXPECT_NEAR(uMv, vMu, 1e-10 * std::fabs(uMv) + 1e-12) << "seed " << seed;
      EXPECT_GT(u.col(c).dot(Mu.col(c)), 0) << "seed " << seed;
      const Eigen::VectorXd x = Eigen::SimplicialLDLT<Matrix>(A).solve(u.col(c));
      const Eigen::VectorXd e = x - Mu.col(c);
      EXPECT_LT(e.dot(A * e), 0.5 * x.dot(A * x)) << "seed " << seed;
    }
  }
}

TEST(Multigrid, OneLevelWhenSmallEnoughToFactor) {
  const Matrix A = cotangent_laplacian(12, 9, 7);
  MultigridSettings settings;
  settings.coarse_size = static_cast<int>(A.rows());
  AggregationMultigrid multigrid(settings);
  ASSERT_TRUE(multigrid.compute(A));
  EXPECT_EQ(multigrid.stats().levels, 1);
  expect_solves(A, random_rhs(A.rows(), 3), settings, "one level");
}

// A hierarchy of several levels on a small matrix.
std::unique_ptr<AggregationMultigrid> built(const Matrix& A) {
  MultigridSettings settings;
  settings.coarse_size = 50;
  auto multigrid = std::make_unique<AggregationMultigrid>(settings);
  EXPECT_TRUE(multigrid->compute(A));
  EXPECT_GE(multigrid->stats().levels, 2);
  return multigrid;
}

TEST(Multigrid, ZeroAndNonFiniteRightHandSides) {
  const Matrix A = grid_laplacian(30, 30, 5, 2.0);
  const std::unique_ptr<AggregationMultigrid> owner = built(A);
  const AggregationMultigrid& multigrid = *owner;
  EXPECT_TRUE(multigrid.solve(Block::Zero(A.rows(), 2)).isZero(0.0));
  Block one = random_rhs(A.rows(), 9);
  one.col(1).setZero();
  const Block x = multigrid.solve(one);
  EXPECT_TRUE(x.col(1).isZero(0.0));
  EXPECT_LE((one.col(0) - A * x.col(0)).norm() / one.col(0).norm(), 1e-11);
  Block bad = random_rhs(A.rows(), 10);
  bad(17, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(multigrid.solve(bad).allFinite());
}

TEST(Multigrid, RefusesAMatrixWithoutAPositiveDiagonal) {
  Matrix A = grid_laplacian(10, 10, 1, 0.0);
  A.coeffRef(5, 5) = 0.0;
  AggregationMultigrid multigrid;
  EXPECT_FALSE(multigrid.compute(A));
  A.coeffRef(5, 5) = -1.0;
  EXPECT_FALSE(multigrid.compute(A));
  A.coeffRef(5, 5) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(multigrid.compute(A));
}

TEST(Multigrid, CancelledTokenStopsTheIterations) {
  const Matrix A = grid_laplacian(40, 40, 2, 1.0);
  const std::unique_ptr<AggregationMultigrid> multigrid = built(A);
  CancelToken token;
  token.cancel();
  EXPECT_THROW(multigrid->solve(random_rhs(A.rows(), 1), &token), Cancelled);
}

}  // namespace
}  // namespace lipmap
