// h_t->i onto a convex domain with prescribed boundary curvature (paper 5.3). See convex_domain.h.
#include "engine/convex_domain.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/CholmodSupport>
#include <Eigen/Dense>

#include "engine/error.h"
#include "engine/flip_check.h"

namespace lipmap {
namespace {

using SpMat = Eigen::SparseMatrix<double>;

// Angle sum at every vertex (corner angles from the 3D positions, atan2 of |e1 x e2| and e1 . e2).
std::vector<double> angle_sums(const std::vector<Point3>& p, const std::vector<Triangle>& faces) {
  std::vector<double> sum(p.size(), 0.0);
  for (const Triangle& t : faces)
    for (int k = 0; k < 3; ++k) {
      const Point3& o = p[static_cast<std::size_t>(t[static_cast<std::size_t>(k)])];
      const Point3& a = p[static_cast<std::size_t>(t[static_cast<std::size_t>((k + 1) % 3)])];
      const Point3& b = p[static_cast<std::size_t>(t[static_cast<std::size_t>((k + 2) % 3)])];
      const double e1x = a.x - o.x, e1y = a.y - o.y, e1z = a.z - o.z;
      const double e2x = b.x - o.x, e2y = b.y - o.y, e2z = b.z - o.z;
      const double cx = e1y * e2z - e1z * e2y, cy = e1z * e2x - e1x * e2z, cz = e1x * e2y - e1y * e2x;
      sum[static_cast<std::size_t>(t[static_cast<std::size_t>(k)])] +=
          std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), e1x * e2x + e1y * e2y + e1z * e2z);
    }
  return sum;
}

double length(const Point3& a, const Point3& b) { return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z)); }

// Log scale factors u of the conformal change with flat interior and boundary turning `target` (step 3).
// Empty when the solve fails.
Eigen::VectorXd scale_factors(const DiskMapInput& in, const std::vector<double>& sums,
                              const std::vector<double>& target, const CancelToken* cancel) {
  const std::vector<int>& loop = *in.boundary_loop;
  const int n = static_cast<int>(in.vertices->size());
  const SpMat L = cotan_laplacian(*in.vertices, *in.faces);
  Eigen::VectorXd rhs(n);
  std::vector<char> on_boundary(static_cast<std::size_t>(n), 0);
  for (int v : loop) on_boundary[static_cast<std::size_t>(v)] = 1;
  for (int v = 0; v < n; ++v) rhs(v) = on_boundary[static_cast<std::size_t>(v)] ? 0.0 : -(2 * M_PI - sums[static_cast<std::size_t>(v)]);
  for (std::size_t k = 0; k < loop.size(); ++k) {
    const int v = loop[k];
    rhs(v) = target[k] - (M_PI - sums[static_cast<std::size_t>(v)]);
  }
  // Gauge: u = 0 at loop[0]; its row is dropped (the system is consistent up to rounding).
  const int fixed = loop[0];
  std::vector<int> row(static_cast<std::size_t>(n));
  for (int v = 0, r = 0; v < n; ++v) row[static_cast<std::size_t>(v)] = v == fixed ? -1 : r++;
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(static_cast<std::size_t>(L.nonZeros()));
  for (int c = 0; c < L.outerSize(); ++c)
    for (SpMat::InnerIterator it(L, c); it; ++it) {
      const int rr = row[static_cast<std::size_t>(it.row())], rc = row[static_cast<std::size_t>(c)];
      if (rr >= 0 && rc >= 0) trip.emplace_back(rr, rc, it.value());
    }
  SpMat A(n - 1, n - 1);
  A.setFromTriplets(trip.begin(), trip.end());
  Eigen::VectorXd b(n - 1);
  for (int v = 0; v < n; ++v)
    if (row[static_cast<std::size_t>(v)] >= 0) b(row[static_cast<std::size_t>(v)]) = rhs(v);
  check_cancel(cancel);
  use_single_threaded_solvers();
  Eigen::CholmodSupernodalLLT<SpMat, Eigen::Lower> llt;
  llt.cholmod().print = 0;
  llt.compute(A);
  if (llt.info() != Eigen::Success) return {};
  const Eigen::VectorXd x = llt.solve(b);
  if (!x.allFinite()) return {};
  Eigen::VectorXd u(n);
  for (int v = 0; v < n; ++v) u(v) = row[static_cast<std::size_t>(v)] < 0 ? 0.0 : x(row[static_cast<std::size_t>(v)]);
  return u;
}

