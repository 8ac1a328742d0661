// Stage "validate": raw arrays -> DiskMesh + BoundaryMap (paper 3.1). The checks run in the order that
// validate.h documents; each one is a full pass that reports the lowest offending index, so the answer
// for a given input is deterministic. The edge checks read the mesh's topology (engine/mesh_topology.h),
// which is built here once and handed on in DiskMesh.
#include "engine/validate.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

#include "engine/cancel.h"
#include "engine/detail/exact_predicates.h"
#include "engine/error.h"

namespace lipmap {
namespace {

[[noreturn]] void reject(const std::string& code, const std::string& message, const std::string& element = {},
                         std::optional<long long> index = std::nullopt) {
  throw InputError(code, message, element, index);
}

std::string s(long long value) { return std::to_string(value); }

// Every pass over the input checks the token now and then (at i = 0 too, so an expired token stops at once):
// a request's deadline must free the worker whatever the input's size.
inline void poll(const CancelToken* cancel, size_t i) {
  if ((i & 0x3fff) == 0) check_cancel(cancel);
}

std::string format_point(const Point3& p) {
  std::ostringstream out;
  out.precision(17);
  out << '(' << p.x << ", " << p.y << ", " << p.z << ')';
  return out.str();
}

// ---- element-wise checks on the raw arrays ---------------------------------------------------------

void check_not_empty(const RawMesh& raw) {
  if (raw.vertices.empty() || raw.faces.empty())
    reject("mesh_empty", "the mesh has " + s(raw.vertices.size()) + " vertices and " + s(raw.faces.size()) +
                             " faces; it needs at least one of each");
}

void check_finite_coordinates(const RawMesh& raw) {
  for (size_t v = 0; v < raw.vertices.size(); ++v) {
    const Point3& p = raw.vertices[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      reject("non_finite_coordinate", "vertex " + s(v) + " has a coordinate that is NaN or infinite: " +
                                          format_point(p), "vertex", v);
  }
}

// face_not_triangle, then face_index_out_of_range, then the faces as Triangles, in one pass over the raw
// faces (one walk over them, not three). A face that is not a triangle is
// reported first whatever the faces before it hold, so an index out of range is only noted on the way.
std::vector<Triangle> checked_triangles(const RawMesh& raw) {
  const long long n = static_cast<long long>(raw.vertices.size());
  std::vector<Triangle> faces(raw.faces.size());
  size_t bad_face = raw.faces.size(), bad_corner = 0;
  for (size_t f = 0; f < raw.faces.size(); ++f) {
    const FaceList::ConstFace face = raw.faces[f];
    if (face.size() != 3)
      reject("face_not_triangle", "face " + s(f) + " has " + s(face.size()) +
                                      " corners; only triangles are accepted", "face", f);
    for (size_t k = 0; k < 3; ++k) {
      const long long v = face[k];
      if ((v < 0 || v >= n) && bad_face == raw.faces.size()) bad_face = f, bad_corner = k;
      faces[f][k] = static_cast<int>(v);  // only returned when every index is in range (then it fits)
    }
  }
  if (bad_face < raw.faces.size())
    reject("face_index_out_of_range", "face " + s(bad_face) + " corner " + s(bad_corner) + " refers to vertex " +
                                          s(raw.faces[bad_face][bad_corner]) + ", but vertex indices run from 0 to " +
                                          s(n - 1), "face", bad_face);
  return faces;
}

void check_no_repeated_corner(const std::vector<Triangle>& faces) {
  for (size_t f = 0; f < faces.size(); ++f) {
    const Triangle& t = faces[f];
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0])
      reject("face_repeated_vertex", "face " + s(f) + " uses the same vertex twice: its corners are " + s(t[0]) +
                                         ", " + s(t[1]) + ", " + s(t[2]), "face", f);
  }
}

void check_all_referenced(size_t n_vertices, const std::vector<Triangle>& faces) {
  std::vector<char> used(n_vertices, 0);
  for (const Triangle& t : faces)
    for (int v : t) used[v] = 1;
  auto unused = std::find(used.begin(), used.end(), 0);
  if (unused != used.end()) {
    long long v = unused - used.begin();
    reject("unreferenced_vertex", "vertex " + s(v) + " is not used by any face; remove it", "vertex", v);
  }
}

void check_no_degenerate_face(const std::vector<Point3>& vertices, const std::vector<Triangle>& faces,
                              const CancelToken* cancel) {
  for (size_t f = 0; f < faces.size(); ++f) {
    poll(cancel, f);
    const Triangle& t = faces[f];
    // Exact predicate: a thin but valid triangle must never be mistaken for a flat one, and vice versa.
    if (!detail::collinear(vertices[t[0]], vertices[t[1]], vertices[t[2]])) continue;
    std::string why = "its corners " + s(t[0]) + ", " + s(t[1]) + ", " + s(t[2]) + " are collinear";
    for (int k = 0; k < 3; ++k) {
      int a = t[k], b = t[(k + 1) % 3];
      if (vertices[a] == vertices[b])
        why = "its corners " + s(a) + " and " + s(b) + " are at the same position " + format_point(vertices[a]);
    }
    reject("degenerate_face", "face " + s(f) + " has zero area: " + why, "face", f);
  }
}

// Two faces on the same three vertices share all three of their edges, so every copy of a face is among the
// uses of each of its edges, and two uses of one edge are copies exactly when their third corners agree: one
// pass over the topology's edges, no sort of all faces (an edge with many faces sorts its own few).
void check_no_duplicate_face(const std::vector<Triangle>& faces, const MeshTopology& mesh, const CancelToken* cancel) {
  int worst = -1, original = -1;  // the lowest face that copies an earlier one, and the earliest copy
  std::vector<std::pair<int, int>> keyed;  // (third corner, face) of a crowded edge's uses
  const auto third = [&](int h) { return mesh.from(MeshTopology::prev(h)); };
  for (int e = 0; e < mesh.edge_count(); ++e) {
    poll(cancel, static_cast<size_t>(e));
    const HalfedgeRange uses = mesh.edge_uses(e);  // ascending half-edges: ascending faces
    if (uses.size() < 2) continue;
    if (uses.size() == 2) {
      const int g = MeshTopology::face_of(uses[0]), f = MeshTopology::face_of(uses[1]);
      if (third(uses[0]) == third(uses[1]) && (worst < 0 || f < worst)) worst = f, original = g;
      continue;
    }
    keyed.clear();
    for (int h : uses) keyed.emplace_back(third(h), MeshTopology::face_of(h));
    std::sort(keyed.begin(), keyed.end());
    size_t run = 0;  // the first entry of the current run of equal third corners: its earliest face
    for (size_t i = 1; i < keyed.size(); ++i) {
      if (keyed[i].first != keyed[i - 1].first) {
        run = i;
        continue;
      }
      if (worst < 0 || keyed[i].second < worst) worst = keyed[i].second, original = keyed[run].second;
    }
  }
  if (worst >= 0) {
    const Triangle& t = faces[worst];
    reject("duplicate_face", "face " + s(worst) + " (vertices " + s(t[0]) + ", " + s(t[1]) + ", " + s(t[2]) +
                                 ") uses the same three vertices as face " + s(original), "face", worst);
  }
}

// ---- edges -----------------------------------------------------------------------------------------

// The mesh's topology (engine/mesh_topology.h) numbers the undirected edges in order of first appearance;
// the "edge" index in errors is that number. Half-edge h = 3f + k runs from corner k of face f to k + 1.
std::string edge_name(const MeshTopology& mesh, int h) {
  const int u = mesh.from(h), v = mesh.to(h);
  return "edge " + s(std::min(u, v)) + "-" + s(std::max(u, v));
}

void check_manifold_edges(const MeshTopology& mesh) {
  for (int e = 0; e < mesh.edge_count(); ++e) {
    const HalfedgeRange uses = mesh.edge_uses(e);
    if (uses.size() <= 2) continue;
    std::string list;
    for (size_t i = 0; i < uses.size() && i < 8; ++i) list += (i ? ", " : "") + s(uses[i] / 3);
    if (uses.size() > 8) list += ", ...";
    reject("non_manifold_edge", edge_name(mesh, uses[0]) + " is shared by " + s(uses.size()) +
                                    " faces (" + list + "); at most two faces may meet at an edge", "edge", e);
  }
}

void check_orientation(const MeshTopology& mesh) {
  for (int e = 0; e < mesh.edge_count(); ++e) {
    if (mesh.edge_use_count(e) != 2) continue;
    const int h1 = mesh.edge_uses(e)[0], h2 = mesh.edge_uses(e)[1];
    if (mesh.from(h1) != mesh.from(h2)) continue;
    reject("inconsistent_orientation",
           "faces " + s(h1 / 3) + " and " + s(h2 / 3) + " both run along " + edge_name(mesh, h1) +
               " from vertex " + s(mesh.from(h1)) + " to " + s(mesh.to(h1)) +
               ": neighbouring faces must list their shared edge in opposite directions (flip one of them)",
           "edge", e);
  }
}

class DisjointSets {
public:
  explicit DisjointSets(size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0); }
  int find(int x) {
    while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
    return x;
  }
  // The smaller index becomes the root, so roots are deterministic.
  void unite(int a, int b) {
    a = find(a), b = find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

private:
  std::vector<int> parent_;
};

// Corner c = 3f + k is vertex faces[f][k] seen from face f. Two corners of the same vertex belong to
// one fan when their faces share an edge at that vertex; one fan per vertex is a manifold vertex.
void check_manifold_vertices(const std::vector<Triangle>& faces, size_t n_vertices, const MeshTopology& mesh) {
  DisjointSets fans(faces.size() * 3);
  for (int e = 0; e < mesh.edge_count(); ++e) {
    if (mesh.edge_use_count(e) != 2) continue;
    const int h1 = mesh.edge_uses(e)[0], h2 = mesh.edge_uses(e)[1];  // opposite directions: h1 = a->b, h2 = b->a
    fans.unite(h1, MeshTopology::next(h2));   // corners of a
    fans.unite(MeshTopology::next(h1), h2);   // corners of b
  }
  std::vector<int> fan_of(n_vertices, -1);
  int bad = -1, face_a = -1, face_b = -1;
  for (int c = 0; c < static_cast<int>(faces.size() * 3); ++c) {
    int v = faces[c / 3][c % 3], fan = fans.find(c);
    if (fan_of[v] < 0) fan_of[v] = fan;
    else if (fan_of[v] != fan && (bad < 0 || v < bad)) bad = v, face_a = fan_of[v] / 3, face_b = c / 3;
  }
  if (bad >= 0)
    reject("non_manifold_vertex", "the faces around vertex " + s(bad) + " form more than one fan: faces " +
                                      s(face_a) + " and " + s(face_b) +
                                      " meet only at this vertex (a surface pinched to a point)", "vertex", bad);
}

void check_connected(const std::vector<Triangle>& faces, const MeshTopology& mesh) {
  DisjointSets parts(faces.size());
  for (int e = 0; e < mesh.edge_count(); ++e)
    if (mesh.edge_use_count(e) == 2) parts.unite(mesh.edge_uses(e)[0] / 3, mesh.edge_uses(e)[1] / 3);
  int components = 0, first_outside = -1;
  for (int f = 0; f < static_cast<int>(faces.size()); ++f) {
    if (parts.find(f) != f) continue;
    ++components;
    if (f != 0 && first_outside < 0) first_outside = f;
  }
  if (components > 1)
    reject("not_connected", "the mesh has " + s(components) + " separate pieces; face " + s(first_outside) +
                                " is not connected to face 0 (a disk is one piece)", "face", first_outside);
}

// ---- boundary and topology ---------------------------------------------------------------------------

void check_one_boundary_loop(const std::vector<std::vector<int>>& loops) {
  if (loops.empty())
    reject("no_boundary", "the mesh is a closed surface (it has no boundary edge); a disk needs one boundary "
                          "loop: cut the surface open first");
  if (loops.size() == 1) return;
  std::string sizes;
  for (size_t i = 0; i < loops.size() && i < 8; ++i)
    sizes += (i ? ", " : "") + s(loops[i].size()) + " vertices from vertex " + s(loops[i][0]);
  if (loops.size() > 8) sizes += ", ...";
  reject("multiple_boundary_loops", "the mesh has " + s(loops.size()) + " boundary loops (" + sizes +
                                        "); a disk has exactly one: fill the holes or cut between them");
}

void check_euler(size_t n_vertices, size_t n_edges, size_t n_faces) {
  long long chi = static_cast<long long>(n_vertices) - static_cast<long long>(n_edges) +
                  static_cast<long long>(n_faces);
  if (chi == 1) return;
  // One boundary loop, connected and orientable: chi = 1 - 2 * genus.
  reject("not_a_disk", "the mesh has one boundary loop but V - E + F = " + s(n_vertices) + " - " + s(n_edges) +
                           " + " + s(n_faces) + " = " + s(chi) + ", not 1: it has " + s((1 - chi) / 2) +
                           " handle(s) (e.g. a punctured torus); cut it into a disk first");
}

// ---- boundary map ----------------------------------------------------------------------------------

void check_lengths(const RawBoundary& raw, size_t expected, bool listed) {
  const std::string what = listed ? "listed boundary vertices" : "boundary vertices of the mesh";
  if (raw.positions.size() != expected)
    reject("boundary_length_mismatch", s(raw.positions.size()) + " boundary positions for " + s(expected) + " " +
                                           what + "; give one position per boundary vertex");
  if (raw.rotation_indices && raw.rotation_indices->size() != expected)
    reject("boundary_length_mismatch", s(raw.rotation_indices->size()) + " rotation indices for " + s(expected) +
                                           " " + what + "; give one per boundary vertex");
}

void check_positions_finite(const std::vector<Point2>& positions) {
  for (size_t k = 0; k < positions.size(); ++k)
    if (!std::isfinite(positions[k].x) || !std::isfinite(positions[k].y))
      reject("boundary_position_non_finite", "boundary position " + s(k) + " has a NaN or infinite coordinate",
             "boundary", k);
}

// The listed vertices must be distinct boundary vertices and, together, the whole boundary loop.
void check_listed_vertices(const DiskMesh& mesh, const std::vector<long long>& listed,
                           const std::vector<int>& position_in_loop) {
  const long long n = static_cast<long long>(mesh.vertices.size());
  std::vector<long long> listed_at(mesh.boundary_loop.size(), -1);
  for (size_t k = 0; k < listed.size(); ++k) {
    long long v = listed[k];
    if (v < 0 || v >= n)
      reject("boundary_vertex_out_of_range", "boundary entry " + s(k) + " is vertex " + s(v) +
                                                 ", but vertex indices run from 0 to " + s(n - 1), "boundary", k);
    int at = position_in_loop[v];
    if (at < 0)
      reject("boundary_vertex_not_on_boundary", "boundary entry " + s(k) + " is vertex " + s(v) +
                                                    ", which is an interior vertex of the mesh", "boundary", k);
    if (listed_at[at] >= 0)
      reject("boundary_vertex_repeated", "boundary entry " + s(k) + " repeats vertex " + s(v) +
                                             " (already entry " + s(listed_at[at]) + ")", "boundary", k);
    listed_at[at] = static_cast<long long>(k);
  }
  auto missing = std::find(listed_at.begin(), listed_at.end(), -1);
  if (missing != listed_at.end())
    reject("boundary_length_mismatch", s(listed.size()) + " boundary vertices listed but the mesh boundary has " +
                                           s(mesh.boundary_loop.size()) + "; vertex " +
                                           s(mesh.boundary_loop[missing - listed_at.begin()]) + " is missing");
}

// listed is a permutation of the loop; it must be a rotation of it (same direction, any start).
void check_loop_order(const std::vector<int>& loop, const std::vector<long long>& listed,
                      const std::vector<int>& position_in_loop) {
  const size_t n = loop.size();
  const size_t start = position_in_loop[listed[0]];
  size_t first_wrong = n;
  for (size_t k = 0; k < n && first_wrong == n; ++k)
    if (listed[k] != loop[(start + k) % n]) first_wrong = k;
  if (first_wrong == n) return;
  bool reversed = true;
  for (size_t k = 0; k < n && reversed; ++k) reversed = listed[k] == loop[(start + n - k) % n];
  if (reversed)
    reject("boundary_not_loop_order", "the boundary vertices are listed in reverse: the interior must be on the "
                                      "left, i.e. list them in the direction of the faces (vertex " +
                                          s(listed[0]) + " is followed by " + s(loop[(start + 1) % n]) + ")",
           "boundary", first_wrong);
  reject("boundary_not_loop_order", "boundary entry " + s(first_wrong) + " is vertex " + s(listed[first_wrong]) +
                                        " but the boundary loop continues with vertex " +
                                        s(loop[(start + first_wrong) % n]) +
                                        "; list the vertices in loop order with the interior on the left",
         "boundary", first_wrong);
}

void check_rotation_indices(const std::vector<long long>& rotation_indices) {
  for (size_t k = 0; k < rotation_indices.size(); ++k) {
    long long r = rotation_indices[k];
    if (r < 0 || r > kMaxRotationIndex)
      reject("rotation_index_out_of_range", "rotation index " + s(k) + " is " + s(r) + "; it must be between 0 and " +
                                                s(kMaxRotationIndex), "boundary", k);
  }
}

}  // namespace

