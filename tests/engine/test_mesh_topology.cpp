// MeshTopology (engine/mesh_topology.h) against a brute-force checker written here: edges by scanning every
// face pair, fans and boundary loops by searching the face list for directed edges. Meshes: grids with random
// diagonals, open and closed fans, disks grown by random gluing, each also with its vertices renumbered, its
// faces reordered and their corners rotated.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "engine/mesh_topology.h"
#include "tests/support/grid_cells.h"

namespace lipmap {
namespace {

struct Faces {
  int vertices = 0;
  std::vector<Triangle> faces;
};

Faces grid(int w, int h, std::mt19937& rng) {
  Faces m;
  m.vertices = (w + 1) * (h + 1);
  m.faces = testgen::grid_triangles(w, h, [&rng](int, int) { return rng() % 2 != 0; });
  return m;
}

// Centre 0 and a ring 1..k; closed: k triangles (centre interior), open: k - 1 (centre on the boundary).
Faces fan_mesh(int k, bool closed) {
  Faces m;
  m.vertices = k + 1;
  for (int i = 0; i < (closed ? k : k - 1); ++i) m.faces.push_back({0, 1 + i, 1 + (i + 1) % k});
  return m;
}

// A triangle grown by random steps: glue a new vertex onto a boundary edge, or close the corner at a boundary
// vertex with one triangle (when that keeps a disk). Irregular valences, interior vertices of degree 3 and up.
Faces grown(int steps, std::mt19937& rng) {
  Faces m;
  m.vertices = 3;
  m.faces.push_back({0, 1, 2});
  std::vector<int> loop = {0, 1, 2};  // boundary in face direction
  std::set<std::pair<int, int>> edges = {{0, 1}, {1, 2}, {0, 2}};
  for (int s = 0; s < steps; ++s) {
    const int n = static_cast<int>(loop.size());
    const int i = static_cast<int>(rng() % n);
    const int a = loop[i], b = loop[(i + 1) % n], c = loop[(i + 2) % n];
    if (rng() % 3 == 0 && n > 3 && !edges.count({std::min(a, c), std::max(a, c)})) {
      m.faces.push_back({a, c, b});  // boundary a -> b -> c becomes a -> c
      edges.insert({std::min(a, c), std::max(a, c)});
      loop.erase(loop.begin() + (i + 1) % n);
    } else {
      const int v = m.vertices++;
      m.faces.push_back({a, v, b});  // boundary a -> b becomes a -> v -> b
      edges.insert({std::min(a, v), std::max(a, v)});
      edges.insert({std::min(b, v), std::max(b, v)});
      loop.insert(loop.begin() + i + 1, v);
    }
  }
  return m;
}

Faces scrambled(Faces m, std::mt19937& rng) {
  std::vector<int> perm(m.vertices);
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), rng);
  for (Triangle& t : m.faces) {
    for (int& v : t) v = perm[v];
    std::rotate(t.begin(), t.begin() + rng() % 3, t.end());
  }
  std::shuffle(m.faces.begin(), m.faces.end(), rng);
  return m;
}

// ---- the brute-force checker ------------------------------------------------------------------------

bool has_directed(const Triangle& t, int a, int b) {
  for (int k = 0; k < 3; ++k)
    if (t[k] == a && t[(k + 1) % 3] == b) return true;
  return false;
}

bool has_vertex(const Triangle& t, int v) { return t[0] == v || t[1] == v || t[2] == v; }

