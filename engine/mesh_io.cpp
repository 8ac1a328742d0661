// Reading mesh files through OpenMesh's own readers (OBJ, OFF, PLY, STL).
//
// OpenMesh's stock importer adds faces to a mesh, which silently drops faces it cannot add (non-manifold
// "complex edge", duplicates). validate must see exactly what the file says, so RecordingImporter below
// stores vertices and faces verbatim in a RawMesh and leaves every judgement to validate.
//
// Known quirks of the OpenMesh 9.0 readers, handled here so that they cannot change the mesh unnoticed:
//  - the OBJ reader skips "v" lines it cannot parse (NaN, out-of-range numbers, fewer than 3 values) and
//    removes repeated vertices from an "f" line, dropping the face when fewer than 3 remain. Either would
//    shift indices or hide a bad face, so the OBJ file's v/f lines are counted and compared (no parsing
//    of numbers: the reader stays OpenMesh's).
//  - the OFF reader stops reading vertices at end of file; the header's counts (passed to reserve())
//    are compared with what arrived.
//  - the readers parse coordinates in single precision (Vec3f); positions are the float values.
#include "engine/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <ostream>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <sstream>

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>

#include "engine/error.h"

namespace lipmap {
namespace {

using OpenMesh::EdgeHandle;
using OpenMesh::FaceHandle;
using OpenMesh::HalfedgeHandle;
using OpenMesh::VertexHandle;

[[noreturn]] void fail(const std::string& path, const std::string& why) {
  throw InputError("mesh_file_unreadable", "cannot read mesh file '" + path + "': " + why);
}

// Records what the reader reports, nothing else. Attribute setters (normals, colors, texture
// coordinates, ...) are ignored: the engine only needs positions and faces.
class RecordingImporter : public OpenMesh::IO::BaseImporter {
public:
  explicit RecordingImporter(RawMesh& out) : out_(out) {}

  std::optional<unsigned> announced_vertices() const { return announced_vertices_; }

  VertexHandle add_vertex(const OpenMesh::Vec3f& p) override { return add_vertex(OpenMesh::Vec3d(p)); }
  VertexHandle add_vertex(const OpenMesh::Vec3d& p) override {
    out_.vertices.push_back(Point3{p[0], p[1], p[2]});
    return VertexHandle(static_cast<int>(out_.vertices.size()) - 1);
  }
  VertexHandle add_vertex() override { return add_vertex(OpenMesh::Vec3d(0, 0, 0)); }
  void set_point(VertexHandle vh, const OpenMesh::Vec3f& p) override {
    if (vh.is_valid() && static_cast<size_t>(vh.idx()) < out_.vertices.size())
      out_.vertices[vh.idx()] = Point3{p[0], p[1], p[2]};
  }

  FaceHandle add_face(const VHandles& corners) override {
    std::vector<long long> face;
    face.reserve(corners.size());
    for (VertexHandle vh : corners) face.push_back(vh.idx());
    out_.faces.push_back(std::move(face));
    return FaceHandle(static_cast<int>(out_.faces.size()) - 1);
  }

  // Half-edge level construction is only used by OpenMesh's own .om format, which is not accepted.
  HalfedgeHandle add_edge(VertexHandle, VertexHandle) override { return HalfedgeHandle(); }
  FaceHandle add_face(HalfedgeHandle) override { return FaceHandle(); }

  void reserve(unsigned n_vertices, unsigned, unsigned n_faces) override {
    announced_vertices_ = n_vertices;
    out_.vertices.reserve(n_vertices);
    out_.faces.reserve(n_faces);
  }

  size_t n_vertices() const override { return out_.vertices.size(); }
  size_t n_faces() const override { return out_.faces.size(); }
  size_t n_edges() const override { return 0; }

