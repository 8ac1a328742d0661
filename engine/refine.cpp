// Stage "refine" (paper 4, "Source mesh refinement", Fig. 10-12).
//
// A source face with inserted points on its edges is a "refined polygon"; its image polygon runs through
// f at the corners and at the inserted points. A polygon is usable when its image has a triangulation with
// positive triangles whose angles are the polygon's own interior angles (self-overlapping, all R_i = 0) and
// in which no triangle has all three corners on one original edge (it would be flat in 3D). The one
// exception: at a corner that is a singular boundary vertex of a weakly self-overlapping target, the face
// may wrap around it (R > 0 there, at most the classification's R). The same
// test drives the refinement loop, the simplification rounds and the final compatible triangulation, so
// every decision is made on the doubles that are returned, with exact predicates.
#include "engine/refine.h"

#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <cstdio>
#include <cstdlib>

#include "engine/detail/disk_walk.h"
#include "engine/detail/exact_predicates.h"
#include "engine/detail/shor_van_wyk.h"

namespace lipmap {
namespace {

using detail::Pt;
using detail::pt;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

struct EdgePoint {
  double t = 0;  // from the edge's lower vertex index towards the higher one
  Point2 uv;
  bool removed = false;
};

// A vertex of a refined polygon: an original vertex, or point `index` of edge `edge`.
struct PolyVertex {
  int vertex = -1, edge = -1, index = -1;
  Point2 uv;
  unsigned edges = 0;  // bit i: lies on the face's edge i (corner i to corner i + 1)
  int singular = 0;    // the classification's R at a corner that is a boundary vertex, else 0
  bool same(const PolyVertex& o) const { return vertex == o.vertex && edge == o.edge && index == o.index; }
};

class Refiner {
public:
  Refiner(const DiskMesh& source, const std::vector<int>& loop, const std::vector<int>& rotation,
          const std::vector<Point2>& source_disk, const TargetMesh& target, const std::vector<Point2>& target_disk,
          const Composition& composition, const CancelToken* cancel)
      : source_(source), faces_(source.faces), source_disk_(source_disk), uv_(composition.uv),
        walk_owned_(composition.walk ? composition.walk
                                     : std::make_shared<const detail::DiskWalk>(target_disk, target.vertices, target.faces,
                                                                                target.topology)),
        walk_(walk_owned_.get()), cancel_(cancel) {
    const int nv = static_cast<int>(source.vertices.size());
    start_face_ = composition.target_face;
    double extent = 0;  // of the target polygon, for the rounding tolerance of drop_repeated_images
    for (const Point2& p : target.vertices) extent = std::max({extent, std::abs(p.x), std::abs(p.y)});
    image_tolerance_ = 1e-12 * extent;
    singular_.assign(nv, 0);
    for (int k = 0; k < static_cast<int>(loop.size()); ++k) {
      start_face_[loop[k]] = walk_->face_at_vertex(k);
      singular_[loop[k]] = rotation[k];
    }
    build_edges();
  }

  // A refined map as it is (simplify_again): the original vertices' uv and the inserted points on their edges.
  // Every polygon already has a triangulation (the map's own) and the rounds of Fig. 11 only remove points
  // from polygons that stay usable, so no point is ever inserted: there is no walk.
  Refiner(const DiskMesh& source, const std::vector<int>& loop, const std::vector<int>& rotation, const RefinedMap& map,
          const CancelToken* cancel)
      : source_(source), faces_(source.faces), source_disk_(no_disk_),
        uv_(map.uv.begin(), map.uv.begin() + static_cast<std::ptrdiff_t>(source.vertices.size())), walk_(nullptr),
        cancel_(cancel) {
    singular_.assign(source.vertices.size(), 0);
    for (std::size_t k = 0; k < loop.size() && k < rotation.size(); ++k) singular_[loop[k]] = rotation[k];
    build_edges();
    const std::size_t nv = source.vertices.size();
    for (std::size_t i = 0; i < map.inserted.size(); ++i) {
      const InsertedVertex& iv = map.inserted[i];
      const int e = source.topology.find_edge(iv.a, iv.b);
      if (e < 0) throw InternalError("refine: an inserted point is not on an edge of the source mesh");
      points_[e].push_back({iv.t, map.uv[nv + i], false});
    }
    for (int e = 0; e < static_cast<int>(points_.size()); ++e) {
      if (points_[e].empty()) continue;
      std::sort(points_[e].begin(), points_[e].end(), [](const EdgePoint& p, const EdgePoint& q) { return p.t < q.t; });
      edge_done_[e] = 1;
      point_base_[e] = point_count_;
      point_count_ += static_cast<long long>(points_[e].size());
    }
  }

