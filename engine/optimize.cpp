// Stage "optimize" (engine/optimize.h).
#include "engine/optimize.h"

#include <algorithm>
#include <chrono>

#include "engine/detail/uv_descent.h"
#include "engine/flip_check.h"
#include "engine/fold_region.h"

namespace lipmap {

const char* to_string(OptimizeEnergy energy) {
  switch (energy) {
    case OptimizeEnergy::none: return "none";
    case OptimizeEnergy::mips: return "mips";
    case OptimizeEnergy::symmetric_dirichlet: return "symmetric_dirichlet";
  }
  return "unknown";
}

bool parse_optimize_energy(const std::string& name, OptimizeEnergy& out) {
  for (OptimizeEnergy e : {OptimizeEnergy::none, OptimizeEnergy::mips, OptimizeEnergy::symmetric_dirichlet})
    if (name == to_string(e)) {
      out = e;
      return true;
    }
  return false;
}

namespace {

// At most face_steps / #triangles steps, at least kMinOptimizeSteps, never more than max_iterations; a time
// budget lifts the bound to max_iterations.
int work_budget(const ParametrizeOptions& options, std::size_t faces, double face_steps) {
  if (options.time_budget_ms > 0) return options.max_iterations;
  const double by_work = face_steps / static_cast<double>(std::max<std::size_t>(faces, 1));
  return std::min(options.max_iterations, std::max(kMinOptimizeSteps, static_cast<int>(by_work)));
}

}  // namespace

int step_budget(const ParametrizeOptions& options, std::size_t faces) {
  return work_budget(options, faces, kOptimizeFaceSteps);
}

int newton_step_budget(const ParametrizeOptions& options, std::size_t faces) {
  return work_budget(options, faces, kNewtonFaceSteps);
}

namespace {

// Free descents of a refined map, each followed by simplify_again (see optimize_map), while points go. Each
// round removes fewer: bench_quality maze / weak_fan 12,231 -> 11,640 points after one, 10,380 after four.
constexpr int kFreeRounds = 4;

// Where the stage's step budget is at its floor (maps of about 67k triangles and more), a free descent of the
// whole map plus the polish would cost at least twice the stage's work bound (bench_pipeline --large, exp_strip
// with one inserted point: optimize at 1M triangles 29 s instead of 10.7 s). There the free descents move only
// the vertices within kFreeRings rings of the inserted points (the folds they were inserted for, as in
// untangling's local attempts), so their cost follows the refinement, not the map.
constexpr int kFreeRings = 6;

// The boundary, plus (keep_refined) the inserted vertices and the original corners of the source faces that
// carry them: those faces' refined polygons then stay as the refinement minimized them.
// Or (free_rings >= 0, with keep_refined false) every vertex farther than free_rings rings from the inserted ones.
std::vector<char> pinned_vertices(const DiskMesh& source, const std::vector<int>& loop, const RefinedMap& map,
                                  bool keep_refined, int free_rings = -1) {
  const std::size_t nv = map.vertices.size(), nv_source = source.vertices.size();
  std::vector<char> pinned(nv, 0);
  if (free_rings >= 0) {
    std::vector<char> near(nv, 0);
    for (std::size_t i = nv_source; i < nv; ++i) near[i] = 1;
    grow_by_rings(map.faces, near, free_rings);
    for (std::size_t v = 0; v < nv; ++v) pinned[v] = !near[v];
  }
  for (int v : loop) pinned[v] = 1;
  if (!keep_refined) return pinned;
  for (std::size_t i = nv_source; i < nv; ++i) {
    pinned[i] = 1;
    const InsertedVertex& iv = map.inserted[i - nv_source];
    const int e = source.topology.find_edge(iv.a, iv.b);
    if (e < 0) continue;
    for (int h : source.topology.edge_uses(e)) {
      const int f = MeshTopology::face_of(h);
      for (int v : source.faces[f]) pinned[v] = 1;
    }
  }
  return pinned;
}

struct Descent {
  detail::DescentOutcome outcome;
  int budget = 0;         // the steps it was allowed
  int free_vertices = 0;
  bool ran = false;       // some vertex could move
};

// L-BFGS, then (MIPS, small maps) projected Newton from where it stopped, on map.uv with `pinned` fixed.
// At most max_iterations steps in all.
Descent descend(const std::vector<Point3>& shape, RefinedMap& map, const std::vector<char>& pinned, double uv_area,
                const ParametrizeOptions& options, const detail::DescentSettings& settings, int max_iterations) {
  Descent out;
  detail::UvDescent descent(shape, map.faces, pinned, uv_area);
  out.free_vertices = descent.free_vertices();
  detail::DescentSettings s = settings;
  s.max_iterations = std::min(max_iterations, step_budget(options, map.faces.size()));
  out.budget = s.max_iterations;
  if (out.free_vertices == 0) {
    out.outcome.energy_before = out.outcome.energy_after = descent.energy(map.uv, s);
    return out;
  }
  out.ran = true;
  detail::DescentOutcome& r = out.outcome;
  r = descent.minimize(map.uv, s);
  // Then projected Newton from where L-BFGS stopped (MIPS, small maps): L-BFGS's cheap steps do most of the
  // descent, and its "converged" can be a crawl along a flat valley that Newton's steps leave in a few steps.
  // Newton from the start instead took 39 steps (635 ms) on a 10k-triangle job that L-BFGS finishes in 103
  // steps (114 ms): its flip-free steps are short while the triangles are far from their optimum.
  if (s.energy == detail::UvEnergy::mips && map.faces.size() <= kNewtonMaxFaces && r.iterations < max_iterations) {
    detail::DescentSettings n = s;
    n.newton = true;
    // A Newton step costs a factorization: three in a row that each gain less than 0.01 % end it (on the
    // 10k-triangle job above, 16 steps of 0.002 % each took 240 ms for a 0.04 % lower mean K).
    n.relative_tolerance = 1e-4;
    n.max_iterations = std::min(max_iterations - r.iterations, newton_step_budget(options, map.faces.size()));
    out.budget = r.iterations + n.max_iterations;
    const detail::DescentOutcome polished = descent.minimize(map.uv, n);
    r.iterations += polished.iterations;
    r.energy_after = polished.energy_after;
    r.converged = polished.converged;
  }
  return out;
}

}  // namespace

Optimization optimize_map(const DiskMesh& source, const std::vector<int>& loop, double uv_area, RefinedMap& map,
                          const ParametrizeOptions& options, const CancelToken* cancel,
                          const std::vector<Point3>* rest, const std::vector<int>* rotation) {
  const auto start = std::chrono::steady_clock::now();
  Optimization out;
  out.energy = options.optimize;
  if (options.optimize == OptimizeEnergy::none) {
    out.outcome = "off";
    return out;
  }
  if (options.max_iterations <= 0) {
    out.outcome = "off: max_iterations is 0";
    return out;
  }
  if (count_non_positive(map.uv, map.faces) > 0) {
    out.outcome = "not run: the map has non-positive triangles";
    return out;
  }
  const std::vector<Point3>& shape = rest ? *rest : map.vertices;
  out.before = conformal_distortion(shape, map.faces, map.uv);
  detail::DescentSettings s;
  s.energy = options.optimize == OptimizeEnergy::mips ? detail::UvEnergy::mips : detail::UvEnergy::symmetric_dirichlet;
  s.flip_free = true;
  s.relative_tolerance = 1e-5;
  s.cancel = cancel;
  if (options.time_budget_ms > 0)
    s.deadline = start + std::chrono::microseconds(static_cast<long long>(options.time_budget_ms * 1000));

  // A refined map: first every vertex off the boundary moves, the inserted ones in uv only (their 3D points stay
  // on their edges), which undoes folds some points were inserted for; the points that this leaves removable go
  // again (refine.h's simplify_again: the rounds of Fig. 11 on the moved map), up to kFreeRounds times, and the
  // descent with the refined polygons pinned polishes what is left. Kept when neither the mean K nor the energy
  // ends above the start's; else the plain descent runs on the map as it came.
  // Each attempt fills its own report; `before` (with its per-face K) is moved into the one returned.
  const int free_rings = step_budget(options, map.faces.size()) > kMinOptimizeSteps ? -1 : kFreeRings;
  // Above kNewtonMaxFaces (no Newton polish: the stage's time is its L-BFGS steps) the polish gets what the free
  // descents left of one step budget, so a refined map costs one budget, as an unrefined one does, unless a
  // free round removed points: the next round has a budget of its own (optimize.h).
  const int steps = map.faces.size() > kNewtonMaxFaces && options.time_budget_ms <= 0
                        ? std::min(options.max_iterations, step_budget(options, map.faces.size()))
                        : options.max_iterations;
  auto run = [&](RefinedMap& m, bool free_first) {
    Optimization o;
    o.energy = out.energy;
    Descent first;  // the free descents together (free_first: never with rest shapes)
    for (int round = 0; free_first && round < kFreeRounds; ++round) {
      const std::size_t points = m.inserted.size();
      const Descent d = descend(m.vertices, m, pinned_vertices(source, loop, m, false, free_rings), uv_area, options, s,
                                options.max_iterations - first.outcome.iterations);
      o.free_descent_vertices = std::max(o.free_descent_vertices, d.free_vertices);
      if (round == 0) first = d;
      else first.outcome.iterations += d.outcome.iterations;
      if (!d.ran || d.outcome.iterations == 0 || !simplify_again(source, loop, *rotation, m, cancel)) break;
      o.points_removed += static_cast<int>(points - m.inserted.size());
      if (m.inserted.empty()) break;
    }
    const std::vector<Point3>& shape_now = rest ? *rest : m.vertices;  // simplify_again replaces m's vertices
    const Descent second = descend(shape_now, m, pinned_vertices(source, loop, m, true), uv_area, options, s,
                                   std::max(0, steps - first.outcome.iterations));
    o.free_vertices = std::max(first.free_vertices, second.free_vertices);
    o.ran = first.ran || second.ran;
    o.iterations = first.outcome.iterations + second.outcome.iterations;
    o.energy_before = first.ran ? first.outcome.energy_before : second.outcome.energy_before;
    o.energy_after = second.outcome.energy_after;
    const detail::DescentOutcome& r = second.outcome;
    if (!o.ran) o.outcome = "nothing to move: every vertex is pinned";
    else if (r.converged) o.outcome = "converged";
    else if (o.iterations >= options.max_iterations) o.outcome = "stopped at max_iterations";
    else if (r.iterations >= second.budget) o.outcome = "stopped at the work budget (steps x triangles; a time budget lifts it)";
    else if (options.time_budget_ms > 0 && std::chrono::steady_clock::now() >= s.deadline) o.outcome = "stopped at the time budget";
    else o.outcome = "stopped: no further flip-free decrease";
    return std::make_pair(o, conformal_distortion(shape_now, m.faces, m.uv).mean);
  };
  // MIPS lowers the mean of K + 1/K; the mean of K itself could, in principle, rise a little (seen: 4.4614 ->
  // 4.4627 on a C-shaped target). The stage promises lower conformal distortion, so it keeps the start then.
  if (rotation && !rotation->empty() && !rest && !map.inserted.empty()) {
    RefinedMap freed = map;
    auto [o, mean] = run(freed, true);
    // Measured over different triangulations (simplify_again triangulates the refined faces again), but both
    // energies are means over the same total rest area.
    if (o.ran && mean <= out.before.mean && o.energy_after <= o.energy_before) {
      map = std::move(freed);
      o.before = std::move(out.before);
      return o;
    }
  }
  const std::vector<Point2> start_uv = map.uv;
  auto [o, mean] = run(map, false);
  if (o.ran && mean > out.before.mean) {
    map.uv = start_uv;
    o.iterations = 0;
    o.energy_after = o.energy_before;
    o.outcome = "reverted: the mean conformal distortion would have risen";
  }
  o.before = std::move(out.before);
  return o;
}

}  // namespace lipmap
