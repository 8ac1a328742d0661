// The regions around a map's folds, cut out as disk meshes, and their refined maps spliced back
// (engine/fold_region.h).
#include "engine/fold_region.h"

#include <algorithm>
#include <optional>

#include "engine/boundary_polygon.h"
#include "engine/detail/exact_predicates.h"
#include "engine/mesh_topology.h"

namespace lipmap {
namespace {

using detail::pt;

// Where a vertex sits on the source's boundary polygon: loop index k (-1 inside), the polygon's neighbours
// and R_k. Its full turn is the polygon's interior angle plus 2 pi R_k, or 2 pi inside (paper 3.2).
struct FullTurns {
  const std::vector<int>& loop_index;
  const std::vector<Point2>& polygon;
  const std::vector<int>& rotation;

  // The full turns of v's full turn beyond the plain sweep from the ray to its next neighbour to the ray to
  // its previous one: 1 inside (a closed chain); on the polygon R_k, plus one at a spike (App. B).
  int turns(int v) const {
    const int k = loop_index[v];
    if (k < 0) return 1;
    const std::size_t n = polygon.size();
    return rotation[k] + (detail::sector(pt(polygon[k]), pt(polygon[(k + 1) % n]), pt(polygon[(k + n - 1) % n])) == 0);
  }
};

// One corner at v: the face's index and the sweep of its corner, counterclockwise from `from` to `to`.
struct Corner {
  int face;
  Point2 from, to;
};

// v's corners in counterclockwise order (the clockwise fan read backwards, App. B): at a boundary vertex
// from the face on the edge to its next boundary vertex to the one on the edge from its previous one.
std::vector<Corner> corners_ccw(const MeshTopology& topo, const std::vector<Point2>& uv, int v) {
  const HalfedgeRange fan = topo.fan(v);
  std::vector<Corner> out;
  out.reserve(fan.size());
  for (std::size_t i = fan.size(); i-- > 0;)
    out.push_back({MeshTopology::face_of(fan[i]), uv[topo.to(fan[i])], uv[topo.from(MeshTopology::prev(fan[i]))]});
  return out;
}

// Does v's star, all of its faces strictly positive, make its full turn (verify's angle-sum test, exactly)?
bool makes_full_turn(const MeshTopology& topo, const std::vector<Point2>& uv, const FullTurns& full, int v) {
  const std::vector<Corner> corners = corners_ccw(topo, uv, v);
  const int k = full.loop_index[v];
  if (k < 0) {
    detail::PositiveChainTurns count(pt(uv[v]));
    for (const Corner& c : corners) count.add(pt(c.from), pt(c.to));
    return count.turns() == 1;
  }
  detail::TurnCount count(pt(uv[v]), pt(corners.front().from));
  for (const Corner& c : corners) count.add(pt(c.from), pt(c.to));
  return count.turns() == full.turns(v);
}

// The rotation index a region must have at its boundary vertex v for the spliced map to make v's full turn:
// the region's corners at v (one run: make_disks saw to it) sweep from q to p, the images of its loop's next
// and previous vertex, and must fill what the positive corners outside leave of the full turn. Counted
// exactly (App. B) by chaining the outside corners with the plain sweep q -> p in place of the region's run:
// if that chain makes T full turns beyond sweep(start, end), the region's angle is sweep(q, p) + 2 pi (F - T),
// F the turns of the full turn (1 inside; on the polygon R_k, plus one at a spike). Sets q and p; nothing
// when v's region corners are not one run with corners outside (make_disks and the cut rule both out).
std::optional<int> region_rotation_index(const MeshTopology& topo, const std::vector<Point2>& uv,
                                         const FullTurns& full, const std::vector<char>& in, int v, Point2& q,
                                         Point2& p) {
  const std::vector<Corner> corners = corners_ccw(topo, uv, v);
  const int n = static_cast<int>(corners.size());
  const int k = full.loop_index[v];
  // On the polygon the chain runs from its next vertex to its previous one; inside it closes, starting just
  // after the region's run (so that the run ends the chain where it started, at p).
  int start = 0;
  if (k < 0)
    while (start < n && !(!in[corners[start].face] && in[corners[(start + n - 1) % n].face])) ++start;
  if (start == n) return std::nullopt;
  const detail::Pt c = pt(uv[v]);
  detail::TurnCount count(c, pt(corners[start].from));
  enum class Run { before, inside, after } run = Run::before;
  for (int i = 0; i < n; ++i) {
    const Corner& corner = corners[(start + i) % n];
    if (in[corner.face]) {
      if (run == Run::after) return std::nullopt;
      if (run == Run::before) q = corner.from;
      run = Run::inside;
      p = corner.to;
      continue;
    }
    if (run == Run::inside) {
      count.add(pt(q), pt(p));
      run = Run::after;
    }
    count.add(pt(corner.from), pt(corner.to));
  }
  if (run == Run::inside) count.add(pt(q), pt(p));
  return detail::rotation_index(c, pt(q), pt(p), full.turns(v) - count.turns());
}

// Runs of region faces in v's fan (cyclic for an interior vertex): more than one means the region is pinched
// at v (two pieces of it meet there, or it touches itself around a hole).
int region_runs(const MeshTopology& topo, int v, const std::vector<char>& in) {
  const HalfedgeRange fan = topo.fan(v);
  int runs = 0;
  const bool cyclic = !topo.is_boundary_vertex(v);
  for (std::size_t i = 0; i < fan.size(); ++i) {
    const bool here = in[MeshTopology::face_of(fan[i])];
    const bool before = i > 0 ? in[MeshTopology::face_of(fan[i - 1])]
                              : cyclic && in[MeshTopology::face_of(fan.back())];
    if (here && !before) ++runs;
  }
  if (cyclic && runs == 0 && !fan.empty() && in[MeshTopology::face_of(fan[0])]) runs = 1;  // the whole star
  return runs;
}

// Grows `in` until no complement piece is enclosed (touches no mesh boundary edge) and no vertex is pinched.
void make_disks(const MeshTopology& topo, std::vector<char>& in) {
  const int nf = topo.face_count();
  for (bool changed = true; changed;) {
    changed = false;
    // Enclosed complement pieces become part of the region.
    std::vector<int> piece(nf, -1), stack;
    for (int f0 = 0; f0 < nf; ++f0) {
      if (in[f0] || piece[f0] >= 0) continue;
      std::vector<int> members;
      bool open = false;
      piece[f0] = f0;
      stack.push_back(f0);
      while (!stack.empty()) {
        const int f = stack.back();
        stack.pop_back();
        members.push_back(f);
        for (int k = 0; k < 3; ++k) {
          const int g = topo.across(f, k);
          if (g < 0) open = true;
          else if (!in[g] && piece[g] < 0) piece[g] = f0, stack.push_back(g);
        }
      }
      if (!open) {
        for (int f : members) in[f] = 1;
        changed = true;
      }
    }
    for (int v = 0; v < topo.vertex_count(); ++v) {
      if (region_runs(topo, v, in) < 2) continue;
      for (int h : topo.fan(v)) in[MeshTopology::face_of(h)] = 1;
      changed = true;
    }
  }
}

// One region per edge-connected piece of `in` (after make_disks, pieces share no vertex), with its boundary
// polygon and rotation indices. Returns why not, or an empty string.
std::string cut_regions(const DiskMesh& source, const std::vector<char>& in, const std::vector<Point2>& uv,
                        const FullTurns& full, std::vector<FoldRegion>& regions) {
  const MeshTopology& topo = source.topology;
  const int nf = static_cast<int>(source.faces.size()), nv = static_cast<int>(source.vertices.size());
  std::vector<int> local(nv, -1);
  std::vector<char> taken(nf, 0);
  for (int f0 = 0; f0 < nf; ++f0) {
    if (!in[f0] || taken[f0]) continue;
    FoldRegion region;
    std::vector<int> stack{f0};
    taken[f0] = 1;
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      region.faces.push_back(f);
      for (int k = 0; k < 3; ++k) {
        const int g = topo.across(f, k);
        if (g >= 0 && in[g] && !taken[g]) taken[g] = 1, stack.push_back(g);
      }
    }
    std::sort(region.faces.begin(), region.faces.end());
    for (int f : region.faces)
      for (int v : source.faces[f]) region.vertices.push_back(v);
    std::sort(region.vertices.begin(), region.vertices.end());
    region.vertices.erase(std::unique(region.vertices.begin(), region.vertices.end()), region.vertices.end());
    const int rn = static_cast<int>(region.vertices.size());
    for (int i = 0; i < rn; ++i) local[region.vertices[i]] = i;
    std::vector<Triangle> faces;
    faces.reserve(region.faces.size());
    for (int f : region.faces) {
      const Triangle& t = source.faces[f];
      faces.push_back({local[t[0]], local[t[1]], local[t[2]]});
    }
    const MeshTopology sub(rn, faces);
    const long euler = rn - sub.edge_count() + static_cast<long>(faces.size());
    if (!sub.oriented_manifold() || sub.first_vertex_with_broken_fan() >= 0 || sub.boundary_loops().size() != 1 ||
        euler != 1)
      return "a region around the folds is not a disk";
    const std::vector<int>& sub_loop = sub.boundary_loops()[0];
    const int m = static_cast<int>(sub_loop.size());
    RawBoundary& b = region.boundary;
    b.vertices.emplace();
    b.rotation_indices.emplace();
    for (int k = 0; k < m; ++k) {
      const int v = region.vertices[sub_loop[k]];
      b.vertices->push_back(sub_loop[k]);
      b.positions.push_back(uv[v]);
    }
    for (int k = 0; k < m; ++k) {
      const int v = region.vertices[sub_loop[k]];
      if (b.positions[k] == b.positions[(k + 1) % m])
        return "two consecutive vertices of a region's boundary have the same image";
      Point2 q, p;
      const std::optional<int> r = region_rotation_index(topo, uv, full, in, v, q, p);
      // The run's ends are the loop's neighbours: the region's boundary edges are its faces' outer edges.
      if (!r || !(q == b.positions[(k + 1) % m] && p == b.positions[(k + m - 1) % m]))
        return "a region's faces at a boundary vertex are not one run between its loop's edges";
      if (*r < 0 || *r > kMaxRotationIndex)
        return "a region's boundary vertex would need rotation index " + std::to_string(*r);
      b.rotation_indices->push_back(*r);
    }
    region.mesh.vertices.reserve(rn);
    for (int v : region.vertices) region.mesh.vertices.push_back(source.vertices[v]);
    region.mesh.faces.reserve(faces.size());
    for (const Triangle& t : faces) region.mesh.faces.push_back({t[0], t[1], t[2]});
    for (int v : region.vertices) local[v] = -1;
    regions.push_back(std::move(region));
  }
  return {};
}

}  // namespace

