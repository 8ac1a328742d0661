// Stage "slide", after optimize (or the extremal relaxation): each inserted point slides along its original
// edge to where its faces are least distorted, uv unchanged.
//
// Where on its edge an inserted point lies is a free choice of the answer (docs/contract.md, point 1: any
// a + t (b - a) with 0 < t < 1), and refinement makes it for exactness, not for quality: t is where the edge
// crossed the target mesh in the disk (paper 4), or a chord's midpoint (engine/untangle.h). The uv of the map
// does not depend on it; the 3D triangles do, and so does the distortion K = sigma1 / sigma2 of every face at
// the point. Sliding keeps everything else: the points of an edge keep their order, so each refined face keeps
// its corners in cyclic order on the boundary of its convex source triangle, with no three on one original edge:
// still a positive, non-degenerate triangle of the same surface, and the refined mesh is the same surface as
// before (contract points 1 and 5). Orientation, angle sums and removability are decided in uv and by the
// points' order, so they do not change either (points 3, 4 and 6); verify checks the answer as always.
//
// The objective is the one the stage before lowered: the area-weighted mean K (optimize: a point's move changes
// only its own faces, whose 3D areas add up to a constant, so a lower sum of area x K over them is a lower mean
// over the whole map), or max K (method extremal: the largest K over the point's faces). One point at a time,
// a sampled search of its interval refined by golden sections, a move kept only when it lowers the objective;
// a few sweeps over all points.
#pragma once

#include "engine/cancel.h"
#include "engine/disk_mesh.h"
#include "engine/refine.h"

namespace lipmap {

enum class SlideObjective { mean_k, max_k };

struct Sliding {
  bool ran = false;
  int points_moved = 0;  // inserted points whose t changed
  int sweeps = 0;
};

// map: a refined map of source at the working scale (map.vertices[v] for v >= source vertices is the lerp of its
// InsertedVertex), every face strictly positive. Changes map.inserted[i].t and map.vertices of inserted points
// only. Throws Cancelled.
Sliding slide_inserted_points(const DiskMesh& source, RefinedMap& map, SlideObjective objective,
                              const CancelToken* cancel = nullptr);

}  // namespace lipmap
