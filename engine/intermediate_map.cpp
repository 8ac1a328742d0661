// Intermediate maps onto the unit disk (paper 4, 5.1). See intermediate_map.h for the contract.
#include "engine/intermediate_map.h"

#include <dlfcn.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <utility>

#include <Eigen/CholmodSupport>
#include <Eigen/UmfPackSupport>

#include "engine/error.h"
#include "engine/multigrid.h"

namespace lipmap {

const char* to_string(MapMethod method) {
  switch (method) {
    case MapMethod::tutte: return "tutte";
    case MapMethod::harmonic: return "harmonic";
    case MapMethod::extremal: return "extremal";
  }
  return "?";
}

const char* to_string(DiskMapSolution solution) {
  switch (solution) {
    case DiskMapSolution::primary: return "primary";
    case DiskMapSolution::mean_value: return "mean_value";
    case DiskMapSolution::tutte: return "tutte";
  }
  return "?";
}

Point2 disk_boundary_point(int k, int n) {
  // 2.0 * M_PI is exact (a power-of-two scaling); keep this exact expression: tests and callers rely on
  // reproducing these values bit for bit.
  const double theta = (2.0 * M_PI * static_cast<double>(k)) / static_cast<double>(n);
  return {std::cos(theta), std::sin(theta)};
}

std::vector<Point2> disk_boundary_positions(int n) {
  std::vector<Point2> out(static_cast<std::size_t>(std::max(n, 0)));
  for (int k = 0; k < n; ++k) out[static_cast<std::size_t>(k)] = disk_boundary_point(k, n);
  return out;
}

namespace {

using Clock = std::chrono::steady_clock;
using SpMat = Eigen::SparseMatrix<double>;                  // column-major, int indices
using Rhs = Eigen::Matrix<double, Eigen::Dynamic, 2>;       // the x and y columns, solved together
using Triplet = Eigen::Triplet<double>;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// ---- corner cotangents ----------------------------------------------------------------------------

inline double cot_from(double dot, double cross_norm) { return dot / cross_norm; }

std::array<double, 3> face_cotangents(const Point3& a, const Point3& b, const Point3& c) {
  const Point3* p[3] = {&a, &b, &c};
  std::array<double, 3> out{};
  for (int k = 0; k < 3; ++k) {
    const Point3& o = *p[k];
    const Point3& u = *p[(k + 1) % 3];
    const Point3& w = *p[(k + 2) % 3];
    const double e1x = u.x - o.x, e1y = u.y - o.y, e1z = u.z - o.z;
    const double e2x = w.x - o.x, e2y = w.y - o.y, e2z = w.z - o.z;
    const double cx = e1y * e2z - e1z * e2y, cy = e1z * e2x - e1x * e2z, cz = e1x * e2y - e1y * e2x;
    out[static_cast<std::size_t>(k)] =
        cot_from(e1x * e2x + e1y * e2y + e1z * e2z, std::sqrt(cx * cx + cy * cy + cz * cz));
  }
  return out;
}

std::array<double, 3> face_cotangents(const Point2& a, const Point2& b, const Point2& c) {
  const Point2* p[3] = {&a, &b, &c};
  std::array<double, 3> out{};
  for (int k = 0; k < 3; ++k) {
    const Point2& o = *p[k];
    const Point2& u = *p[(k + 1) % 3];
    const Point2& w = *p[(k + 2) % 3];
    const double e1x = u.x - o.x, e1y = u.y - o.y, e2x = w.x - o.x, e2y = w.y - o.y;
    out[static_cast<std::size_t>(k)] = cot_from(e1x * e2x + e1y * e2y, std::fabs(e1x * e2y - e1y * e2x));
  }
  return out;
}

template <class P>
std::vector<std::array<double, 3>> corner_cotangents_impl(const std::vector<P>& v, const std::vector<Triangle>& faces) {
  std::vector<std::array<double, 3>> out(faces.size());
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const Triangle& t = faces[f];
    out[f] = face_cotangents(v[static_cast<std::size_t>(t[0])], v[static_cast<std::size_t>(t[1])],
                             v[static_cast<std::size_t>(t[2])]);
  }
  return out;
}

// ---- layout: which vertices are unknowns ----------------------------------------------------------

struct Layout {
  int n = 0;                      // vertex count
  const std::vector<int>* loop = nullptr;
  std::vector<int> row;           // vertex -> row of the interior system, -1 for boundary vertices
  std::vector<int> interior;      // row -> vertex
};

Layout make_layout(const DiskMapInput& in) {
  if (!in.vertices || !in.faces || !in.boundary_loop)
    throw InternalError("map_to_disk: vertices, faces and boundary_loop must all be given");
  const std::vector<int>& loop = *in.boundary_loop;
  Layout lay;
  lay.n = static_cast<int>(in.vertices->size());
  lay.loop = in.boundary_loop;
  if (loop.size() < 3) throw InternalError("map_to_disk: the boundary loop has fewer than 3 vertices");
  lay.row.assign(static_cast<std::size_t>(lay.n), 0);
  for (int v : loop) {
    if (v < 0 || v >= lay.n) throw InternalError("map_to_disk: boundary vertex " + std::to_string(v) + " out of range");
    if (lay.row[static_cast<std::size_t>(v)] == -1)
      throw InternalError("map_to_disk: boundary vertex " + std::to_string(v) + " repeated in the loop");
    lay.row[static_cast<std::size_t>(v)] = -1;
  }
  std::vector<char> used(static_cast<std::size_t>(lay.n), 0);
  for (const Triangle& t : *in.faces)
    for (int v : t) {
      if (v < 0 || v >= lay.n) throw InternalError("map_to_disk: face index " + std::to_string(v) + " out of range");
      used[static_cast<std::size_t>(v)] = 1;
    }
  for (int v = 0; v < lay.n; ++v) {
    if (lay.row[static_cast<std::size_t>(v)] == -1) continue;
    if (!used[static_cast<std::size_t>(v)])
      throw InternalError("map_to_disk: vertex " + std::to_string(v) + " is used by no face");
    lay.row[static_cast<std::size_t>(v)] = static_cast<int>(lay.interior.size());
    lay.interior.push_back(v);
  }
  return lay;
}

// ---- the interior system --------------------------------------------------------------------------

struct System {
  SpMat A;                        // m x m, rows/columns = interior vertices
  std::vector<long double> bx, by;  // -L_IB x_B, accumulated in long double
  Rhs b;                          // the same rounded to double
};

// The right-hand side (accumulated in long double) rounded once.
void round_rhs(System& s, int m) {
  s.b.resize(m, 2);
  for (int i = 0; i < m; ++i) {
    s.b(i, 0) = static_cast<double>(s.bx[static_cast<std::size_t>(i)]);
    s.b(i, 1) = static_cast<double>(s.by[static_cast<std::size_t>(i)]);
  }
}

// The matrix from its triplets, and the right-hand side rounded.
void finish_system(System& s, const std::vector<Triplet>& trip, int m) {
  s.A.resize(m, m);
  s.A.setFromTriplets(trip.begin(), trip.end());
  s.A.makeCompressed();
  round_rhs(s, m);
}

// Interior block and right-hand side of the vertex_count x vertex_count operator L (rows of boundary
// vertices are ignored). uv holds the boundary positions.
System extract(const SpMat& L, const Layout& lay, const std::vector<Point2>& uv) {
  const int m = static_cast<int>(lay.interior.size());
  System s;
  s.bx.assign(static_cast<std::size_t>(m), 0.0L);
  s.by.assign(static_cast<std::size_t>(m), 0.0L);
  std::vector<Triplet> trip;
  trip.reserve(static_cast<std::size_t>(L.nonZeros()));
  for (int c = 0; c < L.outerSize(); ++c) {
    const int ic = lay.row[static_cast<std::size_t>(c)];
    for (SpMat::InnerIterator it(L, c); it; ++it) {
      const int ir = lay.row[static_cast<std::size_t>(it.row())];
      if (ir < 0) continue;
      if (ic >= 0) {
        trip.emplace_back(ir, ic, it.value());
      } else {
        const Point2& p = uv[static_cast<std::size_t>(c)];
        s.bx[static_cast<std::size_t>(ir)] -= static_cast<long double>(it.value()) * p.x;
        s.by[static_cast<std::size_t>(ir)] -= static_cast<long double>(it.value()) * p.y;
      }
    }
  }
  finish_system(s, trip, m);
  return s;
}

// The interior system of a symmetric operator given by per-face edge weights, assembled directly (no
// vertex_count x vertex_count matrix, no triplet list): weight(f, k) is face f's contribution to the edge
// opposite its corner k. Same operator as extract(laplacian_from_...(...)), summed in a different order.
// The pattern is built first (each interior column's interior neighbours and itself, sorted), then the values
// are added into it in face order, which is the order setFromTriplets would sum them in: the same bits, in
// a quarter of the memory (at 1M triangles the triplets alone were 100 MB of freshly faulted pages).
template <class Weight>
System assemble_symmetric(const Layout& lay, const std::vector<Triangle>& faces, const std::vector<Point2>& uv,
                          Weight weight) {
  const int m = static_cast<int>(lay.interior.size());
  auto row_of = [&](int v) { return lay.row[static_cast<std::size_t>(v)]; };
  auto edge_rows = [&](const Triangle& t, int k) {  // the rows of the edge opposite corner k (-1: boundary)
    return std::pair{row_of(t[static_cast<std::size_t>((k + 1) % 3)]),
                     row_of(t[static_cast<std::size_t>((k + 2) % 3)])};
  };
  // Pattern: column c holds c and every interior ri with an edge (ri, c); counted, filled, sorted, deduplicated.
  std::vector<int> start(static_cast<std::size_t>(m) + 1, 0);
  for (const Triangle& t : faces)
    for (int k = 0; k < 3; ++k)
      if (const auto [ri, rj] = edge_rows(t, k); ri >= 0 && rj >= 0) {
        ++start[static_cast<std::size_t>(ri) + 1];
        ++start[static_cast<std::size_t>(rj) + 1];
      }
  for (int c = 0; c < m; ++c) start[static_cast<std::size_t>(c) + 1] += start[static_cast<std::size_t>(c)] + 1;
  std::vector<int> rows(static_cast<std::size_t>(start[static_cast<std::size_t>(m)]));
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int c = 0; c < m; ++c) rows[static_cast<std::size_t>(fill[static_cast<std::size_t>(c)]++)] = c;
    for (const Triangle& t : faces)
      for (int k = 0; k < 3; ++k)
        if (const auto [ri, rj] = edge_rows(t, k); ri >= 0 && rj >= 0) {
          rows[static_cast<std::size_t>(fill[static_cast<std::size_t>(rj)]++)] = ri;
          rows[static_cast<std::size_t>(fill[static_cast<std::size_t>(ri)]++)] = rj;
        }
  }
  System s;
  s.A.resize(m, m);
  {
    std::vector<int> outer(static_cast<std::size_t>(m) + 1, 0);
    int nnz = 0;
    for (int c = 0; c < m; ++c) {
      const auto b = rows.begin() + start[static_cast<std::size_t>(c)];
      const auto e = rows.begin() + start[static_cast<std::size_t>(c) + 1];
      std::sort(b, e);
      const int kept = static_cast<int>(std::unique(b, e) - b);
      std::copy(b, b + kept, rows.begin() + nnz);
      nnz += kept;
      outer[static_cast<std::size_t>(c) + 1] = nnz;
    }
    s.A.resizeNonZeros(nnz);
    std::copy(outer.begin(), outer.end(), s.A.outerIndexPtr());
    std::copy(rows.begin(), rows.begin() + nnz, s.A.innerIndexPtr());
    std::fill(s.A.valuePtr(), s.A.valuePtr() + nnz, 0.0);
  }
  std::vector<int>().swap(rows);
  auto value = [&](int r, int c) -> double& {
    const int* inner = s.A.innerIndexPtr();
    const int* b = inner + s.A.outerIndexPtr()[c];
    const int* e = inner + s.A.outerIndexPtr()[c + 1];
    return s.A.valuePtr()[std::lower_bound(b, e, r) - inner];
  };

  s.bx.assign(static_cast<std::size_t>(m), 0.0L);
  s.by.assign(static_cast<std::size_t>(m), 0.0L);
  std::vector<double> diag(static_cast<std::size_t>(m), 0.0);
  auto half = [&](int ri, int j, int rj, double w) {
    diag[static_cast<std::size_t>(ri)] += w;
    if (rj >= 0) {
      value(ri, rj) += -w;
    } else {
      const Point2& p = uv[static_cast<std::size_t>(j)];
      s.bx[static_cast<std::size_t>(ri)] += static_cast<long double>(w) * p.x;
      s.by[static_cast<std::size_t>(ri)] += static_cast<long double>(w) * p.y;
    }
  };
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const Triangle& t = faces[f];
    for (int k = 0; k < 3; ++k) {
      const int i = t[static_cast<std::size_t>((k + 1) % 3)];
      const int j = t[static_cast<std::size_t>((k + 2) % 3)];
      const int ri = row_of(i), rj = row_of(j);
      if (ri < 0 && rj < 0) continue;
      const double w = weight(f, k);
      if (ri >= 0) half(ri, j, rj, w);
      if (rj >= 0) half(rj, i, ri, w);
    }
  }
  for (int i = 0; i < m; ++i) value(i, i) += diag[static_cast<std::size_t>(i)];
  round_rhs(s, m);
  return s;
}