  // Everything below carries attributes the engine does not use.
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<OpenMesh::Vec2f>&) override {}
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<OpenMesh::Vec3f>&) override {}
  void set_face_texindex(FaceHandle, int) override {}
  void set_halfedge(VertexHandle, HalfedgeHandle) override {}
  void set_normal(VertexHandle, const OpenMesh::Vec3f&) override {}
  void set_normal(VertexHandle, const OpenMesh::Vec3d&) override {}
  void set_color(VertexHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(VertexHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(VertexHandle, const OpenMesh::Vec3f&) override {}
  void set_color(VertexHandle, const OpenMesh::Vec4f&) override {}
  void set_texcoord(VertexHandle, const OpenMesh::Vec2f&) override {}
  void set_texcoord(VertexHandle, const OpenMesh::Vec3f&) override {}
  void set_texcoord(HalfedgeHandle, const OpenMesh::Vec2f&) override {}
  void set_texcoord(HalfedgeHandle, const OpenMesh::Vec3f&) override {}
  void set_status(VertexHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_status(HalfedgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_status(EdgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_status(FaceHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_next(HalfedgeHandle, HalfedgeHandle) override {}
  void set_face(HalfedgeHandle, FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_color(EdgeHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec3f&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec4f&) override {}
  void set_normal(FaceHandle, const OpenMesh::Vec3f&) override {}
  void set_normal(FaceHandle, const OpenMesh::Vec3d&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec3f&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec4f&) override {}
  void add_texture_information(int, std::string) override {}

private:
  RawMesh& out_;
  std::optional<unsigned> announced_vertices_;
};

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

void check_openable(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail(path, "no such file");
  if (std::filesystem::is_directory(path, ec)) fail(path, "it is a directory");
  std::ifstream probe(path, std::ios::binary);
  if (!probe) fail(path, "it cannot be opened (permission?)");
}

// One "v" or "f" record of an OBJ file as the text has it: only what is needed to notice that the
// OBJ reader skipped or shortened it.
struct ObjRecord {
  bool is_face = false;
  int corners = 0;  // whitespace-separated corner tokens before any trailing comment
  long line = 0;
  bool readable = true;  // a "v" line that holds three floats
};

std::vector<ObjRecord> obj_records(const std::string& path) {
  std::ifstream in(path);
  std::vector<ObjRecord> records;
  std::string line, keyword, token;
  for (long number = 1; std::getline(in, line); ++number) {
    std::istringstream words(line);
    if (!(words >> keyword) || (keyword != "v" && keyword != "f")) continue;
    ObjRecord record{keyword == "f", 0, number, true};
    if (record.is_face) {
      while (words >> token && token[0] != '#') ++record.corners;
    } else {
      // Same extraction as OpenMesh's reader, only to point at the line it skipped.
      float x, y, z;
      record.readable = static_cast<bool>(words >> x >> y >> z);
    }
    records.push_back(record);
  }
  return records;
}

// The OBJ reader must have produced one vertex per "v" line and one face, with all its corners, per
// "f" line; anything else means it skipped or rewrote part of the file.
void check_obj_complete(const std::string& path, const RawMesh& mesh) {
  size_t vertices = 0, faces = 0;
  const std::vector<ObjRecord> records = obj_records(path);
  for (const ObjRecord& r : records) {
    if (!r.is_face) {
      if (!r.readable)
        fail(path, "line " + std::to_string(r.line) + ": a 'v' line whose coordinates are not three finite "
                   "numbers (OpenMesh's OBJ reader would skip it and shift every later vertex index)");
      ++vertices;
      continue;
    }
    size_t f = faces++;
    if (f >= mesh.faces.size() || static_cast<int>(mesh.faces[f].size()) != r.corners)
      fail(path, "line " + std::to_string(r.line) + " (face " + std::to_string(f) +
                     "): the face repeats a vertex or has fewer than 3 corners, which OpenMesh's OBJ "
                     "reader cannot keep as written");
  }
  if (vertices != mesh.vertices.size() || faces != mesh.faces.size())
    fail(path, "the OBJ reader returned " + std::to_string(mesh.vertices.size()) + " vertices and " +
                   std::to_string(mesh.faces.size()) + " faces but the file has " +
                   std::to_string(vertices) + " 'v' and " + std::to_string(faces) + " 'f' lines");
}

}  // namespace

RawMesh read_mesh_file(const std::string& path) {
  check_openable(path);
  const std::string ext = lower_extension(path);
  if (ext != "obj" && ext != "off" && ext != "ply" && ext != "stl")
    fail(path, "unknown extension '" + ext + "' (accepted: .obj, .off, .ply, .stl)");

  RawMesh mesh;
  RecordingImporter importer(mesh);
  OpenMesh::IO::Options options;  // default: positions and faces only
  bool ok = false;
  {
    // The reader singletons keep per-read state (OFF header flags, OBJ materials): one read at a time.
    static std::mutex reader_mutex;
    std::lock_guard<std::mutex> lock(reader_mutex);
    ok = OpenMesh::IO::IOManager().read(path, importer, options);
  }
  if (!ok) fail(path, "OpenMesh's ." + ext + " reader rejected it (not a valid ." + ext + " file?)");

  // OFF and PLY headers state the vertex count (STL merges its corner copies, so it cannot be compared).
  const bool counted_header = ext == "off" || ext == "ply";
  if (counted_header && importer.announced_vertices() &&
      *importer.announced_vertices() != mesh.vertices.size())
    fail(path, "the header announces " + std::to_string(*importer.announced_vertices()) +
                   " vertices but only " + std::to_string(mesh.vertices.size()) + " could be read");
  if (ext == "obj") check_obj_complete(path, mesh);
  return mesh;
}

// ---- Writing ------------------------------------------------------------------------------------------

std::string shortest_double(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buf[64];
  const auto result = std::to_chars(buf, buf + sizeof buf, value);  // shortest round-trip form
  return std::string(buf, result.ptr);
}

void write_obj(std::ostream& out, const std::vector<Point3>& vertices, const std::vector<Triangle>& faces,
               const std::vector<Point2>* uv) {
  if (uv && uv->size() != vertices.size())
    throw InternalError("write_obj: " + std::to_string(uv->size()) + " uv positions for " +
                        std::to_string(vertices.size()) + " vertices");
  const long long n = static_cast<long long>(vertices.size());
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (int c : faces[f])
      if (c < 0 || c >= n)
        throw InternalError("write_obj: face " + std::to_string(f) + " has corner index " + std::to_string(c) +
                            " out of range");
  std::string line;
  char buf[64];
  auto number = [&](double v) {
    line += ' ';
    if (std::isfinite(v)) {
      const auto r = std::to_chars(buf, buf + sizeof buf, v);
      line.append(buf, r.ptr);
    } else {
      line += shortest_double(v);
    }
  };
  auto index = [&](long long i) {
    const auto r = std::to_chars(buf, buf + sizeof buf, i);
    line.append(buf, r.ptr);
  };
  out << "# lipmap: " << vertices.size() << " vertices, " << faces.size() << " faces"
      << (uv ? ", one texture coordinate (vt) per vertex" : "") << "\n";
  for (const Point3& p : vertices) {
    line = "v";
    number(p.x);
    number(p.y);
    number(p.z);
    line += '\n';
    out << line;
  }
  if (uv)
    for (const Point2& p : *uv) {
      line = "vt";
      number(p.x);
      number(p.y);
      line += '\n';
      out << line;
    }
  for (const Triangle& t : faces) {
    line = "f";
    for (int c : t) {
      line += ' ';
      index(static_cast<long long>(c) + 1);
      if (uv) {
        line += '/';
        index(static_cast<long long>(c) + 1);
      }
    }
    line += '\n';
    out << line;
  }
}

void write_obj(const std::string& path, const std::vector<Point3>& vertices, const std::vector<Triangle>& faces,
               const std::vector<Point2>* uv) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw InputError("output_file_unwritable", "cannot create '" + path + "'");
  write_obj(file, vertices, faces, uv);
  file.flush();
  if (!file) throw InputError("output_file_unwritable", "cannot write '" + path + "'");
}

}  // namespace lipmap
