// Shared by the pipeline, untangle and optimize tests: a shared disk mesh loaded with its boundary loop computed here
// from the faces alone (not by the engine), a run of the whole pipeline, and the independent checker
// (map_checker.h) on its answer.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "engine/mesh_io.h"
#include "engine/pipeline.h"
#include "tests/support/map_checker.h"
#include "tests/support/target_generators.h"
#include "tests/support/test_meshes.h"
#include "tests/support/triangulation_checker.h"

namespace lipmap::pipelinecases {

struct LoadedMesh {
  std::string name;
  RawMesh raw;
  std::vector<Point3> vertices;
  std::vector<Triangle> faces;
  std::vector<int> loop;  // interior on the left, from the lowest boundary vertex; empty if not one cycle
};

// An n x n grid of the unit square (each cell cut along its (i, j)-(i+1, j+1) diagonal), z = 0.3 sin(4x) cos(3y):
// a curved disk for the descent tests, whose flat grid squeezed towards a corner is a positive, distorted start.
inline RawMesh bumpy_grid(int n) {
  RawMesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double x = double(i) / n, y = double(j) / n;
      m.vertices.push_back({x, y, 0.3 * std::sin(4 * x) * std::cos(3 * y)});
    }
  auto id = [n](int i, int j) { return j * (n + 1) + i; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

// Faces whose uv triangle is not strictly counterclockwise, by the checkers' own exact orientation.
inline int count_folded_by_checker(const std::vector<Point2>& uv, const std::vector<Triangle>& faces) {
  int n = 0;
  for (const Triangle& t : faces)
    n += testgen::exact::orient({uv[t[0]].x, uv[t[0]].y}, {uv[t[1]].x, uv[t[1]].y}, {uv[t[2]].x, uv[t[2]].y}) > 0 ? 0 : 1;
  return n;
}

// The boundary loop from the faces alone: directed boundary edges (used once, never reversed), followed
// from the lowest boundary vertex. Empty when the boundary is not a single simple cycle.
inline std::vector<int> boundary_loop_of(const std::vector<Triangle>& faces, std::size_t nv) {
  std::map<std::pair<int, int>, int> directed;
  for (const Triangle& t : faces)
    for (int c = 0; c < 3; ++c) ++directed[{t[c], t[(c + 1) % 3]}];
  std::vector<int> next(nv, -1);
  int start = -1;
  std::size_t count = 0;
  for (const auto& [e, n] : directed) {
    if (directed.count({e.second, e.first})) continue;
    if (next[e.first] != -1) return {};
    next[e.first] = e.second;
    ++count;
    if (start < 0 || e.first < start) start = e.first;
  }
  std::vector<int> loop;
  if (start < 0) return loop;
  for (int v = start; loop.size() <= count;) {
    loop.push_back(v);
    v = next[v];
    if (v == start) break;
    if (v < 0) return {};
  }
  if (loop.size() != count) return {};
  return loop;
}

inline const LoadedMesh& load(const testmeshes::MeshEntry& entry) {
  static std::mutex mu;
  static std::map<std::string, std::unique_ptr<LoadedMesh>> cache;
  std::lock_guard<std::mutex> lock(mu);
  auto& slot = cache[entry.path()];
  if (!slot) {
    slot = std::make_unique<LoadedMesh>();
    slot->name = entry.name();
    slot->raw = read_mesh_file(entry.path());
    slot->vertices = slot->raw.vertices;
    for (const auto& f : slot->raw.faces) slot->faces.push_back({int(f[0]), int(f[1]), int(f[2])});
    slot->loop = boundary_loop_of(slot->faces, slot->vertices.size());
  }
  return *slot;
}

inline targetgen::DiskMeshRef ref(const LoadedMesh& m) { return {m.vertices, m.faces, m.loop}; }

inline RawBoundary boundary_of(const targetgen::Target& t) {
  RawBoundary b;
  b.positions = t.positions;
  if (t.rotation_indices) b.rotation_indices = std::vector<long long>(t.rotation_indices->begin(), t.rotation_indices->end());
  return b;
}

// The independent checker on an answer (with the prescribed rotation indices when the target has some).
inline mapcheck::Report check(const LoadedMesh& m, const targetgen::Target& t, const ParametrizeResult& r) {
  mapcheck::Result res{r.map.vertices, r.map.faces, r.map.uv, {}};
  for (const InsertedVertex& v : r.map.inserted) res.inserted.push_back({v.a, v.b, v.t});
  return mapcheck::check_map({m.vertices, m.faces, m.loop}, t.positions, res,
                             t.rotation_indices ? &*t.rotation_indices : nullptr);
}

// K = sigma1 / sigma2 of one triangle's affine map from 3D to uv, computed here from the eigenvalues of
// G^-1 H (first fundamental forms of the 3D and uv triangles in the same edge basis: the squared singular
// values), independently of the engine's formulas; orientation is not looked at. 1 for a 3D triangle of zero
// area (no Jacobian), +inf for a degenerate uv triangle.
inline double unsigned_conformal_distortion(const Point3& a, const Point3& b, const Point3& c, const Point2& ua,
                                            const Point2& ub, const Point2& uc) {
  const long double e1[3] = {b.x - a.x, b.y - a.y, b.z - a.z}, e2[3] = {c.x - a.x, c.y - a.y, c.z - a.z};
  const long double g11 = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2], g12 = e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2],
                    g22 = e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2];
  const long double u1x = ub.x - ua.x, u1y = ub.y - ua.y, u2x = uc.x - ua.x, u2y = uc.y - ua.y;
  const long double h11 = u1x * u1x + u1y * u1y, h12 = u1x * u2x + u1y * u2y, h22 = u2x * u2x + u2y * u2y;
  const long double det_g = g11 * g22 - g12 * g12;
  if (!(det_g > 0)) return 1;
  const long double tr = (g22 * h11 - 2 * g12 * h12 + g11 * h22) / det_g;  // trace of G^-1 H
  const long double det = (h11 * h22 - h12 * h12) / det_g;                  // det of G^-1 H
  const long double disc = std::sqrt(std::max<long double>(tr * tr / 4 - det, 0));
  const long double l1 = tr / 2 + disc, l2 = tr / 2 - disc;
  return l2 > 0 ? static_cast<double>(std::sqrt(l1 / l2)) : std::numeric_limits<double>::infinity();
}

