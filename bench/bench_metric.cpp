// The variable metric (paper 5.2) as UV repair: for every shared disk mesh x target kind x seed, a locally
// injective reference map T (the target's certificate g o Tutte when it lives on the source mesh, else the
// pipeline's own answer with optimize none) with 1 to 50 flips injected (interior vertices pushed across a
// neighbour, tests/support/flip_injection.h), mapped with options.metric = T (defaults otherwise) and, for
// comparison, the plain harmonic answer for the same boundary (metric "surface", optimize none). One row each:
// flips, the path taken, inserted vertices, mean |h - T| / chart size of both and their ratio, times; then the
// distribution of the ratios, the inserted counts and a summary line. A row whose pipeline throws prints it.
//
//   bench_metric [--seeds N] [--mesh NAME]... [--max-triangles N] [--kinds all|one] [--pipeline-references]
//
// --kinds one (default) takes one reference map per mesh (the kinds in turn); all takes every kind.
// By default only the certificates serve as reference maps: the pipeline's own answer (optimize none) IS the
// plain harmonic map, so against it the ratio only measures the injected pushes (ours moves the pushed
// vertices less far back than the harmonic map, which never moved: ratios of 2 to 40 in a run of 52 such
// cases). --pipeline-references adds them.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "engine/pipeline.h"
#include "tests/support/flip_injection.h"
#include "tests/support/pipeline_cases.h"

