// Quality meshing of one simple sub-polygon of the target domain (paper 4, "Meshing the target domain"),
// and the exact simplicity test the partition uses. Internal to the target-mesh stage: no CGAL types here,
// CGAL stays in engine/piece_mesher.cpp (the mesher is the expensive translation unit).
#pragma once

#include <cstddef>
#include <vector>

#include "engine/cancel.h"
#include "engine/geometry.h"

namespace lipmap::detail {

// CGAL::is_simple_2 with exact predicates: no two edges meet except consecutive ones at their common
// vertex; repeated points make a polygon non-simple. Orientation is not tested.
bool is_simple_polygon(const std::vector<Point2>& polygon);

// Whether two simple counterclockwise polygons A and B glued along one edge form a simple polygon. A is
// given without that edge as the path a_path = (b, ..., a) and B as b_path = (a, ..., b) (its other side);
// the union is a_path followed by b_path's inner points. Exact: every edge of A is tested against every
// edge of B whose bounding box it meets (A and B are simple themselves, and lie on either side of ab).
bool glued_union_is_simple(const std::vector<Point2>& a_path, const std::vector<Point2>& b_path);

// Signed area (shoelace, doubles).
double signed_area(const std::vector<Point2>& polygon);

// Target edge length over a piece: max(base, max over sources of (size - grading * distance to the source)).
// Long polygon edges are sources: the mesher may not split them nor put points inside their diametral
// circles, so the mesh must grow from their length down to the base size gradually, or the triangles
// between a long edge and the fine interior are badly shaped.
struct SizeSource {
  Point2 a, b;
  double size = 0;
};

class SizingField {
public:
  SizingField() = default;
  SizingField(double base, double grading, std::vector<SizeSource> sources);
  double operator()(const Point2& p) const;
  double base() const { return base_; }

private:
  double base_ = 0, grading_ = 1;
  std::vector<SizeSource> sources_;
  // Uniform grid over the sources' regions of influence: cell -> sources (CSR).
  double x0_ = 0, y0_ = 0, cell_ = 1;
  int nx_ = 0, ny_ = 0;
  std::vector<int> cell_start_, cell_items_;
};

struct PieceMeshResult {
  // Steiner points strictly inside the piece; local id boundary.size() + i.
  std::vector<Point2> steiner;
  // Counterclockwise triangles of local ids (0..boundary.size()-1 are the boundary points, in order).
  std::vector<Triangle> faces;
  bool hit_point_cap = false;  // refinement stopped at max_steiner (the mesh is valid, just coarser)
};

// Meshes the simple, counterclockwise polygon `boundary` with CGAL's constrained Delaunay mesher that never
// refines constrained edges (Delaunay_mesher_no_edge_refinement_2): every boundary edge stays an edge of the
// result and every Steiner point is strictly inside. Criteria: longest edge <= size_factor * field(centroid),
// smallest angle >= min_angle_deg where the mesher can achieve it without touching the boundary. Points that
// would make a bad triangle with a boundary edge are refused; lens_cap is the largest size the field asks for
// next to long edges (infinity: uncapped), see Lens_conform in engine/piece_mesher.cpp. With
// lattice_spacing > 0, the region where the field is at its base size and that is clear of the boundary is
// first filled with a hexagonal lattice of that spacing in one batch (much faster than refining it point by
// point; its triangles are equilateral). Stops after max_steiner points. Checks its own output (boundary edges present, face count = m - 2 + 2s, positive
// faces) and throws InternalError when a check fails.
PieceMeshResult mesh_simple_piece(const std::vector<Point2>& boundary, const SizingField& field,
                                  double size_factor, double min_angle_deg, double lens_cap,
                                  double lattice_spacing, std::size_t max_steiner, const CancelToken* cancel);

}  // namespace lipmap::detail
