// Stage "fixed-face split" (engine/fixed_face_split.h).
#include "engine/fixed_face_split.h"

#include <algorithm>
#include <cmath>

#include "engine/detail/exact_predicates.h"
#include "engine/float32_uv.h"
#include "engine/mesh_topology.h"

namespace lipmap {
namespace {

// Whether float32 texture coordinates can hold the polygon at all: every u, v and 1 - v within float32's range
// (with room) and the polygon at least 2^12 float32 spacings across. Otherwise no map with this boundary can be
// stored (at 1e-12 the stored 1 - v are all 1), and a point on a chord would buy nothing.
bool float32_can_hold(const std::vector<Point2>& polygon) {
  double magnitude = 0, lo_x = polygon[0].x, hi_x = lo_x, lo_y = polygon[0].y, hi_y = lo_y;
  for (const Point2& p : polygon) {
    magnitude = std::max({magnitude, std::abs(p.x), std::abs(p.y), std::abs(1.0 - p.y)});
    lo_x = std::min(lo_x, p.x), hi_x = std::max(hi_x, p.x), lo_y = std::min(lo_y, p.y), hi_y = std::max(hi_y, p.y);
  }
  return magnitude < 1e37 && std::max(hi_x - lo_x, hi_y - lo_y) >= std::ldexp(magnitude, -12);
}

}  // namespace

FixedFaceSplit split_unstorable_fixed_faces(const DiskMesh& source, const std::vector<int>& loop,
                                            const std::vector<Point2>& stored, RefinedMap& map) {
  FixedFaceSplit out;
  if (stored.empty() || !float32_can_hold(stored)) return out;
  const int ns = static_cast<int>(source.vertices.size());
  std::vector<int> loop_index(ns, -1);
  for (int k = 0; k < static_cast<int>(loop.size()); ++k) loop_index[loop[k]] = k;
  // Inserted vertices never lie on the boundary (engine/refine.h): a fixed face has three original corners.
  auto on_loop = [&](int v) { return v < ns && loop_index[v] >= 0; };
  std::vector<int> unstorable;
  for (int f = 0; f < static_cast<int>(map.faces.size()); ++f) {
    const Triangle& t = map.faces[f];
    if (!on_loop(t[0]) || !on_loop(t[1]) || !on_loop(t[2])) continue;
    const Point2 &a = stored[loop_index[t[0]]], &b = stored[loop_index[t[1]]], &c = stored[loop_index[t[2]]];
    if (!float32_face_valid(a, b, c) || !float32_face_robust(a, b, c)) unstorable.push_back(f);
  }
  out.unstorable = static_cast<int>(unstorable.size());
  if (unstorable.empty()) return out;

  const std::vector<char> refined_before = refined_source_faces(source, map);
  const MeshTopology topo(static_cast<int>(map.uv.size()), map.faces);
  std::vector<char> changed(map.faces.size(), 0);
  for (int f : unstorable) {
    if (changed[f]) continue;
    for (int k = 0; k < 3; ++k) {
      const int h = 3 * f + k, o = topo.opposite(h);
      if (o < 0) continue;
      const int g = MeshTopology::face_of(o);
      const int x = topo.from(h), y = topo.to(h);
      if (changed[g] || source.topology.find_edge(x, y) < 0) continue;  // not a chord of the source mesh
      const int b = topo.to(MeshTopology::next(h)), d = topo.to(MeshTopology::next(o));  // topo: faces as found
      // f = (x, y, b) becomes (x, m, b), (m, y, b); g = (y, x, d) becomes (y, m, d), (m, x, d). m goes from the
      // chord's middle towards d, as far as keeps all four strictly positive (b is almost on the chord).
      const Point2 &ux = map.uv[x], &uy = map.uv[y], &ub = map.uv[b], &ud = map.uv[d];
      const Point2 mid{0.5 * (ux.x + uy.x), 0.5 * (ux.y + uy.y)};
      bool placed = false;
      Point2 m;
      for (double s = 0.5; s > 1.0 / 64 && !placed; s *= 0.5) {
        m = {mid.x + s * (ud.x - mid.x), mid.y + s * (ud.y - mid.y)};
        placed = detail::orient(ux, m, ub) > 0 && detail::orient(m, uy, ub) > 0 && detail::orient(uy, m, ud) > 0 &&
                 detail::orient(m, ux, ud) > 0;
      }
      if (!placed) continue;
      const int mv = static_cast<int>(map.uv.size());
      const int lo = std::min(x, y), hi = std::max(x, y);
      map.inserted.push_back({lo, hi, 0.5});
      map.vertices.push_back(point_on_edge(source.vertices[lo], source.vertices[hi], 0.5));
      map.uv.push_back(m);
      map.faces[f] = {x, mv, b};
      map.faces[g] = {y, mv, d};
      map.faces.push_back({mv, y, b});
      map.faces.push_back({mv, x, d});
      changed[f] = changed[g] = 1;
      ++out.split;
      break;
    }
  }
  if (out.split > 0) {
    const std::vector<char> refined_after = refined_source_faces(source, map);
    for (std::size_t i = 0; i < refined_after.size(); ++i) map.refined_faces += refined_after[i] && !refined_before[i];
  }
  return out;
}

}  // namespace lipmap
