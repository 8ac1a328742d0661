// Stage "target mesh" (paper 4, "Meshing the target domain"); see engine/target_mesh.h.
// CGAL's mesher lives in engine/piece_mesher.cpp; this file calls it and the engine's exact predicates.
#include "engine/target_mesh.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <string>
#include <utility>

#include "engine/detail/exact_predicates.h"
#include "engine/detail/piece_mesher.h"
#include "engine/error.h"

namespace lipmap {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

std::uint64_t edge_key(int u, int v) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(u)) << 32) | static_cast<std::uint32_t>(v);
}

double tri_area(const Point2& a, const Point2& b, const Point2& c) {
  return 0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
}

double dist(const Point2& a, const Point2& b) { return std::hypot(b.x - a.x, b.y - a.y); }

// Angle at a in triangle (a, b, c), in [0, pi].
double corner_angle(const Point2& a, const Point2& b, const Point2& c) {
  const double ux = b.x - a.x, uy = b.y - a.y, vx = c.x - a.x, vy = c.y - a.y;
  return std::atan2(std::fabs(ux * vy - uy * vx), ux * vx + uy * vy);
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

// CGAL's size criterion bounds the longest edge of each triangle; Delaunay refinement to bound S leaves
// triangles whose mean area is about that of an equilateral triangle of side S / kSizeFactor (measured).
constexpr double kSizeFactor = 1.35;
// Slope of the sizing field away from long polygon edges (target edge length lost per unit distance).
constexpr double kGrading = 1.0;
// The interior may be made finer than the nominal size h0 by at most this factor (in edge length) to make up
// for the coarser triangles along long polygon edges; beyond that the long edges' sizes are capped instead.
constexpr double kMaxInteriorRefinement = 1.5;
// Delaunay refinement makes about this many more triangles than the integral of the sizing field says
// (measured); the lattice seeded where the field is uniform is spaced to match: h / sqrt(kCountCalibration).
constexpr double kCountCalibration = 1.22;
// Samples of the sizing field for one count estimate.
constexpr double kEstimateSamples = 6000;

[[noreturn]] void fail(const std::string& why) { throw InternalError("target mesh: " + why); }

struct InteriorEdge {
  int a = -1, b = -1;    // directed a -> b in triangle t1, b -> a in t2
  int t1 = -1, t2 = -1;
  double score = 0;      // larger: removed earlier (long against its triangles)
};

// Checks that `coarse` is a triangulation of P with positive triangles and no interior vertices, and
// returns its interior edges.
std::vector<InteriorEdge> check_coarse(const std::vector<Point2>& P, const std::vector<Triangle>& coarse) {
  const int n = static_cast<int>(P.size());
  if (static_cast<int>(coarse.size()) != n - 2)
    fail("coarse triangulation has " + std::to_string(coarse.size()) + " triangles, expected n - 2 = " +
         std::to_string(n - 2));
  std::vector<std::pair<std::uint64_t, int>> directed;  // (edge, triangle * 3 + corner)
  directed.reserve(3 * coarse.size());
  for (std::size_t t = 0; t < coarse.size(); ++t) {
    const Triangle& f = coarse[t];
    for (int c = 0; c < 3; ++c)
      if (f[c] < 0 || f[c] >= n) fail("coarse triangle " + std::to_string(t) + " has a vertex out of range");
    if (detail::orient(P[f[0]], P[f[1]], P[f[2]]) <= 0)
      fail("coarse triangle " + std::to_string(t) + " is not strictly positive");
    for (int c = 0; c < 3; ++c)
      directed.emplace_back(edge_key(f[c], f[(c + 1) % 3]), static_cast<int>(3 * t + c));
  }
  std::sort(directed.begin(), directed.end());
  for (std::size_t i = 1; i < directed.size(); ++i)
    if (directed[i].first == directed[i - 1].first)
      fail("coarse triangulation uses directed edge (" + std::to_string(directed[i].first >> 32) + ", " +
           std::to_string(directed[i].first & 0xffffffffu) + ") twice");
  auto find = [&](int u, int v) -> int {
    auto it = std::lower_bound(directed.begin(), directed.end(), std::make_pair(edge_key(u, v), -1));
    return (it != directed.end() && it->first == edge_key(u, v)) ? it->second : -1;
  };
  std::vector<InteriorEdge> interior;
  interior.reserve(n > 3 ? n - 3 : 0);
  for (const auto& [key, tc] : directed) {
    const int u = static_cast<int>(key >> 32), v = static_cast<int>(key & 0xffffffffu);
    if (v == (u + 1) % n) continue;  // polygon edge
    const int rev = find(v, u);
    if (rev < 0)
      fail("coarse edge (" + std::to_string(u) + ", " + std::to_string(v) +
           ") is neither a polygon edge nor shared by two triangles");
    if (u < v) {
      InteriorEdge e;
      e.a = u, e.b = v, e.t1 = tc / 3, e.t2 = rev / 3;
      const double l = dist(P[u], P[v]);
      const Triangle& f1 = coarse[e.t1];
      const Triangle& f2 = coarse[e.t2];
      const double amin = std::min(tri_area(P[f1[0]], P[f1[1]], P[f1[2]]), tri_area(P[f2[0]], P[f2[1]], P[f2[2]]));
      e.score = l * l / amin;
      interior.push_back(e);
    }
  }
  for (int k = 0; k < n; ++k)
    if (find(k, (k + 1) % n) < 0)
      fail("polygon edge (" + std::to_string(k) + ", " + std::to_string((k + 1) % n) +
           ") is not an edge of the coarse triangulation");
  if (static_cast<int>(interior.size()) != n - 3) fail("coarse triangulation has the wrong number of interior edges");
  // n - 2 triangles joined by n - 3 edges: connected iff the dual graph is a tree (no interior vertex).
  std::vector<int> parent(coarse.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const InteriorEdge& e : interior) {
    const int r1 = root(e.t1), r2 = root(e.t2);
    if (r1 == r2) fail("coarse triangulation has an interior vertex (its dual graph has a cycle)");
    parent[r1] = r2;
  }
  return interior;
}

struct Partition {
  std::vector<std::vector<int>> cycles;  // pieces as boundary cycles of polygon vertex ids (counterclockwise)
  std::vector<int> piece_of;             // coarse triangle -> piece
};

// Step 1.
Partition partition(const std::vector<Point2>& P, const std::vector<Triangle>& coarse,
                    std::vector<InteriorEdge> interior, const CancelToken* cancel) {
  const int n = static_cast<int>(P.size());
  if (detail::is_simple_polygon(P)) {
    Partition part;
    part.cycles.emplace_back(n);
    std::iota(part.cycles[0].begin(), part.cycles[0].end(), 0);
    part.piece_of.assign(coarse.size(), 0);
    return part;
  }
  const int T = static_cast<int>(coarse.size());
  std::vector<int> parent(T);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<std::vector<int>> cycle(T);
  for (int t = 0; t < T; ++t) cycle[t] = {coarse[t][0], coarse[t][1], coarse[t][2]};

  std::stable_sort(interior.begin(), interior.end(),
                   [](const InteriorEdge& x, const InteriorEdge& y) { return x.score > y.score; });
  std::vector<char> removed(interior.size(), 0);
  std::vector<int> merged;
  std::vector<Point2> a_path, b_path;
  for (int pass = 0; pass < 8; ++pass) {
    bool changed = false;
    for (std::size_t i = 0; i < interior.size(); ++i) {
      if (removed[i]) continue;
      if ((i & 63u) == 0) check_cancel(cancel);
      const InteriorEdge& e = interior[i];
      const int A = root(e.t1), B = root(e.t2);
      if (A == B) fail("partition: an interior edge joins a piece to itself");
      const std::vector<int>& ca = cycle[A];
      const std::vector<int>& cb = cycle[B];
      // A holds a -> b, B holds b -> a. Union: A from b round to a, then B from a (exclusive) to b (exclusive).
      const auto ia = std::find(ca.begin(), ca.end(), e.b);
      const auto ib = std::find(cb.begin(), cb.end(), e.a);
      if (ia == ca.end() || ib == cb.end()) fail("partition: shared edge not on both piece boundaries");
      const std::size_t sa = ca.size(), sb = cb.size();
      const std::size_t pa = static_cast<std::size_t>(ia - ca.begin()), pb = static_cast<std::size_t>(ib - cb.begin());
      if (ca[(pa + sa - 1) % sa] != e.a || cb[(pb + sb - 1) % sb] != e.b)
        fail("partition: shared edge has the wrong direction in a piece");
      a_path.clear();
      b_path.clear();
      for (std::size_t j = 0; j < sa; ++j) a_path.push_back(P[ca[(pa + j) % sa]]);  // b ... a
      for (std::size_t j = 0; j < sb; ++j) b_path.push_back(P[cb[(pb + j) % sb]]);  // a ... b
      if (!detail::glued_union_is_simple(a_path, b_path)) continue;
      merged.clear();
      for (std::size_t j = 0; j < sa; ++j) merged.push_back(ca[(pa + j) % sa]);       // b ... a
      for (std::size_t j = 1; j + 1 < sb; ++j) merged.push_back(cb[(pb + j) % sb]);   // after a ... before b
      removed[i] = 1;
      changed = true;
      parent[A] = B;
      cycle[B].swap(merged);
      std::vector<int>().swap(cycle[A]);
    }
    if (!changed) break;
  }
  Partition part;
  std::vector<int> index(T, -1);
  for (int t = 0; t < T; ++t)
    if (root(t) == t) {
      index[t] = static_cast<int>(part.cycles.size());
      part.cycles.push_back(std::move(cycle[t]));
    }
  part.piece_of.resize(T);
  for (int t = 0; t < T; ++t) part.piece_of[t] = index[root(t)];
  return part;
}

struct Split {
  int lo = -1, hi = -1;        // polygon vertex ids, lo < hi
  int left = -1, right = -1;   // pieces holding lo -> hi and hi -> lo
  std::vector<double> t;       // parameters of the inner points from lo towards hi, increasing
  int first_id = -1;           // global id of the first inner point
};

struct Attempt {
  std::vector<Point2> vertices;
  std::vector<Triangle> faces;
  int splits = 0, steiner = 0;
  bool hit_cap = false;
};

// Inner points of segment a -> b at equal steps of the integral of 1 / size along it (size: the smaller of
// the two pieces' fields: short constrained segments never hurt the mesh on the coarser side, which grades
// away from them, while a long one next to a fine mesh does).
std::vector<double> split_parameters(const Point2& a, const Point2& b, const detail::SizingField& f1,
                                     const detail::SizingField& f2, double h, long long max_points) {
  const double len = dist(a, b);
  const int M = static_cast<int>(std::clamp(std::ceil(4.0 * len / h), 8.0, 20000.0));
  std::vector<double> cum(M + 1, 0.0);
  auto inv_size = [&](int i) {
    const double t = static_cast<double>(i) / M;
    const Point2 p{a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t};
    return 1.0 / std::min(f1(p), f2(p));
  };
  double prev = inv_size(0);
  for (int i = 1; i <= M; ++i) {
    const double cur = inv_size(i);
    cum[i] = cum[i - 1] + 0.5 * (prev + cur) * len / M;
    prev = cur;
  }
  const double N = cum[M];
  const long long k = std::clamp<long long>(std::llround(N), 1, std::max<long long>(1, max_points + 1));
  std::vector<double> t;
  t.reserve(static_cast<std::size_t>(k - 1));
  int i = 1;
  for (long long j = 1; j < k; ++j) {
    const double target = N * static_cast<double>(j) / static_cast<double>(k);
    while (i < M && cum[i] < target) ++i;
    const double span = cum[i] - cum[i - 1];
    const double frac = span > 0 ? (target - cum[i - 1]) / span : 0.5;
    const double tj = (static_cast<double>(i - 1) + std::clamp(frac, 0.0, 1.0)) / M;
    if (tj > 0 && tj < 1 && (t.empty() || tj > t.back())) t.push_back(tj);
  }
  return t;
}

// Sizing fields: each piece grades from its polygon edges (target size = edge length, at most cap) down to
// the base size h.
std::vector<detail::SizingField> build_fields(const std::vector<Point2>& P, const Partition& part, double h,
                                              double cap) {
  const int n = static_cast<int>(P.size());
  std::vector<detail::SizingField> fields;
  fields.reserve(part.cycles.size());
  for (const auto& c : part.cycles) {
    std::vector<detail::SizeSource> sources;
    for (std::size_t j = 0; j < c.size(); ++j) {
      const int u = c[j], v = c[(j + 1) % c.size()];
      if (v == (u + 1) % n) sources.push_back({P[u], P[v], std::min(dist(P[u], P[v]), cap)});
    }
    fields.emplace_back(h, kGrading, std::move(sources));
  }
  return fields;
}

// Expected triangle count of a mesh following the fields: the integral of 1 / (area of the equilateral
// triangle of side s(p)) over the coarse triangles (midpoint rule on a regular subdivision of each).
double estimate_triangles(const std::vector<Point2>& P, const std::vector<Triangle>& coarse, const Partition& part,
                          const std::vector<detail::SizingField>& fields, double total_area) {
  const double delta = std::sqrt(total_area / kEstimateSamples);
  double sum = 0;
  for (std::size_t t = 0; t < coarse.size(); ++t) {
    const Point2& a = P[coarse[t][0]];
    const Point2& b = P[coarse[t][1]];
    const Point2& c = P[coarse[t][2]];
    const double area = tri_area(a, b, c);
    const int N = static_cast<int>(std::clamp(std::ceil(1.5 * std::sqrt(area) / delta), 1.0, 100.0));
    const detail::SizingField& f = fields[part.piece_of[t]];
    double acc = 0;
    auto at = [&](double u, double v) {
      const Point2 p{a.x + (b.x - a.x) * u + (c.x - a.x) * v, a.y + (b.y - a.y) * u + (c.y - a.y) * v};
      const double s = f(p);
      return 1.0 / (s * s);
    };
    for (int i = 0; i < N; ++i)
      for (int j = 0; i + j < N; ++j) {
        acc += at((3.0 * i + 1) / (3.0 * N), (3.0 * j + 1) / (3.0 * N));
        if (i + j < N - 1) acc += at((3.0 * i + 2) / (3.0 * N), (3.0 * j + 2) / (3.0 * N));
      }
    sum += acc * area / (static_cast<double>(N) * N);
  }
  return kCountCalibration * sum * 4.0 / std::sqrt(3.0);
}

// Steps 2-4 for one base size h and the fields built for it.
Attempt mesh_partition(const std::vector<Point2>& P, const Partition& part,
                       const std::vector<detail::SizingField>& fields, double h, double cap, double min_angle_deg,
                       double total_area, long long target, const CancelToken* cancel) {
  const int n = static_cast<int>(P.size());
  const std::vector<std::vector<int>>& pieces = part.cycles;
  // Interior edges of the partition, in a deterministic order.
  std::vector<Split> splits;
  for (std::size_t pc = 0; pc < pieces.size(); ++pc) {
    const auto& c = pieces[pc];
    for (std::size_t j = 0; j < c.size(); ++j) {
      const int u = c[j], v = c[(j + 1) % c.size()];
      if (v == (u + 1) % n || u > v) continue;
      Split s;
      s.lo = u, s.hi = v, s.left = static_cast<int>(pc);
      splits.push_back(s);
    }
  }
  std::sort(splits.begin(), splits.end(),
            [](const Split& x, const Split& y) { return std::make_pair(x.lo, x.hi) < std::make_pair(y.lo, y.hi); });
  auto find_split = [&](int u, int v) -> Split& {
    const std::pair<int, int> key(std::min(u, v), std::max(u, v));
    auto it = std::lower_bound(splits.begin(), splits.end(), key, [](const Split& x, const std::pair<int, int>& k) {
      return std::make_pair(x.lo, x.hi) < k;
    });
    if (it == splits.end() || it->lo != key.first || it->hi != key.second) fail("partition edge lookup failed");
    return *it;
  };
  for (std::size_t pc = 0; pc < pieces.size(); ++pc) {
    const auto& c = pieces[pc];
    for (std::size_t j = 0; j < c.size(); ++j) {
      const int u = c[j], v = c[(j + 1) % c.size()];
      if (v != (u + 1) % n && u > v) find_split(u, v).right = static_cast<int>(pc);
    }
  }
  for (Split& s : splits) {
    if (s.left < 0 || s.right < 0) fail("partition: an interior edge does not have a piece on each side");
    s.t = split_parameters(P[s.lo], P[s.hi], fields[s.left], fields[s.right], h, target);
  }
  // The j-th inner point of edge lo -> hi; one double for both pieces.
  auto split_point = [&](const Split& s, std::size_t j) {
    const Point2& a = P[s.lo];
    const Point2& b = P[s.hi];
    return Point2{a.x + (b.x - a.x) * s.t[j], a.y + (b.y - a.y) * s.t[j]};
  };
  auto piece_boundary = [&](const std::vector<int>& c, std::vector<Point2>& pts, std::vector<int>* ids) {
    pts.clear();
    if (ids) ids->clear();
    for (std::size_t j = 0; j < c.size(); ++j) {
      const int u = c[j], v = c[(j + 1) % c.size()];
      pts.push_back(P[u]);
      if (ids) ids->push_back(u);
      if (v == (u + 1) % n) continue;
      const Split& s = find_split(u, v);
      const std::size_t k = s.t.size();
      for (std::size_t q = 0; q < k; ++q) {
        const std::size_t jj = (u == s.lo) ? q : k - 1 - q;
        pts.push_back(split_point(s, jj));
        if (ids) ids->push_back(s.first_id + static_cast<int>(jj));
      }
    }
  };
  // The split points are rounded: a piece with a nearly touching vertex could stop being simple. Such an
  // edge is left unsplit (the exact original diagonal) and the pieces are checked again.
  std::vector<Point2> pts;
  for (int round = 0;; ++round) {
    bool all_simple = true;
    for (const auto& c : pieces) {
      bool has_split = false;
      for (std::size_t j = 0; j < c.size() && !has_split; ++j) {
        const int u = c[j], v = c[(j + 1) % c.size()];
        if (v != (u + 1) % n && !find_split(u, v).t.empty()) has_split = true;
      }
      if (!has_split) continue;
      piece_boundary(c, pts, nullptr);
      if (detail::is_simple_polygon(pts)) continue;
      all_simple = false;
      for (std::size_t j = 0; j < c.size(); ++j) {
        const int u = c[j], v = c[(j + 1) % c.size()];
        if (v != (u + 1) % n) find_split(u, v).t.clear();
      }
    }
    if (all_simple) break;
    if (round > 2) fail("partition: a piece is not simple after splitting its interior edges");
  }

  Attempt out;
  out.vertices = P;
  for (Split& s : splits) {
    s.first_id = static_cast<int>(out.vertices.size());
    for (std::size_t j = 0; j < s.t.size(); ++j) out.vertices.push_back(split_point(s, j));
    out.splits += static_cast<int>(s.t.size());
  }
  std::vector<int> ids;
  for (std::size_t pc = 0; pc < pieces.size(); ++pc) {
    check_cancel(cancel);
    piece_boundary(pieces[pc], pts, &ids);
    const double area = detail::signed_area(pts);
    if (!(area > 0)) fail("partition: a piece is not counterclockwise");
    const double expected = static_cast<double>(target) * area / total_area;
    const std::size_t max_points = static_cast<std::size_t>(4.0 * expected) + 1000;
    detail::PieceMeshResult r =
        detail::mesh_simple_piece(pts, fields[pc], kSizeFactor, min_angle_deg, cap,
                                  h / std::sqrt(kCountCalibration), max_points, cancel);
    out.hit_cap = out.hit_cap || r.hit_point_cap;
    const int base = static_cast<int>(out.vertices.size());
    const int m = static_cast<int>(pts.size());
    for (const Point2& p : r.steiner) out.vertices.push_back(p);
    out.steiner += static_cast<int>(r.steiner.size());
    for (const Triangle& f : r.faces) {
      Triangle g;
      for (int c2 = 0; c2 < 3; ++c2) g[c2] = f[c2] < m ? ids[f[c2]] : base + (f[c2] - m);
      out.faces.push_back(g);
    }
  }
  return out;
}

}  // namespace