void grow_by_rings(const std::vector<Triangle>& faces, std::vector<char>& marked, int rings) {
  for (int r = 0; r < rings; ++r) {
    std::vector<char> next = marked;
    for (const Triangle& t : faces)
      if (marked[t[0]] || marked[t[1]] || marked[t[2]]) next[t[0]] = next[t[1]] = next[t[2]] = 1;
    marked.swap(next);
  }
}

FoldRegions fold_regions(const DiskMesh& source, const std::vector<int>& loop, const std::vector<Point2>& polygon,
                         const std::vector<int>& rotation, const std::vector<Point2>& uv, int rings) {
  FoldRegions out;
  const MeshTopology& topo = source.topology;
  const int nf = static_cast<int>(source.faces.size()), nv = static_cast<int>(source.vertices.size());
  const int n = static_cast<int>(loop.size());

  std::vector<int> loop_index(nv, -1);
  for (int k = 0; k < n; ++k) loop_index[loop[k]] = k;
  const FullTurns full{loop_index, polygon, rotation};

  // Seeds: the corners of non-positive faces, and vertices whose positive star does not make its full turn.
  std::vector<char> near(nv, 0), all_positive(nv, 1);
  for (int f = 0; f < nf; ++f) {
    const Triangle& t = source.faces[f];
    if (detail::orient(uv[t[0]], uv[t[1]], uv[t[2]]) > 0) continue;
    ++out.seed_faces;
    for (int v : t) near[v] = 1, all_positive[v] = 0;
  }
  for (int v = 0; v < nv; ++v)
    if (all_positive[v] && !makes_full_turn(topo, uv, full, v)) {
      near[v] = 1;
      ++out.seed_vertices;
    }
  grow_by_rings(source.faces, near, rings);
  std::vector<char> in(nf, 0);
  for (int f = 0; f < nf; ++f) {
    const Triangle& t = source.faces[f];
    in[f] = near[t[0]] || near[t[1]] || near[t[2]];
  }
  make_disks(topo, in);
  out.region_faces = static_cast<int>(std::count(in.begin(), in.end(), 1));
  if (out.region_faces == 0) {
    out.failure = "no fold";
  } else if (2 * out.region_faces > nf) {
    out.failure = "the regions around the folds hold " + std::to_string(out.region_faces) + " of " +
                  std::to_string(nf) + " faces";
  } else {
    out.failure = cut_regions(source, in, uv, full, out.regions);
    if (!out.failure.empty()) out.regions.clear();
  }
  return out;
}

