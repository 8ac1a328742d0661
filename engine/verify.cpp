// Stage "verify": DESIGN.md section 2, checked exactly on the doubles that will be returned.
#include "engine/verify.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <string>

#include "engine/detail/plane_angles.h"

namespace lipmap {
namespace {

using detail::Pt;

[[noreturn]] void fail(const std::string& what) { throw InternalError("verify: " + what); }

double area3(const Point3& a, const Point3& b, const Point3& c) {
  const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
  const double vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
  const double cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
  return 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
}

std::uint64_t pair_key(int a, int b) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) | static_cast<std::uint32_t>(b);
}

// A sorted key list: cheaper than hash sets for the few hundred thousand edges of a large mesh.
struct SortedKeys {
  explicit SortedKeys(std::vector<std::uint64_t> k) : keys(std::move(k)) { std::sort(keys.begin(), keys.end()); }
  bool contains(std::uint64_t key) const { return std::binary_search(keys.begin(), keys.end(), key); }
  std::vector<std::uint64_t> keys;
};

SortedKeys undirected_edges(const std::vector<Triangle>& faces) {
  std::vector<std::uint64_t> keys;
  keys.reserve(faces.size() * 3);
  for (const Triangle& t : faces)
    for (int c = 0; c < 3; ++c) keys.push_back(pair_key(std::min(t[c], t[(c + 1) % 3]), std::max(t[c], t[(c + 1) % 3])));
  return SortedKeys(std::move(keys));
}

}  // namespace