namespace {

// Full turns of the corner sweeps at polygon vertex v of a mesh whose boundary loop is 0, 1, ..., n - 1,
// chained counterclockwise from the ray towards v + 1 (its fan, read backwards).
int polygon_vertex_turns(const std::vector<Point2>& points, const MeshTopology& mesh, int v) {
  const HalfedgeRange fan = mesh.fan(v);
  auto at = [&](int w) { return detail::Pt(points[w].x, points[w].y); };
  detail::TurnCount count(at(v), at(mesh.to(fan.back())));
  for (std::size_t i = fan.size(); i-- > 0;) count.add(at(mesh.to(fan[i])), at(mesh.from(MeshTopology::prev(fan[i]))));
  return count.turns();
}

// verify_target_mesh; `topology`, when given, is the topology of mesh.faces. Returns the smallest triangle
// angle (radians), a measurement for the report.
double verify_mesh(const BoundaryPolygon& polygon, const std::vector<Triangle>& coarse, const TargetMesh& mesh,
                   const MeshTopology* topology) {
  const std::vector<Point2>& P = polygon.vertices;
  const int n = static_cast<int>(P.size());
  const int V = static_cast<int>(mesh.vertices.size());
  if (V < n) fail("verify: fewer vertices than the polygon");
  for (int k = 0; k < n; ++k)
    if (!same_bits(mesh.vertices[k].x, P[k].x) || !same_bits(mesh.vertices[k].y, P[k].y))
      fail("verify: vertex " + std::to_string(k) + " is not polygon vertex " + std::to_string(k));
  for (int v = n; v < V; ++v)
    if (!std::isfinite(mesh.vertices[v].x) || !std::isfinite(mesh.vertices[v].y))
      fail("verify: vertex " + std::to_string(v) + " is not finite");

  const int F = static_cast<int>(mesh.faces.size());
  std::vector<int> degree(V, 0);
  double min_angle = M_PI;
  for (int f = 0; f < F; ++f) {
    const Triangle& t = mesh.faces[f];
    for (int c = 0; c < 3; ++c)
      if (t[c] < 0 || t[c] >= V) fail("verify: face " + std::to_string(f) + " has a vertex out of range");
    if (detail::orient(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]) <= 0)
      fail("verify: face " + std::to_string(f) + " is not strictly positive");
    for (int c = 0; c < 3; ++c) {
      ++degree[t[c]];
      min_angle = std::min(min_angle, corner_angle(mesh.vertices[t[c]], mesh.vertices[t[(c + 1) % 3]],
                                                   mesh.vertices[t[(c + 2) % 3]]));
    }
  }
  for (int v = 0; v < V; ++v)
    if (degree[v] == 0) fail("verify: vertex " + std::to_string(v) + " is in no face");

