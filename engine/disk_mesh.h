// The source mesh M after validation: a triangle mesh of disk topology (paper 3.1), and the boundary map
// f_b that pins its boundary loop to the boundary polygon P.
#pragma once

#include <optional>
#include <vector>

#include "engine/boundary_polygon.h"
#include "engine/geometry.h"
#include "engine/mesh_topology.h"
#include "engine/raw_mesh.h"

namespace lipmap {

struct DiskMesh {
  std::vector<Point3> vertices;        // index i is input vertex i
  std::vector<Triangle> faces;         // index f is input face f, corners as given
  std::vector<int> boundary_loop;      // interior on the left (face orientation), starts at lowest index
  MeshTopology topology;               // of `faces`, built by validate; the stages after it read it
};

// f_b: boundary vertex loop[k] maps to polygon.vertices[k]. loop is a rotation of DiskMesh::boundary_loop.
struct BoundaryMap {
  std::vector<int> loop;
  BoundaryPolygon polygon;
};

}  // namespace lipmap