  // Inserted points currently in the refinement (not removed).
  long long live_points() const {
    long long n = 0;
    for (const auto& pts : points_)
      for (const EdgePoint& p : pts) n += p.removed ? 0 : 1;
    return n;
  }

  // simplify_again: the rounds of Fig. 11 and the triangulation of Fig. 12 on the map as it is. False (out
  // untouched) when no point went, or when a face found no triangulation.
  bool simplify_map(RefinedMap& out) {
    const long long before = live_points();
    simplify();
    if (live_points() == before) return false;
    triangulate_all();
    if (!failed_faces_.empty()) return false;
    RefinedMap fresh;
    assemble(fresh);
    out.vertices = std::move(fresh.vertices);
    out.faces = std::move(fresh.faces);
    out.uv = std::move(fresh.uv);
    out.inserted = std::move(fresh.inserted);
    return true;
  }

  RefinedMap run(bool refine) {
    RefinedMap out;
    const std::vector<int> bad = initially_bad_faces(out.flipped_before_refinement);
    if (!refine) {
      out.vertices = source_.vertices;
      out.faces = faces_;
      out.uv = uv_;
      return out;
    }
    auto t0 = Clock::now();
    refine_from(bad);
    out.refine_ms = ms_since(t0);
    out.points_before_simplification = static_cast<int>(live_points());

    t0 = Clock::now();
    out.simplification_rounds = simplify();
    out.simplify_ms = ms_since(t0);

    t0 = Clock::now();
    triangulate_all();
    assemble(out);
    out.triangulate_ms = ms_since(t0);
    for (int e = 0; e < static_cast<int>(points_.size()); ++e)
      if (edge_done_[e] && !points_[e].empty()) out.refined_faces += edge_faces_[e][1] >= 0 ? 2 : 1;
    return out;
  }

private:
  // ---- topology ----
  // The source mesh's edges (validate's topology): per edge its two vertices and its one or two faces (the
  // face of its first half-edge first), per face its edges.
  void build_edges() {
    const MeshTopology& mesh = source_.topology;
    face_edges_.resize(faces_.size());
    for (int f = 0; f < static_cast<int>(faces_.size()); ++f)
      for (int i = 0; i < 3; ++i) face_edges_[f][i] = mesh.edge(3 * f + i);
    edge_vertices_.resize(mesh.edge_count());
    edge_faces_.resize(mesh.edge_count());
    for (int e = 0; e < mesh.edge_count(); ++e) {
      const HalfedgeRange uses = mesh.edge_uses(e);
      edge_vertices_[e] = mesh.edge_vertices(e);
      edge_faces_[e] = {MeshTopology::face_of(uses[0]), uses.size() > 1 ? MeshTopology::face_of(uses[1]) : -1};
    }
    points_.resize(edge_vertices_.size());
    point_base_.assign(edge_vertices_.size(), 0);
    edge_done_.assign(edge_vertices_.size(), 0);
  }

  int across(int f, int i) const {  // the face on the other side of edge i of f, or -1
    const auto& ef = edge_faces_[face_edges_[f][i]];
    return ef[0] == f ? ef[1] : ef[0];
  }

  // ---- the image polygon of a refined face ----
  std::vector<PolyVertex> polygon(int f) const {
    std::vector<PolyVertex> poly;
    for (int i = 0; i < 3; ++i) {
      const int c = faces_[f][i];
      poly.push_back({c, -1, -1, uv_[c], (1u << i) | (1u << ((i + 2) % 3)), singular_[c]});
      const int e = face_edges_[f][i];
      const std::vector<EdgePoint>& pts = points_[e];
      const bool ascending = edge_vertices_[e][0] == c;
      for (std::size_t k = 0; k < pts.size(); ++k) {
        const int idx = static_cast<int>(ascending ? k : pts.size() - 1 - k);
        if (!pts[idx].removed) poly.push_back({-1, e, idx, pts[idx].uv, 1u << i});
      }
    }
    return poly;
  }

  static std::vector<Pt> points_of(const std::vector<PolyVertex>& poly) {
    std::vector<Pt> pts;
    pts.reserve(poly.size());
    for (const PolyVertex& v : poly) pts.emplace_back(v.uv.x, v.uv.y);
    return pts;
  }

