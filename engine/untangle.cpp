// Stage "untangle" (engine/untangle.h): Garanzha et al. 2021 on the unrefined mesh, boundary pinned.
#include "engine/untangle.h"

#include <algorithm>
#include <cmath>

#include "engine/detail/uv_descent.h"
#include "engine/error.h"
#include "engine/flip_check.h"
#include "engine/refine.h"
#include "engine/verify.h"

namespace lipmap {
namespace {

// Rounds of eps and L-BFGS steps per round. Each round is a full minimization in the paper; a cap keeps the
// stage's cost bounded (a case it cannot untangle within it goes to refinement, which always finishes).
constexpr int kRounds = 100;
constexpr int kStepsPerRound = 1000;
constexpr int kStepsInAll = 20000;
constexpr double kMaxStartEpsilon = 0.1;

double shoelace(const std::vector<Point2>& p) {
  double a = 0;
  for (std::size_t i = 0, n = p.size(); i < n; ++i) a += p[i].x * p[(i + 1) % n].y - p[(i + 1) % n].x * p[i].y;
  return 0.5 * a;
}

}  // namespace

Untangling untangle(const DiskMesh& source, const std::vector<int>& loop, const BoundaryPolygon& polygon,
                    const std::vector<int>& rotation, const std::vector<Point2>& composed_uv,
                    const CancelToken* cancel, const std::vector<Point3>* rest) {
  Untangling out;
  out.flipped_before = out.flipped_after = count_non_positive(composed_uv, source.faces);
  if (out.flipped_before == 0) {
    out.outcome = "not needed: the composed map has no flipped triangle";
    return out;
  }
  std::vector<char> pinned(source.vertices.size(), 0);
  for (int v : loop) pinned[v] = 1;
  // A face with three boundary corners (an ear, or a triangle whose edges all join boundary vertices) cannot
  // change: if it is not positive, no motion of the interior helps, and refinement must split it.
  for (const Triangle& t : source.faces)
    if (pinned[t[0]] && pinned[t[1]] && pinned[t[2]] && orientation_sign(composed_uv[t[0]], composed_uv[t[1]], composed_uv[t[2]]) <= 0) {
      out.outcome = "not attempted: a face with three boundary corners is not positive";
      return out;
    }
  detail::UvDescent descent(rest ? *rest : source.vertices, source.faces, pinned, shoelace(polygon.vertices));
  if (descent.free_vertices() == 0) {
    out.outcome = "not attempted: no interior vertex";
    return out;
  }
  out.attempted = true;
  std::vector<Point2> uv = composed_uv;
  detail::DescentSettings s;
  s.energy = detail::UvEnergy::untangle;
  s.flip_free = false;
  s.max_iterations = kStepsPerRound;
  s.relative_tolerance = 1e-9;
  s.cancel = cancel;
  // Garanzha et al. 2021, sec. 3: start with eps of the order of the worst determinant, then after each
  // minimization lower it by a factor that follows the energy's progress (sigma), keeping eps large enough
  // that chi stays well above zero on the worst triangle; once every det J > 0, eps becomes tiny.
  double dmin = descent.min_det(uv);
  // Unlike the paper's arbitrary starts, the composed map is nearly injective (few folded triangles, some of
  // them badly): eps of the order of the worst det would make chi nearly constant, the energy a plain
  // Dirichlet energy, and throw that start away (on a 1.5-turn strip: 23 flips became 208). eps is capped at
  // 0.1 (det J is about 1 for an area-preserving map, the rest shapes being scaled to the uv area).
  s.epsilon = dmin > 0 ? 1e-10 : std::min(std::sqrt(1e-8 + 0.04 * dmin * dmin), kMaxStartEpsilon);
  double e_prev = descent.energy(uv, s);
  for (out.rounds = 0; out.rounds < kRounds && out.iterations < kStepsInAll;) {
    check_cancel(cancel);
    const detail::DescentOutcome step = descent.minimize(uv, s);
    ++out.rounds;
    out.iterations += step.iterations;
    dmin = descent.min_det(uv);
    if (dmin > 0) {
      out.flipped_after = count_non_positive(uv, source.faces);
      if (out.flipped_after == 0) break;
    }
    const double e = descent.energy(uv, s);
    const double sigma = std::max(1 - e / e_prev, 0.1);
    const double mu = (1 - sigma) * detail::regularized_det(dmin, s.epsilon);
    s.epsilon = dmin < mu ? 2 * std::sqrt(mu * (mu - dmin)) : 1e-10;
    e_prev = descent.energy(uv, s);
  }
  out.flipped_after = count_non_positive(uv, source.faces);
  if (out.flipped_after > 0) {
    out.outcome = "failed: " + std::to_string(out.flipped_after) + " faces still not positive after " +
                  std::to_string(out.rounds) + " rounds";
    return out;
  }
  // Every face positive; the angle sums and rotation indices are verify's checks, run on the candidate.
  RefinedMap candidate;
  candidate.vertices = source.vertices;
  candidate.faces = source.faces;
  candidate.uv = uv;
  try {
    verify_map(source, loop, polygon, rotation, candidate);
  } catch (const InternalError& e) {
    out.outcome = std::string("failed: every face positive, but ") + e.what();
    return out;
  }
  out.succeeded = true;
  out.outcome = "untangled in " + std::to_string(out.rounds) + " rounds";
  out.uv = std::move(uv);
  return out;
}

}  // namespace lipmap
