// Walks in h_t(M_t). Every decision is an exact orientation test on the disk doubles; crossing positions
// are exact rationals, rounded once at the end.
#include "engine/detail/disk_walk.h"

#include <CGAL/Exact_rational.h>

#include <algorithm>
#include <cstdint>

#include "engine/error.h"

namespace lipmap::detail {
namespace {
using Q = CGAL::Exact_rational;
}  // namespace

DiskWalk::DiskWalk(const std::vector<Point2>& disk, const std::vector<Point2>& target,
                   const std::vector<Triangle>& faces, const MeshTopology& topology)
    : target_(target), faces_(faces), mesh_(&topology) {
  disk_.reserve(disk.size());
  for (const Point2& p : disk) disk_.emplace_back(p.x, p.y);
  if (topology.face_count() != static_cast<int>(faces.size()) ||
      topology.vertex_count() != static_cast<int>(disk.size()) || !topology.oriented_manifold()) {
    own_ = MeshTopology(static_cast<int>(disk.size()), faces);
    mesh_ = &own_;
  }
}

int DiskWalk::face_at_vertex(int w) const {
  int lowest = -1;
  for (int h : mesh_->fan(w))
    if (lowest < 0 || MeshTopology::face_of(h) < lowest) lowest = MeshTopology::face_of(h);
  return lowest;
}

// Stochastic visibility walk (Devillers, Pion, Teillaud): cross an edge that has q strictly on its outer
// side, testing the edges from a random one, which terminates in any triangulation. A generous step cap
// guards against a bug; past it, a scan over all faces decides.
int DiskWalk::locate(const Pt& q, int f, int* steps) const {
  std::uint32_t seed = 0x9e3779b9u ^ static_cast<std::uint32_t>(f);
  const std::size_t cap = 64 + 8 * faces_.size();
  for (std::size_t step = 0; step < cap; ++step) {
    if (steps) ++*steps;
    seed ^= seed << 13; seed ^= seed >> 17; seed ^= seed << 5;
    const int first = static_cast<int>(seed % 3);
    int next = -1;
    for (int r = 0; r < 3 && next < 0; ++r) {
      const int e = (first + r) % 3;
      if (orient(disk_[faces_[f][e]], disk_[faces_[f][(e + 1) % 3]], q) < 0) next = e;
    }
    if (next < 0) return f;
    if (neighbour(f, next) < 0) break;  // q is outside the disk triangulation
    f = neighbour(f, next);
  }
  for (int g = 0; g < static_cast<int>(faces_.size()); ++g) {
    const Triangle& t = faces_[g];
    if (orient(disk_[t[0]], disk_[t[1]], q) >= 0 && orient(disk_[t[1]], disk_[t[2]], q) >= 0 &&
        orient(disk_[t[2]], disk_[t[0]], q) >= 0)
      return g;
  }
  throw InternalError("compose: a point of the source disk map lies outside the target disk map");
}

// The face at vertex w whose closed corner contains the direction w -> b; the lowest-index one when the
// direction runs along an edge (two closed corners contain it).
int DiskWalk::face_around(int w, const Pt& b) const {
  const Pt& pw = disk_[w];
  int found = -1;
  for (int h : mesh_->fan(w)) {
    const int f = MeshTopology::face_of(h);
    if (found >= 0 && f > found) continue;
    const Pt &x = disk_[mesh_->to(h)], &y = disk_[mesh_->from(MeshTopology::prev(h))];
    if (orient(pw, x, b) >= 0 && orient(pw, b, y) >= 0) found = f;
  }
  if (found < 0) throw InternalError("refine: no target face around a vertex contains the walking direction");
  return found;
}

std::vector<Crossing> DiskWalk::crossings(const Pt& a, const Pt& b, int f) const {
  std::vector<Crossing> out;
  // Positions along the line a -> b: exact parameter of a point known to lie on it.
  const bool by_x = a.x() != b.x();
  const Q a0 = by_x ? Q(a.x()) : Q(a.y());
  const Q span = (by_x ? Q(b.x()) : Q(b.y())) - a0;
  auto position = [&](const Pt& p) { return ((by_x ? Q(p.x()) : Q(p.y())) - a0) / span; };
  auto contains_b = [&](int g) {
    const Triangle& t = faces_[g];
    return orient(disk_[t[0]], disk_[t[1]], b) >= 0 && orient(disk_[t[1]], disk_[t[2]], b) >= 0 &&
           orient(disk_[t[2]], disk_[t[0]], b) >= 0;
  };

  Q here = 0;  // position of the walk along a -> b
  int at_vertex = -1;
  for (int v : faces_[f])
    if (disk_[v] == a) at_vertex = v;
  const std::size_t cap = 16 + 4 * faces_.size();
  for (std::size_t step = 0;; ++step) {
    if (step > cap) throw InternalError("refine: walk along a source edge did not terminate");
    if (at_vertex >= 0) f = face_around(at_vertex, b);
    if (contains_b(f)) break;
    const Triangle& t = faces_[f];
    int o[3];
    for (int k = 0; k < 3; ++k) o[k] = orient(a, b, disk_[t[k]]);

    int exit = -1;  // the edge the line leaves through: from its right side to its left side
    for (int e = 0; e < 3; ++e)
      if (o[e] < 0 && o[(e + 1) % 3] > 0) exit = e;
    if (exit >= 0) {
      const int u = t[exit], v = t[(exit + 1) % 3];
      const Q ax(a.x()), ay(a.y()), dx = Q(b.x()) - ax, dy = Q(b.y()) - ay;
      const Q ux(disk_[u].x()), uy(disk_[u].y()), ex = Q(disk_[v].x()) - ux, ey = Q(disk_[v].y()) - uy;
      const Q den = dx * ey - dy * ex;
      const Q tq = ((ux - ax) * ey - (uy - ay) * ex) / den;
      if (tq > here) {
        const Q s = ((ux - ax) * dy - (uy - ay) * dx) / den;
        const Point2 &tu = target_[u], &tv = target_[v];
        const Q x = Q(tu.x) + s * (Q(tv.x) - Q(tu.x)), y = Q(tu.y) + s * (Q(tv.y) - Q(tu.y));
        out.push_back({u, v, CGAL::to_double(tq), {CGAL::to_double(x), CGAL::to_double(y)}});
        here = tq;
      }
      f = neighbour(f, exit);
      if (f < 0) throw InternalError("refine: walk along a source edge left the disk");
      at_vertex = -1;
      continue;
    }
    // The line leaves through a vertex: the nearest one on it strictly ahead of the walk.
    int w = -1;
    Q tw;
    for (int k = 0; k < 3; ++k) {
      if (o[k] != 0) continue;
      const Q tk = position(disk_[t[k]]);
      if (tk > here && (w < 0 || tk < tw)) { w = t[k]; tw = tk; }
    }
    if (w < 0) throw InternalError("refine: walk along a source edge found no way forward");
    out.push_back({w, -1, CGAL::to_double(tw), target_[w]});
    here = tw;
    at_vertex = w;
  }
  return out;
}

Point2 DiskWalk::target_point(const Pt& q, int f) const {
  const Triangle& t = faces_[f];
  const Pt &p0 = disk_[t[0]], &p1 = disk_[t[1]], &p2 = disk_[t[2]];
  auto area = [](const Pt& a, const Pt& b, const Pt& c) {
    return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
  };
  const double total = area(p0, p1, p2);
  const double l0 = area(q, p1, p2) / total, l1 = area(p0, q, p2) / total, l2 = 1 - l0 - l1;
  const Point2 &a = target_[t[0]], &b = target_[t[1]], &c = target_[t[2]];
  return {l0 * a.x + l1 * b.x + l2 * c.x, l0 * a.y + l1 * b.y + l2 * c.y};
}

}  // namespace lipmap::detail
