// Reading mesh files: OBJ and OFF with the strict double-precision reader below; PLY and STL through
// OpenMesh's own readers.
//
// OpenMesh's stock importer adds faces to a mesh, which silently drops faces it cannot add (non-manifold
// "complex edge", duplicates). validate must see exactly what the file says, so RecordingImporter below
// stores vertices and faces verbatim in a RawMesh and leaves every judgement to validate. OpenMesh 9.0's
// readers parse coordinates in single precision (Vec3f): PLY and STL positions are the float values.
#include "engine/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <ostream>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <optional>
#include <set>
#include <string_view>

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

// ---- OBJ and OFF in double precision ----------------------------------------------------------------
// A small strict reader: every coordinate is parsed with std::from_chars (correctly rounded to the nearest
// double), so a file written with 17 significant digits reads back bit for bit. Every line it cannot take
// as written is an error naming the line: nothing is skipped, repaired or reordered. Face corners are kept
// as written (any count, any index) so that validate can name what is wrong with them.

// The lines of a text file, without their end-of-line ("\n" or "\r\n"). Line numbers start at 1.
class Lines {
public:
  explicit Lines(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    text_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    if (in.bad()) fail(path, "it cannot be read");
  }
  // The next line (comment from '#' on removed) in *line; false at end of file.
  bool next(std::string_view* line) {
    if (pos_ >= text_.size()) return false;
    std::size_t end = text_.find('\n', pos_);
    if (end == std::string::npos) end = text_.size();
    std::string_view l(text_.data() + pos_, end - pos_);
    pos_ = end + 1;
    ++number_;
    if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
    const std::size_t hash = l.find('#');
    if (hash != std::string_view::npos) l = l.substr(0, hash);
    *line = l;
    return true;
  }
  long number() const { return number_; }

private:
  std::string text_;
  std::size_t pos_ = 0;
  long number_ = 0;
};

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

std::vector<std::string_view> tokens(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_blank(line[i])) ++i;
    std::size_t j = i;
    while (j < line.size() && !is_blank(line[j])) ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

// The whole token as a finite double (a leading '+' is allowed), or nothing.
std::optional<double> parse_double(std::string_view token) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-' && token[1] != '+') token.remove_prefix(1);
  double value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || end != token.data() + token.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

// The whole token as an integer, or nothing.
std::optional<long long> parse_integer(std::string_view token) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
  long long value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

std::string quoted(std::string_view token) {
  constexpr std::size_t kShown = 40;
  return "'" + std::string(token.substr(0, kShown)) + (token.size() > kShown ? "...'" : "'");
}

[[noreturn]] void fail_at(const std::string& path, long line, const std::string& why) {
  fail(path, "line " + std::to_string(line) + ": " + why);
}

// x y z from tokens [first, first + 3); extra values up to `max_values` in all must be numbers too
// (OBJ: an optional w or a vertex colour; OFF variants: colour, normal, texture coordinates).
Point3 parse_point(const std::string& path, long line, const std::vector<std::string_view>& t, std::size_t first,
                   std::size_t max_values, const char* what) {
  const std::size_t values = t.size() - first;
  if (values < 3 || values > max_values)
    fail_at(path, line, std::string(what) + " has " + std::to_string(values) + " values, expected x y z" +
                            (max_values > 3 ? " (and at most " + std::to_string(max_values - 3) + " more)" : ""));
  double xyz[3];
  for (std::size_t i = 0; i < values; ++i) {
    const std::optional<double> v = parse_double(t[first + i]);
    if (!v)
      fail_at(path, line, std::string(what) + ": " + quoted(t[first + i]) + " is not a finite number");
    if (i < 3) xyz[i] = *v;
  }
  return Point3{xyz[0], xyz[1], xyz[2]};
}

