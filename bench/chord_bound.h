// A lower bound on the points any answer must insert on the chords of a mesh (interior edges joining two
// boundary vertices), for bench_quality's chordLB column. Bench only: it reads the answer's classification.
//
// The refined maps of lipmap (and of the paper, section 4) keep every source edge as a chain of refined edges:
// points are inserted on edges or inside faces, and each refined triangle lies in one source triangle. A chord's
// ends are pinned at polygon vertices P(a) and P(b), so its image is a polygonal path from P(a) to P(b) whose
// bends are points inserted on it. The map lifts to the immersed disk D of its triangulation of P (a simple
// polygon's interior, or the immersed disk of a self-overlapping one, paper 3), so that path lies in D and needs
// at least link(P(a), P(b)) - 1 points, link being the fewest straight links of a path in D. Chords are
// distinct edges, so the bounds add up.
//
// The link distance is bounded from below with the triangulation of P without interior vertices that classify
// found (the same immersion as the answer): its dual is a tree, and any path from a to b crosses, in order, the
// diagonals on the tree path from the triangles around a to those around b (the sleeve). A straight link crosses
// a run of consecutive sleeve diagonals, and a line crossing them all (each diagonal's left end on one side, its
// right end on the other) exists for every such run. The greedy cover of the sleeve by the longest such runs,
// starting at P(a) and ending at P(b) (points the first and last lines must pass through), is the least number
// of runs, hence at most the number of links. The test for a run is a relaxation (a line rather than a segment
// inside D) and takes near-ties as crossable, so floating point only ever lowers the bound.
// On a simple polygon, a chord whose straight image leaves P (decided exactly) needs a point as well; the larger
// of the two counts is taken for each chord.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <unordered_map>
#include <utility>
#include <vector>

#include "engine/disk_mesh.h"
#include "engine/flip_check.h"
#include "engine/geometry.h"

