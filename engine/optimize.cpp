// Stage "optimize" (engine/optimize.h).
#include "engine/optimize.h"

#include <algorithm>
#include <chrono>

#include "engine/detail/uv_descent.h"
#include "engine/flip_check.h"

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

Optimization optimize_map(const DiskMesh& source, const std::vector<int>& loop, double uv_area, RefinedMap& map,
                          const ParametrizeOptions& options, const CancelToken* cancel,
                          const std::vector<Point3>* rest) {
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
  const std::size_t nv = map.vertices.size(), nv_source = source.vertices.size();
  std::vector<char> pinned(nv, 0);
  for (int v : loop) pinned[v] = 1;
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
  const std::vector<Point3>& shape = rest ? *rest : map.vertices;
  out.before = conformal_distortion(shape, map.faces, map.uv);
  detail::UvDescent descent(shape, map.faces, pinned, uv_area);
  out.free_vertices = descent.free_vertices();
  detail::DescentSettings s;
  s.energy = options.optimize == OptimizeEnergy::mips ? detail::UvEnergy::mips : detail::UvEnergy::symmetric_dirichlet;
  s.flip_free = true;
  s.max_iterations = step_budget(options, map.faces.size());
  s.relative_tolerance = 1e-5;
  s.cancel = cancel;
  if (options.time_budget_ms > 0)
    s.deadline = start + std::chrono::microseconds(static_cast<long long>(options.time_budget_ms * 1000));
  if (out.free_vertices == 0) {
    out.energy_before = out.energy_after = descent.energy(map.uv, s);
    out.outcome = "nothing to move: every vertex is pinned";
    return out;
  }
  const std::vector<Point2> start_uv = map.uv;
  detail::DescentOutcome r = descent.minimize(map.uv, s);
  // Then projected Newton from where L-BFGS stopped (MIPS, small maps): L-BFGS's cheap steps do most of the
  // descent, and its "converged" can be a crawl along a flat valley that Newton's steps leave in a few steps.
  // Newton from the start instead took 39 steps (635 ms) on a 10k-triangle job that L-BFGS finishes in 103
  // steps (114 ms): its flip-free steps are short while the triangles are far from their optimum.
  int budget = s.max_iterations;
  if (s.energy == detail::UvEnergy::mips && map.faces.size() <= kNewtonMaxFaces && !(r.iterations >= options.max_iterations)) {
    detail::DescentSettings n = s;
    n.newton = true;
    // A Newton step costs a factorization: three in a row that each gain less than 0.01 % end it (on the
    // 10k-triangle job above, 16 steps of 0.002 % each took 240 ms for a 0.04 % lower mean K).
    n.relative_tolerance = 1e-4;
    n.max_iterations = std::min(options.max_iterations - r.iterations, newton_step_budget(options, map.faces.size()));
    budget = r.iterations + n.max_iterations;
    const detail::DescentOutcome polished = descent.minimize(map.uv, n);
    r.iterations += polished.iterations;
    r.energy_after = polished.energy_after;
    r.converged = polished.converged;
  }
  out.ran = true;
  // MIPS lowers the mean of K + 1/K; the mean of K itself could, in principle, rise a little (seen: 4.4614 ->
  // 4.4627 on a C-shaped target). The stage promises lower conformal distortion, so it keeps the start then.
  if (conformal_distortion(shape, map.faces, map.uv).mean > out.before.mean) {
    map.uv = start_uv;
    out.iterations = 0;
    out.energy_before = out.energy_after = r.energy_before;
    out.outcome = "reverted: the mean conformal distortion would have risen";
    return out;
  }
  out.iterations = r.iterations;
  out.energy_before = r.energy_before;
  out.energy_after = r.energy_after;
  if (r.converged) out.outcome = "converged";
  else if (r.iterations >= options.max_iterations) out.outcome = "stopped at max_iterations";
  else if (r.iterations >= budget) out.outcome = "stopped at the work budget (steps x triangles; a time budget lifts it)";
  else if (options.time_budget_ms > 0 && std::chrono::steady_clock::now() >= s.deadline) out.outcome = "stopped at the time budget";
  else out.outcome = "stopped: no further flip-free decrease";
  return out;
}

}  // namespace lipmap
