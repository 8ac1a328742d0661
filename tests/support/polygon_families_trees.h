// Polygon generators, family 1c: trees of strictly positive triangles and double loops (weakly
// self-overlapping, with certificate triangulations). See polygon_generators.h for the whole list.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "polygon_families_certified.h"

namespace lipmap::testgen {

// ---------------------------------------------------------------------------------------------------
// 1c: trees of triangles.

// A triangulation grown one positive triangle at a time, each glued onto a boundary edge with a new vertex.
struct TriangleTree {
  std::vector<Pt> pos;
  std::vector<Tri> tris;       // counterclockwise, indices into pos
  std::vector<int> boundary;   // boundary loop (vertex ids), interior on the left
  bool allow_coincident = false;  // may a new vertex sit where an old one is (never a neighbour of it)

  long double angle_sum(int v) const {
    long double s = 0;
    for (const Tri& t : tris)
      for (int k = 0; k < 3; ++k)
        if (t[k] == v) s += corner_angle(pos[t[k]], pos[t[(k + 1) % 3]], pos[t[(k + 2) % 3]]);
    return s;
  }
  long double boundary_angle_at(size_t e) const {  // interior angle of the boundary polygon at boundary[e]
    const size_t nb = boundary.size();
    return interior_angle(pos[boundary[(e + nb - 1) % nb]], pos[boundary[e]], pos[boundary[(e + 1) % nb]]);
  }
  // Glue the triangle (q, p, w) onto the boundary edge p = boundary[e] -> q = boundary[e + 1]; w must be on
  // the right of p -> q. Rejected (nothing changes) unless the triangle is strictly positive by the exact
  // predicate, its angles are all > min_angle, and the boundary keeps its angles away from 0 and 2 pi.
  bool glue(size_t e, const Pt& w, double min_angle = 0.05) {
    const size_t nb = boundary.size();
    const int p = boundary[e], q = boundary[(e + 1) % nb];
    if (exact::orient(pos[q], pos[p], w) <= 0) return false;
    if (corner_angle(pos[q], pos[p], w) < min_angle || corner_angle(pos[p], w, pos[q]) < min_angle ||
        corner_angle(w, pos[q], pos[p]) < min_angle)
      return false;
    if (!allow_coincident)
      for (const Pt& o : pos)
        if (o == w) return false;
    const int id = (int)pos.size();
    pos.push_back(w);
    tris.push_back({q, p, id});
    boundary.insert(boundary.begin() + long(e + 1), id);
    bool ok = true;
    for (size_t k = e; k <= e + 2; ++k) {
      const long double a = boundary_angle_at(k % boundary.size());
      if (a < 1e-3L || a > kTwoPiL - 1e-3L) ok = false;
    }
    if (!ok) {
      boundary.erase(boundary.begin() + long(e + 1));
      tris.pop_back();
      pos.pop_back();
    }
    return ok;
  }
};

// Converts a tree to a GenCase: polygon = boundary loop, certificate = the tree's triangles (renumbered),
// R from the angle sums. Expected: weakly_self_overlapping when T = 1 + sum R >= 2 (every triangulation
// then has sum R = T - 1 > 0), else simple or self_overlapping.
inline bool finish_tree_case(GenCase& c, const TriangleTree& tree, int max_R = kGenMaxRotationIndex) {
  std::vector<int> where(tree.pos.size(), -1);
  for (size_t k = 0; k < tree.boundary.size(); ++k) where[tree.boundary[k]] = (int)k;
  c.poly.clear();
  for (int v : tree.boundary) c.poly.push_back(tree.pos[v]);
  c.certificate.clear();
  for (const Tri& t : tree.tris) c.certificate.push_back({where[t[0]], where[t[1]], where[t[2]]});
  if (!well_conditioned(c.poly)) return false;
  std::vector<int> R;
  const CheckReport rep = check_triangulation(c.poly, c.certificate, {}, &R);
  if (!rep.ok()) return false;
  int sum = 0;
  for (int v : R) {
    if (v < 0 || v > max_R) return false;
    sum += v;
  }
  if (!check_triangulation(c.poly, c.certificate, R).ok()) return false;
  c.certificate_R = R;
  c.turning = 1 + sum;
  if (turning_number(c.poly) != c.turning) return false;
  c.expect = c.turning >= 2 ? Expect::weakly_self_overlapping : Expect::simple_or_self_overlapping;
  return true;
}

// Options of gen_tree. Default: 0 to 2 hubs of 1 or 2 turns, real coordinates.
struct TreeOptions {
  bool lattice = false;      // snap every vertex to the grid (Z/4)^2: exact collinearities, and distinct
                             // vertices at the same point (pinched polygons) are allowed
  int deep_min_turns = 0;    // > 0: exactly one hub, wrapped deep_min_turns..deep_max_turns turns
  int deep_max_turns = 0;
  const char* family = "tree";
};

// 1c: random tree of triangles; hubs around which the growth wraps until the hub's triangulation
// angle passes 2 pi * target (so R_hub = target >= 1 when target > 0).
inline std::optional<GenCase> gen_tree(std::uint64_t seed, const TreeOptions& opt = {}) {
  Rng r(seed);
  GenCase c;
  c.family = opt.family;
  c.seed = seed;
  auto snap = [&](Pt q) { return opt.lattice ? Pt{std::round(q.x * 4) / 4, std::round(q.y * 4) / 4} : q; };
  TriangleTree t;
  t.allow_coincident = opt.lattice;
  {
    const double a0 = r.uniform(0, kTwoPi);
    const double ang = r.uniform(0.5, 1.2), len = r.uniform(0.6, 1.4);
    const double sc = opt.lattice ? 2.0 : 1.0;
    const Pt A{0, 0}, B = snap({sc * std::cos(a0), sc * std::sin(a0)});
    const Pt C = snap({sc * len * std::cos(a0 + ang), sc * len * std::sin(a0 + ang)});
    if (exact::orient(A, B, C) <= 0) return std::nullopt;
    t.pos = {A, B, C};
    t.tris = {{0, 1, 2}};
    t.boundary = {0, 1, 2};
  }
  const bool deep = opt.deep_min_turns > 0;
  const int n_target = r.integer(6, 36);
  const int hubs = deep ? 1 : (r.chance(0.2) ? 0 : (r.chance(0.75) ? 1 : 2));
  std::vector<std::pair<int, long double>> hub_goal;  // vertex, angle sum to reach
  int total_target = 0;
  for (int h = 0; h < hubs; ++h) {
    const int target = deep ? r.integer(opt.deep_min_turns, opt.deep_max_turns) : (r.chance(0.8) ? 1 : 2);
    total_target += target;
    hub_goal.push_back({-1, kTwoPiL * target + (long double)r.uniform(0.4, 4.0)});
  }
  const int max_vertices = deep ? 40 + 12 * opt.deep_max_turns : 70;
  const double sc = opt.lattice ? 2.0 : 1.0;
  int guard = 0;
  size_t hub_index = 0;
  while (guard++ < 4000) {
    const bool hub_pending = hub_index < hub_goal.size();
    if (!hub_pending && (int)t.pos.size() >= n_target) break;
    if ((int)t.pos.size() >= max_vertices) return std::nullopt;
    if (hub_pending && ((int)t.pos.size() >= n_target || r.chance(0.65))) {
      auto& [hub, goal] = hub_goal[hub_index];
      if (hub < 0) {
        hub = t.boundary[size_t(r.integer(0, (int)t.boundary.size() - 1))];
        bool taken = false;
        for (size_t k = 0; k < hub_index; ++k) taken |= hub_goal[k].first == hub;
        if (taken) {
          hub = -1;
          continue;
        }
      }
      if (t.angle_sum(hub) >= goal) {
        ++hub_index;
        continue;
      }
      size_t e = 0;
      while (t.boundary[e] != hub) ++e;
      const Pt H = t.pos[hub], Q = t.pos[t.boundary[(e + 1) % t.boundary.size()]];
      const double phi = std::atan2(Q.y - H.y, Q.x - H.x), delta = r.uniform(0.35, 1.0);
      const double rho = std::clamp(std::hypot(Q.x - H.x, Q.y - H.y) * r.uniform(0.7, 1.3), 0.3 * sc, 3.0 * sc);
      t.glue(e, snap({H.x + rho * std::cos(phi - delta), H.y + rho * std::sin(phi - delta)}));
    } else {
      const size_t e = (size_t)r.integer(0, (int)t.boundary.size() - 1);
      const Pt P = t.pos[t.boundary[e]], Q = t.pos[t.boundary[(e + 1) % t.boundary.size()]];
      const double dx = Q.x - P.x, dy = Q.y - P.y;
      const double out = r.uniform(0.3, 1.0), along = r.uniform(-0.5, 0.5);
      // right normal of P -> Q is (dy, -dx)
      t.glue(e, snap({0.5 * (P.x + Q.x) + out * dy + along * dx, 0.5 * (P.y + Q.y) - out * dx + along * dy}));
    }
  }
  if (hub_index < hub_goal.size()) return std::nullopt;
  if (!finish_tree_case(c, t, std::max(kGenMaxRotationIndex, opt.deep_max_turns))) return std::nullopt;
  c.params = "hubs=" + std::to_string(hubs) + " hub_turns=" + std::to_string(total_target) +
             " T=" + std::to_string(c.turning) + (opt.lattice ? " lattice" : "");
  return c;
}

// 1c: the double loop. Polygon O1 = (-eps, 0), O2 = (eps, 0), v_1..v_m on r(t) = 1 + amp cos(t / 2),
// t from pi/2 + 0.1 to pi/2 + 2 pi L - 0.1 (counterclockwise, L = loops around the hubs). Turning number:
// the curve turns 2 pi L, and the corners at O2, v_1, v_m, O1 are all left turns of about pi/2, so T = L + 1.
// Fans from O1 and from O2 are triangulations (checked exactly by the caller / generator).
struct DoubleLoop {
  Poly poly;                // [O1, O2, v_1, ..., v_m]
  int loops = 0;
  std::vector<Tri> fan_O1;  // (O1, O2, v_1), (O1, v_k, v_k+1)
  std::vector<Tri> fan_O2;  // (O2, v_k, v_k+1), (O1, O2, v_m)
  int outermost = -1;       // index of the vertex of largest radius
};

inline DoubleLoop make_double_loop(int loops, int m, double eps, double amp = 0.3, double noise = 0, Rng* rng = nullptr) {
  DoubleLoop d;
  d.loops = loops;
  d.poly.push_back({-eps, 0});
  d.poly.push_back({eps, 0});
  const double ta = kPi / 2 + 0.1, tb = kPi / 2 + kTwoPi * loops - 0.1;
  double best = -1;
  for (int k = 0; k < m; ++k) {
    const double t = ta + (tb - ta) * k / (m - 1);
    double rad = 1 + amp * std::cos(t / 2);
    if (rng && noise > 0) rad *= 1 + noise * rng->uniform(-1, 1);
    d.poly.push_back({rad * std::cos(t), rad * std::sin(t)});
    if (rad > best) {
      best = rad;
      d.outermost = 2 + k;
    }
  }
  const int n = (int)d.poly.size();
  d.fan_O1.push_back({0, 1, 2});
  for (int k = 2; k + 1 < n; ++k) d.fan_O1.push_back({0, k, k + 1});
  for (int k = 2; k + 1 < n; ++k) d.fan_O2.push_back({1, k, k + 1});
  d.fan_O2.push_back({0, 1, n - 1});
  return d;
}

inline std::optional<GenCase> gen_double_loop(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "double_loop";
  c.seed = seed;
  const int loops = r.integer(1, 2);
  const int m = r.integer(12, 30) * loops;
  const double eps = r.uniform(0.01, 0.1), amp = r.uniform(0.2, 0.35), noise = r.uniform(0, 0.02);
  const DoubleLoop d = make_double_loop(loops, m, eps, amp, noise, &r);
  const bool use_O2 = r.chance(0.5);
  c.poly = d.poly;
  c.certificate = use_O2 ? d.fan_O2 : d.fan_O1;
  if (r.chance(0.7)) {  // a random similarity keeps the certificate valid up to rounding: re-checked below
    c.poly = transformed(c.poly, r.uniform(0, kTwoPi), r.uniform(0.5, 10), r.uniform(-5, 5), r.uniform(-5, 5));
  }
  c.params = fmt("loops", loops) + fmt("eps", eps) + fmt("amp", amp) + fmt("noise", noise) + (use_O2 ? "fan=O2" : "fan=O1");
  if (!well_conditioned(c.poly)) return std::nullopt;
  std::vector<int> R;
  if (!check_triangulation(c.poly, c.certificate, {}, &R).ok()) return std::nullopt;
  if (!check_triangulation(c.poly, c.certificate, R).ok()) return std::nullopt;
  int sum = 0;
  for (int v : R) sum += v;
  c.certificate_R = R;
  c.turning = 1 + sum;
  if (c.turning != loops + 1 || turning_number(c.poly) != c.turning) return std::nullopt;
  c.expect = Expect::weakly_self_overlapping;
  return c;
}

}  // namespace lipmap::testgen
