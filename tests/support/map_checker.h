// Independent checker of a finished map against docs/contract.md (tests and benchmarks only).
//
// It shares no code with engine/verify.cpp (nor with any other engine source): the only engine header it
// includes is engine/geometry.h for the plain value types Point2 / Point3 / Triangle. The orientation
// predicate is CGAL's Exact_predicates_inexact_constructions_kernel::orientation_2 evaluated on the returned
// doubles; everything else (edge maps, boundary walk, angle sums in long double, areas) is written here
// from the definitions.
//
// Checks (each failure is one line "check: element: detail"; check names are stable):
//   shape              sizes consistent, indices in range, coordinates finite
//   original_vertex    vertex i < source count keeps its exact 3D position (bit for bit)
//   inserted_count     result vertices = source vertices + inserted records
//   inserted_edge      inserted vertex lies on an original edge (a, b), a < b, 0 < t < 1, at a + t (b - a)
//                      within 1e-12 relative to the edge's coordinates
//   inserted_boundary  the edge of an inserted vertex is not a boundary edge (no inserted vertex on the boundary)
//   boundary_uv        uv of source loop vertex k == prescribed position k, bit for bit
//   positive           every face strictly counterclockwise in uv (exact predicate)
//   angle_sum          every interior vertex's uv angles sum to 2 pi within 1e-6 (one turn, not two)
//   rotation_index     (only when rotation indices are given) boundary vertex k's uv angle sum equals the
//                      polygon's interior angle + 2 pi R_k within 1e-6
//   degenerate_3d      no face has all three corners on one original edge (or repeats a vertex)
//   area               3D area of the result equals the source's within 1e-9 relative
//   disk               manifold edges, consistent orientation, every vertex used, one fan per vertex,
//                      V - E + F = 1, a single boundary loop equal (as a cycle, same direction) to the source's
//   minimal            no inserted point could have been removed (paper 4, Fig. 11), one-sided: for an inserted
//                      vertex v on original edge (a, b), the refined polygons of the two source faces on either
//                      side (their corners and the inserted points on their edges, in order, in uv) are formed
//                      without v. If both are simple and counterclockwise (exact orientation tests on the
//                      doubles: such a polygon is trivially self-overlapping), both have a triangulation with no
//                      triangle whose corners all lie on one original edge, and the uv angle sum at a and at b
//                      would not change (when v is next to them on the edge), v was removable: a failure. A
//                      removable point whose polygons are self-overlapping but not simple is not detected.
//                      Exempt: the only point on an edge of a source face whose three corners are boundary
//                      vertices pinned where float32 rounding may flatten or flip it, when float32 can hold P
//                      (contract point 6).
#pragma once

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "engine/geometry.h"

namespace lipmap::mapcheck {

struct Inserted {
  int a = 0, b = 0;
  double t = 0;
};

struct SourceMesh {
  std::vector<Point3> vertices;
  std::vector<Triangle> faces;
  std::vector<int> loop;  // boundary loop, interior on the left
};

struct Result {
  std::vector<Point3> vertices;
  std::vector<Triangle> faces;
  std::vector<Point2> uv;
  std::vector<Inserted> inserted;
};

struct Report {
  std::vector<std::string> errors;
  int interior_vertices_checked = 0;
  int faces_checked = 0;
  double area_relative_error = 0;
  double max_angle_error = 0;  // |angle sum - 2 pi| over interior vertices

