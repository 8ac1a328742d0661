// Stage "target mesh" (paper 4, "Meshing the target domain", Fig. 7): from the boundary polygon P and its
// coarse triangulation (classify: n - 2 positive triangles, no interior vertices) build the finer target
// mesh M_t whose boundary is exactly P.
//
//  1. Partition: merge coarse triangles across interior edges while the union stays a simple polygon (exact
//     test of the glued union, engine/piece_mesher.cpp); diagonals that are long against their triangles are
//     removed first. A simple P is one piece. Sheets that overlap in the plane end up in different pieces.
//  2. Size: h0 is the edge length of an equilateral triangle of area (summed coarse area, overlapping sheets
//     counted each time) / target. Polygon edges may not be split, so next to an edge longer than the local
//     size the mesh must be about as coarse as the edge; a sizing field grades from each polygon edge's
//     length down to the base size h. The base size (and, if the long edges alone would leave too few
//     triangles, a cap on the sizes they ask for) is chosen from an estimate of the resulting count, so that
//     the count lands near the target without a second meshing pass (one more is made if it misses by 25%).
//  3. Split every interior edge of the partition at equal steps of the integral of 1/size along it (in a
//     uniform zone: k = max(1, round(length / h)) equal segments). The split points belong to the edge
//     (identified by the edge and k, never by position), so both sides use the same vertices.
//  4. Mesh each piece with CGAL's constrained Delaunay mesher that never splits constrained edges: P's edges
//     are never split and the split interior edges are not split further. The uniform zone is first filled
//     with a hexagonal lattice in one batch; Delaunay refinement (size from the field, smallest angle
//     min_angle_deg) does the rest. Points that would make a bad triangle with a constrained edge are refused
//     (a thinner rule than CGAL's Gabriel test, which leaves fans of needles next to long edges).
//  5. Glue: polygon vertex k keeps id k; split points follow, then the pieces' Steiner points.
// The result is verified before it is returned (strictly positive faces by the exact predicate, a disk
// whose single boundary loop is 0, 1, ..., n-1 with the interior on the left, interior angle sums 2 pi and
// the angle at every polygon vertex equal to the coarse triangulation's, both decided exactly by counting
// full turns (engine/detail/exact_predicates.h), total area equal to the coarse area);
// any failure throws InternalError with the reason.
//
// Quality: with boundaries like a source mesh's (edges about as long as the target size) every triangle
// meets the angle bound except at polygon corners sharper than it. Polygon edges many times longer than the
// target size cost some bad triangles next to them (they may not be split).
#pragma once

#include <vector>

#include "engine/boundary_polygon.h"
#include "engine/cancel.h"
#include "engine/geometry.h"
#include "engine/mesh_topology.h"

namespace lipmap {

struct TargetMeshOptions {
  // Target triangle count ~ density * min(source_triangles, target_triangle_cap(n)) (paper: same density as
  // the source, density 1; the cap only binds for large sources, see target_triangle_cap).
  double density = 1.0;
  // Triangles of the source mesh; 0: use 2 * n (n = polygon vertices).
  int source_triangles = 0;
  // Apply target_triangle_cap (false: the paper's rule alone, for benchmarks comparing the two).
  bool cap_to_polygon = true;
  // Smallest angle the mesher aims for away from P's boundary (CGAL's bound; at most 30 degrees).
  double min_angle_deg = 20;
};

struct TargetMesh {
  std::vector<Point2> vertices;  // vertices[k] == P.vertices[k] bit for bit for k < n
  std::vector<Triangle> faces;   // all strictly positive (counterclockwise)
  MeshTopology topology;         // of `faces`, built once here; compose and refine walk M_t with it
  int pieces = 0;                // simple sub-polygons of the partition
  int interior_edge_splits = 0;  // points inserted on the partition's interior edges
  int steiner_points = 0;        // points the mesher inserted inside the pieces
  int target_triangles = 0;      // the triangle count aimed at
  int remesh_rounds = 1;         // meshing passes (a second one when the first missed the count badly)
  double size = 0;               // target edge length h used for the splits and the mesher's size bound
  double min_angle_deg = 0;      // smallest triangle angle in the result
  bool hit_point_cap = false;    // some piece stopped refining at the Steiner point cap
  double partition_ms = 0, mesh_ms = 0, verify_ms = 0;
  double ms = 0;                 // whole stage
};

// The most triangles M_t needs for a polygon of n vertices: max(kTargetCapFloor, kTargetCapPerVertex * n).
// Paper 4, "Meshing the target domain": the bijectivity of the result does not depend on how coarse or fine
// M_t is, and its resolution has little effect on the map's quality (paper Fig. 8). What the composition
// needs is resolution where P needs it, near P's vertices and edges, and the mesher grades from P's edge
// lengths inwards by itself; a source of 1M triangles does not need a 1M-triangle target, whose harmonic map
// would cost as much as the source's. The floor keeps every source up to 20k triangles at the paper's
// density (answers unchanged there); the inserted-vertex counts of bench_pipeline did not change with the
// cap binding at 10k (docs/architecture.md, "Target mesh size", has the figures).
inline constexpr int kTargetCapFloor = 20000;
inline constexpr int kTargetCapPerVertex = 32;
int target_triangle_cap(int polygon_vertices);

// Throws InputError for bad options (code target_density_invalid, source_triangles_invalid,
// min_angle_invalid) or a polygon with fewer than 3 vertices / non-finite coordinates; InternalError when
// the coarse triangulation is not a positive triangulation of P without interior vertices or when the
// result fails verification; Cancelled when the token fires.
TargetMesh build_target_mesh(const BoundaryPolygon& polygon, const std::vector<Triangle>& coarse,
                             const TargetMeshOptions& options = {}, const CancelToken* cancel = nullptr);

// The verification build_target_mesh runs on its result, exposed for tests: throws InternalError with the
// reason when `mesh` is not a valid target mesh for P and the coarse triangulation. It reads mesh.faces
// (and builds their topology itself), never mesh.topology.
void verify_target_mesh(const BoundaryPolygon& polygon, const std::vector<Triangle>& coarse,
                        const TargetMesh& mesh);

}  // namespace lipmap