System assemble_uniform(const Layout& lay, const std::vector<Triangle>& faces, const std::vector<Point2>& uv) {
  return assemble_symmetric(lay, faces, uv, [](std::size_t, int) { return 0.5; });
}

// R = b - A X, accumulated in long double.
void residual(const System& s, const Rhs& X, Rhs& R) {
  const Eigen::Index m = s.A.rows();
  std::vector<long double> ax(static_cast<std::size_t>(m), 0.0L), ay(static_cast<std::size_t>(m), 0.0L);
  for (int c = 0; c < s.A.outerSize(); ++c) {
    const long double xc = X(c, 0), yc = X(c, 1);
    for (SpMat::InnerIterator it(s.A, c); it; ++it) {
      const long double a = it.value();
      ax[static_cast<std::size_t>(it.row())] += a * xc;
      ay[static_cast<std::size_t>(it.row())] += a * yc;
    }
  }
  R.resize(m, 2);
  for (Eigen::Index i = 0; i < m; ++i) {
    R(i, 0) = static_cast<double>(s.bx[static_cast<std::size_t>(i)] - ax[static_cast<std::size_t>(i)]);
    R(i, 1) = static_cast<double>(s.by[static_cast<std::size_t>(i)] - ay[static_cast<std::size_t>(i)]);
  }
}

