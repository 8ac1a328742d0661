// Candidates for the extra turn's vertex (engine/rotation_placement.h).
#include "engine/rotation_placement.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace lipmap {

double rotation_room(const DiskMesh& mesh, const std::vector<int>& loop, const BoundaryPolygon& polygon, int k) {
  const std::size_t n = polygon.vertices.size(), i = static_cast<std::size_t>(k);
  const Point2 &p = polygon.vertices[i], &next = polygon.vertices[(i + 1) % n], &prev = polygon.vertices[(i + n - 1) % n];
  // The polygon's angle at k, counterclockwise from the next vertex to the previous one, in (0, 2 pi].
  const double two_pi = 2 * M_PI;
  double alpha = std::atan2(prev.y - p.y, prev.x - p.x) - std::atan2(next.y - p.y, next.x - p.x);
  alpha = std::fmod(alpha, two_pi);
  if (alpha <= 0) alpha += two_pi;
  const int faces = static_cast<int>(mesh.topology.fan(loop[i]).size());
  return faces * M_PI - alpha - two_pi;
}

std::vector<int> rotation_placement_candidates(const DiskMesh& mesh, const std::vector<int>& loop,
                                               const BoundaryPolygon& polygon, const Classification& found) {
  if (polygon.rotation_indices || !found.stats.free_rotation_search || found.turning_number != 2 ||
      found.singular_vertices.size() != 1)
    return {};
  const int at = found.singular_vertices.front();
  const double room_at = rotation_room(mesh, loop, polygon, at);
  if (room_at >= M_PI) return {};
  const int n = static_cast<int>(polygon.vertices.size());
  std::vector<double> room(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) room[static_cast<std::size_t>(k)] = rotation_room(mesh, loop, polygon, k);
  std::vector<int> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return room[a] > room[b]; });
  std::vector<int> out;
  for (int k : order) {
    if (static_cast<int>(out.size()) == kRotationPlacementCandidates || !(room[static_cast<std::size_t>(k)] > room_at)) break;
    if (k != at) out.push_back(k);
  }
  return out;
}

}  // namespace lipmap
