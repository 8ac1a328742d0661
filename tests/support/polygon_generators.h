// Polygon generators with answers known independently of the engine (tests and benchmarks only).
//
// Part A (always available, no CGAL): value types, a deterministic RNG, the grid-mesh builder and the raw
// polygons the benchmark uses. Part B (unless LIPMAP_TESTGEN_NO_CGAL is defined): the verified families,
// each case carrying its expected verdict and the reason it is known:
//
//  1a  images of a grid mesh of a rectangle under a locally injective map g (exp on a strip, z^k away
//      from 0, spiral strips, bent strips). Every image triangle is checked strictly positive with the
//      exact predicate, every interior vertex's angle sum is 2 pi, every boundary vertex's < 2 pi: the map
//      is locally injective, so its boundary is self-overlapping by definition (or simple).
//  1b  simple polygons by construction (star-shaped, bijective deformations of a circle, combs, zigzag
//      bands), simplicity also checked exactly; counterclockwise -> simple, reversed -> not.
//  1c  trees of strictly positive triangles (no interior vertex ever): the boundary is weakly
//      self-overlapping, the construction is a certificate triangulation with known R_i; and the
//      "double loop" with two hubs, whose hub fans are certificates.
//  1d  not self-overlapping: turning number <= 0 (figure eights, clockwise curves, negative trochoids;
//      every weakly self-overlapping polygon has T = 1 + sum R_i >= 1), curls with a region of negative
//      winding number (see gen_curls), and pinched flowers (T = 1, no negative winding; see gen_flower).
//  small polygons (n <= 10, real or lattice coordinates) answered by an exhaustive oracle that enumerates
//      every positive triangulation (exhaustive_triangulations in triangulation_checker.h).//
// Files: polygon_basics.h (part A), polygon_families_certified.h (1a, 1b), polygon_families_trees.h (1c),
// polygon_families_negative.h (1d, small); this file: the family registry.
#pragma once

#include "polygon_basics.h"

#ifndef LIPMAP_TESTGEN_NO_CGAL
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "polygon_families_certified.h"
#include "polygon_families_negative.h"
#include "polygon_families_trees.h"

