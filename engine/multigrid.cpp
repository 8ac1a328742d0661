// Smoothed-aggregation multigrid as a preconditioner of conjugate gradients. See engine/multigrid.h.
#include "engine/multigrid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <Eigen/CholmodSupport>

namespace lipmap {

namespace {

using Matrix = AggregationMultigrid::Matrix;
using Block = AggregationMultigrid::Block;

// Inside the solver the two right-hand sides are interleaved (x0 y0 x1 y1 ...): every gather of a neighbour
// then reads both from one cache line. At 500k unknowns the vectors no longer fit the caches and the cycles
// are bound by memory traffic.
using Pairs = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

// A level's operator (float values: the preconditioner only needs to be close to A's inverse, and 8 bytes an
// entry instead of 12 is less memory traffic) or transfer (double: scaled to the coarse unit diagonals, its
// entries may exceed float's range) in compressed columns.
template <class Value>
struct Compact {
  std::vector<int> outer, inner;
  std::vector<Value> value;
  Compact(std::vector<int> outer_, std::vector<int> inner_, std::vector<Value> value_)
      : outer(std::move(outer_)), inner(std::move(inner_)), value(std::move(value_)) {}
  explicit Compact(const Matrix& m = Matrix()) : outer(m.outerIndexPtr(), m.outerIndexPtr() + m.outerSize() + 1),
      inner(m.innerIndexPtr(), m.innerIndexPtr() + m.nonZeros()), value(m.valuePtr(), m.valuePtr() + m.nonZeros()) {
    if (m.outerSize() == 0) outer.assign(1, 0);
  }
  int columns() const { return static_cast<int>(outer.size()) - 1; }
  // s_c = sum_i M_ij in_i for column j, for both interleaved right-hand sides c.
  void column_times(int j, const double* in, double& s0, double& s1) const {
    s0 = 0;
    s1 = 0;
    for (int k = outer[static_cast<std::size_t>(j)]; k < outer[static_cast<std::size_t>(j) + 1]; ++k) {
      const double a = value[static_cast<std::size_t>(k)];
      const std::size_t i = 2 * static_cast<std::size_t>(inner[static_cast<std::size_t>(k)]);
      s0 += a * in[i];
      s1 += a * in[i + 1];
    }
  }
  // out_j (+)= sum_i M_ij in_i for each column j (a gather: M^T in), for both interleaved right-hand sides;
  // with dot (M square), also dot[c] += sum_j in_j out_j in the same pass (the conjugate gradients' p.Ap).
  void gather(const double* in, double* out, bool add, double* dot = nullptr) const {
    const int cols = columns();
    for (int j = 0; j < cols; ++j) {
      double s0, s1;
      column_times(j, in, s0, s1);
      if (add) {
        out[2 * j] += s0;
        out[2 * j + 1] += s1;
      } else {
        out[2 * j] = s0;
        out[2 * j + 1] = s1;
      }
      if (dot) {
        dot[0] += in[2 * j] * s0;
        dot[1] += in[2 * j + 1] * s1;
      }
    }
  }
};

// The M-matrix part of a symmetric A is never formed (at 500k unknowns a copy of A is 40 MB of fresh pages):
// its off-diagonal entries are A's negative ones, its diagonal is A's plus the column's positive off-diagonal
// entries (on a cotangent Laplacian, the negative weights of edges opposite obtuse angles), so that A's row
// sums are kept. The aggregates and the prolongation are built from it, the coarse operators from A itself: on
// a scanned 250k-triangle mesh the cycles needed drop from 39 (aggregating on |a_ij|) to 25.
Eigen::VectorXd m_matrix_diagonal(const Matrix& A) {
  Eigen::VectorXd out(A.cols());
  for (int c = 0; c < A.outerSize(); ++c) {
    double diagonal = 0, lumped = 0;
    for (Matrix::InnerIterator it(A, c); it; ++it) {
      if (it.row() == c) diagonal = it.value();
      else if (it.value() > 0) lumped += it.value();
    }
    out[c] = diagonal + lumped;
  }
  return out;
}

// A's entry as the M-matrix part (with diagonal m_diag) has it, or 0 where that part has no entry (a
// non-negative off-diagonal one): the loops below skip those.
double m_entry(const Matrix::InnerIterator& it, Eigen::Index column, const Eigen::VectorXd& m_diag) {
  if (it.row() == column) return m_diag[column];
  return it.value() < 0 ? it.value() : 0.0;
}

// Groups the unknowns into aggregates of strongly connected neighbours in A's M-matrix part (Vanek, Mandel &
// Brezina 1996, 3.1; j is strong for i when -m_ij >= theta sqrt(m_ii m_jj)): first whole neighbourhoods whose
// members are all free, then every leftover joins the aggregate of its strongest neighbour, then what is
// still left forms aggregates of its own. Returns the aggregate of each unknown.
std::vector<int> aggregate(const Matrix& A, const Eigen::VectorXd& m_diag, double theta, int& count) {
  const int n = static_cast<int>(A.rows());
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  const double* value = A.valuePtr();
  auto strong = [&](int i, int k) {
    const int j = inner[k];
    return j != i && value[k] < 0 && -value[k] >= theta * std::sqrt(m_diag[i] * m_diag[j]);
  };
  std::vector<int> agg(static_cast<std::size_t>(n), -1);
  count = 0;
  for (int i = 0; i < n; ++i) {
    if (agg[static_cast<std::size_t>(i)] != -1) continue;
    bool any = false, free = true;
    for (int k = outer[i]; k < outer[i + 1] && free; ++k)
      if (strong(i, k)) {
        any = true;
        free = agg[static_cast<std::size_t>(inner[k])] == -1;
      }
    if (!any || !free) continue;
    agg[static_cast<std::size_t>(i)] = count;
    for (int k = outer[i]; k < outer[i + 1]; ++k)
      if (strong(i, k)) agg[static_cast<std::size_t>(inner[k])] = count;
    ++count;
  }
  const std::vector<int> first = agg;  // leftovers join only aggregates of the first pass (no chains)
  for (int i = 0; i < n; ++i) {
    if (agg[static_cast<std::size_t>(i)] != -1) continue;
    double best = 0;
    for (int k = outer[i]; k < outer[i + 1]; ++k)
      if (strong(i, k) && first[static_cast<std::size_t>(inner[k])] != -1 && std::abs(value[k]) > best) {
        best = std::abs(value[k]);
        agg[static_cast<std::size_t>(i)] = first[static_cast<std::size_t>(inner[k])];
      }
  }
  for (int i = 0; i < n; ++i) {
    if (agg[static_cast<std::size_t>(i)] != -1) continue;
    agg[static_cast<std::size_t>(i)] = count;
    for (int k = outer[i]; k < outer[i + 1]; ++k) {
      int& other = agg[static_cast<std::size_t>(inner[k])];
      if (strong(i, k) && other == -1) other = count;
    }
    ++count;
  }
  return agg;
}

// Scales the symmetric m to a unit diagonal, m <- S m S with S = diag(m_ii^-1/2), and returns S; false (m
// untouched) when a diagonal entry is not positive and finite.
bool scale_to_unit_diagonal(Matrix& m, Eigen::VectorXd& scale) {
  const Eigen::VectorXd diag = m.diagonal();
  if (!(diag.array() > 0).all() || !diag.allFinite()) return false;
  scale = diag.cwiseSqrt().cwiseInverse();
  for (int c = 0; c < m.outerSize(); ++c)
    for (Matrix::InnerIterator it(m, c); it; ++it) it.valueRef() *= scale[it.row()] * scale[c];
  return true;
}

// Cuthill-McKee order of A's graph (breadth first from each component's first unknown, neighbours in
// index order): unknowns that are neighbours get near indices, so the gathers of a sweep stay in cache and
// aggregates (formed in index order) are compact.
std::vector<int> breadth_first_order(const Matrix& A) {
  const int n = static_cast<int>(A.cols());
  std::vector<int> order;
  order.reserve(static_cast<std::size_t>(n));
  std::vector<char> seen(static_cast<std::size_t>(n), 0);
  for (int root = 0; root < n; ++root) {
    if (seen[static_cast<std::size_t>(root)]) continue;
    seen[static_cast<std::size_t>(root)] = 1;
    order.push_back(root);
    for (std::size_t head = order.size() - 1; head < order.size(); ++head)
      for (Matrix::InnerIterator it(A, order[head]); it; ++it)
        if (!seen[static_cast<std::size_t>(it.row())]) {
          seen[static_cast<std::size_t>(it.row())] = 1;
          order.push_back(static_cast<int>(it.row()));
        }
  }
  return order;
}

// B = A with rows and columns renumbered: B(k, l) = A(order[k], order[l]), both triangles stored and each
// column's rows sorted (the sweeps look the diagonal up by binary search).
Matrix permuted(const Matrix& A, const std::vector<int>& order) {
  const int n = static_cast<int>(A.cols());
  std::vector<int> position(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) position[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])] = k;
  Matrix B(n, n);
  B.resizeNonZeros(A.nonZeros());
  int* outer = B.outerIndexPtr();
  int* inner = B.innerIndexPtr();
  double* value = B.valuePtr();
  std::vector<std::pair<int, double>> column;
  outer[0] = 0;
  for (int k = 0; k < n; ++k) {
    column.clear();
    for (Matrix::InnerIterator it(A, order[static_cast<std::size_t>(k)]); it; ++it)
      column.emplace_back(position[static_cast<std::size_t>(it.row())], it.value());
    std::sort(column.begin(), column.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    int at = outer[k];
    for (const auto& [row, v] : column) {
      inner[at] = row;
      value[at] = v;
      ++at;
    }
    outer[k + 1] = at;
  }
  return B;
}

// A compressed column-major matrix from its arrays (rows sorted within each column).
Matrix compressed(int rows, int cols, const std::vector<int>& outer, const std::vector<int>& inner,
                  const std::vector<double>& value) {
  Matrix out(rows, cols);
  out.resizeNonZeros(static_cast<Eigen::Index>(inner.size()));
  std::copy(outer.begin(), outer.end(), out.outerIndexPtr());
  std::copy(inner.begin(), inner.end(), out.innerIndexPtr());
  std::copy(value.begin(), value.end(), out.valuePtr());
  return out;
}

// R = P^T (count x n, by columns) for the smoothed prolongation P = (I - omega D^-1 M) P0 of A's M-matrix part
// M (diagonal m_diag = D), P0(i, agg[i]) = tentative[i]: column i of R is row i of P, which has tentative[i]
// (1 - omega m_ii / m_ii) at i's own aggregate and -omega m_ij / m_ii tentative[j] at the aggregate of each
// neighbour j.
Compact<double> smoothed_restriction(const Matrix& A, const Eigen::VectorXd& m_diag, const std::vector<int>& agg,
                                     const Eigen::VectorXd& tentative, double omega) {
  const int n = static_cast<int>(A.rows());
  std::vector<int> outer(static_cast<std::size_t>(n) + 1, 0);
  std::vector<int> inner;
  std::vector<double> value;
  inner.reserve(static_cast<std::size_t>(A.nonZeros()));  // at most one entry per entry of M (diagonal included)
  value.reserve(static_cast<std::size_t>(A.nonZeros()));
  std::vector<std::pair<int, double>> row;
  for (int i = 0; i < n; ++i) {
    row.clear();
    row.emplace_back(agg[static_cast<std::size_t>(i)], tentative[i]);
    const double inv_diag = 1.0 / m_diag[i];
    for (Matrix::InnerIterator it(A, i); it; ++it) {
      const double m = m_entry(it, i, m_diag);
      if (m == 0.0) continue;
      const auto j = it.row();
      row.emplace_back(agg[static_cast<std::size_t>(j)], -omega * m * inv_diag * tentative[j]);
    }
    std::sort(row.begin(), row.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (std::size_t k = 0; k < row.size();) {
      double sum = 0;
      const int a = row[k].first;
      for (; k < row.size() && row[k].first == a; ++k) sum += row[k].second;
      inner.push_back(a);
      value.push_back(sum);
    }
    outer[static_cast<std::size_t>(i) + 1] = static_cast<int>(inner.size());
  }
  return Compact<double>(std::move(outer), std::move(inner), std::move(value));
}

// The transpose (by columns, rows sorted) of X, which has `rows` rows: a counting sort by row.
Compact<double> transposed(const Compact<double>& X, int rows) {
  std::vector<int> outer(static_cast<std::size_t>(rows) + 1, 0);
  for (int r : X.inner) ++outer[static_cast<std::size_t>(r) + 1];
  for (std::size_t r = 0; r < static_cast<std::size_t>(rows); ++r) outer[r + 1] += outer[r];
  std::vector<int> next(outer.begin(), outer.end() - 1);
  std::vector<int> inner(X.inner.size());
  std::vector<double> value(X.value.size());
  for (int c = 0; c < X.columns(); ++c)
    for (int k = X.outer[static_cast<std::size_t>(c)]; k < X.outer[static_cast<std::size_t>(c) + 1]; ++k) {
      const int at = next[static_cast<std::size_t>(X.inner[static_cast<std::size_t>(k)])]++;
      inner[static_cast<std::size_t>(at)] = c;
      value[static_cast<std::size_t>(at)] = X.value[static_cast<std::size_t>(k)];
    }
  return Compact<double>(std::move(outer), std::move(inner), std::move(value));
}

// The Galerkin operator P^T A P from P (n x count, by columns) and R = P^T (by columns). Column j of A P is
// gathered in a dense accumulator over the fine unknowns (Gustavson's row merge: linear in the flops, where a
// product that sorts or masks whole columns is not), then R is applied to its entries (in the order they were
// first touched: sorting them cost a fifth of the product) into a second accumulator over the aggregates. A P,
// the largest product, is never stored.
Matrix galerkin_product(const Matrix& A, const Compact<double>& P, const Compact<double>& R) {
  const int n = static_cast<int>(A.rows()), count = P.columns();
  std::vector<double> fine(static_cast<std::size_t>(n), 0.0), coarse(static_cast<std::size_t>(count), 0.0);
  std::vector<int> fine_at(static_cast<std::size_t>(n), -1), coarse_at(static_cast<std::size_t>(count), -1);
  std::vector<int> fine_touched, coarse_touched;
  std::vector<int> outer(static_cast<std::size_t>(count) + 1, 0);
  std::vector<int> inner;
  std::vector<double> value;
  for (int j = 0; j < count; ++j) {
    fine_touched.clear();
    for (int k = P.outer[static_cast<std::size_t>(j)]; k < P.outer[static_cast<std::size_t>(j) + 1]; ++k) {
      const double p = P.value[static_cast<std::size_t>(k)];
      for (Matrix::InnerIterator x(A, P.inner[static_cast<std::size_t>(k)]); x; ++x) {
        const auto r = static_cast<std::size_t>(x.row());
        if (fine_at[r] != j) {
          fine_at[r] = j;
          fine[r] = 0.0;
          fine_touched.push_back(static_cast<int>(r));
        }
        fine[r] += x.value() * p;
      }
    }
    coarse_touched.clear();
    for (int r : fine_touched) {
      const double ap = fine[static_cast<std::size_t>(r)];
      for (int k = R.outer[static_cast<std::size_t>(r)]; k < R.outer[static_cast<std::size_t>(r) + 1]; ++k) {
        const auto c = static_cast<std::size_t>(R.inner[static_cast<std::size_t>(k)]);
        if (coarse_at[c] != j) {
          coarse_at[c] = j;
          coarse[c] = 0.0;
          coarse_touched.push_back(static_cast<int>(c));
        }
        coarse[c] += R.value[static_cast<std::size_t>(k)] * ap;
      }
    }
    std::sort(coarse_touched.begin(), coarse_touched.end());
    for (int c : coarse_touched) {
      inner.push_back(c);
      value.push_back(coarse[static_cast<std::size_t>(c)]);
    }
    outer[static_cast<std::size_t>(j) + 1] = static_cast<int>(inner.size());
  }
  return compressed(count, count, outer, inner, value);
}

// c_ij = c_ji = (c_ij + c_ji) / 2 in place, for C with a symmetric pattern and each column's rows sorted: the
// two triangles of a Galerkin product are summed in different orders, and its float copy must be exactly
// symmetric. False when an entry has no mirror (P^T A P of a symmetric A always has one: compute() then
// refuses the matrix rather than go on with a broken operator).
bool symmetrize(Matrix& C) {
  const int* outer = C.outerIndexPtr();
  const int* inner = C.innerIndexPtr();
  double* value = C.valuePtr();
  for (int c = 0; c < C.outerSize(); ++c)
    for (int k = outer[c]; k < outer[c + 1]; ++k) {
      const int r = inner[k];
      if (r <= c) continue;
      const int* mirror = std::lower_bound(inner + outer[r], inner + outer[r + 1], c);
      if (mirror == inner + outer[r + 1] || *mirror != c) return false;
      const double mean = 0.5 * (value[k] + value[mirror - inner]);
      value[k] = mean;
      value[mirror - inner] = mean;
    }
  return true;
}

}  // namespace

template <class Value>
std::vector<int> diagonal_positions(const Compact<Value>& A) {
  std::vector<int> out(static_cast<std::size_t>(A.columns()));
  for (int c = 0; c < A.columns(); ++c) {
    const auto b = A.inner.begin() + A.outer[static_cast<std::size_t>(c)];
    const auto e = A.inner.begin() + A.outer[static_cast<std::size_t>(c) + 1];
    out[static_cast<std::size_t>(c)] = static_cast<int>(std::lower_bound(b, e, c) - A.inner.begin());
  }
  return out;
}

// The right-hand side of a level's sweeps: the level's own vector, or at the finest level S r scaled as it is
// read (the cycle works on S A S; a separate scaled copy of r would be one more pass over two vectors a cycle).
struct RightHandSide {
  const double* b;
  const double* scale = nullptr;  // when set, entry (i, c) is scale[i] b[2i + c]
  double at(int i, int c) const {
    const double v = b[2 * static_cast<std::size_t>(i) + static_cast<std::size_t>(c)];
    return scale ? scale[i] * v : v;
  }
};

struct AggregationMultigrid::Hierarchy {
  struct Level {
    Compact<float> A;           // this level's operator (full symmetric pattern: column i is row i)
    std::vector<int> diagonal;  // where each column's diagonal entry is (its rows are sorted)
    std::vector<double> inv_diag;
    Compact<double> R;          // P^T by columns, i.e. the prolongation P (to this level from the next) by rows
    mutable Pairs x, b;         // scratch of one V-cycle: the next level's right-hand side and answer
    int size() const { return A.columns(); }
  };
  std::vector<int> order;       // unknown k of the levels is unknown order[k] of the system
  Eigen::VectorXd scale;        // S: the levels are built for S A S (in the levels' order)
  Compact<double> finest;       // the system itself (reordered), in double, for the conjugate gradients
  std::vector<Level> levels;    // levels.back() is factored
  Eigen::CholmodSupernodalLLT<Matrix, Eigen::Lower> coarse;

