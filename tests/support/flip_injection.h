// Almost-injective reference maps for the variable-metric tests and bench (paper 5.2, UV repair): a locally
// injective map with flips injected by pushing interior vertices across one of their neighbours, and the
// distance of a map to it. Shares no code with the engine; orientation by the test support's exact predicate.
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "engine/geometry.h"
#include "tests/support/triangulation_checker.h"

namespace lipmap::flipinject {

// Faces whose uv triangle is not strictly counterclockwise (exact).
inline int count_folded(const std::vector<Point2>& uv, const std::vector<Triangle>& faces) {
  int n = 0;
  for (const Triangle& t : faces)
    n += testgen::exact::orient({uv[t[0]].x, uv[t[0]].y}, {uv[t[1]].x, uv[t[1]].y}, {uv[t[2]].x, uv[t[2]].y}) > 0 ? 0 : 1;
  return n;
}

// Pushes random interior vertices v across a random neighbour n, T(v) <- T(n) + s (T(n) - T(v)) with s in
// [0.2, 0.8], until at least `want` faces fold (at most `cap`: a push that overshoots is undone). Returns the
// number of folded faces (0 when no push worked: e.g. no interior vertex).
inline int inject_flips(std::vector<Point2>& uv, const std::vector<Triangle>& faces, const std::vector<int>& loop,
                        int want, int cap, unsigned seed) {
  const std::size_t nv = uv.size();
  std::vector<char> boundary(nv, 0);
  for (int v : loop) boundary[v] = 1;
  std::vector<std::vector<int>> ring(nv);
  for (const Triangle& t : faces)
    for (int c = 0; c < 3; ++c) ring[t[c]].push_back(t[(c + 1) % 3]);
  std::vector<int> interior;
  for (std::size_t v = 0; v < nv; ++v)
    if (!boundary[v] && !ring[v].empty()) interior.push_back(static_cast<int>(v));
  if (interior.empty()) return 0;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> push(0.2, 0.8);
  int folded = count_folded(uv, faces);
  for (int attempt = 0; attempt < 2000 && folded < want; ++attempt) {
    const int v = interior[rng() % interior.size()];
    const int n = ring[v][rng() % ring[v].size()];
    const Point2 old = uv[v];
    const double s = push(rng);
    uv[v] = {uv[n].x + s * (uv[n].x - old.x), uv[n].y + s * (uv[n].y - old.y)};
    const int now = count_folded(uv, faces);
    if (now > cap || now <= folded) uv[v] = old;
    else folded = now;
  }
  return folded;
}

// Mean and max |a(v) - b(v)| over the first b.size() vertices, divided by the diagonal of the bounding box of
// the boundary positions (the chart's size).
struct Distance {
  double mean = 0, max = 0;
};
inline Distance distance(const std::vector<Point2>& a, const std::vector<Point2>& b, const std::vector<Point2>& polygon) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const Point2& p : polygon) x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  const double size = std::hypot(x1 - x0, y1 - y0);
  Distance d;
  long double sum = 0;
  for (std::size_t v = 0; v < b.size(); ++v) {
    const double e = std::hypot(a[v].x - b[v].x, a[v].y - b[v].y) / size;
    sum += e;
    d.max = std::max(d.max, e);
  }
  d.mean = b.empty() ? 0 : static_cast<double>(sum / b.size());
  return d;
}

}  // namespace lipmap::flipinject
