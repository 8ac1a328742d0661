// The engine as one call: each stage a function from one value to the next (docs/architecture.md).
#include "engine/pipeline.h"

#include <chrono>
#include <cmath>
#include <numeric>

#include "engine/compose.h"
#include "engine/target_mesh.h"
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
}

void require_bijective(const DiskMap& map, const char* which) {
  if (map.bijective()) return;
  throw InternalError(std::string("the intermediate map of the ") + which + " onto the disk has " +
                      std::to_string(map.flipped) + " flipped triangles even after recovery (floating point crowding)");
}

}  // namespace

const char* to_string(Stage stage) {
  switch (stage) {
    case Stage::validate: return "validate";
    case Stage::classify: return "classify";
    case Stage::target_mesh: return "target_mesh";
    case Stage::intermediate_maps: return "intermediate_maps";
    case Stage::compose: return "compose";
    case Stage::refine: return "refine";
    case Stage::verify: return "verify";
    case Stage::quality: return "quality";
  }
  return "unknown";
}

ParametrizeResult parametrize(const RawMesh& raw_mesh, const RawBoundary& raw_boundary,
                              const ParametrizeOptions& options, const CancelToken* cancel,
                              const ProgressFn& progress) {
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

  out.classification = run_stage(Stage::classify, time.classify, cancel, progress,
                                 [&] { return classify(out.polygon, cancel); });
  if (out.classification.verdict == Verdict::not_self_overlapping) throw NotSelfOverlapping(out.classification);

  const TargetMesh target = run_stage(Stage::target_mesh, time.target_mesh, cancel, progress, [&] {
    TargetMeshOptions mesher;
    mesher.density = options.target_density;
    mesher.source_triangles = static_cast<int>(input.mesh.faces.size());
    return build_target_mesh(out.polygon, out.classification.triangulation, mesher, cancel);
  });
  out.target_mesh = {static_cast<int>(target.vertices.size()), static_cast<int>(target.faces.size()), target.pieces,
                     target.min_angle_deg};

  struct DiskMaps { DiskMap source, target; };
  const DiskMaps disk = run_stage(Stage::intermediate_maps, time.intermediate_maps, cancel, progress, [&] {
    DiskMaps maps;
    maps.source = map_to_disk({&input.mesh.vertices, &input.mesh.faces, &input.boundary.loop}, options.method, cancel);
    require_bijective(maps.source, "source mesh");
    std::vector<Point3> planar(target.vertices.size());
    for (std::size_t v = 0; v < planar.size(); ++v) planar[v] = {target.vertices[v].x, target.vertices[v].y, 0};
    std::vector<int> target_loop(out.polygon.vertices.size());
    std::iota(target_loop.begin(), target_loop.end(), 0);
    maps.target = map_to_disk({&planar, &target.faces, &target_loop}, options.method, cancel);
    require_bijective(maps.target, "target mesh");
    return maps;
  });
  out.source_map_solution = disk.source.solution;
  out.target_map_solution = disk.target.solution;

  // Relocation moves tangled vertices' disk points (h_s becomes h_s'), so refine works on this copy.
  std::vector<Point2> source_disk = disk.source.uv;
  const Composition composition = run_stage(Stage::compose, time.compose, cancel, progress, [&] {
    Composition c = compose(input.mesh, input.boundary.loop, source_disk, target, disk.target.uv, cancel);
    out.relocation = relocate_tangled_vertices(input.mesh, input.boundary.loop, source_disk, c, target, cancel);
    return c;
  });

  out.map = run_stage(Stage::refine, time.refine, cancel, progress, [&] {
    return refine(input.mesh, input.boundary.loop, out.classification.rotation_indices, source_disk, target,
                  disk.target.uv, composition, options.refine, cancel);
  });
  // Reported as the paper's "flipped before refinement": the composed map's flips, before relocation.
  out.map.flipped_before_refinement = out.relocation.flipped_before;
  out.flipped = count_non_positive(out.map.uv, out.map.faces);

  if (options.refine) {
    run_stage(Stage::verify, time.verify, cancel, progress, [&] {
      return verify_map(input.mesh, input.boundary.loop, out.polygon, out.classification.rotation_indices, out.map);
    });
  }
  out.distortion = run_stage(Stage::quality, time.quality, cancel, progress,
                             [&] { return conformal_distortion(out.map.vertices, out.map.faces, out.map.uv); });
  time.total = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  return out;
}

}  // namespace lipmap