// The closed boundary polygon from scaled lengths and turning angles (step 4); empty with a reason when the
// closing would make a length non-positive or the result is not strictly convex.
std::vector<Point2> closed_curve(const std::vector<double>& lengths, const std::vector<double>& turning,
                                 double& closing_change, std::string& why) {
  const std::size_t n = lengths.size();
  std::vector<double> tx(n), ty(n);
  double phi = 0;
  for (std::size_t j = 0; j < n; ++j) {
    if (j > 0) phi += turning[j];  // edge j leaves vertex j, after the turn there
    tx[j] = std::cos(phi);
    ty[j] = std::sin(phi);
  }
  // min sum (l*_j - l_j)^2 / l_j subject to sum l*_j T_j = 0: l* = l - diag(l) T^T lambda.
  Eigen::Matrix2d M = Eigen::Matrix2d::Zero();
  Eigen::Vector2d g = Eigen::Vector2d::Zero();
  for (std::size_t j = 0; j < n; ++j) {
    const double l = lengths[j];
    M(0, 0) += l * tx[j] * tx[j];
    M(0, 1) += l * tx[j] * ty[j];
    M(1, 1) += l * ty[j] * ty[j];
    g(0) += l * tx[j];
    g(1) += l * ty[j];
  }
  M(1, 0) = M(0, 1);
  const Eigen::Vector2d lambda = M.ldlt().solve(g);
  std::vector<double> closed(n);
  closing_change = 0;
  for (std::size_t j = 0; j < n; ++j) {
    closed[j] = lengths[j] - lengths[j] * (tx[j] * lambda(0) + ty[j] * lambda(1));
    if (!(std::isfinite(closed[j]) && closed[j] > 0)) {
      why = "closing the boundary curve would make a length non-positive";
      return {};
    }
    closing_change = std::max(closing_change, std::fabs(closed[j] - lengths[j]) / lengths[j]);
  }
  std::vector<Point2> c(n);
  double x = 0, y = 0;
  for (std::size_t j = 0; j < n; ++j) {
    c[j] = {x, y};
    x += closed[j] * tx[j];
    y += closed[j] * ty[j];
  }
  // Centred on the vertices' mean, largest distance 1 (the map's scale is free; this keeps it ordinary).
  double mx = 0, my = 0;
  for (const Point2& p : c) mx += p.x, my += p.y;
  mx /= static_cast<double>(n);
  my /= static_cast<double>(n);
  double r = 0;
  for (const Point2& p : c) r = std::max(r, std::hypot(p.x - mx, p.y - my));
  if (!(r > 0 && std::isfinite(r))) {
    why = "the boundary curve is degenerate";
    return {};
  }
  for (Point2& p : c) p = {(p.x - mx) / r, (p.y - my) / r};
  // Strictly convex: every corner turns left exactly, and the tangent turns once in all (the angles).
  for (std::size_t j = 0; j < n; ++j)
    if (orientation_sign(c[(j + n - 1) % n], c[j], c[(j + 1) % n]) <= 0) {
      why = "the boundary curve has a corner that is not strictly convex in floating point";
      return {};
    }
  double turn = 0;
  for (std::size_t j = 0; j < n; ++j) {
    const Point2 &a = c[(j + n - 1) % n], &b = c[j], &d = c[(j + 1) % n];
    turn += std::atan2((b.x - a.x) * (d.y - b.y) - (b.y - a.y) * (d.x - b.x),
                       (b.x - a.x) * (d.x - b.x) + (b.y - a.y) * (d.y - b.y));
  }
  if (std::fabs(turn - 2 * M_PI) > 1.0) {
    why = "the boundary curve winds more than once";
    return {};
  }
  return c;
}

}  // namespace

std::vector<double> prescribed_curvature(const std::vector<double>& turning) {
  const std::size_t n = turning.size();
  std::vector<double> k(n);
  if (n == 0) return k;
  const double floor = 0.5 * M_PI / static_cast<double>(n);
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = std::isfinite(turning[i]) ? turning[i] : 0.0;
    k[i] = std::clamp(t, 0.0, 0.75 * M_PI) + floor;
    sum += k[i];
  }
  // sum >= 2 pi whenever the turning sums to 2 pi (the positive parts alone do, or two are capped), so
  // the scaling only shrinks and every value stays below pi.
  for (double& v : k) v *= 2 * M_PI / sum;
  return k;
}

ConvexDomain map_to_convex_domain(const DiskMapInput& input, const CancelToken* cancel) {
  if (!input.vertices || !input.faces || !input.boundary_loop)
    throw InternalError("map_to_convex_domain: vertices, faces and boundary_loop must all be given");
  const std::vector<int>& loop = *input.boundary_loop;
  const std::size_t nb = loop.size();
  if (nb < 3) throw InternalError("map_to_convex_domain: the boundary loop has fewer than 3 vertices");
  ConvexDomain out;
  const std::vector<double> sums = angle_sums(*input.vertices, *input.faces);
  std::vector<double> turning(nb);
  for (std::size_t k = 0; k < nb; ++k) turning[k] = M_PI - sums[static_cast<std::size_t>(loop[k])];
  out.curvature = prescribed_curvature(turning);

  const Eigen::VectorXd u = scale_factors(input, sums, out.curvature, cancel);
  std::string why;
  if (u.size() == 0) {
    why = "the scale factor solve failed";
  } else {
    std::vector<double> lengths(nb);
    double umin = u(loop[0]), umax = umin;
    for (std::size_t k = 0; k < nb; ++k) {
      const int a = loop[k], b = loop[(k + 1) % nb];
      umin = std::min(umin, u(a));
      umax = std::max(umax, u(a));
      lengths[k] = length((*input.vertices)[static_cast<std::size_t>(a)], (*input.vertices)[static_cast<std::size_t>(b)]) *
                   std::exp(0.5 * (u(a) + u(b)));
      if (!(std::isfinite(lengths[k]) && lengths[k] > 0)) why = "a scaled boundary length is not a positive number";
    }
    out.scale_factor_range = umax - umin;
    if (why.empty()) out.boundary = closed_curve(lengths, out.curvature, out.closing_change, why);
  }
  if (out.boundary.empty()) {
    out.conformal_boundary = false;
    out.fallback = why;
    out.boundary = disk_boundary_positions(static_cast<int>(nb));
  }
  check_cancel(cancel);
  DiskMapInput on_domain = input;
  on_domain.boundary_positions = &out.boundary;
  out.map = map_to_disk_with_laplacian(on_domain, cotan_laplacian(*input.vertices, *input.faces), true, cancel);
  return out;
}

}  // namespace lipmap
