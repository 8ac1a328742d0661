// The engine as one call: each stage a function from one value to the next (docs/architecture.md).
#include "engine/pipeline.h"

#include <chrono>
#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>
#include <optional>
#include <string>

#include "engine/compose.h"
#include "engine/convex_domain.h"
#include "engine/direct_map.h"
#include "engine/extremal_relax.h"
#include "engine/fixed_face_split.h"
#include "engine/flip_check.h"
#include "engine/fold_region.h"
#include "engine/reference_metric.h"
#include "engine/rotation_placement.h"
#include "engine/slide_inserted.h"
#include "engine/target_mesh.h"
#include "engine/teichmuller.h"
#include "engine/validate.h"

namespace lipmap {
namespace {

using Clock = std::chrono::steady_clock;

// Runs one stage: reports progress, checks cancellation before it, and adds its time to `slot`.
template <class F>
auto run_stage(Stage stage, double& slot, const CancelToken* cancel, const ProgressFn& progress, F&& body) {
  check_cancel(cancel);
  if (progress) progress(stage, 0);
  const auto t0 = Clock::now();
  auto value = body();
  slot += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  if (progress) progress(stage, 1);
  return value;
}

void check_options(const ParametrizeOptions& options) {
  if (!(std::isfinite(options.target_density) && options.target_density > 0 && options.target_density <= 100))
    throw InputError("invalid_option", "options.target_density must be a number in (0, 100]", "option");
  if (!(options.max_iterations >= 0 && options.max_iterations <= kMaxOptimizeIterations))
    throw InputError("invalid_option",
                     "options.max_iterations must be an integer in [0, " + std::to_string(kMaxOptimizeIterations) + "]",
                     "option");
  if (!(std::isfinite(options.time_budget_ms) && options.time_budget_ms >= 0))
    throw InputError("invalid_option", "options.time_budget_ms must be a finite number >= 0", "option");
}

// ---- scale normalization --------------------------------------------------------------------------
// The map is invariant under a uniform scale of the 3D mesh, and scales with a uniform scale of the
// boundary polygon. Coordinates near the ends of the double range (1e-300, 1e300) break the stages' float
// steps (squared lengths overflow or underflow, grid sizes become huge), so the stages run on copies scaled
// by a power of two that brings the largest |coordinate| into [0.5, 1). Scaling by 2^k is exact for normal
// doubles, so exact predicates see the same signs, and the answer goes back to the caller's scale exactly.

// k with max |coordinate| * 2^-k in [0.5, 1), or 0 when max |coordinate| is within 2^+-kLeaveAlone: the
// stages' absolute constants make their floating point not exactly scale-equivariant, and inputs at
// ordinary scales keep their answers unchanged, bit for bit.
constexpr int kLeaveAlone = 32;
int scale_exponent(double max_abs) {
  if (!(max_abs > 0)) return 0;
  int k = 0;
  std::frexp(max_abs, &k);
  return std::abs(k) <= kLeaveAlone ? 0 : k;
}

int mesh_exponent(const std::vector<Point3>& vertices) {
  double m = 0;
  for (const Point3& p : vertices) m = std::max({m, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  return scale_exponent(m);
}

int polygon_exponent(const std::vector<Point2>& vertices) {
  double m = 0;
  for (const Point2& p : vertices) m = std::max({m, std::abs(p.x), std::abs(p.y)});
  return scale_exponent(m);
}

Point2 scaled(const Point2& p, int k) { return {std::ldexp(p.x, k), std::ldexp(p.y, k)}; }
Point3 scaled(const Point3& p, int k) { return {std::ldexp(p.x, k), std::ldexp(p.y, k), std::ldexp(p.z, k)}; }

// The refined map back at the caller's scale: original vertices are the caller's, inserted ones are
// a + t (b - a) on the caller's vertices (the contract's formula), uv is scaled back and the boundary pinned
// to the caller's positions bit for bit. A uv that does not survive the round trip (it would be subnormal
// at the caller's scale) cannot be served exactly: refused.
void to_caller_scale(RefinedMap& map, const DiskMesh& caller_mesh, const std::vector<int>& loop,
                     const BoundaryPolygon& caller_polygon, int polygon_k) {
  const std::size_t nv = caller_mesh.vertices.size();
  for (std::size_t v = 0; v < nv; ++v) map.vertices[v] = caller_mesh.vertices[v];
  for (std::size_t i = 0; i < map.inserted.size(); ++i) {
    const InsertedVertex& iv = map.inserted[i];
    map.vertices[nv + i] = point_on_edge(caller_mesh.vertices[iv.a], caller_mesh.vertices[iv.b], iv.t);
  }
  for (std::size_t v = 0; v < map.uv.size(); ++v) {
    const Point2 back = scaled(map.uv[v], polygon_k);
    if (!(scaled(back, -polygon_k) == map.uv[v]))
      throw InputError("coordinate_out_of_range",
                       "the boundary positions are so small (largest |coordinate| about 2^" + std::to_string(polygon_k) +
                           ") that the map's interior uv would underflow to subnormal doubles; scale the polygon up",
                       "boundary");
    map.uv[v] = back;
  }
  for (std::size_t k = 0; k < loop.size(); ++k) map.uv[loop[k]] = caller_polygon.vertices[k];
}

// The shoelace area of the polygon: the area of the immersed disk (each point counted with its winding
// number), the total uv area of any map with that boundary.
double signed_area(const std::vector<Point2>& p) {
  double a = 0;
  for (std::size_t i = 0, n = p.size(); i < n; ++i) a += p[i].x * p[(i + 1) % n].y - p[(i + 1) % n].x * p[i].y;
  return 0.5 * a;
}

void require_bijective(const DiskMap& map, const char* which) {
  if (map.bijective()) return;
  throw InternalError(std::string("the intermediate map of the ") + which + " onto the disk has " +
                      std::to_string(map.flipped) + " flipped triangles even after recovery (floating point crowding)");
}

// The target mesh as a disk mesh of its own: its points in the plane z = 0, its boundary loop the polygon's
// n vertices in order (they come first, engine/target_mesh.h).
struct PlanarTarget {
  std::vector<Point3> vertices;
  std::vector<int> loop;
};
PlanarTarget planar_target(const TargetMesh& target, std::size_t n) {
  PlanarTarget p{std::vector<Point3>(target.vertices.size()), std::vector<int>(n)};
  for (std::size_t v = 0; v < p.vertices.size(); ++v) p.vertices[v] = {target.vertices[v].x, target.vertices[v].y, 0};
  std::iota(p.loop.begin(), p.loop.end(), 0);
  return p;
}

// h_t of paper 4: the target mesh onto the disk, bijective or InternalError.
DiskMap map_target_to_disk(const TargetMesh& target, std::size_t n, MapMethod method, const CancelToken* cancel) {
  const PlanarTarget p = planar_target(target, n);
  DiskMap map = map_to_disk({&p.vertices, &target.faces, &p.loop}, method, cancel);
  require_bijective(map, "target mesh");
  return map;
}

}  // namespace

const char* to_string(Stage stage) {
  switch (stage) {
    case Stage::validate: return "validate";
    case Stage::classify: return "classify";
    case Stage::target_mesh: return "target_mesh";
    case Stage::intermediate_maps: return "intermediate_maps";
    case Stage::compose: return "compose";
    case Stage::untangle: return "untangle";
    case Stage::refine: return "refine";
    case Stage::optimize: return "optimize";
    case Stage::verify: return "verify";
    case Stage::quality: return "quality";
  }
  return "unknown";
}

namespace {

// The whole-mesh refinement's target mesh density, relative to options.target_density (see parametrize_once).
constexpr double kWholeMeshTargetDensity = 0.1;

ParametrizeResult parametrize_once(const RawMesh& raw_mesh, const RawBoundary& raw_boundary,
                                   const ParametrizeOptions& options, const CancelToken* cancel,
                                   const ProgressFn& progress, bool relax_max_k, bool whole_mesh = false,
                                   bool fold_region = false);

// Refinement only where the untangler failed (engine/fold_region.h): the regions around the folds of a map of
// the unrefined mesh, each mapped by the paper's path onto the image of its own boundary, spliced, and kept only
// when the whole map passes verify. The maps tried, in order: the composed one (after relocation), whose faces
// outside its folds are as the paper's maps make them, then the untangler's last iterate, which folds less but
// crushes faces near its folds (swirl_blob x weak_fan: 66 inserted, mean K 9.4 from the composed map; 150 and 33.5
// from the iterate). Regions of 2 rings first, then 6 (a larger region's boundary polygon is further from the
// folds, so more often self-overlapping). Empty when no attempt passes: the whole mesh is refined then.
std::optional<RefinedMap> refine_in_fold_regions(const DiskMesh& mesh, const std::vector<int>& loop,
                                                 const BoundaryPolygon& polygon, const std::vector<int>& rotation,
                                                 const std::vector<const std::vector<Point2>*>& starts,
                                                 const ParametrizeOptions& options, const CancelToken* cancel) {
  ParametrizeOptions inner = options;
  inner.max_iterations = 0;  // the whole map is optimized afterwards
  inner.optimize = OptimizeEnergy::none;
  for (const std::vector<Point2>* start : starts) {
    for (int rings : {2, 6}) {
      const std::vector<Point2>& uv = *start;
      const FoldRegions regions = fold_regions(mesh, loop, polygon.vertices, rotation, uv, rings);
      if (!regions.failure.empty()) continue;
      std::vector<RefinedMap> maps;
      try {
        for (const FoldRegion& r : regions.regions)
          maps.push_back(parametrize_once(r.mesh, r.boundary, inner, cancel, {}, false, true, true).map);
      } catch (const InputError&) {  // e.g. a region's boundary polygon is not self-overlapping
        continue;
      } catch (const InternalError&) {
        continue;
      }
      RefinedMap spliced = splice_regions(mesh, uv, regions, maps);
      try {
        verify_map(mesh, loop, polygon, rotation, spliced);
      } catch (const InternalError&) {
        continue;
      }
      spliced.regions = static_cast<int>(regions.regions.size());
      spliced.region_faces = regions.region_faces;
      return spliced;
    }
  }
  return std::nullopt;
}

// One run of the pipeline. relax_max_k: finish with the extremal relaxation (max K) in place of optimize,
// whatever options.method (method extremal's second start, see parametrize below). whole_mesh: when the
// untangler fails, refine the whole mesh, never regions of it: a fold region's own run (refine_in_fold_regions),
// and method extremal's alternative to its start refined in regions (parametrize below). fold_region: a fold
// region's own run, whose boundary is not the answer's (no fixed-face split there).
ParametrizeResult parametrize_once(const RawMesh& raw_mesh, const RawBoundary& raw_boundary,
                                   const ParametrizeOptions& options, const CancelToken* cancel,
                                   const ProgressFn& progress, bool relax_max_k, bool whole_mesh, bool fold_region) {
  const auto start = Clock::now();
  check_options(options);
  ParametrizeResult out;
  StageTimings& time = out.timings;

  struct Validated { DiskMesh mesh; BoundaryMap boundary; };
  Validated input = run_stage(Stage::validate, time.validate, cancel, progress, [&] {
    DiskMesh mesh = validate_mesh(raw_mesh, cancel);
    BoundaryMap boundary = validate_boundary(mesh, raw_boundary, cancel);
    return Validated{std::move(mesh), std::move(boundary)};
  });
  out.boundary_loop = input.boundary.loop;
  out.polygon = input.boundary.polygon;

  // The stages work at a normalized scale (see scale_exponent); out keeps the caller's values.
  const int mesh_k = mesh_exponent(input.mesh.vertices);
  const int polygon_k = polygon_exponent(out.polygon.vertices);
  // At ordinary scales (nearly always) the stages read the validated mesh itself, topology included: no copy.
  std::optional<DiskMesh> scaled_mesh;
  if (mesh_k != 0) {
    scaled_mesh = input.mesh;
    for (Point3& p : scaled_mesh->vertices) p = scaled(p, -mesh_k);
  }
  const DiskMesh& work_mesh = scaled_mesh ? *scaled_mesh : input.mesh;
  BoundaryPolygon work_polygon = out.polygon;
  for (Point2& p : work_polygon.vertices) p = scaled(p, -polygon_k);

  std::optional<ReferenceMetric> metric;  // paper 5.2, when options.metric gives a reference map (below)

  // The stages after refinement, shared by every path: optimize, back to the caller's scale, verify, quality.
  auto finish = [&]() {
    if (options.refine && !out.metric.reproduced && relax_max_k) {
      // The optimize stage lowers an average energy (MIPS, symmetric Dirichlet), which would pull the map away
      // from the extremal one (least worst-case distortion) that method extremal asked for.
      // Instead, the extremal map's own criterion: max K lowered by local minimax moves (engine/extremal_relax.h).
      out.optimization.energy = options.optimize;
      out.optimization.outcome = "not run: method extremal lowers max K instead (diagnostics.extremal.relaxation)";
      out.extremal.relaxation = run_stage(Stage::optimize, time.optimize, cancel, progress, [&] {
        ExtremalRelaxOptions relax;
        relax.time_budget_ms = options.time_budget_ms;
        relax.rotation = out.classification.rotation_indices;
        return relax_max_dilatation(work_mesh, input.boundary.loop, out.map, relax, cancel);
      });
    } else if (options.refine && !out.metric.reproduced) {
      // With a metric the rest shapes are T's triangles (inserted vertices at T's lerp along their edge), so
      // the default optimization lowers the distortion relative to T: it moves the answer towards T's shape.
      std::vector<Point3> rest_r;
      if (metric) {
        rest_r = metric->rest;
        for (const InsertedVertex& iv : out.map.inserted) {
          const Point3 &a = metric->rest[iv.a], &b = metric->rest[iv.b];
          rest_r.push_back({a.x + iv.t * (b.x - a.x), a.y + iv.t * (b.y - a.y), 0});
        }
      }
      out.optimization = run_stage(Stage::optimize, time.optimize, cancel, progress, [&] {
        return optimize_map(work_mesh, input.boundary.loop, signed_area(work_polygon.vertices), out.map, options, cancel,
                            metric ? &rest_r : nullptr, &out.classification.rotation_indices);
      });
    } else if (out.metric.reproduced) {
      out.optimization.outcome = "not needed: the answer is the reference map itself (every triangle at its rest shape)";
    }
    // Where on its edge an inserted point lies is free: the objective of the stage before picks it
    // (engine/slide_inserted.h). Only after an optimization (not with optimize none, nor in a fold region's own
    // run, whose map is optimized as a whole afterwards), and not with a metric, whose rest shapes are T's.
    const bool optimized = relax_max_k || out.optimization.ran;
    if (optimized && !metric && !out.map.inserted.empty()) {
      out.sliding = run_stage(Stage::optimize, time.optimize, cancel, {}, [&] {
        return slide_inserted_points(work_mesh, out.map, relax_max_k ? SlideObjective::max_k : SlideObjective::mean_k,
                                     cancel);
      });
    }
    // A face that the polygon pins and makes too thin to be stored as float32 gets a point on its chord
    // (engine/fixed_face_split.h); not in a reproduced reference map, which is returned as it is, nor in a fold
    // region, whose boundary vertices are not pinned in the answer.
    if (options.refine && !out.metric.reproduced && !fold_region)
      out.fixed_faces = split_unstorable_fixed_faces(work_mesh, input.boundary.loop, out.polygon.vertices, out.map);
    // Quality is scale-invariant: measured at the working scale, where areas neither overflow nor underflow.
    // (Copies only when a scale applies: otherwise to_caller_scale leaves the values as they are.)
    const bool rescaled = mesh_k != 0 || polygon_k != 0;
    std::vector<Point3> work_vertices;
    std::vector<Point2> work_uv;
    if (rescaled) {
      work_vertices = out.map.vertices;
      work_uv = out.map.uv;
    }
    to_caller_scale(out.map, input.mesh, input.boundary.loop, out.polygon, polygon_k);
    out.flipped = count_non_positive(out.map.uv, out.map.faces);

    if (options.refine) {
      run_stage(Stage::verify, time.verify, cancel, progress, [&] {
        return verify_map(input.mesh, input.boundary.loop, out.polygon, out.classification.rotation_indices, out.map);
      });
    }
    out.distortion = run_stage(Stage::quality, time.quality, cancel, progress,
                               [&] {
      return conformal_distortion(rescaled ? work_vertices : out.map.vertices, out.map.faces,
                                  rescaled ? work_uv : out.map.uv);
    });
    if (metric) out.metric.distance = distance_to_reference(out.map.uv, *options.metric, out.polygon);
    time.total = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  };

  out.classification = run_stage(Stage::classify, time.classify, cancel, progress,
                                 [&] { return classify(work_polygon, cancel); });
  if (out.classification.verdict == Verdict::not_self_overlapping) throw NotSelfOverlapping(out.classification);
  // When nobody prescribed the rotation indices, the untangler may end with the extra turns elsewhere than the
  // classification put them (any placement is an answer, paper 3.1). The classification is then made again with
  // the untangled map's indices prescribed, so that the answer reports one consistent triangulation; such a map
  // proves that one exists, and if classify disagrees the map is not taken (refinement follows as usual).
  auto untangle_freely = [&] { return out.classification.stats.free_rotation_search; };
  auto adopt_untangled_rotation = [&] {
    Untangling& u = out.untangling;
    if (!u.succeeded || u.rotation_indices == out.classification.rotation_indices) return;
    const auto t0 = Clock::now();
    BoundaryPolygon placed = work_polygon;
    placed.rotation_indices = u.rotation_indices;
    Classification c = classify(placed, cancel);
    time.classify += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (c.verdict == Verdict::not_self_overlapping) {
      u.succeeded = false;
      u.outcome = "failed: every face positive with rotation indices that classify refuses (" + c.reason + ")";
      return;
    }
    c.stats.free_rotation_search = true;
    out.classification = std::move(c);
    u.outcome += "; the extra turns at other boundary vertices than the classification's";
  };

  // Paper 5.2: a reference map T's metric. A locally injective T (or T with its boundary moved onto the
  // polygon) is the answer itself: the paper's reproduction property (h = T), taken literally rather than
  // recomputed, since solving again could only add rounding. Else T is untangled with T's triangles as rest
  // shapes; only when that fails does the usual pipeline run, with h_s built in T's metric.
  if (options.metric) {
    check_cancel(cancel);
    const auto t0 = Clock::now();
    std::vector<Point2> reference = *options.metric;
    if (reference.size() == work_mesh.vertices.size())
      for (Point2& p : reference) p = scaled(p, -polygon_k);
    metric = reference_metric(work_mesh, reference);
    out.metric.given = true;
    out.metric.reference_flipped = metric->flipped;
    out.metric.corrected_faces = metric->corrected;
    for (std::size_t k = 0; k < input.boundary.loop.size(); ++k) reference[input.boundary.loop[k]] = work_polygon.vertices[k];
    time.intermediate_maps += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    const std::vector<int>& rotation = out.classification.rotation_indices;
    RefinedMap candidate;
    candidate.vertices = work_mesh.vertices;
    candidate.faces = work_mesh.faces;
    const bool valid = run_stage(Stage::verify, time.verify, cancel, progress, [&] {
      if (count_non_positive(reference, work_mesh.faces) > 0) return false;
      candidate.uv = reference;
      try {
        verify_map(work_mesh, input.boundary.loop, work_polygon, rotation, candidate);
      } catch (const InternalError&) {
        return false;
      }
      return true;
    });
    if (valid) {
      out.map = std::move(candidate);
      out.metric.path = "reference";
      out.metric.reproduced = true;
      for (std::size_t k = 0; k < input.boundary.loop.size() && out.metric.reproduced; ++k)
        out.metric.reproduced = (*options.metric)[input.boundary.loop[k]] == out.polygon.vertices[k];
      finish();
      return out;
    }
    if (options.refine && options.untangle) {
      out.untangling = run_stage(Stage::untangle, time.untangle, cancel, progress, [&] {
        return untangle(work_mesh, input.boundary.loop, work_polygon, rotation, reference, cancel, &metric->rest,
                        untangle_freely());
      });
      adopt_untangled_rotation();
      if (out.untangling.succeeded) {
        out.map = untangled_map(work_mesh, out.untangling);
        out.metric.path = "untangled";
        finish();
      return out;
      }
    }
    out.metric.path = "composed";
  }

  // A strictly convex P: one map straight onto it (engine/direct_map.h), kept only when exactly verified;
  // otherwise the paper's path below.
  if (!metric && options.refine && options.method != MapMethod::extremal &&
      strictly_convex(work_polygon, out.classification.rotation_indices)) {
    DirectMap direct = run_stage(Stage::intermediate_maps, time.intermediate_maps, cancel, progress, [&] {
      return map_onto_convex_polygon(work_mesh, input.boundary.loop, work_polygon, options.method, cancel);
    });
    const bool valid = direct.flipped == 0 && run_stage(Stage::verify, time.verify, cancel, progress, [&] {
      try {
        verify_map(work_mesh, input.boundary.loop, work_polygon, out.classification.rotation_indices, direct.map);
      } catch (const InternalError&) {
        return false;
      }
      return true;
    });
    if (valid) {
      out.map = std::move(direct.map);
      out.source_map_solution = direct.solution;
      finish();
      return out;
    }
  }

  // Paper 4's target mesh M_t at a density, and its summary in the answer.
  auto make_target_mesh = [&](double density) {
    TargetMeshOptions mesher;
    mesher.density = density;
    mesher.source_triangles = static_cast<int>(input.mesh.faces.size());
    return build_target_mesh(work_polygon, out.classification.triangulation, mesher, cancel);
  };
  auto summarize = [&](const TargetMesh& t) {
    out.target_mesh = {static_cast<int>(t.vertices.size()), static_cast<int>(t.faces.size()), t.pieces, t.min_angle_deg};
  };
  // Paper 4's target side for h_s: M_t, h_t and the composition f = h_t^-1 o h_s with tangled vertices relocated
  // (its source_disk is h_s with those moved; refine works on it). Held on the heap: the composition's walk refers
  // to the mesh's topology, so a side is kept or dropped whole, never moved apart.
  struct TargetSide {
    TargetMesh mesh;
    DiskMap disk;
    std::vector<Point2> source_disk;
    Composition composition;
    Relocation relocation;
  };
  auto compose_side = [&](TargetMesh mesh, DiskMap h_t, const std::vector<Point2>& h_s) {
    auto side = std::make_unique<TargetSide>();
    side->mesh = std::move(mesh);
    side->disk = std::move(h_t);
    side->source_disk = h_s;
    side->composition = compose(work_mesh, input.boundary.loop, side->source_disk, side->mesh, side->disk.uv, cancel);
    side->relocation = relocate_tangled_vertices(work_mesh, input.boundary.loop, side->source_disk,
                                                 side->composition, side->mesh, cancel);
    return side;
  };
  // Another target side of the paper's path (harmonic or Tutte h_t), M_t at `density`.
  auto side_at_density = [&](double density, const std::vector<Point2>& h_s) {
    TargetMesh mesh = make_target_mesh(density);
    DiskMap h_t = map_target_to_disk(mesh, work_polygon.vertices.size(), options.method, cancel);
    return compose_side(std::move(mesh), std::move(h_t), h_s);
  };

  // The paper's path. Its target mesh, both disk maps and the composition end with this block: the map is
  // built, and at 1M triangles they hold tens of MB beside the optimization's factorization, the run's peak.
  {
    TargetMesh target = run_stage(Stage::target_mesh, time.target_mesh, cancel, progress,
                                  [&] { return make_target_mesh(options.target_density); });
    summarize(target);

    struct DiskMaps { DiskMap source, target; };
    DiskMaps disk = run_stage(Stage::intermediate_maps, time.intermediate_maps, cancel, progress, [&] {
      DiskMaps maps;
      if (options.method == MapMethod::extremal) {
        // Paper 5.3: both onto a convex domain M_c, the target conformally, the source by a Teichmuller map.
        const PlanarTarget planar = planar_target(target, work_polygon.vertices.size());
        ConvexDomain domain = map_to_convex_domain({&planar.vertices, &target.faces, &planar.loop}, cancel);
        maps.target = std::move(domain.map);
        require_bijective(maps.target, "target mesh");
        DiskMapInput source_in{&work_mesh.vertices, &work_mesh.faces, &input.boundary.loop};
        source_in.boundary_positions = &domain.boundary;
        TeichmullerMap teich = teichmuller_map(source_in, work_mesh.topology, {}, cancel);
        maps.source = std::move(teich.map);
        require_bijective(maps.source, "source mesh");
        ExtremalReport& e = out.extremal;
        e.ran = true;
        e.conformal_boundary = domain.conformal_boundary;
        e.domain_fallback = domain.fallback;
        e.closing_change = domain.closing_change;
        e.scale_factor_range = domain.scale_factor_range;
        e.k = teich.k;
        e.iterations = teich.iterations;
        e.chosen_iteration = teich.chosen_iteration;
        e.folded_iterates = teich.folded_iterates;
        e.harmonic_max_dilatation = teich.harmonic_max_dilatation;
        e.max_dilatation = teich.max_dilatation;
        return maps;
      }
      const DiskMapInput source_input{&work_mesh.vertices, &work_mesh.faces, &input.boundary.loop};
      // Paper 5.2: h_s's cotangent weights from T's edge lengths (Tutte's uniform weights have no metric).
      if (metric && options.method == MapMethod::harmonic)
        maps.source = map_to_disk_with_laplacian(
            source_input,
            laplacian_from_cotangents(static_cast<int>(work_mesh.vertices.size()), work_mesh.faces, metric->cotangents),
            true, cancel);
      else
        maps.source = map_to_disk(source_input, options.method, cancel);
      require_bijective(maps.source, "source mesh");
      maps.target = map_target_to_disk(target, work_polygon.vertices.size(), options.method, cancel);
      return maps;
    });
    out.source_map_solution = disk.source.solution;
    out.target_map_solution = disk.target.solution;
    const std::vector<Point2>& h_s = disk.source.uv;

    std::unique_ptr<TargetSide> side = run_stage(Stage::compose, time.compose, cancel, progress, [&] {
      return compose_side(std::move(target), std::move(disk.target), h_s);
    });
    out.relocation = side->relocation;

    // Where the extra turn goes, when the caller did not say (paper 3.1 leaves it open): the free search keeps
    // the first triangulation its table finds, and its vertex with R = 1 often has 2 or 3 faces for an angle of
    // about 3 pi (a boundary vertex with d faces spans less than d pi). Then the boundary vertices with the most
    // room are tried as well, each exactly classified with that prescription, and the placement whose composed
    // map folds least is kept: on the bench's weak_fan rows (one seed) the fewer folds went with the fewer
    // inserted points in all 11 cases tried (engine/rotation_placement.h).
    if (options.refine && options.untangle && !metric && options.method == MapMethod::harmonic &&
        out.relocation.flipped_before > 0) {
      const auto t0 = Clock::now();
      for (int k : rotation_placement_candidates(work_mesh, input.boundary.loop, work_polygon, out.classification)) {
        BoundaryPolygon prescribed = work_polygon;
        prescribed.rotation_indices = std::vector<int>(work_polygon.vertices.size(), 0);
        (*prescribed.rotation_indices)[static_cast<std::size_t>(k)] = 1;
        Classification placed = classify(prescribed, cancel);
        if (placed.verdict == Verdict::not_self_overlapping) continue;
        placed.stats.free_rotation_search = true;
        std::swap(out.classification, placed);  // make_target_mesh triangulates by out.classification
        try {
          std::unique_ptr<TargetSide> candidate = side_at_density(options.target_density, h_s);
          if (candidate->relocation.flipped_before < side->relocation.flipped_before) {
            side = std::move(candidate);
            out.relocation = side->relocation;
            out.target_map_solution = side->disk.solution;
            summarize(side->mesh);
            continue;
          }
        } catch (const InternalError&) {
        }
        std::swap(out.classification, placed);  // not better: the placement as it was
      }
      time.classify += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    }

    // Untangle the unrefined map when it folds; refinement (paper 4) only when that fails (engine/untangle.h).
    if (options.refine && options.untangle) {
      out.untangling = run_stage(Stage::untangle, time.untangle, cancel, progress, [&] {
        return untangle(work_mesh, input.boundary.loop, work_polygon, out.classification.rotation_indices,
                        side->composition.uv, cancel, metric ? &metric->rest : nullptr, untangle_freely());
      });
      adopt_untangled_rotation();
    }
    out.map = run_stage(Stage::refine, time.refine, cancel, progress, [&] {
      // An untangled map is the answer as it stands: refine(..., false) would only rebuild the composed map
      // that it replaces (and its flip count, which is reported from the relocation below).
      if (out.untangling.succeeded) return untangled_map(work_mesh, out.untangling);
      if (!whole_mesh && out.untangling.attempted && !metric) {
        std::optional<RefinedMap> local =
            refine_in_fold_regions(work_mesh, input.boundary.loop, work_polygon, out.classification.rotation_indices,
                                   {&side->composition.uv, &out.untangling.uv}, options, cancel);
        if (local) return std::move(*local);
      }
      // The whole mesh then. Its points are where the source edges cross the target mesh's edges (paper 4), and
      // any triangulation of P serves the guarantee: one a tenth as dense crosses fewer (bench_quality: maze onto
      // exp_strip 96,772 -> 67,702 points, bent_strip 75,281 -> 54,715, spiral_arm 62,818 -> 53,306, weak_fan
      // 10,380 -> 2,055), and the simplification, the refinement's cost there, has fewer to remove. A target
      // side is made again for it (tens of ms beside seconds); if that fails, the first one serves. (A density
      // so small that a tenth of it is 0 keeps the first one too.)
      const double coarse_density = kWholeMeshTargetDensity * options.target_density;
      if (!whole_mesh && out.untangling.attempted && !metric && options.method != MapMethod::extremal &&
          coarse_density > 0) {
        try {
          const std::unique_ptr<TargetSide> coarse = side_at_density(coarse_density, h_s);
          RefinedMap m = refine(work_mesh, input.boundary.loop, out.classification.rotation_indices,
                                coarse->source_disk, coarse->mesh, coarse->disk.uv, coarse->composition,
                                options.refine, cancel);
          summarize(coarse->mesh);
          out.relocation = coarse->relocation;
          return m;
        } catch (const InternalError&) {
        }
      }
      return refine(work_mesh, input.boundary.loop, out.classification.rotation_indices, side->source_disk,
                    side->mesh, side->disk.uv, side->composition, options.refine, cancel);
    });
  }
  // Reported as the paper's "flipped before refinement": the composed map's flips, before relocation.
  out.map.flipped_before_refinement = out.relocation.flipped_before;
  finish();
  return out;
}

// max K over the faces with a corner off the boundary loop (faces with three boundary corners are the same in
// every map with this boundary; see ExtremalRelaxation::fixed_max).
double movable_max_k(const ParametrizeResult& r) {
  std::vector<char> on_loop(r.map.uv.size(), 0);
  for (int v : r.boundary_loop) on_loop[static_cast<std::size_t>(v)] = 1;
  double m = 1;
  for (std::size_t f = 0; f < r.map.faces.size() && f < r.distortion.per_face.size(); ++f)
    if (!pinned_by_boundary(r.map.faces[f], on_loop)) m = std::max(m, r.distortion.per_face[f]);
  return m;
}

}  // namespace

ParametrizeResult parametrize(const RawMesh& raw_mesh, const RawBoundary& raw_boundary,
                              const ParametrizeOptions& options, const CancelToken* cancel,
                              const ProgressFn& progress) {
  const bool extremal = options.method == MapMethod::extremal;
  if (!extremal || !options.refine || options.metric) return parametrize_once(raw_mesh, raw_boundary, options, cancel, progress, extremal);
  // Method extremal (paper 5.3) asks for the least max K. The composed Teichmuller map is only approximately
  // extremal: its refinement pins the corners of refined faces, and the Lui-Lam iterate is kept flip-free, so
  // on some inputs the harmonic method's map, relaxed the same way, has the lower max K. Both starts are
  // relaxed (engine/extremal_relax.h) and the lower max K is kept (ties: fewer inserted points, the lower max K
  // over faces with a corner off the boundary, then the Teichmuller start). The harmonic start runs first and
  // reports no progress (the stages then report once, for the Teichmuller start).
  // Where the untangler leaves folds, the Teichmuller start is refined in regions around them, as the harmonic
  // method's map is; that usually keeps fewer points and relaxes to a lower max K (swirl_domain / weak_fan: 32
  // points and max K 10.7, refined as a whole 138 and 32.6), but not always (wiggly_strip / weak_fan: 783
  // against 150). So when it was refined in regions and lost to the harmonic start, the start refined as a whole
  // is relaxed too (no progress reported) and competes with the two others on the same terms (ties: regions
  // first).
  ParametrizeOptions harmonic = options;
  harmonic.method = MapMethod::harmonic;
  // Ties in max K come when the worst face is one that no start moved, e.g. one with three boundary corners
  // (mountain / weak_fan: 177.26 in both starts).
  auto lower = [](const ParametrizeResult& a, const ParametrizeResult& b) {
    if (a.distortion.max != b.distortion.max) return a.distortion.max < b.distortion.max;
    if (a.map.inserted.size() != b.map.inserted.size()) return a.map.inserted.size() < b.map.inserted.size();
    return movable_max_k(a) < movable_max_k(b);
  };
  std::vector<ParametrizeResult> starts;  // harmonic, Teichmuller, Teichmuller refined as a whole
  starts.push_back(parametrize_once(raw_mesh, raw_boundary, harmonic, cancel, {}, true));
  starts.push_back(parametrize_once(raw_mesh, raw_boundary, options, cancel, progress, true));
  // Only when the start refined in regions lost to the harmonic one: relaxing a refined map is most of method
  // extremal's time (mountain / weak_fan: 244 s with two starts, 370 s with three).
  if (starts[1].map.regions > 0 && lower(starts[0], starts[1]))
    starts.push_back(parametrize_once(raw_mesh, raw_boundary, options, cancel, {}, true, true));
  std::size_t kept = 1;
  for (std::size_t i : {std::size_t{2}, std::size_t{0}})
    if (i < starts.size() && lower(starts[i], starts[kept])) kept = i;
  std::size_t runner_up = kept == 0 ? 1 : 0;
  double total_ms = 0;
  for (std::size_t i = 0; i < starts.size(); ++i) {
    total_ms += starts[i].timings.total;
    if (i != kept && lower(starts[i], starts[runner_up])) runner_up = i;
  }
  // The Teichmuller iteration's report is the Teichmuller start's whichever map is kept.
  ExtremalReport report = starts[1].extremal;
  report.relaxation = starts[kept].extremal.relaxation;
  if (kept == 0) report.relaxation.start = "harmonic";
  report.relaxation.other_start_max = starts[runner_up].distortion.max;
  report.relaxation.other_start_ms = total_ms - starts[kept].timings.total;
  ParametrizeResult best = std::move(starts[kept]);
  best.timings.total = total_ms;
  best.extremal = std::move(report);
  return best;
}

}  // namespace lipmap
