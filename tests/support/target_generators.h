// Boundary targets for any disk mesh (tests and benchmarks only), each with the reason its verdict is known.
//
// Given a disk mesh (vertices, faces, boundary loop with the interior on the left), every generator returns
// one prescribed position per loop vertex (positions[k] is the image of loop[k]), the expected verdict, and
// a certificate checked here, independently of the engine (CGAL exact orientation on the doubles, angle
// sums in long double; see triangulation_checker.h):
//
//   circle       loop vertices on the unit circle by 3D arc length: convex, so simple.
//   c_shape      loop placed by arc length on the outline of a thick C (an annular sector of 300 degrees):
//                simple (checked exactly) and not star-shaped (its kernel, the intersection of the edges'
//                left half-planes, is empty: checked by clipping a box with every half-plane).
//   spiral_arm   same on a thick spiral arm of about 1.5 turns: simple, not star-shaped, strongly non-convex.
//   exp_strip    self-overlapping by construction: a Tutte map h of the mesh onto an ellipse R (uniform
//                weights, computed here with Eigen::SimplicialLDLT), then g(z) = exp(c z) on R, a wide strip
//                whose height c * 2b is 1.1 to 1.5 turns: locally but not globally injective. The certificate is the composed map
//                g o h itself: every image triangle strictly positive (exact), every interior vertex's angle
//                sum 2 pi, every boundary vertex's in (0, 2 pi) (so all R_i = 0), and the boundary not simple.
//   power_map    same with g(z) = z^k (k = 3 .. 5) on a disk R away from 0 whose argument range times k
//                exceeds 2 pi.
//   cubic_map    same with g(z) = z^3 on a wide disk R close to 0 (a different, three-lobed overlap).
//   bent_strip   same with a long strip R bent through 1.1 to 1.3 turns: g(s, t) = (rho(s) - t) e^{i s / rho0},
//                rho growing along the strip so that the end lies over the start.
//   Each by-construction kind tries a few parameter sets, the most demanding first, and keeps the first that
//   the certificate accepts: first on the Tutte map of the source mesh itself, then, when floating-point
//   crowding or ears of the source make g fold a triangle, on a polar disk mesh built here with exactly the
//   loop's boundary vertices (any locally injective map whose boundary is the polygon certifies it).
//   bent_strip is strongly anisotropic (a strip 6 times longer than wide): on meshes with few boundary
//   vertices (nefertiti, three_peaks) no certificate is found and the kind is skipped, with the reason.
//   weak_fan     weakly self-overlapping with prescribed rotation indices: the loop vertex with the most
//                faces is the hub at the origin, the others follow a spiral around it through 3 pi. The fan
//                of triangles (hub, v_j, v_j+1) is a positive triangulation with R = 1 at the hub and 0
//                elsewhere (checked by check_triangulation); the turning number is 2, so no triangulation
//                with all R_i = 0 exists.
//
// A generator that cannot produce its kind for a mesh (too few boundary vertices, a Tutte map that floating
// point folds) returns nullopt and says why.
#pragma once

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "engine/geometry.h"
#include "triangulation_checker.h"

