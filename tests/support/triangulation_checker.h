// Independent checker for the classify stage (tests and benchmarks only).
//
// Nothing here includes or reuses engine code: the polygon predicates (exact orientation, exact segment
// intersection, exact winding number) come from CGAL's Exact_predicates_inexact_constructions_kernel, the
// angle bookkeeping is plain long-double trigonometry, written from the definitions of the paper
// (Weber & Zorin, section 3.1, 3.2):
//   alpha_i  = interior angle of P at v_i, on the left, in (0, 2 pi]
//   theta_i  = triangulation angle = sum of the angles at v_i of the triangles incident to v_i
//   theta_i  = alpha_i + 2 pi R_i   (R_i = full rotation index, an integer >= 0)
//   turning number T = sum_i (pi - alpha_i) / 2 pi, and for any triangulation sum_i R_i = T - 1
//   (n - 2 triangles carry (n - 2) pi of angle: sum alpha_i + 2 pi sum R_i = (n - 2) pi).
#pragma once

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "testgen_types.h"

namespace lipmap::testgen {

// ---------------------------------------------------------------------------------------------------
// Exact predicates (CGAL Epick: filtered, exact on the given doubles).
namespace exact {
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
inline K::Point_2 kp(const Pt& p) { return K::Point_2(p.x, p.y); }

// +1: (a, b, c) counterclockwise, -1: clockwise, 0: collinear.
inline int orient(const Pt& a, const Pt& b, const Pt& c) {
  const CGAL::Orientation o = CGAL::orientation(kp(a), kp(b), kp(c));
  return o == CGAL::LEFT_TURN ? 1 : (o == CGAL::RIGHT_TURN ? -1 : 0);
}

inline bool segments_intersect(const Pt& a, const Pt& b, const Pt& c, const Pt& d) {
  return CGAL::do_intersect(K::Segment_2(kp(a), kp(b)), K::Segment_2(kp(c), kp(d)));
}

// Is q on the closed segment [a, b]?
inline bool on_segment(const Pt& a, const Pt& b, const Pt& q) {
  if (orient(a, b, q) != 0) return false;
  return std::min(a.x, b.x) <= q.x && q.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= q.y &&
         q.y <= std::max(a.y, b.y);
}
}  // namespace exact

// ---------------------------------------------------------------------------------------------------
// Float angle helpers (long double).

// Angle at a of the triangle (a, b, c), in [0, pi], unsigned.
inline long double corner_angle(const Pt& a, const Pt& b, const Pt& c) {
  const long double ux = (long double)b.x - a.x, uy = (long double)b.y - a.y;
  const long double wx = (long double)c.x - a.x, wy = (long double)c.y - a.y;
  return std::fabs(std::atan2(ux * wy - uy * wx, ux * wx + uy * wy));
}

// Interior angle at v (polygon ... prev, v, next ...), on the left: the counterclockwise rotation from
// (next - v) to (prev - v), in (0, 2 pi]. A spike (prev and next in the same direction) gives 2 pi.
inline long double interior_angle(const Pt& prev, const Pt& v, const Pt& next) {
  const long double ux = (long double)next.x - v.x, uy = (long double)next.y - v.y;
  const long double wx = (long double)prev.x - v.x, wy = (long double)prev.y - v.y;
  long double a = std::atan2(ux * wy - uy * wx, ux * wx + uy * wy);
  if (a <= 0) a += kTwoPiL;
  return a;
}

inline std::vector<long double> interior_angles(const Poly& p) {
  const size_t n = p.size();
  std::vector<long double> a(n);
  for (size_t i = 0; i < n; ++i) a[i] = interior_angle(p[(i + n - 1) % n], p[i], p[(i + 1) % n]);
  return a;
}

// Turning number: sum of signed exterior angles (pi - alpha_i) over 2 pi. *raw receives the unrounded
// value (an integer up to rounding for every polygon without zero-length edges).
inline int turning_number(const Poly& p, long double* raw = nullptr) {
  long double sum = 0;
  for (long double a : interior_angles(p)) sum += kPiL - a;
  const long double t = sum / kTwoPiL;
  if (raw) *raw = t;
  return (int)std::llround(t);
}

// Winding number of p around q, exact (Sunday's crossing rule with the exact orientation predicate).
// *on_boundary is set when q lies on p.
inline int winding_number(const Poly& p, const Pt& q, bool* on_boundary = nullptr) {
  int wn = 0;
  bool on = false;
  const size_t n = p.size();
  for (size_t i = 0; i < n; ++i) {
    const Pt& a = p[i];
    const Pt& b = p[(i + 1) % n];
    if (exact::on_segment(a, b, q)) on = true;
    if (a.y <= q.y) {
      if (b.y > q.y && exact::orient(a, b, q) > 0) ++wn;
    } else {
      if (b.y <= q.y && exact::orient(a, b, q) < 0) --wn;
    }
  }
  if (on_boundary) *on_boundary = on;
  return wn;
}

// Exact O(n^2) simplicity test: no two edges meet except consecutive ones at their common vertex.
inline bool is_simple(const Poly& p, std::string* why = nullptr) {
  const size_t n = p.size();
  auto fail = [&](const std::string& s) {
    if (why) *why = s;
    return false;
  };
  if (n < 3) return fail("fewer than 3 vertices");
  for (size_t i = 0; i < n; ++i)
    if (p[i] == p[(i + 1) % n]) return fail("zero-length edge at " + std::to_string(i));
  // Consecutive edges (prev, v), (v, next) overlap iff collinear and folding back (angle 0 at v).
  for (size_t i = 0; i < n; ++i) {
    const Pt& a = p[(i + n - 1) % n];
    const Pt& b = p[i];
    const Pt& c = p[(i + 1) % n];
    if (exact::orient(a, b, c) == 0 &&
        CGAL::angle(exact::kp(a), exact::kp(b), exact::kp(c)) == CGAL::ACUTE)
      return fail("edges at vertex " + std::to_string(i) + " fold back on each other");
  }
  if (n == 3) return true;
  struct Box { double x0, x1, y0, y1; };
  std::vector<Box> box(n);
  for (size_t i = 0; i < n; ++i) {
    const Pt& a = p[i];
    const Pt& b = p[(i + 1) % n];
    box[i] = {std::min(a.x, b.x), std::max(a.x, b.x), std::min(a.y, b.y), std::max(a.y, b.y)};
  }
  // Sweep by x to skip pairs whose boxes are disjoint in x.
  std::vector<size_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return box[a].x0 < box[b].x0; });
  for (size_t oi = 0; oi < n; ++oi) {
    const size_t i = order[oi];
    for (size_t oj = oi + 1; oj < n; ++oj) {
      const size_t j = order[oj];
      if (box[j].x0 > box[i].x1) break;
      if (box[j].y0 > box[i].y1 || box[i].y0 > box[j].y1) continue;
      const size_t lo = std::min(i, j), hi = std::max(i, j);
      if (hi == lo + 1 || (lo == 0 && hi == n - 1)) continue;  // consecutive: handled above
      if (exact::segments_intersect(p[i], p[(i + 1) % n], p[j], p[(j + 1) % n]))
        return fail("edges " + std::to_string(i) + " and " + std::to_string(j) + " intersect");
    }
  }
  return true;
}

