// The whole engine (engine/pipeline.h) on small meshes whose 3D coordinates and whose boundary positions are
// scaled, separately, by 1e-150 ... 1e150. The problem is invariant under a uniform scale of the mesh and
// scales with the polygon, so every case must give a map that passes the independent checker
// (tests/support/map_checker.h) on the caller's values, or be refused with an InputError: never an
// InternalError or any other exception.
//
// The checker computes areas and angles in (long) double; at 1e+-150 those overflow or underflow. It is run
// on the result and the input multiplied by powers of two (2^-k, exact for normal doubles, so bit-for-bit
// equalities, exact orientations and a + t (b - a) are unchanged) that bring the coordinates near 1.
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/error.h"
#include "engine/pipeline.h"
#include "server/codec/json_codec.h"
#include "tests/support/data_dir.h"
#include "tests/support/map_checker.h"

namespace lipmap {
namespace {

// A w x h grid disk with a bump in z, and its boundary loop (counterclockwise from vertex 0).
struct Case {
  std::string name;
  RawMesh mesh;
  RawBoundary boundary;
};

Case bumped_grid_onto_circle(int w, int h) {
  Case c;
  c.name = "grid" + std::to_string(w) + "x" + std::to_string(h) + "_circle";
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) c.mesh.vertices.push_back({double(i), double(j), 0.3 * std::sin(i + 0.7 * j)});
  for (int j = 0; j + 1 < h; ++j)
    for (int i = 0; i + 1 < w; ++i) {
      const long long a = j * w + i, b = a + 1, d = a + w, e = d + 1;
      c.mesh.faces.push_back({a, b, e});
      c.mesh.faces.push_back({a, e, d});
    }
  std::vector<long long> loop;
  for (int i = 0; i + 1 < w; ++i) loop.push_back(i);
  for (int j = 0; j + 1 < h; ++j) loop.push_back(j * w + w - 1);
  for (int i = w - 1; i > 0; --i) loop.push_back((h - 1) * w + i);
  for (int j = h - 1; j > 0; --j) loop.push_back(j * w);
  c.boundary.vertices = loop;
  const double n = static_cast<double>(loop.size());
  // Off-centre so that the polygon is not symmetric about the origin (a translation, too, must survive).
  for (std::size_t k = 0; k < loop.size(); ++k)
    c.boundary.positions.push_back({3 + std::cos(2 * M_PI * k / n), -1 + 0.8 * std::sin(2 * M_PI * k / n)});
  return c;
}

Case spiral_request() {
  std::ifstream in(data_dir() + "/requests/grid8_spiral.json");
  std::stringstream text;
  text << in.rdbuf();
  const codec::ParametrizeRequest request = codec::parametrize_request_from_json(codec::parse_json(text.str()));
  return {"grid8_spiral", request.mesh, request.boundary};
}

double max_abs(const std::vector<Point3>& v) {
  double m = 0;
  for (const Point3& p : v) m = std::max({m, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  return m;
}
double max_abs(const std::vector<Point2>& v) {
  double m = 0;
  for (const Point2& p : v) m = std::max({m, std::abs(p.x), std::abs(p.y)});
  return m;
}
int exponent_of(double m) {
  int k = 0;
  std::frexp(m, &k);
  return k;
}
Point3 times2(const Point3& p, int k) { return {std::ldexp(p.x, k), std::ldexp(p.y, k), std::ldexp(p.z, k)}; }
Point2 times2(const Point2& p, int k) { return {std::ldexp(p.x, k), std::ldexp(p.y, k)}; }

// Runs the pipeline and the checker (at a power-of-two rescale); returns "" for a checked map, the
// InputError's code for a refusal, and fails the test for anything else.
std::string run_and_check(const RawMesh& mesh, const RawBoundary& boundary, const std::string& what) {
  ParametrizeResult r;
  try {
    r = parametrize(mesh, boundary, ParametrizeOptions{});
  } catch (const InputError& e) {
    return e.code();
  } catch (const std::exception& e) {
    ADD_FAILURE() << what << ": neither a map nor a refusal: " << e.what();
    return "exception";
  }
  const int km = exponent_of(max_abs(mesh.vertices)), kp = exponent_of(max_abs(boundary.positions));
  mapcheck::SourceMesh src;
  for (const Point3& p : mesh.vertices) src.vertices.push_back(times2(p, -km));
  for (const auto& f : mesh.faces) src.faces.push_back({int(f[0]), int(f[1]), int(f[2])});
  src.loop = r.boundary_loop;
  std::vector<Point2> prescribed;
  for (const Point2& p : boundary.positions) prescribed.push_back(times2(p, -kp));
  mapcheck::Result res;
  for (const Point3& p : r.map.vertices) res.vertices.push_back(times2(p, -km));
  for (const Point2& p : r.map.uv) res.uv.push_back(times2(p, -kp));
  res.faces = r.map.faces;
  for (const InsertedVertex& iv : r.map.inserted) res.inserted.push_back({iv.a, iv.b, iv.t});
  // The rescale itself must be exact, or the check below would not speak for the caller's values.
  for (std::size_t v = 0; v < r.map.uv.size(); ++v) EXPECT_EQ(times2(res.uv[v], kp), r.map.uv[v]) << what;
  // Bit for bit on the caller's own values, before any rescale.
  for (std::size_t k = 0; k < r.boundary_loop.size(); ++k)
    EXPECT_EQ(r.map.uv[r.boundary_loop[k]], boundary.positions[k]) << what << ": boundary vertex " << k;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) EXPECT_EQ(r.map.vertices[v], mesh.vertices[v]) << what;
  const mapcheck::Report report = mapcheck::check_map(src, prescribed, res);
  EXPECT_TRUE(report.ok()) << what << "\n" << report.str();
  EXPECT_EQ(r.flipped, 0) << what;
  EXPECT_TRUE(std::isfinite(r.distortion.mean)) << what;
  return "";
}

class ExtremeScale : public ::testing::TestWithParam<int> {};

// Mesh scaled alone, polygon scaled alone, both together: by 10^e.
TEST_P(ExtremeScale, VerifiedMapOrRefusalNeverInternalError) {
  const int e = GetParam();
  const double s = std::pow(10.0, e);
  for (const Case& c : {bumped_grid_onto_circle(5, 4), spiral_request()}) {
    const std::string plain = run_and_check(c.mesh, c.boundary, c.name + " unscaled");
    ASSERT_EQ(plain, "") << c.name << " must map at its own scale";
    RawMesh mesh = c.mesh;
    for (Point3& p : mesh.vertices) p = {p.x * s, p.y * s, p.z * s};
    RawBoundary boundary = c.boundary;
    for (Point2& p : boundary.positions) p = {p.x * s, p.y * s};
    const std::string tag = c.name + " x 1e" + std::to_string(e);
    // Scaling by 1e+-150 keeps every coordinate a normal double with room to spare: all three are servable.
    EXPECT_EQ(run_and_check(mesh, c.boundary, tag + " (mesh)"), "");
    EXPECT_EQ(run_and_check(c.mesh, boundary, tag + " (boundary)"), "");
    EXPECT_EQ(run_and_check(mesh, boundary, tag + " (both)"), "");
  }
}

INSTANTIATE_TEST_SUITE_P(PowersOfTen, ExtremeScale, ::testing::Values(-150, -120, -100, -60, -30, -12, 0, 12, 30, 60, 100, 120, 150),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return (info.param < 0 ? "m" : "p") + std::to_string(std::abs(info.param));
                         });

// At the very ends of the double range the answer may be a refusal, but never an internal error.
TEST(ExtremeScaleLimits, NearTheEndsOfTheDoubleRangeMapOrRefuse) {
  const Case c = bumped_grid_onto_circle(4, 4);
  for (double s : {1e-300, 1e-290, 1e290, 1e300, 1e-305}) {
    RawBoundary boundary = c.boundary;
    for (Point2& p : boundary.positions) p = {p.x * s, p.y * s};
    RawMesh mesh = c.mesh;
    for (Point3& p : mesh.vertices) p = {p.x * s, p.y * s, p.z * s};
    std::ostringstream tag;
    tag << c.name << " x " << s;
    run_and_check(mesh, c.boundary, tag.str() + " (mesh)");
    run_and_check(c.mesh, boundary, tag.str() + " (boundary)");
  }
}

}  // namespace
}  // namespace lipmap
