// Stage "verify": docs/contract.md, checked exactly on the doubles that will be returned.
#include "engine/verify.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>

#include "engine/detail/exact_predicates.h"

namespace lipmap {
namespace {

using detail::Pt;

[[noreturn]] void fail(const std::string& what) { throw InternalError("verify: " + what); }

// Areas are compared relatively, so they are measured on points scaled by 2^-k (exact for normal doubles)
// that bring the largest |coordinate| near 1: squared lengths of meshes at 1e+-150 neither overflow nor
// underflow.
int area_exponent(const std::vector<Point3>& vertices) {
  double m = 0;
  for (const Point3& p : vertices) m = std::max({m, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  int k = 0;
  if (m > 0) std::frexp(m, &k);
  return k;
}

// x * 2^-k: a product by an exact power of two is rounded once, like ldexp, so both give the same double;
// the product is much cheaper, and serves whenever 2^-k itself is a normal double.
struct Scale {
  explicit Scale(int k) : k(k), factor(k > -1000 && k < 1000 ? std::ldexp(1.0, -k) : 0) {}
  double operator()(double x) const { return factor != 0 ? x * factor : std::ldexp(x, -k); }
  int k;
  double factor;
};

double area3(Point3 a, Point3 b, Point3 c, const Scale& s) {
  for (Point3* p : {&a, &b, &c}) *p = {s(p->x), s(p->y), s(p->z)};
  const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
  const double vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
  const double cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
  return 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
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
  // The source's edges and boundary edges (its boundary is the loop's edges): validate's topology.
  const MeshTopology& source_mesh = source.topology;
  auto source_edge = [&](int a, int b) { return a < nv_source && b < nv_source ? source_mesh.find_edge(a, b) : -1; };
  const int n = static_cast<int>(loop.size());
  report.rotation_indices.assign(static_cast<std::size_t>(n), 0);
  for (std::size_t i = 0; i < map.inserted.size(); ++i) {
    const InsertedVertex& iv = map.inserted[i];
    const std::string name = "inserted vertex " + std::to_string(nv_source + i);
    const int e = iv.a < iv.b && iv.a >= 0 && iv.b < nv_source ? source_edge(iv.a, iv.b) : -1;
    if (e < 0) fail(name + " is not on an original edge");
    if (source_mesh.is_boundary_edge(e)) fail(name + " is on the boundary");
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
  double area = 0, source_area = 0;
  const Scale area_k(area_exponent(source.vertices));
  std::vector<char> used(nv, 0);
  for (std::size_t f = 0; f < map.faces.size(); ++f) {
    const Triangle& t = map.faces[f];
    for (int v : t)
      if (v < 0 || v >= nv) fail("face " + std::to_string(f) + " has an index out of range");
    if (detail::orient(uv[t[0]], uv[t[1]], uv[t[2]]) <= 0) fail("face " + std::to_string(f) + " is not strictly positive");
    for (int c = 0; c < 3; ++c) {
      const int a = t[c], b = t[(c + 1) % 3], o = t[(c + 2) % 3];
      if (on_edge(o, a, b) && (a < nv_source && b < nv_source))
        fail("face " + std::to_string(f) + " has all corners on original edge " + std::to_string(a) + "-" + std::to_string(b));
      used[a] = 1;
    }
    area += area3(map.vertices[t[0]], map.vertices[t[1]], map.vertices[t[2]], area_k);
  }
  for (int v = 0; v < nv; ++v)
    if (!used[v]) fail("vertex " + std::to_string(v) + " is used by no face");
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
  // The result's own topology: an oriented manifold whose boundary edges are source boundary edges. When
  // nothing was inserted and the faces are the source's own, that is validate's topology (built once).
  const bool same_faces = nv == nv_source && map.faces == source.faces &&
                          source.topology.face_count() == static_cast<int>(source.faces.size());
  std::optional<MeshTopology> own;
  if (!same_faces) own.emplace(nv, map.faces);
  const MeshTopology& mesh = same_faces ? source.topology : *own;
  for (int e = 0; e < mesh.edge_count(); ++e) {
    const HalfedgeRange uses = mesh.edge_uses(e);
    const int a = mesh.from(uses[0]), b = mesh.to(uses[0]);
    if (uses.size() > 2 || (uses.size() == 2 && mesh.from(uses[1]) == a))
      fail("directed edge " + std::to_string(a) + "-" + std::to_string(b) + " is used twice");
    if (uses.size() == 1) {
      const int se = source_edge(a, b);
      if (se < 0 || !source_mesh.is_boundary_edge(se))
        fail("edge " + std::to_string(a) + "-" + std::to_string(b) + " is on the result's boundary but not the source's");
    }
  }
  if (!mesh.oriented_manifold())
    fail("faces around vertex " + std::to_string(mesh.first_vertex_with_broken_fan()) + " are not one fan");
  for (const Triangle& t : source.faces) source_area += area3(source.vertices[t[0]], source.vertices[t[1]], source.vertices[t[2]], area_k);
  report.area_relative_error = std::abs(area - source_area) / source_area;
  if (!(report.area_relative_error <= 1e-9)) fail("3D area changed by a relative " + std::to_string(report.area_relative_error));

  // 4. angle sums: one full turn at interior vertices, alpha_k + 2 pi R_k at boundary vertex k. The fan is
  // clockwise; the corners' sweeps chain counterclockwise, so it is read backwards.
  for (int v = 0; v < nv; ++v) {
    const HalfedgeRange fan = mesh.fan(v);
    const int k = boundary_index[v];
    const int first = mesh.to(fan.back()), last = mesh.from(MeshTopology::prev(fan.front()));
    if (mesh.is_boundary_vertex(v) != (k >= 0))
      fail("vertex " + std::to_string(v) + (k >= 0 ? " is not on the result's boundary" : " is on the result's boundary"));
    if (k >= 0 && (first != loop[(k + 1) % n] || last != loop[(k + n - 1) % n]))
      fail("faces around vertex " + std::to_string(v) + " do not run from its next boundary vertex to its previous one");
    if (k < 0) {
      // Every face is strictly positive (3.), so each corner sweeps less than pi: the comparison count.
      detail::PositiveChainTurns count(uv[v]);
      for (int h : fan) count.add(uv[mesh.to(h)], uv[mesh.from(MeshTopology::prev(h))]);
      if (count.turns() != 1)
        fail("interior vertex " + std::to_string(v) + " has angle sum " + std::to_string(count.turns()) + " x 2 pi");
      ++report.interior_vertices_checked;
    } else {
      detail::TurnCount count(uv[v], uv[first]);
      for (std::size_t i = fan.size(); i-- > 0;) count.add(uv[mesh.to(fan[i])], uv[mesh.from(MeshTopology::prev(fan[i]))]);
      const int r = detail::rotation_index(uv[v], uv[first], uv[last], count.turns());
      if (rotation.empty() ? r < 0 : r != rotation[k])
        fail("boundary vertex " + std::to_string(v) + " has rotation index " + std::to_string(r) + " instead of " +
             (rotation.empty() ? std::string("at least 0") : std::to_string(rotation[k])));
      report.rotation_indices[k] = r;
    }
  }
  report.faces_checked = static_cast<int>(map.faces.size());
  report.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

}  // namespace lipmap