// ---------------------------------------------------------------------------------------------------
// The checker.

enum class CheckVerdict { simple, self_overlapping, weakly_self_overlapping, not_self_overlapping };

inline const char* verdict_name(CheckVerdict v) {
  switch (v) {
    case CheckVerdict::simple: return "simple";
    case CheckVerdict::self_overlapping: return "self_overlapping";
    case CheckVerdict::weakly_self_overlapping: return "weakly_self_overlapping";
    case CheckVerdict::not_self_overlapping: return "not_self_overlapping";
  }
  return "?";
}

struct CheckReport {
  std::vector<std::string> errors;
  bool ok() const { return errors.empty(); }
  std::string str(size_t max_lines = 8) const {
    std::ostringstream os;
    for (size_t i = 0; i < errors.size() && i < max_lines; ++i) os << "  - " << errors[i] << "\n";
    if (errors.size() > max_lines) os << "  ... and " << errors.size() - max_lines << " more\n";
    return os.str();
  }
  void add(const std::string& e) { errors.push_back(e); }
};

// Checks that `tris` is a triangulation of p with no interior vertices, strictly positive triangles, the
// disk structure (every vertex's triangles form one fan from edge (i, i+1) to edge (i-1, i)), and the
// rotation indices R (triangulation angle = alpha_i + 2 pi R_i, within 1e-6 rad). When R is empty the
// angle check is skipped and *measured_R (if given) receives the rotation indices the angles imply.
inline CheckReport check_triangulation(const Poly& p, const std::vector<Tri>& tris, const std::vector<int>& R,
                                       std::vector<int>* measured_R = nullptr) {
  CheckReport rep;
  const int n = (int)p.size();
  auto S = [](long long v) { return std::to_string(v); };
  if (n < 3) {
    rep.add("polygon has fewer than 3 vertices");
    return rep;
  }
  if ((int)tris.size() != n - 2) rep.add("expected n-2 = " + S(n - 2) + " triangles, got " + S(tris.size()));
  if (!R.empty() && (int)R.size() != n) rep.add("rotation_indices has " + S(R.size()) + " entries, n = " + S(n));
  bool indices_ok = true;
  for (size_t t = 0; t < tris.size(); ++t) {
    const Tri& tr = tris[t];
    for (int k = 0; k < 3; ++k)
      if (tr[k] < 0 || tr[k] >= n) {
        rep.add("triangle " + S(t) + " has out-of-range index " + S(tr[k]));
        indices_ok = false;
      }
    if (tr[0] == tr[1] || tr[1] == tr[2] || tr[0] == tr[2]) {
      rep.add("triangle " + S(t) + " repeats a vertex");
      indices_ok = false;
    }
  }
  if (!indices_ok) return rep;

  // Orientation, exact.
  for (size_t t = 0; t < tris.size(); ++t) {
    const Tri& tr = tris[t];
    const int o = exact::orient(p[tr[0]], p[tr[1]], p[tr[2]]);
    if (o <= 0)
      rep.add("triangle " + S(t) + " (" + S(tr[0]) + "," + S(tr[1]) + "," + S(tr[2]) + ") is " +
              (o == 0 ? "degenerate" : "negative") + " by the exact predicate");
  }

  // Edge incidences. Undirected: polygon edges exactly once, other edges exactly twice. Directed: the
  // polygon edge i -> i+1 keeps the interior on its left, interior edges appear once in each direction.
  std::map<std::pair<int, int>, int> undirected;
  std::map<std::pair<int, int>, int> directed;  // directed edge -> triangle
  for (size_t t = 0; t < tris.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int a = tris[t][k], b = tris[t][(k + 1) % 3];
      ++undirected[{std::min(a, b), std::max(a, b)}];
      if (!directed.emplace(std::make_pair(a, b), (int)t).second)
        rep.add("directed edge " + S(a) + "->" + S(b) + " is used by two triangles");
    }
  }
  auto is_poly_edge = [n](int a, int b) { return (a + 1) % n == b || (b + 1) % n == a; };
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    auto it = undirected.find({std::min(i, j), std::max(i, j)});
    const int count = it == undirected.end() ? 0 : it->second;
    if (count != 1) rep.add("polygon edge (" + S(i) + "," + S(j) + ") is in " + S(count) + " triangles, not 1");
    if (count >= 1 && !directed.count({i, j}))
      rep.add("polygon edge " + S(i) + "->" + S(j) + " is used reversed (triangle on its right)");
  }
  for (const auto& [e, count] : undirected) {
    if (is_poly_edge(e.first, e.second)) continue;
    if (count != 2)
      rep.add("interior edge (" + S(e.first) + "," + S(e.second) + ") is in " + S(count) + " triangles, not 2");
    else if (!directed.count({e.first, e.second}) || !directed.count({e.second, e.first}))
      rep.add("interior edge (" + S(e.first) + "," + S(e.second) + ") is used twice in the same direction");
  }

  // Disk structure: the triangles at vertex i form one fan from (i, i+1) to (i-1, i).
  std::vector<int> incident(n, 0);
  for (const Tri& tr : tris)
    for (int k = 0; k < 3; ++k) ++incident[tr[k]];
  if (rep.ok()) {
    for (int i = 0; i < n; ++i) {
      const int next = (i + 1) % n, prev = (i + n - 1) % n;
      auto it = directed.find({i, next});
      int steps = 0;
      bool closed = false;
      while (it != directed.end() && steps <= incident[i]) {
        ++steps;
        const Tri& tr = tris[it->second];
        int k = 0;
        while (tr[k] != i) ++k;
        const int b = tr[(k + 2) % 3];  // the triangle is (i, a, b), counterclockwise
        if (b == prev) {
          closed = true;
          break;
        }
        it = directed.find({i, b});
      }
      if (!closed || steps != incident[i])
        rep.add("triangles at vertex " + S(i) + " do not form a single fan from (" + S(i) + "," + S(next) +
                ") to (" + S(prev) + "," + S(i) + ")");
    }
  }

  // Angles and rotation indices.
  std::vector<long double> theta(n, 0);
  for (const Tri& tr : tris)
    for (int k = 0; k < 3; ++k) theta[tr[k]] += corner_angle(p[tr[k]], p[tr[(k + 1) % 3]], p[tr[(k + 2) % 3]]);
  const std::vector<long double> alpha = interior_angles(p);
  std::vector<int> meas(n, 0);
  for (int i = 0; i < n; ++i) {
    meas[i] = (int)std::llround((theta[i] - alpha[i]) / kTwoPiL);
    if (!R.empty() && (int)R.size() == n) {
      const long double expect = alpha[i] + kTwoPiL * R[i];
      if (std::fabs(theta[i] - expect) > 1e-6L) {
        std::ostringstream os;
        os.precision(12);
        os << "vertex " << i << ": triangulation angle " << (double)theta[i] << " != alpha + 2 pi R = "
           << (double)alpha[i] << " + 2 pi * " << R[i] << " (angles imply R = " << meas[i] << ")";
        rep.add(os.str());
      }
    }
    if (R.empty() && std::fabs(theta[i] - alpha[i] - kTwoPiL * meas[i]) > 1e-6L)
      rep.add("vertex " + S(i) + ": triangulation angle is not alpha + 2 pi k for an integer k");
  }
  if (measured_R) *measured_R = meas;
  return rep;
}