// OBJ (Wavefront): "v x y z [w | r g b]" and "f c1 c2 c3 ..." with corners v, v/vt, v//vn or v/vt/vn;
// index k > 0 is vertex k - 1, k < 0 counts back from the last vertex read so far. Texture coordinates,
// normals, groups, objects, smoothing and materials are not needed and are skipped; any other statement is
// an error (it may be geometry this reader would otherwise drop silently).
RawMesh read_obj(const std::string& path) {
  static const std::set<std::string_view> kSkipped = {"vt", "vn", "vp", "g", "o", "s", "mtllib", "usemtl"};
  RawMesh mesh;
  Lines lines(path);
  std::string_view line;
  while (lines.next(&line)) {
    const long number = lines.number();
    const std::vector<std::string_view> t = tokens(line);
    if (t.empty() || kSkipped.count(t[0])) continue;
    if (t[0] == "v") {
      mesh.vertices.push_back(parse_point(path, number, t, 1, 7, "the 'v' line"));
      continue;
    }
    if (t[0] != "f")
      fail_at(path, number, "unsupported OBJ statement " + quoted(t[0]) + " (accepted: v, f; skipped: vt, vn, vp, "
                            "g, o, s, mtllib, usemtl)");
    const std::string face_name = "line " + std::to_string(number) + " (face " + std::to_string(mesh.faces.size()) + ")";
    std::vector<long long> face;
    for (std::size_t i = 1; i < t.size(); ++i) {
      // Only the vertex index is used; the vt and vn indices must still be integers.
      std::string_view corner = t[i];
      const std::size_t slash = corner.find('/');
      std::optional<long long> index = parse_integer(corner.substr(0, slash));
      bool well_formed = index && *index != 0;
      if (well_formed && slash != std::string_view::npos) {
        std::string_view rest = corner.substr(slash + 1);
        const std::size_t slash2 = rest.find('/');
        std::string_view vt = rest.substr(0, slash2);
        if (!vt.empty()) well_formed = static_cast<bool>(parse_integer(vt));
        if (slash2 != std::string_view::npos) well_formed = well_formed && parse_integer(rest.substr(slash2 + 1));
        else well_formed = well_formed && !vt.empty();  // "v/" alone
      }
      if (!well_formed)
        fail(path, face_name + ": corner " + quoted(corner) +
                       " is not v, v/vt, v//vn or v/vt/vn with non-zero integer indices");
      long long v = *index > 0 ? *index - 1 : static_cast<long long>(mesh.vertices.size()) + *index;
      if (v < 0)
        fail(path, face_name + ": relative index " + std::to_string(*index) + " reaches before the first vertex (" +
                       std::to_string(mesh.vertices.size()) + " read so far)");
      face.push_back(v);
    }
    // A corner list that is not a polygon is refused here rather than passed on, as before: an OBJ face
    // must name at least 3 distinct vertices.
    if (face.size() < 3)
      fail(path, face_name + ": the face has " + std::to_string(face.size()) + " corners (fewer than 3)");
    std::vector<long long> sorted = face;
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
      fail(path, face_name + ": the face repeats a vertex");
    mesh.faces.push_back(std::move(face));
  }
  return mesh;
}

