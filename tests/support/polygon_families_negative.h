// Polygon generators, family 1d (not self-overlapping) and the small polygons answered by the exhaustive
// oracle. See polygon_generators.h for the whole list.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "polygon_families_certified.h"

namespace lipmap::testgen {

// ---------------------------------------------------------------------------------------------------
// 1d: not self-overlapping.

// Figure eight (lemniscate of Gerono, radial noise, random similarity, possibly mirrored): T = 0.
inline std::optional<GenCase> gen_figure_eight(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "figure_eight";
  c.seed = seed;
  const int n = r.integer(8, 80);
  const double noise = r.uniform(0, 0.05), squash = r.uniform(0.3, 1.5), t0 = r.uniform(0, kTwoPi);
  Poly p;
  for (int k = 0; k < n; ++k) {
    const double t = t0 + kTwoPi * k / n;
    const double f = 1 + noise * r.uniform(-1, 1);
    p.push_back({f * std::cos(t), f * squash * std::sin(t) * std::cos(t)});
  }
  const bool mirror = r.chance(0.5);
  c.poly = transformed(p, r.uniform(0, kTwoPi), r.uniform(0.2, 8), r.uniform(-4, 4), r.uniform(-4, 4), mirror);
  c.params = fmt("noise", noise) + fmt("squash", squash) + fmt("mirror", mirror);
  c.turning = 0;
  c.expect = Expect::not_self_overlapping;
  if (!well_conditioned(c.poly) || turning_number(c.poly) != 0) return std::nullopt;
  return c;
}

// z(t) = e^{it} + b e^{imt}, m <= -1, b |m| > 1: the derivative winds m times, so T = m <= -1.
inline std::optional<GenCase> gen_negative_trochoid(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "negative_trochoid";
  c.seed = seed;
  const int m = -r.integer(1, 4);
  const double b = r.uniform(1.0 / -m + 0.1, 1.5);
  int n = r.integer(12, 40) * (1 - m);
  for (int attempt = 0; attempt < 3; ++attempt, n *= 2) {
    c.poly.clear();
    for (int k = 0; k < n; ++k) {
      const double t = kTwoPi * k / n;
      c.poly.push_back({std::cos(t) + b * std::cos(m * t), std::sin(t) + b * std::sin(m * t)});
    }
    if (well_conditioned(c.poly) && turning_number(c.poly) == m) {
      c.params = fmt("m", m) + fmt("b", b);
      c.turning = m;
      c.expect = Expect::not_self_overlapping;
      return c;
    }
  }
  return std::nullopt;
}

// 1d: a counterclockwise unit circle with k_in >= 0 inward counterclockwise curls and k_out >= 1 outward
// clockwise curls; T = 1 + k_in - k_out (0, 1, 2 and -1 occur).
//
// A curl is a prolate trochoid x = c u + r sin u, y = +-r (1 - cos u), u in [0, 2 pi], r > c, in the frame
// "x along the circle, y towards the center", mapped by (x, y) -> (1 - y) e^{i (t0 + x)} (orientation
// preserving). With y >= 0 it loops on the left, turning left (counterclockwise); with y <= 0 on the right
// (outside), turning right (clockwise): the region enclosed by an outward clockwise curl has winding number
// 0 - 1 = -1.
//
// Why negative winding means not weakly self-overlapping: a weakly self-overlapping polygon has a
// triangulation by strictly positive triangles (Proposition 1); the piecewise-linear map from that disk has,
// at any point q off the triangle edges, degree = winding number of P around q = number of triangles
// containing q >= 0. So a point of negative winding number cannot exist. The generator checks the winding
// number of a probe point inside every outward curl exactly and keeps the case only if one is negative.
inline std::optional<GenCase> gen_curls(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "curls";
  c.seed = seed;
  const int k_out = r.integer(1, 2), k_in = r.integer(0, 2), k = k_in + k_out;
  // Slots around the circle, one curl per slot, in random order.
  std::vector<int> sign(k);  // +1 inward CCW, -1 outward CW
  for (int i = 0; i < k; ++i) sign[i] = i < k_in ? +1 : -1;
  for (int i = k - 1; i > 0; --i) std::swap(sign[i], sign[r.integer(0, i)]);
  const double slot = kTwoPi / k, start = r.uniform(0, kTwoPi);
  struct Curl { double t0, cc, rr; int s; };
  std::vector<Curl> curls;
  for (int i = 0; i < k; ++i) {
    const double cc = r.uniform(0.05, 0.12), rr = cc * r.uniform(1.5, 3.0);
    const double span = kTwoPi * cc;
    const double t0 = start + i * slot + r.uniform(0.05, std::max(0.06, slot - span - 0.05));
    curls.push_back({t0, cc, rr, sign[i]});
  }
  auto to_global = [](double t0, double x, double y) {
    return Pt{(1 - y) * std::cos(t0 + x), (1 - y) * std::sin(t0 + x)};
  };
  const int per_curl = r.integer(16, 32);
  const double arc_step = r.uniform(0.08, 0.25);
  Poly p;
  for (int i = 0; i < k; ++i) {
    const Curl& cu = curls[i];
    for (int q = 0; q <= per_curl; ++q) {
      const double u = kTwoPi * q / per_curl;
      p.push_back(to_global(cu.t0, cu.cc * u + cu.rr * std::sin(u), cu.s * cu.rr * (1 - std::cos(u))));
    }
    // arc to the next curl's start (exclusive at both ends)
    const double a0 = cu.t0 + kTwoPi * cu.cc;
    double a1 = curls[(i + 1) % k].t0;
    if (i + 1 == k) a1 += kTwoPi;
    const int steps = std::max(2, (int)std::ceil((a1 - a0) / arc_step));
    for (int q = 1; q < steps; ++q) {
      const double t = a0 + (a1 - a0) * q / steps;
      p.push_back({std::cos(t), std::sin(t)});
    }
  }
  c.poly = p;
  c.turning = 1 + k_in - k_out;
  c.expect = Expect::not_self_overlapping;
  c.params = "k_in=" + std::to_string(k_in) + " k_out=" + std::to_string(k_out) + " T=" + std::to_string(c.turning);
  if (!well_conditioned(c.poly) || turning_number(c.poly) != c.turning) return std::nullopt;
  // Probe inside each outward loop: crossing at u = pi -+ phi with r sin(phi) = c phi; the loop spans
  // |y| in (r (1 + cos phi), 2 r) at x = c pi.
  for (const Curl& cu : curls) {
    if (cu.s > 0) continue;
    double lo = 1e-9, hi = kPi;
    for (int it = 0; it < 200; ++it) {
      const double mid = 0.5 * (lo + hi);
      (cu.rr * std::sin(mid) - cu.cc * mid > 0 ? lo : hi) = mid;
    }
    const double phi = 0.5 * (lo + hi);
    const double ymid = 0.5 * (cu.rr * (1 + std::cos(phi)) + 2 * cu.rr);
    const Pt probe = to_global(cu.t0, cu.cc * kPi, -ymid);
    bool on = false;
    if (winding_number(c.poly, probe, &on) < 0 && !on) c.negative_probes.push_back(probe);
  }
  if (c.negative_probes.empty()) return std::nullopt;
  return c;
}

// 1d: a flower: k >= 2 petals, each a star-shaped loop [O, p_1..p_m] around its own angular sector of the
// common point O, with gaps between the sectors; the polygon visits O once per petal (distinct vertices at
// the same point). T = 1 (the petals turn sum(w_i) + k pi, the k corners at O turn sum(gap_i) - k pi) and no
// winding number is negative, yet it is not weakly self-overlapping: the visit of O between petal i and
// petal i+1 has the interior angle 2 pi - gap_i (from petal i+1's start round to petal i's end), so the
// triangles at that vertex would sweep every direction except gap_i, and so cover points near O inside
// another gap j, whose winding number is 0 (checked exactly at a probe point in every gap, kept in
// zero_probes); a positive triangle covers only points of winding number >= 1.
inline std::optional<GenCase> gen_flower(std::uint64_t seed) {
  Rng r(seed);
  GenCase c;
  c.family = "flower";
  c.seed = seed;
  const int k = r.integer(2, 5);
  const double slot = kTwoPi / k, start = r.uniform(0, kTwoPi);
  Poly p;
  std::vector<double> gap_mid;
  double min_rad = 1e9;
  for (int i = 0; i < k; ++i) {
    const double g = slot * r.uniform(0.1, 0.5);
    const double a0 = start + i * slot + g / 2, a1 = start + (i + 1) * slot - g / 2;
    gap_mid.push_back(start + (i + 1) * slot);
    const int m = r.integer(2, 8);
    const double rad = r.uniform(0.5, 1.5);
    p.push_back({0, 0});
    for (int q = 0; q < m; ++q) {
      const double a = a0 + (a1 - a0) * q / (m - 1), rr = rad * r.uniform(0.7, 1.3);
      min_rad = std::min(min_rad, rr);
      p.push_back({rr * std::cos(a), rr * std::sin(a)});
    }
  }
  const size_t shift = (size_t)r.integer(0, (int)p.size() - 1);
  std::rotate(p.begin(), p.begin() + long(shift), p.end());
  c.poly = p;
  c.turning = 1;
  c.expect = Expect::not_self_overlapping;
  c.params = "petals=" + std::to_string(k);
  if (!well_conditioned(c.poly) || turning_number(c.poly) != 1) return std::nullopt;
  for (double a : gap_mid) {
    const Pt probe{1e-3 * min_rad * std::cos(a), 1e-3 * min_rad * std::sin(a)};
    bool on = true;
    if (winding_number(c.poly, probe, &on) != 0 || on) return std::nullopt;
    c.zero_probes.push_back(probe);
  }
  return c;
}

// Sets the expected answer of a small polygon from the exhaustive oracle (nullopt if it is too big, or
// nearly degenerate: every vertex triple must span a non-negligible area, so the float R are exact).
inline std::optional<GenCase> finish_small_case(GenCase c) {
  if (c.poly.size() < 3 || !well_conditioned(c.poly)) return std::nullopt;
  const size_t n = c.poly.size();
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j)
      for (size_t k = j + 1; k < n; ++k) {
        const Pt &A = c.poly[i], &B = c.poly[j], &C = c.poly[k];
        const double area2 = std::fabs((B.x - A.x) * (C.y - A.y) - (B.y - A.y) * (C.x - A.x));
        if (area2 < 1e-6) return std::nullopt;
      }
  const OracleResult o = exhaustive_triangulations(c.poly);
  if (!o.complete) return std::nullopt;
  for (const auto& [R, t] : o.by_R) {
    if (!check_triangulation(c.poly, t, R).ok()) return std::nullopt;
    c.feasible_R.push_back(R);
  }
  c.turning = turning_number(c.poly);
  if (c.feasible_R.empty()) {
    c.expect = Expect::not_self_overlapping;
  } else {
    c.certificate = o.by_R.begin()->second;
    c.certificate_R = o.by_R.begin()->first;
    c.expect = c.turning == 1 ? Expect::simple_or_self_overlapping : Expect::weakly_self_overlapping;
  }
  c.params += " realizable_R=" + std::to_string(c.feasible_R.size());
  return c;
}