// Checks a whole classify answer against the definitions.
inline CheckReport check_classification(const Poly& p, CheckVerdict verdict, int reported_turning,
                                        const std::vector<Tri>& tris, const std::vector<int>& R,
                                        const std::vector<int>& singular) {
  CheckReport rep;
  auto S = [](long long v) { return std::to_string(v); };
  long double raw = 0;
  const int T = turning_number(p, &raw);
  if (std::fabs(raw - T) > 1e-6L) rep.add("turning number is not an integer here (" + std::to_string((double)raw) + ")");
  if (reported_turning != T) rep.add("turning_number " + S(reported_turning) + " != independent " + S(T));
  if (verdict == CheckVerdict::not_self_overlapping) {
    if (!tris.empty()) rep.add("not_self_overlapping with a non-empty triangulation (" + S(tris.size()) + ")");
    return rep;
  }
  const CheckReport tri = check_triangulation(p, tris, R);
  rep.errors.insert(rep.errors.end(), tri.errors.begin(), tri.errors.end());
  if ((int)R.size() != (int)p.size()) return rep;
  std::vector<int> expect_singular;
  long long sum = 0;
  bool negative = false;
  for (int i = 0; i < (int)R.size(); ++i) {
    if (R[i] > 0) expect_singular.push_back(i);
    if (R[i] < 0) negative = true;
    sum += R[i];
  }
  if (negative) rep.add("a rotation index is negative");
  if (singular != expect_singular) rep.add("singular_vertices != {i : R_i > 0}");
  if (sum != T - 1) rep.add("sum R_i = " + S(sum) + " != turning number - 1 = " + S(T - 1));
  switch (verdict) {
    case CheckVerdict::simple:
      if (sum != 0) rep.add("verdict simple with a singular vertex");
      if (!is_simple(p)) rep.add("verdict simple for a polygon that is not simple");
      break;
    case CheckVerdict::self_overlapping:
      if (sum != 0) rep.add("verdict self_overlapping with a singular vertex");
      if (is_simple(p)) rep.add("verdict self_overlapping for a simple polygon (should be simple)");
      break;
    case CheckVerdict::weakly_self_overlapping:
      if (sum == 0) rep.add("verdict weakly_self_overlapping but every R_i is 0 (that is self_overlapping)");
      break;
    case CheckVerdict::not_self_overlapping: break;
  }
  return rep;
}