namespace lipmap::targetgen {

enum class Kind { circle, c_shape, spiral_arm, exp_strip, power_map, cubic_map, bent_strip, weak_fan };

inline const char* kind_name(Kind k) {
  switch (k) {
    case Kind::circle: return "circle";
    case Kind::c_shape: return "c_shape";
    case Kind::spiral_arm: return "spiral_arm";
    case Kind::exp_strip: return "exp_strip";
    case Kind::power_map: return "power_map";
    case Kind::cubic_map: return "cubic_map";
    case Kind::bent_strip: return "bent_strip";
    case Kind::weak_fan: return "weak_fan";
  }
  return "?";
}

inline const std::vector<Kind>& all_kinds() {
  static const std::vector<Kind> kinds = {Kind::circle,    Kind::c_shape,   Kind::spiral_arm, Kind::exp_strip,
                                          Kind::power_map, Kind::cubic_map, Kind::bent_strip, Kind::weak_fan};
  return kinds;
}

struct DiskMeshRef {
  const std::vector<Point3>& vertices;
  const std::vector<Triangle>& faces;
  const std::vector<int>& loop;
};

struct Target {
  Kind kind = Kind::circle;
  std::vector<Point2> positions;                   // one per loop vertex
  std::optional<std::vector<int>> rotation_indices;  // prescribed (weak_fan)
  std::string expect;                              // "simple", "self_overlapping", "weakly_self_overlapping"
  // By-construction kinds: the locally injective map g o h that certifies the boundary. Either on the source
  // mesh itself (certificate_on_source: certificate_uv has one point per source vertex), or, when floating
  // point crowding of the source's Tutte map (long, thin or ear-rich meshes) leaves a triangle that g folds,
  // on a polar disk mesh built here with exactly the loop's boundary vertices (certificate_domain: its
  // vertices in the unit disk, certificate_faces, boundary loop 0 .. n-1).
  bool certificate_on_source = false;
  std::vector<Point2> certificate_uv;
  std::vector<Point2> certificate_domain;
  std::vector<Triangle> certificate_faces;
  std::vector<int> singular_positions;             // loop positions with R > 0 (weak_fan)
};

namespace detail {

using testgen::Pt;
constexpr double kPi = 3.14159265358979323846;

inline Pt pt(const Point2& p) { return Pt{p.x, p.y}; }

// 3D arc-length fraction of each loop position: s[0] = 0, strictly increasing, < 1.
inline std::vector<double> arc_fractions(const DiskMeshRef& m) {
  const std::size_t n = m.loop.size();
  std::vector<double> s(n, 0);
  double total = 0;
  std::vector<double> len(n);
  for (std::size_t k = 0; k < n; ++k) {
    const Point3& a = m.vertices[m.loop[k]];
    const Point3& b = m.vertices[m.loop[(k + 1) % n]];
    len[k] = std::sqrt((b.x - a.x) * (b.x - a.x) + (b.y - a.y) * (b.y - a.y) + (b.z - a.z) * (b.z - a.z));
    total += len[k];
  }
  double acc = 0;
  for (std::size_t k = 0; k < n; ++k) {
    s[k] = total > 0 ? acc / total : double(k) / double(n);
    acc += len[k];
  }
  // Guard against equal fractions (a zero-length edge would make them equal; validate refuses such meshes).
  for (std::size_t k = 1; k < n; ++k)
    if (!(s[k] > s[k - 1])) s[k] = std::nextafter(s[k - 1], 1.0);
  return s;
}

// A closed polyline (dense), the point at arc-length fraction f of its perimeter.
struct Outline {
  std::vector<Point2> pts;
  std::vector<double> cum;  // cum[i] = length up to pts[i]; cum.back() = perimeter (closing edge included)
  explicit Outline(std::vector<Point2> p) : pts(std::move(p)) {
    cum.resize(pts.size() + 1, 0);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const Point2& a = pts[i];
      const Point2& b = pts[(i + 1) % pts.size()];
      cum[i + 1] = cum[i] + std::hypot(b.x - a.x, b.y - a.y);
    }
  }
  Point2 at(double f) const {
    const double target = f * cum.back();
    std::size_t i = std::upper_bound(cum.begin(), cum.end(), target) - cum.begin();
    i = std::min(std::max<std::size_t>(i, 1), pts.size()) - 1;
    const Point2& a = pts[i];
    const Point2& b = pts[(i + 1) % pts.size()];
    const double seg = cum[i + 1] - cum[i];
    const double t = seg > 0 ? (target - cum[i]) / seg : 0;
    return {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
  }
};

// Is the kernel of the polygon (the intersection of the closed left half-planes of its edges) empty?
// Floating-point clipping of a large box; the shapes used here are far from the borderline.
inline bool kernel_is_empty(const std::vector<Point2>& p) {
  double lo = 1e300, hi = -1e300;
  for (const Point2& q : p) lo = std::min({lo, q.x, q.y}), hi = std::max({hi, q.x, q.y});
  const double pad = 10 * (hi - lo + 1);
  std::vector<Point2> region = {{lo - pad, lo - pad}, {hi + pad, lo - pad}, {hi + pad, hi + pad}, {lo - pad, hi + pad}};
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n && !region.empty(); ++i) {
    const Point2& a = p[i];
    const Point2& b = p[(i + 1) % n];
    auto side = [&](const Point2& q) { return (b.x - a.x) * (q.y - a.y) - (b.y - a.y) * (q.x - a.x); };
    std::vector<Point2> out;
    for (std::size_t j = 0; j < region.size(); ++j) {
      const Point2& c = region[j];
      const Point2& d = region[(j + 1) % region.size()];
      const double sc = side(c), sd = side(d);
      if (sc >= 0) out.push_back(c);
      if ((sc >= 0) != (sd >= 0)) {
        const double t = sc / (sc - sd);
        out.push_back({c.x + t * (d.x - c.x), c.y + t * (d.y - c.y)});
      }
    }
    region.swap(out);
  }
  if (region.size() < 3) return true;
  double area = 0;
  for (std::size_t j = 0; j < region.size(); ++j) {
    const Point2& c = region[j];
    const Point2& d = region[(j + 1) % region.size()];
    area += c.x * d.y - c.y * d.x;
  }
  double scale = 0;
  for (const Point2& q : p) scale = std::max({scale, std::fabs(q.x), std::fabs(q.y)});
  return std::fabs(0.5 * area) < 1e-12 * scale * scale;
}

inline testgen::Poly poly_of(const std::vector<Point2>& p) {
  testgen::Poly out;
  out.reserve(p.size());
  for (const Point2& q : p) out.push_back(pt(q));
  return out;
}

inline bool distinct_consecutive(const std::vector<Point2>& p) {
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p[i] == p[(i + 1) % p.size()]) return false;
  return true;
}