// Small polygons (n <= max_n <= 12) whose answer comes from the exhaustive oracle (exhaustive_triangulations):
// random points in a square, and "winding" polygons (points at increasing angles over 1 to 3 turns around
// the origin with random radii, plus 0 to 2 points near the origin), which are often weakly self-overlapping
// with several realizable rotation-index vectors.
inline std::optional<GenCase> gen_small(std::uint64_t seed, int max_n = 10) {
  Rng r(seed);
  GenCase c;
  c.family = "small";
  c.seed = seed;
  const int mode = r.integer(0, 2);
  if (mode == 0) {
    const int n = r.integer(4, max_n - 1);
    for (int k = 0; k < n; ++k) c.poly.push_back({r.uniform(-1, 1), r.uniform(-1, 1)});
    c.params = "random points";
  } else {
    const int hubs = r.integer(0, 2), loops = std::min(r.integer(1, 3 + (max_n > 10)), (max_n - hubs) / 3);
    const int m = r.integer(3 * loops, max_n - hubs);
    const double a0 = r.uniform(0, kTwoPi), total = kTwoPi * loops - r.uniform(0.3, 1.5);
    for (int h = 0; h < hubs; ++h) c.poly.push_back({r.uniform(-0.3, 0.3), r.uniform(-0.3, 0.3)});
    std::vector<double> a(m);
    for (double& x : a) x = r.uniform(0, total);
    std::sort(a.begin(), a.end());
    for (int k = 0; k < m; ++k) {
      const double rad = r.uniform(0.4, 1.6);
      c.poly.push_back({rad * std::cos(a0 + a[k]), rad * std::sin(a0 + a[k])});
    }
    if (mode == 2 && c.poly.size() > 3) {  // relabel, the hubs land anywhere in the order
      const size_t shift = (size_t)r.integer(0, (int)c.poly.size() - 1);
      std::rotate(c.poly.begin(), c.poly.begin() + long(shift), c.poly.end());
    }
    c.params = "loops=" + std::to_string(loops) + " hubs=" + std::to_string(hubs);
  }
  return finish_small_case(std::move(c));
}

