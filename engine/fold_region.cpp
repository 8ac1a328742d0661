// The regions around a map's folds, cut out as disk meshes, and their refined maps spliced back
// (engine/fold_region.h).
#include "engine/fold_region.h"

#include <algorithm>
#include <cmath>

#include "engine/boundary_polygon.h"
#include "engine/flip_check.h"
#include "engine/mesh_topology.h"

namespace lipmap {
namespace {

constexpr double kTwoPi = 6.283185307179586;

// The angle at a of triangle (a, b, c), from b - a counterclockwise to c - a, in (-pi, pi]: positive exactly
// for a counterclockwise triangle (up to rounding).
double corner_angle(const Point2& a, const Point2& b, const Point2& c) {
  const double ux = b.x - a.x, uy = b.y - a.y, vx = c.x - a.x, vy = c.y - a.y;
  return std::atan2(ux * vy - uy * vx, ux * vx + uy * vy);
}

// A polygon's interior angle at p (interior on the left), in [0, 2 pi): from the edge to next,
// counterclockwise, to the edge to prev.
double polygon_angle(const Point2& prev, const Point2& p, const Point2& next) {
  const double a = corner_angle(p, next, prev);
  return a < 0 ? a + kTwoPi : a;
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
                        const std::vector<double>& full_turn, std::vector<FoldRegion>& regions) {
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
      // The angle the region must fill at v: v's full turn less the (positive) faces outside the region.
      double inside = full_turn[v];
      for (int h : topo.fan(v))
        if (!in[MeshTopology::face_of(h)]) {
          const Triangle& t = source.faces[MeshTopology::face_of(h)];
          const int c = t[0] == v ? 0 : t[1] == v ? 1 : 2;
          inside -= corner_angle(uv[v], uv[t[(c + 1) % 3]], uv[t[(c + 2) % 3]]);
        }
      const double alpha = polygon_angle(b.positions[(k + m - 1) % m], b.positions[k], b.positions[(k + 1) % m]);
      const double turns = (inside - alpha) / kTwoPi;
      const long r = std::lround(turns);
      if (r < 0 || r > kMaxRotationIndex || std::abs(turns - static_cast<double>(r)) > 0.1)
        return "a region's boundary vertex would need rotation index " + std::to_string(turns);
      b.rotation_indices->push_back(r);
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

  // The full turn each vertex must have: 2 pi inside, the polygon's angle plus 2 pi R_k on the boundary.
  std::vector<double> full_turn(nv, kTwoPi);
  for (int k = 0; k < n; ++k)
    full_turn[loop[k]] = polygon_angle(polygon[(k + n - 1) % n], polygon[k], polygon[(k + 1) % n]) + kTwoPi * rotation[k];

  // Seeds: the corners of non-positive faces, and vertices whose positive star does not make their full turn.
  std::vector<char> positive(nf), near(nv, 0), all_positive(nv, 1);
  std::vector<double> turn(nv, 0);
  for (int f = 0; f < nf; ++f) {
    const Triangle& t = source.faces[f];
    positive[f] = orientation_sign(uv[t[0]], uv[t[1]], uv[t[2]]) > 0;
    out.seed_faces += !positive[f];
    for (int k = 0; k < 3; ++k) {
      if (!positive[f]) near[t[k]] = 1, all_positive[t[k]] = 0;
      else turn[t[k]] += corner_angle(uv[t[k]], uv[t[(k + 1) % 3]], uv[t[(k + 2) % 3]]);
    }
  }
  // (A positive star's angle sum differs from the full turn by a multiple of 2 pi; 1 rad separates them.)
  for (int v = 0; v < nv; ++v)
    if (all_positive[v] && std::abs(turn[v] - full_turn[v]) > 1) {
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
    out.failure = cut_regions(source, in, uv, full_turn, out.regions);
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
