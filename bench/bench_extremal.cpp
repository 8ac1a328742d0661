// Method extremal (paper 5.3) beside the harmonic method: a square grid onto a cross (the paper's Fig. 18
// setting) and every shared disk mesh onto generated targets (circle, c_shape, exp_strip, weak_fan). Both
// methods run with optimize none (the maps as the methods make them). One row per case: total time, max K,
// area-weighted mean K, and over the triangles at least 2 rings from the boundary max K / mean K; medians
// and a summary line at the end. K = sigma1 / sigma2 per triangle (engine/quality.h). start: the relaxed
// start method extremal kept (teich: the Teichmuller map, harm: the harmonic method's map). h movK / e movK:
// max K over the faces with a corner off the boundary; fixedK: max K over faces with three boundary corners
// (the same in both maps, no vertex move changes it); a case whose worst face is such a face is noted.
// starLB: a lower bound on max K two rings in for every locally injective map of the (refined) mesh, from the
// angle sums of single vertex stars (tests/support/star_bound.h); where it exceeds 1.5 x the map's inner mean K, inner
// max / mean <= 1.5 would take a map with a higher mean K.
//
//   bench_extremal [--reps N] [--mesh NAME]... [--kind TARGET]... [--budget-s S]
//
// --mesh and --kind keep only the named meshes and target kinds (circle, c_shape, exp_strip, weak_fan; cross
// for the square grids).
// Times are the median of N runs (default 1). Each run gets S seconds (default 60) through the CancelToken.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "../tests/support/star_bound.h"
#include "../tests/support/target_generators.h"
#include "engine/cancel.h"
#include "engine/error.h"
#include "engine/mesh_io.h"
#include "engine/pipeline.h"
#include "tests/support/test_meshes.h"

