// Stage "quality" (engine/quality.h): conformal distortion K = sigma_1 / sigma_2 per triangle, its
// area-weighted mean and its histogram. Known answers: similarities give K = 1, an affine map A gives the
// ratio of A's singular values (computed here from the eigenvalues of A^T A, not the engine's formula).
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "engine/error.h"
#include "engine/quality.h"

namespace lipmap {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A planar grid (z = 0) with both diagonal directions.
struct Grid {
  std::vector<Point3> v;
  std::vector<Triangle> f;
};

Grid grid(int nx, int ny) {
  Grid g;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) g.v.push_back({0.3 * i + 0.01 * j * j, 0.2 * j + 0.02 * i, 0});
  auto id = [&](int i, int j) { return j * (nx + 1) + i; };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      if ((i + j) % 2) {
        g.f.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
        g.f.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      } else {
        g.f.push_back({id(i, j), id(i + 1, j), id(i, j + 1)});
        g.f.push_back({id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)});
      }
    }
  return g;
}

// Ratio of the singular values of the 2 x 2 matrix [[a, b], [c, d]] from the eigenvalues of A^T A.
double singular_ratio(double a, double b, double c, double d) {
  const double p = a * a + c * c, q = a * b + c * d, r = b * b + d * d;  // A^T A = [[p, q], [q, r]]
  const double mean = 0.5 * (p + r), disc = std::sqrt(0.25 * (p - r) * (p - r) + q * q);
  return std::sqrt((mean + disc) / (mean - disc));
}

std::vector<Point2> affine_image(const std::vector<Point3>& v, double a, double b, double c, double d, double tx,
                                 double ty) {
  std::vector<Point2> uv;
  for (const Point3& p : v) uv.push_back({a * p.x + b * p.y + tx, c * p.x + d * p.y + ty});
  return uv;
}

int total(const std::vector<int>& counts) {
  int s = 0;
  for (int c : counts) s += c;
  return s;
}

TEST(Quality, HistogramHasTheFixedEdges) {
  const Grid g = grid(2, 2);
  const Distortion d = conformal_distortion(g.v, g.f, affine_image(g.v, 1, 0, 0, 1, 0, 0));
  const std::vector<double> edges = {1, 1.1, 1.25, 1.5, 2, 3, 5, 10, kInf};
  EXPECT_EQ(d.bin_edges, edges);
  EXPECT_EQ(d.counts.size(), edges.size() - 1);
  EXPECT_EQ(d.per_face.size(), g.f.size());
  EXPECT_EQ(total(d.counts), static_cast<int>(g.f.size()));
}

TEST(Quality, IdentityAndSimilaritiesHaveKOne) {
  const Grid g = grid(7, 5);
  // Identity, then a rotation by 0.7 rad scaled by 3.5 and translated far away.
  const double s = 3.5, th = 0.7;
  for (const auto& uv : {affine_image(g.v, 1, 0, 0, 1, 0, 0),
                         affine_image(g.v, s * std::cos(th), -s * std::sin(th), s * std::sin(th), s * std::cos(th), 1e3, -7)}) {
    const Distortion d = conformal_distortion(g.v, g.f, uv);
    for (std::size_t f = 0; f < g.f.size(); ++f) EXPECT_NEAR(d.per_face[f], 1.0, 1e-9) << "face " << f;
    EXPECT_NEAR(d.max, 1.0, 1e-9);
    EXPECT_NEAR(d.mean, 1.0, 1e-9);
    EXPECT_EQ(d.counts[0], static_cast<int>(g.f.size()));
  }
}

TEST(Quality, IsometricLayoutOfATiltedTriangleHasKOne) {
  // A 3D triangle off the xy plane, laid out in the plane with its own edge lengths.
  const std::vector<Point3> v = {{0, 0, 0}, {1, 0, 1}, {0, 1, 0}};
  const std::vector<Triangle> f = {{0, 1, 2}};
  const std::vector<Point2> uv = {{5, 5}, {5 + std::sqrt(2.0), 5}, {5, 6}};
  const Distortion d = conformal_distortion(v, f, uv);
  EXPECT_NEAR(d.per_face[0], 1.0, 1e-12);
}

TEST(Quality, KnownAffineStretchesGiveTheirSingularValueRatio) {
  const Grid g = grid(6, 4);
  struct Case {
    double a, b, c, d;
  };
  for (const Case& m : {Case{3, 0, 0, 1}, Case{1, 0, 0, 0.25}, Case{1, 1, 0, 1}, Case{2, -1, 0.5, 1.5},
                        Case{-1, 0.2, 0.3, -2}}) {
    const double expected = singular_ratio(m.a, m.b, m.c, m.d);
    const Distortion d = conformal_distortion(g.v, g.f, affine_image(g.v, m.a, m.b, m.c, m.d, 0.5, 0.25));
    for (std::size_t f = 0; f < g.f.size(); ++f)
      ASSERT_NEAR(d.per_face[f], expected, 1e-9 * expected) << "face " << f << " matrix " << m.a << " " << m.b << " "
                                                            << m.c << " " << m.d;
    EXPECT_NEAR(d.max, expected, 1e-9 * expected);
    EXPECT_NEAR(d.mean, expected, 1e-9 * expected);
  }
  // Stretch by 3 along x: K = 3 exactly, in bin [3, 5).
  const Distortion d3 = conformal_distortion(g.v, g.f, affine_image(g.v, 3, 0, 0, 1, 0, 0));
  EXPECT_NEAR(d3.max, 3.0, 1e-12);
  // Shear [[1, 1], [0, 1]]: singular values phi and 1/phi, K = phi^2.
  const double phi = 0.5 * (1 + std::sqrt(5.0));
  EXPECT_NEAR(singular_ratio(1, 1, 0, 1), phi * phi, 1e-12);
}