void scatter(const Layout& lay, const Rhs& X, std::vector<Point2>& uv) {
  for (std::size_t i = 0; i < lay.interior.size(); ++i)
    uv[static_cast<std::size_t>(lay.interior[i])] = {X(static_cast<Eigen::Index>(i), 0), X(static_cast<Eigen::Index>(i), 1)};
}

struct Attempt {
  Rhs X;
  int flips = 0;          // of X
  int first_flips = 0;    // of the plain solve, before refinement
  DiskMapSolution solution = DiskMapSolution::primary;
};

struct Timing {
  double solve_ms = 0, check_ms = 0, refine_ms = 0;
};

// Solves, checks exactly, and refines iteratively while the map folds. Returns the best iterate (fewest
// non-positive triangles). uv is scratch (interior rows overwritten).
template <class Solver>
Attempt solve_checked(const Solver& solver, const System& s, const Layout& lay, const std::vector<Triangle>& faces,
                      std::vector<Point2>& uv, DiskMapSolution solution, const CancelToken* cancel, Timing& timing,
                      int& refinement_steps) {
  auto t0 = Clock::now();
  Rhs X = solver.solve(s.b);
  timing.solve_ms += ms_since(t0);
  if (!X.allFinite()) {
    if (solution == DiskMapSolution::primary)
      throw InternalError("map_to_disk: the solve is not finite (is every interior vertex connected to the boundary?)");
    // A failed re-map is never picked: more flips than there are faces.
    return Attempt{X, static_cast<int>(faces.size()) + 1, static_cast<int>(faces.size()) + 1, solution};
  }

  t0 = Clock::now();
  scatter(lay, X, uv);
  const int first_flips = count_non_positive(uv, faces);
  Attempt best{X, first_flips, first_flips, solution};
  timing.check_ms += ms_since(t0);

  t0 = Clock::now();
  Rhs R, D;
  int stalled = 0;  // steps in a row without fewer flips
  for (int step = 0; step < kMaxRefinementSteps && best.flips > 0 && stalled < 2; ++step) {
    check_cancel(cancel);
    residual(s, X, R);
    if (R.isZero(0.0)) break;
    D = solver.solve(R);
    if (!D.allFinite()) break;
    const Rhs next = X + D;
    if (next == X) break;  // the correction no longer changes a single double
    X = next;
    ++refinement_steps;
    scatter(lay, X, uv);
    const int flips = count_non_positive(uv, faces);
    if (flips < best.flips) {
      best.X = X;
      best.flips = flips;
      stalled = 0;
    } else {
      ++stalled;
    }
  }
  timing.refine_ms += ms_since(t0);
  return best;
}

}  // namespace