void check(const Faces& m, const char* what) {
  SCOPED_TRACE(what);
  const MeshTopology topo(m.vertices, m.faces);
  const int F = static_cast<int>(m.faces.size());
  ASSERT_EQ(topo.face_count(), F);
  ASSERT_TRUE(topo.oriented_manifold());

  // Edges numbered by first appearance; the face across each edge by scanning every other face.
  std::map<std::pair<int, int>, int> number;
  std::map<std::pair<int, int>, int> uses;
  for (int f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = m.faces[f][k], b = m.faces[f][(k + 1) % 3];
      const std::pair<int, int> key{std::min(a, b), std::max(a, b)};
      number.emplace(key, static_cast<int>(number.size()));
      ++uses[key];
    }
  ASSERT_EQ(topo.edge_count(), static_cast<int>(number.size()));
  EXPECT_EQ(m.vertices - topo.edge_count() + F, 1) << "Euler characteristic of a disk";
  for (int f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) {
      const int h = 3 * f + k, a = m.faces[f][k], b = m.faces[f][(k + 1) % 3];
      ASSERT_EQ(topo.from(h), a);
      ASSERT_EQ(topo.to(h), b);
      const int e = number.at({std::min(a, b), std::max(a, b)});
      ASSERT_EQ(topo.edge(h), e);
      EXPECT_EQ(topo.edge_vertices(e), (std::array<int, 2>{std::min(a, b), std::max(a, b)}));
      int across = -1;
      for (int g = 0; g < F; ++g)
        if (g != f && has_vertex(m.faces[g], a) && has_vertex(m.faces[g], b)) {
          ASSERT_EQ(across, -1) << "a disk edge has at most two faces";
          across = g;
          ASSERT_TRUE(has_directed(m.faces[g], b, a)) << "neighbours list their shared edge oppositely";
        }
      ASSERT_EQ(topo.across(f, k), across);
      EXPECT_EQ(topo.is_boundary_edge(e), across < 0);
      if (across >= 0) {
        ASSERT_TRUE(has_directed(m.faces[topo.opposite(h) / 3], b, a));
      }
      EXPECT_EQ(topo.find_edge(a, b), e);
      EXPECT_EQ(topo.find_edge(b, a), e);
    }

  // Boundary: the directed edges with no reverse; one loop from the lowest boundary vertex.
  std::map<int, int> boundary_next;
  for (const Triangle& t : m.faces)
    for (int k = 0; k < 3; ++k)
      if (uses[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}] == 1)
        boundary_next[t[k]] = t[(k + 1) % 3];
  ASSERT_EQ(topo.boundary_loops().size(), 1u);
  const std::vector<int>& loop = topo.boundary_loops()[0];
  ASSERT_EQ(loop.size(), boundary_next.size());
  EXPECT_EQ(loop[0], boundary_next.begin()->first) << "the loop starts at its lowest vertex";
  for (std::size_t i = 0; i < loop.size(); ++i)
    EXPECT_EQ(boundary_next.at(loop[i]), loop[(i + 1) % loop.size()]) << "interior on the left";

  // Fans: every face at v once, clockwise (the next face holds the reverse of the edge leaving v), from the
  // face on the entering boundary edge to the one on the leaving edge, or, inside, from the highest face.
  for (int v = 0; v < m.vertices; ++v) {
    std::vector<int> at_v;
    for (int f = 0; f < F; ++f)
      if (has_vertex(m.faces[f], v)) at_v.push_back(f);
    const HalfedgeRange fan = topo.fan(v);
    ASSERT_EQ(fan.size(), at_v.size());
    std::vector<int> seen;
    for (int h : fan) {
      ASSERT_EQ(m.faces[h / 3][h % 3], v);
      seen.push_back(h / 3);
    }
    std::sort(seen.begin(), seen.end());
    ASSERT_EQ(seen, at_v);
    for (std::size_t i = 0; i + 1 < fan.size(); ++i) {
      const Triangle& t = m.faces[fan[i] / 3];
      const int leaving_to = t[(fan[i] % 3 + 1) % 3];
      ASSERT_TRUE(has_directed(m.faces[fan[i + 1] / 3], leaving_to, v)) << "vertex " << v << " step " << i;
    }
    const Triangle& first = m.faces[fan.front() / 3];
    const Triangle& last = m.faces[fan.back() / 3];
    const int first_prev = first[(fan.front() % 3 + 2) % 3], last_next = last[(fan.back() % 3 + 1) % 3];
    const bool boundary = boundary_next.count(v) > 0;
    EXPECT_EQ(topo.is_boundary_vertex(v), boundary);
    if (boundary) {
      EXPECT_EQ(boundary_next.at(first_prev), v) << "starts at the face on the boundary edge entering " << v;
      EXPECT_EQ(boundary_next.at(v), last_next) << "ends at the face on the boundary edge leaving " << v;
      EXPECT_EQ(topo.boundary_next(v), last_next);
    } else {
      EXPECT_EQ(fan.front() / 3, at_v.back()) << "an interior fan starts at the highest face";
      EXPECT_TRUE(has_directed(first, last_next, v)) << "the fan closes: the first face follows the last";
      EXPECT_EQ(topo.boundary_next(v), -1);
    }
  }
}

TEST(MeshTopology, GridsWithRandomDiagonals) {
  std::mt19937 rng(7);
  for (int i = 0; i < 40; ++i) {
    const Faces m = grid(1 + rng() % 7, 1 + rng() % 6, rng);
    check(m, "grid");
    check(scrambled(m, rng), "scrambled grid");
  }
}

TEST(MeshTopology, OpenAndClosedFans) {
  std::mt19937 rng(11);
  for (int k = 3; k < 30; ++k) {
    check(fan_mesh(k, true), "closed fan");
    check(fan_mesh(k, false), "open fan");
    check(scrambled(fan_mesh(k, true), rng), "scrambled closed fan");
    check(scrambled(fan_mesh(k, false), rng), "scrambled open fan");
  }
}

TEST(MeshTopology, RandomlyGrownDisks) {
  std::mt19937 rng(13);
  for (int i = 0; i < 60; ++i) {
    const Faces m = grown(1 + rng() % 120, rng);
    check(m, "grown");
    check(scrambled(m, rng), "scrambled grown");
  }
}

// What validate reports must be visible: no fans for a pinched vertex, a fin, or a flipped face.
TEST(MeshTopology, NonManifoldInputsHaveNoFans) {
  // Two triangles sharing only vertex 2.
  const MeshTopology bowtie(5, {{0, 1, 2}, {2, 3, 4}});
  EXPECT_FALSE(bowtie.oriented_manifold());
  EXPECT_EQ(bowtie.first_vertex_with_broken_fan(), 2);
  EXPECT_TRUE(bowtie.fan(2).empty());
  EXPECT_TRUE(bowtie.boundary_loops().empty());
  // Edge 0-1 in three faces.
  const MeshTopology fin(5, {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}});
  EXPECT_FALSE(fin.oriented_manifold());
  EXPECT_EQ(fin.edge_use_count(fin.edge(0)), 3);
  EXPECT_EQ(fin.opposite(0), -1);
  // Faces listing their shared edge in the same direction.
  const MeshTopology flipped(4, {{0, 1, 2}, {0, 1, 3}});
  EXPECT_FALSE(flipped.oriented_manifold());
  EXPECT_EQ(flipped.edge_use_count(0), 2);
  // An unused vertex has no fan.
  const MeshTopology unused(4, {{0, 1, 2}});
  EXPECT_FALSE(unused.oriented_manifold());
  EXPECT_EQ(unused.first_vertex_with_broken_fan(), 3);
}

}  // namespace
}  // namespace lipmap