DiskMesh validate_mesh(const RawMesh& raw, const CancelToken* cancel) {
  // Every pass is linear or one sort; the token is checked between passes and inside the costly ones.
  check_not_empty(raw);
  check_cancel(cancel);
  check_finite_coordinates(raw);
  check_cancel(cancel);
  std::vector<Triangle> faces = checked_triangles(raw);
  check_cancel(cancel);
  check_no_repeated_corner(faces);
  check_all_referenced(raw.vertices.size(), faces);
  check_cancel(cancel);
  check_no_degenerate_face(raw.vertices, faces, cancel);
  // The topology takes any face list with indices in range; the duplicate check reads its edges.
  MeshTopology mesh(static_cast<int>(raw.vertices.size()), faces);
  check_cancel(cancel);
  check_no_duplicate_face(faces, mesh, cancel);
  check_cancel(cancel);
  check_manifold_edges(mesh);
  check_orientation(mesh);
  check_cancel(cancel);
  // With every edge manifold and oriented, the topology's fans exist exactly when each vertex's corners form
  // one fan; only a mesh without them needs the corner-by-corner search that names the pinched vertex.
  if (!mesh.oriented_manifold()) check_manifold_vertices(faces, raw.vertices.size(), mesh);
  if (!mesh.oriented_manifold()) throw InternalError("validate: a manifold, oriented mesh has no fans");
  check_cancel(cancel);
  check_connected(faces, mesh);
  check_one_boundary_loop(mesh.boundary_loops());
  check_euler(raw.vertices.size(), static_cast<size_t>(mesh.edge_count()), faces.size());

  DiskMesh disk;
  disk.vertices = raw.vertices;
  disk.boundary_loop = mesh.boundary_loops().front();
  disk.faces = std::move(faces);
  disk.topology = std::move(mesh);
  return disk;
}

BoundaryMap validate_boundary(const DiskMesh& mesh, const RawBoundary& raw, const CancelToken* cancel) {
  check_cancel(cancel);
  const bool listed = raw.vertices.has_value();
  check_lengths(raw, listed ? raw.vertices->size() : mesh.boundary_loop.size(), listed);
  check_positions_finite(raw.positions);

  BoundaryMap map;
  if (listed) {
    std::vector<int> position_in_loop(mesh.vertices.size(), -1);
    for (size_t i = 0; i < mesh.boundary_loop.size(); ++i) position_in_loop[mesh.boundary_loop[i]] = int(i);
    check_listed_vertices(mesh, *raw.vertices, position_in_loop);
    check_loop_order(mesh.boundary_loop, *raw.vertices, position_in_loop);
    map.loop.assign(raw.vertices->begin(), raw.vertices->end());
  } else {
    map.loop = mesh.boundary_loop;
  }

  map.polygon.vertices = raw.positions;
  if (raw.rotation_indices) {
    check_rotation_indices(*raw.rotation_indices);
    map.polygon.rotation_indices.emplace(raw.rotation_indices->begin(), raw.rotation_indices->end());
  }
  validate_polygon(map.polygon);
  return map;
}

}  // namespace lipmap
