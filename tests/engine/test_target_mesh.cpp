// Target mesh stage (paper 4, "Meshing the target domain"). The coarse triangulations are built here
// (ear clipping, fans, trees of glued triangles) so that the stage is tested independently of classify; the
// checker below shares no code with the engine's verify_target_mesh.
#include <gtest/gtest.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2_algorithms.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "engine/classify.h"
#include "engine/detail/piece_mesher.h"
#include "engine/error.h"
#include "engine/target_mesh.h"

namespace lipmap {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

CGAL::Orientation orient(const Point2& a, const Point2& b, const Point2& c) {
  return CGAL::orientation(K::Point_2(a.x, a.y), K::Point_2(b.x, b.y), K::Point_2(c.x, c.y));
}

double area2(const Point2& a, const Point2& b, const Point2& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// Angle at a by the law of cosines (a different formula from the engine's).
double angle_at(const Point2& a, const Point2& b, const Point2& c) {
  const double ab = std::hypot(b.x - a.x, b.y - a.y), ac = std::hypot(c.x - a.x, c.y - a.y);
  const double bc = std::hypot(c.x - b.x, c.y - b.y);
  const double cs = (ab * ab + ac * ac - bc * bc) / (2 * ab * ac);
  return std::acos(std::clamp(cs, -1.0, 1.0));
}

struct Coarse {
  BoundaryPolygon P;
  std::vector<Triangle> tris;
};

// From positive triangles over arbitrary vertex ids forming a disk without interior vertices: find the
// boundary loop (directed edges without their reverse) and relabel so that the loop is 0, 1, ..., n-1.
Coarse from_triangles(const std::vector<Point2>& pos, const std::vector<Triangle>& tris) {
  std::set<std::pair<int, int>> directed;
  for (const Triangle& t : tris)
    for (int c = 0; c < 3; ++c) directed.insert({t[c], t[(c + 1) % 3]});
  std::map<int, int> next;
  for (const auto& [u, v] : directed)
    if (!directed.count({v, u})) next[u] = v;
  const int start = next.begin()->first;
  std::map<int, int> label;
  Coarse out;
  int cur = start;
  do {
    label[cur] = static_cast<int>(out.P.vertices.size());
    out.P.vertices.push_back(pos[cur]);
    cur = next.at(cur);
  } while (cur != start);
  for (const Triangle& t : tris) out.tris.push_back({label.at(t[0]), label.at(t[1]), label.at(t[2])});
  return out;
}

// Ear clipping of a simple counterclockwise polygon (exact predicates).
std::vector<Triangle> ear_clip(const std::vector<Point2>& poly) {
  std::vector<int> idx(poly.size());
  for (std::size_t i = 0; i < poly.size(); ++i) idx[i] = static_cast<int>(i);
  std::vector<Triangle> out;
  while (idx.size() > 3) {
    const std::size_t m = idx.size();
    bool clipped = false;
    for (std::size_t i = 0; i < m && !clipped; ++i) {
      const int a = idx[(i + m - 1) % m], b = idx[i], c = idx[(i + 1) % m];
      if (orient(poly[a], poly[b], poly[c]) != CGAL::LEFT_TURN) continue;
      bool empty = true;
      for (int v : idx) {
        if (v == a || v == b || v == c) continue;
        if (orient(poly[a], poly[b], poly[v]) != CGAL::RIGHT_TURN &&
            orient(poly[b], poly[c], poly[v]) != CGAL::RIGHT_TURN &&
            orient(poly[c], poly[a], poly[v]) != CGAL::RIGHT_TURN) {
          empty = false;
          break;
        }
      }
      if (!empty) continue;
      out.push_back({a, b, c});
      idx.erase(idx.begin() + static_cast<long>(i));
      clipped = true;
    }
    if (!clipped) ADD_FAILURE() << "ear clipping found no ear";
    if (!clipped) return out;
  }
  out.push_back({idx[0], idx[1], idx[2]});
  return out;
}

Coarse simple_polygon(std::vector<Point2> poly, bool fan) {
  Coarse c;
  c.P.vertices = poly;
  if (fan) {
    for (int i = 1; i + 1 < static_cast<int>(poly.size()); ++i) c.tris.push_back({0, i, i + 1});
  } else {
    c.tris = ear_clip(poly);
  }
  return c;
}

std::vector<Point2> regular_polygon(int n, double r) {
  std::vector<Point2> p;
  for (int i = 0; i < n; ++i) p.push_back({r * std::cos(2 * M_PI * i / n), r * std::sin(2 * M_PI * i / n)});
  return p;
}

// A non-convex, non-star-shaped simple polygon: a thick "C" (annulus sector) with wavy outer rim; `cap`
// extra points on each of the two straight ends.
std::vector<Point2> c_shape(int m, int cap = 0) {
  std::vector<Point2> p;
  const double a0 = 0.3, a1 = 2 * M_PI - 0.3;
  auto rim = [&](int i) {
    const double t = a0 + (a1 - a0) * i / m;
    const double r = 2.0 + 0.15 * std::sin(9 * t);
    return Point2{r * std::cos(t), r * std::sin(t)};
  };
  auto inner = [&](int i) {
    const double t = a0 + (a1 - a0) * i / m;
    return Point2{std::cos(t), std::sin(t)};
  };
  for (int i = 0; i <= m; ++i) p.push_back(rim(i));
  for (int k = 1; k <= cap; ++k) {  // end at a1, from the rim inwards
    const double s = static_cast<double>(k) / (cap + 1);
    p.push_back({rim(m).x + (inner(m).x - rim(m).x) * s, rim(m).y + (inner(m).y - rim(m).y) * s});
  }
  for (int i = m; i >= 0; --i) p.push_back(inner(i));
  for (int k = 1; k <= cap; ++k) {  // start at a0, outwards
    const double s = static_cast<double>(k) / (cap + 1);
    p.push_back({inner(0).x + (rim(0).x - inner(0).x) * s, inner(0).y + (rim(0).y - inner(0).y) * s});
  }
  return p;
}

// A strip of triangles between two rails bent around the origin through `turns` full turns; the radius grows
// by `growth` per turn (0: the sheets lie exactly on top of each other, with coincident vertices). `cap`
// extra boundary points on each straight end of the strip (its first and last cells become fans).
Coarse strip(int m, double turns, double r1, double r2, double growth, int cap = 0) {
  std::vector<Point2> pos;
  const int per_turn = static_cast<int>(std::lround(m / turns));
  for (int j = 0; j <= m; ++j) {
    // Without growth, positions one turn apart are computed from the same angle: bit-identical.
    const double t = 2 * M_PI * turns * (growth == 0 ? j % per_turn : j) / m;
    const double g = growth * turns * j / m;
    pos.push_back({(r1 + g) * std::cos(t), (r1 + g) * std::sin(t)});  // inner: 2j
    pos.push_back({(r2 + g) * std::cos(t), (r2 + g) * std::sin(t)});  // outer: 2j+1
  }
  auto cap_points = [&](int from, int to) {  // ids of points strictly between pos[from] and pos[to]
    std::vector<int> ids;
    for (int k = 1; k <= cap; ++k) {
      const double s = static_cast<double>(k) / (cap + 1);
      ids.push_back(static_cast<int>(pos.size()));
      pos.push_back({pos[from].x + (pos[to].x - pos[from].x) * s, pos[from].y + (pos[to].y - pos[from].y) * s});
    }
    return ids;
  };
  std::vector<Triangle> tris;
  for (int j = 0; j < m; ++j) {
    if (cap > 0 && j == 0) {
      // Cell 0 is the convex polygon i0, (cap points), o0, o1, i1: a fan from i1.
      std::vector<int> chain = {0};
      for (int id : cap_points(0, 1)) chain.push_back(id);
      chain.push_back(1);
      chain.push_back(3);
      for (std::size_t k = 0; k + 1 < chain.size(); ++k) tris.push_back({2, chain[k], chain[k + 1]});
      continue;
    }
    if (cap > 0 && j == m - 1) {
      // Last cell: i_{m-1}, o_{m-1}, o_m, (cap points from o_m to i_m), i_m: a fan from o_{m-1}.
      std::vector<int> chain = {2 * m + 1};
      for (int id : cap_points(2 * m + 1, 2 * m)) chain.push_back(id);
      chain.push_back(2 * m);
      chain.push_back(2 * j);
      for (std::size_t k = 0; k + 1 < chain.size(); ++k) tris.push_back({2 * j + 1, chain[k], chain[k + 1]});
      continue;
    }
    tris.push_back({2 * j, 2 * j + 1, 2 * j + 3});
    tris.push_back({2 * j, 2 * j + 3, 2 * j + 2});
  }
  return from_triangles(pos, tris);
}

// A tree of triangles grown by gluing a new positive triangle onto a random boundary edge; the growth is
// biased to turn left so that the disk spirals over itself.
Coarse random_tree(unsigned seed, int count) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::vector<Point2> pos = {{0, 0}, {1, 0}, {0.5, 0.8}};
  std::vector<Triangle> tris = {{0, 1, 2}};
  std::vector<std::pair<int, int>> boundary = {{0, 1}, {1, 2}, {2, 0}};  // directed, interior on the left
  while (static_cast<int>(tris.size()) < count) {
    // Prefer the most recent edges (a long arm that curls), sometimes any edge.
    const std::size_t i = U(rng) < 0.8 ? boundary.size() - 1 - static_cast<std::size_t>(U(rng) * std::min<std::size_t>(3, boundary.size()))
                                       : static_cast<std::size_t>(U(rng) * boundary.size());
    const auto [u, v] = boundary[i];
    const Point2 a = pos[u], b = pos[v];
    const double ex = b.x - a.x, ey = b.y - a.y, len = std::hypot(ex, ey);
    if (len < 0.3 || len > 3) continue;
    // Apex on the right of u -> v, shifted forward along the edge so the arm turns.
    const double s = 0.3 + 0.5 * U(rng), hgt = (0.6 + 0.4 * U(rng)) * len;
    const Point2 w{a.x + s * ex + hgt * ey / len, a.y + s * ey - hgt * ex / len};
    if (orient(b, a, w) != CGAL::LEFT_TURN) continue;
    const int id = static_cast<int>(pos.size());
    pos.push_back(w);
    tris.push_back({v, u, id});
    boundary[i] = {u, id};
    boundary.insert(boundary.begin() + static_cast<long>(i) + 1, {id, v});
  }
  return from_triangles(pos, tris);
}

// A fan around a hub sweeping `sweep` radians (> 2 pi: weakly self-overlapping, the hub is singular); `cap`
// extra boundary points on each of the two spokes that are polygon edges.
Coarse hub_fan(double sweep, int m, double wobble, int cap = 0) {
  std::vector<Point2> pos = {{0, 0}};
  for (int i = 0; i <= m; ++i) {
    const double t = sweep * i / m;
    const double r = 1.0 + wobble * std::sin(5 * t);
    pos.push_back({r * std::cos(t), r * std::sin(t)});
  }
  auto spoke = [&](int from, int to) {
    std::vector<int> ids;
    for (int k = 1; k <= cap; ++k) {
      const double s = static_cast<double>(k) / (cap + 1);
      ids.push_back(static_cast<int>(pos.size()));
      pos.push_back({pos[from].x + (pos[to].x - pos[from].x) * s, pos[from].y + (pos[to].y - pos[from].y) * s});
    }
    return ids;
  };
  std::vector<Triangle> tris;
  for (int i = 1; i <= m; ++i) {
    if (cap > 0 && i == 1) {  // hub, (points towards rim 1), rim 1, rim 2: a fan from rim 2
      std::vector<int> chain = {0};
      for (int id : spoke(0, 1)) chain.push_back(id);
      chain.push_back(1);
      for (std::size_t k = 0; k + 1 < chain.size(); ++k) tris.push_back({2, chain[k], chain[k + 1]});
      continue;
    }
    if (cap > 0 && i == m) {  // rim m, rim m+1, (points towards the hub), hub: a fan from rim m
      std::vector<int> chain = {m + 1};
      for (int id : spoke(m + 1, 0)) chain.push_back(id);
      chain.push_back(0);
      for (std::size_t k = 0; k + 1 < chain.size(); ++k) tris.push_back({m, chain[k], chain[k + 1]});
      continue;
    }
    tris.push_back({0, i, i + 1});
  }
  return from_triangles(pos, tris);
}

struct MeshReport {
  double min_angle_all = 180, min_angle_inner = 180;  // inner: triangles with no polygon vertex
  double frac_below_20 = 0;
};

// Independent check of every property the stage promises.
MeshReport check_mesh(const Coarse& c, const TargetMesh& m) {
  MeshReport rep;
  const int n = static_cast<int>(c.P.vertices.size());
  const int V = static_cast<int>(m.vertices.size());
  const int F = static_cast<int>(m.faces.size());
  EXPECT_GE(V, n);
  for (int k = 0; k < n && k < V; ++k) {
    EXPECT_EQ(std::memcmp(&m.vertices[k], &c.P.vertices[k], sizeof(Point2)), 0) << "vertex " << k;
  }
  std::map<std::pair<int, int>, int> directed;
  std::vector<std::vector<int>> faces_at(V);
  int bad_orient = 0;
  for (int f = 0; f < F; ++f) {
    const Triangle& t = m.faces[f];
    for (int i = 0; i < 3; ++i) {
      EXPECT_TRUE(t[i] >= 0 && t[i] < V);
      if (t[i] < 0 || t[i] >= V) return rep;
    }
    if (orient(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]) != CGAL::LEFT_TURN) ++bad_orient;
    for (int i = 0; i < 3; ++i) {
      ++directed[{t[i], t[(i + 1) % 3]}];
      faces_at[t[i]].push_back(f);
    }
  }
  EXPECT_EQ(bad_orient, 0) << "faces not strictly positive";
  std::set<std::pair<int, int>> undirected;
  std::map<int, int> boundary_next;
  for (const auto& [e, cnt] : directed) {
    EXPECT_EQ(cnt, 1) << "directed edge used twice";
    undirected.insert({std::min(e.first, e.second), std::max(e.first, e.second)});
    if (!directed.count({e.second, e.first})) {
      EXPECT_FALSE(boundary_next.count(e.first)) << "two boundary edges leave " << e.first;
      boundary_next[e.first] = e.second;
    }
  }
  // Single boundary loop 0, 1, ..., n-1 (interior on the left because the faces are counterclockwise).
  EXPECT_EQ(static_cast<int>(boundary_next.size()), n);
  for (int k = 0; k < n; ++k) {
    auto it = boundary_next.find(k);
    EXPECT_TRUE(it != boundary_next.end() && it->second == (k + 1) % n) << "boundary at " << k;
  }
  const long long E = static_cast<long long>(undirected.size());
  EXPECT_EQ(V - E + F, 1) << "Euler characteristic";
  // Each vertex's faces form one edge-connected fan; interior angle sums are 2 pi.
  double angle_total_err = 0;
  for (int v = 0; v < V; ++v) {
    const auto& fs = faces_at[v];
    EXPECT_FALSE(fs.empty()) << "unused vertex " << v;
    if (fs.empty()) continue;
    std::vector<char> seen(fs.size(), 0);
    std::vector<std::size_t> stack = {0};
    seen[0] = 1;
    std::size_t reached = 1;
    auto others = [&](int f) {
      std::vector<int> o;
      for (int x : m.faces[f])
        if (x != v) o.push_back(x);
      return o;
    };
    while (!stack.empty()) {
      const std::size_t i = stack.back();
      stack.pop_back();
      const auto oi = others(fs[i]);
      for (std::size_t j = 0; j < fs.size(); ++j) {
        if (seen[j]) continue;
        const auto oj = others(fs[j]);
        if (oi[0] == oj[0] || oi[0] == oj[1] || oi[1] == oj[0] || oi[1] == oj[1]) {
          seen[j] = 1;
          ++reached;
          stack.push_back(j);
        }
      }
    }
    EXPECT_EQ(reached, fs.size()) << "vertex " << v << " is not manifold";
    if (v >= n) {
      double sum = 0;
      for (int f : fs) {
        const Triangle& t = m.faces[f];
        const int i = t[0] == v ? 0 : (t[1] == v ? 1 : 2);
        sum += angle_at(m.vertices[v], m.vertices[t[(i + 1) % 3]], m.vertices[t[(i + 2) % 3]]);
      }
      angle_total_err = std::max(angle_total_err, std::fabs(sum - 2 * M_PI));
    }
  }
  EXPECT_LT(angle_total_err, 1e-6) << "interior angle sum differs from 2 pi";
  double a = 0, ca = 0;
  for (const Triangle& t : m.faces) a += area2(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]);
  for (const Triangle& t : c.tris) ca += area2(c.P.vertices[t[0]], c.P.vertices[t[1]], c.P.vertices[t[2]]);
  EXPECT_NEAR(a / ca, 1.0, 1e-9) << "area";
  int below = 0;
  for (const Triangle& t : m.faces) {
    double mn = 180;
    for (int i = 0; i < 3; ++i)
      mn = std::min(mn, angle_at(m.vertices[t[i]], m.vertices[t[(i + 1) % 3]], m.vertices[t[(i + 2) % 3]]) * 180 / M_PI);
    rep.min_angle_all = std::min(rep.min_angle_all, mn);
    if (t[0] >= n && t[1] >= n && t[2] >= n) rep.min_angle_inner = std::min(rep.min_angle_inner, mn);
    if (mn < 20) ++below;
  }
  rep.frac_below_20 = F ? static_cast<double>(below) / F : 0;
  return rep;
}