// Simple, counterclockwise (turning number 1), not star-shaped.
inline bool finish_non_star(Target& t, const std::string& what, std::string* why) {
  const testgen::Poly poly = poly_of(t.positions);
  std::string reason;
  if (!distinct_consecutive(t.positions)) reason = what + ": two consecutive positions coincide";
  else if (!testgen::is_simple(poly, &reason)) reason = what + " is not simple after sampling: " + reason;
  else if (testgen::turning_number(poly) != 1) reason = what + " is not counterclockwise";
  else if (!kernel_is_empty(t.positions)) reason = what + " is star-shaped after sampling (too few vertices)";
  if (!reason.empty()) {
    if (why) *why = reason;
    return false;
  }
  t.expect = "simple";
  return true;
}

// Tutte map (uniform weights) of the mesh onto the unit disk, loop vertex k at angle 2 pi s_k (arc length).
// Solved with SimplicialLDLT on the interior block of the graph Laplacian.
inline std::optional<std::vector<Point2>> tutte_disk(const DiskMeshRef& m, std::string* why) {
  const int nv = static_cast<int>(m.vertices.size());
  const std::vector<double> s = arc_fractions(m);
  std::vector<int> slot(nv, -1);  // interior index, or -1 for boundary
  std::vector<Point2> uv(nv);
  std::vector<char> boundary(nv, 0);
  for (std::size_t k = 0; k < m.loop.size(); ++k) {
    boundary[m.loop[k]] = 1;
    uv[m.loop[k]] = {std::cos(2 * kPi * s[k]), std::sin(2 * kPi * s[k])};
  }
  int ni = 0;
  for (int v = 0; v < nv; ++v)
    if (!boundary[v]) slot[v] = ni++;
  if (ni == 0) return uv;
  // Undirected edges, each once.
  std::vector<std::pair<int, int>> edges;
  edges.reserve(m.faces.size() * 3);
  for (const Triangle& t : m.faces)
    for (int c = 0; c < 3; ++c) edges.push_back({std::min(t[c], t[(c + 1) % 3]), std::max(t[c], t[(c + 1) % 3])});
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::vector<Eigen::Triplet<double>> trip;
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(ni, 2);
  std::vector<double> degree(ni, 0);
  for (const auto& [a, b] : edges) {
    for (int pass = 0; pass < 2; ++pass) {
      const int u = pass ? b : a, w = pass ? a : b;
      if (slot[u] < 0) continue;
      degree[slot[u]] += 1;
      if (slot[w] >= 0) trip.emplace_back(slot[u], slot[w], -1.0);
      else {
        rhs(slot[u], 0) += uv[w].x;
        rhs(slot[u], 1) += uv[w].y;
      }
    }
  }
  for (int i = 0; i < ni; ++i) trip.emplace_back(i, i, degree[i]);
  Eigen::SparseMatrix<double> L(ni, ni);
  L.setFromTriplets(trip.begin(), trip.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(L);
  if (solver.info() != Eigen::Success) {
    if (why) *why = "Tutte map: factorization failed";
    return std::nullopt;
  }
  Eigen::MatrixXd x = solver.solve(rhs);
  // Two steps of iterative refinement (crowded interiors).
  for (int step = 0; step < 2; ++step) {
    const Eigen::MatrixXd r = rhs - L * x;
    x += solver.solve(r);
  }
  for (int v = 0; v < nv; ++v)
    if (slot[v] >= 0) uv[v] = {x(slot[v], 0), x(slot[v], 1)};
  return uv;
}

// The certificate of a by-construction target: image triangles strictly positive (exact), interior angle
// sums 2 pi, boundary angle sums in (0, 2 pi); the boundary polygon has distinct consecutive vertices,
// turning number 1, and is not simple.
inline bool certify_locally_injective(const DiskMeshRef& m, const std::vector<Point2>& uv, std::string* why) {
  auto fail = [&](const std::string& s) {
    if (why) *why = s;
    return false;
  };
  for (std::size_t f = 0; f < m.faces.size(); ++f) {
    const Triangle& t = m.faces[f];
    if (testgen::exact::orient(pt(uv[t[0]]), pt(uv[t[1]]), pt(uv[t[2]])) <= 0)
      return fail("composed image triangle " + std::to_string(f) + " is not strictly positive");
  }
  std::vector<long double> theta(m.vertices.size(), 0);
  for (const Triangle& t : m.faces)
    for (int c = 0; c < 3; ++c)
      theta[t[c]] += testgen::corner_angle(pt(uv[t[c]]), pt(uv[t[(c + 1) % 3]]), pt(uv[t[(c + 2) % 3]]));
  std::vector<char> boundary(m.vertices.size(), 0);
  for (int v : m.loop) boundary[v] = 1;
  for (std::size_t v = 0; v < m.vertices.size(); ++v) {
    if (boundary[v]) {
      if (!(theta[v] > 1e-9L && theta[v] < testgen::kTwoPiL - 1e-9L))
        return fail("boundary vertex " + std::to_string(v) + " has angle sum outside (0, 2 pi)");
    } else if (std::fabs(theta[v] - testgen::kTwoPiL) > 1e-7L) {
      return fail("interior vertex " + std::to_string(v) + " has angle sum != 2 pi");
    }
  }
  std::vector<Point2> poly;
  for (int v : m.loop) poly.push_back(uv[v]);
  if (!distinct_consecutive(poly)) return fail("two consecutive boundary images coincide");
  const testgen::Poly p = poly_of(poly);
  if (testgen::turning_number(p) != 1) return fail("boundary turning number is not 1");
  if (testgen::is_simple(p)) return fail("the boundary came out simple (no overlap)");
  return true;
}

// A polar triangulation of the unit disk whose boundary vertices are exactly the points at `angles`
// (strictly increasing in [0, 2 pi)), in that order (vertex k = boundary point k): a first ring at the
// midpoints of the boundary arcs, pushed inwards by 0.8 times the local spacing (so that no triangle has
// two boundary edges), then rings of uniformly spaced vertices whose spacing grows by 15 % per ring (at
// most 0.06), joined by zipper triangulations, and a centre vertex. Every triangle is counterclockwise.
inline void polar_disk(const std::vector<double>& angles, std::vector<Point2>& pts, std::vector<Triangle>& faces) {
  const int n = static_cast<int>(angles.size());
  pts.clear();
  faces.clear();
  for (double a : angles) pts.push_back({std::cos(a), std::sin(a)});
  struct RingVertex {
    double angle;
    int id;
  };
  // Ring 1: one vertex per boundary arc.
  std::vector<RingVertex> ring;
  double max_spacing = 0;
  for (int k = 0; k < n; ++k) {
    double a0 = angles[k], a1 = k + 1 < n ? angles[k + 1] : angles[0] + 2 * kPi;
    const double d = a1 - a0, mid = 0.5 * (a0 + a1), r = std::max(0.3, 1 - 0.8 * d);
    max_spacing = std::max(max_spacing, d);
    ring.push_back({mid, static_cast<int>(pts.size())});
    pts.push_back({r * std::cos(mid), r * std::sin(mid)});
  }
  // Boundary triangles (b_k, b_k+1, m_k) and (m_k-1, b_k, m_k).
  for (int k = 0; k < n; ++k) {
    faces.push_back({k, (k + 1) % n, ring[k].id});
    faces.push_back({ring[(k + n - 1) % n].id, k, ring[k].id});
  }
  // Zipper between an outer ring and an inner ring (both sorted by angle, CCW, angles unwrapped).
  auto zipper = [&](const std::vector<RingVertex>& outer, const std::vector<RingVertex>& inner) {
    const std::size_t no = outer.size(), ni = inner.size();
    std::size_t i = 0, j = 0;
    // Start: align inner[0] to the outer vertex just before it in angle.
    auto ang = [](const std::vector<RingVertex>& r, std::size_t idx) {
      const std::size_t m = r.size();
      return r[idx % m].angle + 2 * kPi * static_cast<double>(idx / m);
    };
    std::size_t i0 = 0;
    while (i0 + 1 < no && outer[i0 + 1].angle <= inner[0].angle) ++i0;
    i = i0;
    const std::size_t i_end = i0 + no, j_end = ni;
    while (i < i_end || j < j_end) {
      const bool advance_outer = j >= j_end || (i < i_end && ang(outer, i + 1) <= ang(inner, j + 1));
      if (advance_outer) {
        faces.push_back({outer[i % no].id, outer[(i + 1) % no].id, inner[j % ni].id});
        ++i;
      } else {
        faces.push_back({inner[j % ni].id, outer[i % no].id, inner[(j + 1) % ni].id});
        ++j;
      }
    }
  };
  double radius = 1 - 0.8 * max_spacing;
  double spacing = 2 * kPi / n;
  // Inner rings: uniform spacing (arc length on the ring), growing.
  double r = 0;
  for (const RingVertex& v : ring) r += std::hypot(pts[v.id].x, pts[v.id].y);
  radius = std::min(r / n, radius);
  for (;;) {
    spacing = std::min(spacing * 1.15, 0.06);
    const double next_radius = radius - 0.87 * spacing;
    const int count = static_cast<int>(std::floor(2 * kPi * next_radius / spacing));
    if (next_radius <= 0 || count < 6) break;
    std::vector<RingVertex> inner;
    const double offset = ring[0].angle;
    for (int k = 0; k < count; ++k) {
      const double a = offset + 2 * kPi * (k + 0.5) / count;
      inner.push_back({a, static_cast<int>(pts.size())});
      pts.push_back({next_radius * std::cos(a), next_radius * std::sin(a)});
    }
    zipper(ring, inner);
    ring = std::move(inner);
    radius = next_radius;
  }
  // Centre.
  const int centre = static_cast<int>(pts.size());
  pts.push_back({0, 0});
  for (std::size_t k = 0; k < ring.size(); ++k) faces.push_back({ring[k].id, ring[(k + 1) % ring.size()].id, centre});
}

// Tries the candidate maps g in order (the most demanding first): first on the source mesh's own Tutte map,
// then on the polar disk mesh; keeps the first composition that passes the certificate.
inline std::optional<Target> by_construction(Kind kind, const DiskMeshRef& m,
                                             const std::vector<std::function<Point2(double, double)>>& candidates,
                                             std::string* why) {
  std::string reason, reasons;
  if (auto disk = tutte_disk(m, &reason)) {
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      Target t;
      t.kind = kind;
      t.certificate_on_source = true;
      t.certificate_uv.resize(disk->size());
      for (std::size_t v = 0; v < disk->size(); ++v) t.certificate_uv[v] = candidates[i]((*disk)[v].x, (*disk)[v].y);
      if (!certify_locally_injective(m, t.certificate_uv, &reason)) {
        reasons += (reasons.empty() ? "" : "; ") + std::string("source, candidate ") + std::to_string(i) + ": " + reason;
        continue;
      }
      for (int v : m.loop) t.positions.push_back(t.certificate_uv[v]);
      t.expect = "self_overlapping";
      return t;
    }
  } else {
    reasons = reason;
  }
  const std::vector<double> s = arc_fractions(m);
  std::vector<double> angles;
  for (double f : s) angles.push_back(2 * kPi * f);
  std::vector<Point2> domain;
  std::vector<Triangle> faces;
  polar_disk(angles, domain, faces);
  std::vector<Point3> domain3;
  for (const Point2& p : domain) domain3.push_back({p.x, p.y, 0});
  std::vector<int> loop(m.loop.size());
  for (std::size_t k = 0; k < loop.size(); ++k) loop[k] = static_cast<int>(k);
  const DiskMeshRef polar{domain3, faces, loop};
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    Target t;
    t.kind = kind;
    t.certificate_domain = domain;
    t.certificate_faces = faces;
    for (const Point2& p : domain) t.certificate_uv.push_back(candidates[i](p.x, p.y));
    if (!certify_locally_injective(polar, t.certificate_uv, &reason)) {
      reasons += "; polar mesh, candidate " + std::to_string(i) + ": " + reason;
      continue;
    }
    t.positions.assign(t.certificate_uv.begin(), t.certificate_uv.begin() + static_cast<long>(m.loop.size()));
    t.expect = "self_overlapping";
    return t;
  }
  if (why) *why = std::string(kind_name(kind)) + ": " + reasons;
  return std::nullopt;
}

}  // namespace detail