  bool ok() const { return errors.empty(); }
  bool has(const std::string& check) const {
    for (const std::string& e : errors)
      if (e.compare(0, check.size() + 1, check + ":") == 0) return true;
    return false;
  }
  std::string str(std::size_t max_lines = 12) const {
    std::ostringstream os;
    for (std::size_t i = 0; i < errors.size() && i < max_lines; ++i) os << "  - " << errors[i] << "\n";
    if (errors.size() > max_lines) os << "  ... and " << errors.size() - max_lines << " more\n";
    return os.str();
  }
};

namespace detail {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
constexpr long double kPi = 3.141592653589793238462643383279502884L;
constexpr long double kTwoPi = 2 * kPi;

inline int orient(const Point2& a, const Point2& b, const Point2& c) {
  const CGAL::Orientation o = CGAL::orientation(K::Point_2(a.x, a.y), K::Point_2(b.x, b.y), K::Point_2(c.x, c.y));
  return o == CGAL::LEFT_TURN ? 1 : (o == CGAL::RIGHT_TURN ? -1 : 0);
}

inline bool same_bits(double a, double b) { return a == b && std::signbit(a) == std::signbit(b); }

inline std::uint64_t key(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) | static_cast<std::uint32_t>(b);
}

// Unsigned angle at a of triangle (a, b, c), long double.
inline long double corner_angle(const Point2& a, const Point2& b, const Point2& c) {
  const long double ux = (long double)b.x - a.x, uy = (long double)b.y - a.y;
  const long double wx = (long double)c.x - a.x, wy = (long double)c.y - a.y;
  return std::fabs(std::atan2(ux * wy - uy * wx, ux * wx + uy * wy));
}

// Interior angle of a polygon at v (prev, v, next), on the left, in (0, 2 pi].
inline long double interior_angle(const Point2& prev, const Point2& v, const Point2& next) {
  const long double ux = (long double)next.x - v.x, uy = (long double)next.y - v.y;
  const long double wx = (long double)prev.x - v.x, wy = (long double)prev.y - v.y;
  long double a = std::atan2(ux * wy - uy * wx, ux * wx + uy * wy);
  if (a <= 0) a += kTwoPi;
  return a;
}

inline long double area3(const Point3& a, const Point3& b, const Point3& c) {
  const long double ux = (long double)b.x - a.x, uy = (long double)b.y - a.y, uz = (long double)b.z - a.z;
  const long double wx = (long double)c.x - a.x, wy = (long double)c.y - a.y, wz = (long double)c.z - a.z;
  const long double nx = uy * wz - uz * wy, ny = uz * wx - ux * wz, nz = ux * wy - uy * wx;
  return 0.5L * std::sqrt(nx * nx + ny * ny + nz * nz);
}

inline std::string num(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

// Directed-edge structure of a face list: for each undirected edge the faces using it.
struct EdgeUse {
  int count = 0;      // faces using the undirected edge
  int forward = 0;    // uses as (lo -> hi)
  int backward = 0;   // uses as (hi -> lo)
};

inline std::unordered_map<std::uint64_t, EdgeUse> edge_uses(const std::vector<Triangle>& faces) {
  std::unordered_map<std::uint64_t, EdgeUse> uses;
  uses.reserve(faces.size() * 2);
  for (const Triangle& t : faces)
    for (int c = 0; c < 3; ++c) {
      const int a = t[c], b = t[(c + 1) % 3];
      EdgeUse& u = uses[key(a, b)];
      ++u.count;
      if (a < b) ++u.forward;
      else ++u.backward;
    }
  return uses;
}


// ---- float32 (contract point 6's exception) ----

// The triangle stored as glTF stores uv, (fl32(u), fl32(1 - v)), read back as (s, 1 - t): counterclockwise?
inline bool positive_in_float32(const Point2& a, const Point2& b, const Point2& c) {
  auto back = [](const Point2& p) {
    volatile float s = static_cast<float>(p.x), t = static_cast<float>(1.0 - p.y);
    return K::Point_2(s, 1.0 - static_cast<double>(t));
  };
  return CGAL::orientation(back(a), back(b), back(c)) == CGAL::LEFT_TURN;
}

// Counterclockwise with a doubled area above 2 sqrt(2) h times the perimeter, h = 2^-24 times the largest of
// |u|, |v|, |1 - v| over the corners: the most float32 rounding can take from it (each corner moves by at most
// sqrt(2) h, changing the doubled area by at most that times the opposite side), twice over.
inline bool clear_of_float32_rounding(const Point2& a, const Point2& b, const Point2& c) {
  long double m = 0;
  for (const Point2* p : {&a, &b, &c})
    m = std::max({m, std::fabs(static_cast<long double>(p->x)), std::fabs(static_cast<long double>(p->y)),
                  std::fabs(1.0L - p->y)});
  const long double h = std::ldexp(m, -24);
  auto side = [](const Point2& p, const Point2& q) {
    return std::hypot(static_cast<long double>(q.x) - p.x, static_cast<long double>(q.y) - p.y);
  };
  const long double area2 = (static_cast<long double>(b.x) - a.x) * (static_cast<long double>(c.y) - a.y) -
                            (static_cast<long double>(b.y) - a.y) * (static_cast<long double>(c.x) - a.x);
  return area2 > 2 * std::sqrt(2.0L) * h * (side(a, b) + side(b, c) + side(c, a));
}

// ---- minimality (Fig. 11) helpers ----

// Closed segments pq and rs share a point (exact: orientation tests and coordinate comparisons).
inline bool on_segment(const Point2& p, const Point2& q, const Point2& r) {  // r on pq, given collinear
  return std::min(p.x, q.x) <= r.x && r.x <= std::max(p.x, q.x) && std::min(p.y, q.y) <= r.y &&
         r.y <= std::max(p.y, q.y);
}
inline bool segments_meet(const Point2& p, const Point2& q, const Point2& r, const Point2& s) {
  const int o1 = orient(p, q, r), o2 = orient(p, q, s), o3 = orient(r, s, p), o4 = orient(r, s, q);
  if (o1 != o2 && o3 != o4 && o1 != 0 && o2 != 0 && o3 != 0 && o4 != 0) return true;
  return (o1 == 0 && on_segment(p, q, r)) || (o2 == 0 && on_segment(p, q, s)) || (o3 == 0 && on_segment(r, s, p)) ||
         (o4 == 0 && on_segment(r, s, q));
}

// A closed polygon is simple and counterclockwise: no two vertices equal, consecutive edges meet only at their
// common vertex, other edges not at all; orientation taken at the lexicographically smallest vertex (a convex
// hull vertex of a simple polygon, where the turn is strict).
inline bool simple_counterclockwise(const std::vector<Point2>& poly) {
  const std::size_t m = poly.size();
  if (m < 3) return false;
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = i + 1; j < m; ++j)
      if (poly[i] == poly[j]) return false;
  for (std::size_t i = 0; i < m; ++i) {
    const Point2 &p = poly[i], &q = poly[(i + 1) % m], &r = poly[(i + 2) % m];
    // Consecutive edges pq, qr overlap beyond q when r is collinear and on p's side of q (the signs of exact
    // coordinate differences decide it, q being distinct from both).
    auto sign = [](double d) { return (d > 0) - (d < 0); };
    if (orient(p, q, r) == 0 && sign(r.x - q.x) == sign(p.x - q.x) && sign(r.y - q.y) == sign(p.y - q.y)) return false;
    for (std::size_t j = i + 2; j < m; ++j) {
      if (i == 0 && j == m - 1) continue;  // edges m-1 and 0 are consecutive
      if (segments_meet(p, q, poly[j], poly[(j + 1) % m])) return false;
    }
  }
  std::size_t low = 0;
  for (std::size_t i = 1; i < m; ++i)
    if (poly[i].x < poly[low].x || (poly[i].x == poly[low].x && poly[i].y < poly[low].y)) low = i;
  return orient(poly[(low + m - 1) % m], poly[low], poly[(low + 1) % m]) > 0;
}

// A triangulation of the polygon (no interior vertices) whose triangles are all strictly positive and none
// has its three corners on one original edge (on[i]: bit e set when vertex i lies on source-face edge e).
// Interval dynamic programming over the chains i..j, exact orientation tests: O(m^3).
inline bool has_unflat_positive_triangulation(const std::vector<Point2>& poly, const std::vector<unsigned>& on) {
  const std::size_t m = poly.size();
  std::vector<char> ok(m * m, 0);  // ok[i * m + j]: chain i..j (closed by j-i) can be triangulated
  for (std::size_t i = 0; i + 1 < m; ++i) ok[i * m + i + 1] = 1;
  for (std::size_t len = 2; len < m; ++len)
    for (std::size_t i = 0; i + len < m; ++i) {
      const std::size_t j = i + len;
      for (std::size_t k = i + 1; k < j && !ok[i * m + j]; ++k)
        ok[i * m + j] = ok[i * m + k] && ok[k * m + j] && orient(poly[i], poly[k], poly[j]) > 0 &&
                        !(on[i] & on[k] & on[j]);
    }
  return ok[m - 1];
}

// The counterclockwise angle from direction (from - o) to direction (to - o), in [0, 2 pi): magnitude in long
// double, side from the exact predicate.
inline long double ccw_angle(const Point2& o, const Point2& from, const Point2& to) {
  const long double ux = (long double)from.x - o.x, uy = (long double)from.y - o.y;
  const long double wx = (long double)to.x - o.x, wy = (long double)to.y - o.y;
  const long double mag = std::fabs(std::atan2(ux * wy - uy * wx, ux * wx + uy * wy));
  const int side = orient(o, from, to);
  if (side > 0) return mag;
  if (side < 0) return kTwoPi - mag;
  return ux * wx + uy * wy > 0 ? 0.0L : kPi;
}
}  // namespace detail

