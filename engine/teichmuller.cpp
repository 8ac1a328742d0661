// h_s->i: an approximate Teichmuller map onto the convex domain (paper 5.3). See teichmuller.h.
#include "engine/teichmuller.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>

#include <Eigen/CholmodSupport>

#include "engine/error.h"
#include "engine/extremal_relax.h"
#include "engine/flip_check.h"

namespace lipmap {
namespace {

using Clock = std::chrono::steady_clock;
using SpMat = Eigen::SparseMatrix<double>;
using Complex = std::complex<double>;

// A face in its own isometric frame: corner 0 at the origin, corner 1 on the +x axis.
struct Frame {
  double q1x = 0, q2x = 0, q2y = 0;  // corner 1 = (q1x, 0), corner 2 = (q2x, q2y), q2y > 0
  double area = 0;
  bool ok = false;                   // finite and not flat
  std::array<Complex, 3> edge_dir;   // unit direction of edge (corner c -> c + 1) in this frame
};

Frame make_frame(const Point3& p0, const Point3& p1, const Point3& p2) {
  Frame f;
  const double e1[3] = {p1.x - p0.x, p1.y - p0.y, p1.z - p0.z};
  const double e2[3] = {p2.x - p0.x, p2.y - p0.y, p2.z - p0.z};
  const double l1 = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
  const double x = (e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]) / l1;
  const double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2], cz = e1[0] * e2[1] - e1[1] * e2[0];
  const double y = std::sqrt(cx * cx + cy * cy + cz * cz) / l1;
  f.q1x = l1;
  f.q2x = x;
  f.q2y = y;
  f.area = 0.5 * l1 * y;
  f.ok = std::isfinite(l1) && std::isfinite(x) && std::isfinite(y) && l1 > 0 && y > 0 && f.area > 0;
  if (f.ok) {
    const Complex q[3] = {{0, 0}, {l1, 0}, {x, y}};
    for (int c = 0; c < 3; ++c) {
      const Complex d = q[(c + 1) % 3] - q[c];
      f.edge_dir[static_cast<std::size_t>(c)] = d / std::abs(d);
    }
  }
  return f;
}

// Beltrami coefficient f_zbar / f_z of the affine map taking the frame's corners to a, b, c.
Complex beltrami(const Frame& fr, const Point2& a, const Point2& b, const Point2& c) {
  // J = [b - a, c - a] * Q^-1 with Q = [[q1x, q2x], [0, q2y]].
  const double du1 = b.x - a.x, dv1 = b.y - a.y, du2 = c.x - a.x, dv2 = c.y - a.y;
  const double ux = du1 / fr.q1x, vx = dv1 / fr.q1x;
  const double uy = (du2 - fr.q2x * ux) / fr.q2y, vy = (dv2 - fr.q2x * vx) / fr.q2y;
  const Complex fz(0.5 * (ux + vy), 0.5 * (vx - uy));
  const Complex fzbar(0.5 * (ux - vy), 0.5 * (vx + uy));
  if (std::abs(fz) == 0) return Complex(1, 0);
  return fzbar / fz;
}

double dilatation(const Complex& mu) {
  const double m = std::abs(mu);
  return m >= 1 ? std::numeric_limits<double>::infinity() : (1 + m) / (1 - m);
}

struct Layout {
  std::vector<int> row;       // vertex -> unknown row, -1 on the boundary
  std::vector<int> interior;  // row -> vertex
};

class BeltramiSolver {
public:
  BeltramiSolver(const DiskMapInput& in, const std::vector<Frame>& frames, const Layout& lay)
      : in_(in), frames_(frames), lay_(lay) {}

