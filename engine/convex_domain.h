// Stage "intermediate maps", method extremal, target side (paper 5.3): h_t->i, a conformal map of a disk
// mesh (the target mesh M_t) onto a convex domain M_c with prescribed positive boundary curvature, edge
// lengths free.
//
// The solve is boundary-first-flattening style (Sawhney & Crane 2017), on the mesh's own cotangent
// Laplacian L:
//   1. the mesh's angle defects Omega_i (interior) and boundary turning k_i = pi - angle sum;
//   2. prescribed turning k~_i > 0 with sum 2 pi (prescribed_curvature below);
//   3. the log scale factors u of the conformal change that flattens the interior and turns the boundary by
//      k~: one Neumann solve L u = [-Omega_I; k~_B - k_B] (consistent by Gauss-Bonnet; u fixed to 0 at one
//      boundary vertex, the reduced matrix factored by CHOLMOD);
//   4. the boundary curve: edge lengths l_ij e^{(u_i + u_j)/2}, tangents turning by k~, closed by the least
//      change of lengths (weighted least squares, two constraints). Turning angles all in (0, pi) summing to
//      2 pi make it a strictly convex polygon; that is checked exactly (orientation of every corner) and, if
//      it fails or a closed length is not positive, the boundary falls back to the unit disk positions
//      (disk_boundary_point), still convex;
//   5. the interior by the harmonic (cotangent) extension onto that boundary, through map_to_disk's solve,
//      exact flip check and recovery: a folded extension is replaced by the mean-value, then Tutte, map onto
//      the same convex boundary, bijective because the boundary is convex (paper 5.1; the paper's guarantee
//      needs bijective intermediate maps).
#pragma once

#include <string>
#include <vector>

#include "engine/cancel.h"
#include "engine/geometry.h"
#include "engine/intermediate_map.h"

namespace lipmap {

struct ConvexDomain {
  std::vector<Point2> boundary;      // c_k, where loop[k] goes: a strictly convex polygon, counterclockwise
  std::vector<double> curvature;     // the prescribed turning k~ at each boundary vertex (sum 2 pi)
  bool conformal_boundary = true;    // false: the unit disk positions are used (why: `fallback`)
  std::string fallback;
  double closing_change = 0;         // largest relative change of a boundary length to close the curve
  double scale_factor_range = 0;     // max u - min u over the boundary (how far from the mesh's own lengths)
  DiskMap map;                       // h_t->i: one point per vertex, boundary at `boundary`, exact flip count
};

// Turning angles for the convex domain from the mesh's own boundary turning k (sum 2 pi): the positive part,
// capped at 3 pi / 4, plus a floor that gives every boundary vertex a share (pi / 2 over the whole loop),
// scaled to sum 2 pi. Each result lies in (0, pi).
std::vector<double> prescribed_curvature(const std::vector<double>& turning);

// input.boundary_positions is ignored (the domain is what this computes). Preconditions as map_to_disk.
// Throws Cancelled.
ConvexDomain map_to_convex_domain(const DiskMapInput& input, const CancelToken* cancel = nullptr);

}  // namespace lipmap