namespace lipmap::testgen {

// ---------------------------------------------------------------------------------------------------
// Family registry.

enum class Family {
  exp_strip, power_map, spiral_overlap, spiral_thin, bent_strip,           // 1a
  star, deformed_circle, comb, zigzag, dart,                                // 1b (+ reversed)
  tree, double_loop, lattice_tree, deep_hub_tree,                           // 1c
  figure_eight, negative_trochoid, curls, grid_reversed, tree_reversed, flower,  // 1d
  small, small_lattice,                                                     // exhaustive oracle
};

inline const char* family_name(Family f) {
  switch (f) {
    case Family::exp_strip: return "exp_strip";
    case Family::power_map: return "power_map";
    case Family::spiral_overlap: return "spiral_overlap";
    case Family::spiral_thin: return "spiral_thin";
    case Family::bent_strip: return "bent_strip";
    case Family::star: return "star";
    case Family::deformed_circle: return "deformed_circle";
    case Family::comb: return "comb";
    case Family::zigzag: return "zigzag";
    case Family::dart: return "dart";
    case Family::flower: return "flower";
    case Family::small: return "small";
    case Family::small_lattice: return "small_lattice";
    case Family::tree: return "tree";
    case Family::double_loop: return "double_loop";
    case Family::lattice_tree: return "lattice_tree";
    case Family::deep_hub_tree: return "deep_hub_tree";
    case Family::figure_eight: return "figure_eight";
    case Family::negative_trochoid: return "negative_trochoid";
    case Family::curls: return "curls";
    case Family::grid_reversed: return "grid_reversed";
    case Family::tree_reversed: return "tree_reversed";
  }
  return "?";
}

inline std::optional<GenCase> generate_one(Family f, std::uint64_t seed) {
  switch (f) {
    case Family::exp_strip: return gen_exp_strip(seed);
    case Family::power_map: return gen_power_map(seed);
    case Family::spiral_overlap: return gen_spiral_strip(seed, true);
    case Family::spiral_thin: return gen_spiral_strip(seed, false);
    case Family::bent_strip: return gen_bent_strip(seed);
    case Family::star: return gen_star(seed);
    case Family::deformed_circle: return gen_deformed_circle(seed);
    case Family::comb: return gen_comb(seed);
    case Family::zigzag: return gen_zigzag(seed);
    case Family::dart: return gen_dart(seed);
    case Family::flower: return gen_flower(seed);
    case Family::small: return gen_small(seed);
    case Family::small_lattice: return gen_small_lattice(seed);
    case Family::tree: return gen_tree(seed);
    case Family::double_loop: return gen_double_loop(seed);
    case Family::lattice_tree: {
      TreeOptions o;
      o.lattice = true;
      o.family = "lattice_tree";
      return gen_tree(seed, o);
    }
    case Family::deep_hub_tree: {
      TreeOptions o;
      o.deep_min_turns = 3;
      o.deep_max_turns = kGenMaxRotationIndex;
      o.family = "deep_hub_tree";
      return gen_tree(seed, o);
    }
    case Family::figure_eight: return gen_figure_eight(seed);
    case Family::negative_trochoid: return gen_negative_trochoid(seed);
    case Family::curls: return gen_curls(seed);
    case Family::grid_reversed: {
      std::optional<GenCase> g;
      switch (seed % 3) {
        case 0: g = gen_exp_strip(seed); break;
        case 1: g = gen_spiral_strip(seed, true); break;
        default: g = gen_bent_strip(seed); break;
      }
      if (!g) return std::nullopt;
      return reversed_case(*g);
    }
    case Family::tree_reversed: {
      std::optional<GenCase> g = gen_tree(seed);
      if (!g) return std::nullopt;
      return reversed_case(*g);
    }
  }
  return std::nullopt;
}

// Default number of cases per family in the test suite (1b families are also run reversed).
inline int default_count(Family f) {
  switch (f) {
    case Family::exp_strip: return 50;
    case Family::power_map: return 40;
    case Family::spiral_overlap: return 50;
    case Family::spiral_thin: return 30;
    case Family::bent_strip: return 40;
    case Family::star: return 120;
    case Family::deformed_circle: return 50;
    case Family::comb: return 30;
    case Family::zigzag: return 30;
    case Family::dart: return 60;
    case Family::flower: return 40;
    case Family::small: return 400;
    case Family::small_lattice: return 400;
    case Family::tree: return 250;
    case Family::double_loop: return 40;
    case Family::lattice_tree: return 120;
    case Family::deep_hub_tree: return 30;
    case Family::figure_eight: return 50;
    case Family::negative_trochoid: return 40;
    case Family::curls: return 100;
    case Family::grid_reversed: return 30;
    case Family::tree_reversed: return 30;
  }
  return 0;
}

inline bool is_simple_family(Family f) {
  return f == Family::star || f == Family::deformed_circle || f == Family::comb || f == Family::zigzag ||
         f == Family::dart;
}

inline const std::vector<Family>& all_families() {
  static const std::vector<Family> all = {
      Family::exp_strip, Family::power_map, Family::spiral_overlap, Family::spiral_thin, Family::bent_strip,
      Family::star, Family::deformed_circle, Family::comb, Family::zigzag, Family::dart, Family::tree, Family::double_loop,
      Family::lattice_tree, Family::deep_hub_tree,
      Family::figure_eight, Family::negative_trochoid, Family::curls, Family::grid_reversed, Family::tree_reversed,
      Family::flower, Family::small, Family::small_lattice};
  return all;
}

// `count` cases of a family from seeds base, base + 1, ... (generators may reject a seed; at most
// 20 * count seeds are tried). Deterministic.
inline std::vector<GenCase> generate(Family f, int count, std::uint64_t base = 0) {
  std::vector<GenCase> out;
  const std::uint64_t family_base = (std::uint64_t(f) + 1) * 1000003ULL + base * 7919ULL;
  for (std::uint64_t s = 0; (int)out.size() < count && s < std::uint64_t(20 * count); ++s)
    if (auto g = generate_one(f, family_base + s)) out.push_back(std::move(*g));
  return out;
}

}  // namespace lipmap::testgen
#endif  // LIPMAP_TESTGEN_NO_CGAL