// ---------------------------------------------------------------------------------------------------
// Exhaustive oracle for small polygons. By Proposition 1 a polygon is weakly self-overlapping iff it has a
// triangulation by strictly positive triangles with no interior vertex, and such a triangulation is
// combinatorially a triangulation of the n-gon (every diagonal set of the convex n-gon). This enumerates
// all of them whose triangles are all positive (exact predicate; the product explodes as Catalan(n-2),
// so n <= 12) and collects every rotation-index vector they realize, with one certificate each.
struct OracleResult {
  bool complete = false;                           // false: too big, nothing enumerated
  long long positive_triangulations = 0;
  std::map<std::vector<int>, std::vector<Tri>> by_R;  // realized R vectors -> a certificate
};

inline OracleResult exhaustive_triangulations(const Poly& p, int max_n = 12, long long max_count = 200000) {
  OracleResult out;
  const int n = (int)p.size();
  if (n < 3 || n > max_n) return out;
  // sub[i][j]: every positive triangulation of the chain i..j closed by the chord (j, i), i < j.
  std::vector<std::vector<std::vector<std::vector<Tri>>>> sub(n, std::vector<std::vector<std::vector<Tri>>>(n));
  long long work = 0;
  for (int d = 1; d < n; ++d)
    for (int i = 0; i + d < n; ++i) {
      const int j = i + d;
      auto& here = sub[i][j];
      if (d == 1) {
        here.push_back({});
        continue;
      }
      for (int k = i + 1; k < j; ++k) {
        if (exact::orient(p[i], p[k], p[j]) <= 0) continue;
        for (const auto& a : sub[i][k])
          for (const auto& b : sub[k][j]) {
            if (++work > max_count * 20) return out;
            std::vector<Tri> t = a;
            t.insert(t.end(), b.begin(), b.end());
            t.push_back({i, k, j});
            here.push_back(std::move(t));
          }
      }
    }
  const std::vector<long double> alpha = interior_angles(p);
  for (const auto& t : sub[0][n - 1]) {
    if (++out.positive_triangulations > max_count) return OracleResult{};
    std::vector<long double> theta(n, 0);
    for (const Tri& tr : t)
      for (int k = 0; k < 3; ++k) theta[tr[k]] += corner_angle(p[tr[k]], p[tr[(k + 1) % 3]], p[tr[(k + 2) % 3]]);
    std::vector<int> R(n);
    for (int v = 0; v < n; ++v) R[v] = (int)std::llround((theta[v] - alpha[v]) / kTwoPiL);
    out.by_R.emplace(R, t);
  }
  out.complete = true;
  return out;
}

}  // namespace lipmap::testgen
