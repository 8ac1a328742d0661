// Classify with prescribed rotation indices (paper 3.2, App. B): "the triangulation matches them exactly,
// or the verdict is not_self_overlapping (for that prescription)" (engine/classify.h).
//
// Every feasible prescription below is backed by an explicit certificate triangulation that the
// independent checker (tests/support/triangulation_checker.h) validates with exact predicates; every
// infeasible one by a stated argument:
//   sum rule:      any triangulation has sum R_i = T - 1 (n - 2 triangles carry (n - 2) pi of angle);
//   winding rule:  if R_v >= 1 the triangles at v cover a whole neighbourhood of v (their angles at v add up
//                  to more than 2 pi), and positive triangles cover each point q off P exactly
//                  winding(P, q) times, so no point near v may have winding number 0.
//
// Suite: ClassifyPrescribed*.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "engine/boundary_polygon.h"
#include "engine/classify.h"
#include "engine/error.h"
#include "tests/support/polygon_generators.h"
#include "tests/support/triangulation_checker.h"

namespace lipmap {
namespace {

using namespace lipmap::testgen;

BoundaryPolygon to_boundary(const Poly& p, const std::optional<std::vector<int>>& R) {
  BoundaryPolygon b;
  for (const Pt& q : p) b.vertices.push_back({q.x, q.y});
  b.rotation_indices = R;
  return b;
}

CheckVerdict to_check(Verdict v) {
  switch (v) {
    case Verdict::simple: return CheckVerdict::simple;
    case Verdict::self_overlapping: return CheckVerdict::self_overlapping;
    case Verdict::weakly_self_overlapping: return CheckVerdict::weakly_self_overlapping;
    case Verdict::not_self_overlapping: return CheckVerdict::not_self_overlapping;
  }
  return CheckVerdict::not_self_overlapping;
}

std::vector<Tri> to_tris(const std::vector<Triangle>& t) {
  std::vector<Tri> out;
  for (const Triangle& x : t) out.push_back({x[0], x[1], x[2]});
  return out;
}

std::string polygon_json(const Poly& p, const std::vector<int>& R) {
  std::ostringstream os;
  char buf[80];
  os << "{\"polygon\": [";
  for (size_t i = 0; i < p.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s[%.17g, %.17g]", i ? ", " : "", p[i].x, p[i].y);
    os << buf;
  }
  os << "], \"rotation_indices\": [";
  for (size_t i = 0; i < R.size(); ++i) os << (i ? ", " : "") << R[i];
  os << "]}";
  return os.str();
}

std::string nonzero(const std::vector<int>& R) {
  std::ostringstream os;
  os << "{";
  bool first = true;
  for (size_t i = 0; i < R.size(); ++i)
    if (R[i]) {
      os << (first ? "" : ", ") << "R" << i << "=" << R[i];
      first = false;
    }
  os << "}";
  return os.str();
}

int sum_of(const std::vector<int>& R) {
  int s = 0;
  for (int r : R) s += r;
  return s;
}

// Classify p with R prescribed. feasible: the answer must be a valid triangulation with exactly R (verdict
// weakly_self_overlapping when some R_i > 0, else simple / self_overlapping by exact simplicity);
// otherwise the verdict must be not_self_overlapping with no triangulation. Returns "" or a description.
std::string check_prescribed(const std::string& name, const Poly& p, const std::vector<int>& R, bool feasible) {
  std::ostringstream os;
  Classification res;
  try {
    res = classify(to_boundary(p, R));
  } catch (const std::exception& e) {
    os << name << " with R " << nonzero(R) << ": classify threw: " << e.what() << "\n";
  }
  if (os.str().empty()) {
    const CheckVerdict got = to_check(res.verdict);
    CheckVerdict expected = CheckVerdict::not_self_overlapping;
    if (feasible)
      expected = sum_of(R) > 0 ? CheckVerdict::weakly_self_overlapping
                               : (is_simple(p) ? CheckVerdict::simple : CheckVerdict::self_overlapping);
    if (got != expected)
      os << name << " with R " << nonzero(R) << ": expected " << verdict_name(expected) << ", got "
         << verdict_name(got) << (res.reason.empty() ? "" : " (reason: " + res.reason + ")") << "\n";
    const CheckReport rep = check_classification(p, got, res.turning_number, to_tris(res.triangulation),
                                                 res.rotation_indices, res.singular_vertices);
    if (!rep.ok()) os << name << ": verdict " << verdict_name(got) << " but the answer is invalid:\n" << rep.str();
    if (got != CheckVerdict::not_self_overlapping && res.rotation_indices != R)
      os << name << ": prescribed R " << nonzero(R) << ", triangulation has R " << nonzero(res.rotation_indices) << "\n";
    if (res.stats.free_rotation_search) os << name << ": stats.free_rotation_search is true although R was prescribed\n";
  }
  if (!os.str().empty()) os << "  reproduce: " << polygon_json(p, R) << "\n";
  return os.str();
}

struct Collector {
  std::vector<std::pair<size_t, std::string>> failures;
  size_t total = 0;
  void add(size_t n, const std::string& s) {
    ++total;
    if (!s.empty()) failures.push_back({n, s});
  }
  void expect_none(const std::string& what) {
    std::sort(failures.begin(), failures.end());
    std::string smallest;
    for (size_t i = 0; i < failures.size() && i < 3; ++i) smallest += failures[i].second;
    EXPECT_EQ(failures.size(), 0u) << what << ": " << failures.size() << " of " << total
                                   << " prescriptions failed; the smallest:\n" << smallest;
  }
};

std::vector<int> unit(size_t n, std::initializer_list<std::pair<int, int>> entries) {
  std::vector<int> R(n, 0);
  for (auto [i, r] : entries) R[size_t(i)] = r;
  return R;
}

// A point just outside the vertex v of largest distance from the origin. Every point of P is within that
// distance (a segment's points are no farther than its farther end), so the ray from the origin through v
// leaves P at v: beyond v the winding number is 0.
Pt just_outside(const Pt& v) { return {v.x * 1.001, v.y * 1.001}; }

// The double loop of the brief, with L loops: O1 = (-eps, 0), O2 = (eps, 0), then v_1..v_m on
// r = 1 + 0.3 cos(t/2), t from pi/2 + 0.1 to pi/2 + 2 pi L - 0.1.
//
// Turning number: the curve turns 2 pi L, and the four corners O1, O2, v_1, v_m are left turns of about
// pi/2 each, so T = L + 1. The fan from O1 sweeps from O2 (direction 0) through v_1 .. v_m, i.e.
// 2 pi L + pi/2 - 0.1 (about), while alpha_O1 is about pi/2 - 0.1: R_O1 = L. Likewise the fan from O2
// (closing with triangle (O1, O2, v_m)) has R_O2 = L. So with L = 1 (the curve goes once around the hubs)
// the two fans have R = 1 at one hub, as the brief intends; with L = 2 (the brief's t range of 4 pi) the
// turning number is 3 and the fans have R_hub = 2; then a mixed triangulation (O1, O2, v_s) with v_s on the
// first loop above the hubs, O2 fanning v_1..v_s and O1 fanning v_s..v_m, has R_O1 = R_O2 = 1. All
// certificates are validated below, none of those numbers is taken on trust.
TEST(ClassifyPrescribed, DoubleLoopOnceAroundEitherHub) {
  const DoubleLoop d = make_double_loop(1, 24, 0.05);
  const Poly& p = d.poly;
  const size_t n = p.size();
  ASSERT_EQ(turning_number(p), 2);
  const std::vector<int> R_O1 = unit(n, {{0, 1}}), R_O2 = unit(n, {{1, 1}});
  {
    const CheckReport a = check_triangulation(p, d.fan_O1, R_O1), b = check_triangulation(p, d.fan_O2, R_O2);
    ASSERT_TRUE(a.ok()) << a.str();
    ASSERT_TRUE(b.ok()) << b.str();
  }
  Collector col;
  col.add(n, check_prescribed("double_loop_L1", p, R_O1, true));
  col.add(n, check_prescribed("double_loop_L1", p, R_O2, true));
  // (i) all zeros: sum R = 0 != T - 1 = 1.
  col.add(n, check_prescribed("double_loop_L1", p, std::vector<int>(n, 0), false));
  // Both hubs: sum 2 != 1.
  col.add(n, check_prescribed("double_loop_L1", p, unit(n, {{0, 1}, {1, 1}}), false));
  // (ii) R = 1 at the outermost vertex (sum rule satisfied): the winding number just outside it is 0, so
  // no fan can wrap around it.
  ASSERT_GE(d.outermost, 2);
  bool on = true;
  ASSERT_EQ(winding_number(p, just_outside(p[size_t(d.outermost)]), &on), 0);
  ASSERT_FALSE(on);
  col.add(n, check_prescribed("double_loop_L1", p, unit(n, {{d.outermost, 1}}), false));
  col.expect_none("double loop, once around");
}

TEST(ClassifyPrescribed, DoubleLoopTwiceAroundAsInTheBrief) {
  const int m = 40;
  const DoubleLoop d = make_double_loop(2, m, 0.05);
  const Poly& p = d.poly;
  const size_t n = p.size();
  ASSERT_EQ(turning_number(p), 3);
  const std::vector<int> R_O1 = unit(n, {{0, 2}}), R_O2 = unit(n, {{1, 2}}), R_mixed = unit(n, {{0, 1}, {1, 1}});
  // The mixed certificate: split at the first-loop vertex closest to t = 2 pi + pi/4.
  const double ta = kPi / 2 + 0.1, tb = kPi / 2 + 4 * kPi - 0.1;
  int s = -1;
  double best = 1e9;
  for (int k = 0; k < m; ++k) {
    const double t = ta + (tb - ta) * k / (m - 1);
    if (std::fabs(t - (kTwoPi + kPi / 4)) < best) {
      best = std::fabs(t - (kTwoPi + kPi / 4));
      s = 2 + k;
    }
  }
  std::vector<Tri> mixed{{0, 1, s}};
  for (int k = 2; k < s; ++k) mixed.push_back({1, k, k + 1});
  for (int k = s; k + 1 < (int)n; ++k) mixed.push_back({0, k, k + 1});
  {
    const CheckReport a = check_triangulation(p, d.fan_O1, R_O1), b = check_triangulation(p, d.fan_O2, R_O2),
                      c = check_triangulation(p, mixed, R_mixed);
    ASSERT_TRUE(a.ok()) << a.str();
    ASSERT_TRUE(b.ok()) << b.str();
    ASSERT_TRUE(c.ok()) << c.str();
  }
  Collector col;
  col.add(n, check_prescribed("double_loop_L2", p, R_O1, true));
  col.add(n, check_prescribed("double_loop_L2", p, R_O2, true));
  col.add(n, check_prescribed("double_loop_L2", p, R_mixed, true));
  // Sum rule (T - 1 = 2): all zeros, and R_O1 = 1 alone, and R_O2 = 1 alone.
  col.add(n, check_prescribed("double_loop_L2", p, std::vector<int>(n, 0), false));
  col.add(n, check_prescribed("double_loop_L2", p, unit(n, {{0, 1}}), false));
  col.add(n, check_prescribed("double_loop_L2", p, unit(n, {{1, 1}}), false));
  // Winding rule at the outermost vertex (sum rule satisfied).
  bool on = true;
  ASSERT_EQ(winding_number(p, just_outside(p[size_t(d.outermost)]), &on), 0);
  ASSERT_FALSE(on);
  col.add(n, check_prescribed("double_loop_L2", p, unit(n, {{0, 1}, {d.outermost, 1}}), false));
  col.expect_none("double loop, twice around");
}

// Each tree of triangles (1c) is its own certificate: prescribing its R must succeed with exactly those R.
// Moving the sum off T - 1 (one more, or one less at a singular vertex) must fail by the sum rule.
TEST(ClassifyPrescribed, TreesReproduceTheirOwnRotationIndices) {
  Collector ok, bad;
  for (const GenCase& c : generate(Family::tree, default_count(Family::tree))) {
    ASSERT_EQ(sum_of(c.certificate_R), c.turning - 1) << c.name();
    ok.add(c.poly.size(), check_prescribed(c.name(), c.poly, c.certificate_R, true));
    std::vector<int> more = c.certificate_R;
    more[c.seed % more.size()] += 1;
    if (more[c.seed % more.size()] <= kMaxRotationIndex)
      bad.add(c.poly.size(), check_prescribed(c.name(), c.poly, more, false));
    if (c.turning >= 2) {
      std::vector<int> less = c.certificate_R;
      *std::max_element(less.begin(), less.end()) -= 1;
      bad.add(c.poly.size(), check_prescribed(c.name(), c.poly, less, false));
      bad.add(c.poly.size(), check_prescribed(c.name(), c.poly, std::vector<int>(c.poly.size(), 0), false));
    }
  }
  ok.expect_none("trees with their own R");
  bad.expect_none("trees with R violating the sum rule");
}

// The same with lattice trees (exact collinearities, distinct vertices at one point) and trees wrapped
// 3 to kMaxRotationIndex turns around one hub.
TEST(ClassifyPrescribed, LatticeAndDeepHubTreesReproduceTheirOwnRotationIndices) {
  Collector ok, bad;
  for (Family f : {Family::lattice_tree, Family::deep_hub_tree})
    for (const GenCase& c : generate(f, default_count(f))) {
      ASSERT_EQ(sum_of(c.certificate_R), c.turning - 1) << c.name();
      ok.add(c.poly.size(), check_prescribed(c.name(), c.poly, c.certificate_R, true));
      std::vector<int> more = c.certificate_R;
      more[c.seed % more.size()] += 1;
      if (more[c.seed % more.size()] <= kMaxRotationIndex)
        bad.add(c.poly.size(), check_prescribed(c.name(), c.poly, more, false));
    }
  ok.expect_none("lattice / deep-hub trees with their own R");
  bad.expect_none("lattice / deep-hub trees with R violating the sum rule");
}

// Hubs closer and closer together (down to 1e-12 apart, nearly degenerate triangle (O1, O2, v_1)): the
// fans stay certificates (checked exactly), the prescriptions stay feasible / infeasible.
TEST(ClassifyPrescribed, DoubleLoopWithNearlyCoincidentHubs) {
  Collector col;
  for (int loops = 1; loops <= 2; ++loops)
    for (double eps : {1e-3, 1e-6, 1e-9, 1e-12}) {
      const DoubleLoop d = make_double_loop(loops, 16 * loops, eps);
      const size_t n = d.poly.size();
      const std::string name = "double_loop_L" + std::to_string(loops) + "_eps" + std::to_string(eps);
      ASSERT_EQ(turning_number(d.poly), loops + 1) << name;
      const std::vector<int> R_O1 = unit(n, {{0, loops}}), R_O2 = unit(n, {{1, loops}});
      ASSERT_TRUE(check_triangulation(d.poly, d.fan_O1, R_O1).ok()) << name;
      ASSERT_TRUE(check_triangulation(d.poly, d.fan_O2, R_O2).ok()) << name;
      col.add(n, check_prescribed(name, d.poly, R_O1, true));
      col.add(n, check_prescribed(name, d.poly, R_O2, true));
      col.add(n, check_prescribed(name, d.poly, std::vector<int>(n, 0), false));
      col.add(n, check_prescribed(name, d.poly, unit(n, {{d.outermost, loops}}), false));
    }
  col.expect_none("double loops with nearly coincident hubs");
}

TEST(ClassifyPrescribed, DoubleLoopFamilyReproducesItsFanIndices) {
  Collector col;
  for (const GenCase& c : generate(Family::double_loop, default_count(Family::double_loop), 3)) {
    col.add(c.poly.size(), check_prescribed(c.name(), c.poly, c.certificate_R, true));
    // The other hub's fan, when it is a certificate too.
    const int hub = c.certificate_R[0] > 0 ? 0 : 1;
    std::vector<int> other(c.poly.size(), 0);
    other[1 - hub] = c.certificate_R[hub];
    std::vector<Tri> fan;
    const int n = (int)c.poly.size();
    if (hub == 0) {  // build the fan from O2
      for (int k = 2; k + 1 < n; ++k) fan.push_back({1, k, k + 1});
      fan.push_back({0, 1, n - 1});
    } else {
      fan.push_back({0, 1, 2});
      for (int k = 2; k + 1 < n; ++k) fan.push_back({0, k, k + 1});
    }
    if (check_triangulation(c.poly, fan, other).ok())
      col.add(c.poly.size(), check_prescribed(c.name() + " other hub", c.poly, other, true));
  }
  col.expect_none("double loop family");
}

// Self-overlapping by construction (1a, all R_i = 0 by Shor-van Wyk / Proposition 1): prescribing all
// zeros must give the R = 0 triangulation.
TEST(ClassifyPrescribed, GridImagesWithZeroIndices) {
  Collector col;
  for (Family f : {Family::exp_strip, Family::power_map, Family::spiral_overlap, Family::bent_strip})
    for (const GenCase& c : generate(f, 15, 11))
      col.add(c.poly.size(), check_prescribed(c.name(), c.poly, std::vector<int>(c.poly.size(), 0), true));
  for (const GenCase& c : generate(Family::star, 20, 11))
    col.add(c.poly.size(), check_prescribed(c.name(), c.poly, std::vector<int>(c.poly.size(), 0), true));
  col.expect_none("self-overlapping polygons with R = 0");
}

// Not weakly self-overlapping at all (1d): no prescription can succeed. For T >= 1 a prescription that
// satisfies the sum rule is tried (all of T - 1 on one vertex, or spread), for T <= 0 all zeros.
TEST(ClassifyPrescribed, NegativeFamiliesRejectEveryPrescription) {
  Collector col;
  for (Family f : {Family::curls, Family::figure_eight, Family::grid_reversed, Family::flower}) {
    for (const GenCase& c : generate(f, 25, 5)) {
      std::vector<int> R(c.poly.size(), 0);
      if (c.turning >= 2) R[c.seed % R.size()] = c.turning - 1;
      col.add(c.poly.size(), check_prescribed(c.name(), c.poly, R, false));
      if (c.turning >= 3) {
        std::vector<int> spread(c.poly.size(), 0);
        for (int k = 0; k < c.turning - 1; ++k) spread[(c.seed + 7 * k) % spread.size()] += 1;
        col.add(c.poly.size(), check_prescribed(c.name(), c.poly, spread, false));
      }
    }
  }
  col.expect_none("negative families with prescriptions");
}

// Small polygons against the exhaustive oracle: EVERY rotation-index vector with sum R = T - 1 (all of
// them, enumerated) must succeed iff some positive triangulation realizes it. This exercises the
// "set of feasible end-rotation pairs" of the table (docs/hard-points.md): a table keeping one choice per
// entry misses some of the realizable vectors.
void all_vectors_with_sum(int n, int sum, std::vector<int>& cur, int pos, std::vector<std::vector<int>>& out) {
  if (pos == n - 1) {
    cur[size_t(pos)] = sum;
    out.push_back(cur);
    return;
  }
  for (int v = 0; v <= sum; ++v) {
    cur[size_t(pos)] = v;
    all_vectors_with_sum(n, sum - v, cur, pos + 1, out);
  }
}

TEST(ClassifyPrescribed, SmallPolygonsEveryRotationVectorAgainstExhaustiveOracle) {
  Collector feasible, infeasible;
  size_t vectors = 0;
  std::vector<GenCase> cases = generate(Family::small, default_count(Family::small), 1);
  for (const GenCase& c : generate(Family::small_lattice, default_count(Family::small_lattice), 1)) cases.push_back(c);
  for (const GenCase& c : cases) {
    const int n = (int)c.poly.size();
    if (c.turning < 1 || c.turning > 4) {
      infeasible.add(c.poly.size(), check_prescribed(c.name(), c.poly, std::vector<int>(size_t(n), 0), false));
      continue;
    }
    std::vector<std::vector<int>> all;
    std::vector<int> cur(size_t(n), 0);
    all_vectors_with_sum(n, c.turning - 1, cur, 0, all);
    for (const std::vector<int>& R : all) {
      ++vectors;
      const bool ok = std::find(c.feasible_R.begin(), c.feasible_R.end(), R) != c.feasible_R.end();
      (ok ? feasible : infeasible).add(c.poly.size(), check_prescribed(c.name(), c.poly, R, ok));
    }
    // Off the sum rule: one more at vertex 0.
    std::vector<int> more(size_t(n), 0);
    more[0] = c.turning;
    infeasible.add(c.poly.size(), check_prescribed(c.name(), c.poly, more, false));
  }
  EXPECT_GE(feasible.total, 300u);
  EXPECT_GE(infeasible.total, 1000u);
  feasible.expect_none("small polygons, realizable R (oracle)");
  infeasible.expect_none("small polygons, unrealizable R (oracle)");
}

TEST(ClassifyPrescribed, RotationIndexInputErrors) {
  const Poly p{{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  auto code_of = [&](const std::vector<int>& R) -> std::string {
    try {
      classify(to_boundary(p, R));
    } catch (const InputError& e) {
      return e.code();
    } catch (const std::exception& e) {
      return std::string("other exception: ") + e.what();
    }
    return "no exception";
  };
  EXPECT_EQ(code_of({0, -1, 0, 0}), "rotation_index_out_of_range");
  EXPECT_EQ(code_of({0, 0, 0, -1000}), "rotation_index_out_of_range");
  EXPECT_EQ(code_of({0, 0, kMaxRotationIndex + 1, 0}), "rotation_index_out_of_range");
  EXPECT_EQ(code_of({0, 0, 0}), "rotation_indices_length");
  EXPECT_EQ(code_of({0, 0, 0, 0, 0}), "rotation_indices_length");
  EXPECT_EQ(code_of({}), "rotation_indices_length");
  // The largest accepted value is not an input error (the square cannot realize it: sum rule).
  EXPECT_EQ(code_of({kMaxRotationIndex, 0, 0, 0}), "no exception");
  const Classification res = classify(to_boundary(p, std::vector<int>{kMaxRotationIndex, 0, 0, 0}));
  EXPECT_EQ(res.verdict, Verdict::not_self_overlapping);
  EXPECT_TRUE(res.triangulation.empty());
  // All zeros on the square: simple, the prescription reproduced.
  EXPECT_EQ(check_prescribed("square", p, {0, 0, 0, 0}, true), "");
}

}  // namespace
}  // namespace lipmap
