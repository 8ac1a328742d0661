// The engine's options, std-only so that the codecs (JSON, glTF, the request loader) include them rather
// than redefine them: engine/pipeline.h and engine/intermediate_map.h pull in Eigen and OpenMesh.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "engine/geometry.h"

namespace lipmap {

// How the intermediate maps are built (paper 4 and 5.1; engine/intermediate_map.h). extremal (paper 5.3):
// both meshes onto a convex domain instead of the disk, the target conformally (engine/convex_domain.h),
// the source by an approximate Teichmuller map (engine/teichmuller.h).
enum class MapMethod { tutte, harmonic, extremal };

const char* to_string(MapMethod method);  // "tutte", "harmonic", "extremal" (engine/intermediate_map.cpp)

// The energy the optimize stage lowers (engine/optimize.h): none (the map as refined), mips (the default:
// tr(J^T J) / det J = K + 1/K, conformal distortion) or symmetric_dirichlet (|J|^2 + |J^-1|^2).
enum class OptimizeEnergy { none, mips, symmetric_dirichlet };

const char* to_string(OptimizeEnergy energy);  // "none", "mips", "symmetric_dirichlet" (engine/optimize.cpp)
bool parse_optimize_energy(const std::string& name, OptimizeEnergy& out);  // false for an unknown name

// Upper bound of max_iterations (a larger value is refused as an option error).
inline constexpr int kMaxOptimizeIterations = 100000;

struct ParametrizeOptions {
  MapMethod method = MapMethod::harmonic;
  bool refine = true;           // false: the vertex-wise map only (may have flips; reported, never verified)
  double target_density = 1.0;  // target mesh triangles ~ density * source triangles
  // Untangling (before refine) and optimization (after it) run only with refine on.
  bool untangle = true;         // false: refine whenever the composed map folds (the paper's path only)
  OptimizeEnergy optimize = OptimizeEnergy::mips;
  int max_iterations = 1000;    // optimization steps, at most; 0 turns optimization off
  double time_budget_ms = 0;    // wall time of the optimize stage, at most; 0: no budget (max_iterations only)
  // The metric of the source's harmonic map (paper 5.2, engine/reference_metric.h): none for the surface's
  // own (3D) metric; else a reference map T, one uv per source vertex, whose edge lengths |T(a) - T(b)| are
  // the metric. A locally injective T with T's boundary as the polygon comes back as T itself.
  std::optional<std::vector<Point2>> metric;
};

}  // namespace lipmap