// With LIPMAP_TM_SVG_DIR set, writes the mesh as an SVG (triangles under 20 degrees in red) for inspection.
void maybe_dump_svg(const Coarse& c, const TargetMesh& m, const std::string& name) {
  const char* dir = std::getenv("LIPMAP_TM_SVG_DIR");
  if (!dir) return;
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const Point2& p : m.vertices) {
    x0 = std::min(x0, p.x), y0 = std::min(y0, p.y), x1 = std::max(x1, p.x), y1 = std::max(y1, p.y);
  }
  const double scale = 1000.0 / std::max(x1 - x0, y1 - y0);
  std::string file = std::string(dir) + "/" + name + ".svg";
  for (char& ch : file)
    if (ch == ' ') ch = '_';
  FILE* f = std::fopen(file.c_str(), "w");
  if (!f) return;
  std::fprintf(f, "<svg xmlns='http://www.w3.org/2000/svg' width='1000' height='1000'><rect width='1000' height='1000' fill='white'/>\n");
  auto X = [&](const Point2& p) { return (p.x - x0) * scale; };
  auto Y = [&](const Point2& p) { return 1000 - (p.y - y0) * scale; };
  for (const Triangle& t : m.faces) {
    double mn = 180;
    for (int i = 0; i < 3; ++i)
      mn = std::min(mn, angle_at(m.vertices[t[i]], m.vertices[t[(i + 1) % 3]], m.vertices[t[(i + 2) % 3]]) * 180 / M_PI);
    std::fprintf(f, "<polygon points='%.2f,%.2f %.2f,%.2f %.2f,%.2f' fill='%s' fill-opacity='0.35' stroke='black' stroke-width='0.3'/>\n",
                 X(m.vertices[t[0]]), Y(m.vertices[t[0]]), X(m.vertices[t[1]]), Y(m.vertices[t[1]]), X(m.vertices[t[2]]),
                 Y(m.vertices[t[2]]), mn < 20 ? "red" : "#8cf");
  }
  const int n = static_cast<int>(c.P.vertices.size());
  for (int k = 0; k < n; ++k) {
    const Point2& a = c.P.vertices[k];
    const Point2& b = c.P.vertices[(k + 1) % n];
    std::fprintf(f, "<line x1='%.2f' y1='%.2f' x2='%.2f' y2='%.2f' stroke='blue' stroke-width='1.2'/>\n", X(a), Y(a), X(b), Y(b));
  }
  std::fprintf(f, "</svg>\n");
  std::fclose(f);
}