  // The turning number t of the image says how many extra turns (t - 1) the triangulation must take; they
  // can only sit at singular corners, within each one's R. Every split of them is tried (a face has at
  // most three corners, so there are few).
  static std::optional<std::vector<Triangle>> triangulate(const std::vector<PolyVertex>& poly) {
    const std::vector<Pt> pts = points_of(poly);
    const detail::AllowedTriangle not_flat = [&](int i, int k, int j) {
      return (poly[i].edges & poly[k].edges & poly[j].edges) == 0;
    };
    const int extra = detail::turning_number(pts) - 1;
    if (extra == 0) return detail::triangulate_self_overlapping(pts, &not_flat);
    if (extra < 0) return std::nullopt;
    std::vector<int> corners;
    for (int k = 0; k < static_cast<int>(poly.size()); ++k)
      if (poly[k].singular > 0) corners.push_back(k);
    std::vector<int> rotation(poly.size(), 0);
    std::optional<std::vector<Triangle>> found;
    auto spread = [&](auto&& self, std::size_t c, int left) -> void {
      if (found) return;
      if (c == corners.size()) {
        if (left == 0) found = detail::triangulate_with_rotation(pts, rotation, &not_flat);
        return;
      }
      for (int r = std::min(left, poly[corners[c]].singular); r >= 0; --r) {
        rotation[corners[c]] = r;
        self(self, c + 1, left - r);
      }
      rotation[corners[c]] = 0;
    };
    spread(spread, 0, extra);
    return found;
  }

  bool usable(int f) const { return triangulate(polygon(f)).has_value(); }

  // ---- stage 1: which faces need refinement ----
  // Faces whose image is not strictly positive, and the faces around interior vertices whose image
  // one-ring does not wind exactly once (positive triangles can still wrap twice, paper Fig. 1a).
  std::vector<int> initially_bad_faces(int& flipped) {
    const int nf = static_cast<int>(faces_.size());
    std::vector<char> bad(nf, 0);
    flipped = 0;
    for (int f = 0; f < nf; ++f) {
      const Triangle& t = faces_[f];
      if (detail::orient(pt(uv_[t[0]]), pt(uv_[t[1]]), pt(uv_[t[2]])) <= 0) { bad[f] = 1; ++flipped; }
    }
    const MeshTopology& mesh = source_.topology;
    for (int v = 0; v < mesh.vertex_count(); ++v) {
      if (mesh.is_boundary_vertex(v)) continue;
      bool all_positive = true;
      for (int h : mesh.fan(v)) all_positive = all_positive && !bad[MeshTopology::face_of(h)];
      if (all_positive && positive_winding(v) != 1)
        for (int h : mesh.fan(v)) bad[MeshTopology::face_of(h)] = 1;
    }
    std::vector<int> out;
    for (int f = 0; f < nf; ++f)
      if (bad[f]) out.push_back(f);
    return out;
  }

  // Full turns of the image one-ring around interior vertex v, summing its faces' corner sweeps (App. B).
  // Each side of a corner points at the first remaining point on that edge, or at the far vertex.
  int winding(int v) const {
    const MeshTopology& mesh = source_.topology;
    std::vector<detail::FanCorner>& fan = fan_scratch_;  // reused: no allocation per vertex
    fan.clear();
    for (int h : mesh.fan(v)) {
      const int g = MeshTopology::prev(h);
      fan.push_back({mesh.to(h), mesh.from(g), ray_point(v, mesh.edge(h)), ray_point(v, mesh.edge(g))});
    }
    return detail::fan_turns(pt(uv_[v]), fan);
  }

  // winding(v) before any point is inserted, when every face around v is strictly positive: each corner
  // then sweeps less than pi from next to prev, and the comparison count of App. B's turns applies.
  int positive_winding(int v) const {
    const MeshTopology& mesh = source_.topology;
    detail::PositiveChainTurns turns(pt(uv_[v]));
    for (int h : mesh.fan(v)) turns.add(pt(uv_[mesh.to(h)]), pt(uv_[mesh.from(MeshTopology::prev(h))]));
    return turns.turns();
  }

  // Where the image of edge e leaves v: its first remaining point seen from v, or its other end.
  Pt ray_point(int v, int e) const {
    const std::vector<EdgePoint>& pts = points_[e];
    const bool from_low = edge_vertices_[e][0] == v;
    for (std::size_t k = 0; k < pts.size(); ++k) {
      const EdgePoint& p = pts[from_low ? k : pts.size() - 1 - k];
      if (!p.removed) return pt(p.uv);
    }
    return pt(uv_[from_low ? edge_vertices_[e][1] : edge_vertices_[e][0]]);
  }