  // The map with Beltrami coefficient mu (per face, in the face's frame); false when the factorization fails.
  bool solve(const std::vector<Complex>& mu, std::vector<Point2>& uv) {
    const std::vector<Triangle>& faces = *in_.faces;
    const int m = static_cast<int>(lay_.interior.size());
    std::vector<Eigen::Triplet<double>> trip;
    trip.reserve(faces.size() * 9);
    Eigen::Matrix<double, Eigen::Dynamic, 2> b = Eigen::Matrix<double, Eigen::Dynamic, 2>::Zero(m, 2);
    for (std::size_t f = 0; f < faces.size(); ++f) {
      const Frame& fr = frames_[f];
      double S[3][3];
      if (fr.ok) {
        const double rho = mu[f].real(), tau = mu[f].imag(), d = 1 - rho * rho - tau * tau;
        const double a11 = ((rho - 1) * (rho - 1) + tau * tau) / d, a12 = -2 * tau / d,
                     a22 = ((1 + rho) * (1 + rho) + tau * tau) / d;
        // Gradients of the hat functions: the opposite edge turned a quarter, over twice the area.
        const double qx[3] = {0, fr.q1x, fr.q2x}, qy[3] = {0, 0, fr.q2y};
        double gx[3], gy[3];
        for (int c = 0; c < 3; ++c) {
          const int i = (c + 1) % 3, j = (c + 2) % 3;
          gx[c] = -(qy[j] - qy[i]) / (2 * fr.area);
          gy[c] = (qx[j] - qx[i]) / (2 * fr.area);
        }
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c)
            S[r][c] = fr.area * (gx[r] * (a11 * gx[c] + a12 * gy[c]) + gy[r] * (a12 * gx[c] + a22 * gy[c]));
      } else {
        // A numerically flat face: uniform weights 1/2 per edge, as the cotangent map does.
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) S[r][c] = r == c ? 1.0 : -0.5;
      }
      const Triangle& t = faces[f];
      for (int r = 0; r < 3; ++r) {
        const int rr = lay_.row[static_cast<std::size_t>(t[static_cast<std::size_t>(r)])];
        if (rr < 0) continue;
        for (int c = 0; c < 3; ++c) {
          const int vc = t[static_cast<std::size_t>(c)];
          const int rc = lay_.row[static_cast<std::size_t>(vc)];
          if (rc >= 0) {
            trip.emplace_back(rr, rc, S[r][c]);
          } else {
            b(rr, 0) -= S[r][c] * uv[static_cast<std::size_t>(vc)].x;
            b(rr, 1) -= S[r][c] * uv[static_cast<std::size_t>(vc)].y;
          }
        }
      }
    }
    SpMat A(m, m);
    A.setFromTriplets(trip.begin(), trip.end());  // same pattern every call: analysed once
    if (!analysed_) {
      llt_.cholmod().print = 0;
      llt_.analyzePattern(A);
      analysed_ = true;
    }
    llt_.factorize(A);
    ++factorizations;
    if (llt_.info() != Eigen::Success) return false;
    const Eigen::Matrix<double, Eigen::Dynamic, 2> X = llt_.solve(b);
    if (!X.allFinite()) return false;
    for (int i = 0; i < m; ++i) uv[static_cast<std::size_t>(lay_.interior[static_cast<std::size_t>(i)])] = {X(i, 0), X(i, 1)};
    return true;
  }

  int factorizations = 0;

private:
  const DiskMapInput& in_;
  const std::vector<Frame>& frames_;
  const Layout& lay_;
  Eigen::CholmodSupernodalLLT<SpMat, Eigen::Lower> llt_;
  bool analysed_ = false;
};

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

}  // namespace

