// Stage "fixed-face split", after the optimization and before verify. A face whose three corners lie on the
// boundary polygon (a fixed face) is the same in every map with this boundary: no motion of the map changes it.
// When the polygon makes one so thin that its corners, stored as float32 texture coordinates (glTF's
// TEXCOORD_0, engine/float32_uv.h), may no longer form a positive triangle (float32_face_valid and
// float32_face_robust), the map cannot be stored however good it is in doubles, and its K is beyond 1e7 or past
// what doubles resolve (maze onto spiral_arm: 2e14, or infinite; docs/contract.md, point 6). One point
// on the face's chord (an original interior edge joining two of its corners, paper 4's refinement restricted to
// that edge) removes it: the new vertex is free, and placed towards the face across the chord it leaves four
// positive triangles of ordinary shape. Nothing else is inserted, so every other map is unchanged; nor when
// float32 cannot hold the polygon itself (beyond its range, or under 2^12 of its spacings across).
#pragma once

#include <vector>

#include "engine/disk_mesh.h"
#include "engine/geometry.h"
#include "engine/refine.h"

namespace lipmap {

struct FixedFaceSplit {
  int unstorable = 0;  // fixed faces whose stored corners may not be a positive triangle
  int split = 0;       // of them, those whose chord got a point (a face without an original chord stays as it is)
};

// source: the mesh that map refines; map: every face strictly positive (work scale); stored[k]: where boundary
// vertex loop[k] is stored (the caller's polygon, exactly). Splits in place: the new vertices are appended to
// map.inserted at t = 1/2 of their chord, their uv in the face across it.
FixedFaceSplit split_unstorable_fixed_faces(const DiskMesh& source, const std::vector<int>& loop,
                                            const std::vector<Point2>& stored, RefinedMap& map);

}  // namespace lipmap