  // ---- stage 2: the refinement loop of paper 4 ----
  // The paper inserts every crossing of a refined edge and lets Fig. 11 remove what is not needed. Here an
  // edge starts with its first and last crossings only (so the rays leaving its two ends are the true
  // ones, as with every crossing), and a face whose polygon is not usable gets the middle crossing of every
  // gap on its edges, level after level, until it is usable or its edges carry every crossing (then it is
  // the paper's polygon, which is usable). Polygons stay small, and the rounds of Fig. 11 start close to
  // their end.
  void insert_crossings(int e) {
    edge_done_[e] = 1;
    if (edge_faces_[e][1] < 0) return;  // boundary edges coincide with h_t(M_t)'s boundary: nothing crosses
    const int a = edge_vertices_[e][0], b = edge_vertices_[e][1];
    point_base_[e] = point_count_;
    for (const detail::Crossing& c : walk_->crossings(pt(source_disk_[a]), pt(source_disk_[b]), start_face_[a]))
      points_[e].push_back({c.t, c.uv, false});
    drop_repeated_images(e);
    point_count_ += static_cast<long long>(points_[e].size());
    for (std::size_t k = 1; k + 1 < points_[e].size(); ++k) points_[e][k].removed = true;
  }

  // Puts back the middle crossing of every gap between remaining points on one edge of f: the edge with the
  // widest gap, so that each step changes as few neighbours as possible. False when every crossing of
  // every edge of f is already there.
  bool densify(int f, std::vector<char>& changed_edge) {
    int widest = 0, edge = -1;
    for (int i = 0; i < 3; ++i) {
      const int gap = widest_gap(face_edges_[f][i]);
      if (gap > widest) { widest = gap; edge = i; }
    }
    if (edge < 0) return false;
    std::vector<EdgePoint>& pts = points_[face_edges_[f][edge]];
    int last = -1;
    for (int k = 0; k < static_cast<int>(pts.size()); ++k) {
      if (pts[k].removed) continue;
      if (last >= 0 && k - last > 1) pts[(last + k) / 2].removed = false;
      last = k;
    }
    changed_edge[edge] = 1;
    return true;
  }

  int widest_gap(int e) const {  // the most removed crossings between two remaining ones on e
    int widest = 0, last = -1;
    for (int k = 0; k < static_cast<int>(points_[e].size()); ++k) {
      if (points_[e][k].removed) continue;
      if (last >= 0) widest = std::max(widest, k - last - 1);
      last = k;
    }
    return widest;
  }

  void refine_from(std::vector<int> bad) {
    std::vector<char> queued(faces_.size(), 0);
    while (!bad.empty()) {
      std::vector<int> stack(bad.rbegin(), bad.rend());
      for (int f : bad) queued[f] = 1;
      run_refinement(stack, queued);
      bad = faces_around_wrong_windings();
    }
  }

  void run_refinement(std::vector<int>& stack, std::vector<char>& queued) {
    int steps = 0;
    while (!stack.empty()) {
      if (++steps % 256 == 0) check_cancel(cancel_);
      const int f = stack.back();
      stack.pop_back();
      queued[f] = 0;
      std::vector<char> changed(3, 0);
      for (int i = 0; i < 3; ++i)
        if (!edge_done_[face_edges_[f][i]]) {
          insert_crossings(face_edges_[f][i]);
          changed[i] = 1;
        }
      while (!usable(f) && densify(f, changed)) {}
      for (int i = 0; i < 3; ++i) {
        const int g = across(f, i);
        if (changed[i] && g >= 0 && !queued[g] && !usable(g)) {
          queued[g] = 1;
          stack.push_back(g);
        }
      }
    }
  }

  // Interior vertices at a refined edge whose image one-ring no longer winds once: every edge around them
  // is refined, so that the rays leaving them are the true ones; their faces are checked again.
  std::vector<int> faces_around_wrong_windings() {
    std::vector<int> out;
    const MeshTopology& mesh = source_.topology;
    for (int v = 0; v < mesh.vertex_count(); ++v) {
      if (mesh.is_boundary_vertex(v)) continue;
      bool touched = false, all_done = true;
      for (int h : mesh.fan(v)) {
        for (int e : {mesh.edge(h), mesh.edge(MeshTopology::prev(h))}) {  // the two edges at v
          touched = touched || !points_[e].empty();
          all_done = all_done && edge_done_[e];
        }
      }
      if (!touched || all_done || winding(v) == 1) continue;
      for (int h : mesh.fan(v)) out.push_back(MeshTopology::face_of(h));
    }
    return out;
  }