TEST(Quality, StretchOfA3DTriangleInItsOwnFrame) {
  // The triangle's isometric layout scaled by 2 along its first edge: K = 2.
  const std::vector<Point3> v = {{1, 2, 3}, {1, 2, 5}, {1, 4, 3}};  // edge p0->p1 along z, p0->p2 along y
  const std::vector<Triangle> f = {{0, 1, 2}};
  const std::vector<Point2> uv = {{0, 0}, {4, 0}, {0, 2}};           // |p1 - p0| = 2 -> 4, |p2 - p0| = 2 -> 2
  EXPECT_NEAR(conformal_distortion(v, f, uv).per_face[0], 2.0, 1e-12);
}

TEST(Quality, HistogramBinsAreHalfOpenAndTheLastIsOpenAbove) {
  // One triangle per K: stretches along x by exactly an edge value land in the bin starting there.
  const std::vector<double> ks = {1.0, 1.1, 1.5, 2.0, 2.5, 10.0, 40.0};
  std::vector<Point3> v;
  std::vector<Triangle> f;
  std::vector<Point2> uv;
  for (std::size_t i = 0; i < ks.size(); ++i) {
    const int base = static_cast<int>(v.size());
    const double off = 10.0 * static_cast<double>(i);
    v.push_back({off, 0, 0});
    v.push_back({off + 1, 0, 0});
    v.push_back({off, 1, 0});
    uv.push_back({0, 0});
    uv.push_back({ks[i], 0});
    uv.push_back({0, 1});
    f.push_back({base, base + 1, base + 2});
  }
  const Distortion d = conformal_distortion(v, f, uv);
  for (std::size_t i = 0; i < ks.size(); ++i) EXPECT_NEAR(d.per_face[i], ks[i], 1e-12 * ks[i]);
  // Bins: [1,1.1) [1.1,1.25) [1.25,1.5) [1.5,2) [2,3) [3,5) [5,10) [10,inf].
  // Stretch factors computed in floating point may land a hair below an edge; the ones that are exact
  // binary fractions (1, 1.5, 2, 2.5, 10, 40) must be exactly in their bins.
  EXPECT_EQ(d.counts[0], 1);  // 1.0
  EXPECT_EQ(d.counts[3], 1);  // 1.5
  EXPECT_EQ(d.counts[4], 2);  // 2.0, 2.5
  EXPECT_EQ(d.counts[7], 2);  // 10, 40
  EXPECT_EQ(d.counts[1] + d.counts[0], 2);  // 1.1 in [1, 1.1) or [1.1, 1.25) depending on rounding
  EXPECT_EQ(total(d.counts), static_cast<int>(ks.size()));
  EXPECT_NEAR(d.max, 40.0, 1e-10);
}

TEST(Quality, MeanIsWeightedBy3DArea) {
  // Triangle A: area 0.5, K = 1. Triangle B: area 4.5 (legs 3), K = 2.
  const std::vector<Point3> v = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {10, 0, 0}, {13, 0, 0}, {10, 3, 0}};
  const std::vector<Triangle> f = {{0, 1, 2}, {3, 4, 5}};
  const std::vector<Point2> uv = {{0, 0}, {1, 0}, {0, 1}, {0, 0}, {6, 0}, {0, 3}};
  const Distortion d = conformal_distortion(v, f, uv);
  EXPECT_NEAR(d.per_face[0], 1.0, 1e-12);
  EXPECT_NEAR(d.per_face[1], 2.0, 1e-12);
  EXPECT_NEAR(d.mean, (0.5 * 1 + 4.5 * 2) / 5.0, 1e-12);
  EXPECT_NEAR(d.max, 2.0, 1e-12);
}

TEST(Quality, MirroredTriangleKeepsItsSingularValuesAndDegenerateIsInfinite) {
  const std::vector<Point3> v = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const std::vector<Triangle> f = {{0, 1, 2}};
  // Mirror image (clockwise): same singular values, K = 1. Flips are counted elsewhere.
  EXPECT_NEAR(conformal_distortion(v, f, {{0, 0}, {1, 0}, {0, -1}}).per_face[0], 1.0, 1e-12);
  // Collinear uv: sigma_2 = 0, K = inf, and so are max and mean.
  const Distortion d = conformal_distortion(v, f, {{0, 0}, {1, 0}, {2, 0}});
  EXPECT_TRUE(std::isinf(d.per_face[0]));
  EXPECT_TRUE(std::isinf(d.max));
  EXPECT_TRUE(std::isinf(d.mean));
  EXPECT_EQ(d.counts[7], 1);
}

TEST(Quality, EmptyMeshAndBadInput) {
  const Distortion d = conformal_distortion({}, {}, {});
  EXPECT_EQ(d.max, 1.0);
  EXPECT_EQ(d.mean, 1.0);
  EXPECT_EQ(total(d.counts), 0);
  const std::vector<Point3> v = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_THROW(conformal_distortion(v, {{0, 1, 2}}, {{0, 0}, {1, 0}}), InternalError);
  EXPECT_THROW(conformal_distortion(v, {{0, 1, 3}}, {{0, 0}, {1, 0}, {0, 1}}), InternalError);
}

}  // namespace
}  // namespace lipmap
