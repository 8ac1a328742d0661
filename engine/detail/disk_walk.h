// Walking in the disk image h_t(M_t) of the target mesh (paper 4, Fig. 10): point location for the
// composition and the exact crossings of a source edge's disk image with h_t(M_t)'s edges for the
// refinement. Internal to the compose and refine stages; includes CGAL through exact_predicates.h.
#pragma once

#include <vector>

#include "engine/detail/exact_predicates.h"
#include "engine/geometry.h"
#include "engine/mesh_topology.h"

namespace lipmap::detail {

// Where a segment A -> B of the disk meets h_t(M_t) strictly between its ends: either the interior of the
// edge (u, v), or the vertex u (v == -1). t in (0, 1) is the position along A -> B and uv the image in the
// target plane, each the exact value rounded to the nearest double (uv is M_t's own vertex at a vertex).
struct Crossing {
  int u = -1, v = -1;
  double t = 0;
  Point2 uv;
};

class DiskWalk {
public:
  // disk: h_t at every M_t vertex; target: M_t's own vertex positions; faces counterclockwise in the disk;
  // topology: M_t's (build_target_mesh's), kept by reference, so it must outlive the walk. When it is not
  // the topology of `faces` (a target mesh made by hand), the walk builds its own.
  DiskWalk(const std::vector<Point2>& disk, const std::vector<Point2>& target, const std::vector<Triangle>& faces,
           const MeshTopology& topology);
  DiskWalk(const DiskWalk&) = delete;  // may point at its own topology
  DiskWalk& operator=(const DiskWalk&) = delete;

  // A face whose closed disk triangle contains q, walking from `start`. Throws InternalError if q is
  // outside the disk triangulation.
  int locate(const Pt& q, int start, int* steps = nullptr) const;

  // The lowest-index face incident to vertex w.
  int face_at_vertex(int w) const;

  // The crossings of the segment a -> b, in order along it. start_face must contain a.
  std::vector<Crossing> crossings(const Pt& a, const Pt& b, int start_face) const;

  // The target-plane image of disk point q inside face f, by barycentric coordinates in double.
  Point2 target_point(const Pt& q, int f) const;

  const Pt& disk_point(int v) const { return disk_[v]; }
  const Triangle& face(int f) const { return faces_[f]; }

private:
  int neighbour(int f, int edge) const { return mesh_->across(f, edge); }  // across edge (corner edge, edge + 1)
  int face_around(int w, const Pt& b) const;

  std::vector<Pt> disk_;
  std::vector<Point2> target_;
  std::vector<Triangle> faces_;
  MeshTopology own_;
  const MeshTopology* mesh_ = nullptr;
};

}  // namespace lipmap::detail
