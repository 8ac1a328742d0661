// A picture of a map people can look at (`lipmap map --preview OUT.svg`): the uv triangles filled by their
// conformal distortion K (with a colour legend), every non-positive triangle in red, the target polygon's
// outline, inserted vertices and singular boundary vertices marked, and a caption with the verdict, the
// counts and the distortion. Self-contained SVG 1.1 (no script, no external reference, no dependency),
// viewBox in uv units fitted to the uv bounding box, y up.
//
// Structure (stable, the tests rely on it):
//   <g id="triangles" transform="translate(x0 y0) scale(1 -1)">   uv (u, v) drawn at (u - x0, v - y0), y up
//     <g class="bin-i" fill="#...">   one group per distortion bin that has triangles, i = 0 .. 7
//       <polygon points="..."/>       one per triangle
//     <g class="flipped" fill="#e31a1c">   the non-positive triangles (exact orientation test)
//   <g id="outline" ...>      the target polygon (closed polyline)
//   <g id="inserted" ...>     one <circle> per inserted vertex
//   <g id="singular" ...>     one <circle> per singular boundary vertex
//   <g id="legend">, <g id="caption">
#pragma once

#include <string>
#include <vector>

#include "engine/geometry.h"

namespace lipmap {
struct ParametrizeResult;
}

namespace lipmap::preview {

// Fill colours: one per histogram bin of the distortion (edges 1, 1.1, 1.25, 1.5, 2, 3, 5, 10, inf) and
// the colour of non-positive triangles.
inline constexpr const char* kFlippedColour = "#e31a1c";
const std::vector<double>& bin_edges();          // 1, 1.1, ..., 10, inf (9 values, 8 bins)
const std::vector<std::string>& bin_colours();   // 8 colours
int bin_of(double k);                            // 0 .. 7 (K = inf or NaN: 7)

struct MapPicture {
  std::vector<Point2> uv;
  std::vector<Triangle> faces;
  std::vector<double> distortion;  // K per face (same size as faces), or empty: every triangle in bin 0
  std::vector<Point2> outline;     // the target polygon (drawn closed); may be empty
  std::vector<int> inserted;       // vertex indices to mark as inserted
  std::vector<int> singular;       // vertex indices to mark as singular
  std::vector<std::string> caption;  // lines under the picture (UTF-8; escaped on output)
  std::string title;
};

struct SvgOptions {
  int width_px = 960;  // rendered width; the height follows the aspect ratio
};

// Throws InternalError when a face index is out of range of uv or distortion has the wrong size.
std::string render_svg(const MapPicture& picture, const SvgOptions& options = {});

// The picture of a pipeline result: uv and faces of the refined map, K from result.distortion, outline =
// result.polygon, inserted vertices, singular vertices, and a caption with the verdict, the counts
// (vertices, triangles, inserted, flipped before refinement, flipped) and the distortion max / mean.
MapPicture picture_of(const ParametrizeResult& result, const std::string& title = "lipmap map");

}  // namespace lipmap::preview
