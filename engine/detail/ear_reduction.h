// Ear clipping before the Shor–van Wyk table (paper App. C). Internal to the classify stage.
#pragma once

#include <functional>
#include <vector>

#include "engine/cancel.h"
#include "engine/detail/exact_predicates.h"
#include "engine/geometry.h"

namespace lipmap::detail {

struct EarReduction {
  std::vector<int> remaining;   // polygon vertices still present, in order (indices into the input)
  std::vector<int> turns;       // prescribed full turns of the remaining vertices, updated by the clips
  std::vector<Triangle> ears;   // clipped triangles, input indices, each strictly positive
};

// Clips ears (v_{i-1}, v_i, v_{i+1}) while it is safe: v_i strictly convex with zero prescribed turns, and
// the closed ear triangle meets the polygon only in its two polygon edges (the neighbouring edges may touch
// it at their shared vertex, from outside). Such a triangle lifts into every triangulated immersed disk
// bounded by P, so P meets the prescribed angles iff the clipped polygon meets the updated ones.
// `turns[k]` is the full-turn count of the prescribed angle at k (see shor_van_wyk). Stops at 3 vertices.
// `allowed` (indices into `polygon`), when given, can forbid ears besides the unsafe ones.
EarReduction clip_ears(const std::vector<Pt>& polygon, std::vector<int> turns, const CancelToken* cancel,
                       const std::function<bool(int, int, int)>* allowed = nullptr);

}  // namespace lipmap::detail