RefinedMap splice_regions(const DiskMesh& source, const std::vector<Point2>& uv, const FoldRegions& regions,
                          const std::vector<RefinedMap>& maps) {
  RefinedMap out;
  const int nv = static_cast<int>(source.vertices.size());
  out.vertices = source.vertices;
  out.uv.assign(uv.begin(), uv.begin() + nv);
  std::vector<char> replaced(source.faces.size(), 0);
  for (const FoldRegion& r : regions.regions)
    for (int f : r.faces) replaced[f] = 1;
  for (std::size_t f = 0; f < source.faces.size(); ++f)
    if (!replaced[f]) out.faces.push_back(source.faces[f]);
  for (std::size_t i = 0; i < regions.regions.size(); ++i) {
    const FoldRegion& r = regions.regions[i];
    const RefinedMap& m = maps[i];
    const int rn = static_cast<int>(r.vertices.size()), base = nv + static_cast<int>(out.inserted.size());
    // Region vertex order is source order, so an inserted vertex's edge (a < b) keeps its orientation.
    auto global = [&](int x) { return x < rn ? r.vertices[x] : base + (x - rn); };
    for (int v = 0; v < rn; ++v) out.uv[r.vertices[v]] = m.uv[v];
    for (std::size_t j = 0; j < m.inserted.size(); ++j) {
      const InsertedVertex& iv = m.inserted[j];
      out.inserted.push_back({r.vertices[iv.a], r.vertices[iv.b], iv.t});
      out.vertices.push_back(m.vertices[rn + j]);
      out.uv.push_back(m.uv[rn + j]);
    }
    for (const Triangle& t : m.faces) out.faces.push_back({global(t[0]), global(t[1]), global(t[2])});
    out.refined_faces += m.refined_faces;
    out.points_before_simplification += m.points_before_simplification;
    out.simplification_rounds = std::max(out.simplification_rounds, m.simplification_rounds);
    out.refine_ms += m.refine_ms;
    out.simplify_ms += m.simplify_ms;
    out.triangulate_ms += m.triangulate_ms;
  }
  return out;
}

}  // namespace lipmap
