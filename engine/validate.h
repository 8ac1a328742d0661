// Stage "validate" (paper 3.1: "a mesh of disk topology", no degenerate triangle): raw arrays -> DiskMesh
// and BoundaryMap. Every failure throws InputError with its own stable code and names the offending
// element (vertex, face, edge, boundary position).
//
// Mesh codes, checked in this order:
//   mesh_empty                 no vertices or no faces
//   non_finite_coordinate      vertex with NaN or infinite coordinate            (element "vertex")
//   face_not_triangle          face with other than 3 corners                    (element "face")
//   face_index_out_of_range    corner index < 0 or >= vertex count               (element "face")
//   face_repeated_vertex       a face uses the same vertex twice                 (element "face")
//   unreferenced_vertex        a vertex no face uses                             (element "vertex")
//   degenerate_face            three collinear corners in 3D (exact predicate)   (element "face")
//   duplicate_face             two faces on the same three vertices              (element "face")
//   non_manifold_edge          an edge with more than two faces                  (element "edge")
//   inconsistent_orientation   two faces use the same directed edge              (element "edge")
//   non_manifold_vertex        faces around a vertex form more than one fan      (element "vertex")
//   not_connected              more than one connected component                 (element "face")
//   no_boundary                closed surface
//   multiple_boundary_loops    more than one boundary loop
//   not_a_disk                 Euler characteristic V - E + F != 1 (e.g. a punctured torus)
//
// Index meanings: a "vertex" or "face" index is the input index. An "edge" index numbers the undirected
// edges in order of first appearance when faces are walked in input order, corners (0,1), (1,2), (2,0);
// the message also names the edge by its two vertices.
//
// Boundary codes:
//   boundary_length_mismatch   positions (or rotation indices) not one per boundary vertex, or the listed
//                              vertices leave out part of the boundary loop
//   boundary_position_non_finite                                                 (element "boundary")
//   boundary_vertex_out_of_range                                                 (element "boundary")
//   boundary_vertex_not_on_boundary   a listed vertex is interior                (element "boundary")
//   boundary_vertex_repeated                                                     (element "boundary")
//   boundary_not_loop_order    the listed vertices are the loop but not in its order (interior on the left)
//                                                                                (element "boundary")
//   rotation_index_out_of_range                                                  (element "boundary")
// "boundary" indices are positions in the caller's lists (vertices / positions / rotation_indices).
// Then validate_polygon (boundary_polygon.h) runs on the positions.
#pragma once

#include "engine/cancel.h"
#include "engine/disk_mesh.h"

namespace lipmap {

// Every pass is O(n log n) at worst; a cancelled or expired token throws Cancelled.
DiskMesh validate_mesh(const RawMesh& raw, const CancelToken* cancel = nullptr);

BoundaryMap validate_boundary(const DiskMesh& mesh, const RawBoundary& raw, const CancelToken* cancel = nullptr);

}  // namespace lipmap