TargetMesh run(const Coarse& c, double density, int source) {
  TargetMeshOptions o;
  o.density = density;
  o.source_triangles = source;
  return build_target_mesh(c.P, c.tris, o);
}

// Quality expectations. Coarse polygons whose edges are many times longer than the target size cannot be
// meshed without some bad triangles next to those edges (they may not be split), so for them only the share
// of triangles under 20 degrees is bounded; polygons with source-like boundaries (edges about as long as the
// target size) also get a bound on the smallest angle of the triangles away from the boundary.
struct Quality {
  double max_below_20 = 0.05;   // share of triangles with an angle under 20 degrees
  double min_inner = 0;         // smallest angle of triangles with no polygon vertex
};

void check_counts(const Coarse& c, const char* name, Quality q, std::vector<double> densities = {0.5, 1.0, 4.0},
                  int source = 2000) {
  for (double density : densities) {
    SCOPED_TRACE(std::string(name) + " density " + std::to_string(density));
    TargetMesh m = run(c, density, source);
    maybe_dump_svg(c, m, std::string(name) + "_" + std::to_string(static_cast<int>(density * 10)));
    const MeshReport r = check_mesh(c, m);
    const double want = density * source;
    EXPECT_EQ(m.target_triangles, static_cast<int>(want));
    EXPECT_GT(static_cast<double>(m.faces.size()), want / 1.5) << "too few triangles";
    EXPECT_LT(static_cast<double>(m.faces.size()), want * 1.5) << "too many triangles";
    EXPECT_LE(r.frac_below_20, q.max_below_20) << "too many triangles under 20 degrees";
    EXPECT_GE(r.min_angle_inner, q.min_inner) << "badly shaped triangles away from the boundary";
    EXPECT_NEAR(m.min_angle_deg, r.min_angle_all, 1e-6);
    std::printf("[%s] n=%zu target=%.0f faces=%zu pieces=%d splits=%d min=%.1f min_inner=%.1f under20=%.4f "
                "ms=%.1f\n",
                name, c.P.vertices.size(), want, m.faces.size(), m.pieces, m.interior_edge_splits, r.min_angle_all,
                r.min_angle_inner, r.frac_below_20, m.ms);
  }
}

