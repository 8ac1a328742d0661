// MeshTopology: counting sorts and short per-vertex sorts, O(F) for bounded valence and O(F log F) at worst;
// no hashing.
#include "engine/mesh_topology.h"

#include <algorithm>
#include <utility>

namespace lipmap {

MeshTopology::MeshTopology(int vertex_count, const std::vector<Triangle>& faces) : vertex_count_(vertex_count) {
  corner_.resize(faces.size() * 3);
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (int k = 0; k < 3; ++k) corner_[3 * f + k] = faces[f][k];
  build_edges();
  build_fans();
}

std::array<int, 2> MeshTopology::edge_vertices(int e) const {
  const int h = edge_uses_[edge_first_use_[e]];
  return {std::min(from(h), to(h)), std::max(from(h), to(h))};
}

int MeshTopology::find_edge(int a, int b) const {
  for (int h : fan(a)) {
    if (to(h) == b) return edge(h);
    if (from(prev(h)) == b) return edge(prev(h));
  }
  return -1;
}

// Half-edges bucketed by their lower vertex (a counting sort), each bucket sorted by (upper vertex, half-edge):
// the half-edges of one edge are then adjacent, the first of each run is the edge's first appearance. The
// buckets carry their upper vertex with them, so the sorts read contiguous memory.
void MeshTopology::build_edges() {
  const int H = halfedge_count();
  std::vector<int> begin(static_cast<std::size_t>(vertex_count_) + 1, 0);
  for (int h = 0; h < H; ++h) ++begin[std::min(from(h), to(h)) + 1];
  for (int v = 0; v < vertex_count_; ++v) begin[v + 1] += begin[v];
  std::vector<std::pair<int, int>> bucket(H);  // (upper vertex, half-edge); half-edges ascending per bucket
  {
    std::vector<int> fill(begin.begin(), begin.end() - 1);
    for (int h = 0; h < H; ++h) {
      const int a = from(h), b = to(h);
      bucket[fill[std::min(a, b)]++] = {std::max(a, b), h};
    }
  }
  std::vector<int> first(H);  // per half-edge: the first half-edge of its edge
  for (int v = 0; v < vertex_count_; ++v) {
    const auto b = bucket.begin() + begin[v], e = bucket.begin() + begin[v + 1];
    // Insertion sort: buckets hold a vertex's few edges, already ordered by half-edge. A crowded bucket (a
    // vertex of huge valence, or the many copies of a face that validate is about to refuse) is sorted in
    // O(k log k) instead: the same order, since (upper vertex, half-edge) pairs are distinct.
    if (e - b > 64) std::sort(b, e);
    else
      for (auto it = b + (b != e); it < e; ++it)
        for (auto j = it; j != b && *j < *(j - 1); --j) std::iter_swap(j, j - 1);
    for (auto it = b; it != e; ++it)
      first[it->second] = (it != b && it->first == (it - 1)->first) ? first[(it - 1)->second] : it->second;
  }
  edge_of_.resize(H);
  int edges = 0;
  for (int h = 0; h < H; ++h) edge_of_[h] = first[h] == h ? edges++ : edge_of_[first[h]];
  edge_first_use_.assign(static_cast<std::size_t>(edges) + 1, 0);
  for (int h = 0; h < H; ++h) ++edge_first_use_[edge_of_[h] + 1];
  for (int e = 0; e < edges; ++e) edge_first_use_[e + 1] += edge_first_use_[e];
  edge_uses_.resize(H);
  std::vector<int> fill(edge_first_use_.begin(), edge_first_use_.end() - 1);
  for (int h = 0; h < H; ++h) edge_uses_[fill[edge_of_[h]]++] = h;
  opposite_.assign(H, -1);
  for (int e = 0; e < edges; ++e)
    if (edge_first_use_[e + 1] - edge_first_use_[e] == 2) {
      const int a = edge_uses_[edge_first_use_[e]], b = edge_uses_[edge_first_use_[e] + 1];
      opposite_[a] = b;
      opposite_[b] = a;
    }
}

// Clockwise around v: from h (v -> a in face f) to next(opposite(h)), the half-edge leaving v in the face
// across (v, a). A boundary vertex's walk starts at the corner whose entering edge is a boundary edge and ends
// at the one whose leaving edge is; an interior vertex's walk starts at its highest face and closes.
void MeshTopology::build_fans() {
  const int H = halfedge_count(), V = vertex_count_;
  fan_begin_.assign(static_cast<std::size_t>(V) + 1, 0);
  boundary_next_.assign(V, -1);
  boundary_loops_.clear();
  fan_.clear();
  oriented_manifold_ = false;
  broken_fan_vertex_ = -1;
  for (int e = 0; e < edge_count(); ++e) {
    const int n = edge_use_count(e);
    if (n > 2) return;
    const int h = edge_uses_[edge_first_use_[e]];
    if (from(h) == to(h)) return;
    if (n == 2 && from(h) == from(edge_uses_[edge_first_use_[e] + 1])) return;
  }
  std::vector<int> begin(static_cast<std::size_t>(V) + 1, 0);
  for (int h = 0; h < H; ++h) ++begin[from(h) + 1];
  for (int v = 0; v < V; ++v) begin[v + 1] += begin[v];
  std::vector<int> corners(H);  // half-edges leaving each vertex, ascending
  {
    std::vector<int> fill(begin.begin(), begin.end() - 1);
    for (int h = 0; h < H; ++h) corners[fill[from(h)]++] = h;
  }
  fan_.resize(H);
  for (int v = 0; v < V; ++v) {
    const int b = begin[v], d = begin[v + 1] - b;
    int start = -1, starts = 0;
    for (int i = b; i < b + d; ++i)
      if (opposite(prev(corners[i])) < 0) { start = corners[i]; ++starts; }
    if (starts == 0 && d > 0) start = corners[b + d - 1];  // interior: the highest face
    int count = 0;
    bool ended = false;  // at the boundary edge leaving v, or back at the start
    for (int h = start; h >= 0 && count < d;) {
      fan_[b + count++] = h;
      const int o = opposite(h);
      if (o < 0) {
        boundary_next_[v] = to(h);
        ended = true;
        break;
      }
      h = next(o);
      if (h == start) ended = true;
      if (ended) break;
    }
    if ((starts > 1 || !ended || count != d) && broken_fan_vertex_ < 0) broken_fan_vertex_ = v;
  }
  if (broken_fan_vertex_ >= 0) {
    fan_.clear();
    std::fill(boundary_next_.begin(), boundary_next_.end(), -1);
    return;
  }
  fan_begin_ = std::move(begin);
  oriented_manifold_ = true;
  std::vector<char> seen(V, 0);
  for (int start = 0; start < V; ++start) {
    if (boundary_next_[start] < 0 || seen[start]) continue;
    std::vector<int> loop;
    for (int v = start; !seen[v]; v = boundary_next_[v]) {
      seen[v] = 1;
      loop.push_back(v);
    }
    boundary_loops_.push_back(std::move(loop));
  }
}

}  // namespace lipmap
