// Turning number and spike vertices of a closed polygon, exactly (App. B). Internal: includes CGAL.
#pragma once

#include <vector>

#include "engine/detail/plane_angles.h"

namespace lipmap::detail {

// Which half-plane of directions an edge a -> b points into: upper is [0, pi), lower is [pi, 2 pi).
inline bool points_up(const Pt& a, const Pt& b) {
  const int dy = compare_coord(b.y(), a.y());
  return dy > 0 || (dy == 0 && b.x() > a.x());
}

// Number of full counterclockwise turns of the edge direction around P, counted exactly: each turn at a
// vertex is in [-pi, pi) (a spike, where the polygon doubles back, is the clockwise half turn because its
// interior angle is 2 pi), and the direction crosses angle 0 upwards on left turns from the lower to the
// upper half-plane and downwards on right turns from the upper to the lower one.
inline int turning_number(const std::vector<Pt>& p) {
  const int n = static_cast<int>(p.size());
  int turns = 0;
  for (int i = 0; i < n; ++i) {
    const Pt &a = p[(i + n - 1) % n], &b = p[i], &c = p[(i + 1) % n];
    const bool up_in = points_up(a, b), up_out = points_up(b, c);
    const int o = orient(a, b, c);
    if (o > 0 && !up_in && up_out) ++turns;
    if (o < 0 && up_in && !up_out) --turns;
    if (o == 0 && same_ray(b, a, c) && up_in) --turns;  // spike: v_{i+1} back towards v_{i-1}
  }
  return turns;
}

// A spike vertex (v_{i+1} on the ray towards v_{i-1}) has interior angle 2 pi: zero sweep plus one turn.
inline std::vector<int> spike_turns(const std::vector<Pt>& p) {
  const int n = static_cast<int>(p.size());
  std::vector<int> spikes(n);
  for (int i = 0; i < n; ++i) spikes[i] = sector(p[i], p[(i + 1) % n], p[(i + n - 1) % n]) == 0;
  return spikes;
}

// One corner of a vertex's one-ring: the face (center, next, prev), counterclockwise, whose corner sweeps
// from the ray towards `from` to the ray towards `to` (the images of next and prev, or points on those edges).
struct FanCorner {
  int next, prev;
  Pt from, to;
};

// Full turns of the one-ring around an interior vertex (App. B): the corner sweeps chained from next to
// prev, counted where they pass the first corner's `from` ray. 1 for a locally injective one-ring (positive
// triangles can still wind twice, paper Fig. 1a); 0 when the corners do not close into one cycle.
inline int fan_turns(const Pt& center, const std::vector<FanCorner>& fan) {
  if (fan.empty()) return 0;
  const Pt start = fan[0].from;
  int at = fan[0].next, turns = 0;
  for (std::size_t step = 0; step < fan.size(); ++step) {
    const FanCorner* corner = nullptr;
    for (const FanCorner& c : fan)
      if (c.next == at) corner = &c;
    if (!corner) return 0;
    turns += extra_turn(center, start, corner->from, corner->to);
    at = corner->prev;
  }
  return at == fan[0].next ? turns : 0;
}

}  // namespace lipmap::detail