VerifyReport verify_map(const DiskMesh& source, const std::vector<int>& loop, const BoundaryPolygon& polygon,
                        const std::vector<int>& rotation, const RefinedMap& map) {
  const auto t0 = std::chrono::steady_clock::now();
  VerifyReport report;
  const int nv_source = static_cast<int>(source.vertices.size());
  const int nv = static_cast<int>(map.vertices.size());
  if (map.uv.size() != map.vertices.size()) fail("uv count differs from vertex count");
  if (nv != nv_source + static_cast<int>(map.inserted.size())) fail("vertex count is not source + inserted");

  // 1. original vertices kept; inserted ones on an original interior edge at a + t (b - a).
  for (int v = 0; v < nv_source; ++v)
    if (!(map.vertices[v] == source.vertices[v])) fail("original vertex " + std::to_string(v) + " moved");
  const SortedKeys source_edges = undirected_edges(source.faces);
  std::vector<std::uint64_t> boundary_list;
  const int n = static_cast<int>(loop.size());
  for (int k = 0; k < n; ++k) {
    const int a = loop[k], b = loop[(k + 1) % n];
    boundary_list.push_back(pair_key(std::min(a, b), std::max(a, b)));
  }
  const SortedKeys boundary_edges(std::move(boundary_list));
  for (std::size_t i = 0; i < map.inserted.size(); ++i) {
    const InsertedVertex& iv = map.inserted[i];
    const std::string name = "inserted vertex " + std::to_string(nv_source + i);
    if (!(iv.a < iv.b) || iv.a < 0 || iv.b >= nv_source || !source_edges.contains(pair_key(iv.a, iv.b)))
      fail(name + " is not on an original edge");
    if (boundary_edges.contains(pair_key(iv.a, iv.b))) fail(name + " is on the boundary");
    if (!(iv.t > 0 && iv.t < 1)) fail(name + " has t outside (0, 1)");
    const Point3 &pa = source.vertices[iv.a], &pb = source.vertices[iv.b];
    const Point3 expect{pa.x + iv.t * (pb.x - pa.x), pa.y + iv.t * (pb.y - pa.y), pa.z + iv.t * (pb.z - pa.z)};
    if (!(map.vertices[nv_source + i] == expect)) fail(name + " is not at a + t (b - a)");
  }

  // 2. boundary pinned bit for bit.
  std::vector<int> boundary_index(nv, -1);
  for (int k = 0; k < n; ++k) {
    boundary_index[loop[k]] = k;
    if (!(map.uv[loop[k]] == polygon.vertices[k])) fail("boundary vertex " + std::to_string(loop[k]) + " is not at its target");
  }

  // 3. and 5. every face strictly positive, none flat in 3D; a manifold disk whose boundary is the loop.
  std::vector<Pt> uv;
  uv.reserve(nv);
  for (const Point2& p : map.uv) uv.emplace_back(p.x, p.y);
  auto on_edge = [&](int v, int a, int b) {  // v is a, b, or inserted on (a, b)
    if (v == a || v == b) return true;
    if (v < nv_source) return false;
    const InsertedVertex& iv = map.inserted[v - nv_source];
    return iv.a == std::min(a, b) && iv.b == std::max(a, b);
  };
  std::vector<std::uint64_t> directed_list;
  directed_list.reserve(map.faces.size() * 3);
  double area = 0, source_area = 0;
  // Corners around each vertex, compressed rows: (next, prev) of v in each of its faces.
  std::vector<int> fan_begin(nv + 1, 0);
  for (const Triangle& t : map.faces)
    for (int v : t)
      if (v >= 0 && v < nv) ++fan_begin[v + 1];
  for (int v = 0; v < nv; ++v) fan_begin[v + 1] += fan_begin[v];
  std::vector<std::pair<int, int>> fan(fan_begin[nv]);
  std::vector<int> fill(fan_begin.begin(), fan_begin.end() - 1);
  for (std::size_t f = 0; f < map.faces.size(); ++f) {
    const Triangle& t = map.faces[f];
    for (int v : t)
      if (v < 0 || v >= nv) fail("face " + std::to_string(f) + " has an index out of range");
    if (detail::orient(uv[t[0]], uv[t[1]], uv[t[2]]) <= 0) fail("face " + std::to_string(f) + " is not strictly positive");
    for (int c = 0; c < 3; ++c) {
      const int a = t[c], b = t[(c + 1) % 3], o = t[(c + 2) % 3];
      if (on_edge(o, a, b) && (a < nv_source && b < nv_source))
        fail("face " + std::to_string(f) + " has all corners on original edge " + std::to_string(a) + "-" + std::to_string(b));
      directed_list.push_back(pair_key(a, b));
      fan[fill[a]++] = {b, o};
    }
    area += area3(map.vertices[t[0]], map.vertices[t[1]], map.vertices[t[2]]);
  }
  // A flat face with inserted corners only: all three on one original edge (a, b).
  for (std::size_t f = 0; f < map.faces.size(); ++f) {
    const Triangle& t = map.faces[f];
    for (int c = 0; c < 3; ++c) {
      if (t[c] < nv_source) continue;
      const InsertedVertex& iv = map.inserted[t[c] - nv_source];
      if (on_edge(t[(c + 1) % 3], iv.a, iv.b) && on_edge(t[(c + 2) % 3], iv.a, iv.b))
        fail("face " + std::to_string(f) + " is flat: its corners lie on original edge " + std::to_string(iv.a) + "-" +
             std::to_string(iv.b));
    }
  }
  const SortedKeys directed(std::move(directed_list));
  for (std::size_t i = 1; i < directed.keys.size(); ++i)
    if (directed.keys[i] == directed.keys[i - 1])
      fail("directed edge " + std::to_string(directed.keys[i] >> 32) + "-" + std::to_string(directed.keys[i] & 0xffffffffu) +
           " is used twice");
  for (const std::uint64_t key : directed.keys) {
    const int a = static_cast<int>(key >> 32), b = static_cast<int>(key & 0xffffffffu);
    if (!directed.contains(pair_key(b, a))) {  // a boundary edge of the result: must be a source boundary edge
      if (a >= nv_source || b >= nv_source || !boundary_edges.contains(pair_key(std::min(a, b), std::max(a, b))))
        fail("edge " + std::to_string(a) + "-" + std::to_string(b) + " is on the result's boundary but not the source's");
    }
  }
  for (const Triangle& t : source.faces) source_area += area3(source.vertices[t[0]], source.vertices[t[1]], source.vertices[t[2]]);
  report.area_relative_error = std::abs(area - source_area) / source_area;
  if (!(report.area_relative_error <= 1e-9)) fail("3D area changed by a relative " + std::to_string(report.area_relative_error));

  // 4. angle sums: one full turn at interior vertices, alpha_k + 2 pi R_k at boundary vertex k.
  for (int v = 0; v < nv; ++v) {
    const auto begin = fan.begin() + fan_begin[v], end = fan.begin() + fan_begin[v + 1];
    if (begin == end) fail("vertex " + std::to_string(v) + " is used by no face");
    std::sort(begin, end);
    const std::vector<std::pair<int, int>> corners(begin, end);
    const int k = boundary_index[v];
    const int first = k >= 0 ? loop[(k + 1) % n] : corners[0].first;
    const int last = k >= 0 ? loop[(k + n - 1) % n] : corners[0].first;
    int at = first, turns = 0;
    for (std::size_t step = 0; step < corners.size(); ++step) {
      auto it = std::lower_bound(corners.begin(), corners.end(), std::pair<int, int>{at, -1});
      if (it == corners.end() || it->first != at) fail("faces around vertex " + std::to_string(v) + " are not one fan");
      turns += detail::extra_turn(uv[v], uv[first], uv[at], uv[it->second]);
      at = it->second;
    }
    if (at != last) fail("faces around vertex " + std::to_string(v) + " do not close up");
    if (k < 0) {
      if (turns != 1) fail("interior vertex " + std::to_string(v) + " has angle sum " + std::to_string(turns) + " x 2 pi");
      ++report.interior_vertices_checked;
    } else {
      const Pt &next = uv[first], &prev = uv[last];
      const int spike = detail::sector(uv[v], next, prev) == 0 ? 1 : 0;
      if (turns - spike != rotation[k])
        fail("boundary vertex " + std::to_string(v) + " has rotation index " + std::to_string(turns - spike) +
             " instead of " + std::to_string(rotation[k]));
    }
  }
  report.faces_checked = static_cast<int>(map.faces.size());
  report.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

}  // namespace lipmap
