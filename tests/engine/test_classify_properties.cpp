// Property tests of the classify stage (engine/classify.h) against polygons whose answer is known
// independently of the engine (tests/support/polygon_generators.h), every answer checked by the independent
// checker (tests/support/triangulation_checker.h). Suites:
//   ClassifyGenerators*  the generators and the checker themselves (no engine call)
//   ClassifyProperty*    classify on every generated family, metamorphic invariances, input errors
//
// Failures name the case (family#seed) and print the smallest failing polygons as JSON
// ({"polygon": [[x, y], ...]}, the body of POST /v1/polygons/classify). With LIPMAP_CLASSIFY_DUMP_DIR set,
// every failing polygon is also written there as <family>_<seed>.json.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "engine/boundary_polygon.h"
#include "engine/cancel.h"
#include "engine/classify.h"
#include "engine/error.h"
#include "tests/support/polygon_generators.h"
#include "tests/support/triangulation_checker.h"

namespace lipmap {
namespace {

using namespace lipmap::testgen;

// ------------------------------------------------------------------------------------------------
// Adapters between the engine's types and the test support's own types.

BoundaryPolygon to_boundary(const Poly& p, const std::optional<std::vector<int>>& R = std::nullopt) {
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

CheckVerdict expected_verdict(const GenCase& c) {
  switch (c.expect) {
    case Expect::simple: return CheckVerdict::simple;
    case Expect::self_overlapping: return CheckVerdict::self_overlapping;
    case Expect::weakly_self_overlapping: return CheckVerdict::weakly_self_overlapping;
    case Expect::not_self_overlapping: return CheckVerdict::not_self_overlapping;
    case Expect::simple_or_self_overlapping:
      return is_simple(c.poly) ? CheckVerdict::simple : CheckVerdict::self_overlapping;
  }
  return CheckVerdict::not_self_overlapping;
}

std::vector<Tri> to_tris(const std::vector<Triangle>& t) {
  std::vector<Tri> out;
  for (const Triangle& x : t) out.push_back({x[0], x[1], x[2]});
  return out;
}

std::string polygon_json(const Poly& p, const std::vector<int>* R = nullptr) {
  std::ostringstream os;
  char buf[80];
  os << "{\"polygon\": [";
  for (size_t i = 0; i < p.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s[%.17g, %.17g]", i ? ", " : "", p[i].x, p[i].y);
    os << buf;
  }
  os << "]";
  if (R) {
    os << ", \"rotation_indices\": [";
    for (size_t i = 0; i < R->size(); ++i) os << (i ? ", " : "") << (*R)[i];
    os << "]";
  }
  os << "}";
  return os.str();
}

void dump_if_asked(const GenCase& c, const std::vector<int>* R) {
  const char* dir = std::getenv("LIPMAP_CLASSIFY_DUMP_DIR");
  if (!dir || !*dir) return;
  std::ofstream(std::string(dir) + "/" + c.family + "_" + std::to_string(c.seed) + ".json") << polygon_json(c.poly, R) << "\n";
}

struct Failure {
  size_t n = 0;
  std::string text;
};

// Runs classify on a case and checks everything: verdict against the independently known answer, the
// answer against the definitions (checker), the prescription when one was given, basic stats.
std::optional<Failure> run_case(const GenCase& c, const std::optional<std::vector<int>>& R = std::nullopt,
                                std::optional<CheckVerdict> expect_override = std::nullopt) {
  const CheckVerdict expected = expect_override ? *expect_override : expected_verdict(c);
  std::ostringstream os;
  Classification res;
  try {
    res = classify(to_boundary(c.poly, R));
  } catch (const std::exception& e) {
    os << c.name() << ": expected " << verdict_name(expected) << ", classify threw: " << e.what() << "\n";
  }
  if (os.str().empty()) {
    const CheckVerdict got = to_check(res.verdict);
    if (got != expected)
      os << c.name() << ": expected " << verdict_name(expected) << ", got " << verdict_name(got)
         << (res.reason.empty() ? "" : " (reason: " + res.reason + ")") << "\n";
    const CheckReport rep = check_classification(c.poly, got, res.turning_number, to_tris(res.triangulation),
                                                 res.rotation_indices, res.singular_vertices);
    if (!rep.ok()) os << c.name() << ": verdict " << verdict_name(got) << " but the answer is invalid:\n" << rep.str();
    if (R && got != CheckVerdict::not_self_overlapping && res.rotation_indices != *R)
      os << c.name() << ": the triangulation does not match the prescribed rotation indices\n";
    if (res.stats.input_vertices != (int)c.poly.size())
      os << c.name() << ": stats.input_vertices = " << res.stats.input_vertices << ", n = " << c.poly.size() << "\n";
    if (res.stats.reduced_vertices > (int)c.poly.size())
      os << c.name() << ": stats.reduced_vertices = " << res.stats.reduced_vertices << " > n\n";
  }
  if (os.str().empty()) return std::nullopt;
  dump_if_asked(c, R ? &*R : nullptr);
  os << "  reproduce: " << polygon_json(c.poly, R ? &*R : nullptr) << "\n";
  return Failure{c.poly.size(), os.str()};
}

// Reports the number of failures and the smallest few failing polygons in full.
void report(const std::string& what, size_t total, std::vector<Failure> failures) {
  std::sort(failures.begin(), failures.end(), [](const Failure& a, const Failure& b) { return a.n < b.n; });
  std::ostringstream os;
  for (size_t i = 0; i < failures.size() && i < 3; ++i) os << failures[i].text;
  EXPECT_EQ(failures.size(), 0u) << what << ": " << failures.size() << " of " << total
                                 << " cases failed; the smallest:\n" << os.str();
}

void run_family(Family f, bool also_reversed = false) {
  const std::vector<GenCase> cases = generate(f, default_count(f));
  ASSERT_GE(cases.size(), size_t(default_count(f) * 9 / 10)) << family_name(f);
  std::vector<Failure> failures;
  size_t total = 0;
  for (const GenCase& c : cases) {
    ++total;
    if (auto fail = run_case(c)) failures.push_back(*fail);
    if (also_reversed) {
      ++total;
      if (auto fail = run_case(reversed_case(c))) failures.push_back(*fail);
    }
  }
  report(family_name(f), total, failures);
}

// ------------------------------------------------------------------------------------------------
// ClassifyGenerators: the support code itself.

Poly square() { return {{0, 0}, {1, 0}, {1, 1}, {0, 1}}; }

TEST(ClassifyGenerators, TurningWindingSimplicityOnHandCases) {
  EXPECT_EQ(turning_number(square()), 1);
  EXPECT_EQ(turning_number(reversed(square())), -1);
  const Poly bowtie{{0, 0}, {1, 1}, {1, 0}, {0, 1}};
  EXPECT_EQ(turning_number(bowtie), 0);
  EXPECT_FALSE(is_simple(bowtie));
  EXPECT_TRUE(is_simple(square()));
  EXPECT_TRUE(is_simple(reversed(square())));
  // A vertex touching a non-adjacent edge, a fold-back spike, a repeated vertex: not simple.
  EXPECT_FALSE(is_simple({{0, 0}, {2, 0}, {2, 2}, {1, 0}, {0, 2}}));
  EXPECT_FALSE(is_simple({{0, 0}, {2, 0}, {1, 0}, {1, 1}}));
  EXPECT_FALSE(is_simple({{0, 0}, {2, 0}, {1, 1}, {2, 2}, {0, 2}, {1, 1}}));
  // Collinear vertices are fine.
  EXPECT_TRUE(is_simple({{0, 0}, {1, 0}, {2, 0}, {2, 1}, {0, 1}}));
  // A circle traversed twice (2 n vertices on 2 turns): T = 2.
  Poly twice;
  for (int k = 0; k < 14; ++k) twice.push_back({std::cos(k * kTwoPi / 7.0 + 0.01 * k), std::sin(k * kTwoPi / 7.0 + 0.01 * k)});
  EXPECT_EQ(turning_number(twice), 2);
  bool on = true;
  EXPECT_EQ(winding_number(square(), {0.5, 0.5}, &on), 1);
  EXPECT_FALSE(on);
  EXPECT_EQ(winding_number(reversed(square()), {0.5, 0.5}), -1);
  EXPECT_EQ(winding_number(square(), {1.5, 0.5}), 0);
  winding_number(square(), {0.5, 0}, &on);  // on the boundary: only the flag is meaningful
  EXPECT_TRUE(on);
  on = false;
  winding_number(square(), {0, 0}, &on);
  EXPECT_TRUE(on);
  EXPECT_EQ(winding_number(twice, {0.01, 0.02}), 2);
}

TEST(ClassifyGenerators, CheckerAcceptsValidTriangulations) {
  // Square, both diagonals.
  EXPECT_TRUE(check_triangulation(square(), {{0, 1, 2}, {0, 2, 3}}, {0, 0, 0, 0}).ok());
  EXPECT_TRUE(check_triangulation(square(), {{1, 2, 3}, {3, 0, 1}}, {0, 0, 0, 0}).ok());
  EXPECT_TRUE(check_classification(square(), CheckVerdict::simple, 1, {{0, 1, 2}, {0, 2, 3}}, {0, 0, 0, 0}, {}).ok());
  EXPECT_TRUE(check_classification(reversed(square()), CheckVerdict::not_self_overlapping, -1, {}, {}, {}).ok());
  // Single hub double loop: O, then a curve around O twice; fan from O, R_O = 1, T = 2.
  Poly p{{0, 0}};
  for (int k = 0; k < 20; ++k) {
    const double t = kPi / 2 + 0.1 + (4 * kPi - 0.2) * k / 19;
    const double r = 1 + 0.3 * std::cos(t / 2);
    p.push_back({r * std::cos(t), r * std::sin(t)});
  }
  std::vector<Tri> fan;
  for (int k = 1; k + 1 < (int)p.size(); ++k) fan.push_back({0, k, k + 1});
  std::vector<int> R(p.size(), 0);
  R[0] = 1;
  EXPECT_EQ(turning_number(p), 2);
  const CheckReport rep = check_classification(p, CheckVerdict::weakly_self_overlapping, 2, fan, R, {0});
  EXPECT_TRUE(rep.ok()) << rep.str();
}

TEST(ClassifyGenerators, CheckerRejectsBrokenAnswers) {
  const Poly sq = square();
  const std::vector<Tri> good{{0, 1, 2}, {0, 2, 3}};
  const std::vector<int> zero(4, 0);
  EXPECT_FALSE(check_triangulation(sq, {{0, 2, 1}, {0, 2, 3}}, zero).ok());             // negative triangle
  EXPECT_FALSE(check_triangulation(sq, {{0, 1, 2}}, zero).ok());                        // missing triangle
  EXPECT_FALSE(check_triangulation(sq, {{0, 1, 2}, {0, 2, 3}, {0, 1, 3}}, zero).ok());  // extra triangle
  EXPECT_FALSE(check_triangulation(sq, {{0, 1, 2}, {0, 2, 4}}, zero).ok());             // index out of range
  EXPECT_FALSE(check_triangulation(sq, {{0, 1, 2}, {0, 1, 2}}, zero).ok());             // duplicate
  EXPECT_FALSE(check_triangulation(sq, good, {1, 0, 0, 0}).ok());                       // wrong R
  EXPECT_FALSE(check_triangulation(sq, good, {0, 0, 0}).ok());                          // R too short
  EXPECT_FALSE(check_classification(sq, CheckVerdict::simple, 2, good, zero, {}).ok()); // wrong turning
  EXPECT_FALSE(check_classification(sq, CheckVerdict::simple, 1, good, zero, {1}).ok());// wrong singular set
  EXPECT_FALSE(check_classification(sq, CheckVerdict::self_overlapping, 1, good, zero, {}).ok());  // simple!
  EXPECT_FALSE(check_classification(sq, CheckVerdict::weakly_self_overlapping, 1, good, zero, {}).ok());
  EXPECT_FALSE(check_classification(sq, CheckVerdict::not_self_overlapping, 1, good, zero, {}).ok());
  // A degenerate triangle on collinear vertices.
  const Poly col{{0, 0}, {1, 0}, {2, 0}, {1, 1}};
  EXPECT_FALSE(check_triangulation(col, {{0, 1, 2}, {0, 2, 3}}, {0, 0, 0, 0}).ok());
  EXPECT_TRUE(check_triangulation(col, {{0, 1, 3}, {1, 2, 3}}, {0, 0, 0, 0}).ok());
  // Hexagon: the fan from 0 is fine; a repeated triangle (edge (0,4) missing, (3,4) twice) is not.
  Poly hex;
  for (int k = 0; k < 6; ++k) hex.push_back({std::cos(k * kPi / 3), std::sin(k * kPi / 3)});
  EXPECT_TRUE(check_triangulation(hex, {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 5}}, std::vector<int>(6, 0)).ok());
  EXPECT_FALSE(check_triangulation(hex, {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 3, 4}}, std::vector<int>(6, 0)).ok());
  // Mutations of every tree certificate are caught.
  for (const GenCase& c : generate(Family::tree, 40)) {
    ASSERT_TRUE(check_triangulation(c.poly, c.certificate, c.certificate_R).ok()) << c.name();
    std::vector<Tri> t = c.certificate;
    std::swap(t[t.size() / 2][0], t[t.size() / 2][1]);
    EXPECT_FALSE(check_triangulation(c.poly, t, c.certificate_R).ok()) << c.name();
    std::vector<int> R = c.certificate_R;
    R[c.seed % R.size()] += 1;
    EXPECT_FALSE(check_triangulation(c.poly, c.certificate, R).ok()) << c.name();
    t = c.certificate;
    t.pop_back();
    EXPECT_FALSE(check_triangulation(c.poly, t, c.certificate_R).ok()) << c.name();
  }
}

TEST(ClassifyGenerators, FamiliesAreReproducibleAndLargeEnough) {
  size_t total = 0;
  for (Family f : all_families()) {
    const std::vector<GenCase> a = generate(f, default_count(f));
    EXPECT_GE(a.size(), size_t(default_count(f) * 9 / 10)) << family_name(f);
    total += a.size() * (is_simple_family(f) ? 2 : 1);
    const std::vector<GenCase> b = generate(f, 5);
    ASSERT_LE(b.size(), a.size());
    for (size_t i = 0; i < b.size(); ++i) {
      EXPECT_EQ(a[i].seed, b[i].seed) << family_name(f);
      ASSERT_EQ(a[i].poly.size(), b[i].poly.size()) << family_name(f);
      for (size_t k = 0; k < a[i].poly.size(); ++k) ASSERT_EQ(a[i].poly[k], b[i].poly[k]) << family_name(f);
    }
  }
  EXPECT_GE(total, 1000u);
}

TEST(ClassifyGenerators, KnownAnswersHoldForEveryFamily) {
  for (Family f : all_families()) {
    int nonsimple = 0, count = 0;
    for (const GenCase& c : generate(f, default_count(f))) {
      ++count;
      SCOPED_TRACE(c.name());
      if (f != Family::small_lattice) ASSERT_TRUE(well_conditioned(c.poly));  // lattice: slits on purpose
      ASSERT_EQ(turning_number(c.poly), c.turning);
      const bool simple = is_simple(c.poly);
      nonsimple += !simple;
      switch (c.expect) {
        case Expect::simple:
          EXPECT_TRUE(simple);
          EXPECT_EQ(c.turning, 1);
          EXPECT_EQ(turning_number(reversed(c.poly)), -1);
          break;
        case Expect::simple_or_self_overlapping:
          EXPECT_EQ(c.turning, 1);
          break;
        case Expect::weakly_self_overlapping:
          EXPECT_GE(c.turning, 2);
          break;
        case Expect::not_self_overlapping:
          // Either T <= 0 (sum R = T - 1 < 0 is impossible), or a point of negative winding number, or
          // (flowers) points of winding number 0 inside the fans of the pinch vertices.
          for (const Pt& q : c.zero_probes) {
            bool on = true;
            EXPECT_EQ(winding_number(c.poly, q, &on), 0);
            EXPECT_FALSE(on);
          }
          // (small) or the exhaustive oracle found no positive triangulation at all.
          if (f == Family::small || f == Family::small_lattice) {
            const OracleResult o = exhaustive_triangulations(c.poly);
            EXPECT_TRUE(o.complete && o.by_R.empty());
          } else if (c.turning >= 1 && c.zero_probes.empty()) {
            ASSERT_FALSE(c.negative_probes.empty());
            for (const Pt& q : c.negative_probes) {
              bool on = true;
              EXPECT_LT(winding_number(c.poly, q, &on), 0);
              EXPECT_FALSE(on);
            }
          }
          break;
        case Expect::self_overlapping: break;
      }
      if (!c.certificate.empty()) {
        const CheckReport rep = check_triangulation(c.poly, c.certificate, c.certificate_R);
        EXPECT_TRUE(rep.ok()) << rep.str();
        int sum = 0;
        for (int r : c.certificate_R) sum += r;
        EXPECT_EQ(sum, c.turning - 1);
      }
    }
    // The overlap families really overlap; the simple ones are simple.
    if (f == Family::exp_strip || f == Family::power_map || f == Family::spiral_overlap || f == Family::bent_strip ||
        f == Family::double_loop || f == Family::figure_eight || f == Family::curls || f == Family::flower)
      EXPECT_GE(nonsimple, count * 9 / 10) << family_name(f);
    if (is_simple_family(f) || f == Family::spiral_thin) EXPECT_EQ(nonsimple, 0) << family_name(f);
  }
}

TEST(ClassifyGenerators, TreesCoverSeveralTurningNumbersAndCurlsCoverZeroOneTwo) {
  std::map<int, int> tree_T, curl_T;
  for (const GenCase& c : generate(Family::tree, default_count(Family::tree))) ++tree_T[c.turning];
  for (const GenCase& c : generate(Family::curls, default_count(Family::curls))) ++curl_T[c.turning];
  EXPECT_GE(tree_T[1], 5);
  EXPECT_GE(tree_T[2], 20);
  EXPECT_GE(tree_T[3], 20);
  EXPECT_GE(curl_T[0], 5);
  EXPECT_GE(curl_T[1], 5);
  EXPECT_GE(curl_T[2], 5);
}

// The oracle agrees with the certificates it must find and the negatives it must not.
TEST(ClassifyGenerators, ExhaustiveOracleAgreesWithKnownCases) {
  {
    const OracleResult o = exhaustive_triangulations(square());
    ASSERT_TRUE(o.complete);
    EXPECT_EQ(o.positive_triangulations, 2);
    ASSERT_EQ(o.by_R.size(), 1u);
    EXPECT_EQ(o.by_R.begin()->first, std::vector<int>(4, 0));
  }
  EXPECT_TRUE(exhaustive_triangulations(reversed(square())).by_R.empty());
  EXPECT_TRUE(exhaustive_triangulations({{0, 0}, {1, 1}, {1, 0}, {0, 1}}).by_R.empty());
  // Double loops: the fans' R are realized (and, L = 1, nothing else).
  for (int loops = 1; loops <= 2; ++loops) {
    const DoubleLoop d = make_double_loop(loops, 4 * loops + 1, 0.05);
    const OracleResult o = exhaustive_triangulations(d.poly);
    ASSERT_TRUE(o.complete);
    std::vector<int> R1(d.poly.size(), 0), R2(d.poly.size(), 0);
    R1[0] = loops;
    R2[1] = loops;
    EXPECT_TRUE(o.by_R.count(R1));
    EXPECT_TRUE(o.by_R.count(R2));
    if (loops == 1) EXPECT_EQ(o.by_R.size(), 2u);
  }
  // Small trees: their own R is realized; small stars: only R = 0; small figure eights: nothing.
  int trees = 0;
  for (const GenCase& c : generate(Family::tree, 250))
    if (c.poly.size() <= 11) {
      ++trees;
      const OracleResult o = exhaustive_triangulations(c.poly);
      ASSERT_TRUE(o.complete) << c.name();
      EXPECT_TRUE(o.by_R.count(c.certificate_R)) << c.name();
    }
  EXPECT_GE(trees, 5);
  for (const GenCase& c : generate(Family::star, 120))
    if (c.poly.size() <= 11) {
      const OracleResult o = exhaustive_triangulations(c.poly);
      ASSERT_TRUE(o.complete);
      ASSERT_EQ(o.by_R.size(), 1u) << c.name();
      EXPECT_EQ(o.by_R.begin()->first, std::vector<int>(c.poly.size(), 0));
    }
  for (const GenCase& c : generate(Family::figure_eight, 50))
    if (c.poly.size() <= 11) EXPECT_TRUE(exhaustive_triangulations(c.poly).by_R.empty()) << c.name();
  // The small family has every kind of answer, and several realizable R vectors often.
  std::map<Expect, int> kinds;
  int multi = 0, t2_negative = 0;
  for (const GenCase& c : generate(Family::small, default_count(Family::small))) {
    ++kinds[c.expect];
    multi += c.feasible_R.size() >= 2;
    t2_negative += c.turning >= 2 && c.feasible_R.empty();
  }
  EXPECT_GE(kinds[Expect::not_self_overlapping], 50);
  EXPECT_GE(kinds[Expect::weakly_self_overlapping], 30);
  EXPECT_GE(kinds[Expect::simple_or_self_overlapping], 30);
  EXPECT_GE(multi, 20);
  EXPECT_GE(t2_negative, 5);
}

TEST(ClassifyGenerators, DoubleLoopFansAreCertificates) {
  for (int loops = 1; loops <= 2; ++loops) {
    const DoubleLoop d = make_double_loop(loops, 20 * loops, 0.05);
    EXPECT_EQ(turning_number(d.poly), loops + 1);
    std::vector<int> R1(d.poly.size(), 0), R2(d.poly.size(), 0);
    R1[0] = loops;
    R2[1] = loops;
    EXPECT_TRUE(check_triangulation(d.poly, d.fan_O1, R1).ok()) << check_triangulation(d.poly, d.fan_O1, R1).str();
    EXPECT_TRUE(check_triangulation(d.poly, d.fan_O2, R2).ok()) << check_triangulation(d.poly, d.fan_O2, R2).str();
  }
}

// ------------------------------------------------------------------------------------------------
// ClassifyProperty: the engine on every family.

TEST(ClassifyProperty, ExpStrip) { run_family(Family::exp_strip); }
TEST(ClassifyProperty, PowerMap) { run_family(Family::power_map); }
TEST(ClassifyProperty, SpiralOverlap) { run_family(Family::spiral_overlap); }
TEST(ClassifyProperty, SpiralThin) { run_family(Family::spiral_thin); }
TEST(ClassifyProperty, BentStrip) { run_family(Family::bent_strip); }
TEST(ClassifyProperty, StarBothOrientations) { run_family(Family::star, true); }
TEST(ClassifyProperty, DeformedCircleBothOrientations) { run_family(Family::deformed_circle, true); }
TEST(ClassifyProperty, CombBothOrientations) { run_family(Family::comb, true); }
TEST(ClassifyProperty, ZigzagBothOrientations) { run_family(Family::zigzag, true); }
TEST(ClassifyProperty, DartFalseEarBothOrientations) { run_family(Family::dart, true); }
TEST(ClassifyProperty, PinchedFlower) { run_family(Family::flower); }
// Small polygons against the exhaustive oracle (every positive triangulation enumerated).
TEST(ClassifyProperty, SmallPolygonsAgainstExhaustiveOracle) { run_family(Family::small); }
// The same on integer / half-integer grids: collinear and coincident vertices, T-junctions, slits.
TEST(ClassifyProperty, SmallLatticePolygonsAgainstExhaustiveOracle) { run_family(Family::small_lattice); }
TEST(ClassifyProperty, TreeOfTriangles) { run_family(Family::tree); }
TEST(ClassifyProperty, DoubleLoop) { run_family(Family::double_loop); }
TEST(ClassifyProperty, LatticeTreeCollinearAndPinched) { run_family(Family::lattice_tree); }
TEST(ClassifyProperty, DeepHubTreeUpToMaxRotationIndex) { run_family(Family::deep_hub_tree); }

// A tree wrapped 7 or 8 turns around one hub is weakly self-overlapping by construction (its own
// triangulation is the certificate), although R_hub exceeds kMaxRotationIndex, which bounds only what a
// caller may prescribe. Unprescribed, the verdict must still be weakly_self_overlapping: answering
// not_self_overlapping would claim that no locally injective map exists for any mesh.
TEST(ClassifyProperty, HubBeyondMaxRotationIndexIsStillWeaklySelfOverlapping) {
  TreeOptions o;
  o.deep_min_turns = kMaxRotationIndex + 1;
  o.deep_max_turns = kMaxRotationIndex + 2;
  o.family = "tree_beyond_kmax";
  std::vector<Failure> failures;
  size_t total = 0;
  for (std::uint64_t s = 0; s < 200 && total < 4; ++s) {
    const std::optional<GenCase> c = gen_tree(900000 + s, o);
    if (!c) continue;
    ASSERT_GT(*std::max_element(c->certificate_R.begin(), c->certificate_R.end()), kMaxRotationIndex);
    ++total;
    if (auto f = run_case(*c)) failures.push_back(*f);
  }
  ASSERT_EQ(total, 4u);
  report("trees with R_hub > kMaxRotationIndex", total, failures);
}

// Big inputs, still with known answers: star-shaped noisy circles (simple by construction) and the
// benchmark's overlapping spiral strips, whose grid mesh is verified locally injective here.
TEST(ClassifyProperty, LargeVerifiedPolygons) {
  std::vector<GenCase> cases;
  for (int n : {2000, 4000}) {
    Rng rng(31 + n);
    GenCase c;
    c.family = "noisy_circle_" + std::to_string(n);
    c.poly = noisy_circle(n, 0.05, rng);
    c.expect = Expect::simple;
    c.turning = 1;
    cases.push_back(c);
  }
  for (int n : {600, 1500})
    for (double turns : {2.0, 4.0}) {
      Rng rng(2000 + (unsigned)n);
      const GridMesh m = spiral_strip_mesh(1, std::max(4, n / 2 - 1), turns, 1.0, 0.15, 1.6, rng);
      ASSERT_TRUE(verify_locally_injective(m));
      GenCase c;
      c.family = "spiral_" + std::to_string(n) + "_" + std::to_string((int)turns);
      c.poly = m.boundary_polygon();
      c.expect = Expect::simple_or_self_overlapping;
      c.turning = 1;
      cases.push_back(c);
    }
  for (std::uint64_t seed : {1u, 2u}) {  // a long bent strip, fine grid
    Rng rng(seed);
    const int ns = 700;
    // (rho, theta) as (x, y): the Jacobian determinant is the radius > 0.
    const GridMesh m = make_grid_mesh(
        2, ns,
        [&](int i, int j) {
          const double th = 5 * kTwoPi * j / ns, rad = 1 + 0.05 * th + 0.25 * i;  // 5 turns, overlapping layers
          return Pt{rad * std::cos(th), rad * std::sin(th)};
        },
        rng);
    ASSERT_TRUE(verify_locally_injective(m));
    GenCase c;
    c.family = "spiral5_" + std::to_string(seed);
    c.seed = seed;
    c.poly = m.boundary_polygon();
    c.expect = Expect::simple_or_self_overlapping;
    c.turning = 1;
    cases.push_back(c);
  }
  std::vector<Failure> failures;
  for (const GenCase& c : cases) {
    ASSERT_TRUE(well_conditioned(c.poly)) << c.name();
    ASSERT_EQ(turning_number(c.poly), 1) << c.name();
    if (auto f = run_case(c)) failures.push_back(*f);
  }
  report("large polygons", cases.size(), failures);
}
TEST(ClassifyProperty, FigureEight) { run_family(Family::figure_eight); }
TEST(ClassifyProperty, NegativeTrochoid) { run_family(Family::negative_trochoid); }
TEST(ClassifyProperty, CurlsWithNegativeWinding) { run_family(Family::curls); }
TEST(ClassifyProperty, GridImagesReversed) { run_family(Family::grid_reversed); }
TEST(ClassifyProperty, TreesReversed) { run_family(Family::tree_reversed); }

TEST(ClassifyProperty, HandCases) {
  auto mk = [](const char* name, Poly p, Expect e, int T) {
    GenCase c;
    c.family = name;
    c.poly = std::move(p);
    c.expect = e;
    c.turning = T;
    return c;
  };
  std::vector<GenCase> cases;
  cases.push_back(mk("triangle", {{0, 0}, {1, 0}, {0, 1}}, Expect::simple, 1));
  cases.push_back(mk("triangle_cw", {{0, 0}, {0, 1}, {1, 0}}, Expect::not_self_overlapping, -1));
  cases.push_back(mk("square", square(), Expect::simple, 1));
  cases.push_back(mk("bowtie", {{0, 0}, {1, 1}, {1, 0}, {0, 1}}, Expect::not_self_overlapping, 0));
  // Collinear vertices: only triangles joining the two long sides are non-degenerate.
  Poly rect;
  for (int i = 0; i <= 12; ++i) rect.push_back({double(i), 0});
  for (int i = 12; i >= 0; --i) rect.push_back({double(i), 1});
  cases.push_back(mk("collinear_rectangle", rect, Expect::simple, 1));
  Poly rect2;  // only one vertex on the top side: the fan from it is the only triangulation
  for (int i = 0; i <= 9; ++i) rect2.push_back({double(i), 0});
  rect2.push_back({4.5, 3});
  cases.push_back(mk("collinear_fan", rect2, Expect::simple, 1));
  // A thin L and a U: simple, reflex vertices.
  cases.push_back(mk("L", {{0, 0}, {3, 0}, {3, 0.5}, {0.5, 0.5}, {0.5, 3}, {0, 3}}, Expect::simple, 1));
  cases.push_back(mk("U", {{0, 0}, {3, 0}, {3, 3}, {2.5, 3}, {2.5, 0.5}, {0.5, 0.5}, {0.5, 3}, {0, 3}}, Expect::simple, 1));
  // A big coordinate offset (float cancellation): the same U far from the origin.
  Poly far;
  for (const Pt& q : cases.back().poly) far.push_back({q.x + 1e7, q.y - 3e6});
  cases.push_back(mk("U_far", far, Expect::simple, 1));
  std::vector<Failure> failures;
  for (const GenCase& c : cases) {
    ASSERT_EQ(turning_number(c.poly), c.turning) << c.family;
    if (auto f = run_case(c)) failures.push_back(*f);
  }
  report("hand cases", cases.size(), failures);
}

// Exact transformations preserve the verdict: cyclic relabeling, rotation by 90 degrees, scaling by 2,
// 2^-40 and 2^40, and mirroring followed by reversal (which keeps the interior on the left). All are exact in floating point,
// so simplicity, turning number and winding numbers are unchanged.
TEST(ClassifyProperty, VerdictInvariantUnderExactTransformations) {
  std::vector<GenCase> base;
  for (Family f : {Family::exp_strip, Family::spiral_overlap, Family::star, Family::comb, Family::tree,
                   Family::double_loop, Family::curls, Family::figure_eight, Family::lattice_tree,
                   Family::dart, Family::flower}) {
    std::vector<GenCase> cs = generate(f, 12, 77);
    base.insert(base.end(), cs.begin(), cs.end());
  }
  std::vector<Failure> failures;
  size_t total = 0;
  for (const GenCase& c : base) {
    const size_t n = c.poly.size();
    for (int variant = 0; variant < 6; ++variant) {
      GenCase v = c;
      v.certificate.clear();
      v.certificate_R.clear();
      v.negative_probes.clear();
      switch (variant) {
        case 0: {
          const size_t k = 1 + c.seed % (n - 1);
          std::rotate(v.poly.begin(), v.poly.begin() + long(k), v.poly.end());
          v.family += "_shift" + std::to_string(k);
          break;
        }
        case 1:
          for (Pt& q : v.poly) q = {-q.y, q.x};
          v.family += "_rot90";
          break;
        case 2:
          for (Pt& q : v.poly) q = {2 * q.x, 2 * q.y};
          v.family += "_scale2";
          break;
        case 3:
          for (Pt& q : v.poly) q.y = -q.y;
          v.poly = reversed(v.poly);
          v.family += "_mirror_reversed";
          break;
        case 4:
          for (Pt& q : v.poly) q = {std::ldexp(q.x, -40), std::ldexp(q.y, -40)};
          v.family += "_scale2^-40";
          break;
        case 5:
          for (Pt& q : v.poly) q = {std::ldexp(q.x, 40), std::ldexp(q.y, 40)};
          v.family += "_scale2^40";
          break;
      }
      ++total;
      if (auto f = run_case(v, std::nullopt, expected_verdict(c))) failures.push_back(*f);
    }
  }
  report("exact transformations", total, failures);
}

// Far from the origin. Lattice trees (coordinates in (Z/4)^2, |x| < 2^6) translate exactly by
// (2^20, -2^21): same polygon up to translation, same verdict. Small oracle polygons are translated by
// (1e6 + 1/3, -3e5) with rounding, and their answer is recomputed by the oracle on the rounded polygon.
TEST(ClassifyProperty, FarFromTheOrigin) {
  std::vector<Failure> failures;
  size_t total = 0;
  for (const GenCase& c : generate(Family::lattice_tree, 60, 9)) {
    GenCase v = c;
    for (Pt& q : v.poly) {
      ASSERT_LT(std::fabs(q.x) + std::fabs(q.y), 64.0);
      q = {q.x + 1048576.0, q.y - 2097152.0};
    }
    v.family += "_translated";
    ASSERT_TRUE(check_triangulation(v.poly, v.certificate, v.certificate_R).ok()) << v.name();
    ++total;
    if (auto f = run_case(v, std::nullopt, expected_verdict(c))) failures.push_back(*f);
  }
  for (const GenCase& c : generate(Family::small, 150, 9)) {
    GenCase v;
    v.family = "small_far";
    v.seed = c.seed;
    for (const Pt& q : c.poly) v.poly.push_back({q.x + (1e6 + 1.0 / 3), q.y - 3e5});
    const std::optional<GenCase> w = finish_small_case(v);
    if (!w) continue;
    ++total;
    if (auto f = run_case(*w)) failures.push_back(*f);
  }
  EXPECT_GE(total, 150u);
  report("far from the origin", total, failures);
}

TEST(ClassifyProperty, MalformedPolygonsThrowInputError) {
  auto code_of = [](const Poly& p) -> std::string {
    try {
      classify(to_boundary(p));
    } catch (const InputError& e) {
      return e.code();
    } catch (const std::exception& e) {
      return std::string("other exception: ") + e.what();
    }
    return "no exception";
  };
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(code_of({}), "polygon_too_small");
  EXPECT_EQ(code_of({{0, 0}}), "polygon_too_small");
  EXPECT_EQ(code_of({{0, 0}, {1, 0}}), "polygon_too_small");
  EXPECT_EQ(code_of({{0, 0}, {1, nan}, {0, 1}}), "polygon_non_finite");
  EXPECT_EQ(code_of({{0, 0}, {1, 0}, {inf, 1}}), "polygon_non_finite");
  EXPECT_EQ(code_of({{0, 0}, {1, 0}, {1, 0}, {0, 1}}), "polygon_zero_length_edge");
  EXPECT_EQ(code_of({{0, 0}, {1, 0}, {0, 1}, {0, 0}}), "polygon_zero_length_edge");
}

TEST(ClassifyProperty, CancelledTokenStopsClassify) {
  Rng rng(5);
  const Poly p = overlapping_spiral(600, 4.0, rng);
  CancelToken token;
  token.cancel();
  EXPECT_THROW(classify(to_boundary(p), &token), Cancelled);
  CancelToken expired;
  expired.set_deadline(CancelToken::Clock::now() - std::chrono::seconds(1));
  EXPECT_THROW(classify(to_boundary(p), &expired), Cancelled);
}

}  // namespace
}  // namespace lipmap
