// The engine's exact module (engine/detail/exact_predicates.h) against independent checks written here:
// orientation against the cross product in exact rationals (CGAL::Exact_rational, no filter) and in 128-bit
// integers; turn counts against angles summed in long double on rays far apart (where rounding cannot
// decide); turning numbers against summed exterior angles.
#include <gtest/gtest.h>

#include <CGAL/Exact_rational.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "engine/detail/exact_predicates.h"

namespace lipmap {
namespace {

using detail::Pt;
using Q = CGAL::Exact_rational;

int exact_sign(const Point2& a, const Point2& b, const Point2& c) {
  const Q d = (Q(b.x) - Q(a.x)) * (Q(c.y) - Q(a.y)) - (Q(b.y) - Q(a.y)) * (Q(c.x) - Q(a.x));
  return d > 0 ? 1 : d < 0 ? -1 : 0;
}

TEST(ExactPredicates, OrientationMatchesExactRationals) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> coord(-1e3, 1e3);
  for (int i = 0; i < 20000; ++i) {
    const Point2 a{coord(rng), coord(rng)}, b{coord(rng), coord(rng)};
    // c near the line ab: a point on it rounded to doubles, then nudged by a few ulps (signs rounding decides).
    const double t = coord(rng) / 1e3;
    Point2 c{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
    for (int k = 0; k < static_cast<int>(rng() % 3); ++k) c.y = std::nextafter(c.y, (rng() % 2) ? 1e300 : -1e300);
    ASSERT_EQ(detail::orient(a, b, c), exact_sign(a, b, c));
    ASSERT_EQ(detail::orient(Pt(a.x, a.y), Pt(b.x, b.y), Pt(c.x, c.y)), exact_sign(a, b, c));
  }
}

TEST(ExactPredicates, OrientationOfIntegerPointsMatchesIntegerCrossProduct) {
  std::mt19937_64 rng(5);
  for (int i = 0; i < 20000; ++i) {
    const long long range = (i % 2) ? 8 : (1LL << 26);  // small: many exactly collinear triples
    auto r = [&] { return static_cast<long long>(rng() % (2 * range + 1)) - range; };
    const long long ax = r(), ay = r(), bx = r(), by = r(), cx = r(), cy = r();
    const __int128 cross = static_cast<__int128>(bx - ax) * (cy - ay) - static_cast<__int128>(by - ay) * (cx - ax);
    const int sign = cross > 0 ? 1 : cross < 0 ? -1 : 0;
    ASSERT_EQ(detail::orient(Point2{double(ax), double(ay)}, Point2{double(bx), double(by)},
                             Point2{double(cx), double(cy)}),
              sign);
    // In the plane z = 0 (tilted by z = x) three points are on a line exactly when their 2D cross product is 0.
    ASSERT_EQ(detail::collinear(Point3{double(ax), double(ay), double(ax)}, Point3{double(bx), double(by), double(bx)},
                                Point3{double(cx), double(cy), double(cx)}),
              sign == 0);
  }
  EXPECT_TRUE(detail::collinear({0, 0, 0}, {1, 2, 3}, {2, 4, 6}));
  EXPECT_FALSE(detail::collinear({0, 0, 0}, {1, 2, 3}, {2, 4, 7}));
}

constexpr long double kTwoPi = 6.283185307179586476925286766559L;

long double direction(const Pt& c, const Pt& p) {
  return std::atan2(static_cast<long double>(p.y()) - c.y(), static_cast<long double>(p.x()) - c.x());
}

// Counterclockwise sweep from direction u to w at c, in [0, 2 pi).
long double sweep(const Pt& c, const Pt& u, const Pt& w) {
  long double s = direction(c, w) - direction(c, u);
  while (s < 0) s += kTwoPi;
  while (s >= kTwoPi) s -= kTwoPi;
  return s;
}

// Chains of corner sweeps at a centre on rays 3 degrees apart at least: the total angle minus the final
// sweep from the start is a whole number of turns, which rounding cannot change.
TEST(ExactPredicates, TurnCountOfChainedSweepsMatchesSummedAngles) {
  std::mt19937 rng(9);
  for (int trial = 0; trial < 3000; ++trial) {
    const Pt c(static_cast<double>(rng() % 11) - 5, static_cast<double>(rng() % 11) - 5);
    auto ray = [&](int slot) {  // 120 slots of 3 degrees; one point per slot, so equal slots are equal rays
      const double a = slot * 3.0 * M_PI / 180.0, len = 1 + slot % 7;
      return Pt(c.x() + len * std::cos(a), c.y() + len * std::sin(a));
    };
    const int corners = 1 + static_cast<int>(rng() % 12);
    std::vector<Pt> rays = {ray(static_cast<int>(rng() % 120))};
    const bool closed = rng() % 2;
    for (int k = 0; k < corners; ++k)
      rays.push_back(closed && k + 1 == corners ? rays[0] : ray(static_cast<int>(rng() % 120)));
    detail::TurnCount count(c, rays[0]);
    long double total = 0;
    for (int k = 0; k < corners; ++k) {
      count.add(rays[k], rays[k + 1]);
      total += sweep(c, rays[k], rays[k + 1]);
    }
    const long double whole = (total - sweep(c, rays[0], rays.back())) / kTwoPi;
    ASSERT_EQ(count.turns(), static_cast<int>(std::lround(whole))) << "trial " << trial;
  }
}

// A one-ring: positive triangles around a centre that wind `turns` times (paper Fig. 1a) by stepping round
// the circle in steps shorter than pi; fan_turns finds the corners by their next vertex in any order.
TEST(ExactPredicates, FanTurnsCountsWindingsOfOneRings) {
  std::mt19937 rng(17);
  for (int trial = 0; trial < 500; ++trial) {
    const int turns = 1 + static_cast<int>(rng() % 3);
    const int steps = 3 * turns + static_cast<int>(rng() % 20);
    std::vector<Pt> ring;
    for (int k = 0; k < steps; ++k) {
      const double a = kTwoPi * turns * k / steps;
      ring.emplace_back(std::cos(static_cast<double>(a)) * (1 + k % 3), std::sin(static_cast<double>(a)) * (1 + k % 3));
    }
    const Pt centre(0, 0);
    std::vector<detail::FanCorner> fan;
    for (int k = 0; k < steps; ++k) fan.push_back({k, (k + 1) % steps, ring[k], ring[(k + 1) % steps]});
    std::shuffle(fan.begin() + 1, fan.end(), rng);
    EXPECT_EQ(detail::fan_turns(centre, fan), turns);
    fan.pop_back();  // an open ring is no cycle
    EXPECT_EQ(detail::fan_turns(centre, fan), 0);
  }
}

// Turning numbers of star-shaped loops that go round `k` times (well separated angles), and of their mirror.
TEST(ExactPredicates, TurningNumberMatchesSummedExteriorAngles) {
  std::mt19937 rng(23);
  for (int trial = 0; trial < 1000; ++trial) {
    const int n = 3 + static_cast<int>(rng() % 30);
    std::vector<Pt> p;
    for (int i = 0; i < n; ++i) p.emplace_back(static_cast<double>(rng() % 41) - 20, static_cast<double>(rng() % 41) - 20);
    long double exterior = 0;
    bool clean = true;
    for (int i = 0; i < n; ++i) {
      const Pt &a = p[(i + n - 1) % n], &b = p[i], &c = p[(i + 1) % n];
      const long double ux = b.x() - a.x(), uy = b.y() - a.y(), vx = c.x() - b.x(), vy = c.y() - b.y();
      const long double cross = ux * vy - uy * vx, dot = ux * vx + uy * vy;
      if ((ux == 0 && uy == 0) || cross == 0) clean = false;  // repeated point, straight or spike: skip
      exterior += std::atan2(cross, dot);
    }
    if (!clean) continue;
    EXPECT_EQ(detail::turning_number(p), static_cast<int>(std::lround(exterior / kTwoPi))) << "trial " << trial;
  }
  // A slit into a square: the spike at its tip turns back by a clockwise half turn (interior angle 2 pi: one
  // turn, rotation index 0), so the loop still turns once: 6 quarter turns left, one half turn right.
  const std::vector<Pt> slit = {Pt(0, 0), Pt(6, 0), Pt(6, 6), Pt(3, 6), Pt(3, 3), Pt(3, 6), Pt(0, 6)};
  EXPECT_EQ(detail::turning_number(slit), 1);
  EXPECT_EQ(detail::spike_turns(slit), (std::vector<int>{0, 0, 0, 0, 1, 0, 0}));
  EXPECT_EQ(detail::rotation_index(Pt(3, 3), Pt(3, 6), Pt(3, 6), 1), 0);
  EXPECT_EQ(detail::rotation_index(Pt(0, 0), Pt(1, 0), Pt(0, 1), 1), 1);
}

}  // namespace
}  // namespace lipmap