// Small lattice polygons: integer coordinates in [0, 4]^2 (random points), or winding polygons snapped to
// the half-integer grid. Collinear vertices, distinct vertices at one point, vertices on other edges and
// slits (spikes, interior angle 2 pi) all occur; the oracle stays exact (strict positivity by the exact
// predicate, and on such a grid no angle is close to 0 or 2 pi without being exactly that).
inline std::optional<GenCase> gen_small_lattice(std::uint64_t seed, int max_n = 10) {
  Rng r(seed);
  GenCase c;
  c.family = "small_lattice";
  c.seed = seed;
  if (r.chance(0.5)) {
    const int n = r.integer(4, max_n - 1);
    for (int k = 0; k < n; ++k) c.poly.push_back({double(r.integer(0, 4)), double(r.integer(0, 4))});
    c.params = "lattice points";
  } else {
    const int hubs = r.integer(0, 2), loops = std::min(r.integer(1, 3), (max_n - hubs) / 3);
    const int m = r.integer(3 * loops, max_n - hubs);
    const double a0 = r.uniform(0, kTwoPi), total = kTwoPi * loops - r.uniform(0.3, 1.5);
    for (int h = 0; h < hubs; ++h) c.poly.push_back({0.5 * r.integer(-1, 1), 0.5 * r.integer(-1, 1)});
    std::vector<double> a(m);
    for (double& x : a) x = r.uniform(0, total);
    std::sort(a.begin(), a.end());
    for (int k = 0; k < m; ++k) {
      const double rad = r.uniform(1.0, 3.0);
      c.poly.push_back({0.5 * std::round(2 * rad * std::cos(a0 + a[k])), 0.5 * std::round(2 * rad * std::sin(a0 + a[k]))});
    }
    const size_t shift = (size_t)r.integer(0, (int)c.poly.size() - 1);
    std::rotate(c.poly.begin(), c.poly.begin() + long(shift), c.poly.end());
    c.params = "snapped loops=" + std::to_string(loops) + " hubs=" + std::to_string(hubs);
  }
  const size_t n = c.poly.size();
  if (n < 3) return std::nullopt;
  for (size_t i = 0; i < n; ++i)
    if (c.poly[i] == c.poly[(i + 1) % n]) return std::nullopt;
  long double raw = 0;
  c.turning = turning_number(c.poly, &raw);
  if (std::fabs(raw - c.turning) > 1e-9L) return std::nullopt;
  const OracleResult o = exhaustive_triangulations(c.poly);
  if (!o.complete) return std::nullopt;
  for (const auto& [R, t] : o.by_R) {
    if (!check_triangulation(c.poly, t, R).ok()) return std::nullopt;
    c.feasible_R.push_back(R);
  }
  if (c.feasible_R.empty()) {
    c.expect = Expect::not_self_overlapping;
  } else {
    c.certificate = o.by_R.begin()->second;
    c.certificate_R = o.by_R.begin()->first;
    c.expect = c.turning == 1 ? Expect::simple_or_self_overlapping : Expect::weakly_self_overlapping;
  }
  c.params += " realizable_R=" + std::to_string(c.feasible_R.size());
  return c;
}

}  // namespace lipmap::testgen