  MeshTopology built;
  if (!topology) {
    built = MeshTopology(V, mesh.faces);
    topology = &built;
  }
  const MeshTopology& topo = *topology;
  // Edge-manifold: every directed edge once; boundary edges are exactly P's edges k -> k+1.
  long long boundary_edges = 0;
  for (int e = 0; e < topo.edge_count(); ++e) {
    const HalfedgeRange uses = topo.edge_uses(e);
    const int a = topo.from(uses[0]), b = topo.to(uses[0]);
    if (uses.size() > 2 || (uses.size() == 2 && topo.from(uses[1]) == a))
      fail("verify: directed edge (" + std::to_string(a) + ", " + std::to_string(b) + ") is used twice (not manifold)");
    if (uses.size() == 2) continue;
    ++boundary_edges;
    if (a >= n || b != (a + 1) % n)
      fail("verify: boundary edge (" + std::to_string(a) + ", " + std::to_string(b) + ") is not a polygon edge");
  }
  if (boundary_edges != n) fail("verify: the boundary is not the polygon's n edges");
  const long long E = topo.edge_count();
  if (static_cast<long long>(V) - E + F != 1)
    fail("verify: Euler characteristic " + std::to_string(static_cast<long long>(V) - E + F) + ", expected 1");
  // One fan per vertex (the boundary edges being P's, a polygon vertex's fan runs from v + 1 to v - 1).
  if (!topo.oriented_manifold()) {
    const int v = topo.first_vertex_with_broken_fan();
    fail(std::string("verify: ") + (v < n ? "polygon" : "interior") + " vertex " + std::to_string(v) +
         " has more than one fan (not a disk)");
  }

