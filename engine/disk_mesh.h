// The source mesh M after validation: a triangle mesh of disk topology (paper 3.1), and the boundary map
// f_b that pins its boundary loop to the boundary polygon P.
#pragma once

#include <optional>
#include <vector>

#include "engine/boundary_polygon.h"
#include "engine/geometry.h"
#include "engine/mesh_topology.h"

namespace lipmap {

// Mesh as it arrives (JSON arrays or a file), before any check. Indices are wide so that out-of-range
// and negative values survive until validate can name them.
struct RawMesh {
  std::vector<Point3> vertices;
  std::vector<std::vector<long long>> faces;
};

struct DiskMesh {
  std::vector<Point3> vertices;        // index i is input vertex i
  std::vector<Triangle> faces;         // index f is input face f, corners as given
  std::vector<int> boundary_loop;      // interior on the left (face orientation), starts at lowest index
  MeshTopology topology;               // of `faces`, built by validate; the stages after it read it
};

// Boundary positions as they arrive: positions[k] is the image of the k-th boundary vertex, in the order
// of `vertices` when given, else of DiskMesh::boundary_loop.
struct RawBoundary {
  std::optional<std::vector<long long>> vertices;
  std::vector<Point2> positions;
  std::optional<std::vector<long long>> rotation_indices;
};

// f_b: boundary vertex loop[k] maps to polygon.vertices[k]. loop is a rotation of DiskMesh::boundary_loop.
struct BoundaryMap {
  std::vector<int> loop;
  BoundaryPolygon polygon;
};

}  // namespace lipmap
