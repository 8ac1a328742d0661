// Stage "reference metric" (paper 5.2, "Variable metric"): a reference map T of the source mesh (an existing
// uv layout, possibly with flipped triangles) defines a metric on the mesh: edge (a, b) gets the length
// |T(a) - T(b)|. The cotangent weights need only edge lengths, so the source's harmonic map h_s is built in
// that metric; the paper's reproduction property then gives h = T whenever T is locally injective with T's
// boundary as the boundary polygon, and a locally injective map close to T when T is almost injective.
//
// The cotangents of a face in T's metric are those of T's own triangle, unsigned (a flipped triangle has the
// same edge lengths as its mirror image): corner_cotangents of engine/intermediate_map.h on T's points.
//
// Corrected faces: lengths taken from points of the plane always satisfy the triangle inequality, but not
// strictly when T's triangle is degenerate (collinear or coincident corners), and a nearly degenerate one has
// unbounded cotangents. A face whose T lengths fail the STRICT inequality with a relative margin
// (l_i + l_j - l_k <= kMetricMargin * (l_0 + l_1 + l_2) for some corner), or whose cotangents are not finite,
// takes the cotangents of its 3D triangle instead (the surface metric; cotangents are scale-invariant, so no
// scale is needed for the Laplacian). The rest shapes of the descent stages (untangle, optimize) are T's
// triangles lifted to z = 0; their own rule gives a (nearly) zero-area rest triangle an equilateral shape of
// the mean area (engine/detail/uv_descent.h). Either way every face's Dirichlet form is positive
// semi-definite, so the interior block of the Laplacian stays positive definite.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "engine/boundary_polygon.h"
#include "engine/disk_mesh.h"
#include "engine/geometry.h"

namespace lipmap {

inline constexpr double kMetricMargin = 1e-12;

struct ReferenceMetric {
  std::vector<std::array<double, 3>> cotangents;  // per face and corner (as corner_cotangents)
  std::vector<Point3> rest;                       // T lifted to z = 0: rest shapes of untangle and optimize
  int flipped = 0;                                // T's faces that are not strictly positive (exact predicate)
  int corrected = 0;                              // faces given the 3D metric (see above)
};

// T: one uv per source vertex. Throws InputError (element "metric"): metric_length_mismatch (not one point per
// vertex), metric_non_finite (a NaN or infinite coordinate; index: the vertex), metric_degenerate (every edge
// has length 0: T maps the whole mesh to one point).
ReferenceMetric reference_metric(const DiskMesh& mesh, const std::vector<Point2>& T);

// How far a map is from T, in units of the chart's size: the diagonal of the boundary polygon's bounding box.
// Over the original vertices (the first T.size() of uv); an answer's inserted vertices have no T value.
struct MetricDistance {
  double chart_size = 0;       // the diagonal, in uv units
  double max = 0, mean = 0;    // max and mean |uv(v) - T(v)| / chart_size
};
MetricDistance distance_to_reference(const std::vector<Point2>& uv, const std::vector<Point2>& T,
                                     const BoundaryPolygon& polygon);

// What the pipeline did with a metric (ParametrizeResult::metric).
struct MetricReport {
  bool given = false;       // options.metric was a uv map (false: the surface metric, nothing below applies)
  // "reference": T itself (or T with its boundary moved onto the polygon) is locally injective: returned;
  // "untangled": T's folds removed by the untangle stage started from T, nothing inserted;
  // "composed": h_t^-1 o h_s with h_s in T's metric, untangled or refined as usual (paper 4's guarantee).
  std::string path;
  bool reproduced = false;  // the answer is T itself, bit for bit
  int reference_flipped = 0;
  int corrected_faces = 0;
  MetricDistance distance;
};

}  // namespace lipmap
