// The whole engine as one call (docs/architecture.md): validate -> classify -> target mesh -> intermediate
// maps -> compose -> untangle -> refine -> optimize -> verify -> quality. Each stage is timed; the cancel token is checked between
// stages and inside long loops; progress is reported by stage. No transport here: the CLI and the HTTP
// server both call parametrize().
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "engine/cancel.h"
#include "engine/classify.h"
#include "engine/disk_mesh.h"
#include "engine/error.h"
#include "engine/extremal_relax.h"
#include "engine/fixed_face_split.h"
#include "engine/intermediate_map.h"
#include "engine/optimize.h"
#include "engine/parametrize_options.h"
#include "engine/quality.h"
#include "engine/reference_metric.h"
#include "engine/refine.h"
#include "engine/relocate.h"
#include "engine/slide_inserted.h"
#include "engine/untangle.h"
#include "engine/verify.h"

namespace lipmap {

enum class Stage {
  validate, classify, target_mesh, intermediate_maps, compose, untangle, refine, optimize, verify, quality
};
const char* to_string(Stage stage);

// Called at the start of every stage (fraction 0) and when it ends (fraction 1); long stages may report
// in between. Must be cheap and must not throw.
using ProgressFn = std::function<void(Stage stage, double fraction)>;

struct StageTimings {  // milliseconds
  double validate = 0, classify = 0, target_mesh = 0, intermediate_maps = 0, compose = 0, untangle = 0,
         refine = 0, optimize = 0, verify = 0, quality = 0, total = 0;
};

struct TargetMeshSummary {
  int vertices = 0, faces = 0, pieces = 0;
  double min_angle_deg = 0;
};

// Method extremal (paper 5.3): how the convex domain and the Teichmuller map came out.
struct ExtremalReport {
  bool ran = false;
  // h_t->i (engine/convex_domain.h)
  bool conformal_boundary = false;  // false: the domain fell back to the unit disk positions (why: domain_fallback)
  std::string domain_fallback;
  double closing_change = 0;        // largest relative length change that closed the boundary curve
  double scale_factor_range = 0;    // max - min log scale factor on the boundary
  // h_s->i (engine/teichmuller.h)
  double k = 0;                     // |mu| of the chosen iterate's coefficient (0: the harmonic start)
  int iterations = 0, chosen_iteration = 0, folded_iterates = 0;
  // max K of h_s->i over the faces with a corner off the boundary: harmonic start, answer
  double harmonic_max_dilatation = 1, max_dilatation = 1;
  // The refined map's max K lowered by a p-norm descent and local minimax moves (engine/extremal_relax.h), in
  // place of optimize.
  ExtremalRelaxation relaxation;
};

struct ParametrizeResult {
  Classification classification;    // verdict, turning number, singular vertices, coarse triangulation
  std::vector<int> boundary_loop;   // boundary vertex loop[k] is pinned to polygon vertex k
  BoundaryPolygon polygon;
  RefinedMap map;                   // refined mesh, uv, inserted vertices
  TargetMeshSummary target_mesh;
  DiskMapSolution source_map_solution = DiskMapSolution::primary, target_map_solution = DiskMapSolution::primary;
  Distortion distortion;
  Relocation relocation;            // flips of the composed map, and the vertices moved to undo some (compose)
  Untangling untangling;            // flips before and after untangling; succeeded: no refinement was needed
  Optimization optimization;        // energy and distortion before optimization (after: `distortion`)
  Sliding sliding;                  // inserted points slid along their edges after it (engine/slide_inserted.h)
  FixedFaceSplit fixed_faces;       // fixed faces not storable as float32, and the chords split for them
  ExtremalReport extremal;          // method extremal only (ran: false otherwise)
  MetricReport metric;              // options.metric (paper 5.2): the path taken, T's flips, distance to T
  int flipped = 0;                  // non-positive uv triangles of the result: 0 whenever refine is on
  StageTimings timings;
};

// The boundary polygon admits no locally injective map (for the prescribed rotation indices, if any).
// An InputError with code "not_self_overlapping" that also carries the classification.
class NotSelfOverlapping : public InputError {
public:
  explicit NotSelfOverlapping(Classification c)
      : InputError("not_self_overlapping", "the boundary polygon is not self-overlapping: " + c.reason),
        classification_(std::move(c)) {}
  const Classification& classification() const { return classification_; }

private:
  Classification classification_;
};

// With options.metric (paper 5.2, engine/reference_metric.h), after classify: a locally injective reference map
// T whose boundary is the polygon is returned as it is (no insertion); else T is untangled with T's triangles
// as rest shapes; else the stages above run with h_s in T's metric (refinement keeps paper 4's guarantee).
// Optimization then measures distortion against T's triangles.
// Method extremal without a metric runs the pipeline twice (the harmonic method's map as a second start of the
// max K relaxation, the harmonic run first and without progress reports) and keeps the lower max K.
// Throws InputError (validation, options, NotSelfOverlapping), Cancelled, or InternalError when a result
// fails verify (never returned).
ParametrizeResult parametrize(const RawMesh& mesh, const RawBoundary& boundary, const ParametrizeOptions& options,
                              const CancelToken* cancel = nullptr, const ProgressFn& progress = {});

}  // namespace lipmap
