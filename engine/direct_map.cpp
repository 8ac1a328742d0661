// Stage "direct map": see engine/direct_map.h.
#include "engine/direct_map.h"

#include <cstddef>

#include "engine/detail/exact_predicates.h"

namespace lipmap {

bool strictly_convex(const BoundaryPolygon& polygon, const std::vector<int>& rotation) {
  const std::vector<Point2>& p = polygon.vertices;
  const std::size_t n = p.size();
  if (n < 3) return false;
  for (int r : rotation)
    if (r != 0) return false;
  std::vector<detail::Pt> pts;
  pts.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    if (detail::orient(p[(k + n - 1) % n], p[k], p[(k + 1) % n]) <= 0) return false;
    pts.emplace_back(p[k].x, p[k].y);
  }
  // All left turns with turning number 1: a convex polygon (more turns would wind around more than once).
  return detail::turning_number(pts) == 1;
}

DirectMap map_onto_convex_polygon(const DiskMesh& mesh, const std::vector<int>& loop, const BoundaryPolygon& polygon,
                                  MapMethod method, const CancelToken* cancel) {
  DiskMapInput input{&mesh.vertices, &mesh.faces, &loop};
  input.boundary_positions = &polygon.vertices;
  DiskMap disk = map_to_disk(input, method, cancel);
  DirectMap out;
  out.solution = disk.solution;
  out.flipped = disk.flipped;
  out.map.vertices = mesh.vertices;
  out.map.faces = mesh.faces;
  out.map.uv = std::move(disk.uv);
  // Pinned bit for bit (the map stage writes the given positions; this makes it the contract here).
  for (std::size_t k = 0; k < loop.size(); ++k) out.map.uv[loop[k]] = polygon.vertices[k];
  return out;
}

}  // namespace lipmap
