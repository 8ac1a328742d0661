// Quality benchmark of the default pipeline against the by-construction certificates of
// tests/support/target_generators.h: for every shared disk mesh x every by-construction kind (exp_strip,
// power_map, cubic_map, bent_strip) x seeds, one row with the certificate's inserted count and mean K beside
// ours, the composed map's flips, and the time per stage.
//
//   bench_quality [--seeds N] [--mesh NAME]... [--budget-s S] [--baseline] [--optimize NAME]
//                 [--max-iterations N] [--all-kinds] [--kind NAME]... [--prescribed]
//
// Seeds: seed 0 is the generator's target as it is; seed s > 0 applies an orientation-preserving linear map
// A_s (a rotation, an anisotropic stretch of 1.15 .. 1.6, another rotation; std::mt19937 seeded with s) to the
// prescribed positions AND to the certificate, which stays a locally injective map of the same mesh (A_s
// keeps every triangle's orientation and every angle sum; checked again exactly after rounding). So each seed
// is a different target with a known unrefined map.
// The certificate is g o Tutte of the source mesh itself when the generator could build it there
// ("on source"): 0 inserted vertices, and its mean K is comparable with ours. When the generator had to build
// it on its own polar disk mesh it proves only that the boundary is self-overlapping: such rows show "-" and
// stay out of the comparisons of the summary.
// --baseline runs the pipeline as it was before untangling and optimization existed (untangle off, optimize
// none): the "before" figures. Each row gets S seconds (default 30) through the CancelToken: "timeout".
// --all-kinds adds the kinds without a certificate on the source (circle, c_shape, spiral_arm: simple polygons;
// weak_fan: weakly self-overlapping): their rows show "-" and stay out of the comparisons, but count for the
// time and inserted-count figures (the maze onto a simple spiral is the classic runaway case).
// --kind NAME (repeatable) keeps only those kinds (any of the above).
// --prescribed gives weak_fan's rotation indices as the generator made them (R = 1 at the hub) in the request,
// as a client who knows them would; without it the classification finds indices of its own (any that make the
// polygon weakly self-overlapping), which can be a different map problem.
// Mean K: area-weighted mean of K = sigma1 / sigma2 (engine/quality.h), the same measure for both.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "../tests/support/target_generators.h"
#include "chord_bound.h"
#include "engine/cancel.h"
#include "engine/classify.h"
#include "engine/error.h"
#include "engine/flip_check.h"
#include "engine/extremal_relax.h"
#include "engine/mesh_io.h"
#include "engine/pipeline.h"
#include "engine/quality.h"
#include "engine/validate.h"
#include "tests/support/test_meshes.h"