// lipmap runs one job per core, so threads inside a factorization only oversubscribe the cores: they spin
// and yield against the other workers and against the job's own thread. Two libraries start such threads:
// - CHOLMOD's supernodal factorization calls BLAS: OpenBLAS is told to use one thread (on 2 cores, the disk
//   maps of a 63k-triangle mesh took 3x longer wall time with its threads);
// - Debian's CHOLMOD opens OpenMP teams of a fixed 4 threads (CHOLMOD_OMP_NUM_THREADS, a num_threads clause
//   that omp_set_num_threads cannot lower): max-active-levels 0 makes every OpenMP region run on the calling
//   thread alone (alone on 2 cores, the disk maps of a 250k-triangle mesh took 550-870 ms with the team,
//   320 ms without). It is set on every call: an OpenMP runtime may keep it per thread.
// Both are looked up at run time, so that any other BLAS or OpenMP runtime works unchanged.
void use_single_threaded_solvers() {
  using SetInt = void (*)(int);
  static const SetInt set_levels = [] {
    if (auto set = reinterpret_cast<SetInt>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) set(1);
    return reinterpret_cast<SetInt>(dlsym(RTLD_DEFAULT, "omp_set_max_active_levels"));
  }();
  if (set_levels) set_levels(0);
}

namespace {

using Cholesky = Eigen::CholmodSupernodalLLT<SpMat, Eigen::Lower>;
using LU = Eigen::UmfPackLU<SpMat>;

// The multigrid solver as solve_checked sees it: counts its conjugate-gradient iterations, passes the token
// into them, and notes whether the first solve converged (relative residual within 1e-10; it stops at 1e-13).
// A solve that did not converge answers zero: after the first, solve_checked then ends at once (its refinement
// sees no change) and solve_spd factors the system instead; a refinement step's correction that did not
// converge ends the refinement and keeps the iterate.
struct MultigridSolves {
  const AggregationMultigrid& multigrid;
  const CancelToken* cancel;
  int& iterations;
  mutable bool converged = true;
  mutable int solves = 0;
  Rhs solve(const Rhs& b) const {
    if (!converged) return Rhs::Zero(b.rows(), 2);
    Rhs x = multigrid.solve(b, cancel);
    iterations += multigrid.stats().iterations;
    if (!(multigrid.stats().relative_residual <= 1e-10) || !x.allFinite()) {
      if (solves == 0) converged = false;
      x.setZero();
    }
    ++solves;
    return x;
  }
};

// Solve a system that should be SPD: CHOLMOD supernodal LLT, or UMFPACK when it is numerically not. From
// multigrid_min_unknowns unknowns on, conjugate gradients preconditioned by aggregation multigrid instead of
// the factorization (engine/multigrid.h): its cost grows linearly, the factor's as n^1.5.
Attempt solve_spd(const System& s, const Layout& lay, const std::vector<Triangle>& faces, std::vector<Point2>& uv,
                  DiskMapSolution solution, int multigrid_min_unknowns, const CancelToken* cancel, DiskMap& out,
                  Timing& timing, double* factor_ms) {
  use_single_threaded_solvers();
  auto t0 = Clock::now();
  if (s.A.rows() >= multigrid_min_unknowns) {
    AggregationMultigrid multigrid;
    if (multigrid.compute(s.A)) {
      ++out.factorizations;
      if (solution == DiskMapSolution::primary) out.multigrid_levels = multigrid.stats().levels;
      if (factor_ms) *factor_ms += ms_since(t0);
      check_cancel(cancel);
      const MultigridSolves solves{multigrid, cancel, out.solver_iterations};
      Attempt attempt = solve_checked(solves, s, lay, faces, uv, solution, cancel, timing, out.refinement_steps);
      if (solves.converged) return attempt;
      // Not converged (a system far from what aggregation handles): factor it after all.
      if (solution == DiskMapSolution::primary) out.multigrid_levels = 0;
      t0 = Clock::now();
    }
  }
  Cholesky llt;
  llt.cholmod().print = 0;  // a non-SPD matrix is handled below, not printed
  llt.compute(s.A);
  ++out.factorizations;
  if (llt.info() == Eigen::Success) {
    if (factor_ms) *factor_ms += ms_since(t0);
    check_cancel(cancel);
    return solve_checked(llt, s, lay, faces, uv, solution, cancel, timing, out.refinement_steps);
  }
  LU lu;
  lu.compute(s.A);
  ++out.factorizations;
  if (factor_ms) *factor_ms += ms_since(t0);
  if (lu.info() != Eigen::Success)
    throw InternalError(std::string("map_to_disk: the ") + to_string(solution) +
                        " system is singular (is every interior vertex connected to the boundary?)");
  if (solution == DiskMapSolution::primary) out.lu_for_primary = true;
  check_cancel(cancel);
  return solve_checked(lu, s, lay, faces, uv, solution, cancel, timing, out.refinement_steps);
}

// ---- mean-value weights (Floater 2003) ------------------------------------------------------------

// tan(theta / 2) of the angle between e1 and e2, from |e1 x e2| and e1 . e2 (stable for all theta < pi).
inline double half_angle_tan(double cross_norm, double dot, double l1, double l2) {
  return cross_norm / (l1 * l2 + dot);
}

// Row-major n x n matrix of directed mean-value weights w_ij > 0 (off-diagonal, positive) for the rows
// flagged in `rows`, from positions p (2D or 3D through the accessor).
template <class Corner>
Eigen::SparseMatrix<double, Eigen::RowMajor> mean_value_weights(int n, const std::vector<Triangle>& faces,
                                                                const std::vector<char>& rows, Corner corner) {
  std::vector<Triplet> trip;
  trip.reserve(faces.size() * 6);
  for (const Triangle& t : faces)
    for (int k = 0; k < 3; ++k) {
      const int i = t[static_cast<std::size_t>(k)];
      if (!rows[static_cast<std::size_t>(i)]) continue;
      const int j = t[static_cast<std::size_t>((k + 1) % 3)];
      const int l = t[static_cast<std::size_t>((k + 2) % 3)];
      double l1, l2, tan_half;
      corner(i, j, l, l1, l2, tan_half);
      trip.emplace_back(i, j, tan_half / l1);
      trip.emplace_back(i, l, tan_half / l2);
    }
  Eigen::SparseMatrix<double, Eigen::RowMajor> W(n, n);
  W.setFromTriplets(trip.begin(), trip.end());
  return W;
}

bool row_ok(const Eigen::SparseMatrix<double, Eigen::RowMajor>& W, int i) {
  bool any = false;
  double sum = 0;
  for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(W, i); it; ++it) {
    if (!(std::isfinite(it.value()) && it.value() > 0)) return false;
    sum += it.value();
    any = true;
  }
  return any && std::isfinite(sum);
}

