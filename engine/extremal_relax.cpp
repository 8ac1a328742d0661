// Local minimax relaxation of max K for method extremal (paper 5.3). See extremal_relax.h.
#include "engine/extremal_relax.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "engine/flip_check.h"
#include "engine/mesh_topology.h"

namespace lipmap {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kInf = std::numeric_limits<double>::infinity();

// The inverse of a face's rest edge matrix S = [[q1x, q2x], [0, q2y]] (quality.cpp's frame), or !ok for a
// rest triangle of zero area (no Jacobian: such a face is only kept positive).
struct RestInverse {
  double s00 = 0, s01 = 0, s11 = 0;
  bool ok = false;
};

RestInverse rest_inverse(const Point3& p0, const Point3& p1, const Point3& p2) {
  const double ax = p1.x - p0.x, ay = p1.y - p0.y, az = p1.z - p0.z;
  const double bx = p2.x - p0.x, by = p2.y - p0.y, bz = p2.z - p0.z;
  const double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
  const double n = std::sqrt(nx * nx + ny * ny + nz * nz), la = std::sqrt(ax * ax + ay * ay + az * az);
  RestInverse r;
  if (!(n > 0) || !(la > 0) || !std::isfinite(n)) return r;
  const double q1x = la, q2x = (ax * bx + ay * by + az * bz) / la, q2y = n / la;
  r = {1.0 / q1x, -q2x / (q1x * q2y), 1.0 / q2y, true};
  return r;
}

// K of the affine map on one face; +inf unless the uv triangle is positive (floating point). A face without
// a rest Jacobian counts 1 when positive.
double face_k(const RestInverse& s, const Point2& u0, const Point2& u1, const Point2& u2) {
  const double dux1 = u1.x - u0.x, duy1 = u1.y - u0.y, dux2 = u2.x - u0.x, duy2 = u2.y - u0.y;
  if (!(dux1 * duy2 - dux2 * duy1 > 0)) return kInf;
  if (!s.ok) return 1;
  const double a = dux1 * s.s00, b = dux1 * s.s01 + dux2 * s.s11, c = duy1 * s.s00, d = duy1 * s.s01 + duy2 * s.s11;
  const double Q = std::hypot(0.5 * (a + d), 0.5 * (c - b)), R = std::hypot(0.5 * (a - d), 0.5 * (c + b));
  if (!(Q > R)) return kInf;
  return (Q + R) / (Q - R);
}

}  // namespace

