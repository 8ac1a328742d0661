// A uv map stored as float32 texture coordinates, as glTF stores TEXCOORD_0: (s, t) = (fl32(u), fl32(1 - v))
// with 1 - v evaluated in double and rounded once, read back as (u, v) = (s, 1 - t). The t axis points
// down, so a counterclockwise uv triangle is clockwise in (s, t).
//
// Plain rounding can flip or flatten a tiny triangle. The repair: an interior corner of such a triangle
// moves to a neighbouring float (at most 2 ulps in s and in t, smallest move first) when that makes every
// triangle around it valid; boundary vertices never move (they stay the float32 of their targets). The
// result is then checked in full, exactly (the engine's orientation predicate and exact turn counting, App. B):
//   * every face strictly clockwise in the float (s, t) AND strictly counterclockwise in (s, 1 - t)
//     evaluated in double;
//   * the one-ring of every interior vertex turns exactly once around it in (s, 1 - t).
// Std-only: the glTF writer includes it.
#pragma once

#include <cstddef>
#include <vector>

#include "engine/geometry.h"

namespace lipmap {

struct Float32Uv {
  std::vector<Point2> st;    // per vertex: (s, t), both float32 values (held as doubles)
  std::size_t adjusted = 0;  // interior vertices moved off plain rounding

  // The first fault that remains, if any (then the map cannot be stored as float32).
  int bad_face = -1;         // lowest face that is not valid as stored
  int bad_face_orientation = 0;  // that face's orientation in (s, 1 - t): 0 degenerate, -1 flipped, +1 (then
                                 // it is the (s, t) test that failed)
  int bad_vertex = -1;       // lowest interior vertex whose one-ring does not turn once (checked when no face is bad)
  int bad_vertex_turns = 0;  // its full turns (0 also when its corners do not close into one cycle)

  bool ok() const { return bad_face < 0 && bad_vertex < 0; }
};

// uv: one point per vertex; faces: counterclockwise in uv, every index in range (not checked). Boundary
// vertices are those on an edge that one face uses.
Float32Uv float32_texcoords(const std::vector<Point2>& uv, const std::vector<Triangle>& faces);

// Whether a triangle with these corners, stored by plain rounding (no repair: as a boundary vertex is stored),
// passes the face test above: strictly clockwise in the float (s, t) and counterclockwise in (s, 1 - t).
bool float32_face_valid(const Point2& a, const Point2& b, const Point2& c);

// Whether the triangle's doubled area, counterclockwise, exceeds (twice over) what moving each corner by half a
// float32 ulp at the corners' largest magnitude can change: then no rounding of its corners to float32 flips or
// flattens it. A thinner one that float32_face_valid accepts passed by the luck of the rounding, with a K near
// 1e7 as stored and far more in doubles.
bool float32_face_robust(const Point2& a, const Point2& b, const Point2& c);

// Rounds to float32, always: the compiler may not elide the conversion (see float32_uv.cpp). The glTF writer
// stores every FLOAT with it, so that what is written is what was checked.
float to_float32(double x);

}  // namespace lipmap