  bool has_points(int f) const {
    for (int i = 0; i < 3; ++i)
      for (const EdgePoint& p : points_[face_edges_[f][i]])
        if (!p.removed) return true;
    return false;
  }

  bool fully_refined(int f) const {
    for (int i = 0; i < 3; ++i) {
      const int e = face_edges_[f][i];
      if (!edge_done_[e]) return false;
      for (const EdgePoint& p : points_[e])
        if (p.removed) return false;
    }
    return true;
  }

  // ---- stage 3: simplification rounds of Fig. 11 ----
  // A point that stayed after a round can only become removable when one of its two polygons changed, so
  // later rounds look only at the edges of faces that lost a point in the round before. On each edge the
  // remaining points are tried as a run: all of them, then each half, down to single points, so an edge
  // that needs few of its points costs a few tests rather than one per point.
  int simplify() {
    const int ne = static_cast<int>(points_.size());
    std::vector<char> look(ne, 1), next(ne, 0);
    face_version_.assign(faces_.size(), 0);
    failed_runs_.assign(points_.size(), {});
    int rounds = 0;
    for (bool changed = true; changed;) {
      changed = false;
      ++rounds;
      check_cancel(cancel_);
      std::fill(next.begin(), next.end(), 0);
      for (int e = 0; e < ne; ++e) {
        if (!look[e] || edge_faces_[e][1] < 0) continue;
        std::vector<int> kept;
        for (int i = 0; i < static_cast<int>(points_[e].size()); ++i)
          if (!points_[e][i].removed) kept.push_back(i);
        if (kept.empty()) continue;
        std::vector<FailedRun>& failed = failed_runs_[e];  // drop what its faces' changes made stale
        failed.erase(std::remove_if(failed.begin(), failed.end(),
                                    [&](const FailedRun& r) { return face_version_[r.face] != r.version; }),
                     failed.end());
        if (!remove_runs(e, kept, 0, static_cast<int>(kept.size()))) continue;
        changed = true;
        for (int f : edge_faces_[e])
          for (int k = 0; k < 3; ++k) next[face_edges_[f][k]] = 1;
      }
      look.swap(next);
    }
    return rounds;
  }

  // Tries to remove the run kept[lo, hi) of edge e's points; when that fails, each half of it, recursively.
  bool remove_runs(int e, const std::vector<int>& kept, int lo, int hi) {
    if (run_removable(e, kept, lo, hi)) {
      for (int k = lo; k < hi; ++k) points_[e][kept[k]].removed = true;
      for (int f : edge_faces_[e]) ++face_version_[f];
      failed_runs_[e].clear();
      return true;
    }
    if (hi - lo == 1) return false;
    const int mid = lo + (hi - lo) / 2;
    const bool left = remove_runs(e, kept, lo, mid);
    return remove_runs(e, kept, mid, hi) || left;
  }

  // The run can go when both polygons stay usable with the same turning number and the angle sums at the
  // run's two neighbours along the edge are unchanged (the neighbouring wedges still add up to the same
  // number of full turns).
  bool run_removable(int e, const std::vector<int>& kept, int lo, int hi) {
    const int f1 = edge_faces_[e][0], f2 = edge_faces_[e][1];
    const std::vector<PolyVertex> before1 = polygon(f1), before2 = polygon(f2);
    const PolyVertex y = run_neighbour(e, kept, lo - 1, edge_vertices_[e][0]);
    const PolyVertex z = run_neighbour(e, kept, hi, edge_vertices_[e][1]);
    const PolyVertex first = run_neighbour(e, kept, lo, -1), last = run_neighbour(e, kept, hi - 1, -1);
    if (!wedge_kept(before1, before2, y, first, z) || !wedge_kept(before1, before2, z, last, y)) return false;
    // A face's polygon is a function of the removed flags on its three edges: when the run's removal left a
    // face not usable and that face has not changed since (its version), the same removal fails again.
    std::vector<FailedRun>& failed = failed_runs_[e];
    const int first_point = kept[lo], last_point = kept[hi - 1];
    for (const FailedRun& r : failed)
      if (r.first == first_point && r.last == last_point && face_version_[r.face] == r.version) return false;
    for (int k = lo; k < hi; ++k) points_[e][kept[k]].removed = true;
    bool ok = same_turning(before1, f1) && same_turning(before2, f2);
    // Test first the face that refused this edge's latest run: a run's halves mostly fail where the run did.
    const bool second_first = !failed.empty() && failed.back().face == f2;
    for (int f : {second_first ? f2 : f1, second_first ? f1 : f2}) {
      if (!ok) break;
      if (!(ok = usable(f))) failed.push_back({first_point, last_point, f, face_version_[f]});
    }
    for (int k = lo; k < hi; ++k) points_[e][kept[k]].removed = false;
    return ok;
  }