// The same for a map: +inf for a uv triangle that is not positive (floating point).
inline double conformal_distortion_of(const Point3& a, const Point3& b, const Point3& c, const Point2& ua,
                                      const Point2& ub, const Point2& uc) {
  const long double u1x = ub.x - ua.x, u1y = ub.y - ua.y, u2x = uc.x - ua.x, u2y = uc.y - ua.y;
  if (!(u1x * u2y - u1y * u2x > 0)) return std::numeric_limits<double>::infinity();
  return unsigned_conformal_distortion(a, b, c, ua, ub, uc);
}

// Area-weighted mean K of a map of the source mesh itself (no inserted vertices), per face as
// unsigned_conformal_distortion (independently of engine/quality.cpp); faces of zero 3D area are left out.
inline double mean_conformal_distortion(const std::vector<Point3>& p, const std::vector<Triangle>& faces,
                                        const std::vector<Point2>& uv) {
  long double sum = 0, area = 0;
  for (const Triangle& t : faces) {
    const Point3 &a = p[t[0]], &b = p[t[1]], &c = p[t[2]];
    const long double e1[3] = {b.x - a.x, b.y - a.y, b.z - a.z}, e2[3] = {c.x - a.x, c.y - a.y, c.z - a.z};
    const long double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2], cz = e1[0] * e2[1] - e1[1] * e2[0];
    const long double w = std::sqrt(cx * cx + cy * cy + cz * cz) / 2;
    if (!(w > 0)) continue;
    sum += w * unsigned_conformal_distortion(a, b, c, uv[t[0]], uv[t[1]], uv[t[2]]);
    area += w;
  }
  return area > 0 ? static_cast<double>(sum / area) : 1.0;
}

}  // namespace lipmap::pipelinecases