// The mean-value operator (rows of interior vertices only): L_ii = sum_j w_ij, L_ij = -w_ij. Weights from
// the 2D positions uv (the folded harmonic map, paper 5.1); a row whose 2D weights are unusable (coincident
// or collinear images) takes mean-value weights from the 3D positions, and failing that uniform weights.
// Every row is then a strictly positive convex combination, so Floater's theorem applies.
SpMat mean_value_laplacian(const Layout& lay, const std::vector<Triangle>& faces, const std::vector<Point2>& uv,
                           const std::vector<Point3>& xyz, int& repaired) {
  const int n = lay.n;
  std::vector<char> rows(static_cast<std::size_t>(n), 0);
  for (int v : lay.interior) rows[static_cast<std::size_t>(v)] = 1;

  auto corner2 = [&](int i, int j, int l, double& l1, double& l2, double& th) {
    const Point2& o = uv[static_cast<std::size_t>(i)];
    const double e1x = uv[static_cast<std::size_t>(j)].x - o.x, e1y = uv[static_cast<std::size_t>(j)].y - o.y;
    const double e2x = uv[static_cast<std::size_t>(l)].x - o.x, e2y = uv[static_cast<std::size_t>(l)].y - o.y;
    l1 = std::hypot(e1x, e1y);
    l2 = std::hypot(e2x, e2y);
    th = half_angle_tan(std::fabs(e1x * e2y - e1y * e2x), e1x * e2x + e1y * e2y, l1, l2);
  };
  auto corner3 = [&](int i, int j, int l, double& l1, double& l2, double& th) {
    const Point3& o = xyz[static_cast<std::size_t>(i)];
    const Point3& a = xyz[static_cast<std::size_t>(j)];
    const Point3& b = xyz[static_cast<std::size_t>(l)];
    const double e1x = a.x - o.x, e1y = a.y - o.y, e1z = a.z - o.z;
    const double e2x = b.x - o.x, e2y = b.y - o.y, e2z = b.z - o.z;
    const double cx = e1y * e2z - e1z * e2y, cy = e1z * e2x - e1x * e2z, cz = e1x * e2y - e1y * e2x;
    l1 = std::sqrt(e1x * e1x + e1y * e1y + e1z * e1z);
    l2 = std::sqrt(e2x * e2x + e2y * e2y + e2z * e2z);
    th = half_angle_tan(std::sqrt(cx * cx + cy * cy + cz * cz), e1x * e2x + e1y * e2y + e1z * e2z, l1, l2);
  };
  auto uniform = [](int, int, int, double& l1, double& l2, double& th) { l1 = l2 = 1.0; th = 0.5; };

  Eigen::SparseMatrix<double, Eigen::RowMajor> W = mean_value_weights(n, faces, rows, corner2);
  std::vector<char> bad(static_cast<std::size_t>(n), 0);
  bool any_bad = false;
  for (int v : lay.interior)
    if (!row_ok(W, v)) bad[static_cast<std::size_t>(v)] = any_bad = 1;
  Eigen::SparseMatrix<double, Eigen::RowMajor> W3, Wu;
  std::vector<char> bad3(static_cast<std::size_t>(n), 0);
  if (any_bad) {
    W3 = mean_value_weights(n, faces, bad, corner3);
    bool any_bad3 = false;
    for (int v : lay.interior)
      if (bad[static_cast<std::size_t>(v)] && !row_ok(W3, v)) bad3[static_cast<std::size_t>(v)] = any_bad3 = 1;
    if (any_bad3) Wu = mean_value_weights(n, faces, bad3, uniform);
  }

  std::vector<Triplet> trip;
  trip.reserve(static_cast<std::size_t>(W.nonZeros()) * 2);
  repaired = 0;
  for (int v : lay.interior) {
    const Eigen::SparseMatrix<double, Eigen::RowMajor>* src = &W;
    if (bad[static_cast<std::size_t>(v)]) {
      ++repaired;
      src = bad3[static_cast<std::size_t>(v)] ? &Wu : &W3;
    }
    double sum = 0;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(*src, v); it; ++it) {
      trip.emplace_back(v, static_cast<int>(it.col()), -it.value());
      sum += it.value();
    }
    trip.emplace_back(v, v, sum);
  }
  SpMat L(n, n);
  L.setFromTriplets(trip.begin(), trip.end());
  return L;
}

