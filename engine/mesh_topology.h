// The adjacency of a triangle mesh, built once from its face list where the mesh is born (validate for the
// source mesh M, build_target_mesh for M_t, verify for the refined mesh) and read by every stage after it.
//
// Half-edge h = 3 f + k runs from corner k of face f to corner k + 1: face f lies on its left. An edge is an
// unordered vertex pair; edges are numbered in order of first appearance when the faces are walked in order,
// corners (0, 1), (1, 2), (2, 0) (the "edge" index of validate's errors). Any face list whose indices are in
// range can be built, so that validate can name what is wrong with it; the fans and the boundary loops exist
// only for an oriented manifold (every edge in one or two faces, two in opposite directions, the faces around
// every vertex one fan).
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "engine/geometry.h"

namespace lipmap {

// A read-only run of half-edge ids.
struct HalfedgeRange {
  const int* first = nullptr;
  const int* last = nullptr;
  const int* begin() const { return first; }
  const int* end() const { return last; }
  std::size_t size() const { return static_cast<std::size_t>(last - first); }
  bool empty() const { return first == last; }
  int operator[](std::size_t i) const { return first[i]; }
  int front() const { return *first; }
  int back() const { return *(last - 1); }
};

class MeshTopology {
public:
  MeshTopology() = default;
  // Precondition: every index in [0, vertex_count). Faces that repeat a corner are accepted (their degenerate
  // half-edge is an edge of its own), the fans then do not exist.
  MeshTopology(int vertex_count, const std::vector<Triangle>& faces);

  int vertex_count() const { return vertex_count_; }
  int face_count() const { return static_cast<int>(corner_.size() / 3); }
  int halfedge_count() const { return static_cast<int>(corner_.size()); }
  int edge_count() const { return static_cast<int>(edge_first_use_.size()) - 1; }

  // ---- half-edges ----
  static int face_of(int h) { return h / 3; }
  static int next(int h) { return h % 3 == 2 ? h - 2 : h + 1; }
  static int prev(int h) { return h % 3 == 0 ? h + 2 : h - 1; }
  int from(int h) const { return corner_[h]; }
  int to(int h) const { return corner_[next(h)]; }
  int edge(int h) const { return edge_of_[h]; }
  // The other half-edge of h's edge when exactly two faces use that edge, else -1 (boundary or non-manifold).
  int opposite(int h) const { return opposite_[h]; }
  // The face across edge (corner k, corner k + 1) of face f, or -1.
  int across(int f, int k) const {
    const int o = opposite(3 * f + k);
    return o < 0 ? -1 : o / 3;
  }

  // ---- edges ----
  int edge_use_count(int e) const { return edge_first_use_[e + 1] - edge_first_use_[e]; }
  // The half-edges along edge e, ascending.
  HalfedgeRange edge_uses(int e) const {
    return {edge_uses_.data() + edge_first_use_[e], edge_uses_.data() + edge_first_use_[e + 1]};
  }
  // The edge's two vertices, the lower index first.
  std::array<int, 2> edge_vertices(int e) const;
  bool is_boundary_edge(int e) const { return edge_use_count(e) == 1; }

  // ---- oriented manifolds only ----
  bool oriented_manifold() const { return oriented_manifold_; }
  // The lowest vertex whose faces do not form one fan, when every edge is fine; else -1.
  int first_vertex_with_broken_fan() const { return broken_fan_vertex_; }

  // The half-edges leaving v, one per face at v, clockwise (each next one is next(opposite(h))): for a
  // boundary vertex from the face on the boundary edge that enters v to the face on the one that leaves it;
  // for an interior vertex starting at its highest-index face. (Clockwise and this start are the order in
  // which the stages have always visited one-rings; their results depend on it through work orders.)
  // The counterclockwise fan, in which a face's corner sweeps from its next vertex to its previous one
  // (paper App. B), is this range read backwards. Empty unless oriented_manifold().
  HalfedgeRange fan(int v) const {
    return {fan_.data() + fan_begin_[v], fan_.data() + fan_begin_[v + 1]};
  }
  bool is_boundary_vertex(int v) const { return boundary_next_[v] >= 0; }
  // The edge joining a and b, or -1 (a walk around a's fan).
  int find_edge(int a, int b) const;
  // For a boundary vertex, the next vertex on its boundary loop (interior on the left); else -1.
  int boundary_next(int v) const { return boundary_next_[v]; }
  // Boundary loops following the boundary half-edges (interior on the left), listed by their lowest vertex,
  // each starting there.
  const std::vector<std::vector<int>>& boundary_loops() const { return boundary_loops_; }

private:
  void build_edges();
  void build_fans();

  int vertex_count_ = 0;
  std::vector<int> corner_;           // per half-edge: its from vertex (the faces, flattened)
  std::vector<int> edge_of_;          // per half-edge
  std::vector<int> edge_first_use_;   // per edge, CSR into edge_uses_ (size E + 1)
  std::vector<int> edge_uses_;        // half-edges of each edge, ascending
  std::vector<int> opposite_;         // per half-edge: opposite(h), stored (the walks' hottest lookup)
  bool oriented_manifold_ = false;
  int broken_fan_vertex_ = -1;
  std::vector<int> fan_begin_;        // per vertex, CSR into fan_ (size V + 1)
  std::vector<int> fan_;
  std::vector<int> boundary_next_;
  std::vector<std::vector<int>> boundary_loops_;
};

}  // namespace lipmap