  // x_i += (b_i - (A x)_i) / a_ii for row i, using the columns of the symmetric A as its rows.
  static void relax_row(const Level& l, const RightHandSide& b, double* xv, int i) {
    const int* inner = l.A.inner.data();
    const float* value = l.A.value.data();
    double r0 = b.at(i, 0), r1 = b.at(i, 1);
    for (int k = l.A.outer[static_cast<std::size_t>(i)]; k < l.A.outer[static_cast<std::size_t>(i) + 1]; ++k) {
      r0 -= value[k] * xv[2 * inner[k]];
      r1 -= value[k] * xv[2 * inner[k] + 1];
    }
    xv[2 * i] += r0 * l.inv_diag[static_cast<std::size_t>(i)];
    xv[2 * i + 1] += r1 * l.inv_diag[static_cast<std::size_t>(i)];
  }

  // One forward Gauss-Seidel sweep on A x = b, in place. From x = 0 it needs only the entries above the
  // diagonal of each column (j < i; the rest multiply zeros): half the traffic.
  static void forward_sweep(const Level& l, const RightHandSide& b, Pairs& x, bool from_zero) {
    const int n = l.size();
    double* xv = x.data();
    if (!from_zero) {
      for (int i = 0; i < n; ++i) relax_row(l, b, xv, i);
      return;
    }
    const int* inner = l.A.inner.data();
    const float* value = l.A.value.data();
    for (int i = 0; i < n; ++i) {
      double r0 = b.at(i, 0), r1 = b.at(i, 1);
      for (int k = l.A.outer[static_cast<std::size_t>(i)]; k < l.diagonal[static_cast<std::size_t>(i)]; ++k) {
        r0 -= value[k] * xv[2 * inner[k]];
        r1 -= value[k] * xv[2 * inner[k] + 1];
      }
      xv[2 * i] = r0 * l.inv_diag[static_cast<std::size_t>(i)];
      xv[2 * i + 1] = r1 * l.inv_diag[static_cast<std::size_t>(i)];
    }
  }

