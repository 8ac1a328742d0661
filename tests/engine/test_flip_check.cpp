// engine/flip_check.h: exact orientation of uv triangles. The reference here is integer arithmetic: points with
// integer coordinates below 2^26 are exact doubles and their cross products are exact in 128-bit integers, so
// the sign is known without any floating point. Near-degenerate cases come from points on a line nudged by
// one ulp, decided exactly with long double products of the (exact) coordinate differences.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "engine/flip_check.h"

namespace lipmap {
namespace {

int reference_sign(const Point2& a, const Point2& b, const Point2& c) {
  const auto ax = static_cast<__int128>(a.x), ay = static_cast<__int128>(a.y);
  const auto bx = static_cast<__int128>(b.x), by = static_cast<__int128>(b.y);
  const auto cx = static_cast<__int128>(c.x), cy = static_cast<__int128>(c.y);
  const __int128 cross = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
  return (cross > 0) - (cross < 0);
}

TEST(FlipCheck, OrientationAgreesWithIntegerArithmetic) {
  std::mt19937_64 rng(7);
  for (int range : {3, 100, 1 << 25}) {
    std::uniform_int_distribution<int> coord(-range, range);
    for (int i = 0; i < 20000; ++i) {
      const Point2 a{double(coord(rng)), double(coord(rng))}, b{double(coord(rng)), double(coord(rng))},
          c{double(coord(rng)), double(coord(rng))};
      ASSERT_EQ(orientation_sign(a, b, c), reference_sign(a, b, c)) << range << " case " << i;
    }
  }
}

TEST(FlipCheck, OneUlpOffALineIsDecidedExactly) {
  // b lies exactly on the line through a and c (a multiple of (1, 3) from a); moving b's y by one ulp up turns
  // the triangle clockwise... or counterclockwise: the sign is that of -(dy) * (c.x - a.x) for b = a + t (c - a).
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<int> k(1, 1 << 20);
  for (int i = 0; i < 5000; ++i) {
    const double t = k(rng);
    const Point2 a{0.25, 0.75};
    const Point2 c{a.x + 2 * t, a.y + 6 * t};  // exact: small integers plus quarters
    const Point2 on{a.x + t, a.y + 3 * t};
    ASSERT_EQ(orientation_sign(a, on, c), 0);
    const Point2 up{on.x, std::nextafter(on.y, INFINITY)}, down{on.x, std::nextafter(on.y, -INFINITY)};
    // (a, b, c) with b above the line a->c (which goes right and up) is clockwise.
    EXPECT_EQ(orientation_sign(a, up, c), -1) << t;
    EXPECT_EQ(orientation_sign(a, down, c), 1) << t;
  }
}

TEST(FlipCheck, CountsAndListsEveryNonPositiveFace) {
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<int> coord(-4, 4);  // a small grid: many collinear and repeated corners
  for (int round = 0; round < 200; ++round) {
    std::vector<Point2> uv(12);
    for (Point2& p : uv) p = {double(coord(rng)), double(coord(rng))};
    std::uniform_int_distribution<int> index(0, static_cast<int>(uv.size()) - 1);
    std::vector<Triangle> faces(30);
    std::vector<int> expected;
    for (int f = 0; f < static_cast<int>(faces.size()); ++f) {
      faces[f] = {index(rng), index(rng), index(rng)};
      if (reference_sign(uv[faces[f][0]], uv[faces[f][1]], uv[faces[f][2]]) <= 0) expected.push_back(f);
    }
    EXPECT_EQ(count_non_positive(uv, faces), static_cast<int>(expected.size()));
    EXPECT_EQ(non_positive_faces(uv, faces), expected);
  }
}

}  // namespace
}  // namespace lipmap
