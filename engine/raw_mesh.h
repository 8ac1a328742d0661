// The engine's input as it arrives (JSON arrays, a mesh file, a glTF primitive), before any check. Std-only,
// so that the codecs include it; engine/disk_mesh.h holds what validate makes of it.
#pragma once

#include <optional>
#include <vector>

#include "engine/geometry.h"

namespace lipmap {

// Indices are wide so that out-of-range and negative values survive until validate can name them.
struct RawMesh {
  std::vector<Point3> vertices;
  std::vector<std::vector<long long>> faces;
};

// Boundary positions as they arrive: positions[k] is the image of the k-th boundary vertex, in the order
// of `vertices` when given, else of DiskMesh::boundary_loop.
struct RawBoundary {
  std::optional<std::vector<long long>> vertices;
  std::vector<Point2> positions;
  std::optional<std::vector<long long>> rotation_indices;
};

}  // namespace lipmap