  // One backward Gauss-Seidel sweep, in place. With `coarse`, the coarse correction P x_c is added to each row
  // of x first, just before the sweep reads that row (row i reads rows from its first column on): the two go
  // down together and the rows prolonged are still in cache when the sweep reads them, where a separate pass
  // would read and write x once more. With `dot` (the finest level, b read scaled), dot[c] += sum_i
  // b_ic (S x)_ic, the conjugate gradients' r.z, taken as each row is final.
  static void backward_sweep(const Level& l, const RightHandSide& b, Pairs& x, const double* coarse, double* dot) {
    const int n = l.size();
    const int* outer = l.A.outer.data();
    const int* inner = l.A.inner.data();
    double* xv = x.data();
    int prolonged = n;  // rows >= prolonged have had P x_c added
    for (int i = n - 1; i >= 0; --i) {
      if (coarse) {
        const int first = outer[i] < outer[i + 1] ? std::min(i, inner[outer[i]]) : i;
        while (prolonged > first) {
          --prolonged;
          double s0, s1;
          l.R.column_times(prolonged, coarse, s0, s1);
          xv[2 * prolonged] += s0;
          xv[2 * prolonged + 1] += s1;
        }
      }
      relax_row(l, b, xv, i);
      if (dot) {
        dot[0] += b.b[2 * i] * (b.scale[i] * xv[2 * i]);
        dot[1] += b.b[2 * i + 1] * (b.scale[i] * xv[2 * i + 1]);
      }
    }
  }

