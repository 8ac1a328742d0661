// Stage "intermediate maps", method extremal, source side (paper 5.3): h_s->i, an approximate Teichmuller
// map of the source mesh onto the convex domain M_c with the boundary fixed (loop[k] at c_k), by the
// quasiconformal iteration of Lui and Lam (Lui, Wong, Thompson, Chan, Gu and Yau 2014, "Teichmuller mapping
// (T-map) and its applications"): a Teichmuller map has a Beltrami coefficient of constant modulus k whose
// argument comes from a holomorphic quadratic differential, so
//   1. start from the harmonic (cotangent) map onto M_c (with map_to_disk's recovery: bijective);
//   2. compute the map's Beltrami coefficient mu = f_zbar / f_z on every triangle, in the triangle's own
//      isometric frame (the source is a surface);
//   3. smooth mu: a few averaging steps over the faces across each edge, each neighbour's coefficient
//      carried into this face's frame by the rotation that unfolds the shared edge (mu turns by e^{2i delta}
//      under a frame rotation by delta), then set |mu| = k, the area-weighted mean of |mu|, keeping the
//      argument;
//   4. solve the linear Beltrami solver for a map with that coefficient: per triangle the anisotropic
//      Laplacian div(A grad u) = 0, A = [[(rho-1)^2 + tau^2, -2 tau], [-2 tau, (1+rho)^2 + tau^2]] / (1 - |mu|^2)
//      for mu = rho + i tau (A = I for mu = 0: the cotangent Laplacian), boundary fixed; one CHOLMOD
//      factorization per step on a pattern analysed once, one two-column solve;
//   5. repeat from 2 a fixed number of times or until k settles.
// Every iterate is checked with the exact orientation predicate; the answer is the flip-free iterate with
// the smallest max K over the faces with a corner off the boundary (the harmonic start included: so never
// above the start's), the quantity a Teichmuller map minimizes. (The last flip-free iterate was tried first:
// on meshes where later iterates fold, an early one can have a nearly flat triangle and a far larger max K
// than the start.) The paper's guarantee needs only a bijective h_s->i; the Teichmuller property is what
// lowers the distortion of the composed map (h_t->i is conformal, so f = h_t->i^-1 o h_s->i has h_s->i's
// dilatation).
#pragma once

#include <vector>

#include "engine/cancel.h"
#include "engine/geometry.h"
#include "engine/intermediate_map.h"
#include "engine/mesh_topology.h"

namespace lipmap {

struct TeichmullerOptions {
  int max_iterations = 20;      // Beltrami solves, at most
  int smoothing_steps = 2;      // averaging steps of mu per iteration
  double tolerance = 1e-4;      // stop when k changes less than this between iterations
  double max_k = 0.9;           // |mu| is capped here (K = (1 + k) / (1 - k) = 19) to keep A well conditioned
};

struct TeichmullerMap {
  DiskMap map;                  // h_s->i: uv (boundary at the domain's points), exact flip count
  double k = 0;                 // the constant |mu| prescribed for the chosen iterate (0: the harmonic start)
  std::vector<double> k_history;  // k of every Beltrami solve, in order
  int iterations = 0;           // Beltrami solves done
  int chosen_iteration = 0;     // 0: the harmonic start; i: the i-th Beltrami solve
  int folded_iterates = 0;      // Beltrami solves whose map had a non-positive triangle (never chosen)
  // max K of the start and of the answer over the faces with a corner off the boundary (the others are the same
  // in every map with this boundary: pinned_by_boundary, engine/extremal_relax.h)
  double harmonic_max_dilatation = 1, max_dilatation = 1;
  double ms = 0;
};

// input.boundary_positions must be given (the convex domain). topology: of *input.faces. Throws Cancelled.
TeichmullerMap teichmuller_map(const DiskMapInput& input, const MeshTopology& topology,
                               const TeichmullerOptions& options = {}, const CancelToken* cancel = nullptr);

}  // namespace lipmap