TEST(TargetMesh, ConvexFanIsOnePiece) {
  const Coarse c = simple_polygon(regular_polygon(40, 1.0), true);
  check_counts(c, "convex fan", {0.01, 12});
  const TargetMesh m = run(c, 1, 2000);
  EXPECT_EQ(m.pieces, 1);
  EXPECT_EQ(m.interior_edge_splits, 0);
}

TEST(TargetMesh, NonConvexEarClipped) {
  const Coarse c = simple_polygon(c_shape(40), false);
  check_counts(c, "C shape", {0.02, 8});
  EXPECT_EQ(run(c, 1, 2000).pieces, 1);
}

TEST(TargetMesh, TriangleAndDefaultDensity) {
  const Coarse c = simple_polygon({{0, 0}, {1, 0}, {0, 1}}, true);
  const TargetMesh m = build_target_mesh(c.P, c.tris);
  check_mesh(c, m);
  EXPECT_EQ(m.target_triangles, 6);  // 2n
  EXPECT_GE(m.faces.size(), 1u);
  // A polygon with more vertices than the target allows: the boundary alone gives n - 2 triangles.
  const Coarse d = simple_polygon(regular_polygon(200, 1.0), true);
  TargetMeshOptions o;
  o.source_triangles = 50;
  const TargetMesh md = build_target_mesh(d.P, d.tris, o);
  check_mesh(d, md);
  EXPECT_GE(md.faces.size(), 198u);
}

