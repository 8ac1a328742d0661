// Benchmark of the target-mesh stage (paper 4, "Meshing the target domain"): median over 5 runs for
// boundary polygons of 100..1500 vertices, simple and self-overlapping, at 10k and 50k target triangles.
// Coarse triangulations are built here (ear clipping / strip construction), not by classify, so that the
// numbers are the stage's own. Wall time and thread CPU time are both reported: on a shared machine the
// CPU time is the steadier of the two.
//
//   bench_target_mesh [runs=5]
#include <sys/utsname.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "engine/target_mesh.h"

using namespace lipmap;

namespace {

struct Input {
  std::string name;
  BoundaryPolygon P;
  std::vector<Triangle> coarse;
};

double orient(const Point2& a, const Point2& b, const Point2& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// Ear clipping of a simple counterclockwise polygon (floating-point predicates; fine for these
// well-conditioned shapes). Scans onwards from the last ear, so typical polygons take O(n^2).
std::vector<Triangle> ear_clip(const std::vector<Point2>& p) {
  const int n = static_cast<int>(p.size());
  std::vector<int> next(n), prev(n);
  for (int i = 0; i < n; ++i) next[i] = (i + 1) % n, prev[i] = (i + n - 1) % n;
  std::vector<Triangle> out;
  int cur = 0, remaining = n, guard = 0;
  while (remaining > 3) {
    const int a = prev[cur], b = cur, c = next[cur];
    bool ear = orient(p[a], p[b], p[c]) > 0;
    for (int v = next[c]; ear && v != a; v = next[v])
      if (orient(p[a], p[b], p[v]) >= 0 && orient(p[b], p[c], p[v]) >= 0 && orient(p[c], p[a], p[v]) >= 0) ear = false;
    if (ear) {
      out.push_back({a, b, c});
      next[a] = c, prev[c] = a;
      --remaining;
      cur = a;
      guard = 0;
    } else {
      cur = c;
      if (++guard > 2 * remaining) {
        std::fprintf(stderr, "ear clipping failed\n");
        std::exit(1);
      }
    }
  }
  out.push_back({prev[cur], cur, next[cur]});
  return out;
}

// A wavy star: simple, not convex.
Input simple_star(int n) {
  Input in;
  in.name = "simple star";
  for (int i = 0; i < n; ++i) {
    const double t = 2 * M_PI * i / n;
    const double r = 1.0 + 0.3 * std::sin(7 * t);
    in.P.vertices.push_back({r * std::cos(t), r * std::sin(t)});
  }
  in.coarse = ear_clip(in.P.vertices);
  return in;
}

// A strip of triangles bent through 1.5 turns with a slowly growing radius: self-overlapping.
Input spiral_strip(int n) {
  Input in;
  in.name = "spiral strip";
  const int m = n / 2 - 1;  // n = 2 (m + 1)
  std::vector<Point2> inner, outer;
  for (int j = 0; j <= m; ++j) {
    const double t = 2 * M_PI * 1.5 * j / m, g = 0.4 * t / (2 * M_PI);
    inner.push_back({(1.0 + g) * std::cos(t), (1.0 + g) * std::sin(t)});
    outer.push_back({(2.0 + g) * std::cos(t), (2.0 + g) * std::sin(t)});
  }
  // Polygon: outer rail forwards (ids 0..m), inner rail backwards (ids m+1..2m+1).
  for (int j = 0; j <= m; ++j) in.P.vertices.push_back(outer[j]);
  for (int j = m; j >= 0; --j) in.P.vertices.push_back(inner[j]);
  auto O = [&](int j) { return j; };
  auto I = [&](int j) { return 2 * m + 1 - j; };
  for (int j = 0; j < m; ++j) {
    in.coarse.push_back({I(j), O(j), O(j + 1)});
    in.coarse.push_back({I(j), O(j + 1), I(j + 1)});
  }
  return in;
}

// A fan around a hub sweeping 1.4 turns: weakly self-overlapping (the hub is singular).
Input hub_fan(int n) {
  Input in;
  in.name = "hub fan 1.4 turns";
  const int m = n - 2;  // rim 0..m, hub m+1
  for (int i = 0; i <= m; ++i) {
    const double t = 2 * M_PI * 1.4 * i / m, r = 1.0 + 0.2 * std::sin(5 * t);
    in.P.vertices.push_back({r * std::cos(t), r * std::sin(t)});
  }
  in.P.vertices.push_back({0, 0});
  for (int i = 0; i < m; ++i) in.coarse.push_back({m + 1, i, i + 1});
  return in;
}

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int runs = argc > 1 ? std::max(1, std::atoi(argv[1])) : 5;
  utsname u{};
  uname(&u);
  double load[3] = {0, 0, 0};
  if (getloadavg(load, 3) < 0) load[0] = -1;
  std::printf("machine: %s %s %s %s, nproc %u, load average %.2f\n", u.sysname, u.release, u.version, u.machine,
              std::thread::hardware_concurrency(), load[0]);
  std::printf("target mesh stage, median of %d runs (wall ms and thread CPU ms)\n\n", runs);
  std::printf("%-18s %5s %7s %7s %6s %6s %8s %8s %8s %8s %8s %8s\n", "polygon", "n", "target", "faces", "pieces",
              "splits", "wall", "cpu", "part", "mesh", "verify", "minang");
  for (int n : {100, 500, 1000, 1500}) {
    for (auto make : {simple_star, spiral_strip, hub_fan}) {
      const Input in = make(n);
      for (int target : {10000, 50000}) {
        TargetMeshOptions o;
        o.source_triangles = target;
        std::vector<double> wall, cpu, part, mesh, verify;
        TargetMesh m;
        for (int r = 0; r < runs; ++r) {
          const double c0 = thread_cpu_ms();
          const auto w0 = std::chrono::steady_clock::now();
          m = build_target_mesh(in.P, in.coarse, o);
          wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - w0).count());
          cpu.push_back(thread_cpu_ms() - c0);
          part.push_back(m.partition_ms);
          mesh.push_back(m.mesh_ms);
          verify.push_back(m.verify_ms);
        }
        std::printf("%-18s %5zu %7d %7zu %6d %6d %8.1f %8.1f %8.1f %8.1f %8.1f %8.1f\n", in.name.c_str(),
                    in.P.vertices.size(), target, m.faces.size(), m.pieces, m.interior_edge_splits, median(wall),
                    median(cpu), median(part), median(mesh), median(verify), m.min_angle_deg);
        std::fflush(stdout);
      }
    }
  }
  return 0;
}