// rotation_indices: optional, one per loop position (the prescription the map must honour).
inline Report check_map(const SourceMesh& src, const std::vector<Point2>& prescribed, const Result& res,
                        const std::vector<int>* rotation_indices = nullptr, std::size_t max_errors = 64) {
  using namespace detail;
  Report rep;
  auto add = [&](const std::string& check, const std::string& what) {
    if (rep.errors.size() < max_errors) rep.errors.push_back(check + ": " + what);
  };
  const std::size_t n0 = src.vertices.size();
  const std::size_t nv = res.vertices.size();

  // ---- shape ----
  if (res.uv.size() != nv) {
    add("shape", std::to_string(res.uv.size()) + " uv positions for " + std::to_string(nv) + " vertices");
    return rep;
  }
  if (prescribed.size() != src.loop.size()) {
    add("shape", std::to_string(prescribed.size()) + " prescribed positions for a loop of " + std::to_string(src.loop.size()));
    return rep;
  }
  for (std::size_t f = 0; f < res.faces.size(); ++f)
    for (int c : res.faces[f])
      if (c < 0 || static_cast<std::size_t>(c) >= nv) {
        add("shape", "face " + std::to_string(f) + " has index " + std::to_string(c) + " out of range");
        return rep;
      }
  for (std::size_t v = 0; v < nv; ++v)
    if (!std::isfinite(res.uv[v].x) || !std::isfinite(res.uv[v].y) || !std::isfinite(res.vertices[v].x) ||
        !std::isfinite(res.vertices[v].y) || !std::isfinite(res.vertices[v].z))
      add("shape", "vertex " + std::to_string(v) + " has a non-finite coordinate");

  // ---- 1. original vertices, inserted vertices ----
  if (nv != n0 + res.inserted.size())
    add("inserted_count", std::to_string(nv) + " vertices but " + std::to_string(n0) + " original + " +
                              std::to_string(res.inserted.size()) + " inserted records");
  for (std::size_t v = 0; v < std::min(n0, nv); ++v) {
    const Point3 &p = res.vertices[v], &q = src.vertices[v];
    if (!same_bits(p.x, q.x) || !same_bits(p.y, q.y) || !same_bits(p.z, q.z))
      add("original_vertex", "vertex " + std::to_string(v) + " moved from (" + num(q.x) + ", " + num(q.y) + ", " +
                                 num(q.z) + ") to (" + num(p.x) + ", " + num(p.y) + ", " + num(p.z) + ")");
  }
  const auto src_edges = edge_uses(src.faces);
  // For the 3D degeneracy check: the original edge each vertex lies on (-1, -1 for original vertices).
  std::vector<std::pair<int, int>> on_edge(nv, {-1, -1});
  for (std::size_t i = 0; i < res.inserted.size(); ++i) {
    const Inserted& ins = res.inserted[i];
    const std::size_t v = n0 + i;
    const std::string name = "inserted vertex " + std::to_string(v) + " (record " + std::to_string(i) + ", edge (" +
                             std::to_string(ins.a) + ", " + std::to_string(ins.b) + "), t " + num(ins.t) + ")";
    if (ins.a < 0 || ins.b < 0 || static_cast<std::size_t>(ins.a) >= n0 || static_cast<std::size_t>(ins.b) >= n0) {
      add("inserted_edge", name + ": edge endpoints are not original vertices");
      continue;
    }
    if (!(ins.a < ins.b)) add("inserted_edge", name + ": edge not reported as (a, b) with a < b");
    auto it = src_edges.find(key(ins.a, ins.b));
    if (it == src_edges.end()) {
      add("inserted_edge", name + ": (a, b) is not an edge of the source mesh");
      continue;
    }
    if (it->second.count < 2) add("inserted_boundary", name + ": (a, b) is a boundary edge");
    if (!(ins.t > 0 && ins.t < 1)) add("inserted_edge", name + ": t not in (0, 1)");
    if (v < nv) {
      on_edge[v] = {std::min(ins.a, ins.b), std::max(ins.a, ins.b)};
      const Point3 &a = src.vertices[ins.a], &b = src.vertices[ins.b], &p = res.vertices[v];
      const long double t = ins.t;
      const long double ex = a.x + t * ((long double)b.x - a.x), ey = a.y + t * ((long double)b.y - a.y),
                        ez = a.z + t * ((long double)b.z - a.z);
      const long double scale = std::max({std::fabs((long double)a.x), std::fabs((long double)a.y),
                                          std::fabs((long double)a.z), std::fabs((long double)b.x),
                                          std::fabs((long double)b.y), std::fabs((long double)b.z), 1e-300L});
      const long double err = std::max({std::fabs(p.x - ex), std::fabs(p.y - ey), std::fabs(p.z - ez)});
      if (err > 1e-12L * scale)
        add("inserted_edge", name + ": position (" + num(p.x) + ", " + num(p.y) + ", " + num(p.z) +
                                 ") is off a + t (b - a) by " + num(static_cast<double>(err / scale)) + " relative");
    }
  }

  // ---- 2. boundary positions ----
  for (std::size_t k = 0; k < src.loop.size(); ++k) {
    const int v = src.loop[k];
    if (v < 0 || static_cast<std::size_t>(v) >= nv) continue;
    const Point2 &u = res.uv[v], &p = prescribed[k];
    if (!same_bits(u.x, p.x) || !same_bits(u.y, p.y))
      add("boundary_uv", "loop position " + std::to_string(k) + " (vertex " + std::to_string(v) + ") has uv (" +
                             num(u.x) + ", " + num(u.y) + "), prescribed (" + num(p.x) + ", " + num(p.y) + ")");
  }

  // ---- 3. positive faces; 5. no face flat in 3D ----
  for (std::size_t f = 0; f < res.faces.size(); ++f) {
    const Triangle& t = res.faces[f];
    ++rep.faces_checked;
    const int o = orient(res.uv[t[0]], res.uv[t[1]], res.uv[t[2]]);
    if (o <= 0)
      add("positive", "face " + std::to_string(f) + " (" + std::to_string(t[0]) + ", " + std::to_string(t[1]) + ", " +
                          std::to_string(t[2]) + ") is " + (o < 0 ? "clockwise" : "degenerate") + " in uv");
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      add("degenerate_3d", "face " + std::to_string(f) + " repeats a vertex");
      continue;
    }
    // All three corners on one original edge e: each corner is an endpoint of e or inserted on e.
    std::vector<std::pair<int, int>> candidates;
    for (int c = 0; c < 3; ++c)
      if (on_edge[t[c]].first >= 0) candidates.push_back(on_edge[t[c]]);
    if (candidates.empty()) continue;  // three original vertices: a source face (area checked below)
    for (const auto& e : candidates) {
      bool all = true;
      for (int c = 0; c < 3 && all; ++c) {
        const int v = t[c];
        all = v == e.first || v == e.second || on_edge[v] == e;
      }
      if (all) {
        add("degenerate_3d", "face " + std::to_string(f) + " has all three corners on original edge (" +
                                 std::to_string(e.first) + ", " + std::to_string(e.second) + ")");
        break;
      }
    }
  }

  // ---- disk structure of the result ----
  const auto res_edges = edge_uses(res.faces);
  std::vector<char> used(nv, 0);
  for (const Triangle& t : res.faces)
    for (int c : t) used[c] = 1;
  for (std::size_t v = 0; v < nv; ++v)
    if (!used[v]) add("disk", "vertex " + std::to_string(v) + " is used by no face");
  std::unordered_map<int, int> boundary_next;  // directed boundary edge a -> b (interior on the left)
  std::size_t boundary_edges = 0;
  for (const auto& [k, u] : res_edges) {
    const int lo = static_cast<int>(k >> 32), hi = static_cast<int>(k & 0xffffffffu);
    if (u.count > 2) add("disk", "edge (" + std::to_string(lo) + ", " + std::to_string(hi) + ") has " + std::to_string(u.count) + " faces");
    if (u.forward > 1 || u.backward > 1)
      add("disk", "edge (" + std::to_string(lo) + ", " + std::to_string(hi) + ") is used twice in the same direction");
    if (u.count == 1) {
      ++boundary_edges;
      if (u.forward == 1) boundary_next[lo] = hi;
      else boundary_next[hi] = lo;
    }
  }
  const long long euler = static_cast<long long>(std::count(used.begin(), used.end(), 1)) -
                          static_cast<long long>(res_edges.size()) + static_cast<long long>(res.faces.size());
  if (euler != 1) add("disk", "V - E + F = " + std::to_string(euler) + " (a disk has 1)");
  // The boundary loop must be the source's loop, same direction, as a cycle.
  std::vector<char> on_boundary(nv, 0);
  if (boundary_edges != src.loop.size()) {
    add("disk", std::to_string(boundary_edges) + " boundary edges, the source loop has " + std::to_string(src.loop.size()));
  }
  for (std::size_t k = 0; k < src.loop.size(); ++k) {
    const int a = src.loop[k], b = src.loop[(k + 1) % src.loop.size()];
    if (a >= 0 && static_cast<std::size_t>(a) < nv) on_boundary[a] = 1;
    auto it = boundary_next.find(a);
    if (it == boundary_next.end() || it->second != b) {
      add("disk", "source boundary edge " + std::to_string(a) + " -> " + std::to_string(b) +
                      " is not a boundary edge of the result in that direction");
    }
  }
  for (const auto& [a, b] : boundary_next)
    if (a < 0 || static_cast<std::size_t>(a) >= nv || !on_boundary[a])
      add("disk", "boundary edge " + std::to_string(a) + " -> " + std::to_string(b) + " is not on the source loop");
  // One fan per vertex: the link of v (for each face at v, an edge between its two other corners) must be
  // connected. Faces are grouped by vertex, then a small union-find runs on each link.
  {
    std::vector<std::array<int, 3>> corners;  // (v, w1, w2)
    corners.reserve(res.faces.size() * 3);
    for (const Triangle& t : res.faces)
      for (int c = 0; c < 3; ++c) corners.push_back({t[c], t[(c + 1) % 3], t[(c + 2) % 3]});
    std::sort(corners.begin(), corners.end());
    std::vector<int> ids, parent;
    auto find = [&](int x) {
      while (parent[x] != x) x = parent[x] = parent[parent[x]];
      return x;
    };
    for (std::size_t i = 0; i < corners.size();) {
      std::size_t j = i;
      while (j < corners.size() && corners[j][0] == corners[i][0]) ++j;
      ids.clear();
      for (std::size_t k = i; k < j; ++k) {
        ids.push_back(corners[k][1]);
        ids.push_back(corners[k][2]);
      }
      std::sort(ids.begin(), ids.end());
      ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
      parent.resize(ids.size());
      for (std::size_t k = 0; k < ids.size(); ++k) parent[k] = static_cast<int>(k);
      auto local = [&](int w) { return static_cast<int>(std::lower_bound(ids.begin(), ids.end(), w) - ids.begin()); };
      int components = static_cast<int>(ids.size());
      for (std::size_t k = i; k < j; ++k) {
        const int x = find(local(corners[k][1])), y = find(local(corners[k][2]));
        if (x != y) {
          parent[x] = y;
          --components;
        }
      }
      if (components != 1)
        add("disk", "vertex " + std::to_string(corners[i][0]) + ": its faces form " + std::to_string(components) +
                        " fans (a disk has one per vertex)");
      i = j;
    }
  }

  // ---- 4. angle sums (and the prescribed rotation indices at the boundary) ----
  std::vector<long double> theta(nv, 0);
  for (const Triangle& t : res.faces)
    for (int c = 0; c < 3; ++c) theta[t[c]] += corner_angle(res.uv[t[c]], res.uv[t[(c + 1) % 3]], res.uv[t[(c + 2) % 3]]);
  for (std::size_t v = 0; v < nv; ++v) {
    if (!used[v] || on_boundary[v]) continue;
    ++rep.interior_vertices_checked;
    const long double err = std::fabs(theta[v] - kTwoPi);
    rep.max_angle_error = std::max(rep.max_angle_error, static_cast<double>(err));
    const long long turns = std::llround(theta[v] / kTwoPi);
    if (err > 1e-6L)
      add("angle_sum", "interior vertex " + std::to_string(v) + ": uv angles sum to " + num(static_cast<double>(theta[v])) +
                           " = " + num(static_cast<double>(theta[v] / kTwoPi)) + " turns (" + std::to_string(turns) +
                           "), not 2 pi");
  }
  if (rotation_indices && rotation_indices->size() == src.loop.size()) {
    const std::size_t n = src.loop.size();
    for (std::size_t k = 0; k < n; ++k) {
      const long double alpha = interior_angle(prescribed[(k + n - 1) % n], prescribed[k], prescribed[(k + 1) % n]);
      const int v = src.loop[k];
      if (v < 0 || static_cast<std::size_t>(v) >= nv) continue;
      const long double expected = alpha + kTwoPi * (*rotation_indices)[k];
      if (std::fabs(theta[v] - expected) > 1e-6L)
        add("rotation_index", "loop position " + std::to_string(k) + " (vertex " + std::to_string(v) +
                                  "): uv angle sum " + num(static_cast<double>(theta[v])) + ", expected interior angle " +
                                  num(static_cast<double>(alpha)) + " + 2 pi * " +
                                  std::to_string((*rotation_indices)[k]));
    }
  }

  // ---- 6. minimal: no inserted point could be removed (Fig. 11) ----
  if (nv == n0 + res.inserted.size() && !rep.has("shape") && !rep.has("inserted_edge")) {
    // Source faces on each undirected edge; inserted points on each edge, ordered by t (from min to max index).
    std::unordered_map<std::uint64_t, std::vector<int>> edge_faces;
    for (std::size_t f = 0; f < src.faces.size(); ++f)
      for (int c = 0; c < 3; ++c) edge_faces[key(src.faces[f][c], src.faces[f][(c + 1) % 3])].push_back(static_cast<int>(f));
    std::unordered_map<std::uint64_t, std::vector<std::pair<double, int>>> on_source_edge;
    for (std::size_t i = 0; i < res.inserted.size(); ++i)
      on_source_edge[key(res.inserted[i].a, res.inserted[i].b)].push_back({res.inserted[i].t, static_cast<int>(n0 + i)});
    for (auto& [k, points] : on_source_edge) std::sort(points.begin(), points.end());
    // Refined polygon of source face f: vertex ids, counterclockwise.
    auto refined_polygon = [&](int f) {
      std::vector<int> ids;
      for (int c = 0; c < 3; ++c) {
        const int p = src.faces[f][c], q = src.faces[f][(c + 1) % 3];
        ids.push_back(p);
        auto it = on_source_edge.find(key(p, q));
        if (it == on_source_edge.end()) continue;
        if (p < q) for (const auto& tp : it->second) ids.push_back(tp.second);
        else for (auto r = it->second.rbegin(); r != it->second.rend(); ++r) ids.push_back(r->second);
      }
      return ids;
    };
    // Faces of the result inside source face f: all three corners on f's refined polygon (a face of the other
    // side with all corners on the shared edge would be degenerate_3d).
    auto angle_in_face = [&](int f, int vertex) {
      std::vector<int> ids = refined_polygon(f);
      std::sort(ids.begin(), ids.end());
      long double sum = 0;
      for (const Triangle& t : res.faces) {
        int at = -1;
        bool inside = true;
        for (int c = 0; c < 3 && inside; ++c) {
          inside = std::binary_search(ids.begin(), ids.end(), t[c]);
          if (t[c] == vertex) at = c;
        }
        if (inside && at >= 0) sum += corner_angle(res.uv[t[at]], res.uv[t[(at + 1) % 3]], res.uv[t[(at + 2) % 3]]);
      }
      return sum;
    };
    // Contract point 6's exception: a face whose three corners are on the boundary, pinned where float32 cannot
    // be trusted to keep it positive, may have one point on its chord.
    std::vector<int> loop_position(n0, -1);
    for (std::size_t k = 0; k < src.loop.size(); ++k)
      loop_position[static_cast<std::size_t>(src.loop[k])] = static_cast<int>(k);
    // ... when float32 can hold P at all: every u, v, 1 - v under 1e37 in magnitude, P 2^12 spacings across.
    long double magnitude = 0, lo_x = 0, hi_x = 0, lo_y = 0, hi_y = 0;
    for (std::size_t k = 0; k < prescribed.size(); ++k) {
      const Point2& p = prescribed[k];
      magnitude = std::max({magnitude, std::fabs(static_cast<long double>(p.x)),
                            std::fabs(static_cast<long double>(p.y)), std::fabs(1.0L - p.y)});
      if (k == 0) lo_x = hi_x = p.x, lo_y = hi_y = p.y;
      lo_x = std::min<long double>(lo_x, p.x), hi_x = std::max<long double>(hi_x, p.x);
      lo_y = std::min<long double>(lo_y, p.y), hi_y = std::max<long double>(hi_y, p.y);
    }
    const bool float32_holds_p =
        magnitude < 1e37L && std::max(hi_x - lo_x, hi_y - lo_y) >= std::ldexp(magnitude, -12);
    auto thin_for_float32 = [&](int f) {
      if (!float32_holds_p) return false;
      std::array<Point2, 3> p;
      for (int c = 0; c < 3; ++c) {
        const int k = loop_position[static_cast<std::size_t>(src.faces[f][c])];
        if (k < 0 || static_cast<std::size_t>(k) >= prescribed.size()) return false;
        p[c] = prescribed[static_cast<std::size_t>(k)];
      }
      return !positive_in_float32(p[0], p[1], p[2]) || !clear_of_float32_rounding(p[0], p[1], p[2]);
    };
    for (std::size_t i = 0; i < res.inserted.size(); ++i) {
      const int v = static_cast<int>(n0 + i);
      const Inserted& ins = res.inserted[i];
      const auto it = edge_faces.find(key(ins.a, ins.b));
      if (it == edge_faces.end() || it->second.size() != 2) continue;  // reported above
      if (on_source_edge[key(ins.a, ins.b)].size() == 1 &&
          (thin_for_float32(it->second[0]) || thin_for_float32(it->second[1])))
        continue;
      bool removable = true;
      std::vector<std::vector<int>> without(2);
      for (int side = 0; side < 2 && removable; ++side) {
        without[side] = refined_polygon(it->second[side]);
        without[side].erase(std::remove(without[side].begin(), without[side].end(), v), without[side].end());
        std::vector<Point2> poly;
        for (int id : without[side]) poly.push_back(res.uv[id]);
        // Which source-face edges each vertex lies on: a corner on two, an inserted point on its own.
        const Triangle& face = src.faces[it->second[side]];
        std::vector<unsigned> on;
        for (int id : without[side]) {
          unsigned bits = 0;
          for (int c = 0; c < 3; ++c) {
            const int p = face[c], q = face[(c + 1) % 3];
            const bool on_edge_c = id == p || id == q ||
                                   (id >= static_cast<int>(n0) && key(res.inserted[id - n0].a, res.inserted[id - n0].b) == key(p, q));
            if (on_edge_c) bits |= 1u << c;
          }
          on.push_back(bits);
        }
        // Simple and counterclockwise, and (the refinement's own rule) triangulable without a triangle flat on
        // one original edge.
        removable = simple_counterclockwise(poly) && has_unflat_positive_triangulation(poly, on);
      }
      if (!removable) continue;
      // The angle sum at an original endpoint next to v changes when the polygons' angles there do (by a full
      // turn): then the removal would break the angle sum and v is needed. (At an inserted neighbour on the
      // same edge the two angles always add up to 2 pi.)
      const auto& chain = on_source_edge[key(ins.a, ins.b)];
      const auto pos = std::find_if(chain.begin(), chain.end(), [&](const auto& tp) { return tp.second == v; }) - chain.begin();
      std::vector<int> endpoints;
      if (pos == 0) endpoints.push_back(std::min(ins.a, ins.b));
      if (pos + 1 == static_cast<long>(chain.size())) endpoints.push_back(std::max(ins.a, ins.b));
      for (int e : endpoints) {
        long double before = 0, after = 0;
        for (int side = 0; side < 2; ++side) {
          before += angle_in_face(it->second[side], e);
          const std::vector<int>& ids = without[side];
          const std::size_t m = ids.size();
          const std::size_t at = std::find(ids.begin(), ids.end(), e) - ids.begin();
          // Interior angle of a counterclockwise polygon at ids[at]: from the next vertex round to the previous.
          after += ccw_angle(res.uv[e], res.uv[ids[(at + 1) % m]], res.uv[ids[(at + m - 1) % m]]);
        }
        if (std::fabs(before - after) > kPi) removable = false;
      }
      if (removable)
        add("minimal", "inserted vertex " + std::to_string(v) + " on edge (" + std::to_string(ins.a) + ", " +
                           std::to_string(ins.b) + ") could be removed: the refined polygons of source faces " +
                           std::to_string(it->second[0]) + " and " + std::to_string(it->second[1]) +
                           " stay simple and counterclockwise without it");
    }
  }

  // ---- 5. area ----
  long double a_src = 0, a_res = 0;
  for (const Triangle& t : src.faces) a_src += area3(src.vertices[t[0]], src.vertices[t[1]], src.vertices[t[2]]);
  for (const Triangle& t : res.faces) a_res += area3(res.vertices[t[0]], res.vertices[t[1]], res.vertices[t[2]]);
  rep.area_relative_error = a_src > 0 ? static_cast<double>(std::fabs(a_res - a_src) / a_src) : 0.0;
  if (!(rep.area_relative_error <= 1e-9))
    add("area", "3D area " + num(static_cast<double>(a_res)) + " vs source " + num(static_cast<double>(a_src)) +
                    " (relative error " + num(rep.area_relative_error) + ")");
  return rep;
}

}  // namespace lipmap::mapcheck
