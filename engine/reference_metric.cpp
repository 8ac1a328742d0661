// Stage "reference metric" (engine/reference_metric.h, paper 5.2).
#include "engine/reference_metric.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "engine/error.h"
#include "engine/flip_check.h"
#include "engine/intermediate_map.h"

namespace lipmap {

ReferenceMetric reference_metric(const DiskMesh& mesh, const std::vector<Point2>& T) {
  const std::size_t nv = mesh.vertices.size();
  if (T.size() != nv)
    throw InputError("metric_length_mismatch",
                     "options.metric.uv has " + std::to_string(T.size()) + " points; the mesh has " + std::to_string(nv) +
                         " vertices (one [u, v] per vertex)",
                     "metric");
  for (std::size_t v = 0; v < nv; ++v)
    if (!(std::isfinite(T[v].x) && std::isfinite(T[v].y)))
      throw InputError("metric_non_finite", "options.metric.uv of vertex " + std::to_string(v) + " is not finite", "metric",
                       static_cast<long long>(v));
  ReferenceMetric out;
  out.cotangents = corner_cotangents(T, mesh.faces);
  const std::vector<std::array<double, 3>> surface = corner_cotangents(mesh.vertices, mesh.faces);
  bool any_length = false;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const Triangle& t = mesh.faces[f];
    double l[3];
    for (int c = 0; c < 3; ++c) {
      const Point2 &a = T[t[(c + 1) % 3]], &b = T[t[(c + 2) % 3]];  // the edge opposite corner c
      l[c] = std::hypot(b.x - a.x, b.y - a.y);
    }
    const double perimeter = l[0] + l[1] + l[2];
    any_length = any_length || perimeter > 0;
    bool strict = std::isfinite(perimeter) && perimeter > 0;
    for (int c = 0; c < 3 && strict; ++c)
      strict = l[(c + 1) % 3] + l[(c + 2) % 3] - l[c] > kMetricMargin * perimeter;
    std::array<double, 3>& cot = out.cotangents[f];
    if (!strict || !(std::isfinite(cot[0]) && std::isfinite(cot[1]) && std::isfinite(cot[2]))) {
      cot = surface[f];
      ++out.corrected;
    }
  }
  if (!any_length)
    throw InputError("metric_degenerate", "options.metric.uv gives every edge length 0 (all points equal): no metric",
                     "metric");
  out.rest.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) out.rest[v] = {T[v].x, T[v].y, 0};
  out.flipped = count_non_positive(T, mesh.faces);
  return out;
}

MetricDistance distance_to_reference(const std::vector<Point2>& uv, const std::vector<Point2>& T,
                                     const BoundaryPolygon& polygon) {
  MetricDistance d;
  if (polygon.vertices.empty() || T.empty()) return d;
  double x0 = polygon.vertices[0].x, x1 = x0, y0 = polygon.vertices[0].y, y1 = y0;
  for (const Point2& p : polygon.vertices) {
    x0 = std::min(x0, p.x), x1 = std::max(x1, p.x);
    y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  }
  d.chart_size = std::hypot(x1 - x0, y1 - y0);
  if (!(d.chart_size > 0)) return d;
  long double sum = 0;
  const std::size_t n = std::min(uv.size(), T.size());
  for (std::size_t v = 0; v < n; ++v) {
    const double e = std::hypot(uv[v].x - T[v].x, uv[v].y - T[v].y) / d.chart_size;
    d.max = std::max(d.max, e);
    sum += e;
  }
  d.mean = n ? static_cast<double>(sum / static_cast<long double>(n)) : 0;
  return d;
}

}  // namespace lipmap
