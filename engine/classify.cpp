// Stage "classify" (paper 3.1, 3.2, App. B, App. C).
//
// The turning number t of P decides which search runs. Summing the angles of the n - 2 triangles of any
// positive triangulation without interior vertices gives sum(R_i) = t - 1, hence:
//   t <= 0                  no triangulation exists: not self-overlapping;
//   t == 1                  every R_i is 0: the Shor–van Wyk table with exact angle targets, after the
//                           ear reduction of App. C;
//   t >= 2, R not given     some R_i > 0 and they are unknown: the plain positive-triangulation table of
//                           section 3.1 (weakly self-overlapping test);
//   R given                 sum(R_i) must be t - 1; then the table with those exact targets.
#include "engine/classify.h"

#include <CGAL/Polygon_2_algorithms.h>

#include <algorithm>
#include <chrono>
#include <numeric>
#include <string>

#include "engine/detail/ear_reduction.h"
#include "engine/detail/exact_predicates.h"
#include "engine/mesh_topology.h"
#include "engine/detail/shor_van_wyk.h"

namespace lipmap {
namespace {

using detail::Pt;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Full rotation index at every vertex of a triangulation, from the exact sweep of its fan of triangles
// (App. B), after checking that it is a triangulation of P: n - 2 strictly positive triangles, each polygon
// edge in exactly one triangle and each other edge in two, the triangles at every vertex one fan from
// v_{i+1} to v_{i-1}. Any violation is a bug of this stage.
std::vector<int> rotation_indices_of(const std::vector<Pt>& p, const std::vector<Triangle>& tris,
                                     const std::vector<int>& spikes) {
  const int n = static_cast<int>(p.size());
  auto fail = [](const std::string& why) { throw InternalError("classify produced an invalid triangulation: " + why); };
  if (static_cast<int>(tris.size()) != n - 2) fail("wrong triangle count");
  for (const Triangle& t : tris) {
    for (int v : t)
      if (v < 0 || v >= n) fail("index out of range");
    if (detail::orient(p[t[0]], p[t[1]], p[t[2]]) <= 0) fail("a triangle is not strictly positive");
  }
  const MeshTopology mesh(n, tris);
  for (int e = 0; e < mesh.edge_count(); ++e) {
    const auto [a, b] = mesh.edge_vertices(e);
    const bool polygon_edge = b - a == 1 || (a == 0 && b == n - 1);
    if (mesh.edge_use_count(e) != (polygon_edge ? 1 : 2)) fail("edge used the wrong number of times");
  }
  if (!mesh.oriented_manifold()) fail("triangles around a vertex do not form one fan");
  std::vector<int> rotation(n);
  for (int v = 0; v < n; ++v) {
    // The fan read backwards sweeps counterclockwise from v_{i+1} to v_{i-1}.
    const HalfedgeRange fan = mesh.fan(v);
    const int first = (v + 1) % n, last = (v + n - 1) % n;
    if (mesh.to(fan.back()) != first || mesh.from(MeshTopology::prev(fan.front())) != last)
      fail("fan does not run from the next polygon vertex to the previous one");
    detail::TurnCount count(p[v], p[first]);
    for (std::size_t i = fan.size(); i-- > 0;) count.add(p[mesh.to(fan[i])], p[mesh.from(MeshTopology::prev(fan[i]))]);
    rotation[v] = count.turns() - spikes[v];
    if (rotation[v] < 0) fail("negative rotation index");
  }
  return rotation;
}

struct Search {
  std::optional<std::vector<Triangle>> triangles;
  ClassifyStats stats;
};

// Exact angle targets: App. C reduction, then the table on what is left.
Search search_with_targets(const std::vector<Pt>& p, const std::vector<int>& turns, const CancelToken* cancel) {
  Search s;
  auto t0 = Clock::now();
  detail::EarReduction reduced = detail::clip_ears(p, turns, cancel);
  s.stats.ear_clipping_ms = ms_since(t0);
  s.stats.ears_clipped = static_cast<int>(reduced.ears.size());
  s.stats.reduced_vertices = static_cast<int>(reduced.remaining.size());

  std::vector<Pt> sub;
  sub.reserve(reduced.remaining.size());
  for (int v : reduced.remaining) sub.push_back(p[v]);
  t0 = Clock::now();
  detail::ShorVanWykResult table = detail::shor_van_wyk(sub, &reduced.turns, cancel);
  s.stats.table_ms = ms_since(t0);
  s.stats.table_bytes = table.table_bytes;
  if (!table.triangles) return s;

  std::vector<Triangle> all = std::move(reduced.ears);
  for (const Triangle& t : *table.triangles)
    all.push_back({reduced.remaining[t[0]], reduced.remaining[t[1]], reduced.remaining[t[2]]});
  s.triangles = std::move(all);
  return s;
}

// No targets (turning number >= 2, R not given): any positive triangulation, on the whole polygon since
// ears cannot be clipped safely when a vertex might need extra turns.
Search search_free(const std::vector<Pt>& p, const CancelToken* cancel) {
  Search s;
  s.stats.free_rotation_search = true;
  s.stats.reduced_vertices = static_cast<int>(p.size());
  const auto t0 = Clock::now();
  detail::ShorVanWykResult table = detail::shor_van_wyk(p, nullptr, cancel);
  s.stats.table_ms = ms_since(t0);
  s.stats.table_bytes = table.table_bytes;
  s.triangles = std::move(table.triangles);
  return s;
}

bool is_simple(const std::vector<Pt>& p) {
  return CGAL::is_simple_2(p.begin(), p.end(), detail::Kernel());
}

}  // namespace

const char* to_string(Verdict verdict) {
  switch (verdict) {
    case Verdict::simple: return "simple";
    case Verdict::self_overlapping: return "self_overlapping";
    case Verdict::weakly_self_overlapping: return "weakly_self_overlapping";
    case Verdict::not_self_overlapping: return "not_self_overlapping";
  }
  return "unknown";
}

Classification classify(const BoundaryPolygon& polygon, const CancelToken* cancel) {
  validate_polygon(polygon);
  const auto t0 = Clock::now();
  const int n = static_cast<int>(polygon.vertices.size());
  std::vector<Pt> p;
  p.reserve(n);
  for (const Point2& v : polygon.vertices) p.emplace_back(v.x, v.y);

  Classification out;
  out.turning_number = detail::turning_number(p);
  const std::vector<int> spikes = detail::spike_turns(p);
  const std::vector<int>* prescribed = polygon.rotation_indices ? &*polygon.rotation_indices : nullptr;
  const int t = out.turning_number;

  Search search;
  if (prescribed) {
    const long long sum = std::accumulate(prescribed->begin(), prescribed->end(), 0LL);
    if (sum != t - 1) {
      out.reason = "the prescribed rotation indices sum to " + std::to_string(sum) +
                   " but the polygon's turning number " + std::to_string(t) + " requires a sum of " +
                   std::to_string(t - 1) + " (sum of R_i = turning number - 1)";
    } else {
      std::vector<int> turns(n);
      for (int i = 0; i < n; ++i) turns[i] = (*prescribed)[i] + spikes[i];
      search = search_with_targets(p, turns, cancel);
      if (!search.triangles)
        out.reason = "no triangulation with positive triangles has the prescribed rotation indices";
    }
  } else if (t <= 0) {
    out.reason = "the turning number is " + std::to_string(t) +
                 "; the boundary of a locally injective map turns once (or more, with singular vertices)";
  } else if (t == 1) {
    search = search_with_targets(p, spikes, cancel);
    if (!search.triangles)
      out.reason = "no triangulation with positive triangles matches the polygon's angles "
                   "(the polygon is not the boundary of any locally injective map)";
  } else {
    search = search_free(p, cancel);
    if (!search.triangles)
      out.reason = "no triangulation with positive triangles exists, with or without singular vertices";
  }

  out.stats = search.stats;
  out.stats.input_vertices = n;
  if (search.triangles) {
    out.triangulation = std::move(*search.triangles);
    out.rotation_indices = rotation_indices_of(p, out.triangulation, spikes);
    if (prescribed && out.rotation_indices != *prescribed)
      throw InternalError("classify: triangulation does not match the prescribed rotation indices");
    for (int i = 0; i < n; ++i)
      if (out.rotation_indices[i] > 0) out.singular_vertices.push_back(i);
    if (!out.singular_vertices.empty()) out.verdict = Verdict::weakly_self_overlapping;
    else out.verdict = (t == 1 && is_simple(p)) ? Verdict::simple : Verdict::self_overlapping;
  }
  out.stats.total_ms = ms_since(t0);
  return out;
}

}  // namespace lipmap