// OFF (Geomview): header "OFF" (or with C/N/ST prefixes: extra per-vertex values), then counts
// "vertices faces [edges]" (on the header line or the next), the vertices one per line, then the faces
// "k i1 ... ik [colour]". Comments (#) and blank lines anywhere. Binary OFF and other dimensions are
// refused.
RawMesh read_off(const std::string& path) {
  RawMesh mesh;
  Lines lines(path);
  std::string_view line;
  std::vector<std::string_view> t;
  auto next_tokens = [&]() {
    while (lines.next(&line)) {
      t = tokens(line);
      if (!t.empty()) return true;
    }
    return false;
  };
  if (!next_tokens()) fail_at(path, lines.number(), "end of file: the file is empty (an OFF file starts with OFF)");
  const std::string_view header = t[0];
  static const std::set<std::string_view> kHeaders = {"OFF", "COFF", "NOFF", "CNOFF", "NCOFF", "STOFF", "STCOFF",
                                                      "STNOFF", "STCNOFF"};
  if (!kHeaders.count(header))
    fail_at(path, lines.number(), "the header " + quoted(header) + " is not OFF (nor COFF, NOFF, STOFF ...)");
  if (t.size() > 1 && t[1] == "BINARY") fail_at(path, lines.number(), "binary OFF is not supported");
  // Extra values per vertex line: ST texture coordinates (2), C a colour (3 or 4), N a normal (3).
  std::size_t extra = 0;
  if (header.find("ST") != std::string_view::npos) extra += 2;
  if (header.find('C') != std::string_view::npos) extra += 4;
  if (header.find('N') != std::string_view::npos) extra += 3;
  std::size_t first_count = 1;
  if (t.size() == 1) {
    if (!next_tokens()) fail_at(path, lines.number(), "end of file: the counts after the header are missing");
    first_count = 0;
  }
  const long counts_line = lines.number();
  if (t.size() - first_count < 2 || t.size() - first_count > 3)
    fail_at(path, counts_line, "expected the counts 'vertices faces [edges]'");
  std::optional<long long> counts[3];
  for (std::size_t i = first_count; i < t.size(); ++i) {
    counts[i - first_count] = parse_integer(t[i]);
    if (!counts[i - first_count] || *counts[i - first_count] < 0)
      fail_at(path, counts_line, "the count " + quoted(t[i]) + " is not a non-negative integer");
  }
  const long long n_vertices = *counts[0], n_faces = *counts[1];
  // Reserve only what the file can hold (a lying header must not allocate gigabytes).
  constexpr long long kReserveCap = 1 << 20;
  mesh.vertices.reserve(static_cast<std::size_t>(std::min(n_vertices, kReserveCap)));
  mesh.faces.reserve(static_cast<std::size_t>(std::min(n_faces, kReserveCap)));
  for (long long i = 0; i < n_vertices; ++i) {
    if (!next_tokens())
      fail_at(path, lines.number(), "end of file: the header announces " + std::to_string(n_vertices) +
                                        " vertices but only " + std::to_string(i) + " could be read");
    mesh.vertices.push_back(parse_point(path, lines.number(), t, 0, 3 + extra, "the vertex line"));
  }
  for (long long f = 0; f < n_faces; ++f) {
    if (!next_tokens())
      fail_at(path, lines.number(), "end of file: the header announces " + std::to_string(n_faces) +
                                        " faces but only " + std::to_string(f) + " could be read");
    const long number = lines.number();
    const std::optional<long long> k = parse_integer(t[0]);
    if (!k || *k < 0 || static_cast<std::size_t>(*k) > t.size() - 1)
      fail_at(path, number, "face " + std::to_string(f) + ": " + quoted(t[0]) + " is not a corner count followed by "
                            "that many indices");
    std::vector<long long> face;
    face.reserve(static_cast<std::size_t>(*k));
    for (long long c = 0; c < *k; ++c) {
      const std::optional<long long> index = parse_integer(t[1 + c]);
      if (!index) fail_at(path, number, "face " + std::to_string(f) + ": " + quoted(t[1 + c]) + " is not an index");
      face.push_back(*index);
    }
    // After the indices the format allows a colour: up to four numbers.
    const std::size_t rest = t.size() - 1 - static_cast<std::size_t>(*k);
    if (rest > 4) fail_at(path, number, "face " + std::to_string(f) + ": more values than its " + std::to_string(*k) +
                                        " corners and a colour");
    for (std::size_t i = t.size() - rest; i < t.size(); ++i)
      if (!parse_double(t[i]))
        fail_at(path, number, "face " + std::to_string(f) + ": " + quoted(t[i]) + " is not a number");
    mesh.faces.push_back(std::move(face));
  }
  if (next_tokens())
    fail_at(path, lines.number(), "text after the last of the " + std::to_string(n_faces) + " faces");
  return mesh;
}

}  // namespace

RawMesh read_mesh_file(const std::string& path) {
  check_openable(path);
  const std::string ext = lower_extension(path);
  if (ext == "obj") return read_obj(path);
  if (ext == "off") return read_off(path);
  if (ext != "ply" && ext != "stl")
    fail(path, "unknown extension '" + ext + "' (accepted: .obj, .off, .ply, .stl)");

  RawMesh mesh;
  RecordingImporter importer(mesh);
  OpenMesh::IO::Options options;  // default: positions and faces only
  bool ok = false;
  {
    // The reader singletons keep per-read state: one read at a time.
    static std::mutex reader_mutex;
    std::lock_guard<std::mutex> lock(reader_mutex);
    ok = OpenMesh::IO::IOManager().read(path, importer, options);
  }
  if (!ok) fail(path, "OpenMesh's ." + ext + " reader rejected it (not a valid ." + ext + " file?)");

  // PLY headers state the vertex count (STL merges its corner copies, so it cannot be compared).
  if (ext == "ply" && importer.announced_vertices() && *importer.announced_vertices() != mesh.vertices.size())
    fail(path, "the header announces " + std::to_string(*importer.announced_vertices()) +
                   " vertices but only " + std::to_string(mesh.vertices.size()) + " could be read");
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
