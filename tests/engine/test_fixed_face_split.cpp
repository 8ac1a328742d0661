// Stage "fixed-face split" (engine/fixed_face_split.h), through the whole pipeline, on generated fans with ears.
//
// The mesh: a convex n-gon P_0 .. P_{n-1} fanned to a centre vertex, with ears (P_i, B_i, P_{i+1}) on some sides:
// each ear is a face whose three corners are boundary vertices, pinned by the polygon, and (P_i, P_{i+1}) is its
// chord. The target polygon: the same n-gon moved, turned and scaled at random, with each B_i pushed outward from
// the side's middle by a fraction eps of the side: thin ears (eps 1e-12 .. 1e-9) are positive in doubles but not
// as float32 texture coordinates, thick ones (eps 1e-3 .. 0.3) are fine. Checked with the independent map checker
// (tests/support/map_checker.h: CGAL's exact orientation, on the rounded floats where float32 is meant):
//   - every answer passes the contract;
//   - exactly one point is inserted per thin ear, on its chord, and none for a thick one;
//   - every face with three boundary corners is strictly positive as stored in float32, (s, 1 - t) read back
//     (the checker's positive_in_float32);
//   - the answer's max K is finite and below 1e6 (a thin ear alone has K near 1 / eps).
#include <cmath>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/pipeline.h"
#include "tests/support/map_checker.h"

namespace lipmap {
namespace {

struct EarCase {
  RawMesh mesh;
  RawBoundary boundary;
  mapcheck::SourceMesh source;
  std::vector<std::pair<int, int>> thin_chords, thick_chords;  // (P_i, P_{i+1}) of thin and thick ears
};

EarCase make_case(std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0, 1);
  const int n = 5 + static_cast<int>(rng() % 8);
  EarCase c;
  auto corner = [&](int i, double r) {
    const double a = 2 * M_PI * i / n;
    return Point2{r * std::cos(a), r * std::sin(a)};
  };
  // Vertices: P_0 .. P_{n-1}, the centre n, then the ears' B_i.
  for (int i = 0; i < n; ++i) c.mesh.vertices.push_back({corner(i, 1).x, corner(i, 1).y, 0.1 * unit(rng)});
  c.mesh.vertices.push_back({0, 0, 0.2});
  const double turn = 2 * M_PI * unit(rng), scale = std::pow(10.0, -2 + 4 * unit(rng));
  const Point2 shift{scale * (6 * unit(rng) - 3), scale * (6 * unit(rng) - 3)};
  auto place = [&](const Point2& p) {
    return Point2{shift.x + scale * (std::cos(turn) * p.x - std::sin(turn) * p.y),
                  shift.y + scale * (std::sin(turn) * p.x + std::cos(turn) * p.y)};
  };
  std::vector<long long> loop;
  std::vector<Point2> positions;
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    c.mesh.faces.push_back({i, j, n});
    loop.push_back(i);
    positions.push_back(place(corner(i, 1)));
    const int kind = static_cast<int>(rng() % 3);  // 0: no ear, 1: thin, 2: thick
    if (kind == 0) continue;
    const Point2 p = corner(i, 1), q = corner(j, 1);
    const Point2 mid{0.5 * (p.x + q.x), 0.5 * (p.y + q.y)};
    const double side = std::hypot(q.x - p.x, q.y - p.y);
    const Point2 out{mid.x / std::hypot(mid.x, mid.y), mid.y / std::hypot(mid.x, mid.y)};
    const int b = static_cast<int>(c.mesh.vertices.size());
    c.mesh.vertices.push_back({mid.x + 0.3 * side * out.x, mid.y + 0.3 * side * out.y, 0});
    c.mesh.faces.push_back({i, b, j});
    loop.push_back(b);
    const double eps = kind == 1 ? std::pow(10.0, -12 + 3 * unit(rng)) : std::pow(10.0, -3 + 2.5 * unit(rng));
    const Point2 pb = place({mid.x + eps * side * out.x, mid.y + eps * side * out.y});
    // Even the thinnest ear is over 1e3 ulps of its coordinates thick: strictly positive in doubles (a valid
    // answer as it stands; only its storage is at stake).
    const Point2 pp = place(p), pq = place(q);
    EXPECT_GT(mapcheck::detail::orient(pp, pb, pq), 0);
    positions.push_back(pb);
    (kind == 1 ? c.thin_chords : c.thick_chords).emplace_back(std::min(i, j), std::max(i, j));
  }
  c.boundary.vertices = loop;
  c.boundary.positions = positions;
  c.source.vertices = c.mesh.vertices;
  for (const auto& f : c.mesh.faces)
    c.source.faces.push_back({static_cast<int>(f[0]), static_cast<int>(f[1]), static_cast<int>(f[2])});
  for (long long v : loop) c.source.loop.push_back(static_cast<int>(v));
  return c;
}

TEST(FixedFaceSplit, ThinEarsGetOnePointOnTheirChordAndAreStorableAsFloat32) {
  std::mt19937 rng(20261207);
  int cases = 0, thin = 0, thick = 0;
  for (int i = 0; i < 300; ++i) {
    const EarCase c = make_case(rng);
    if (c.thin_chords.empty() && c.thick_chords.empty()) continue;
    ++cases;
    thin += static_cast<int>(c.thin_chords.size());
    thick += static_cast<int>(c.thick_chords.size());
    const ParametrizeResult r = parametrize(c.mesh, c.boundary, ParametrizeOptions{});
    mapcheck::Result res{r.map.vertices, r.map.faces, r.map.uv, {}};
    for (const InsertedVertex& iv : r.map.inserted) res.inserted.push_back({iv.a, iv.b, iv.t});
    const mapcheck::Report report = mapcheck::check_map(c.source, c.boundary.positions, res);
    ASSERT_TRUE(report.ok()) << "case " << i << ":\n" << report.str();

    ASSERT_EQ(r.map.inserted.size(), c.thin_chords.size()) << "case " << i;
    for (const auto& [a, b] : c.thin_chords) {
      bool found = false;
      for (const InsertedVertex& iv : r.map.inserted) found = found || (iv.a == a && iv.b == b);
      EXPECT_TRUE(found) << "case " << i << ": no point on the chord (" << a << ", " << b << ")";
    }
    std::vector<char> on_loop(r.map.uv.size(), 0);
    for (int v : c.source.loop) on_loop[v] = 1;
    for (const Triangle& t : r.map.faces)
      if (on_loop[t[0]] && on_loop[t[1]] && on_loop[t[2]])
        EXPECT_TRUE(mapcheck::detail::positive_in_float32(r.map.uv[t[0]], r.map.uv[t[1]], r.map.uv[t[2]]))
            << "case " << i << ": face (" << t[0] << ", " << t[1] << ", " << t[2] << ") as float32";
    EXPECT_LT(r.distortion.max, 1e6) << "case " << i;
  }
  std::cout << "[ ears ] " << cases << " cases, " << thin << " thin ears, " << thick << " thick ears\n";
  EXPECT_GT(thin, 100);
  EXPECT_GT(thick, 100);
}

}  // namespace
}  // namespace lipmap