namespace lipmap::bench {

// Unit normals n with n . v >= 0 for every constraint v given so far: an arc [lo, hi] of angles (at most pi
// wide), the whole circle before the first constraint. kSlack widens each constraint a little (conservative).
class NormalArc {
public:
  // False once no normal is left.
  bool add(double vx, double vy) {
    if (empty_) return false;
    if (vx == 0 && vy == 0) return true;  // coincident points: no constraint
    constexpr double kSlack = 1e-9, kPi = 3.14159265358979323846;
    double phi = std::atan2(vy, vx);
    if (!any_) {
      any_ = true;
      lo_ = phi - kPi / 2 - kSlack;
      hi_ = phi + kPi / 2 + kSlack;
      return true;
    }
    const double mid = 0.5 * (lo_ + hi_);
    while (phi < mid - kPi) phi += 2 * kPi;
    while (phi > mid + kPi) phi -= 2 * kPi;
    lo_ = std::max(lo_, phi - kPi / 2 - kSlack);
    hi_ = std::min(hi_, phi + kPi / 2 + kSlack);
    empty_ = lo_ > hi_;
    return !empty_;
  }

private:
  bool any_ = false, empty_ = false;
  double lo_ = 0, hi_ = 0;
};

// Whether the straight segment between polygon vertices a and b leaves the simple counterclockwise polygon p
// (exact orientation tests): it must start into the interior angle at both ends and touch no other edge.
inline bool chord_leaves_simple_polygon(const std::vector<Point2>& p, int a, int b) {
  const int n = static_cast<int>(p.size());
  auto orient = [&](int i, int j, int k) {
    return orientation_sign(p[static_cast<std::size_t>(i)], p[static_cast<std::size_t>(j)], p[static_cast<std::size_t>(k)]);
  };
  auto into_interior = [&](int v, int w) {
    const int next = (v + 1) % n, prev = (v + n - 1) % n;
    const bool left_of_next = orient(v, next, w) > 0, right_of_prev = orient(v, prev, w) < 0;
    return orient(prev, v, next) > 0 ? left_of_next && right_of_prev : left_of_next || right_of_prev;
  };
  if (!into_interior(a, b) || !into_interior(b, a)) return true;
  for (int k = 0; k < n; ++k) {
    const int k2 = (k + 1) % n;
    if (k == a || k == b || k2 == a || k2 == b) continue;
    const int o1 = orient(a, b, k), o2 = orient(a, b, k2), o3 = orient(k, k2, a), o4 = orient(k, k2, b);
    if (o1 * o2 <= 0 && o3 * o4 <= 0 && (o1 != 0 || o2 != 0)) return true;  // touches or crosses edge k
  }
  return false;
}

struct ChordBound {
  long long points = 0;  // the bound: points needed on the chords, summed
  int chords = 0;        // chords of the mesh
  int bent = 0;          // chords that need at least one point
};

// p: the polygon (p[k] is the image of mesh.boundary_loop[k]); triangulation: P's triangles of polygon vertex
// indices, counterclockwise, no interior vertices (Classification::triangulation); simple: P is a simple polygon.
inline ChordBound chord_lower_bound(const DiskMesh& mesh, const std::vector<Point2>& p,
                                    const std::vector<Triangle>& triangulation, bool simple) {
  ChordBound out;
  const int n = static_cast<int>(p.size()), nt = static_cast<int>(triangulation.size());
  if (n < 3 || nt != n - 2) return out;
  std::vector<int> at(mesh.vertices.size(), -1);
  for (int k = 0; k < n; ++k) at[static_cast<std::size_t>(mesh.boundary_loop[static_cast<std::size_t>(k)])] = k;
  // The dual tree: across[3 f + c] is the triangle on the other side of edge (t[c], t[c + 1]) of triangle f, or -1.
  std::unordered_map<long long, int> half;  // directed edge (i, j) -> 3 f + c
  for (int f = 0; f < nt; ++f)
    for (int c = 0; c < 3; ++c)
      half[static_cast<long long>(triangulation[f][c]) * n + triangulation[f][(c + 1) % 3]] = 3 * f + c;
  std::vector<int> across(3 * static_cast<std::size_t>(nt), -1);
  std::vector<std::vector<int>> fan(n);
  for (int f = 0; f < nt; ++f)
    for (int c = 0; c < 3; ++c) {
      const int i = triangulation[f][c], j = triangulation[f][(c + 1) % 3];
      const auto it = half.find(static_cast<long long>(j) * n + i);
      if (it != half.end()) across[3 * f + c] = it->second / 3;
      fan[i].push_back(f);
    }
  std::vector<int> parent(nt), via(nt), seen(nt, -1), goal(nt, -1);  // seen, goal: stamped with the chord's query
  int query = 0;
  for (int e = 0; e < mesh.topology.edge_count(); ++e) {
    if (mesh.topology.is_boundary_edge(e)) continue;
    const std::array<int, 2> ends = mesh.topology.edge_vertices(e);
    const int a = at[static_cast<std::size_t>(ends[0])], b = at[static_cast<std::size_t>(ends[1])];
    if (a < 0 || b < 0) continue;
    ++out.chords;
    // The sleeve: breadth-first from the triangles around a to the first one around b.
    ++query;
    std::deque<int> queue;
    for (int f : fan[a]) {
      seen[f] = query;
      parent[f] = -1;
      queue.push_back(f);
    }
    for (int f : fan[b]) goal[f] = query;
    int hit = -1;
    while (!queue.empty() && hit < 0) {
      const int f = queue.front();
      queue.pop_front();
      if (goal[f] == query) hit = f;
      for (int c = 0; c < 3 && hit < 0; ++c) {
        const int g = across[3 * f + c];
        if (g < 0 || seen[g] == query) continue;
        seen[g] = query;
        parent[g] = f;
        via[g] = 3 * f + c;
        queue.push_back(g);
      }
    }
    if (hit < 0) continue;  // not a disk triangulation: no bound for this chord
    // (left, right) ends of each diagonal in the order the path crosses them, between P(a) and P(b). Leaving
    // triangle f across its counterclockwise edge (i, j), the path has j on its left and i on its right.
    std::vector<std::pair<Point2, Point2>> sleeve{{p[a], p[a]}};
    std::vector<std::pair<Point2, Point2>> diagonals;
    for (int f = hit; parent[f] >= 0; f = parent[f]) {
      const Triangle& t = triangulation[via[f] / 3];
      const int c = via[f] % 3;
      diagonals.push_back({p[t[(c + 1) % 3]], p[t[c]]});
    }
    sleeve.insert(sleeve.end(), diagonals.rbegin(), diagonals.rend());
    sleeve.push_back({p[b], p[b]});
    // Greedy cover by runs that one line crosses: every left end on the line's left of every right end.
    int links = 1;
    std::size_t start = 0;
    NormalArc arc;
    auto extend = [&](NormalArc& x, std::size_t from, std::size_t to) {
      bool ok = true;
      for (std::size_t k = from; k <= to && ok; ++k)
        ok = x.add(sleeve[to].first.x - sleeve[k].second.x, sleeve[to].first.y - sleeve[k].second.y) &&
             x.add(sleeve[k].first.x - sleeve[to].second.x, sleeve[k].first.y - sleeve[to].second.y);
      return ok;
    };
    for (std::size_t i = 0; i < sleeve.size(); ++i) {
      NormalArc next = arc;
      if (extend(next, start, i)) {
        arc = next;
        continue;
      }
      ++links;
      start = i;
      arc = NormalArc();
      extend(arc, i, i);
    }
    int need = links - 1;
    if (simple && need == 0 && chord_leaves_simple_polygon(p, a, b)) need = 1;
    out.points += need;
    out.bent += need > 0;
  }
  return out;
}

}  // namespace lipmap::bench