// ---- the driver -----------------------------------------------------------------------------------

// build(uv) returns the primary interior system for the boundary positions in uv.
template <class Build>
DiskMap run(const DiskMapInput& in, const Layout& lay, Build build, bool fallbacks, double assemble_ms,
            const CancelToken* cancel, Clock::time_point t_start) {
  const std::vector<Triangle>& faces = *in.faces;
  const std::vector<int>& loop = *lay.loop;
  const int nb = static_cast<int>(loop.size());

  DiskMap out;
  out.assemble_ms = assemble_ms;
  out.interior_vertices = static_cast<int>(lay.interior.size());
  out.uv.assign(static_cast<std::size_t>(lay.n), Point2{});
  if (in.boundary_positions && in.boundary_positions->size() != loop.size())
    throw InternalError("map_to_disk: boundary_positions does not have one point per loop vertex");
  for (int k = 0; k < nb; ++k)
    out.uv[static_cast<std::size_t>(loop[static_cast<std::size_t>(k)])] =
        in.boundary_positions ? (*in.boundary_positions)[static_cast<std::size_t>(k)] : disk_boundary_point(k, nb);

  if (lay.interior.empty()) {
    auto t0 = Clock::now();
    out.flipped = out.flipped_after_solve = count_non_positive(out.uv, faces);
    out.check_ms = ms_since(t0);
    out.total_ms = ms_since(t_start);
    return out;
  }

  auto t0 = Clock::now();
  const System sys = build(out.uv);
  out.assemble_ms += ms_since(t0);
  check_cancel(cancel);

  // Primary solve. Its first solve and check are timed apart from its refinement (in fallback_ms).
  Timing primary_timing;
  std::vector<Point2> scratch = out.uv;
  std::vector<Attempt> attempts;
  attempts.push_back(
      solve_spd(sys, lay, faces, scratch, DiskMapSolution::primary, in.multigrid_min_unknowns, cancel, out,
                primary_timing, &out.factor_ms));
  out.solve_ms = primary_timing.solve_ms;
  out.check_ms = primary_timing.check_ms;
  out.flipped_after_solve = attempts.back().first_flips;
  double fallback_ms = primary_timing.refine_ms;

  if (attempts.back().flips > 0 && fallbacks) {
    auto tf = Clock::now();
    check_cancel(cancel);
    // Mean-value re-map on the (best) harmonic 2D positions.
    scatter(lay, attempts.front().X, scratch);
    const SpMat Lmv = mean_value_laplacian(lay, faces, scratch, *in.vertices, out.mean_value_rows_repaired);
    const System smv = extract(Lmv, lay, out.uv);
    check_cancel(cancel);
    {
      LU lu;
      lu.compute(smv.A);
      ++out.factorizations;
      if (lu.info() == Eigen::Success) {
        Timing t;
        attempts.push_back(solve_checked(lu, smv, lay, faces, scratch, DiskMapSolution::mean_value, cancel, t,
                                         out.refinement_steps));
      }
    }
    if (attempts.back().flips > 0) {
      check_cancel(cancel);
      const System st = assemble_uniform(lay, faces, out.uv);
      Timing t;
      attempts.push_back(solve_spd(st, lay, faces, scratch, DiskMapSolution::tutte, in.multigrid_min_unknowns,
                                   cancel, out, t, nullptr));
    }
    fallback_ms += ms_since(tf);
  }

  // Fewest flips wins; on a tie the later (positive-weight) re-map wins.
  std::size_t pick = 0;
  for (std::size_t i = 1; i < attempts.size(); ++i)
    if (attempts[i].flips <= attempts[pick].flips) pick = i;
  const Attempt& best = attempts[pick];
  scatter(lay, best.X, out.uv);
  out.flipped = best.flips;
  out.solution = best.solution;
  out.used_mean_value_fallback = best.solution == DiskMapSolution::mean_value;
  out.used_tutte_fallback = best.solution == DiskMapSolution::tutte;
  out.fallback_ms = fallback_ms;
  out.total_ms = ms_since(t_start);
  return out;
}

}  // namespace