namespace {

using Clock = std::chrono::steady_clock;
using lipmap::MapMethod;
using lipmap::Point2;
using lipmap::Point3;
using lipmap::Triangle;
using lipmap::targetgen::Kind;

double median(std::vector<double> v) {
  if (v.empty()) return -1;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// The boundary loop from the faces (directed edges used once), from the lowest boundary vertex.
std::vector<int> boundary_loop(const std::vector<Triangle>& faces, std::size_t nv) {
  std::map<std::pair<int, int>, int> directed;
  for (const Triangle& t : faces)
    for (int c = 0; c < 3; ++c) ++directed[{t[c], t[(c + 1) % 3]}];
  std::vector<int> next(nv, -1);
  int start = -1;
  for (const auto& [e, n] : directed) {
    if (directed.count({e.second, e.first})) continue;
    next[e.first] = e.second;
    if (start < 0 || e.first < start) start = e.first;
  }
  std::vector<int> loop;
  for (int v = start; v >= 0 && loop.size() < nv;) {
    loop.push_back(v);
    v = next[v];
    if (v == start) break;
  }
  return loop;
}

struct Stats {
  bool ok = false;
  std::string error;
  double ms = 0, max_k = 0, mean_k = 0, inner_ratio = 0, k = 0;
  double star_lb = 1, star_lb_ratio = 1;  // star_bound's largest value two rings in, and over the inner mean K
  double fixed_max = 1, movable_max = 1;  // max K over faces with three boundary corners / the other faces
  std::string start;                      // extremal: the relaxed start kept
  int inserted = 0;
};

// Faces whose three corners are boundary vertices have the polygon's uv and the mesh's 3D shape in every map
// (no vertex move changes their K): max K over them, and over the other faces.
void fixed_and_movable(const lipmap::ParametrizeResult& r, Stats& s) {
  std::vector<char> on_loop(r.map.uv.size(), 0);
  for (int v : r.boundary_loop) on_loop[v] = 1;
  s.fixed_max = s.movable_max = 1;
  for (std::size_t f = 0; f < r.map.faces.size(); ++f) {
    const Triangle& t = r.map.faces[f];
    double& m = on_loop[t[0]] && on_loop[t[1]] && on_loop[t[2]] ? s.fixed_max : s.movable_max;
    m = std::max(m, r.distortion.per_face[f]);
  }
}

// max K / mean K over faces whose corners are all at least 2 edges from the boundary; star_lb: the largest
// star_bound over the vertices at least 3 edges from the boundary (their stars are such faces), and its ratio to
// the map's mean K over those faces.
double inner_ratio(const lipmap::ParametrizeResult& r, double* star_lb = nullptr, double* star_lb_ratio = nullptr) {
  const auto& faces = r.map.faces;
  const std::vector<int> dist = lipmap::starbound::ring_distances(r.map.vertices.size(), faces);
  double mx = 1, sum = 0, area = 0;
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const Triangle& t = faces[f];
    if (std::min({dist[t[0]], dist[t[1]], dist[t[2]]}) < 2) continue;
    const Point3 &a = r.map.vertices[t[0]], &b = r.map.vertices[t[1]], &c = r.map.vertices[t[2]];
    const double e1[3] = {b.x - a.x, b.y - a.y, b.z - a.z}, e2[3] = {c.x - a.x, c.y - a.y, c.z - a.z};
    const double w = 0.5 * std::sqrt(std::pow(e1[1] * e2[2] - e1[2] * e2[1], 2) + std::pow(e1[2] * e2[0] - e1[0] * e2[2], 2) +
                                     std::pow(e1[0] * e2[1] - e1[1] * e2[0], 2));
    const double k = r.distortion.per_face[f];
    mx = std::max(mx, k);
    sum += w * k;
    area += w;
  }
  if (star_lb) {
    *star_lb = lipmap::starbound::largest_star_bound(r.map.vertices, faces, dist, 3);
    if (star_lb_ratio) *star_lb_ratio = area > 0 ? *star_lb / (sum / area) : 1;
  }
  return area > 0 ? mx / (sum / area) : 1;
}

Stats run(const lipmap::RawMesh& mesh, const std::vector<Point2>& positions, const std::optional<std::vector<int>>& rot,
          MapMethod method, int reps, double budget_s) {
  Stats s;
  lipmap::RawBoundary b;
  b.positions = positions;
  if (rot) b.rotation_indices = std::vector<long long>(rot->begin(), rot->end());
  lipmap::ParametrizeOptions o;
  o.method = method;
  o.optimize = lipmap::OptimizeEnergy::none;
  std::vector<double> times;
  for (int i = 0; i < reps; ++i) {
    lipmap::CancelToken token;
    token.set_deadline(Clock::now() + std::chrono::milliseconds(static_cast<long long>(budget_s * 1000)));
    try {
      const lipmap::ParametrizeResult r = lipmap::parametrize(mesh, b, o, &token);
      times.push_back(r.timings.total);
      s.max_k = r.distortion.max;
      s.mean_k = r.distortion.mean;
      s.inner_ratio = inner_ratio(r, &s.star_lb, &s.star_lb_ratio);
      s.inserted = static_cast<int>(r.map.inserted.size());
      s.k = r.extremal.k;
      s.start = r.extremal.relaxation.start;
      fixed_and_movable(r, s);
      s.ok = true;
    } catch (const std::exception& e) {
      s.ok = false;
      s.error = e.what();
      return s;
    }
  }
  s.ms = median(times);
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 1;
  double budget_s = 60;
  std::vector<std::string> only, only_kinds;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--reps") && i + 1 < argc) reps = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--mesh") && i + 1 < argc) only.push_back(argv[++i]);
    else if (!std::strcmp(argv[i], "--kind") && i + 1 < argc) only_kinds.push_back(argv[++i]);
    else if (!std::strcmp(argv[i], "--budget-s") && i + 1 < argc) budget_s = std::max(1.0, std::atof(argv[++i]));
    else {
      std::printf("usage: %s [--reps N] [--mesh NAME]... [--kind TARGET]... [--budget-s S]\n", argv[0]);
      return 2;
    }
  }
  std::printf("bench_extremal: %d rep%s, optimize none; times in ms (median); inner = max K / mean K 2 rings in\n", reps,
              reps == 1 ? "" : "s");
  std::printf("%-34s %9s %9s %8s %8s %7s %7s %7s %7s %7s %6s %6s %5s %9s %9s %9s %s\n", "case", "harm ms", "extr ms",
              "harm maxK", "extr maxK", "h meanK", "e meanK", "h inner", "e inner", "starLB", "k", "ins", "start", "h movK",
              "e movK", "fixedK", "note");
  std::vector<double> time_ratio, h_inner, e_inner, h_max, e_max;
  int cases = 0, lower_max = 0, failed = 0, fixed_worst = 0, lower_movable = 0, inner_ok = 0, star_forced = 0;
  std::vector<std::string> not_lower;
  auto row = [&](const std::string& name, const lipmap::RawMesh& mesh, const std::vector<Point2>& positions,
                 const std::optional<std::vector<int>>& rot) {
    const Stats h = run(mesh, positions, rot, MapMethod::harmonic, reps, budget_s);
    const Stats e = run(mesh, positions, rot, MapMethod::extremal, reps, budget_s);
    if (!h.ok || !e.ok) {
      std::printf("%-34s failed: %s\n", name.c_str(), (!h.ok ? h.error : e.error).c_str());
      ++failed;
      return;
    }
    // A worst face with three boundary corners is in both maps (the same K): no vertex move can lower max K;
    // then the faces with a corner off the boundary are compared.
    const bool fixed = e.max_k >= h.max_k && h.fixed_max >= h.max_k && e.fixed_max >= e.max_k;
    const char* note = e.max_k < h.max_k ? "lower" : fixed ? "worst face fixed (3 boundary corners)" : "NOT LOWER";
    std::printf("%-34s %9.1f %9.1f %8.3f %8.3f %7.3f %7.3f %7.3f %7.3f %7.3f %6.3f %6d %5s %9.3f %9.3f %9.3f %s\n",
                name.c_str(), h.ms, e.ms, h.max_k, e.max_k, h.mean_k, e.mean_k, h.inner_ratio, e.inner_ratio, e.star_lb, e.k,
                e.inserted, e.start == "harmonic" ? "harm" : "teich", h.movable_max, e.movable_max, h.fixed_max, note);
    ++cases;
    lower_max += e.max_k < h.max_k;
    fixed_worst += e.max_k >= h.max_k && fixed;
    lower_movable += e.movable_max < h.movable_max;
    inner_ok += e.inner_ratio <= 1.5;
    star_forced += e.inner_ratio > 1.5 && e.star_lb_ratio > 1.5;
    if (!(e.max_k < h.max_k) && !fixed) not_lower.push_back(name);
    time_ratio.push_back(e.ms / h.ms);
    h_inner.push_back(h.inner_ratio);
    e_inner.push_back(e.inner_ratio);
    h_max.push_back(h.max_k);
    e_max.push_back(e.max_k);
  };
  auto wanted = [&](const std::string& name) {
    return only.empty() || std::find(only.begin(), only.end(), name) != only.end();
  };
  auto wanted_kind = [&](const std::string& kind) {
    return only_kinds.empty() || std::find(only_kinds.begin(), only_kinds.end(), kind) != only_kinds.end();
  };

  // The square grid onto the cross (12 unit edges), loop vertices by arc length, corners on corners.
  for (int n : {24, 48}) {
    const std::string name = "square" + std::to_string(n);
    if (!wanted(name) || !wanted_kind("cross")) continue;
    lipmap::RawMesh mesh;
    std::vector<Triangle> faces;
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) mesh.vertices.push_back({double(i) / n, double(j) / n, 0});
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const int a = j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
        if ((i + j) % 2) faces.push_back({a, b, c}), faces.push_back({a, c, d});
        else faces.push_back({a, b, d}), faces.push_back({b, c, d});
      }
    for (const Triangle& t : faces) mesh.faces.push_back({t[0], t[1], t[2]});
    const std::vector<int> loop = boundary_loop(faces, mesh.vertices.size());
    static const Point2 cross[12] = {{1, 0}, {2, 0}, {2, 1}, {3, 1}, {3, 2}, {2, 2}, {2, 3}, {1, 3}, {1, 2}, {0, 2}, {0, 1}, {1, 1}};
    std::vector<Point2> positions(loop.size());
    for (std::size_t k = 0; k < loop.size(); ++k) {
      const double s = 12.0 * double(k) / double(loop.size());
      const int e = std::min(11, int(std::floor(s)));
      const double t = s - e;
      const Point2 &p = cross[e], &q = cross[(e + 1) % 12];
      positions[k] = t == 0 ? p : Point2{p.x + t * (q.x - p.x), p.y + t * (q.y - p.y)};
    }
    row(name + " / cross", mesh, positions, std::nullopt);
  }

  for (const lipmap::testmeshes::MeshEntry& entry : lipmap::testmeshes::disk_meshes()) {
    if (entry.extra || entry.long_boundary || !wanted(entry.name())) continue;
    const lipmap::RawMesh raw = lipmap::read_mesh_file(entry.path());
    std::vector<Point3> vertices = raw.vertices;
    std::vector<Triangle> faces;
    for (const auto& f : raw.faces) faces.push_back({int(f[0]), int(f[1]), int(f[2])});
    const std::vector<int> loop = boundary_loop(faces, vertices.size());
    for (Kind kind : {Kind::circle, Kind::c_shape, Kind::exp_strip, Kind::weak_fan}) {
      if (!wanted_kind(lipmap::targetgen::kind_name(kind))) continue;
      const auto t = lipmap::targetgen::make_target(kind, {vertices, faces, loop});
      if (!t) continue;
      row(entry.name() + " / " + lipmap::targetgen::kind_name(kind), raw, t->positions, t->rotation_indices);
    }
  }
  std::printf("summary: %d cases (%d failed); max K lower than harmonic in %d, worst face fixed in both (3 boundary "
              "corners, same K) in %d, neither in %d; max K over faces with a corner off the boundary lower in %d; "
              "median time extremal / harmonic %.2f; median max K harmonic %.3f, extremal %.3f; median inner max/mean "
              "harmonic %.3f, extremal %.3f; inner max/mean <= 1.5 in %d; of the others, a vertex's star forces K above 1.5 x "
              "the inner mean (starLB) in %d\n",
              cases, failed, lower_max, fixed_worst, static_cast<int>(not_lower.size()), lower_movable,
              median(time_ratio), median(h_max), median(e_max), median(h_inner), median(e_inner), inner_ok, star_forced);
  for (const std::string& n : not_lower) std::printf("not lower: %s\n", n.c_str());
  return failed ? 1 : 0;
}