  // kept[k] as a polygon vertex, or the edge's end `vertex` when k is outside the kept points.
  PolyVertex run_neighbour(int e, const std::vector<int>& kept, int k, int vertex) const {
    if (k < 0 || k >= static_cast<int>(kept.size())) return {vertex, -1, -1, uv_[vertex], 0};
    return {-1, e, kept[k], points_[e][kept[k]].uv, 0};
  }

  bool same_turning(const std::vector<PolyVertex>& before, int f) const {
    return detail::turning_number(points_of(before)) == detail::turning_number(points_of(polygon(f)));
  }

  static int find(const std::vector<PolyVertex>& poly, const PolyVertex& v) {
    for (int k = 0; k < static_cast<int>(poly.size()); ++k)
      if (poly[k].same(v)) return k;
    return -1;
  }

  // At y, the ray towards x becomes the ray towards z. In the polygon whose next vertex after y is x the
  // wedge at y starts at x; in the other it ends at x. Their union must keep its number of full turns.
  static bool wedge_kept(const std::vector<PolyVertex>& p1, const std::vector<PolyVertex>& p2,
                         const PolyVertex& y, const PolyVertex& x, const PolyVertex& z) {
    const PolyVertex* wedge_end = nullptr;    // in the polygon where x follows y: the wedge x -> prev(y)
    const PolyVertex* wedge_start = nullptr;  // in the polygon where x precedes y: the wedge next(y) -> x
    for (const auto* poly : {&p1, &p2}) {
      const int k = find(*poly, y);
      if (k < 0) return false;
      const int n = static_cast<int>(poly->size());
      const PolyVertex& next = (*poly)[(k + 1) % n];
      const PolyVertex& prev = (*poly)[(k + n - 1) % n];
      if (next.same(x)) wedge_end = &prev;
      else if (prev.same(x)) wedge_start = &next;
    }
    if (!wedge_end || !wedge_start) return false;
    const Pt c = pt(y.uv), from = pt(wedge_start->uv), to = pt(wedge_end->uv);
    return detail::extra_turn(c, from, pt(x.uv), to) == detail::extra_turn(c, from, pt(z.uv), to);
  }

  // ---- stage 4: compatible triangulation of Fig. 12 ----
  // A polygon without a valid triangulation gets back every point of its edges (refining edges not yet
  // refined); its neighbours are then triangulated again. A fully refined polygon that still has none is
  // a failure, reported by verify's caller as an internal error.
  void triangulate_all() {
    const int nf = static_cast<int>(faces_.size());
    triangles_.assign(nf, {});
    as_is_.assign(nf, 0);
    subdivisions_.assign(nf, 0);
    std::vector<int> work(nf);
    for (int f = 0; f < nf; ++f) work[f] = nf - 1 - f;
    std::vector<char> queued(nf, 1);
    int steps = 0;
    while (!work.empty()) {
      if (++steps % 4096 == 0) check_cancel(cancel_);
      const int f = work.back();
      work.pop_back();
      queued[f] = 0;
      if (!has_points(f)) {  // the common case: the source triangle itself, when its image is positive
        const Triangle& t = faces_[f];
        if (detail::orient(pt(uv_[t[0]]), pt(uv_[t[1]]), pt(uv_[t[2]])) > 0) {
          triangles_[f].clear();
          as_is_[f] = 1;
          continue;
        }
      }
      const std::vector<PolyVertex> poly = polygon(f);
      std::optional<std::vector<Triangle>> tri;
      if (poly.size() == 3) {
        if (detail::orient(pt(poly[0].uv), pt(poly[1].uv), pt(poly[2].uv)) > 0) tri = std::vector<Triangle>{{0, 1, 2}};
      } else {
        tri = triangulate(poly);
      }
      as_is_[f] = 0;
      if (tri) {
        triangles_[f].clear();
        for (const Triangle& t : *tri) triangles_[f].push_back({key(poly[t[0]]), key(poly[t[1]]), key(poly[t[2]])});
        continue;
      }
      if (!walk_ || (fully_refined(f) && subdivisions_[f] >= kMaxSubdivisions)) {
        failed_faces_.push_back(f);
        triangles_[f].clear();
        continue;
      }
      const bool subdivide = fully_refined(f);
      if (subdivide) ++subdivisions_[f];
      for (int i = 0; i < 3; ++i) {
        const int e = face_edges_[f][i];
        if (!edge_done_[e]) insert_crossings(e);
        for (EdgePoint& p : points_[e]) p.removed = false;
        if (subdivide) subdivide_edge(e);
        const int g = across(f, i);
        if (g >= 0 && !queued[g]) { queued[g] = 1; work.push_back(g); }
      }
      queued[f] = 1;
      work.push_back(f);
    }
  }

