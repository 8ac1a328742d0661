// Stage "compose" (paper 4): f = h_t^-1 o h_s evaluated at every source vertex. h_s(v) is located in the
// disk image h_t(M_t) by walking from the face where a neighbour was found (source vertices are visited
// breadth first, so each walk is short: amortized O(1) per query, no linear scans), then f(v) is the
// barycentric combination of the M_t triangle's corners. Boundary vertex k gets P's vertex k bit for bit.
#pragma once

#include <memory>
#include <vector>

#include "engine/cancel.h"
#include "engine/disk_mesh.h"
#include "engine/geometry.h"
#include "engine/target_mesh.h"

namespace lipmap {

namespace detail {
class DiskWalk;  // h_t(M_t) with adjacency, built once by compose and reused by refine
}

struct Composition {
  std::vector<Point2> uv;          // f at every source vertex (the uv of the unrefined map)
  std::vector<int> target_face;    // M_t face whose image contains h_s(v); -1 for boundary vertices
  int walk_steps = 0;              // faces visited by all walks together
  double ms = 0;
  std::shared_ptr<const detail::DiskWalk> walk;
};

// source_disk: h_s (one point per source vertex); target_disk: h_t (one per M_t vertex). Boundary vertex
// loop[k] of the source and polygon vertex k of M_t share the disk point k.
Composition compose(const DiskMesh& source, const std::vector<int>& loop, const std::vector<Point2>& source_disk,
                    const TargetMesh& target, const std::vector<Point2>& target_disk,
                    const CancelToken* cancel = nullptr);

}  // namespace lipmap
