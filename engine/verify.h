// Stage "verify": the checks of docs/contract.md on a finished map, with exact predicates, before it is
// returned. A violation is a bug: verify_map throws InternalError naming the check and the element.
#pragma once

#include <vector>

#include "engine/boundary_polygon.h"
#include "engine/disk_mesh.h"
#include "engine/refine.h"

namespace lipmap {

struct VerifyReport {
  int faces_checked = 0;
  int interior_vertices_checked = 0;
  double area_relative_error = 0;  // |area(M_r) - area(M)| / area(M)
  std::vector<int> rotation_indices;  // the map's R_k at boundary vertex loop[k]
  double ms = 0;
};

// loop and polygon: boundary vertex loop[k] must have uv == polygon.vertices[k] bit for bit, and its angle
// in the map must be the polygon's interior angle plus 2 pi rotation[k] (the classification's R_k). An empty
// rotation accepts any R_k >= 0 (none prescribed, paper 3.1); the report has the map's own either way.
VerifyReport verify_map(const DiskMesh& source, const std::vector<int>& loop, const BoundaryPolygon& polygon,
                        const std::vector<int>& rotation, const RefinedMap& map);

}  // namespace lipmap