  // A point whose image coincides, up to rounding, with the image of the point before it along the edge (or
  // of the edge's far end) adds nothing to the image polygon but a side of rounding-error length whose
  // direction is noise, which breaks the polygon's angles. It happens when a source vertex lands on, or
  // within rounding of, a target vertex in the disk: the walk then crosses that vertex at t ~ 0 while the
  // barycentric image of the source vertex rounds a few ulps away. Such points are dropped; every decision
  // after this is still made exactly on the doubles that remain.
  bool same_image(const Point2& p, const Point2& q) const {
    return std::abs(p.x - q.x) <= image_tolerance_ && std::abs(p.y - q.y) <= image_tolerance_;
  }

  void drop_repeated_images(int e) {
    const auto [a, b] = edge_vertices_[e];
    std::vector<EdgePoint> kept;
    Point2 previous = uv_[a];
    for (const EdgePoint& p : points_[e]) {
      if (same_image(p.uv, previous)) continue;
      kept.push_back(p);
      previous = p.uv;
    }
    while (!kept.empty() && same_image(kept.back().uv, uv_[b])) kept.pop_back();
    points_[e] = std::move(kept);
  }

  // Fallback when even every crossing leaves a face without a valid triangulation (paper Fig. 12 can fail
  // when the face's image is a bent channel between two edge chains and its third edge is on the boundary,
  // where no point may go): halve every segment of the face's interior edges. Between two crossings the
  // edge lies in one target face, where f is affine, so the new points sit on the image's straight sides
  // and give the triangulation more vertices to connect across. Inserted points stay on original edges.
  void subdivide_edge(int e) {
    if (edge_faces_[e][1] < 0) return;  // never on the boundary
    // Plain names, not a structured binding: the lambda below captures a, which C++17 does not allow for
    // a binding (GCC accepts it, Clang refuses).
    const int a = edge_vertices_[e][0], b = edge_vertices_[e][1];
    const Point2 &A = source_disk_[a], &B = source_disk_[b];
    std::vector<EdgePoint> finer;
    double last = 0;
    auto add_midpoint = [&](double t0, double t1) {
      const double t = 0.5 * (t0 + t1);
      if (!(t > t0 && t < t1)) return;  // the segment is too short to halve in double
      const Pt q(A.x + t * (B.x - A.x), A.y + t * (B.y - A.y));
      const int face = walk_->locate(q, start_face_[a]);
      finer.push_back({t, walk_->target_point(q, face), false});
    };
    for (const EdgePoint& p : points_[e]) {
      add_midpoint(last, p.t);
      finer.push_back(p);
      last = p.t;
    }
    add_midpoint(last, 1);
    points_[e] = std::move(finer);
    drop_repeated_images(e);
    point_base_[e] = point_count_;  // fresh keys: the two faces of e are triangulated again anyway
    point_count_ += static_cast<long long>(points_[e].size());
  }

  // Vertex keys before numbering: original vertex v is v; point k of edge e is -1 - (point_base_[e] + k).
  // An edge receives its points once, so the keys never change.
  long long key(const PolyVertex& v) const {
    if (v.vertex >= 0) return v.vertex;
    return -1 - (point_base_[v.edge] + v.index);
  }