std::vector<std::array<double, 3>> corner_cotangents(const std::vector<Point3>& vertices,
                                                     const std::vector<Triangle>& faces) {
  return corner_cotangents_impl(vertices, faces);
}

std::vector<std::array<double, 3>> corner_cotangents(const std::vector<Point2>& vertices,
                                                     const std::vector<Triangle>& faces) {
  return corner_cotangents_impl(vertices, faces);
}

Eigen::SparseMatrix<double> laplacian_from_cotangents(int vertex_count, const std::vector<Triangle>& faces,
                                                      const std::vector<std::array<double, 3>>& cotangents,
                                                      int* non_finite_faces) {
  std::vector<Triplet> trip;
  trip.reserve(faces.size() * 12);
  int bad = 0;
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const Triangle& t = faces[f];
    const std::array<double, 3>& c = cotangents[f];
    const bool finite = std::isfinite(c[0]) && std::isfinite(c[1]) && std::isfinite(c[2]);
    if (!finite) ++bad;
    for (int k = 0; k < 3; ++k) {
      const int i = t[static_cast<std::size_t>((k + 1) % 3)];
      const int j = t[static_cast<std::size_t>((k + 2) % 3)];
      const double w = finite ? 0.5 * c[static_cast<std::size_t>(k)] : 0.5;
      trip.emplace_back(i, j, -w);
      trip.emplace_back(j, i, -w);
      trip.emplace_back(i, i, w);
      trip.emplace_back(j, j, w);
    }
  }
  if (non_finite_faces) *non_finite_faces = bad;
  SpMat L(vertex_count, vertex_count);
  L.setFromTriplets(trip.begin(), trip.end());
  return L;
}