ExtremalRelaxation relax_max_dilatation(const DiskMesh& source, const std::vector<int>& loop, RefinedMap& map,
                                        const ExtremalRelaxOptions& options, const CancelToken* cancel,
                                        const std::vector<Point3>* rest) {
  const auto t0 = Clock::now();
  ExtremalRelaxation out;
  const std::size_t nv = map.vertices.size(), nf = map.faces.size(), nv_source = source.vertices.size();
  const std::vector<Point3>& shape = rest ? *rest : map.vertices;
  std::vector<RestInverse> inv(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const Triangle& t = map.faces[f];
    inv[f] = rest_inverse(shape[static_cast<std::size_t>(t[0])], shape[static_cast<std::size_t>(t[1])],
                          shape[static_cast<std::size_t>(t[2])]);
  }
  auto k_of = [&](std::size_t f) {
    const Triangle& t = map.faces[f];
    return face_k(inv[f], map.uv[static_cast<std::size_t>(t[0])], map.uv[static_cast<std::size_t>(t[1])],
                  map.uv[static_cast<std::size_t>(t[2])]);
  };
  std::vector<double> k(nf);
  for (std::size_t f = 0; f < nf; ++f) k[f] = k_of(f);
  out.max_before = out.max_after = k.empty() ? 1 : *std::max_element(k.begin(), k.end());
  if (nf == 0 || !std::isfinite(out.max_before) || count_non_positive(map.uv, map.faces) > 0) return out;

  // Free vertices: as the optimize stage's (see extremal_relax.h).
  std::vector<char> pinned(nv, 0);
  for (int v : loop) pinned[static_cast<std::size_t>(v)] = 1;
  for (std::size_t i = nv_source; i < nv; ++i) {
    pinned[i] = 1;
    const InsertedVertex& iv = map.inserted[i - nv_source];
    const int e = source.topology.find_edge(iv.a, iv.b);
    if (e < 0) continue;
    for (int h : source.topology.edge_uses(e))
      for (int v : source.faces[static_cast<std::size_t>(MeshTopology::face_of(h))]) pinned[static_cast<std::size_t>(v)] = 1;
  }
  const MeshTopology topo(static_cast<int>(nv), map.faces);
  if (!topo.oriented_manifold()) return out;
  for (std::size_t v = 0; v < nv; ++v)
    if (topo.is_boundary_vertex(static_cast<int>(v))) pinned[v] = 1;
  for (std::size_t v = 0; v < nv; ++v) out.free_vertices += !pinned[v];
  if (out.free_vertices == 0) return out;
  out.ran = true;

  std::vector<int> star;
  auto star_max = [&](int v) {
    double m = 1;
    for (int f : star) m = std::max(m, k_of(static_cast<std::size_t>(f)));
    (void)v;
    return m;
  };
  // One vertex: compass search on the star's max K; true when a move was kept.
  auto relax_vertex = [&](int v) {
    star.clear();
    for (int h : topo.fan(v)) star.push_back(MeshTopology::face_of(h));
    Point2& p = map.uv[static_cast<std::size_t>(v)];
    const Point2 start = p;
    const double g0 = star_max(v);
    double g = g0, edge = 0;
    for (int h : topo.fan(v)) {
      const Point2& q = map.uv[static_cast<std::size_t>(topo.to(h))];
      edge += std::hypot(q.x - p.x, q.y - p.y);
    }
    double step = 0.25 * edge / static_cast<double>(star.size());
    const double min_step = 1e-4 * step;
    static const double dir[8][2] = {{1, 0}, {0.70710678118654752, 0.70710678118654752}, {0, 1},
                                     {-0.70710678118654752, 0.70710678118654752}, {-1, 0},
                                     {-0.70710678118654752, -0.70710678118654752}, {0, -1},
                                     {0.70710678118654752, -0.70710678118654752}};
    for (int evals = 0; evals < 60 && step > min_step; ++evals) {
      const Point2 here = p;
      Point2 best = here;
      double best_g = g;
      for (const auto& d : dir) {
        p = {here.x + step * d[0], here.y + step * d[1]};
        const double trial = star_max(v);
        if (trial < best_g) best_g = trial, best = p;
      }
      p = best;
      if (best_g < g) g = best_g;
      else step *= 0.5;
    }
    if (!(g < g0)) {
      p = start;
      return false;
    }
    for (int f : star) {
      const Triangle& t = map.faces[static_cast<std::size_t>(f)];
      if (orientation_sign(map.uv[static_cast<std::size_t>(t[0])], map.uv[static_cast<std::size_t>(t[1])],
                           map.uv[static_cast<std::size_t>(t[2])]) <= 0) {
        p = start;
        return false;
      }
    }
    for (int f : star) k[static_cast<std::size_t>(f)] = k_of(static_cast<std::size_t>(f));
    return true;
  };

  std::vector<std::pair<double, int>> order;
  std::vector<char> queued(nv, 0);
  for (int sweep = 0; sweep < options.max_sweeps; ++sweep) {
    check_cancel(cancel);
    if (options.time_budget_ms > 0 &&
        std::chrono::duration<double, std::milli>(Clock::now() - t0).count() > options.time_budget_ms)
      break;
    // The worst face that can still change sets the threshold: its free corners and those of every face
    // within half of its excess over 1 are visited, worst star first.
    double movable = 1;
    for (std::size_t f = 0; f < nf; ++f) {
      const Triangle& t = map.faces[f];
      if (!pinned[static_cast<std::size_t>(t[0])] || !pinned[static_cast<std::size_t>(t[1])] || !pinned[static_cast<std::size_t>(t[2])])
        movable = std::max(movable, k[f]);
    }
    const double threshold = 1 + 0.5 * (movable - 1);
    const double before = movable;
    order.clear();
    for (std::size_t f = 0; f < nf; ++f) {
      if (k[f] < threshold) continue;
      for (int v : map.faces[f])
        if (!pinned[static_cast<std::size_t>(v)] && !queued[static_cast<std::size_t>(v)]) {
          queued[static_cast<std::size_t>(v)] = 1;
          order.push_back({k[f], v});
        }
    }
    for (const auto& [kv, v] : order) queued[static_cast<std::size_t>(v)] = 0;
    std::sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first > b.first || (a.first == b.first && a.second < b.second); });
    int moved = 0;
    for (const auto& [kv, v] : order) moved += relax_vertex(v);
    out.moves += moved;
    ++out.sweeps;
    double after = 1;
    for (std::size_t f = 0; f < nf; ++f) {
      const Triangle& t = map.faces[f];
      if (!pinned[static_cast<std::size_t>(t[0])] || !pinned[static_cast<std::size_t>(t[1])] || !pinned[static_cast<std::size_t>(t[2])])
        after = std::max(after, k[f]);
    }
    if (moved == 0 || after > before - 1e-3 * (before - 1)) break;
  }
  out.max_after = *std::max_element(k.begin(), k.end());
  out.ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  return out;
}

}  // namespace lipmap