  void assemble(RefinedMap& out) {
    if (!failed_faces_.empty()) {
      throw InternalError("refine: no compatible triangulation exists for source face " +
                          std::to_string(failed_faces_.front()) + " even with every intersection point inserted (" +
                          std::to_string(failed_faces_.size()) + " faces)");
    }
    out.vertices = source_.vertices;
    out.uv = uv_;
    const long long nv = static_cast<long long>(source_.vertices.size());
    std::vector<int> id(static_cast<std::size_t>(point_count_), -1);
    for (int e = 0; e < static_cast<int>(points_.size()); ++e) {
      const auto [a, b] = edge_vertices_[e];
      for (int k = 0; k < static_cast<int>(points_[e].size()); ++k) {
        const EdgePoint& p = points_[e][k];
        if (p.removed) continue;
        id[point_base_[e] + k] = static_cast<int>(out.vertices.size());
        out.vertices.push_back(point_on_edge(source_.vertices[a], source_.vertices[b], p.t));
        out.uv.push_back(p.uv);
        out.inserted.push_back({a, b, p.t});
      }
    }
    out.faces.reserve(faces_.size());
    for (std::size_t f = 0; f < triangles_.size(); ++f) {
      if (as_is_[f]) {  // the source face itself: its corners are original vertices
        out.faces.push_back(faces_[f]);
        continue;
      }
      for (const auto& t : triangles_[f]) {
        Triangle face;
        for (int c = 0; c < 3; ++c) {
          const long long v = t[c];
          face[c] = v >= 0 ? static_cast<int>(v) : id[-1 - v];
          if (face[c] < 0 || (v >= 0 && v >= nv)) throw InternalError("refine: triangle uses a removed point");
        }
        out.faces.push_back(face);
      }
    }
  }

  const DiskMesh& source_;
  const std::vector<Triangle>& faces_;
  const std::vector<Point2>& source_disk_;
  static inline const std::vector<Point2> no_disk_{};  // source_disk_ of a map taken as it is
  std::vector<Point2> uv_;
  std::shared_ptr<const detail::DiskWalk> walk_owned_;
  const detail::DiskWalk* walk_;  // null for a refined map taken as it is (simplify_again): nothing to insert
  const CancelToken* cancel_;
  std::vector<int> start_face_;
  double image_tolerance_ = 0;
  std::vector<int> singular_;  // per source vertex: the classification's R at boundary vertices, else 0

  std::vector<std::array<int, 3>> face_edges_;
  std::vector<std::array<int, 2>> edge_vertices_, edge_faces_;
  std::vector<std::vector<EdgePoint>> points_;
  std::vector<char> edge_done_;

  // Per face: its triangles in vertex keys, or as_is_[f] for the source face itself (the common case, kept
  // out of triangles_ so that a map with nothing to refine allocates nothing per face).
  std::vector<std::vector<std::array<long long, 3>>> triangles_;
  std::vector<char> as_is_;
  mutable std::vector<detail::FanCorner> fan_scratch_;  // winding()'s one-ring
  std::vector<int> failed_faces_;
  // The simplification's memo of refused runs: per edge, runs (first and last point) whose removal left a
  // face not usable, with that face's version then; a face's version counts the removals on its edges.
  struct FailedRun {
    int first, last, face;
    unsigned version;
  };
  std::vector<std::vector<FailedRun>> failed_runs_;
  std::vector<unsigned> face_version_;
  std::vector<int> subdivisions_;  // per face: how often the fallback halved its edges
  static constexpr int kMaxSubdivisions = 6;
  std::vector<long long> point_base_;
  long long point_count_ = 0;
};

}  // namespace

RefinedMap refine(const DiskMesh& source, const std::vector<int>& loop, const std::vector<int>& rotation,
                  const std::vector<Point2>& source_disk, const TargetMesh& target,
                  const std::vector<Point2>& target_disk, const Composition& composition, bool refine,
                  const CancelToken* cancel) {
  Refiner refiner(source, loop, rotation, source_disk, target, target_disk, composition, cancel);
  return refiner.run(refine);
}

bool simplify_again(const DiskMesh& source, const std::vector<int>& loop, const std::vector<int>& rotation,
                    RefinedMap& map, const CancelToken* cancel) {
  if (map.inserted.empty()) return false;
  Refiner refiner(source, loop, rotation, map, cancel);
  return refiner.simplify_map(map);
}

std::vector<char> refined_source_faces(const DiskMesh& source, const RefinedMap& map) {
  std::vector<char> refined(source.faces.size(), 0);
  for (const InsertedVertex& iv : map.inserted) {
    const int e = source.topology.find_edge(iv.a, iv.b);
    if (e >= 0)
      for (int h : source.topology.edge_uses(e)) refined[static_cast<std::size_t>(MeshTopology::face_of(h))] = 1;
  }
  return refined;
}

}  // namespace lipmap
