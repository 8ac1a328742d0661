// Local minimax relaxation of max K for method extremal (paper 5.3). See extremal_relax.h.
#include "engine/extremal_relax.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <tuple>

#include "engine/detail/face_k.h"
#include "engine/detail/piece_mesher.h"
#include "engine/detail/uv_descent.h"
#include "engine/flip_check.h"
#include "engine/mesh_topology.h"
#include "engine/refined_flips.h"

namespace lipmap {
namespace {

using Clock = std::chrono::steady_clock;
using detail::face_k;
using detail::rest_inverse;
using detail::RestInverse;
constexpr double kInf = std::numeric_limits<double>::infinity();

// max K over map's faces and over those pinned by the boundary (ExtremalRelaxation::max_after, fixed_max), from
// every face's K.
std::pair<double, double> maxima(const RefinedMap& map, const std::vector<int>& loop, const std::vector<double>& k) {
  std::vector<char> on_loop(map.uv.size(), 0);
  for (int v : loop) on_loop[static_cast<std::size_t>(v)] = 1;
  double all = 1, fixed = 1;
  for (std::size_t f = 0; f < map.faces.size(); ++f) {
    all = std::max(all, k[f]);
    if (pinned_by_boundary(map.faces[f], on_loop)) fixed = std::max(fixed, k[f]);
  }
  return {all, fixed};
}

// The same, K measured against shape.
std::pair<double, double> max_k(const RefinedMap& map, const std::vector<int>& loop, const std::vector<Point3>& shape) {
  std::vector<double> k(map.faces.size());
  for (std::size_t f = 0; f < k.size(); ++f) {
    const Triangle& t = map.faces[f];
    k[f] = face_k(rest_inverse(shape[static_cast<std::size_t>(t[0])], shape[static_cast<std::size_t>(t[1])],
                               shape[static_cast<std::size_t>(t[2])]),
                  map.uv[static_cast<std::size_t>(t[0])], map.uv[static_cast<std::size_t>(t[1])],
                  map.uv[static_cast<std::size_t>(t[2])]);
  }
  return maxima(map, loop, k);
}

// max K over the source faces with three boundary corners and no inserted point on their edges: every map
// with this boundary that refines no further (simplify_again, flip_refined_diagonals, vertex moves) keeps them.
double unrefined_fixed_max(const DiskMesh& source, const RefinedMap& map, const std::vector<int>& loop) {
  std::vector<char> on_loop(source.vertices.size(), 0);
  for (int v : loop) on_loop[static_cast<std::size_t>(v)] = 1;
  const std::vector<char> refined = refined_source_faces(source, map);
  double fixed = 1;
  for (std::size_t f = 0; f < source.faces.size(); ++f) {
    const Triangle& t = source.faces[f];
    if (refined[f] || !pinned_by_boundary(t, on_loop)) continue;
    const auto c = [&](int i) { return static_cast<std::size_t>(t[i]); };
    fixed = std::max(fixed, face_k(rest_inverse(map.vertices[c(0)], map.vertices[c(1)], map.vertices[c(2)]),
                                   map.uv[c(0)], map.uv[c(1)], map.uv[c(2)]));
  }
  return fixed;
}

// Whether face t has a corner on the boundary (pinned 2, see relax_round): the interior polish and the interior
// minimax leave such faces out of the interior.
bool touches_boundary(const Triangle& t, const std::vector<char>& pinned) {
  return pinned[static_cast<std::size_t>(t[0])] == 2 || pinned[static_cast<std::size_t>(t[1])] == 2 ||
         pinned[static_cast<std::size_t>(t[2])] == 2;
}

// The boundary polygon's signed area under map (UvDescent scales the rest shapes to it).
double polygon_area(const RefinedMap& map, const std::vector<int>& loop) {
  std::vector<Point2> polygon;
  polygon.reserve(loop.size());
  for (int v : loop) polygon.push_back(map.uv[static_cast<std::size_t>(v)]);
  return detail::signed_area(polygon);
}

// The settings of the flip-free projected Newton descents on powers of mips (relax_round's descent and the
// interior polish), up to max_iterations steps per power. Newton converges in few steps; a looser stop than
// L-BFGS needed (1e-6, 100 steps per power) left the same K on bench_extremal's camel_head cases in half the time.
detail::DescentSettings powered_newton(int max_iterations, const ExtremalRelaxOptions& options, const CancelToken* cancel,
                                       Clock::time_point t0) {
  detail::DescentSettings s;
  s.energy = detail::UvEnergy::mips;
  s.flip_free = true;
  s.max_iterations = max_iterations;
  s.relative_tolerance = 1e-4;
  s.newton = true;
  s.cancel = cancel;
  if (options.time_budget_ms > 0)
    s.deadline = t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(options.time_budget_ms));
  return s;
}

// Interior polish, after the minimax (relax_round). The minimax settles the worst faces, which sit next to the
// boundary, and its single vertex moves carry their distortion inward where, frozen level by level, it stays:
// on max_registration_partial onto a circle the start (Teichmuller) had max K / mean K 1.27 two rings in, the
// relaxed map 1.81, for a worst movable face 9.07 -> 4.48. A flip-free descent on a weighted p-norm of K
// (p = 2 ... 256; DescentSettings::face_base) evens the interior out: a face touching the boundary weighs
// against its own K (it can hardly rise), every other face against 1.25 x the movable faces' mean K (the
// Teichmuller map's K is constant; above that a face is pushed down). It moves the freely movable vertices only
// (pinned 0: no inserted point's need depends on them; on refined maps, moving the others too while every point
// stayed needed lowered nothing on bench_extremal). Kept when max K over the faces off the boundary drops and
// max K over all faces does not rise, else the largest of 1/2, 1/4, 1/8 of the way that does so, every face
// positive (exact). When none of these is kept, a second descent with the first ring frozen too (every corner of a
// face touching the boundary): those faces cannot change then, so max K cannot rise through them, and the rest
// of the interior is evened out under them. bench_extremal mannequin_devil / weak_fan: the first descent lowered
// max K off the boundary 6.38 -> 4.57 but raised a face touching the boundary 6.39 -> 7.87; the second keeps
// max K at 6.372 and lowers max K / mean K two rings in 1.900 -> 1.060, the faces there rising towards the worst
// (area-weighted mean K over all faces 3.38 -> 5.37: the extremal map's K is as even as its boundary allows, the
// Teichmuller map's is constant); kept on no other bench case. Runs only when the interior is uneven, max K over the
// faces off the boundary above 1.5 x the mean (a descent not kept costs as much as the minimax on 60k-face
// meshes). k: every face's K, updated when kept. Says whether it was kept.
bool polish_interior(const std::vector<Point3>& shape, const std::vector<int>& loop, RefinedMap& map,
                     const std::vector<char>& pinned, const std::vector<RestInverse>& inv, std::vector<double>& k,
                     const ExtremalRelaxOptions& options, const CancelToken* cancel, Clock::time_point t0) {
  const std::size_t nv = map.uv.size(), nf = map.faces.size();
  const auto corner = [&](std::size_t f, int i) { return static_cast<std::size_t>(map.faces[f][static_cast<std::size_t>(i)]); };
  std::vector<char> fixed(nv);
  for (std::size_t v = 0; v < nv; ++v) fixed[v] = pinned[v] != 0;
  double sum = 0;
  int count = 0;
  for (std::size_t f = 0; f < nf; ++f)
    if (!fixed[corner(f, 0)] || !fixed[corner(f, 1)] || !fixed[corner(f, 2)]) sum += k[f], ++count;
  if (count == 0) return false;
  const double mean = sum / count, target_k = 1.25 * mean, target = 0.5 * (target_k + 1 / target_k);
  std::vector<char> touches(nf);
  std::vector<double> base(nf);
  double interior_before = 1;  // max K over the faces off the boundary
  for (std::size_t f = 0; f < nf; ++f) {
    touches[f] = touches_boundary(map.faces[f], pinned);
    base[f] = touches[f] ? std::max(target, 0.5 * (k[f] + 1 / k[f])) : target;
    if (!touches[f]) interior_before = std::max(interior_before, k[f]);
  }
  if (!(interior_before > 1.5 * mean)) return false;
  const double before = *std::max_element(k.begin(), k.end());
  const std::vector<Point2> start = map.uv;
  std::vector<double> k_new(nf);
  // One descent with the vertices in fixed pinned; true when (a fraction of) it is kept, map.uv and k updated.
  auto descend_and_keep = [&]() {
    map.uv = start;
    detail::UvDescent descent(shape, map.faces, fixed, polygon_area(map, loop));
    detail::DescentSettings s = powered_newton(10, options, cancel, t0);
    s.face_base = &base;
    for (double p = 2; p <= 256; p *= 2) {
      s.power = p;
      descent.minimize(map.uv, s);
    }
    const std::vector<Point2> polished = map.uv;
    if (polished == start) return false;
    for (double t = 1; t > 0.1; t *= 0.5) {
      for (std::size_t v = 0; v < nv; ++v)
        map.uv[v] = {start[v].x + t * (polished[v].x - start[v].x), start[v].y + t * (polished[v].y - start[v].y)};
      double after = 1, interior_after = 1;
      for (std::size_t f = 0; f < nf; ++f) {
        after = std::max(after, k_new[f] = face_k(inv[f], map.uv[corner(f, 0)], map.uv[corner(f, 1)], map.uv[corner(f, 2)]));
        if (!touches[f]) interior_after = std::max(interior_after, k_new[f]);
      }
      if (after <= before && interior_after < interior_before && count_non_positive(map.uv, map.faces) == 0) {
        k = std::move(k_new);
        return true;
      }
    }
    return false;
  };
  if (descend_and_keep()) return true;
  // Refused: again with the first ring fixed too, when that fixes anything more.
  bool more = false;
  for (std::size_t f = 0; f < nf; ++f)
    if (touches[f])
      for (int i = 0; i < 3; ++i)
        if (!fixed[corner(f, i)]) fixed[corner(f, i)] = 1, more = true;
  if (more && descend_and_keep()) return true;
  map.uv = start;
  return false;
}

// One relaxation of map (see relax_max_dilatation). With removable non-null, a conditional descent (below) that
// would make an inserted point removable ends the round at once: that map (every face positive) goes to
// *removable and map is left as it came.
ExtremalRelaxation relax_round(const DiskMesh& source, const std::vector<int>& loop, RefinedMap& map,
                               const ExtremalRelaxOptions& options, const CancelToken* cancel,
                               const std::vector<Point3>* rest, Clock::time_point t0, std::vector<Point2>* removable) {
  ExtremalRelaxation out;
  const std::size_t nv = map.vertices.size(), nf = map.faces.size(), nv_source = source.vertices.size();
  const std::vector<Point3>& shape = rest ? *rest : map.vertices;
  std::vector<RestInverse> inv(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const Triangle& t = map.faces[f];
    inv[f] = rest_inverse(shape[static_cast<std::size_t>(t[0])], shape[static_cast<std::size_t>(t[1])],
                          shape[static_cast<std::size_t>(t[2])]);
  }
  auto k_of = [&](std::size_t f) {
    const Triangle& t = map.faces[f];
    return face_k(inv[f], map.uv[static_cast<std::size_t>(t[0])], map.uv[static_cast<std::size_t>(t[1])],
                  map.uv[static_cast<std::size_t>(t[2])]);
  };
  std::vector<double> k(nf);
  for (std::size_t f = 0; f < nf; ++f) k[f] = k_of(f);
  std::tie(out.max_before, out.fixed_max) = maxima(map, loop, k);
  out.max_after = out.max_before;
  if (nf == 0 || !std::isfinite(out.max_before) || count_non_positive(map.uv, map.faces) > 0) return out;

  // Free vertices: as the optimize stage's (see extremal_relax.h).
  std::vector<char> pinned(nv, 0);
  for (int v : loop) pinned[static_cast<std::size_t>(v)] = 2;
  // Inserted points per source face (on its edges). An inserted point p may move (its uv only: its 3D point
  // stays on its edge, contract point 1) when it is the only one on both source faces of its edge: whether a
  // point is removable (contract point 6) depends on the polygons without it, so p's own uv never makes p
  // removable, and no other point's polygon contains p. The corners of refined faces and the other inserted
  // points are conditionally free (below). pinned: 0 free, 1 conditionally free, 2 boundary.
  std::vector<int> per_face(source.faces.size(), 0);
  std::vector<int> edge_of(nv - nv_source, -1);
  for (std::size_t i = nv_source; i < nv; ++i) {
    pinned[i] = 1;
    const InsertedVertex& iv = map.inserted[i - nv_source];
    const int e = source.topology.find_edge(iv.a, iv.b);
    edge_of[i - nv_source] = e;
    if (e < 0) continue;
    for (int h : source.topology.edge_uses(e)) {
      const int f = MeshTopology::face_of(h);
      ++per_face[static_cast<std::size_t>(f)];
      for (int v : source.faces[static_cast<std::size_t>(f)]) pinned[static_cast<std::size_t>(v)] = std::max<char>(pinned[static_cast<std::size_t>(v)], 1);
    }
  }
  for (std::size_t i = nv_source; i < nv; ++i) {
    const int e = edge_of[i - nv_source];
    if (e < 0) continue;
    bool alone = true;
    for (int h : source.topology.edge_uses(e)) alone = alone && per_face[static_cast<std::size_t>(MeshTopology::face_of(h))] == 1;
    if (alone) pinned[i] = 0;
  }
  const MeshTopology topo(static_cast<int>(nv), map.faces);
  if (!topo.oriented_manifold()) return out;
  for (std::size_t v = 0; v < nv; ++v)
    if (topo.is_boundary_vertex(static_cast<int>(v))) pinned[v] = 2;

  // Conditionally free (pinned == 1: a corner of a refined face, an inserted point sharing a source face with
  // another): such a move changes the refined polygons of the inserted points q on the source faces around v,
  // so it is kept only when every such q is still certainly needed afterwards: one of q's two polygons without
  // q (corners and inserted points in order, paper 4 Fig. 11) has two edges that cross properly (exact
  // orientation) or a negative area, so it is not simple and counterclockwise and q cannot be removed.
  std::vector<std::vector<std::pair<double, int>>> on_edge(static_cast<std::size_t>(source.topology.edge_count()));
  for (std::size_t i = nv_source; i < nv; ++i)
    if (edge_of[i - nv_source] >= 0)
      on_edge[static_cast<std::size_t>(edge_of[i - nv_source])].push_back({map.inserted[i - nv_source].t, static_cast<int>(i)});
  for (auto& points : on_edge) std::sort(points.begin(), points.end());
  std::vector<int> poly_ids;
  std::vector<Point2> poly;
  auto refined_polygon_without = [&](int f, int q) {
    poly_ids.clear();
    const Triangle& t = source.faces[static_cast<std::size_t>(f)];
    for (int c = 0; c < 3; ++c) {
      const int a = t[c], b = t[(c + 1) % 3];
      poly_ids.push_back(a);
      const int e = source.topology.edge(3 * f + c);  // corner c to c + 1
      const auto& points = on_edge[static_cast<std::size_t>(e)];
      if (a < b) {
        for (const auto& tp : points)
          if (tp.second != q) poly_ids.push_back(tp.second);
      } else {
        for (auto r = points.rbegin(); r != points.rend(); ++r)
          if (r->second != q) poly_ids.push_back(r->second);
      }
    }
    poly.clear();
    for (int id : poly_ids) poly.push_back(map.uv[static_cast<std::size_t>(id)]);
  };
  auto not_simple_ccw = [&]() {
    const std::size_t m = poly.size();
    long double area = 0, scale = 0;
    for (std::size_t i = 0; i < m; ++i) {
      const Point2 &a = poly[i], &b = poly[(i + 1) % m];
      const long double term = static_cast<long double>(a.x) * b.y - static_cast<long double>(b.x) * a.y;
      area += term;
      scale += std::fabs(term);
    }
    if (area < -1e-9L * scale) return true;
    for (std::size_t i = 0; i < m; ++i)
      for (std::size_t j = i + 2; j < m; ++j) {
        if (i == 0 && j + 1 == m) continue;  // adjacent through the closing edge
        const Point2 &p1 = poly[i], &p2 = poly[(i + 1) % m], &p3 = poly[j], &p4 = poly[(j + 1) % m];
        if (orientation_sign(p1, p2, p3) * orientation_sign(p1, p2, p4) < 0 &&
            orientation_sign(p3, p4, p1) * orientation_sign(p3, p4, p2) < 0)
          return true;
      }
    return false;
  };
  std::vector<int> affected;
  // Inserted points whose polygons contain v: on the edges of the source faces that have v as a corner or
  // (v inserted) that hold v's edge.
  auto affected_points = [&](int v) {
    affected.clear();
    std::vector<int> faces;
    if (static_cast<std::size_t>(v) < nv_source) {
      for (int h : source.topology.fan(v)) faces.push_back(MeshTopology::face_of(h));
    } else if (edge_of[static_cast<std::size_t>(v) - nv_source] >= 0) {
      for (int h : source.topology.edge_uses(edge_of[static_cast<std::size_t>(v) - nv_source])) faces.push_back(MeshTopology::face_of(h));
    }
    for (int f : faces)
      for (int c = 0; c < 3; ++c)
        for (const auto& tp : on_edge[static_cast<std::size_t>(source.topology.edge(3 * f + c))])
          if (tp.second != v) affected.push_back(tp.second);
    std::sort(affected.begin(), affected.end());
    affected.erase(std::unique(affected.begin(), affected.end()), affected.end());
  };
  // Whether inserted point q is still certainly needed: one of its polygons without it is not simple and ccw.
  auto still_needed_point = [&](int q) {
    const int e = edge_of[static_cast<std::size_t>(q) - nv_source];
    for (int h : source.topology.edge_uses(e)) {
      refined_polygon_without(MeshTopology::face_of(h), q);
      if (not_simple_ccw()) return true;
    }
    return false;
  };
  auto still_needed = [&](int v) {
    affected_points(v);
    for (int q : affected)
      if (!still_needed_point(q)) return false;
    return true;
  };
  for (std::size_t v = 0; v < nv; ++v) out.free_vertices += pinned[v] != 2;
  if (out.free_vertices == 0) return out;
  out.ran = true;

  // Frozen faces: the levels already settled (see below). A move may not raise a frozen face's K and must
  // lower the max K over the star's other faces.
  std::vector<char> frozen(nf, 0);
  // The largest K over the faces that can still change (a free corner) and are not frozen.
  auto level = [&]() {
    double m = 1;
    for (std::size_t f = 0; f < nf; ++f) {
      const Triangle& t = map.faces[f];
      if (!frozen[f] && (pinned[static_cast<std::size_t>(t[0])] != 2 || pinned[static_cast<std::size_t>(t[1])] != 2 ||
                         pinned[static_cast<std::size_t>(t[2])] != 2))
        m = std::max(m, k[f]);
    }
    return m;
  };

  // First a flip-free descent (engine/detail/uv_descent.h) on the sum over faces of ((K + 1/K) / 2)^p relative
  // to the worst movable face's, p = 2, 4, ..., 256 (mips / 2 = (K + 1/K) / 2): a smooth stand-in for the largest
  // K that moves many vertices at once, where the compass search below moves one vertex at a time: on a refined
  // map first every vertex off the boundary, kept only when every inserted point is still needed afterwards
  // (contract point 6), else (and on an unrefined map) the freely movable ones (pinned 0). As p grows its
  // minimizers tend to a map whose K is as even as the mesh allows (a Teichmuller map's is constant), not only
  // one whose worst face is low: the interior's spread of K is what method extremal is judged by besides max K.
  // Projected Newton, since L-BFGS crawls at large p (bench_extremal:
  // L-BFGS to p = 16 left max K / mean K two rings in at 1.6-3.0 on camel_head and mannequin_devil onto c_shape
  // and weak_fan, Newton to p = 256 at 1.05-1.11). Each p is relative to the level it starts from, so that the
  // terms neither overflow nor all vanish. It is kept only when it lowers the max K over the movable faces; the
  // compass search then settles the worst faces level by level as before.
  // descend(conditional): the descent over the vertices with pinned 0, and with conditional also those with
  // pinned 1, every inserted point staying certainly needed (as for a compass move of such a vertex, below);
  // kept only when it lowers the movable faces' max K. Says whether it was kept, and whether whole.
  enum class Descent { none, partial, complete };
  auto descend = [&](bool conditional) {
    std::vector<char> fixed(nv);
    for (std::size_t v = 0; v < nv; ++v) fixed[v] = conditional ? pinned[v] == 2 : pinned[v] != 0;
    if (std::all_of(fixed.begin(), fixed.end(), [](char c) { return c != 0; })) return Descent::none;
    // max K over the faces this descent can change (a corner not fixed): a worst face that it cannot move (all
    // corners fixed) would otherwise set the power's base and leave every other term near 0.
    auto movable_level = [&]() {
      double m = 1;
      for (std::size_t f = 0; f < nf; ++f) {
        const Triangle& t = map.faces[f];
        if (!fixed[static_cast<std::size_t>(t[0])] || !fixed[static_cast<std::size_t>(t[1])] || !fixed[static_cast<std::size_t>(t[2])])
          m = std::max(m, k[f]);
      }
      return m;
    };
    const double before = movable_level();
    const std::vector<Point2> start = map.uv;
    const std::vector<double> k_start = k;
    detail::UvDescent descent(shape, map.faces, fixed, polygon_area(map, loop));
    detail::DescentSettings s = powered_newton(20, options, cancel, t0);
    auto every_point_needed = [&]() {
      for (std::size_t i = nv_source; i < nv; ++i)
        if (edge_of[i - nv_source] >= 0 && !still_needed_point(static_cast<int>(i))) return false;
      return true;
    };
    // The last map every inserted point was still needed on (checked after every power): a descent that makes
    // a point removable ends there, after a step back toward it that keeps every point needed, when one of
    // 1/2, 1/4, ..., 1/32 of the way does (with every face positive, exact).
    std::vector<Point2> good = map.uv, tried;
    Descent result = Descent::complete;
    for (double p = 2; p <= 256; p *= 2) {
      for (std::size_t f = 0; f < nf; ++f) k[f] = k_of(f);
      const double worst = movable_level();
      s.power = p;
      s.power_base = 0.5 * (worst + 1 / worst);  // mips / 2 = (K + 1/K) / 2 of the worst movable face
      descent.minimize(map.uv, s);
      if (!conditional || every_point_needed()) {
        good = map.uv;
        continue;
      }
      result = Descent::partial;
      tried = map.uv;
      if (removable && count_non_positive(tried, map.faces) == 0) {
        *removable = std::move(tried);
        map.uv = start;
        k = k_start;
        return Descent::none;
      }
      map.uv = good;
      for (double t = 0.5; t > 0.02; t *= 0.5) {
        for (std::size_t v = 0; v < nv; ++v)
          map.uv[v] = {good[v].x + t * (tried[v].x - good[v].x), good[v].y + t * (tried[v].y - good[v].y)};
        if (count_non_positive(map.uv, map.faces) == 0 && every_point_needed()) break;
        map.uv = good;
      }
      break;
    }
    for (std::size_t f = 0; f < nf; ++f) k[f] = k_of(f);
    // The faces with every corner fixed keep their K, so max K over the others dropping keeps the global one
    // from rising.
    if (!(movable_level() < before && count_non_positive(map.uv, map.faces) == 0)) {
      map.uv = start;
      k = k_start;
      return Descent::none;
    }
    return result;
  };
  // On a refined map, first over every vertex off the boundary until an inserted point would become removable,
  // then over the freely movable ones only (three_peaks onto c_shape, one point inserted: max K / mean K two
  // rings in 1.72 -> 1.06). Pinning the polygons of the points that became removable and starting over, up to three
  // times, lowered it on two more bench_extremal cases, 6.5 -> 4.7 and 2.3 -> 2.1, for up to 24x the time.
  // A conditional descent that stopped early leaves the freely movable vertices room to go on.
  if (!(nv > nv_source && descend(true) == Descent::complete)) {
    if (removable && !removable->empty()) return out;
    descend(false);
  }

  std::vector<int> star;
  long long evals = 0;
  double rise_limit = kInf;  // a move may not raise a face above the larger of its K and this (interior minimax)
  auto star_max = [&]() {
    double m = 1;
    evals += static_cast<long long>(star.size());
    for (int f : star) {
      const double kf = k_of(static_cast<std::size_t>(f)), was = k[static_cast<std::size_t>(f)];
      if (frozen[static_cast<std::size_t>(f)] ? kf > was : kf > rise_limit && kf > was) return kInf;
      if (!frozen[static_cast<std::size_t>(f)]) m = std::max(m, kf);
    }
    return m;
  };
  // One vertex: compass search on the star's max K; true when a move was kept.
  auto relax_vertex = [&](int v) {
    star.clear();
    for (int h : topo.fan(v)) star.push_back(MeshTopology::face_of(h));
    Point2& p = map.uv[static_cast<std::size_t>(v)];
    const Point2 start = p;
    const double g0 = star_max();
    double g = g0, edge = 0;
    for (int h : topo.fan(v)) {
      const Point2& q = map.uv[static_cast<std::size_t>(topo.to(h))];
      edge += std::hypot(q.x - p.x, q.y - p.y);
    }
    double step = 0.25 * edge / static_cast<double>(star.size());
    const double min_step = 1e-4 * step;
    static const double dir[8][2] = {{1, 0}, {0.70710678118654752, 0.70710678118654752}, {0, 1},
                                     {-0.70710678118654752, 0.70710678118654752}, {-1, 0},
                                     {-0.70710678118654752, -0.70710678118654752}, {0, -1},
                                     {0.70710678118654752, -0.70710678118654752}};
    for (int tries = 0; tries < 60 && step > min_step; ++tries) {
      const Point2 here = p;
      Point2 best = here;
      double best_g = g;
      for (const auto& d : dir) {
        p = {here.x + step * d[0], here.y + step * d[1]};
        const double trial = star_max();
        if (trial < best_g) best_g = trial, best = p;
      }
      p = best;
      if (best_g < g) g = best_g;
      else step *= 0.5;
    }
    if (!(g < g0)) {
      p = start;
      return false;
    }
    for (int f : star) {
      const Triangle& t = map.faces[static_cast<std::size_t>(f)];
      if (orientation_sign(map.uv[static_cast<std::size_t>(t[0])], map.uv[static_cast<std::size_t>(t[1])],
                           map.uv[static_cast<std::size_t>(t[2])]) <= 0) {
        p = start;
        return false;
      }
    }
    if (pinned[static_cast<std::size_t>(v)] == 1 && !still_needed(v)) {
      p = start;
      return false;
    }
    for (int f : star) k[static_cast<std::size_t>(f)] = k_of(static_cast<std::size_t>(f));
    return true;
  };
  // An inserted point's 3D position along its source edge (its t): the refinement put it where the
  // intermediate map's edges cross, a choice of no consequence to the contract (the point stays on its edge,
  // strictly between its neighbours there, so the refined polygons keep their order) nor to local injectivity
  // or minimality (uv only), but one that shapes the 3D triangles around it and so their K. A compass search on
  // t lowers the star's max K (frozen faces may not rise, as for a uv move). Only with the mesh's own 3D shape
  // (rest null: a given rest shape has no edge to slide along) and off the boundary, in the interior minimax
  // (below). True when t was changed.
  auto relax_edge_point = [&](int v) {
    if (rest || static_cast<std::size_t>(v) < nv_source || pinned[static_cast<std::size_t>(v)] == 2) return false;
    const std::size_t i = static_cast<std::size_t>(v) - nv_source;
    const int e = edge_of[i];
    if (e < 0) return false;
    InsertedVertex& iv = map.inserted[i];
    auto& points = on_edge[static_cast<std::size_t>(e)];
    const auto here = std::find_if(points.begin(), points.end(), [&](const auto& tp) { return tp.second == v; });
    if (here == points.end()) return false;
    const double lo = here == points.begin() ? 0.0 : std::prev(here)->first;
    const double hi = std::next(here) == points.end() ? 1.0 : std::next(here)->first;
    const double margin = 0.02 * (hi - lo);
    const Point3 &a = map.vertices[static_cast<std::size_t>(iv.a)], &b = map.vertices[static_cast<std::size_t>(iv.b)];
    star.clear();
    for (int h : topo.fan(v)) star.push_back(MeshTopology::face_of(h));
    auto place = [&](double t) {
      map.vertices[static_cast<std::size_t>(v)] = point_on_edge(a, b, t);
      for (int f : star) {
        const Triangle& tri = map.faces[static_cast<std::size_t>(f)];
        inv[static_cast<std::size_t>(f)] = rest_inverse(map.vertices[static_cast<std::size_t>(tri[0])], map.vertices[static_cast<std::size_t>(tri[1])],
                                                       map.vertices[static_cast<std::size_t>(tri[2])]);
      }
      return star_max();
    };
    const double t_start = iv.t, g0 = star_max();
    double t = t_start, g = g0, step = 0.25 * (hi - lo);
    for (int tries = 0; tries < 30 && step > 1e-4 * (hi - lo); ++tries) {
      double best_t = t, best_g = g;
      for (double d : {step, -step}) {
        const double trial_t = t + d;
        if (!(trial_t > lo + margin && trial_t < hi - margin)) continue;
        const double trial = place(trial_t);
        if (trial < best_g) best_g = trial, best_t = trial_t;
      }
      if (best_g < g) t = best_t, g = best_g;
      else step *= 0.5;
    }
    place(g < g0 ? t : t_start);
    if (!(g < g0)) return false;
    iv.t = t;
    here->first = t;
    for (int f : star) k[static_cast<std::size_t>(f)] = k_of(static_cast<std::size_t>(f));
    return true;
  };
  // Lexicographic minimax: sweeps lower the current level (the worst face that can change and is not frozen
  // sets a threshold; the free corners of every face within the band's share of its excess over 1 are visited,
  // worst star first). When a sweep lowers the level by less than a relative 1e-3, the faces at the level are
  // frozen and the next level down is treated: the global max K is settled first, then the worst faces
  // elsewhere (the interior's worst triangles are otherwise left as they are whenever the global worst sits at
  // a stuck place, e.g. next to the boundary). Bounded by the sweeps' cap and by cap face evaluations. Returns
  // the moves kept.
  std::vector<std::pair<double, int>> order;
  std::vector<char> queued(nv, 0);
  bool slide_points = false;  // also relax_edge_point (the interior minimax)
  auto minimax = [&](long long cap, double band) {
    int kept = 0;
    for (int sweep = 0; sweep < options.max_sweeps && evals < cap; ++sweep) {
      check_cancel(cancel);
      if (options.time_budget_ms > 0 &&
          std::chrono::duration<double, std::milli>(Clock::now() - t0).count() > options.time_budget_ms)
        break;
      const double before = level();
      if (before <= 1 + 1e-3) break;
      const double threshold = 1 + band * (before - 1);
      order.clear();
      for (std::size_t f = 0; f < nf; ++f) {
        if (frozen[f] || k[f] < threshold) continue;
        for (int v : map.faces[f])
          if (pinned[static_cast<std::size_t>(v)] != 2 && !queued[static_cast<std::size_t>(v)]) {
            queued[static_cast<std::size_t>(v)] = 1;
            order.push_back({k[f], v});
          }
      }
      for (const auto& [kv, v] : order) queued[static_cast<std::size_t>(v)] = 0;
      std::sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first > b.first || (a.first == b.first && a.second < b.second); });
      int moved = 0;
      for (const auto& [kv, v] : order) {
        if (evals >= cap) break;
        moved += slide_points ? relax_vertex(v) | relax_edge_point(v) : relax_vertex(v);
      }
      kept += moved;
      ++out.sweeps;
      const double after = level();
      if (moved == 0 || after > before - 1e-3 * (before - 1)) {
        // Stuck at this level: freeze its faces (within 1 % of its excess) and go on with the next one.
        int newly = 0;
        for (std::size_t f = 0; f < nf; ++f)
          if (!frozen[f] && k[f] >= 1 + 0.99 * (after - 1)) frozen[f] = 1, ++newly;
        if (newly == 0) break;
        ++out.levels;
      }
    }
    out.moves += kept;
    return kept;
  };
  // First over every face, visiting those within half of the level's excess: about 2,000 face evaluations per
  // face (at most 1e8).
  minimax(std::min<long long>(2000LL * static_cast<long long>(nf), 100000000LL), 0.5);
  if (options.polish_interior && (options.time_budget_ms <= 0 ||
                                  std::chrono::duration<double, std::milli>(Clock::now() - t0).count() < options.time_budget_ms)) {
    out.polished = polish_interior(shape, loop, map, pinned, inv, k, options, cancel, t0);
    // Then the interior alone, where its K is still uneven (max K over the faces off the boundary above 1.5 x
    // their mean, as for the polish): the faces touching the boundary are frozen (no move may raise them) and
    // the minimax starts over on the others, from their own worst level, visiting only the faces within 5 % of
    // it, and no face may rise above the larger of its K and 1.5 x their mean; inserted points also slide along
    // their source edges (relax_edge_point; wiggly_strip / weak_fan 1.468 -> 1.399; in the first minimax too,
    // that path changed which start won and raised max K on swirl_domain / weak_fan, 32.6 -> 34.4, so
    // only here, where the level off the boundary is all that can change). The first pass spends its budget
    // on the levels next to the boundary, and the polish moves only the freely movable vertices, while on
    // refined maps the interior's worst faces are often refined faces whose corners move only while every
    // inserted point stays needed: bench_extremal wiggly_strip / weak_fan, max K / mean K two rings in 1.554 ->
    // 1.468 (1.488 without the limit on rises; on mountain / weak_fan, 6.985 -> 7.731 without it: the worst
    // faces next to the boundary's ring went down a little by pushing those two rings in up). Up to 3,000 face
    // evaluations per face (at most 1e8).
    double sum = 0, interior_max = 1;
    int count = 0;
    for (std::size_t f = 0; f < nf; ++f) {
      frozen[f] = touches_boundary(map.faces[f], pinned);
      if (!frozen[f]) sum += k[f], ++count, interior_max = std::max(interior_max, k[f]);
    }
    if (count > 0 && interior_max > 1.5 * sum / count) {
      evals = 0;
      rise_limit = 1.5 * sum / count;
      slide_points = true;
      out.interior_moves = minimax(std::min<long long>(3000LL * static_cast<long long>(nf), 100000000LL), 0.95);
    }
  }
  out.max_after = *std::max_element(k.begin(), k.end());
  return out;
}

}  // namespace

