// Edge flips inside the refined faces. See refined_flips.h.
#include "engine/refined_flips.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <unordered_map>

#include "engine/detail/face_k.h"
#include "engine/flip_check.h"
#include "engine/mesh_topology.h"

namespace lipmap {

int flip_refined_diagonals(const DiskMesh& source, RefinedMap& map, const std::vector<Point3>& shape) {
  const std::size_t nv_source = source.vertices.size(), nf = map.faces.size();
  if (map.inserted.empty()) return 0;
  const MeshTopology& topo = source.topology;
  const std::vector<char> refined = refined_source_faces(source, map);
  std::vector<int> edge_of(map.inserted.size(), -1);
  for (std::size_t i = 0; i < map.inserted.size(); ++i) edge_of[i] = topo.find_edge(map.inserted[i].a, map.inserted[i].b);
  // The source edges of face F (edge c: corner c to corner c + 1) and where a map vertex lies on F: a bit per
  // edge of F it lies on, 0 when it is not on F.
  auto edge_mask = [&](int v, int F) -> unsigned {
    const Triangle& t = source.faces[static_cast<std::size_t>(F)];
    if (static_cast<std::size_t>(v) < nv_source) {
      for (int c = 0; c < 3; ++c)
        if (t[c] == v) return (1u << c) | (1u << ((c + 2) % 3));
      return 0;
    }
    const int e = edge_of[static_cast<std::size_t>(v) - nv_source];
    for (int c = 0; c < 3; ++c)
      if (e >= 0 && topo.edge(3 * F + c) == e) return 1u << c;
    return 0;
  };
  // The refined source face each map face lies in (-1: an unrefined one, never flipped).
  std::vector<int> face_of(nf, -1);
  for (std::size_t f = 0; f < nf; ++f) {
    const Triangle& t = map.faces[f];
    // The source faces of an edge that holds a corner: of an inserted corner's edge, else of (t0, t1).
    int edge = -1;
    for (int v : t)
      if (edge < 0 && static_cast<std::size_t>(v) >= nv_source) edge = edge_of[static_cast<std::size_t>(v) - nv_source];
    if (edge < 0) edge = topo.find_edge(t[0], t[1]);
    if (edge < 0) continue;
    for (int h : topo.edge_uses(edge)) {
      const int F = MeshTopology::face_of(h);
      if (refined[static_cast<std::size_t>(F)] && edge_mask(t[0], F) && edge_mask(t[1], F) && edge_mask(t[2], F)) {
        face_of[f] = F;
        break;
      }
    }
  }
  auto key = [](int a, int b) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(std::min(a, b))) << 32) | static_cast<std::uint32_t>(std::max(a, b));
  };
  std::unordered_map<std::uint64_t, std::array<int, 2>> faces_at;  // edge -> its (one or two) faces, -1 none
  std::vector<std::uint64_t> work;
  for (std::size_t f = 0; f < nf; ++f) {
    if (face_of[f] < 0) continue;
    const Triangle& t = map.faces[f];
    for (int c = 0; c < 3; ++c) {
      auto [it, fresh] = faces_at.try_emplace(key(t[c], t[(c + 1) % 3]), std::array<int, 2>{static_cast<int>(f), -1});
      if (!fresh) it->second[1] = static_cast<int>(f);
      else work.push_back(it->first);
    }
  }
  auto k_of = [&](int a, int b, int c) {
    return detail::face_k(detail::rest_inverse(shape[static_cast<std::size_t>(a)], shape[static_cast<std::size_t>(b)], shape[static_cast<std::size_t>(c)]),
                  map.uv[static_cast<std::size_t>(a)], map.uv[static_cast<std::size_t>(b)], map.uv[static_cast<std::size_t>(c)]);
  };
  auto replace = [&](std::uint64_t e, int from, int to) {
    auto& fs = faces_at.at(e);
    (fs[0] == from ? fs[0] : fs[1]) = to;
  };
  int flips = 0;
  const long long cap = 64LL * static_cast<long long>(faces_at.size()) + 64;
  for (long long steps = 0; !work.empty() && steps < cap; ++steps) {
    const std::uint64_t e = work.back();
    work.pop_back();
    const auto it = faces_at.find(e);
    if (it == faces_at.end() || it->second[1] < 0) continue;
    const int f1 = it->second[0], f2 = it->second[1];
    const int F = face_of[static_cast<std::size_t>(f1)];
    if (F != face_of[static_cast<std::size_t>(f2)]) continue;
    // f1 = (u, w, x) and f2 = (w, u, y), both counterclockwise: the quad is u, y, w, x.
    Triangle t1 = map.faces[static_cast<std::size_t>(f1)];
    for (int r = 0; r < 2 && key(t1[0], t1[1]) != e; ++r) t1 = {t1[1], t1[2], t1[0]};
    const int u = t1[0], w = t1[1], x = t1[2];
    int y = -1;
    for (int v : map.faces[static_cast<std::size_t>(f2)])
      if (v != u && v != w) y = v;
    if (y < 0 || y == x || faces_at.count(key(x, y))) continue;
    if ((edge_mask(x, F) & edge_mask(u, F) & edge_mask(y, F)) || (edge_mask(y, F) & edge_mask(w, F) & edge_mask(x, F))) continue;
    const Point2 &px = map.uv[static_cast<std::size_t>(x)], &pu = map.uv[static_cast<std::size_t>(u)],
                 &py = map.uv[static_cast<std::size_t>(y)], &pw = map.uv[static_cast<std::size_t>(w)];
    if (orientation_sign(px, pu, py) <= 0 || orientation_sign(py, pw, px) <= 0) continue;
    const double before = std::max(k_of(u, w, x), k_of(w, u, y)), after = std::max(k_of(x, u, y), k_of(y, w, x));
    if (!(after < before * (1 - 1e-9))) continue;
    map.faces[static_cast<std::size_t>(f1)] = {x, u, y};
    map.faces[static_cast<std::size_t>(f2)] = {y, w, x};
    faces_at.erase(it);
    faces_at.emplace(key(x, y), std::array<int, 2>{f1, f2});
    replace(key(w, x), f1, f2);
    replace(key(u, y), f2, f1);
    for (std::uint64_t side : {key(u, x), key(w, x), key(u, y), key(w, y)}) work.push_back(side);
    ++flips;
  }
  return flips;
}

}  // namespace lipmap