  // Angles, exactly: one full turn at interior vertices; at polygon vertex k the turns of the coarse
  // triangulation's fan (both fans sweep from the ray towards k + 1 to the ray towards k - 1).
  for (const Triangle& t : coarse)
    for (int c : t)
      if (c < 0 || c >= n) fail("verify: a coarse triangle has a vertex out of range");
  const MeshTopology coarse_topology(n, coarse);
  if (!coarse_topology.oriented_manifold() || coarse_topology.boundary_loops().size() != 1 ||
      coarse_topology.boundary_loops()[0].size() != static_cast<std::size_t>(n) || coarse_topology.boundary_next(0) != 1 % n)
    fail("verify: the coarse triangulation is not a disk bounded by the polygon");
  for (int v = 0; v < V; ++v) {
    if (v < n) {
      if (polygon_vertex_turns(mesh.vertices, topo, v) != polygon_vertex_turns(P, coarse_topology, v))
        fail("verify: angle at polygon vertex " + std::to_string(v) + " differs from the coarse triangulation's");
      continue;
    }
    const HalfedgeRange fan = topo.fan(v);
    const Point2& c = mesh.vertices[v];
    auto at = [&](int w) { return detail::Pt(mesh.vertices[w].x, mesh.vertices[w].y); };
    detail::TurnCount count(detail::Pt(c.x, c.y), at(topo.to(fan.back())));
    for (std::size_t i = fan.size(); i-- > 0;) count.add(at(topo.to(fan[i])), at(topo.from(MeshTopology::prev(fan[i]))));
    if (count.turns() != 1)
      fail("verify: angle sum at interior vertex " + std::to_string(v) + " is " + std::to_string(count.turns()) +
           " x 2 pi, not 2 pi");
  }

