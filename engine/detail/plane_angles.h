// Exact angle bookkeeping in the plane (paper App. B), for engine .cpp files only: this header pulls in
// CGAL and must never be included by a public header.
//
// An angle at a centre c is swept counterclockwise from one direction (towards point u) to another
// (towards point w). Its value is phi + 2*pi*turns with phi in [0, 2*pi) the plain sweep and turns >= 0
// counted separately, so angles are never formed in floating point: every decision below is an exact
// orientation test or an exact comparison of input coordinates.
#pragma once

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

namespace lipmap::detail {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Pt = Kernel::Point_2;

// +1: a, b, c turn left (counterclockwise); -1: right; 0: collinear.
inline int orient(const Pt& a, const Pt& b, const Pt& c) {
  return static_cast<int>(CGAL::orientation(a, b, c));
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

}  // namespace lipmap::detail