TeichmullerMap teichmuller_map(const DiskMapInput& input, const MeshTopology& topology,
                               const TeichmullerOptions& options, const CancelToken* cancel) {
  const auto t0 = Clock::now();
  if (!input.boundary_positions) throw InternalError("teichmuller_map: the convex domain's boundary is not given");
  TeichmullerMap out;
  out.map = map_to_disk(input, MapMethod::harmonic, cancel);
  const std::vector<Triangle>& faces = *input.faces;
  const std::vector<Point3>& p = *input.vertices;
  const std::size_t nf = faces.size();

  std::vector<Frame> frames(nf);
  for (std::size_t f = 0; f < nf; ++f)
    frames[f] = make_frame(p[static_cast<std::size_t>(faces[f][0])], p[static_cast<std::size_t>(faces[f][1])],
                           p[static_cast<std::size_t>(faces[f][2])]);
  auto coefficients = [&](const std::vector<Point2>& uv) {
    std::vector<Complex> mu(nf, Complex(0, 0));
    for (std::size_t f = 0; f < nf; ++f)
      if (frames[f].ok)
        mu[f] = beltrami(frames[f], uv[static_cast<std::size_t>(faces[f][0])], uv[static_cast<std::size_t>(faces[f][1])],
                         uv[static_cast<std::size_t>(faces[f][2])]);
    return mu;
  };
  // Faces with three boundary corners have the same image in every map with this boundary, so they cannot
  // tell two iterates apart: where one of them is the worst face (often, next to a boundary corner), a max
  // over all faces would tie every iterate with the harmonic start and always keep the start.
  std::vector<char> on_loop(p.size(), 0);
  for (int v : *input.boundary_loop) on_loop[static_cast<std::size_t>(v)] = 1;
  auto max_dilatation = [&](const std::vector<Complex>& mu) {
    double m = 1;
    for (std::size_t f = 0; f < nf; ++f)
      if (frames[f].ok && !pinned_by_boundary(faces[f], on_loop)) m = std::max(m, dilatation(mu[f]));
    return m;
  };
  std::vector<Complex> mu = coefficients(out.map.uv);
  out.harmonic_max_dilatation = out.max_dilatation = max_dilatation(mu);
  if (options.max_iterations <= 0 || nf == 0) {
    out.ms = ms_since(t0);
    return out;
  }

  // The rotation carrying a neighbour's coefficient into face f's frame across f's edge c: the shared
  // edge's direction is d_f in f's frame and -d_g in g's, so frames differ by delta = arg(d_f / -d_g) and
  // mu_f = mu_g e^{2 i delta} = mu_g (d_f / d_g)^2.
  std::vector<std::array<Complex, 3>> carry(nf);
  for (std::size_t f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) {
      const int g = topology.across(static_cast<int>(f), c);
      carry[f][static_cast<std::size_t>(c)] = Complex(0, 0);
      if (g < 0 || !frames[f].ok || !frames[static_cast<std::size_t>(g)].ok) continue;
      const int o = topology.opposite(3 * static_cast<int>(f) + c) % 3;
      const Complex r = frames[f].edge_dir[static_cast<std::size_t>(c)] /
                        frames[static_cast<std::size_t>(g)].edge_dir[static_cast<std::size_t>(o)];
      carry[f][static_cast<std::size_t>(c)] = r * r;
    }

  Layout lay;
  lay.row.assign(p.size(), 0);
  for (int v : *input.boundary_loop) lay.row[static_cast<std::size_t>(v)] = -1;
  for (std::size_t v = 0; v < p.size(); ++v)
    if (lay.row[v] == 0) {
      lay.row[v] = static_cast<int>(lay.interior.size());
      lay.interior.push_back(static_cast<int>(v));
    }
  if (lay.interior.empty()) {
    out.ms = ms_since(t0);
    return out;
  }
  use_single_threaded_solvers();
  BeltramiSolver solver(input, frames, lay);
  std::vector<Point2> uv = out.map.uv;
  double area = 0;
  for (const Frame& fr : frames) area += fr.ok ? fr.area : 0;
  double previous_k = -1;
  for (int it = 1; it <= options.max_iterations; ++it) {
    check_cancel(cancel);
    // k: the area-weighted mean |mu| of the current map, before smoothing (smoothing shrinks the modulus
    // where arguments disagree).
    double k = 0;
    for (std::size_t f = 0; f < nf; ++f)
      if (frames[f].ok) k += frames[f].area * std::min(std::abs(mu[f]), options.max_k);
    k = area > 0 ? k / area : 0;
    for (int s = 0; s < options.smoothing_steps; ++s) {
      std::vector<Complex> next(nf);
      for (std::size_t f = 0; f < nf; ++f) {
        Complex sum = mu[f];
        double weight = 1;
        for (int c = 0; c < 3; ++c) {
          const int g = topology.across(static_cast<int>(f), c);
          if (g < 0 || carry[f][static_cast<std::size_t>(c)] == Complex(0, 0)) continue;
          sum += mu[static_cast<std::size_t>(g)] * carry[f][static_cast<std::size_t>(c)];
          weight += 1;
        }
        next[f] = sum / weight;
      }
      mu.swap(next);
    }
    for (std::size_t f = 0; f < nf; ++f) {
      const double m = std::abs(mu[f]);
      mu[f] = m > 0 ? mu[f] * (k / m) : Complex(0, 0);
    }
    if (!solver.solve(mu, uv)) break;
    ++out.iterations;
    out.k_history.push_back(k);
    mu = coefficients(uv);
    if (count_non_positive(uv, faces) == 0) {
      // The extremal map minimizes the largest dilatation: keep the flip-free iterate with the smallest.
      const double m = max_dilatation(mu);
      if (m < out.max_dilatation || out.map.flipped > 0) {
        out.map.uv = uv;
        out.map.flipped = 0;
        out.k = k;
        out.chosen_iteration = it;
        out.max_dilatation = m;
      }
    } else {
      ++out.folded_iterates;
    }
    if (previous_k >= 0 && std::fabs(k - previous_k) < options.tolerance) break;
    previous_k = k;
  }
  out.map.factorizations += solver.factorizations;
  out.ms = ms_since(t0);
  return out;
}

}  // namespace lipmap