namespace {

using namespace lipmap;
using Clock = std::chrono::steady_clock;
using targetgen::Kind;

double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

struct Reference {
  RawMesh mesh;
  std::vector<Triangle> faces;
  std::vector<int> loop;
  std::vector<Point2> T, positions;
  const char* source = "";
};

bool pipeline_references = false;

bool reference_map(const pipelinecases::LoadedMesh& m, Kind kind, Reference& r) {
  const auto t = targetgen::make_target(kind, pipelinecases::ref(m));
  if (!t || t->rotation_indices) return false;
  if (!t->certificate_on_source && !pipeline_references) return false;
  if (t->certificate_on_source) {
    r.mesh = m.raw;
    r.faces = m.faces;
    r.loop = m.loop;
    r.T = t->certificate_uv;
    r.source = "certificate";
  } else {
    ParametrizeOptions o;
    o.optimize = OptimizeEnergy::none;
    const ParametrizeResult p = parametrize(m.raw, pipelinecases::boundary_of(*t), o);
    r.faces = p.map.faces;
    r.mesh.vertices = p.map.vertices;
    for (const Triangle& f : r.faces) r.mesh.faces.push_back({f[0], f[1], f[2]});
    r.loop = pipelinecases::boundary_loop_of(r.faces, p.map.vertices.size());
    r.T = p.map.uv;
    r.source = "pipeline";
  }
  r.positions.clear();
  for (int v : r.loop) r.positions.push_back(r.T[v]);
  return flipinject::count_folded(r.T, r.faces) == 0;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * (v.size() - 1) + 0.5)];
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 3, max_triangles = 1 << 30;
  bool all_kinds = false;
  std::vector<std::string> only;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seeds" && i + 1 < argc) seeds = std::atoi(argv[++i]);
    else if (a == "--mesh" && i + 1 < argc) only.push_back(argv[++i]);
    else if (a == "--max-triangles" && i + 1 < argc) max_triangles = std::atoi(argv[++i]);
    else if (a == "--kinds" && i + 1 < argc) all_kinds = std::strcmp(argv[++i], "all") == 0;
    else if (a == "--pipeline-references") pipeline_references = true;
    else {
      std::fprintf(stderr, "usage: bench_metric [--seeds N] [--mesh NAME]... [--max-triangles N] [--kinds all|one] [--pipeline-references]\n");
      return 2;
    }
  }
  const std::vector<Kind> kinds = {Kind::exp_strip, Kind::circle, Kind::power_map, Kind::c_shape,
                                   Kind::cubic_map, Kind::spiral_arm, Kind::bent_strip};
  std::printf("%-26s %-11s %-11s %4s %5s %-10s %8s %10s %10s %7s %9s %9s\n", "mesh", "kind", "T from", "seed", "flips",
              "path", "inserted", "ours", "plain", "ratio", "ours ms", "plain ms");
  std::vector<double> ratios, inserted;
  std::map<std::string, int> paths;
  int rows = 0, errors = 0, turn = 0;
  for (const testmeshes::MeshEntry& e : testmeshes::disk_meshes()) {
    if (e.triangles > max_triangles) continue;
    if (!only.empty() && std::find(only.begin(), only.end(), e.name()) == only.end()) continue;
    const pipelinecases::LoadedMesh& m = pipelinecases::load(e);
    if (m.loop.empty()) continue;
    int taken = 0;
    for (std::size_t i = 0; i < kinds.size(); ++i) {
      const Kind kind = kinds[(turn + i) % kinds.size()];
      Reference ref;
      try {
        if (!reference_map(m, kind, ref)) continue;
      } catch (const std::exception& ex) {
        std::printf("%-26s %-11s reference map failed: %s\n", m.name.c_str(), targetgen::kind_name(kind), ex.what());
        continue;
      }
      ++taken;
      ParametrizeOptions plain_options;
      plain_options.optimize = OptimizeEnergy::none;
      const auto t_plain = Clock::now();
      const ParametrizeResult plain = parametrize(ref.mesh, RawBoundary{std::nullopt, ref.positions, std::nullopt}, plain_options);
      const double plain_ms = ms_since(t_plain);
      for (int seed = 1; seed <= seeds; ++seed) {
        std::vector<Point2> T = ref.T;
        const int want = 1 + (seed * 17 + rows * 7) % 50;
        const int flips = flipinject::inject_flips(T, ref.faces, ref.loop, want, 50, static_cast<unsigned>(seed));
        if (flips == 0) continue;
        ParametrizeOptions o;
        o.metric = T;
        const auto t0 = Clock::now();
        ParametrizeResult r;
        try {
          r = parametrize(ref.mesh, RawBoundary{std::nullopt, ref.positions, std::nullopt}, o);
        } catch (const std::exception& ex) {
          std::printf("%-26s %-11s %-11s %4d %5d error: %s\n", m.name.c_str(), targetgen::kind_name(kind), ref.source, seed,
                      flips, ex.what());
          ++errors;
          continue;
        }
        const double ours_ms = ms_since(t0);
        const double ours = flipinject::distance(r.map.uv, T, ref.positions).mean;
        const double theirs = flipinject::distance(plain.map.uv, T, ref.positions).mean;
        const double ratio = ours / theirs;
        ratios.push_back(ratio);
        inserted.push_back(static_cast<double>(r.map.inserted.size()));
        ++paths[r.metric.path];
        ++rows;
        std::printf("%-26s %-11s %-11s %4d %5d %-10s %8zu %10.3g %10.3g %7.3f %9.1f %9.1f\n", m.name.c_str(),
                    targetgen::kind_name(kind), ref.source, seed, flips, r.metric.path.c_str(), r.map.inserted.size(), ours,
                    theirs, ratio, ours_ms, plain_ms);
        std::fflush(stdout);
      }
      if (!all_kinds && taken > 0) break;
    }
    ++turn;
  }
  int half = 0;
  for (double q : ratios) half += q <= 0.5 ? 1 : 0;
  std::printf("\nratio ours / plain (mean distance to T): p10 %.3f  median %.3f  p90 %.3f  max %.3f\n", percentile(ratios, 0.1),
              percentile(ratios, 0.5), percentile(ratios, 0.9), percentile(ratios, 1.0));
  std::printf("inserted vertices: median %.0f  p90 %.0f  max %.0f\n", percentile(inserted, 0.5), percentile(inserted, 0.9),
              percentile(inserted, 1.0));
  std::printf("paths:");
  for (const auto& [p, n] : paths) std::printf(" %s %d", p.c_str(), n);
  std::printf("\nsummary: %d cases, %d errors, ratio <= 0.5 in %d (%.1f%%), median ratio %.3f, median inserted %.0f\n", rows,
              errors, half, rows ? 100.0 * half / rows : 0.0, percentile(ratios, 0.5), percentile(inserted, 0.5));
  return errors ? 1 : 0;
}