  double area = 0, coarse_area = 0, coarse_abs = 0;
  for (const Triangle& t : mesh.faces)
    area += tri_area(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]);
  for (const Triangle& t : coarse) {
    const double a = tri_area(P[t[0]], P[t[1]], P[t[2]]);
    coarse_area += a;
    coarse_abs += std::fabs(a);
  }
  if (std::fabs(area - coarse_area) > 1e-9 * coarse_abs)
    fail("verify: total area " + std::to_string(area) + " differs from the coarse area " +
         std::to_string(coarse_area));
  return min_angle;
}

}  // namespace

void verify_target_mesh(const BoundaryPolygon& polygon, const std::vector<Triangle>& coarse,
                        const TargetMesh& mesh) {
  verify_mesh(polygon, coarse, mesh, nullptr);
}

int target_triangle_cap(int polygon_vertices) {
  const long long by_polygon = static_cast<long long>(kTargetCapPerVertex) * std::max(0, polygon_vertices);
  return static_cast<int>(std::min<long long>(std::max<long long>(kTargetCapFloor, by_polygon), 20000000));
}

TargetMesh build_target_mesh(const BoundaryPolygon& polygon, const std::vector<Triangle>& coarse,
                             const TargetMeshOptions& options, const CancelToken* cancel) {
  const auto t0 = Clock::now();
  const std::vector<Point2>& P = polygon.vertices;
  const int n = static_cast<int>(P.size());
  if (!(options.density > 0) || !std::isfinite(options.density))
    throw InputError("target_density_invalid", "target density must be a positive number", "options");
  if (options.source_triangles < 0)
    throw InputError("source_triangles_invalid", "source triangle count must not be negative", "options");
  if (!(options.min_angle_deg >= 0 && options.min_angle_deg <= 30))
    throw InputError("min_angle_invalid", "minimum angle must be between 0 and 30 degrees", "options");
  if (n < 3) throw InputError("polygon_too_small", "the polygon needs at least 3 vertices", "boundary");
  for (int k = 0; k < n; ++k)
    if (!std::isfinite(P[k].x) || !std::isfinite(P[k].y))
      throw InputError("polygon_non_finite", "polygon vertex has a non-finite coordinate", "polygon_vertex", k);
  double source = options.source_triangles > 0 ? options.source_triangles : 2.0 * n;
  if (options.cap_to_polygon) source = std::min(source, static_cast<double>(target_triangle_cap(n)));
  const double wanted = options.density * source;
  constexpr double kMaxTarget = 2e7;
  if (wanted > kMaxTarget)
    throw InputError("target_density_invalid", "target mesh would exceed 20 million triangles", "options");
  const long long target = std::max<long long>(1, std::llround(wanted));

  TargetMesh result;
  result.target_triangles = static_cast<int>(target);

  std::vector<InteriorEdge> interior = check_coarse(P, coarse);
  check_cancel(cancel);
  double total_area = 0;
  for (const Triangle& t : coarse) total_area += tri_area(P[t[0]], P[t[1]], P[t[2]]);

  const auto tp = Clock::now();
  const Partition part = partition(P, coarse, std::move(interior), cancel);
  result.pieces = static_cast<int>(part.cycles.size());
  result.partition_ms = ms_since(tp);

  // Size: h0 is the edge length of an equilateral triangle of area total_area / target. Polygon edges
  // longer than the local size get coarser triangles around them (sizing field); the base size h is chosen
  // from an estimate of the count so that the total stays near the target: first by refining the interior
  // (down to h0 / kMaxInteriorRefinement), then by capping the sizes the long edges ask for.
  const auto tm = Clock::now();
  const double h0 = std::sqrt(4.0 * total_area / (std::sqrt(3.0) * static_cast<double>(target)));
  const double want = static_cast<double>(target);
  auto estimate = [&](double h, double cap) {
    return estimate_triangles(P, coarse, part, build_fields(P, part, h, cap), total_area);
  };
  // Solves estimate = want for a parameter x > 0 on which log(estimate) depends monotonically, by bracketed
  // secant steps in log-log space (the estimate goes like x^-2 for the base size), to 3%.
  auto solve = [&](auto&& est, double x_lo, double x_hi) {
    double a = std::log(x_lo), b = std::log(x_hi);
    double fa = std::log(est(x_lo) / want), fb = std::log(est(x_hi) / want);
    if (fa * fb > 0) return std::fabs(fa) < std::fabs(fb) ? x_lo : x_hi;
    double x = a, fx = fa;
    for (int it = 0; it < 30 && std::fabs(fx) > 0.03; ++it) {
      x = (fb != fa) ? b - fb * (b - a) / (fb - fa) : 0.5 * (a + b);
      if (!(x > std::min(a, b) && x < std::max(a, b))) x = 0.5 * (a + b);
      fx = std::log(est(std::exp(x)) / want);
      if ((fx > 0) == (fa > 0)) {
        a = x, fa = fx, fb *= 0.5;  // Illinois: keep the other end from stalling
      } else {
        b = x, fb = fx, fa *= 0.5;
      }
    }
    return std::exp(x);
  };
  double h = h0, cap = INFINITY;
  const double h_min = h0 / kMaxInteriorRefinement;
  if (estimate(h_min, cap) >= want) {
    h = solve([&](double x) { return estimate(x, cap); }, h_min, 4 * h0);
  } else {
    h = h_min;  // the long edges' coarse surroundings leave too few triangles: cap their sizes
    cap = solve([&](double x) { return estimate(h, x); }, h, 1e3 * h0);
  }
  check_cancel(cancel);

  Attempt best;
  double best_err = INFINITY, best_h = h;
  int attempts = 0;
  for (;;) {
    ++attempts;
    const std::vector<detail::SizingField> fields = build_fields(P, part, h, cap);
    Attempt a = mesh_partition(P, part, fields, h, cap, options.min_angle_deg, total_area, target, cancel);
    const double ratio = static_cast<double>(a.faces.size()) / static_cast<double>(target);
    const double err = std::fabs(std::log(ratio));
    const bool better = err < best_err;
    const bool no_steiner = a.steiner == 0;
    if (better) {
      best = std::move(a);
      best_err = err;
      best_h = h;
    }
    // Within 25% is good enough; so is a mesh that cannot get coarser (no Steiner point left to drop).
    if (err < std::log(1.25) || !better || attempts == 3) break;
    if (ratio > 1 && no_steiner) break;
    h *= std::sqrt(ratio);
  }
  result.remesh_rounds = attempts;
  result.mesh_ms = ms_since(tm);
  result.vertices = std::move(best.vertices);
  result.faces = std::move(best.faces);
  result.interior_edge_splits = best.splits;
  result.steiner_points = best.steiner;
  result.hit_point_cap = best.hit_cap;
  result.size = best_h;

  const auto tv = Clock::now();
  result.topology = MeshTopology(static_cast<int>(result.vertices.size()), result.faces);
  result.min_angle_deg = verify_mesh(polygon, coarse, result, &result.topology) * 180.0 / M_PI;
  result.verify_ms = ms_since(tv);
  result.ms = ms_since(t0);
  return result;
}

}  // namespace lipmap