  // z = V-cycle(b) on level k, from z = 0. Symmetric (forward sweeps before, backward after), so it is a
  // valid preconditioner for conjugate gradients. `dot` as in backward_sweep (level 0 of a hierarchy with more
  // than one level, b read scaled).
  void cycle(std::size_t k, const RightHandSide& b, Pairs& z, int sweeps, double* dot = nullptr) const {
    const Level& l = levels[k];
    const int n = l.size();
    if (k + 1 == levels.size()) {
      if (b.scale) {  // a one-level hierarchy: its factor solves S A S
        Pairs scaled(n, 2);
        for (int i = 0; i < n; ++i) scaled.row(i) << b.at(i, 0), b.at(i, 1);
        z = coarse.solve(scaled);
      } else {
        z = coarse.solve(Eigen::Map<const Pairs>(b.b, n, 2));
      }
      return;
    }
    const Level& next = levels[k + 1];
    z.resize(n, 2);
    for (int s = 0; s < sweeps; ++s) forward_sweep(l, b, z, s == 0);
    // The residual, restricted as each row of it is formed (next.b = P^T r, scattered through P's rows: the
    // coarse vector is small enough to stay in cache, and r itself is never stored).
    next.b.setZero(next.size(), 2);
    double* nb = next.b.data();
    const int* outer = l.A.outer.data();
    const int* inner = l.A.inner.data();
    const float* value = l.A.value.data();
    const double* zv = z.data();
    for (int i = 0; i < n; ++i) {
      double r0 = 0, r1 = 0;
      if (sweeps == 1) {
        // After one forward sweep from zero, b_i - sum_{j <= i} a_ij z_j = 0 for every i: the residual is
        // -sum_{j > i} a_ij z_j, half a pass over A instead of a whole one.
        for (int q = l.diagonal[static_cast<std::size_t>(i)] + 1; q < outer[i + 1]; ++q) {
          r0 -= value[q] * zv[2 * inner[q]];
          r1 -= value[q] * zv[2 * inner[q] + 1];
        }
      } else {
        double s0, s1;
        l.A.column_times(i, zv, s0, s1);  // (A z)_i: A is symmetric
        r0 = b.at(i, 0) - s0;
        r1 = b.at(i, 1) - s1;
      }
      for (int q = l.R.outer[static_cast<std::size_t>(i)]; q < l.R.outer[static_cast<std::size_t>(i) + 1]; ++q) {
        const double a = l.R.value[static_cast<std::size_t>(q)];
        const std::size_t c = 2 * static_cast<std::size_t>(l.R.inner[static_cast<std::size_t>(q)]);
        nb[c] += a * r0;
        nb[c + 1] += a * r1;
      }
    }
    cycle(k + 1, RightHandSide{next.b.data()}, next.x, sweeps);
    for (int s = 0; s < sweeps; ++s)
      backward_sweep(l, b, z, s == 0 ? next.x.data() : nullptr, s + 1 == sweeps ? dot : nullptr);
  }