TEST(TargetMesh, StripBentThroughOneAndAHalfTurns) {
  const Coarse c = strip(90, 1.5, 1.0, 2.0, 0.4);
  check_counts(c, "spiral strip", {0.01, 8});
  const TargetMesh m = run(c, 1, 2000);
  EXPECT_GE(m.pieces, 2);
  EXPECT_GT(m.interior_edge_splits, 0);
}

TEST(TargetMesh, StripWithCoincidentSheets) {
  // Constant radius: vertices one turn apart coincide exactly (different sheets, same position).
  const Coarse c = strip(60, 1.5, 1.0, 2.0, 0.0);
  int coincident = 0;
  for (std::size_t i = 0; i < c.P.vertices.size(); ++i)
    for (std::size_t j = i + 1; j < c.P.vertices.size(); ++j) coincident += c.P.vertices[i] == c.P.vertices[j];
  EXPECT_GT(coincident, 0);
  check_counts(c, "coincident strip", {0.02, 8});
  EXPECT_GE(run(c, 1, 2000).pieces, 2);
}

TEST(TargetMesh, RandomTreesOfTriangles) {
  for (unsigned seed = 1; seed <= 6; ++seed) {
    const Coarse c = random_tree(seed, 60);
    SCOPED_TRACE("seed " + std::to_string(seed));
    // Coarse and spiky: edges about ten times the target size.
    check_counts(c, ("tree " + std::to_string(seed)).c_str(), {0.10, 0}, {1.0}, 3000);
  }
}

