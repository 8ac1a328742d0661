// The engine's one exact module for orientation and angle bookkeeping in the plane (paper App. B): every
// orientation test, angle sum (count of full turns) and turning number of the engine is decided here. For
// engine .cpp files only: this header pulls in CGAL and must never be included by a public header.
//
// An angle at a centre c is swept counterclockwise from one direction (towards point u) to another
// (towards point w). Its value is phi + 2*pi*turns with phi in [0, 2*pi) the plain sweep and turns >= 0
// counted separately, so angles are never formed in floating point: every decision below is an exact
// orientation test (CGAL's filtered predicates on the doubles as they are) or an exact comparison of input
// coordinates.
#pragma once

#include <cmath>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include "engine/geometry.h"

namespace lipmap::detail {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Pt = Kernel::Point_2;

inline Pt pt(const Point2& p) { return Pt(p.x, p.y); }

// +1: a, b, c turn left (counterclockwise); -1: right; 0: collinear.
inline int orient(const Pt& a, const Pt& b, const Pt& c) {
  return static_cast<int>(CGAL::orientation(a, b, c));
}
inline int orient(const Point2& a, const Point2& b, const Point2& c) {
  return orient(Pt(a.x, a.y), Pt(b.x, b.y), Pt(c.x, c.y));
}

// Three points of space on one line (a triangle of zero area), exactly. They are collinear exactly when the
// three coordinate-plane projections of the triangle all have a zero orientation determinant. A projection
// whose determinant, computed in double, exceeds Shewchuk's forward error bound for it (orient2d's
// ccwerrboundA, valid without underflow: the products are checked to be far from it) is certainly not
// zero, so the triangle is not flat: that settles almost every call at the cost of a few multiplications;
// the rest go to CGAL's exact predicate.
inline bool collinear(const Point3& a, const Point3& b, const Point3& c) {
  constexpr double eps = 0x1p-53;
  constexpr double bound = (3.0 + 16.0 * eps) * eps;
  auto certainly_nonzero = [&](double ax, double ay, double bx, double by, double cx, double cy) {
    const double l = (ax - cx) * (by - cy), r = (ay - cy) * (bx - cx);
    const double sum = std::abs(l) + std::abs(r);
    return sum > 0x1p-900 && sum < 0x1p+900 && std::abs(l - r) > bound * sum;
  };
  if (certainly_nonzero(a.x, a.y, b.x, b.y, c.x, c.y) || certainly_nonzero(a.y, a.z, b.y, b.z, c.y, c.z) ||
      certainly_nonzero(a.z, a.x, b.z, b.x, c.z, c.x))
    return false;
  using P3 = Kernel::Point_3;
  return CGAL::collinear(P3(a.x, a.y, a.z), P3(b.x, b.y, b.z), P3(c.x, c.y, c.z));
}

inline int compare_coord(double a, double b) { return (a > b) - (a < b); }

// For collinear c, u, w with u != c and w != c: do u and w lie on the same side of c?
inline bool same_ray(const Pt& c, const Pt& u, const Pt& w) {
  const int ux = compare_coord(u.x(), c.x());
  if (ux != 0) return ux == compare_coord(w.x(), c.x());
  return compare_coord(u.y(), c.y()) == compare_coord(w.y(), c.y());
}

// Where the direction c->w lies when sweeping counterclockwise from c->u:
// 0 on the ray itself, 1 in the open left half-plane, 2 on the opposite ray, 3 in the open right half-plane.
inline int sector(const Pt& c, const Pt& u, const Pt& w) {
  const int o = orient(c, u, w);
  if (o > 0) return 1;
  if (o < 0) return 3;
  return same_ray(c, u, w) ? 0 : 2;
}

// Is direction c->a met strictly before direction c->b when sweeping counterclockwise from c->u?
// (Sweep positions are in [0, 2*pi); equal directions are not "before" each other.)
inline bool sweeps_before(const Pt& c, const Pt& u, const Pt& a, const Pt& b) {
  const int sa = sector(c, u, a);
  const int sb = sector(c, u, b);
  if (sa != sb) return sa < sb;
  if (sa == 1 || sa == 3) return orient(c, a, b) > 0;
  return false;
}

// Adding the sweep u->w to the sweep w->x at c: 1 when the sum passes the start direction u again (one more
// full turn than the two turn counts add up to), else 0. This is the delta of App. B, derived from the
// sweep order rather than case by case, so collinear and reflex cases need no special handling.
inline int extra_turn(const Pt& c, const Pt& u, const Pt& w, const Pt& x) {
  return sweeps_before(c, u, x, w) ? 1 : 0;
}

// ---- angle sums -------------------------------------------------------------------------------------

// The full turns of a chain of corner sweeps at c, each from the ray towards `from` counterclockwise to the
// ray towards `to`, the next corner starting where the last one ended: the number of times the chained
// sweep passes the first corner's `from` ray. The chained angle is sweep(first from, last to) + 2*pi*turns;
// for a closed chain (the last `to` is the first `from`) it is 2*pi*turns, the angle sum of App. B.
class TurnCount {
public:
  TurnCount(const Pt& center, const Pt& start) : center_(center), start_(start) {}
  void add(const Pt& from, const Pt& to) { turns_ += extra_turn(center_, start_, from, to); }
  int turns() const { return turns_; }

private:
  Pt center_, start_;
  int turns_ = 0;
};

// The interior angle at a polygon vertex c with neighbours next and prev is sweep(next, prev) + 2*pi*turns;
// a spike (prev on the ray towards next) has sweep 0 but interior angle 2*pi, so its rotation index, the
// number of extra full turns, is turns - 1 (App. B).
inline int rotation_index(const Pt& c, const Pt& next, const Pt& prev, int turns) {
  return turns - (sector(c, next, prev) == 0 ? 1 : 0);
}


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

// Full turns of a closed chain of corner sweeps at c when every sweep is strictly between 0 and pi (each
// corner's triangle (c, from, to) strictly positive; the caller has checked it): the chained angle is
// 2 pi * turns, and each full turn passes the direction of angle 0 exactly once, so the turns are the
// sweeps that start in the lower half-plane of directions [pi, 2 pi) and end in the upper one [0, pi). The
// same count as TurnCount over the chain, from coordinate comparisons only (no orientation test).
class PositiveChainTurns {
public:
  explicit PositiveChainTurns(const Pt& center) : center_(center) {}
  void add(const Pt& from, const Pt& to) { turns_ += (!points_up(center_, from) && points_up(center_, to)) ? 1 : 0; }
  int turns() const { return turns_; }

private:
  Pt center_;
  int turns_ = 0;
};

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
  int at = fan[0].next;
  TurnCount count(center, start);
  for (std::size_t step = 0; step < fan.size(); ++step) {
    const FanCorner* corner = nullptr;
    for (const FanCorner& c : fan)
      if (c.next == at) corner = &c;
    if (!corner) return 0;
    count.add(corner->from, corner->to);
    at = corner->prev;
  }
  return at == fan[0].next ? count.turns() : 0;
}

}  // namespace lipmap::detail