  // A block of the system's unknowns in the levels' order, and back.
  Pairs in_level_order(const Block& b) const {
    Pairs out(b.rows(), 2);
    for (Eigen::Index k = 0; k < b.rows(); ++k) out.row(k) = b.row(order[static_cast<std::size_t>(k)]);
    return out;
  }
  Block in_input_order(const Pairs& x) const {
    Block out(x.rows(), 2);
    for (Eigen::Index k = 0; k < x.rows(); ++k) out.row(order[static_cast<std::size_t>(k)]) = x.row(k);
    return out;
  }

  // z = S V(S r): the V-cycle of S A S, an approximation of A^-1 (exact with one level: the factor's solve).
  void precondition(const Pairs& r, Pairs& z, int sweeps) const {
    cycle(0, RightHandSide{r.data(), scale.data()}, z, sweeps);
    for (Eigen::Index i = 0; i < z.rows(); ++i) z.row(i) *= scale[i];
  }
};

AggregationMultigrid::AggregationMultigrid(MultigridSettings settings) : settings_(settings) {
  settings_.smoothing_sweeps = std::max(1, settings_.smoothing_sweeps);  // none: P B_c P^T alone is singular
}
AggregationMultigrid::~AggregationMultigrid() = default;

bool AggregationMultigrid::compute(const Matrix& A) {
  hierarchy_ = std::make_unique<Hierarchy>();
  stats_ = MultigridStats{};
  Hierarchy& h = *hierarchy_;
  h.order = breadth_first_order(A);
  Matrix current = permuted(A, h.order);
  h.finest = Compact<double>(current);
  Eigen::VectorXd near_null;  // the level's near null space (a Laplacian's constants), P0's values
  // The hierarchy is built for S A S with S = diag(a_ii^-1/2): unit diagonal, off-diagonal entries within
  // [-1, 1] (A is SPD), so that its float copies neither overflow nor lose a row to underflow whatever A's
  // range (the optimizer's powered-mips weights span 1e+-80 and more); the cycle is scaled back (precondition).
  near_null = current.diagonal().cwiseSqrt();  // A's constant vector in the scaled unknowns: S^-1 1
  if (!scale_to_unit_diagonal(current, h.scale)) return false;
  for (;;) {  // every level has a unit diagonal (up to rounding) here
    const int n = static_cast<int>(current.rows());
    stats_.operator_nonzeros += current.nonZeros();
    const Eigen::VectorXd diag = current.diagonal();
    h.levels.emplace_back();
    Hierarchy::Level& l = h.levels.back();
    // The inverse of the diagonal as the sweeps see it, in float like the rest of the level's matrix: with the
    // double diagonal the forward and backward sweeps would not be each other's adjoints (u.Mv - v.Mu ~ 3e-8).
    l.inv_diag.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i)
      l.inv_diag[static_cast<std::size_t>(i)] = 1.0 / static_cast<double>(static_cast<float>(diag[i]));
    if (n <= settings_.coarse_size || h.levels.size() >= 25) break;

    const Eigen::VectorXd m_diag = m_matrix_diagonal(current);
    int count = 0;
    const std::vector<int> agg = aggregate(current, m_diag, settings_.strength, count);
    if (count >= n - n / 8) break;  // aggregation no longer coarsens: factor this level
    // Smoothed prolongation P = (I - omega D^-1 M) P0 (P0: 1 where unknown i is in aggregate j) with omega =
    // 4 / (3 rho(D^-1 M)); rho is bounded by Gershgorin's circles (an upper bound: a smaller, safe omega).
    double rho = 0;
    for (int c = 0; c < n; ++c) {
      double row = 0;
      for (Matrix::InnerIterator it(current, c); it; ++it) row += std::abs(m_entry(it, c, m_diag));
      rho = std::max(rho, row / m_diag[c]);
    }
    // The tentative prolongation holds the near null vector on each aggregate, normalized (Vanek et al. 3.2);
    // the coarse level's near null vector is then the aggregates' norms.
    Eigen::VectorXd norm = Eigen::VectorXd::Zero(count);
    for (int i = 0; i < n; ++i) norm[agg[static_cast<std::size_t>(i)]] += near_null[i] * near_null[i];
    norm = norm.cwiseSqrt();
    Eigen::VectorXd tentative(n);
    for (int i = 0; i < n; ++i) tentative[i] = near_null[i] / norm[agg[static_cast<std::size_t>(i)]];
    Compact<double> R = smoothed_restriction(current, m_diag, agg, tentative, 4.0 / (3.0 * rho));
    Matrix coarse = galerkin_product(current, transposed(R, count), R);  // P itself is not kept
    if (!symmetrize(coarse)) return false;
    // Scaled to a unit diagonal as the finest level is (S_c P^T A P S_c with P's columns scaled by S_c): an
    // aggregate joined to the rest by tiny weights only has a tiny diagonal entry, which float would lose.
    Eigen::VectorXd coarse_scale;
    if (!scale_to_unit_diagonal(coarse, coarse_scale)) return false;
    for (std::size_t k = 0; k < R.inner.size(); ++k) R.value[k] *= coarse_scale[R.inner[k]];
    near_null = norm.cwiseQuotient(coarse_scale);  // in the coarse level's scaled unknowns
    l.A = Compact<float>(current);
    l.diagonal = diagonal_positions(l.A);
    l.R = std::move(R);
    current = std::move(coarse);
  }
  stats_.levels = static_cast<int>(h.levels.size());
  h.levels.back().A = Compact<float>(current);
  h.coarse.cholmod().print = 0;
  h.coarse.compute(current);
  return h.coarse.info() == Eigen::Success;
}