TEST(TargetMesh, WeaklySelfOverlappingHubFan) {
  const Coarse c = hub_fan(2 * M_PI * 1.4, 40, 0.2);
  check_counts(c, "hub fan 1.4 turns", {0.02, 3});
  EXPECT_GE(run(c, 1, 2000).pieces, 2);
  const Coarse d = hub_fan(4 * M_PI, 48, 0.0);  // two exact turns: rim vertices coincide
  check_counts(d, "hub fan 2 turns", {0.02, 3});
}

// Boundaries like those of real source meshes: all edges about as long as the target size. Then the mesher
// reaches its 20 degree bound everywhere, except where the polygon itself has sharper corners (the random
// tree's spikes).
TEST(TargetMesh, SourceLikeBoundariesGiveGoodTriangles) {
  struct Case {
    const char* name;
    Coarse c;
    int source;
    Quality q;
  };
  const Quality strict{0.0, 20.0};
  const std::vector<Case> cases = {
      {"dense C", simple_polygon(c_shape(150, 12), false), 4000, strict},
      {"dense spiral", strip(300, 1.5, 1.0, 2.0, 0.4, 15), 8000, strict},
      {"dense coincident strip", strip(240, 1.5, 1.0, 2.0, 0.0, 12), 6000, strict},
      {"dense hub 1.4 turns", hub_fan(2 * M_PI * 1.4, 200, 0.2, 20), 6000, strict},
      {"dense tree", random_tree(3, 800), 4000, {0.05, 8.0}},
  };
  for (const Case& cs : cases) check_counts(cs.c, cs.name, cs.q, {1.0}, cs.source);
}

