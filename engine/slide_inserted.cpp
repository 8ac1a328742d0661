// Stage "slide" (engine/slide_inserted.h).
#include "engine/slide_inserted.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include "engine/detail/face_k.h"

namespace lipmap {
namespace {

constexpr int kSweeps = 8;
constexpr int kSamples = 12;     // evenly spaced trials over a point's interval
constexpr int kGoldenSteps = 24;  // then golden sections around the best trial
// A point keeps this share of its interval's length away from each end: its faces stay far from flat in 3D.
constexpr double kMargin = 1e-3;
constexpr double kGain = 1e-6;  // a move must lower the objective by this relative amount

double area3(const Point3& p0, const Point3& p1, const Point3& p2) {
  const double ax = p1.x - p0.x, ay = p1.y - p0.y, az = p1.z - p0.z;
  const double bx = p2.x - p0.x, by = p2.y - p0.y, bz = p2.z - p0.z;
  const double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
  return 0.5 * std::sqrt(nx * nx + ny * ny + nz * nz);
}

}  // namespace

Sliding slide_inserted_points(const DiskMesh& source, RefinedMap& map, SlideObjective objective,
                              const CancelToken* cancel) {
  Sliding out;
  const std::size_t nv = source.vertices.size(), ni = map.inserted.size();
  if (ni == 0) return out;
  out.ran = true;
  // The faces at each inserted point.
  std::vector<std::vector<int>> faces_at(ni);
  for (std::size_t f = 0; f < map.faces.size(); ++f)
    for (int v : map.faces[f])
      if (static_cast<std::size_t>(v) >= nv) faces_at[static_cast<std::size_t>(v) - nv].push_back(static_cast<int>(f));
  // The points of each original edge in order of t: a point's interval ends at its neighbours (or the edge's ends).
  std::map<std::pair<int, int>, std::vector<int>> on_edge;
  for (std::size_t i = 0; i < ni; ++i) on_edge[{map.inserted[i].a, map.inserted[i].b}].push_back(static_cast<int>(i));
  std::vector<int> before(ni, -1), after(ni, -1);
  for (auto& [edge, points] : on_edge) {
    std::sort(points.begin(), points.end(), [&](int p, int q) { return map.inserted[p].t < map.inserted[q].t; });
    for (std::size_t k = 0; k < points.size(); ++k) {
      if (k > 0) before[points[k]] = points[k - 1];
      if (k + 1 < points.size()) after[points[k]] = points[k + 1];
    }
  }
  std::vector<char> moved(ni, 0);
  // Point i's faces with the point at t: the sums of 3D area x K and of 3D area x K^2, and the largest K.
  struct Local {
    double sum = 0, sum2 = 0, worst = 0;
  };
  const double inf = std::numeric_limits<double>::infinity();
  auto local = [&](std::size_t i, double t) {
    const InsertedVertex& iv = map.inserted[i];
    const Point3 at = point_on_edge(source.vertices[iv.a], source.vertices[iv.b], t);
    Local l;
    for (int f : faces_at[i]) {
      const Triangle& tri = map.faces[f];
      std::array<Point3, 3> p;
      for (int c = 0; c < 3; ++c) p[c] = static_cast<std::size_t>(tri[c]) == nv + i ? at : map.vertices[tri[c]];
      const double k = detail::face_k(detail::rest_inverse(p[0], p[1], p[2]), map.uv[tri[0]], map.uv[tri[1]], map.uv[tri[2]]);
      if (!std::isfinite(k)) return Local{inf, inf, inf};
      const double area = area3(p[0], p[1], p[2]);
      l.sum += area * k;
      l.sum2 += area * k * k;
      l.worst = std::max(l.worst, k);
    }
    return l;
  };
  // What the search lowers. For the mean, the sum of area x K^2 rather than area x K: the latter can shrink
  // while K explodes on a face that becomes a sliver (its area goes to 0 as fast as its K grows), the former
  // cannot. A move is then kept only when the sum of area x K (the mean K) does not rise either, and no face
  // of the point ends above the map's max K before the stage, so neither the mean nor the max K ever rises.
  auto searched = [&](const Local& l) { return objective == SlideObjective::max_k ? l.worst : l.sum2; };
  double global_max = 0;
  for (std::size_t f = 0; f < map.faces.size(); ++f) {
    const Triangle& tri = map.faces[f];
    global_max = std::max(global_max, detail::face_k(detail::rest_inverse(map.vertices[tri[0]], map.vertices[tri[1]], map.vertices[tri[2]]),
                                                     map.uv[tri[0]], map.uv[tri[1]], map.uv[tri[2]]));
  }
  for (int sweep = 0; sweep < kSweeps; ++sweep) {
    check_cancel(cancel);
    ++out.sweeps;
    int moves = 0;
    for (std::size_t i = 0; i < ni; ++i) {
      const double lo0 = before[i] < 0 ? 0.0 : map.inserted[before[i]].t;
      const double hi0 = after[i] < 0 ? 1.0 : map.inserted[after[i]].t;
      const double lo = lo0 + kMargin * (hi0 - lo0), hi = hi0 - kMargin * (hi0 - lo0);
      const double t0 = map.inserted[i].t;
      const Local l0 = local(i, t0);
      auto cost = [&](double t) { return searched(local(i, t)); };
      const double c0 = searched(l0);
      if (!(lo < hi) || !std::isfinite(c0)) continue;
      double best_t = t0, best_c = c0;
      const double step = (hi - lo) / kSamples;
      for (int s = 0; s <= kSamples; ++s) {
        const double t = lo + s * step, c = cost(t);
        if (c < best_c) best_t = t, best_c = c;
      }
      // Golden sections on the bracket around the best trial (the objective is not unimodal over the whole
      // interval, but near its best trial it usually is).
      const double g = 0.5 * (std::sqrt(5.0) - 1);
      double a = std::max(lo, best_t - step), b = std::min(hi, best_t + step);
      double x1 = b - g * (b - a), x2 = a + g * (b - a), f1 = cost(x1), f2 = cost(x2);
      for (int s = 0; s < kGoldenSteps; ++s) {
        if (f1 < f2) {
          b = x2, x2 = x1, f2 = f1, x1 = b - g * (b - a), f1 = cost(x1);
        } else {
          a = x1, x1 = x2, f1 = f2, x2 = a + g * (b - a), f2 = cost(x2);
        }
      }
      if (f1 < best_c) best_t = x1, best_c = f1;
      if (f2 < best_c) best_t = x2, best_c = f2;
      if (!(best_c < c0 * (1 - kGain)) || !(best_t > lo0 && best_t < hi0)) continue;
      if (objective == SlideObjective::mean_k) {
        const Local l = local(i, best_t);
        if (!(l.sum <= l0.sum && l.worst <= global_max)) continue;
      }
      map.inserted[i].t = best_t;
      map.vertices[nv + i] = point_on_edge(source.vertices[map.inserted[i].a], source.vertices[map.inserted[i].b], best_t);
      moved[i] = 1;
      ++moves;
    }
    if (moves == 0) break;
  }
  out.points_moved = static_cast<int>(std::count(moved.begin(), moved.end(), 1));
  return out;
}

}  // namespace lipmap