AggregationMultigrid::Block AggregationMultigrid::cycle(const Block& b_in) const {
  const Hierarchy& h = *hierarchy_;
  Pairs z;
  h.precondition(h.in_level_order(b_in), z, settings_.smoothing_sweeps);
  return h.in_input_order(z);
}

AggregationMultigrid::Block AggregationMultigrid::solve(const Block& b_in, const CancelToken* cancel) const {
  const Hierarchy& h = *hierarchy_;
  const Eigen::Index n = b_in.rows();
  stats_.iterations = 0;
  stats_.relative_residual = 0;
  if (!b_in.allFinite()) return Block::Constant(n, 2, std::numeric_limits<double>::quiet_NaN());
  const Eigen::Array2d bnorm = b_in.colwise().stableNorm().transpose().array();
  Pairs r = h.in_level_order(b_in), z(n, 2), q(n, 2);
  if (h.levels.size() == 1) {  // small enough to factor whole
    h.precondition(r, z, settings_.smoothing_sweeps);
    return h.in_input_order(z);
  }
  Pairs x = Pairs::Zero(n, 2);
  Eigen::Array2d active(bnorm(0) > 0 ? 1.0 : 0.0, bnorm(1) > 0 ? 1.0 : 0.0);
  if ((active == 0).all()) return Block::Zero(n, 2);
  // z holds V(S r) unscaled: the preconditioned residual is S z, formed where it is used (p's update), and
  // r.(S z) is summed by the cycle's last sweep, as each row of z is final. Each saves a pass over the vectors.
  const double* sv = h.scale.data();
  Eigen::Array2d rz = Eigen::Array2d::Zero();
  h.cycle(0, RightHandSide{r.data(), sv}, z, settings_.smoothing_sweeps, rz.data());
  Pairs p = Pairs::Zero(n, 2);
  const auto update_direction = [&](const Eigen::Array2d& beta) {  // p = S z + beta p, one pass
    double* pv = p.data();
    const double* zv = z.data();
    for (Eigen::Index i = 0; i < n; ++i) {
      pv[2 * i] = sv[i] * zv[2 * i] + beta(0) * pv[2 * i];
      pv[2 * i + 1] = sv[i] * zv[2 * i + 1] + beta(1) * pv[2 * i + 1];
    }
  };
  update_direction(Eigen::Array2d::Zero());
  Eigen::Array2d relative(1.0, 1.0);
  std::vector<Eigen::Array2d> history;  // relative residuals, to stop a column that no longer converges
  for (int it = 0; it < settings_.max_iterations; ++it) {
    check_cancel(cancel);
    // The vector work of an iteration is fused into two passes (at 500k unknowns each pass over a vector
    // is memory traffic): q = A p with p.q, then x += alpha p, r -= alpha q with |r|^2.
    Eigen::Array2d pq = Eigen::Array2d::Zero();
    h.finest.gather(p.data(), q.data(), false, pq.data());
    Eigen::Array2d alpha = Eigen::Array2d::Zero();
    for (int c = 0; c < 2; ++c)
      if (active(c) > 0 && pq(c) > 0 && std::isfinite(pq(c))) alpha(c) = rz(c) / pq(c);
    Eigen::Array2d rnorm = Eigen::Array2d::Zero();
    {
      const double* pv = p.data();
      const double* qv = q.data();
      double* xv = x.data();
      double* rv = r.data();
      for (Eigen::Index i = 0; i < 2 * n; i += 2) {
        xv[i] += alpha(0) * pv[i];
        xv[i + 1] += alpha(1) * pv[i + 1];
        rv[i] -= alpha(0) * qv[i];
        rv[i + 1] -= alpha(1) * qv[i + 1];
        rnorm(0) += rv[i] * rv[i];
        rnorm(1) += rv[i + 1] * rv[i + 1];
      }
    }
    rnorm = rnorm.sqrt();
    ++stats_.iterations;
    for (int c = 0; c < 2; ++c) {
      if (active(c) == 0) continue;
      relative(c) = rnorm(c) / bnorm(c);
      // Converged; or no longer a descent (pq not positive: the iterate is as good as it gets); or stalled:
      // not 10x lower than kStall iterations ago (a healthy solve gains that in 2 or 3).
      constexpr int kStall = 40;
      const bool stalled = it >= kStall && relative(c) > 0.1 * history[static_cast<std::size_t>(it - kStall)](c);
      if (relative(c) <= settings_.tolerance || alpha(c) == 0 || stalled) active(c) = 0;
    }
    history.push_back(relative);
    if ((active == 0).all()) break;
    Eigen::Array2d rz_next = Eigen::Array2d::Zero();
    h.cycle(0, RightHandSide{r.data(), sv}, z, settings_.smoothing_sweeps, rz_next.data());
    Eigen::Array2d beta = Eigen::Array2d::Zero();
    for (int c = 0; c < 2; ++c)
      if (active(c) > 0 && rz(c) != 0) beta(c) = rz_next(c) / rz(c);
    update_direction(beta);
    rz = rz_next;
  }
  for (int c = 0; c < 2; ++c)
    if (bnorm(c) > 0) stats_.relative_residual = std::max(stats_.relative_residual, relative(c));
  return h.in_input_order(x);
}

}  // namespace lipmap
