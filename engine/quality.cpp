// Stage "quality": conformal distortion K = sigma_1 / sigma_2 of the 3D -> uv map, per triangle.
//
// For triangle (p0, p1, p2) with uv (u0, u1, u2) the map is affine. In an orthonormal frame of the 3D
// triangle's plane (e1 along p1 - p0, e2 completing it towards p2) the corners are q0 = (0, 0),
// q1 = (|p1 - p0|, 0), q2 = (<p2 - p0, e1>, <p2 - p0, e2>), and the Jacobian is
//   J = [u1 - u0, u2 - u0] * [q1 - q0, q2 - q0]^-1       (2 x 2).
// Its singular values come in closed form: with J = [[a, b], [c, d]],
//   E = (a + d) / 2, F = (a - d) / 2, G = (c + b) / 2, H = (c - b) / 2,
//   Q = hypot(E, H), R = hypot(F, G), sigma_1 = Q + R, sigma_2 = |Q - R|
// (Q is the conformal part |f_z|, R the anticonformal part |f_zbar|). So K = (Q + R) / |Q - R| >= 1; it is
// 1 exactly when the map is a similarity on that triangle.
//
// Conventions:
//  - K depends on the singular values only, so a flipped (clockwise) uv triangle gets the finite K of its
//    mirror image; flips are counted elsewhere (ParametrizeResult::flipped) and drawn in red by the preview.
//  - A uv triangle of zero area (sigma_2 = 0), or a 3D triangle of zero area (no Jacobian), gets K = +inf.
//  - The mean is weighted by 3D area over faces of positive 3D area; it is +inf when one of those has
//    K = +inf, and 1 for a mesh without any positive-area face.
//  - Histogram: fixed edges 1, 1.1, 1.25, 1.5, 2, 3, 5, 10, +inf; counts[i] faces with
//    edges[i] <= K < edges[i + 1], the last bin [10, +inf] closed above so that K = +inf is counted.
#include "engine/quality.h"

#include <cmath>
#include <limits>
#include <string>

#include "engine/error.h"

namespace lipmap {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct FaceDistortion {
  double k = kInf;
  double area3d = 0;
};

FaceDistortion face_distortion(const Point3& p0, const Point3& p1, const Point3& p2, const Point2& u0,
                               const Point2& u1, const Point2& u2) {
  const double ax = p1.x - p0.x, ay = p1.y - p0.y, az = p1.z - p0.z;  // p1 - p0
  const double bx = p2.x - p0.x, by = p2.y - p0.y, bz = p2.z - p0.z;  // p2 - p0
  const double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
  const double n = std::sqrt(nx * nx + ny * ny + nz * nz);
  const double la = std::sqrt(ax * ax + ay * ay + az * az);
  FaceDistortion out;
  out.area3d = 0.5 * n;
  if (!(n > 0) || !(la > 0) || !std::isfinite(n)) return out;  // no Jacobian: K = inf
  // Local frame: e1 = a / |a|; b = (b.e1) e1 + (b.e2) e2 with b.e2 = |a x b| / |a| = n / |a|.
  const double q1x = la;
  const double q2x = (ax * bx + ay * by + az * bz) / la;
  const double q2y = n / la;
  // S = [q1 - q0, q2 - q0] = [[q1x, q2x], [0, q2y]]; S^-1 = [[1/q1x, -q2x/(q1x q2y)], [0, 1/q2y]].
  const double s00 = 1.0 / q1x, s01 = -q2x / (q1x * q2y), s11 = 1.0 / q2y;
  const double dux1 = u1.x - u0.x, duy1 = u1.y - u0.y, dux2 = u2.x - u0.x, duy2 = u2.y - u0.y;
  // J = D * S^-1 with D = [[dux1, dux2], [duy1, duy2]].
  const double a = dux1 * s00;
  const double b = dux1 * s01 + dux2 * s11;
  const double c = duy1 * s00;
  const double d = duy1 * s01 + duy2 * s11;
  const double E = 0.5 * (a + d), F = 0.5 * (a - d), G = 0.5 * (c + b), H = 0.5 * (c - b);
  const double Q = std::hypot(E, H), R = std::hypot(F, G);
  const double s1 = Q + R, s2 = std::fabs(Q - R);
  if (!(s2 > 0) || !std::isfinite(s1)) return out;  // degenerate uv triangle
  out.k = s1 / s2;
  return out;
}

}  // namespace

Distortion conformal_distortion(const std::vector<Point3>& vertices, const std::vector<Triangle>& faces,
                                const std::vector<Point2>& uv) {
  if (uv.size() != vertices.size())
    throw InternalError("conformal_distortion: " + std::to_string(uv.size()) + " uv positions for " +
                        std::to_string(vertices.size()) + " vertices");
  Distortion out;
  out.bin_edges = {1.0, 1.1, 1.25, 1.5, 2.0, 3.0, 5.0, 10.0, kInf};
  out.counts.assign(out.bin_edges.size() - 1, 0);
  out.per_face.reserve(faces.size());
  const long long nv = static_cast<long long>(vertices.size());

  long double weighted = 0, area_sum = 0;
  bool infinite_mean = false;
  double max_k = 1;
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const Triangle& t = faces[f];
    for (int c = 0; c < 3; ++c)
      if (t[c] < 0 || t[c] >= nv)
        throw InternalError("conformal_distortion: face " + std::to_string(f) + " has corner index " +
                            std::to_string(t[c]) + " out of range");
    const FaceDistortion fd = face_distortion(vertices[t[0]], vertices[t[1]], vertices[t[2]], uv[t[0]], uv[t[1]],
                                              uv[t[2]]);
    out.per_face.push_back(fd.k);
    if (fd.k > max_k) max_k = fd.k;
    if (fd.area3d > 0) {
      if (std::isinf(fd.k)) infinite_mean = true;
      else weighted += static_cast<long double>(fd.area3d) * fd.k;
      area_sum += fd.area3d;
    }
    // Bin: the last edge below or at K (K >= 1 always; a K rounded below 1 cannot happen, but would go to bin 0).
    std::size_t bin = 0;
    while (bin + 1 < out.counts.size() && fd.k >= out.bin_edges[bin + 1]) ++bin;
    ++out.counts[bin];
  }
  out.max = faces.empty() ? 1.0 : max_k;
  if (infinite_mean) out.mean = kInf;
  else if (area_sum > 0) out.mean = static_cast<double>(weighted / area_sum);
  else out.mean = 1.0;
  return out;
}

}  // namespace lipmap