ExtremalRelaxation relax_max_dilatation(const DiskMesh& source, const std::vector<int>& loop, RefinedMap& map,
                                        const ExtremalRelaxOptions& options, const CancelToken* cancel,
                                        const std::vector<Point3>* rest) {
  const auto t0 = Clock::now();
  // The refined faces' corners can move only while every inserted point stays needed (contract point 6). When
  // the descent would make points removable, they are removed instead (refine.h's simplify_again: the rounds
  // of Fig. 11 on the moved map) and the relaxation starts over on the smaller refinement: the descent wants
  // the folds the points were inserted for undone. A few rounds at most: each costs a descent.
  constexpr int kSimplifyRounds = 12;
  const bool may_simplify = !options.rotation.empty() && !rest && !map.inserted.empty();
  double max_before = 0, fixed_before = 0;
  int removed = 0;
  std::optional<RefinedMap> original;
  if (may_simplify) original = map, fixed_before = unrefined_fixed_max(source, map, loop);
  // The refined faces' triangulations are reshaped before each relaxation and after the last one.
  auto reshape = [&](RefinedMap& m) { return flip_refined_diagonals(source, m, rest ? *rest : m.vertices); };
  auto finish = [&](ExtremalRelaxation& out, RefinedMap& m, int& flips) {
    const int n = reshape(m);
    flips += n;
    if (n > 0) std::tie(out.max_after, out.fixed_max) = max_k(m, loop, rest ? *rest : m.vertices);
  };
  int flips = 0;
  for (int round = 0;; ++round) {
    std::vector<Point2> removable;
    const bool offer = may_simplify && round < kSimplifyRounds && !map.inserted.empty();
    if (round == 0) max_before = max_k(map, loop, rest ? *rest : map.vertices).first;  // the map as it came
    flips += reshape(map);
    ExtremalRelaxation out = relax_round(source, loop, map, options, cancel, rest, t0, offer ? &removable : nullptr);
    if (!removable.empty()) {
      RefinedMap simpler = map;
      simpler.uv = std::move(removable);
      const std::size_t points = map.inserted.size();
      if (simplify_again(source, loop, options.rotation, simpler, cancel)) {
        removed += static_cast<int>(points - simpler.inserted.size());
        map = std::move(simpler);
        continue;
      }
      out = relax_round(source, loop, map, options, cancel, rest, t0, nullptr);
    }
    finish(out, map, flips);
    // The original map relaxed cannot end below fixed_before: when the smaller refinement is already there, the
    // comparison below cannot change the answer.
    if (removed > 0 && out.max_after > fixed_before) {
      // The map relaxed without removing points, for comparison: the smaller refinement's map is kept only when
      // its max K is not higher (the new triangulations of Fig. 12 are any valid ones, not the best shaped), so
      // the relaxation never raises max K and never does worse than without simplify_again.
      RefinedMap simplified = std::move(map);
      map = std::move(*original);
      int kept_flips = reshape(map);
      ExtremalRelaxation kept = relax_round(source, loop, map, options, cancel, rest, t0, nullptr);
      finish(kept, map, kept_flips);
      if (out.max_after <= kept.max_after) map = std::move(simplified);
      else out = kept, removed = 0, flips = kept_flips;
    }
    // The relaxation stops at its sweep and evaluation caps, not at a minimum: while the worst face is one a move
    // can change, relaxing the relaxed map again lowers max K further (wiggly_strip / weak_fan 170.6 -> 149.9, the
    // fixed faces' bound; mountain / weak_fan 254.6 -> 178.8 in three). Each round is kept only when it lowers max K
    // by 1 %, so max K never rises.
    for (int again = 0; again < options.relax_again && out.max_after > out.fixed_max * (1 + 1e-9); ++again) {
      RefinedMap trial = map;
      int trial_flips = 0;
      ExtremalRelaxation next = relax_round(source, loop, trial, options, cancel, rest, t0, nullptr);
      finish(next, trial, trial_flips);
      if (!(next.max_after < 0.99 * out.max_after)) break;
      map = std::move(trial);
      next.sweeps += out.sweeps, next.moves += out.moves, next.interior_moves += out.interior_moves;
      next.polished = next.polished || out.polished;
      out = next;
      flips += trial_flips;
    }
    out.max_before = max_before;
    out.points_removed = removed;
    out.edge_flips = flips;
    out.ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    return out;
  }
}

}  // namespace lipmap