Eigen::SparseMatrix<double> cotan_laplacian(const std::vector<Point3>& vertices, const std::vector<Triangle>& faces,
                                            int* non_finite_faces) {
  return laplacian_from_cotangents(static_cast<int>(vertices.size()), faces, corner_cotangents(vertices, faces),
                                   non_finite_faces);
}

Eigen::SparseMatrix<double> uniform_laplacian(int vertex_count, const std::vector<Triangle>& faces) {
  // 1/2 per face and edge: 1 on every interior edge. (Boundary edges get 1/2, but they join two boundary
  // vertices, whose rows the maps never use: every edge at an interior vertex is interior.)
  std::vector<Triplet> trip;
  trip.reserve(faces.size() * 12);
  for (const Triangle& t : faces)
    for (int k = 0; k < 3; ++k) {
      const int i = t[static_cast<std::size_t>((k + 1) % 3)];
      const int j = t[static_cast<std::size_t>((k + 2) % 3)];
      trip.emplace_back(i, j, -0.5);
      trip.emplace_back(j, i, -0.5);
      trip.emplace_back(i, i, 0.5);
      trip.emplace_back(j, j, 0.5);
    }
  SpMat L(vertex_count, vertex_count);
  L.setFromTriplets(trip.begin(), trip.end());
  return L;
}

DiskMap map_to_disk_with_laplacian(const DiskMapInput& input, const Eigen::SparseMatrix<double>& laplacian,
                                   bool mean_value_fallback, const CancelToken* cancel) {
  const auto t_start = Clock::now();
  const Layout lay = make_layout(input);
  if (laplacian.rows() != lay.n || laplacian.cols() != lay.n)
    throw InternalError("map_to_disk_with_laplacian: the Laplacian is not vertex_count x vertex_count");
  return run(
      input, lay, [&](const std::vector<Point2>& uv) { return extract(laplacian, lay, uv); }, mean_value_fallback, 0.0,
      cancel, t_start);
}

DiskMap map_to_disk(const DiskMapInput& input, MapMethod method, const CancelToken* cancel) {
  const auto t_start = Clock::now();
  const Layout lay = make_layout(input);
  check_cancel(cancel);
  const std::vector<Triangle>& faces = *input.faces;
  if (method == MapMethod::tutte)
    return run(
        input, lay, [&](const std::vector<Point2>& uv) { return assemble_uniform(lay, faces, uv); }, false, 0.0,
        cancel, t_start);

  auto t0 = Clock::now();
  const std::vector<std::array<double, 3>> cot = corner_cotangents(*input.vertices, faces);
  int non_finite = 0;
  std::vector<char> finite(faces.size(), 1);
  for (std::size_t f = 0; f < faces.size(); ++f)
    if (!(std::isfinite(cot[f][0]) && std::isfinite(cot[f][1]) && std::isfinite(cot[f][2]))) {
      finite[f] = 0;
      ++non_finite;
    }
  const double assemble_ms = ms_since(t0);
  // The same weights as laplacian_from_cotangents: cot / 2 per face and edge, 1/2 for a non-finite face.
  DiskMap out = run(
      input, lay,
      [&](const std::vector<Point2>& uv) {
        return assemble_symmetric(lay, faces, uv, [&](std::size_t f, int k) {
          return finite[f] ? 0.5 * cot[f][static_cast<std::size_t>(k)] : 0.5;
        });
      },
      true, assemble_ms, cancel, t_start);
  out.numerically_degenerate_faces = non_finite;
  return out;
}

}  // namespace lipmap
