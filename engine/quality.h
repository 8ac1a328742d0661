// Stage "quality" (paper 6, Table 1, Fig. 19): conformal distortion of the finished map, per triangle, as
// K = sigma_1 / sigma_2 >= 1, the ratio of the singular values of the map's Jacobian from the 3D triangle
// to its uv triangle (1: conformal on that triangle).
#pragma once

#include <vector>

#include "engine/geometry.h"

namespace lipmap {

struct Distortion {
  double max = 1, mean = 1;            // mean weighted by 3D area
  std::vector<double> bin_edges;        // histogram of K over faces: counts[i] faces with edges[i] <= K < edges[i+1]
  std::vector<int> counts;              // (the last bin is open above)
  std::vector<double> per_face;         // K of every face
};

Distortion conformal_distortion(const std::vector<Point3>& vertices, const std::vector<Triangle>& faces,
                                const std::vector<Point2>& uv);

}  // namespace lipmap