TEST(TargetMesh, CollinearBoundaryVerticesAndFarCoordinates) {
  // A square with three extra points on each side (straight polygon vertices), ear clipped.
  std::vector<Point2> sq;
  for (int side = 0; side < 4; ++side)
    for (int k = 0; k < 4; ++k) {
      const double t = k / 4.0;
      const Point2 corners[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
      const Point2 a = corners[side], b = corners[(side + 1) % 4];
      sq.push_back({a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t});
    }
  check_counts(simple_polygon(sq, false), "square with straight vertices", {0.0, 20}, {1.0});
  // The self-overlapping strip far from the origin and small: relative precision is what matters.
  Coarse far = strip(90, 1.5, 1.0, 2.0, 0.4, 3);
  for (Point2& p : far.P.vertices) p = {1e6 + 1e-3 * p.x, -2e6 + 1e-3 * p.y};
  check_counts(far, "far small strip", {0.01, 8}, {1.0});
}

TEST(TargetMesh, DeterministicAndInputKeptBitForBit) {
  Coarse c = strip(90, 1.5, 1.0, 2.0, 0.4);
  // Coordinates that do not round-trip through arithmetic: the output must still copy them exactly.
  c.P.vertices[5].x = std::nextafter(c.P.vertices[5].x, 10.0);
  ASSERT_EQ(c.P.vertices[0].y, 0.0);
  c.P.vertices[0].y = -0.0;
  const TargetMesh a = run(c, 1, 2000), b = run(c, 1, 2000);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  ASSERT_EQ(a.faces, b.faces);
  EXPECT_EQ(std::memcmp(a.vertices.data(), b.vertices.data(), a.vertices.size() * sizeof(Point2)), 0);
  EXPECT_TRUE(std::signbit(a.vertices[0].y));
  check_mesh(c, a);
}

TEST(TargetMesh, SplitPointsLieOnTheirEdgeAndAreShared) {
  const Coarse c = hub_fan(2 * M_PI * 1.4, 40, 0.2);
  const TargetMesh m = run(c, 1, 4000);
  const int n = static_cast<int>(c.P.vertices.size());
  ASSERT_GT(m.interior_edge_splits, 0);
  // Split points are ids n .. n+splits-1: each lies within rounding of a coarse interior edge and is used by
  // faces on both sides (its fan closes: it is an interior vertex with angle sum 2 pi, checked in check_mesh).
  for (int v = n; v < n + m.interior_edge_splits; ++v) {
    double best = INFINITY;
    for (const Triangle& t : c.tris)
      for (int i = 0; i < 3; ++i) {
        const Point2& a = c.P.vertices[t[i]];
        const Point2& b = c.P.vertices[t[(i + 1) % 3]];
        const double len = std::hypot(b.x - a.x, b.y - a.y);
        const double d = std::fabs(area2(a, b, m.vertices[v])) / len;
        const double along = ((m.vertices[v].x - a.x) * (b.x - a.x) + (m.vertices[v].y - a.y) * (b.y - a.y)) / len;
        if (along > 0 && along < len) best = std::min(best, d);
      }
    EXPECT_LT(best, 1e-12) << "split point " << v << " is not on a coarse edge";
  }
  check_mesh(c, m);
}

// The stage on classify's own coarse triangulations (Shor-van Wyk: many long, needle-like diagonals).
TEST(TargetMesh, OnClassifyTriangulations) {
  struct Case {
    const char* name;
    BoundaryPolygon P;
    Verdict verdict;
    int source;
  };
  std::vector<Case> cases = {
      {"classify C", simple_polygon(c_shape(60, 6), false).P, Verdict::simple, 3000},
      {"classify spiral", strip(120, 1.5, 1.0, 2.0, 0.4, 6).P, Verdict::self_overlapping, 5000},
      {"classify coincident strip", strip(90, 1.5, 1.0, 2.0, 0.0, 4).P, Verdict::self_overlapping, 4000},
      {"classify hub 1.4 turns", hub_fan(2 * M_PI * 1.4, 80, 0.2, 8).P, Verdict::weakly_self_overlapping, 4000},
      // A tree of triangles may wind more than once around some vertex: either verdict is right.
      {"classify tree", random_tree(5, 150).P, Verdict::not_self_overlapping, 3000},
  };
  for (Case& cs : cases) {
    SCOPED_TRACE(cs.name);
    const Classification cl = classify(cs.P);
    if (cs.verdict == Verdict::not_self_overlapping)
      ASSERT_NE(cl.verdict, Verdict::not_self_overlapping) << cl.reason;
    else
      ASSERT_EQ(cl.verdict, cs.verdict) << cl.reason;
    const Coarse c{cs.P, cl.triangulation};
    check_counts(c, cs.name, {0.05, 0}, {1.0}, cs.source);
    if (cs.verdict == Verdict::simple) EXPECT_EQ(run(c, 1, cs.source).pieces, 1);
  }
}

// The partition's merge test (two simple pieces glued along an edge) against CGAL::is_simple_2 on the whole
// union, for many pairs of adjacent sub-trees of random trees of triangles.
TEST(TargetMesh, GluedUnionTestAgreesWithIsSimple) {
  using KP = K::Point_2;
  auto cycle_of = [](const std::vector<Triangle>& tris, const std::vector<int>& set) {
    std::set<std::pair<int, int>> directed;
    for (int t : set)
      for (int c = 0; c < 3; ++c) directed.insert({tris[t][c], tris[t][(c + 1) % 3]});
    std::map<int, int> next;
    for (const auto& [u, v] : directed)
      if (!directed.count({v, u})) next[u] = v;
    std::vector<int> cyc;
    int cur = next.begin()->first;
    do {
      cyc.push_back(cur);
      cur = next.at(cur);
    } while (cur != cyc.front() && cyc.size() <= next.size());
    return cyc;
  };
  auto simple = [](const std::vector<Point2>& q) {
    std::vector<KP> k;
    for (const Point2& p : q) k.emplace_back(p.x, p.y);
    return CGAL::is_simple_2(k.begin(), k.end(), K());
  };
  std::mt19937 rng(7);
  int agree_simple = 0, agree_not = 0;
  for (unsigned seed = 1; seed <= 12; ++seed) {
    const Coarse c = random_tree(seed, 40);
    const auto& P = c.P.vertices;
    std::map<std::pair<int, int>, int> owner;
    for (int t = 0; t < static_cast<int>(c.tris.size()); ++t)
      for (int k = 0; k < 3; ++k) owner[{c.tris[t][k], c.tris[t][(k + 1) % 3]}] = t;
    std::vector<std::vector<int>> adj(c.tris.size());
    for (const auto& [e, t] : owner) {
      auto it = owner.find({e.second, e.first});
      if (it != owner.end()) adj[t].push_back(it->second);
    }
    for (const auto& [e, t1] : owner) {
      auto it = owner.find({e.second, e.first});
      if (it == owner.end()) continue;
      const int t2 = it->second, a = e.first, b = e.second;  // a -> b in t1
      auto grow = [&](int start, int avoid, int size) {
        std::vector<int> set = {start};
        std::set<int> in = {start, avoid};
        for (std::size_t i = 0; i < set.size() && static_cast<int>(set.size()) < size; ++i)
          for (int nb : adj[set[i]])
            if (!in.count(nb) && static_cast<int>(set.size()) < size) {
              in.insert(nb);
              set.push_back(nb);
            }
        return set;
      };
      const std::vector<int> A = grow(t1, t2, 1 + static_cast<int>(rng() % 12));
      const std::vector<int> B = grow(t2, t1, 1 + static_cast<int>(rng() % 12));
      const std::vector<int> ca = cycle_of(c.tris, A), cb = cycle_of(c.tris, B);
      std::vector<Point2> qa, qb;
      for (int v : ca) qa.push_back(P[v]);
      for (int v : cb) qb.push_back(P[v]);
      if (!simple(qa) || !simple(qb)) continue;
      const std::size_t pa = std::find(ca.begin(), ca.end(), b) - ca.begin();
      const std::size_t pb = std::find(cb.begin(), cb.end(), a) - cb.begin();
      std::vector<Point2> a_path, b_path, whole;
      for (std::size_t j = 0; j < ca.size(); ++j) a_path.push_back(P[ca[(pa + j) % ca.size()]]);
      for (std::size_t j = 0; j < cb.size(); ++j) b_path.push_back(P[cb[(pb + j) % cb.size()]]);
      whole = a_path;
      whole.insert(whole.end(), b_path.begin() + 1, b_path.end() - 1);
      const bool expected = simple(whole);
      ASSERT_EQ(detail::glued_union_is_simple(a_path, b_path), expected) << "seed " << seed << " edge " << a << "," << b;
      (expected ? agree_simple : agree_not)++;
    }
  }
  EXPECT_GT(agree_simple, 50);
  EXPECT_GT(agree_not, 50);
  std::printf("glued union: %d simple, %d not simple, all agree with is_simple_2\n", agree_simple, agree_not);
}

TEST(TargetMesh, BadOptionsAndBadTriangulations) {
  const Coarse c = simple_polygon(regular_polygon(8, 1.0), true);
  TargetMeshOptions o;
  o.density = 0;
  EXPECT_THROW(build_target_mesh(c.P, c.tris, o), InputError);
  o.density = NAN;
  EXPECT_THROW(build_target_mesh(c.P, c.tris, o), InputError);
  o.density = 1;
  o.min_angle_deg = 40;
  EXPECT_THROW(build_target_mesh(c.P, c.tris, o), InputError);
  o.min_angle_deg = 20;
  o.source_triangles = -1;
  EXPECT_THROW(build_target_mesh(c.P, c.tris, o), InputError);
  std::vector<Triangle> missing(c.tris.begin(), c.tris.end() - 1);
  EXPECT_THROW(build_target_mesh(c.P, missing, {}), InternalError);
  std::vector<Triangle> flipped = c.tris;
  std::swap(flipped[2][1], flipped[2][2]);
  EXPECT_THROW(build_target_mesh(c.P, flipped, {}), InternalError);
  std::vector<Triangle> out_of_range = c.tris;
  out_of_range[0][0] = 8;
  EXPECT_THROW(build_target_mesh(c.P, out_of_range, {}), InternalError);
  // Right count, wrong shape: two fans over the same hexagon-half would reuse a directed edge.
  std::vector<Triangle> duplicate = c.tris;
  duplicate[1] = duplicate[0];
  EXPECT_THROW(build_target_mesh(c.P, duplicate, {}), InternalError);
}

TEST(TargetMesh, Cancellation) {
  const Coarse c = strip(90, 1.5, 1.0, 2.0, 0.4);
  CancelToken token;
  token.cancel();
  TargetMeshOptions o;
  o.source_triangles = 20000;
  EXPECT_THROW(build_target_mesh(c.P, c.tris, o, &token), Cancelled);
}

TEST(TargetMesh, VerifyRejectsBrokenMeshes) {
  const Coarse c = simple_polygon(regular_polygon(12, 1.0), true);
  TargetMesh m = run(c, 1, 200);
  verify_target_mesh(c.P, c.tris, m);
  TargetMesh flipped = m;
  std::swap(flipped.faces[0][1], flipped.faces[0][2]);
  EXPECT_THROW(verify_target_mesh(c.P, c.tris, flipped), InternalError);
  TargetMesh dropped = m;
  dropped.faces.pop_back();
  EXPECT_THROW(verify_target_mesh(c.P, c.tris, dropped), InternalError);
  TargetMesh moved = m;
  moved.vertices[3].x = std::nextafter(moved.vertices[3].x, 10.0);
  EXPECT_THROW(verify_target_mesh(c.P, c.tris, moved), InternalError);
  TargetMesh extra = m;
  extra.vertices.push_back({0.0, 0.0});  // unused vertex
  EXPECT_THROW(verify_target_mesh(c.P, c.tris, extra), InternalError);
  // A boundary vertex moved inside keeps orientation of most faces but breaks the angle/area checks.
  TargetMesh shifted = m;
  shifted.vertices[m.vertices.size() - 1].x += 1e-3;
  try {
    verify_target_mesh(c.P, c.tris, shifted);
  } catch (const InternalError&) {
  }
}

}  // namespace
}  // namespace lipmap
