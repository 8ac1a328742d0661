// The engine's options, std-only so that the codecs (JSON, glTF, the request loader) include them rather
// than redefine them: engine/pipeline.h and engine/intermediate_map.h pull in Eigen and OpenMesh.
#pragma once

namespace lipmap {

// How the intermediate maps onto the disk are built (paper 4 and 5.1; engine/intermediate_map.h).
enum class MapMethod { tutte, harmonic };

const char* to_string(MapMethod method);  // "tutte", "harmonic" (engine/intermediate_map.cpp)

struct ParametrizeOptions {
  MapMethod method = MapMethod::harmonic;
  bool refine = true;           // false: the vertex-wise map only (may have flips; reported, never verified)
  double target_density = 1.0;  // target mesh triangles ~ density * source triangles
};

}  // namespace lipmap