namespace {

using Clock = std::chrono::steady_clock;
using lipmap::Point2;
using lipmap::Point3;
using lipmap::Triangle;
using lipmap::targetgen::Kind;

std::string default_data_dir() { return LIPMAP_DATA_DIR; }

double median(std::vector<double> v) {
  if (v.empty()) return -1;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// A_s: rotation(a) * diag(l, 1 / l) * rotation(b); identity for seed 0.
struct Linear {
  double a = 1, b = 0, c = 0, d = 1;
  Point2 operator()(const Point2& p) const { return {a * p.x + b * p.y, c * p.x + d * p.y}; }
};
Linear seeded_map(int seed) {
  if (seed == 0) return {};
  std::mt19937 rng(static_cast<unsigned>(seed));
  std::uniform_real_distribution<double> angle(0, 2 * 3.14159265358979323846), stretch(1.15, 1.6);
  const double t1 = angle(rng), t2 = angle(rng), l = stretch(rng);
  const double c1 = std::cos(t1), s1 = std::sin(t1), c2 = std::cos(t2), s2 = std::sin(t2);
  // [[c1, -s1], [s1, c1]] * [[l, 0], [0, 1/l]] * [[c2, -s2], [s2, c2]]
  const double m00 = c1 * l, m01 = -s1 / l, m10 = s1 * l, m11 = c1 / l;
  return {m00 * c2 + m01 * s2, -m00 * s2 + m01 * c2, m10 * c2 + m11 * s2, -m10 * s2 + m11 * c2};
}

struct Row {
  std::string mesh, kind, error;
  int seed = 0;
  bool cert_on_source = false;
  double cert_mean_k = -1, mean_k = -1, max_k = -1, mean_k_before_opt = -1;
  // max K over the answer's faces with three boundary corners (-1: none): their uv is the polygon's, so no
  // vertex move changes them, and splitting their chords would insert points the contract calls removable
  // (docs/contract.md, point 6). A row whose max K is one of these shows why no allowed map does better.
  double pinned_max_k = -1;
  long long chord_bound = -1;  // bench/chord_bound.h on the answer's triangulation of P (-1: no answer)
  long long inserted = -1;
  int flips_before = -1, flips_after_untangle = -1, iterations = 0;
  bool untangled = false;
  std::string untangle_outcome;
  double t_untangle = 0, t_refine = 0, t_optimize = 0, total = 0;
};

}  // namespace

int main(int argc, char** argv) {
  int seeds = 3;
  double budget_s = 30;
  bool baseline = false;
  bool all_kinds = false;
  bool prescribed = false;
  std::vector<std::string> only, only_kinds;
  lipmap::ParametrizeOptions options;
  std::string data = default_data_dir();
  if (const char* env = std::getenv("LIPMAP_DATA_DIR"); env && *env) data = env;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--seeds") && i + 1 < argc) seeds = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--mesh") && i + 1 < argc) only.push_back(argv[++i]);
    else if (!std::strcmp(argv[i], "--budget-s") && i + 1 < argc) budget_s = std::max(1.0, std::atof(argv[++i]));
    else if (!std::strcmp(argv[i], "--baseline")) baseline = true;
    else if (!std::strcmp(argv[i], "--all-kinds")) all_kinds = true;
    else if (!std::strcmp(argv[i], "--prescribed")) prescribed = true;
    else if (!std::strcmp(argv[i], "--kind") && i + 1 < argc) only_kinds.push_back(argv[++i]);
    else if (!std::strcmp(argv[i], "--optimize") && i + 1 < argc) {
      if (!lipmap::parse_optimize_energy(argv[++i], options.optimize)) {
        std::printf("unknown energy %s\n", argv[i]);
        return 2;
      }
    } else if (!std::strcmp(argv[i], "--max-iterations") && i + 1 < argc) options.max_iterations = std::atoi(argv[++i]);
    else {
      std::printf("usage: %s [--seeds N] [--mesh NAME]... [--budget-s S] [--baseline] [--optimize NAME] "
                  "[--max-iterations N] [--all-kinds] [--kind NAME]... [--prescribed]\n", argv[0]);
      return 0;
    }
  }
  // The kinds each mesh gets: --kind's, else the certified ones (--all-kinds: every one).
  std::vector<Kind> kinds;
  for (const std::string& name : only_kinds) {
    const std::vector<Kind>& every = lipmap::targetgen::all_kinds();
    const auto k =
        std::find_if(every.begin(), every.end(), [&](Kind x) { return name == lipmap::targetgen::kind_name(x); });
    if (k == every.end()) {
      std::printf("unknown kind %s\n", name.c_str());
      return 2;
    }
    kinds.push_back(*k);
  }
  if (kinds.empty())
    kinds = all_kinds ? lipmap::targetgen::all_kinds()
                      : std::vector<Kind>{Kind::exp_strip, Kind::power_map, Kind::cubic_map, Kind::bent_strip};
  if (baseline) {
    options.untangle = false;
    options.optimize = lipmap::OptimizeEnergy::none;
  }
  std::printf("bench_quality: %s%s; %d seed%s; budget %.0f s per row; times in ms\n",
              baseline ? "baseline (untangle off, optimize none)"
                       : (std::string("untangle on, optimize ") + lipmap::to_string(options.optimize) +
                          ", max_iterations " + std::to_string(options.max_iterations)).c_str(),
              prescribed ? "; weak_fan's rotation indices prescribed" : "",
              seeds, seeds == 1 ? "" : "s", budget_s);
  std::printf("\n%-26s %-10s %4s %4s %6s %6s %7s %9s %9s %9s %9s %6s %7s %7s %5s %9s %9s %9s %9s %9s\n", "model", "kind",
              "seed", "cert", "c.ins", "ins", "chordLB", "c.meanK", "meanK", "maxK", "pinnedK", "ratio", "flips", "left", "iter", "untangle",
              "refine", "optimize", "total", "meanK0");
  std::vector<Row> rows;
  for (const lipmap::testmeshes::MeshEntry& entry : lipmap::testmeshes::disk_meshes()) {
    const std::string name = entry.name();
    if (!only.empty() && std::find(only.begin(), only.end(), name) == only.end()) continue;
    lipmap::RawMesh raw;
    lipmap::DiskMesh mesh;
    try {
      raw = lipmap::read_mesh_file(entry.extra ? entry.file : data + "/meshes/" + entry.file);
      mesh = lipmap::validate_mesh(raw);
    } catch (const std::exception& e) {
      std::printf("%-26s cannot read: %s\n", name.c_str(), e.what());
      continue;
    }
    const lipmap::targetgen::DiskMeshRef ref{mesh.vertices, mesh.faces, mesh.boundary_loop};
    for (Kind kind : kinds) {
      std::string why;
      const auto target = lipmap::targetgen::make_target(kind, ref, &why);
      if (!target) {
        std::printf("%-26s %-10s no target: %s\n", name.c_str(), lipmap::targetgen::kind_name(kind), why.substr(0, 120).c_str());
        continue;
      }
      for (int seed = 0; seed < seeds; ++seed) {
        Row r;
        r.mesh = name;
        r.kind = lipmap::targetgen::kind_name(kind);
        r.seed = seed;
        const Linear A = seeded_map(seed);
        lipmap::RawBoundary b;
        for (const Point2& p : target->positions) b.positions.push_back(A(p));
        if (prescribed && target->rotation_indices) {
          b.vertices.emplace(mesh.boundary_loop.begin(), mesh.boundary_loop.end());
          b.rotation_indices.emplace(target->rotation_indices->begin(), target->rotation_indices->end());
        }
        if (target->certificate_on_source) {
          std::vector<Point2> cert;
          for (const Point2& p : target->certificate_uv) cert.push_back(A(p));
          // The certificate's boundary is the prescribed positions (same doubles, same map A).
          r.cert_on_source = lipmap::count_non_positive(cert, mesh.faces) == 0;
          if (r.cert_on_source) r.cert_mean_k = lipmap::conformal_distortion(mesh.vertices, mesh.faces, cert).mean;
        }
        lipmap::CancelToken token;
        token.set_deadline(Clock::now() + std::chrono::milliseconds(static_cast<long long>(budget_s * 1000)));
        try {
          const lipmap::ParametrizeResult res = lipmap::parametrize(raw, b, options, &token);
          r.inserted = static_cast<long long>(res.map.inserted.size());
          r.chord_bound = lipmap::bench::chord_lower_bound(mesh, res.polygon.vertices, res.classification.triangulation,
                                                           res.classification.verdict == lipmap::Verdict::simple)
                              .points;
          r.mean_k = res.distortion.mean;
          r.max_k = res.distortion.max;
          std::vector<char> on_loop(res.map.uv.size(), 0);
          for (int v : res.boundary_loop) on_loop[static_cast<std::size_t>(v)] = 1;
          for (std::size_t f = 0; f < res.map.faces.size() && f < res.distortion.per_face.size(); ++f)
            if (lipmap::pinned_by_boundary(res.map.faces[f], on_loop))
              r.pinned_max_k = std::max(r.pinned_max_k, res.distortion.per_face[f]);
          r.mean_k_before_opt = res.optimization.ran ? res.optimization.before.mean : res.distortion.mean;
          r.flips_before = res.relocation.flipped_before;
          r.flips_after_untangle = res.untangling.attempted ? res.untangling.flipped_after : res.relocation.flipped_after;
          r.untangled = res.untangling.succeeded;
          r.untangle_outcome = res.untangling.outcome;
          if (res.map.regions > 0)
            r.untangle_outcome += "; refined in " + std::to_string(res.map.regions) + " regions around the folds (" +
                                  std::to_string(res.map.region_faces) + " faces)";
          if (res.optimization.points_removed > 0)
            r.untangle_outcome += "; the optimizer's free descent left " + std::to_string(res.optimization.points_removed) +
                                  " inserted points removable, removed";
          r.iterations = res.optimization.iterations;
          r.t_untangle = res.timings.untangle;
          r.t_refine = res.timings.refine;
          r.t_optimize = res.timings.optimize;
          r.total = res.timings.total;
        } catch (const lipmap::Cancelled&) {
          r.error = "timeout (" + std::to_string(static_cast<int>(budget_s)) + " s)";
        } catch (const std::exception& e) {
          r.error = e.what();
        }
        if (!r.error.empty()) {
          // No answer (a timeout): the bound of the polygon's own classification. (An answer's triangulation is
          // the one to use when there is one: with its rotation indices placed, a weakly self-overlapping
          // polygon's can differ.)
          try {
            lipmap::BoundaryPolygon polygon{b.positions, std::nullopt};
            if (b.rotation_indices) polygon.rotation_indices.emplace(b.rotation_indices->begin(), b.rotation_indices->end());
            const lipmap::Classification c = lipmap::classify(polygon);
            if (c.verdict != lipmap::Verdict::not_self_overlapping)
              r.chord_bound = lipmap::bench::chord_lower_bound(mesh, b.positions, c.triangulation,
                                                               c.verdict == lipmap::Verdict::simple).points;
          } catch (const std::exception&) {
          }
          std::printf("%-26s %-10s %4d error: %s", name.c_str(), r.kind.c_str(), seed, r.error.substr(0, 200).c_str());
          if (r.chord_bound >= 0) std::printf(" (chordLB %lld)", r.chord_bound);
          std::printf("\n");
        } else {
          char cert_ins[16] = "-", cert_k[32] = "-", ratio[32] = "-";
          if (r.cert_on_source) {
            std::snprintf(cert_ins, sizeof cert_ins, "0");
            std::snprintf(cert_k, sizeof cert_k, "%.3g", r.cert_mean_k);
            std::snprintf(ratio, sizeof ratio, "%.2f", r.mean_k / r.cert_mean_k);
          }
          if ((r.inserted > 0 || r.untangled) && !r.untangle_outcome.empty()) std::printf("   untangle: %s\n", r.untangle_outcome.c_str());
          char pinned_k[32] = "-";
          if (r.pinned_max_k >= 0) std::snprintf(pinned_k, sizeof pinned_k, "%.3g", r.pinned_max_k);
          char chord_lb[16] = "-";
          if (r.chord_bound >= 0) std::snprintf(chord_lb, sizeof chord_lb, "%lld", r.chord_bound);
          std::printf("%-26s %-10s %4d %4s %6s %6lld %7s %9s %9.3g %9.3g %9s %6s %7d %7d %5d %9.1f %9.1f %9.1f %9.1f %9.3g\n",
                      name.c_str(), r.kind.c_str(), seed, r.cert_on_source ? "src" : "poly", cert_ins, r.inserted, chord_lb, cert_k,
                      r.mean_k, r.max_k, pinned_k, ratio, r.flips_before, r.flips_after_untangle, r.iterations, r.t_untangle,
                      r.t_refine, r.t_optimize, r.total, r.mean_k_before_opt);
        }
        std::fflush(stdout);
        rows.push_back(r);
      }
    }
  }

  // ---- summary ----
  int comparable = 0, within = 0, over5 = 0, errors = 0, over30 = 0, zero_ins = 0;
  long long excess = 0;
  std::vector<double> ratios;
  const Row* worst_ratio = nullptr;
  const Row* worst_excess = nullptr;
  const Row* slowest = nullptr;
  const Row* most_inserted = nullptr;
  const Row* largest_max_k = nullptr;
  for (const Row& r : rows) {
    if (!r.error.empty()) {
      ++errors;
      continue;
    }
    if (r.total > 30000) ++over30;
    if (!slowest || r.total > slowest->total) slowest = &r;
    if (!most_inserted || r.inserted > most_inserted->inserted) most_inserted = &r;
    if (!largest_max_k || r.max_k > largest_max_k->max_k) largest_max_k = &r;
    if (r.inserted == 0) ++zero_ins;
    if (!r.cert_on_source) continue;
    ++comparable;
    if (r.inserted <= 0) ++within;
    if (r.inserted > 5) ++over5;
    excess += std::max(0LL, r.inserted);
    if (!worst_excess || r.inserted > worst_excess->inserted) worst_excess = &r;
    const double q = r.mean_k / r.cert_mean_k;
    ratios.push_back(q);
    if (!worst_ratio || q > worst_ratio->mean_k / worst_ratio->cert_mean_k) worst_ratio = &r;
  }
  int k_within = 0;
  for (double q : ratios) k_within += q <= 1.0 ? 1 : 0;
  std::printf("\nsummary: %zu rows, %d with the certificate on the source mesh, %d errors/timeouts, %d over 30 s, "
              "%d with 0 inserted overall\n", rows.size(), comparable, errors, over30, zero_ins);
  std::printf("summary: inserted <= certificate: %d / %d (%.1f%%); more than certificate + 5: %d; total excess %lld\n",
              within, comparable, comparable ? 100.0 * within / comparable : 0.0, over5, excess);
  std::printf("summary: mean K ours / certificate: median %.3f, <= 1.0 in %d / %zu (%.1f%%)\n", median(ratios), k_within,
              ratios.size(), ratios.empty() ? 0.0 : 100.0 * k_within / ratios.size());
  if (worst_ratio)
    std::printf("summary: worst K ratio %.3f: %s %s seed %d (ours %.4g, certificate %.4g)\n",
                worst_ratio->mean_k / worst_ratio->cert_mean_k, worst_ratio->mesh.c_str(), worst_ratio->kind.c_str(),
                worst_ratio->seed, worst_ratio->mean_k, worst_ratio->cert_mean_k);
  if (worst_excess)
    std::printf("summary: most inserted where the certificate has 0: %lld: %s %s seed %d\n", worst_excess->inserted,
                worst_excess->mesh.c_str(), worst_excess->kind.c_str(), worst_excess->seed);
  if (slowest)
    std::printf("summary: slowest row %.0f ms: %s %s seed %d\n", slowest->total, slowest->mesh.c_str(),
                slowest->kind.c_str(), slowest->seed);
  if (most_inserted)
    std::printf("summary: most inserted in any row %lld: %s %s seed %d\n", most_inserted->inserted,
                most_inserted->mesh.c_str(), most_inserted->kind.c_str(), most_inserted->seed);
  if (largest_max_k)
    std::printf("summary: largest max K %.4g: %s %s seed %d%s\n", largest_max_k->max_k, largest_max_k->mesh.c_str(),
                largest_max_k->kind.c_str(), largest_max_k->seed,
                largest_max_k->pinned_max_k == largest_max_k->max_k ? " (a face with three boundary corners)" : "");
  // A row whose pinned faces alone have K > 1e4 has no map (without removable insertions) with max K <= 1e4.
  int over_1e4 = 0, over_1e4_pinned = 0;
  for (const Row& r : rows)
    if (r.error.empty() && r.max_k > 1e4) {
      ++over_1e4;
      over_1e4_pinned += r.pinned_max_k > 1e4 ? 1 : 0;
    }
  int bound_rows = 0, at_bound = 0, below_bound = 0;
  long long bound_sum = 0, inserted_sum = 0;
  for (const Row& r : rows)
    if (r.error.empty() && r.chord_bound >= 0) {
      ++bound_rows;
      at_bound += r.inserted == r.chord_bound ? 1 : 0;
      below_bound += r.inserted < r.chord_bound ? 1 : 0;  // would mean the bound is wrong
      bound_sum += r.chord_bound;
      inserted_sum += r.inserted;
    }
  if (bound_rows > 0)
    std::printf("summary: chord lower bound: %d rows answered, inserted = the bound in %d, below it in %d; inserted %lld "
                "in all, bound %lld\n", bound_rows, at_bound, below_bound, inserted_sum, bound_sum);
  std::printf("summary: max K > 1e4 in %d rows; in %d of them a face with three boundary corners (fixed by the "
              "polygon) has K > 1e4 itself\n", over_1e4, over_1e4_pinned);
  std::printf("\ncolumns: cert = where the certificate lives (src: the source mesh, poly: the generator's own mesh); "
              "c.ins / ins = inserted vertices; chordLB = points any answer with this triangulation of P needs on the chords "
              "(interior edges joining two boundary vertices): over the chords, the link distance between their pinned ends "
              "in the immersed disk, less 1 (bench/chord_bound.h); c.meanK / meanK = area-weighted mean K; pinnedK = max K over the faces with "
              "three boundary corners (fixed by the polygon; - if none); ratio = meanK / c.meanK; "
              "flips = composed map's non-positive faces; left = after untangling; iter = optimization steps; "
              "meanK0 = mean K before optimization\n");
  return 0;
}
