// 1-to-4 subdivision of a disk mesh for the benchmarks' large rows (~250k and ~1M triangles made at bench
// time from a shared mesh): a new vertex at the midpoint of every edge, numbered after the old vertices in
// the engine's edge order (engine/mesh_topology.h), and every triangle replaced by its three corner
// triangles and the middle one. Same orientation, still a disk; the boundary doubles.
#pragma once

#include <vector>

#include "engine/geometry.h"
#include "engine/mesh_topology.h"

namespace lipmap::bench {

inline void subdivide(std::vector<Point3>& vertices, std::vector<Triangle>& faces) {
  const MeshTopology topo(static_cast<int>(vertices.size()), faces);
  const int nv = static_cast<int>(vertices.size());
  vertices.resize(static_cast<std::size_t>(nv) + topo.edge_count());
  for (int e = 0; e < topo.edge_count(); ++e) {
    const auto [a, b] = topo.edge_vertices(e);
    const Point3 &p = vertices[a], &q = vertices[b];
    vertices[nv + e] = {0.5 * (p.x + q.x), 0.5 * (p.y + q.y), 0.5 * (p.z + q.z)};
  }
  std::vector<Triangle> out;
  out.reserve(4 * faces.size());
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const Triangle& t = faces[f];
    const int h = static_cast<int>(3 * f);
    const int m01 = nv + topo.edge(h), m12 = nv + topo.edge(h + 1), m20 = nv + topo.edge(h + 2);
    out.push_back({t[0], m01, m20});
    out.push_back({m01, t[1], m12});
    out.push_back({m20, m12, t[2]});
    out.push_back({m01, m12, m20});
  }
  faces = std::move(out);
}

}  // namespace lipmap::bench
