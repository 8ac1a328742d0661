// engine/boundary_polygon.h: validate_polygon's preconditions, each fault with its code, the offending vertex
// and nothing else refused. Polygons are generated; the expected verdict of each follows from how it was made.
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/boundary_polygon.h"
#include "engine/error.h"

namespace lipmap {
namespace {

// A polygon with distinct consecutive vertices (a random star around the origin), any orientation: orientation
// and self-intersection are classify's business, not a precondition.
BoundaryPolygon random_polygon(std::mt19937_64& rng, int n) {
  std::uniform_real_distribution<double> r(0.5, 2.0);
  BoundaryPolygon p;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    p.vertices.push_back({r(rng) * std::cos(a), r(rng) * std::sin(a)});
  }
  return p;
}

std::string code_of(const BoundaryPolygon& p, std::optional<long long>* index = nullptr) {
  try {
    validate_polygon(p);
  } catch (const InputError& e) {
    if (index) *index = e.index();
    return e.code();
  }
  return "";
}

TEST(BoundaryPolygon, AcceptsEveryPolygonThatMeetsThePreconditions) {
  std::mt19937_64 rng(1);
  for (int n = 3; n < 60; ++n) {
    BoundaryPolygon p = random_polygon(rng, n);
    EXPECT_EQ(code_of(p), "") << n;
    std::uniform_int_distribution<int> r(0, kMaxRotationIndex);
    p.rotation_indices = std::vector<int>(n);
    for (int& x : *p.rotation_indices) x = r(rng);
    EXPECT_EQ(code_of(p), "") << n;
  }
}

TEST(BoundaryPolygon, RefusesEachFaultWithItsCodeAndVertex) {
  std::mt19937_64 rng(2);
  EXPECT_EQ(code_of(BoundaryPolygon{}), "polygon_too_small");
  EXPECT_EQ(code_of(BoundaryPolygon{{{0, 0}, {1, 0}}, std::nullopt}), "polygon_too_small");
  for (int n = 3; n < 40; ++n) {
    std::uniform_int_distribution<int> vertex(0, n - 1);
    for (double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                       -std::numeric_limits<double>::infinity()}) {
      BoundaryPolygon p = random_polygon(rng, n);
      const int i = vertex(rng);
      (vertex(rng) % 2 ? p.vertices[i].x : p.vertices[i].y) = bad;
      std::optional<long long> index;
      EXPECT_EQ(code_of(p, &index), "polygon_non_finite") << n;
      EXPECT_EQ(index, i);
    }
    {  // a vertex repeated right after itself (the last one after the first, too)
      BoundaryPolygon p = random_polygon(rng, n);
      const int i = vertex(rng);
      p.vertices[(i + 1) % n] = p.vertices[i];
      EXPECT_EQ(code_of(p), "polygon_zero_length_edge") << n << " at " << i;
    }
    {
      BoundaryPolygon p = random_polygon(rng, n);
      p.rotation_indices = std::vector<int>(n + (vertex(rng) % 2 ? 1 : -1), 0);
      EXPECT_EQ(code_of(p), "rotation_indices_length") << n;
    }
    for (int bad : {-1, kMaxRotationIndex + 1, std::numeric_limits<int>::max()}) {
      BoundaryPolygon p = random_polygon(rng, n);
      p.rotation_indices = std::vector<int>(n, 0);
      const int i = vertex(rng);
      (*p.rotation_indices)[i] = bad;
      std::optional<long long> index;
      EXPECT_EQ(code_of(p, &index), "rotation_index_out_of_range") << n;
      EXPECT_EQ(index, i);
    }
  }
}

}  // namespace
}  // namespace lipmap