inline std::optional<Target> make_target(Kind kind, const DiskMeshRef& m, std::string* why = nullptr) {
  using detail::kPi;
  const std::size_t n = m.loop.size();
  const std::vector<double> s = detail::arc_fractions(m);
  Target t;
  t.kind = kind;
  switch (kind) {
    case Kind::circle: {
      for (std::size_t k = 0; k < n; ++k) t.positions.push_back({std::cos(2 * kPi * s[k]), std::sin(2 * kPi * s[k])});
      t.expect = "simple";
      return t;
    }
    case Kind::c_shape: {
      // Outer arc radius 1 from angle a0 to a0 + span (counterclockwise), cap, inner arc radius r back, cap.
      const double r = 0.45, span = 300.0 / 180.0 * kPi, a0 = 0.5 * (2 * kPi - span);
      std::vector<Point2> outline;
      const int steps = 400;
      for (int i = 0; i <= steps; ++i) {
        const double a = a0 + span * i / steps;
        outline.push_back({std::cos(a), std::sin(a)});
      }
      for (int i = steps; i >= 0; --i) {
        const double a = a0 + span * i / steps;
        outline.push_back({r * std::cos(a), r * std::sin(a)});
      }
      const detail::Outline o(outline);
      for (std::size_t k = 0; k < n; ++k) t.positions.push_back(o.at(s[k]));
      if (!detail::finish_non_star(t, "the C shape", why)) return std::nullopt;
      return t;
    }
    case Kind::spiral_arm: {
      // Centre line rho(a) = 1 + b a, a in [0, A]; half width w < pi b keeps the layers apart.
      const double turns = 1.5, A = turns * 2 * kPi, b = 0.25, w = 0.45 * kPi * b;
      std::vector<Point2> outline;
      const int steps = 900;
      for (int i = 0; i <= steps; ++i) {
        const double a = A * i / steps, rho = 1 + b * a + w;
        outline.push_back({rho * std::cos(a), rho * std::sin(a)});
      }
      for (int i = steps; i >= 0; --i) {
        const double a = A * i / steps, rho = 1 + b * a - w;
        outline.push_back({rho * std::cos(a), rho * std::sin(a)});
      }
      const detail::Outline o(outline);
      for (std::size_t k = 0; k < n; ++k) t.positions.push_back(o.at(s[k]));
      if (!detail::finish_non_star(t, "the spiral arm", why)) return std::nullopt;
      return t;
    }
    case Kind::exp_strip: {
      // R: the ellipse with semi-axes (a, b) around 0 (the affine image of the Tutte disk); g(z) = exp(c z)
      // with c = turns * 2 pi / (2 b): the ellipse's height wraps `turns` times around the origin, its width
      // gives radii e^{-c a} .. e^{c a}. Candidates: from 1.5 turns and a narrow strip to milder ones.
      std::vector<std::function<Point2(double, double)>> g;
      for (const auto& [turns, a, b] : std::vector<std::array<double, 3>>{
               {1.5, 0.75, 2.0}, {1.3, 1.0, 1.6}, {1.15, 1.2, 1.4}, {1.1, 1.5, 1.5}})
        g.push_back([turns = turns, a = a, b = b](double x, double y) {
          const double c = turns * 2 * kPi / (2 * b);
          const std::complex<double> e = std::exp(std::complex<double>(c * a * x, c * b * y));
          return Point2{e.real(), e.imag()};
        });
      return detail::by_construction(kind, m, g, why);
    }
    case Kind::power_map: {
      // R: the disk of radius rho around i (argument range 2 asin rho); g(z) = z^k with k * 2 asin(rho) > 2 pi.
      std::vector<std::function<Point2(double, double)>> g;
      for (const auto& [k, rho] : std::vector<std::array<double, 2>>{{4, 0.75}, {4, 0.8}, {5, 0.65}, {3, 0.9}})
        g.push_back([k = static_cast<int>(k), rho = rho](double x, double y) {
          const std::complex<double> z(rho * x, 1.0 + rho * y);
          std::complex<double> w = z;
          for (int e = 1; e < k; ++e) w *= z;
          return Point2{w.real(), w.imag()};
        });
      return detail::by_construction(kind, m, g, why);
    }
    case Kind::cubic_map: {
      // R: a wide disk of radius rho around i, close to 0 (argument range 2 asin rho > 120 degrees); g(z) = z^3.
      std::vector<std::function<Point2(double, double)>> g;
      for (double rho : {0.9, 0.88, 0.87})
        g.push_back([rho](double x, double y) {
          const std::complex<double> z(rho * x, 1.0 + rho * y);
          const std::complex<double> w = z * z * z;
          return Point2{w.real(), w.imag()};
        });
      return detail::by_construction(kind, m, g, why);
    }
    case Kind::bent_strip: {
      // R: the ellipse over s in [0, L], t in [-w, w]; g(s, t) = (rho(s) - t) e^{i s / rho0} with
      // rho = rho0 (1 + 0.3 s / L) and L = turns full turns of the circle of radius rho0; det Dg > 0 since
      // w < rho0. The end lies over the start.
      std::vector<std::function<Point2(double, double)>> g;
      for (const auto& [turns, w] : std::vector<std::array<double, 2>>{{1.3, 0.7}, {1.2, 0.8}, {1.1, 0.85}})
        g.push_back([turns = turns, w = w](double x, double y) {
          const double rho0 = 1.0, L = turns * 2 * kPi * rho0;
          const double sp = L * (x + 1) / 2, tp = w * y;
          const double rho = rho0 * (1 + 0.3 * sp / L) - tp;
          return Point2{rho * std::cos(sp / rho0), rho * std::sin(sp / rho0)};
        });
      return detail::by_construction(kind, m, g, why);
    }
    case Kind::weak_fan: {
      if (n < 8) {
        if (why) *why = "weak_fan needs at least 8 boundary vertices (" + std::to_string(n) + ")";
        return std::nullopt;
      }
      // Hub: the loop vertex with the most faces.
      std::vector<int> valence(m.vertices.size(), 0);
      for (const Triangle& f : m.faces)
        for (int c : f) ++valence[c];
      std::size_t hub = 0;
      for (std::size_t k = 1; k < n; ++k)
        if (valence[m.loop[k]] > valence[m.loop[hub]]) hub = k;
      // Others: loop positions hub+1 .. hub+n-1, arc-length fraction sigma in (0, 1) measured from the hub
      // (the two loop edges at the hub get a share as in 3D), on a spiral through 3 pi.
      const double sweep = 3 * kPi;
      t.positions.assign(n, Point2{});
      t.positions[hub] = {0, 0};
      for (std::size_t j = 1; j < n; ++j) {
        const std::size_t k = (hub + j) % n;
        double sigma = s[k] - s[hub];
        if (sigma < 0) sigma += 1;
        const double a = sweep * sigma, rho = 1 + 0.5 * sigma;
        t.positions[k] = {rho * std::cos(a), rho * std::sin(a)};
      }
      t.rotation_indices = std::vector<int>(n, 0);
      (*t.rotation_indices)[hub] = 1;
      t.singular_positions = {static_cast<int>(hub)};
      // Certificate: the fan from the hub, in loop positions.
      std::vector<testgen::Tri> fan;
      for (std::size_t j = 1; j + 1 < n; ++j)
        fan.push_back({static_cast<int>(hub), static_cast<int>((hub + j) % n), static_cast<int>((hub + j + 1) % n)});
      const testgen::Poly poly = detail::poly_of(t.positions);
      const testgen::CheckReport rep = testgen::check_triangulation(poly, fan, *t.rotation_indices);
      if (!rep.ok()) {
        if (why) *why = "weak_fan certificate failed:\n" + rep.str();
        return std::nullopt;
      }
      if (testgen::turning_number(poly) != 2) {
        if (why) *why = "weak_fan: turning number is not 2";
        return std::nullopt;
      }
      t.expect = "weakly_self_overlapping";
      return t;
    }
  }
  return std::nullopt;
}

}  // namespace lipmap::targetgen
