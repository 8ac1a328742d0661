// Stage "compose" (paper 4): f = h_t^-1 o h_s at the source vertices.
#include "engine/compose.h"

#include <chrono>
#include <vector>

#include "engine/detail/disk_walk.h"

namespace lipmap {

Composition compose(const DiskMesh& source, const std::vector<int>& loop, const std::vector<Point2>& source_disk,
                    const TargetMesh& target, const std::vector<Point2>& target_disk, const CancelToken* cancel) {
  const auto t0 = std::chrono::steady_clock::now();
  const int n = static_cast<int>(source.vertices.size());
  Composition out;
  out.walk = std::make_shared<const detail::DiskWalk>(target_disk, target.vertices, target.faces, target.topology);
  const detail::DiskWalk& walk = *out.walk;
  out.uv.assign(n, Point2{});
  out.target_face.assign(n, -1);
  std::vector<int> boundary_index(n, -1);
  for (int k = 0; k < static_cast<int>(loop.size()); ++k) boundary_index[loop[k]] = k;

  // Breadth first from the boundary, so every walk starts in the face where a neighbour was found.
  std::vector<int> start_face(n, -1);
  std::vector<char> seen(n, 0);
  // Every vertex enters the queue once: a flat array read from its front, no deque blocks to allocate.
  std::vector<int> queue;
  queue.reserve(n);
  std::size_t head = 0;
  for (int k = 0; k < static_cast<int>(loop.size()); ++k) {
    const int v = loop[k];
    out.uv[v] = target.vertices[k];  // h_s and h_t pin boundary vertex k to the same disk point
    start_face[v] = walk.face_at_vertex(k);
    seen[v] = 1;
    queue.push_back(v);
  }
  const MeshTopology& mesh = source.topology;
  int visited = 0;
  while (head < queue.size()) {
    const int v = queue[head++];
    if (++visited % 4096 == 0) check_cancel(cancel);
    if (boundary_index[v] < 0) {
      const Point2& q = source_disk[v];
      const int f = walk.locate(detail::Pt(q.x, q.y), start_face[v], &out.walk_steps);
      out.target_face[v] = f;
      out.uv[v] = walk.target_point(detail::Pt(q.x, q.y), f);
      start_face[v] = f;
    }
    // v's neighbours clockwise (a boundary vertex's starting with its predecessor on the loop): the
    // visiting order, and so each walk's start, depends on it.
    const HalfedgeRange fan = mesh.fan(v);
    const int before = mesh.is_boundary_vertex(v) ? mesh.from(MeshTopology::prev(fan.front())) : -1;
    for (int i = before >= 0 ? -1 : 0; i < static_cast<int>(fan.size()); ++i) {
      const int w = i < 0 ? before : mesh.to(fan[i]);
      if (seen[w]) continue;
      seen[w] = 1;
      start_face[w] = start_face[v];
      queue.push_back(w);
    }
  }
  out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace lipmap
