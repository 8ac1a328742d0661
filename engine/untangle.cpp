// Stage "untangle" (engine/untangle.h): Garanzha et al. 2021 on the unrefined mesh, boundary pinned.
#include "engine/untangle.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string>

#include "engine/detail/uv_descent.h"
#include "engine/error.h"
#include "engine/flip_check.h"
#include "engine/fold_region.h"
#include "engine/refine.h"
#include "engine/verify.h"

namespace lipmap {
namespace {

// Rounds of eps and L-BFGS steps per round. Each round is a full minimization in the paper; a cap keeps the
// stage's cost bounded (a case it cannot untangle within it goes to refinement, which always finishes).
constexpr int kRounds = 100;
constexpr int kStepsPerRound = 1000;
constexpr int kStepsInAll = 20000;
constexpr int kMinStepsInAll = 2000;
constexpr double kFaceStepsInAll = 6e7;  // steps x faces: about 4 s on the 9k-face maze
constexpr int kSplitPasses = 3;          // rounds of chord splits after a failed run
// Whole-interior runs on meshes up to kNewtonMaxFaces faces take projected Newton steps (engine/detail/uv_descent.h)
// instead of L-BFGS: on thin, strongly stretched meshes L-BFGS stalls with hundreds of folds left (maze onto
// power_map: 815 non-positive faces after 6,540 steps, and 822 after 60,000), where Newton ends with none but
// the fixed faces whose chords get split. At most kNewtonStepsPerRound steps per eps (more do not lower the
// total), and kNewtonFaceSteps steps x faces in all (about 1,300 steps on the 9k-face maze).
constexpr int kNewtonMaxFaces = 60000;
constexpr int kNewtonStepsPerRound = 10;
constexpr double kNewtonFaceSteps = 3e7;
constexpr int kMinNewtonSteps = 200;
constexpr int kNewtonRounds = 400;
constexpr int kNewtonPatience = 25;
constexpr double kMaxStartEpsilon = 0.1;
// Local attempts: the free vertices within kLocalRings (then 3x as many) rings of the folds, when they are at
// most a quarter of the free vertices, with at most kLocalSteps steps each.
constexpr int kLocalRings = 2;
constexpr int kLocalSteps = 500;

double shoelace(const std::vector<Point2>& p) {
  double a = 0;
  for (std::size_t i = 0, n = p.size(); i < n; ++i) a += p[i].x * p[(i + 1) % n].y - p[(i + 1) % n].x * p[i].y;
  return 0.5 * a;
}

// near[v]: v is a corner of a face not positive under uv, or within `rings` rings of one (over `faces`).
std::vector<char> near_folds(const std::vector<Triangle>& faces, const std::vector<Point2>& uv, std::size_t nv,
                             int rings) {
  std::vector<char> near(nv, 0);
  for (const Triangle& t : faces)
    if (orientation_sign(uv[t[0]], uv[t[1]], uv[t[2]]) <= 0) near[t[0]] = near[t[1]] = near[t[2]] = 1;
  grow_by_rings(faces, near, rings);
  return near;
}

// The chord splits of the header: for each fixed (three pinned corners) non-positive face not yet served by a
// split, one of its interior edges, preferring one whose other face is fixed and non-positive too (one
// insertion serves both). midpoint[e]: the vertex inserted on source edge e, or -1. Returns the count added.
int choose_fixed_face_chords(const DiskMesh& source, const std::vector<char>& pinned, const std::vector<Point2>& uv,
                             std::vector<int>& midpoint, std::vector<InsertedVertex>& inserted) {
  const MeshTopology& topo = source.topology;
  const int nf = static_cast<int>(source.faces.size()), nv = static_cast<int>(source.vertices.size());
  std::vector<char> bad(nf, 0);
  for (int f = 0; f < nf; ++f) {
    const Triangle& t = source.faces[f];
    bad[f] = pinned[t[0]] && pinned[t[1]] && pinned[t[2]] && orientation_sign(uv[t[0]], uv[t[1]], uv[t[2]]) <= 0;
  }
  int added = 0;
  for (int f = 0; f < nf; ++f) {
    if (!bad[f]) continue;
    int pick = -1, fallback = -1;
    bool served = false;
    for (int k = 0; k < 3; ++k) {
      const int h = 3 * f + k, o = topo.opposite(h);
      if (o < 0) continue;
      if (midpoint[topo.edge(h)] >= 0) served = true;
      if (fallback < 0) fallback = topo.edge(h);
      if (pick < 0 && bad[MeshTopology::face_of(o)]) pick = topo.edge(h);
    }
    if (served) continue;
    if (pick < 0) pick = fallback;
    if (pick < 0) continue;  // a single triangle: nothing to split
    const std::array<int, 2> ab = topo.edge_vertices(pick);
    midpoint[pick] = nv + static_cast<int>(inserted.size());
    inserted.push_back({ab[0], ab[1], 0.5});
    ++added;
  }
  return added;
}

// The source faces with their split edges: 2, 3 or 4 triangles each, corners in the original order, no
// triangle with its three corners on one original edge.
std::vector<Triangle> split_faces(const DiskMesh& source, const std::vector<int>& midpoint) {
  const MeshTopology& topo = source.topology;
  std::vector<Triangle> out;
  for (int f = 0; f < static_cast<int>(source.faces.size()); ++f) {
    const Triangle& t = source.faces[f];
    std::array<int, 3> m;  // m[k]: midpoint on edge (t[k], t[k+1]), or -1
    int count = 0;
    for (int k = 0; k < 3; ++k) count += (m[k] = midpoint[topo.edge(3 * f + k)]) >= 0;
    if (count == 0) {
      out.push_back(t);
    } else if (count == 3) {
      out.push_back({t[0], m[0], m[2]});
      out.push_back({m[0], t[1], m[1]});
      out.push_back({m[2], m[1], t[2]});
      out.push_back({m[0], m[1], m[2]});
    } else if (count == 1) {
      const int k = m[0] >= 0 ? 0 : m[1] >= 0 ? 1 : 2;
      out.push_back({t[k], m[k], t[(k + 2) % 3]});
      out.push_back({m[k], t[(k + 1) % 3], t[(k + 2) % 3]});
    } else {  // two: edge u is whole, the corner w opposite it has both its edges split
      const int u = m[0] < 0 ? 0 : m[1] < 0 ? 1 : 2;
      const int c0 = t[u], c1 = t[(u + 1) % 3], w = t[(u + 2) % 3], m1 = m[(u + 1) % 3], m2 = m[(u + 2) % 3];
      out.push_back({m1, w, m2});
      out.push_back({c0, c1, m1});
      out.push_back({c0, m1, m2});
    }
  }
  return out;
}

}  // namespace

RefinedMap untangled_map(const DiskMesh& source, Untangling& u) {
  RefinedMap m;
  m.vertices = source.vertices;
  for (const InsertedVertex& iv : u.inserted) m.vertices.push_back(point_on_edge(source.vertices[iv.a], source.vertices[iv.b], iv.t));
  m.faces = u.faces.empty() ? source.faces : u.faces;
  m.inserted = u.inserted;
  m.uv = std::move(u.uv);
  return m;
}

Untangling untangle(const DiskMesh& source, const std::vector<int>& loop, const BoundaryPolygon& polygon,
                    const std::vector<int>& rotation, const std::vector<Point2>& composed_uv,
                    const CancelToken* cancel, const std::vector<Point3>* rest, bool any_rotation) {
  Untangling out;
  out.flipped_before = out.flipped_after = count_non_positive(composed_uv, source.faces);
  if (out.flipped_before == 0) {
    out.outcome = "not needed: the composed map has no flipped triangle";
    return out;
  }
  const int nv = static_cast<int>(source.vertices.size());
  std::vector<char> pinned(nv, 0);
  for (int v : loop) pinned[v] = 1;
  std::vector<Point2> uv = composed_uv;
  std::vector<Point3> shape = rest ? *rest : source.vertices;
  std::vector<int> midpoint(source.topology.edge_count(), -1);
  // New midpoints start at the middle of their chord's image; they are free, like interior vertices.
  auto add_midpoints = [&](std::size_t from) {
    for (std::size_t i = from; i < out.inserted.size(); ++i) {
      const InsertedVertex& iv = out.inserted[i];
      uv.push_back({0.5 * (uv[iv.a].x + uv[iv.b].x), 0.5 * (uv[iv.a].y + uv[iv.b].y)});
      shape.push_back(point_on_edge(shape[iv.a], shape[iv.b], iv.t));
      pinned.push_back(0);
    }
    out.faces = out.inserted.empty() ? std::vector<Triangle>{} : split_faces(source, midpoint);
  };
  choose_fixed_face_chords(source, pinned, composed_uv, midpoint, out.inserted);
  add_midpoints(0);
  if (std::count(pinned.begin(), pinned.end(), 0) == 0) {
    out.outcome = "not attempted: no interior vertex";
    return out;
  }
  out.attempted = true;
  detail::DescentSettings s;
  s.energy = detail::UvEnergy::untangle;
  s.flip_free = false;
  s.max_iterations = kStepsPerRound;
  s.relative_tolerance = 1e-9;
  s.stop_when_positive = true;
  s.cancel = cancel;
  // Steps in all, fewer on large meshes (a step costs a pass over the faces): a case the untangler cannot
  // solve within them goes to refinement.
  const double face_count = static_cast<double>(std::max<std::size_t>(source.faces.size(), 1));
  const int lbfgs_steps_in_all = std::max(kMinStepsInAll, std::min(kStepsInAll, static_cast<int>(kFaceStepsInAll / face_count)));
  const int newton_steps_in_all = std::max(kMinNewtonSteps, static_cast<int>(kNewtonFaceSteps / face_count));
  // One run of Garanzha et al. 2021 from `x`, until every face is positive or the step budget is spent; with
  // `newton`, rounds of at most kNewtonStepsPerRound projected Newton steps, each round ended early once a step
  // gains less than 1e-4 of the energy (eps is lowered next anyway).
  int whole_steps = 0;  // steps of the whole-interior runs (the local attempts have their own cap)
  auto run = [&](detail::UvDescent& descent, const std::vector<Triangle>& faces, std::vector<Point2>& x, int budget,
                 bool newton) {
    s.newton = newton;
    s.relative_tolerance = newton ? 1e-4 : 1e-9;
    const int per_round = newton ? kNewtonStepsPerRound : kStepsPerRound;
    // Sec. 3: start with eps of the order of the worst determinant, then after each minimization lower it by a
    // factor that follows the energy's progress (sigma), keeping eps large enough that chi stays well above
    // zero on the worst triangle; once every det J > 0, eps becomes tiny.
    double dmin = descent.min_det(x);
    // Unlike the paper's arbitrary starts, the composed map is nearly injective (few folded triangles, some
    // of them badly): eps of the order of the worst det would make chi nearly constant, the energy a plain
    // Dirichlet energy, and throw that start away (on a 1.5-turn strip: 23 flips became 208). eps is capped
    // at 0.1 (det J is about 1 for an area-preserving map, the rest shapes being scaled to the uv area).
    s.epsilon = dmin > 0 ? 1e-10 : std::min(std::sqrt(1e-8 + 0.04 * dmin * dmin), kMaxStartEpsilon);
    int best = static_cast<int>(faces.size()) + 1, since_best = 0;
    for (int used = 0, rounds = 0; rounds < (newton ? kNewtonRounds : kRounds) && used < budget;) {
      check_cancel(cancel);
      s.max_iterations = std::min(per_round, budget - used);
      const detail::DescentOutcome step = descent.minimize(x, s);
      ++rounds;
      ++out.rounds;
      used += step.iterations;
      out.iterations += step.iterations;
      whole_steps += step.iterations;
      dmin = descent.min_det(x);
      const int left = dmin > 0 || newton ? count_non_positive(x, faces) : -1;
      if (dmin > 0 && left == 0) return 0;
      if (step.iterations == 0) break;  // stalled
      // Newton's rounds are short: a run whose fold count has not reached a new low in kNewtonPatience rounds
      // has settled (on maze / spiral_arm, about 1,900 folds from round 40 on), and refinement takes over.
      if (newton && (left < best ? (best = left, since_best = 0, false) : ++since_best >= kNewtonPatience)) break;
      // The energy's progress over this round at this eps (minimize reports both ends: no extra pass).
      const double sigma = std::max(1 - step.energy_after / step.energy_before, 0.1);
      const double mu = (1 - sigma) * detail::regularized_det(dmin, s.epsilon);
      s.epsilon = dmin < mu ? 2 * std::sqrt(mu * (mu - dmin)) : 1e-10;
    }
    return count_non_positive(x, faces);
  };
  const double uv_area = shoelace(polygon.vertices);
  // Local first: when the folds are few, only the free vertices near them move. The system is then the size of
  // that neighbourhood (on a 50k-face mesh with one fold, no factorization of the whole Laplacian), and the
  // rest of the map stays as composed. Failing that, the whole interior moves, as before.
  auto untangle_locally = [&](const std::vector<Triangle>& faces) {
    const auto free_all = std::count(pinned.begin(), pinned.end(), 0);
    for (int rings : {kLocalRings, 3 * kLocalRings}) {
      const std::vector<char> near = near_folds(faces, uv, pinned.size(), rings);
      std::vector<char> local_pinned(pinned.size());
      long free_local = 0;
      for (std::size_t v = 0; v < pinned.size(); ++v) free_local += !(local_pinned[v] = pinned[v] || !near[v]);
      if (free_local == 0 || 4 * free_local > free_all) return false;
      detail::UvDescent local(shape, faces, local_pinned, uv_area);
      std::vector<Point2> x = uv;
      const int before = whole_steps;
      const bool done = run(local, faces, x, kLocalSteps, false) == 0;
      whole_steps = before;
      if (done) {
        uv.swap(x);
        out.moved_locally = static_cast<int>(free_local);
        return true;
      }
    }
    return false;
  };
  // With a rotation index above 0 (a weakly self-overlapping polygon), Newton from the harmonic start goes
  // straight to every face positive around a branch point (maze / weak_fan: the hub's turn at 0, another vertex's
  // angle sum 4 pi) and from the composed start kept 350 folds after 3,270 steps (34 s): L-BFGS then, as before.
  const bool all_zero_rotation = std::all_of(rotation.begin(), rotation.end(), [](int r) { return r == 0; });
  // verify's complaint about x (every face positive) as the untangled answer, empty when it passes; the angle
  // sums and rotation indices are its checks (any R_k >= 0 with any_rotation). uv_error: that of uv, once known;
  // verified_rotation: the R_k of the map that passed last.
  std::vector<int> verified_rotation;
  auto verify_error = [&](const std::vector<Point2>& x) -> std::string {
    Untangling probe;
    probe.inserted = out.inserted;
    probe.faces = out.faces;
    probe.uv = x;
    try {
      verified_rotation =
          verify_map(source, loop, polygon, any_rotation ? std::vector<int>{} : rotation, untangled_map(source, probe))
              .rotation_indices;
    } catch (const InternalError& e) {
      return e.what();
    }
    return {};
  };
  std::optional<std::string> uv_error;
  for (int pass = 0;; ++pass) {
    const std::vector<Triangle>& faces = out.faces.empty() ? source.faces : out.faces;
    if (untangle_locally(faces)) {
      out.flipped_after = 0;
      break;
    }
    detail::UvDescent descent(shape, faces, pinned, uv_area);
    const bool newton = faces.size() <= static_cast<std::size_t>(kNewtonMaxFaces) && all_zero_rotation;
    if (newton) out.newton = true;
    const int steps_in_all = newton ? newton_steps_in_all : lbfgs_steps_in_all;
    // Steps spent against that budget: L-BFGS's count the local attempts' too (as they always have), Newton's
    // only its own (a local L-BFGS step is no Newton step).
    auto spent = [&] { return newton ? whole_steps : out.iterations; };
    if (pass == 0) {
      // Two starts: the composed map, and the harmonic map with the boundary pinned (Garanzha et al.'s usual
      // start). The composed map is the better one when it folds little; when the source is a long corridor
      // the harmonic intermediate maps crowd it exponentially and it folds in thousands of places, while the
      // pinned boundary keeps the harmonic start close to the polygon. The one with fewer non-positive faces
      // goes first (with half the steps); the other gets what is left.
      // A start that ends with every face positive but fails verify (a branch point: an interior angle sum of
      // 4 pi, or a boundary vertex off its rotation index) counts as failed, and the other start gets the rest
      // of the steps. So does L-BFGS's second start always: cut at a quarter of the budget it can stop halfway
      // (maze / weak_fan from the harmonic start: 752 -> 181 folds in its 1,635 steps, none left after 2,845),
      // and the chord-split passes after it restart eps from the worst determinant, which undoes progress
      // rather than extends it (181 -> 560 folds in the 635 steps they had).
      std::vector<Point2> other = uv;
      descent.harmonic(other);
      if (count_non_positive(other, faces) < count_non_positive(uv, faces)) std::swap(uv, other);
      out.flipped_after = run(descent, faces, uv, steps_in_all / 2, newton);
      if (out.flipped_after == 0) uv_error = verify_error(uv);
      const bool branched = uv_error && !uv_error->empty();
      if ((out.flipped_after > 0 || branched) && spent() < steps_in_all) {
        const int left = run(descent, faces, other, (steps_in_all - spent()) / (branched || !newton ? 1 : 2), newton);
        if (branched || left < out.flipped_after) {
          out.flipped_after = left;
          uv.swap(other);
          uv_error.reset();
        }
      }
    } else {
      out.flipped_after = run(descent, faces, uv, steps_in_all - spent(), newton);
    }
    if (out.flipped_after == 0 || pass == kSplitPasses || spent() >= steps_in_all) break;
    // Still folded: a chord (an interior edge joining two boundary vertices) is a fixed straight segment, and
    // one that leaves the polygon cannot be an edge of any injective map there. Split the unsplit chords of
    // the faces still not positive, and go on from this map (paper-4 refinement stays the last resort).
    const std::size_t before = out.inserted.size();
    for (const Triangle& t : faces) {
      if (orientation_sign(uv[t[0]], uv[t[1]], uv[t[2]]) > 0) continue;
      for (int k = 0; k < 3; ++k) {
        const int a = t[k], b = t[(k + 1) % 3];
        if (a >= nv || b >= nv || !pinned[a] || !pinned[b]) continue;
        const int e = source.topology.find_edge(a, b);
        if (e < 0 || source.topology.is_boundary_edge(e) || midpoint[e] >= 0) continue;
        midpoint[e] = nv + static_cast<int>(out.inserted.size());
        out.inserted.push_back({std::min(a, b), std::max(a, b), 0.5});
      }
    }
    if (out.inserted.size() == before) break;
    add_midpoints(before);
  }
  const std::vector<Triangle>& faces = out.faces.empty() ? source.faces : out.faces;
  if (out.flipped_after > 0) {
    // Faces whose free corners all have only pinned neighbours: their stars are fixed polygons, and when such
    // a star has an empty kernel no position of its centre is positive (then only insertions help).
    std::vector<char> caged(pinned.size(), 1);
    for (const Triangle& t : faces)
      for (int k = 0; k < 3; ++k)
        if (!pinned[t[k]] && (!pinned[t[(k + 1) % 3]] || !pinned[t[(k + 2) % 3]])) caged[t[k]] = 0;
    int stuck = 0;
    for (const Triangle& t : faces)
      if (orientation_sign(uv[t[0]], uv[t[1]], uv[t[2]]) <= 0 && caged[t[0]] && caged[t[1]] && caged[t[2]]) ++stuck;
    out.outcome = "failed: " + std::to_string(out.flipped_after) + " faces still not positive (" +
                  std::to_string(stuck) + " around vertices with only boundary neighbours) after " +
                  std::to_string(out.rounds) + " rounds, " + std::to_string(out.iterations) +
                  (out.newton ? " steps (projected Newton), " : " steps, ") +
                  std::to_string(out.inserted.size()) + " chords split";
    out.uv = std::move(uv);  // the last iterate: where its folds are is where refinement is needed
    return out;
  }
  // Every face positive: verify decides (once per map).
  const std::string why = uv_error ? *uv_error : verify_error(uv);
  if (!why.empty()) {
    out.outcome = "failed: every face positive, but " + why;
    out.uv = std::move(uv);
    return out;
  }
  out.succeeded = true;
  out.rotation_indices = std::move(verified_rotation);
  out.outcome = (out.moved_locally > 0 ? "untangled locally (" + std::to_string(out.moved_locally) + " vertices moved) in "
                                       : std::string("untangled in ")) +
                std::to_string(out.rounds) + " rounds, " + std::to_string(out.iterations) +
                (out.newton ? " steps (projected Newton)" : " steps") +
                (out.inserted.empty() ? "" : " after splitting " + std::to_string(out.inserted.size()) + " chords");
  out.uv = std::move(uv);
  return out;
}

}  // namespace lipmap
