// Hand-reasoned classify cases at the degenerate corners of the input space: straight vertices, slits
// (spikes of interior angle 2 pi), touching points, tiny polygons, cancellation. Each expectation is argued
// in its comment; the generated property tests live in test_classify_properties.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>

#include "engine/classify.h"

namespace lipmap {
namespace {

BoundaryPolygon polygon(std::vector<Point2> v, std::optional<std::vector<int>> r = std::nullopt) {
  return BoundaryPolygon{std::move(v), std::move(r)};
}

TEST(ClassifyCases, TriangleAndSquare) {
  const auto tri = classify(polygon({{0, 0}, {1, 0}, {0, 1}}));
  EXPECT_EQ(tri.verdict, Verdict::simple);
  ASSERT_EQ(tri.triangulation.size(), 1u);
  EXPECT_EQ(tri.turning_number, 1);

  const auto sq = classify(polygon({{0, 0}, {1, 0}, {1, 1}, {0, 1}}));
  EXPECT_EQ(sq.verdict, Verdict::simple);
  EXPECT_EQ(sq.triangulation.size(), 2u);
  EXPECT_EQ(sq.rotation_indices, std::vector<int>(4, 0));
}

// Finite coordinates near the ends of the double range: the extents overflow to infinity inside the ear
// clipper's grid, which must fall back to one cell rather than cast infinity to int (undefined behaviour,
// found by the classify fuzzer; the sanitizer run of the tests catches a regression). The verdicts follow
// from the shapes: a counterclockwise square and a counterclockwise regular 40-gon are simple.
TEST(ClassifyCases, CoordinatesNearTheEndsOfTheDoubleRange) {
  for (double s : {1e308, 1.7e308, 1e-308, 4.9e-324}) {
    const auto sq = classify(polygon({{-s, 0}, {s, 0}, {s, s}, {-s, s}}));
    EXPECT_EQ(sq.verdict, Verdict::simple) << s;
    std::vector<Point2> ngon;
    for (int k = 0; k < 40; ++k)
      ngon.push_back({s * std::cos(2 * M_PI * k / 40), s * std::sin(2 * M_PI * k / 40)});
    if (s < 1e-300) continue;  // a subnormal scale rounds the 40-gon's vertices onto each other
    EXPECT_EQ(classify(polygon(ngon)).verdict, Verdict::simple) << s;
  }
}

// Peak resident memory of this process in kB since the last reset (Linux: VmHWM, reset by writing 5 to
// clear_refs); -1 where that is not available.
long peak_rss_kb(bool reset) {
  if (reset) {
    std::ofstream clear("/proc/self/clear_refs");
    if (!(clear << "5" << std::flush)) return -1;
  }
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

double from_bits(std::uint64_t bits) {
  double d;
  std::memcpy(&d, &bits, sizeof d);
  return d;
}

// Subnormal coordinates: the ear clipper's grid cell is then subnormal and its inverse infinite, which put every
// edge in all 4096 x 4096 cells: a triangle took 2 GB and 20 s (found by the classify fuzzer; its input is the
// first polygon here). Each polygon must classify within a few MB, with the verdict of the same polygon scaled
// by 2^1000 (exact: a power of two, no rounding), where the grid is an ordinary one.
TEST(ClassifyCases, SubnormalCoordinatesGetAnOrdinaryGrid) {
  const std::vector<std::vector<Point2>> polygons = {
      {{0, from_bits(0x3ff00000)}, {0, from_bits(0x01010000)}, {from_bits(0x3ff0), 0}},
      {{0, 0}, {4.9e-324, 0}, {0, 4.9e-324}},
      {{0, 0}, {3e-320, 0}, {3e-320, 2e-320}, {0, 2e-320}},
      {{1e-310, 1e-310}, {0, 2e-310}, {-1e-310, 1e-310}, {0, 0}},
  };
  for (const auto& p : polygons) {
    const long before = peak_rss_kb(true);
    const auto c = classify(polygon(p));
    const long peak = peak_rss_kb(false);
    if (before >= 0 && peak >= 0) EXPECT_LT(peak - before, 64 * 1024) << "kB of peak RSS growth";
    std::vector<Point2> scaled;
    for (const Point2& q : p) scaled.push_back({std::ldexp(q.x, 1000), std::ldexp(q.y, 1000)});
    EXPECT_EQ(c.verdict, classify(polygon(scaled)).verdict);
  }
}

// Straight vertices (angle pi) turn the tangent by zero: the square with its edge midpoints is a simple
// counterclockwise polygon of turning number 1, each midpoint needing two triangles.
TEST(ClassifyCases, StraightVerticesAreNotTurns) {
  const auto c = classify(polygon({{0, 0}, {1, 0}, {2, 0}, {2, 1}, {2, 2}, {1, 2}, {0, 2}, {0, 1}}));
  EXPECT_EQ(c.turning_number, 1);
  EXPECT_EQ(c.verdict, Verdict::simple);
  EXPECT_EQ(c.triangulation.size(), 6u);
}

// Clockwise: the turning number is -1, and positive triangles force sum R_i = t - 1 >= 0.
TEST(ClassifyCases, ClockwiseIsRefusedWithReason) {
  const auto c = classify(polygon({{0, 0}, {0, 1}, {1, 1}, {1, 0}}));
  EXPECT_EQ(c.verdict, Verdict::not_self_overlapping);
  EXPECT_EQ(c.turning_number, -1);
  EXPECT_TRUE(c.triangulation.empty());
  EXPECT_NE(c.reason.find("turning number"), std::string::npos);
}

// A square with a slit cut down from its top edge: the slit's tip (1,1) is a spike of interior angle 2 pi
// and the slit's mouth (1,2) is visited twice. The region is the square minus a segment, which a locally
// injective map covers (fan every triangle around the tip), so R = 0 works: self-overlapping, not simple.
TEST(ClassifyCases, SlitTipHasFullAngle) {
  const auto c = classify(polygon({{0, 0}, {2, 0}, {2, 2}, {1, 2}, {1, 1}, {1, 2}, {0, 2}}));
  EXPECT_EQ(c.turning_number, 1);
  EXPECT_EQ(c.verdict, Verdict::self_overlapping);
  EXPECT_EQ(c.rotation_indices, std::vector<int>(7, 0));
}

// A vertex touching the interior of another edge pinches the region into two triangles joined at a
// point; no positive triangle can cover the directions below that edge, so no triangulation exists.
TEST(ClassifyCases, VertexTouchingAnEdgeIsRefused) {
  const auto c = classify(polygon({{0, 0}, {1, 0}, {1, 1}, {0.5, 0}, {0, 1}}));
  EXPECT_EQ(c.verdict, Verdict::not_self_overlapping);
}

// All three vertices on a line: no positive triangle at all.
TEST(ClassifyCases, CollinearTriangleIsRefused) {
  EXPECT_EQ(classify(polygon({{0, 0}, {1, 0}, {2, 0}})).verdict, Verdict::not_self_overlapping);
  EXPECT_EQ(classify(polygon({{0, 0}, {2, 0}, {1, 0}})).verdict, Verdict::not_self_overlapping);
}

// A circle traversed twice, with one vertex O pulled to the centre: the fan from O is a positive
// triangulation whose angle at O is the interior angle plus one full turn, so the polygon is weakly
// self-overlapping with turning number 2; R = 0 everywhere is impossible (sum R_i must be 1).
TEST(ClassifyCases, DoubleCircleWithHubIsWeak) {
  std::vector<Point2> v{{0, 0}};
  const int m = 80;
  for (int i = 0; i < m; ++i) {
    const double th = M_PI / 2 + 0.1 + (4 * M_PI - 0.2) * i / (m - 1);
    const double r = 1 + 0.3 * std::cos(th / 2);
    v.push_back({r * std::cos(th), r * std::sin(th)});
  }
  const auto free = classify(polygon(v));
  EXPECT_EQ(free.turning_number, 2);
  EXPECT_EQ(free.verdict, Verdict::weakly_self_overlapping);
  EXPECT_EQ(free.singular_vertices.size(), 1u);

  std::vector<int> hub(v.size(), 0);
  hub[0] = 1;
  const auto fan = classify(polygon(v, hub));
  EXPECT_EQ(fan.verdict, Verdict::weakly_self_overlapping);
  EXPECT_EQ(fan.rotation_indices, hub);
  EXPECT_EQ(fan.singular_vertices, std::vector<int>{0});

  const auto none = classify(polygon(v, std::vector<int>(v.size(), 0)));
  EXPECT_EQ(none.verdict, Verdict::not_self_overlapping);
  EXPECT_NE(none.reason.find("sum"), std::string::npos);
}

TEST(ClassifyCases, CancelledTokenStopsTheStage) {
  std::vector<Point2> v;
  for (int i = 0; i < 3000; ++i) v.push_back({std::cos(2 * M_PI * i / 3000), std::sin(2 * M_PI * i / 3000)});
  CancelToken token;
  token.cancel();
  EXPECT_THROW(classify(polygon(v), &token), Cancelled);
}

}  // namespace
}  // namespace lipmap
