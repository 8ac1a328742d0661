// read_mesh_file for OBJ and OFF in double precision: generated meshes whose coordinates a float cannot
// hold, written here with printf's %.17g (not with the program's writer), must read back bit for bit, with
// every corner form and index form of OBJ; every malformed form must be refused with mesh_file_unreadable
// and a one-line message naming its line; the repository's meshes must read as OpenMesh's own readers
// read them (same counts, same faces, coordinates equal after rounding to float).
#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>

#include "tests/support/data_dir.h"
#include "tests/support/temp_dir_fixture.h"

#include "engine/error.h"
#include "engine/mesh_io.h"

namespace lipmap {
namespace {

namespace fs = std::filesystem;

std::uint64_t bits(double v) {
  std::uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

std::string g17(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

class MeshIoDouble : public TempDirTest {
protected:
  MeshIoDouble() : TempDirTest("lipmap_mesh_io_double_") {}
};

// A coordinate of one of several kinds, most of them not representable as a float: full 53-bit mantissas
// at scales from 1e-300 to 1e300, subnormals, signed zeros, the largest double, small integers.
double random_coordinate(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-1, 1);
  std::uniform_int_distribution<int> kind(0, 9), exponent(-300, 300);
  switch (kind(rng)) {
    case 0: return std::ldexp(unit(rng), -1060);                    // subnormal
    case 1: return (rng() & 1) ? 0.0 : -0.0;
    case 2: return (rng() & 1) ? std::numeric_limits<double>::max() : -std::numeric_limits<double>::min();
    case 3: return static_cast<double>(static_cast<int>(rng() % 2001) - 1000);
    case 4: return unit(rng) * std::pow(10.0, exponent(rng));
    default: return unit(rng) * 1000;  // ordinary model coordinates, full mantissa
  }
}

struct Generated {
  std::vector<Point3> vertices;
  std::vector<std::vector<long long>> faces;
};

// A random mesh (faces are arbitrary vertex triples and quads: the reader must not judge them).
Generated random_mesh(std::mt19937_64& rng, int n_vertices, int n_faces) {
  Generated g;
  for (int i = 0; i < n_vertices; ++i)
    g.vertices.push_back({random_coordinate(rng), random_coordinate(rng), random_coordinate(rng)});
  std::uniform_int_distribution<long long> pick(0, n_vertices - 1);
  for (int f = 0; f < n_faces; ++f) {
    std::vector<long long> face;
    const int corners = (n_vertices > 3 && rng() % 4 == 0) ? 4 : 3;
    while (static_cast<int>(face.size()) < corners) {
      const long long v = pick(rng);
      if (std::find(face.begin(), face.end(), v) == face.end()) face.push_back(v);
    }
    g.faces.push_back(face);
  }
  return g;
}

void expect_same(const Generated& expected, const RawMesh& got) {
  ASSERT_EQ(got.vertices.size(), expected.vertices.size());
  for (std::size_t i = 0; i < got.vertices.size(); ++i) {
    const Point3 &e = expected.vertices[i], &r = got.vertices[i];
    ASSERT_EQ(bits(r.x), bits(e.x)) << "vertex " << i << " x: " << g17(r.x) << " vs " << g17(e.x);
    ASSERT_EQ(bits(r.y), bits(e.y)) << "vertex " << i << " y: " << g17(r.y) << " vs " << g17(e.y);
    ASSERT_EQ(bits(r.z), bits(e.z)) << "vertex " << i << " z: " << g17(r.z) << " vs " << g17(e.z);
  }
  ASSERT_EQ(got.faces, expected.faces);
}

// At least one coordinate a float cannot hold, or the round trip would prove nothing about precision.
bool has_non_float(const Generated& g) {
  for (const Point3& p : g.vertices)
    for (double c : {p.x, p.y, p.z})
      if (std::fabs(c) < 1e38 && static_cast<double>(static_cast<float>(c)) != c) return true;
  return false;
}

// OBJ with every corner form, positive and negative (relative) indices, faces interleaved with the vertices
// (a negative index counts back from the vertices read so far), skipped statements, comments, CRLF.
std::string to_obj(const Generated& g, std::mt19937_64& rng, bool crlf) {
  const std::string eol = crlf ? "\r\n" : "\n";
  std::string text = "# generated" + eol + "mtllib none.mtl" + eol + "o thing" + eol;
  // Face f is written once all its corners are written; vertices go out in order.
  std::size_t written = 0;
  auto write_vertex = [&](std::size_t i) {
    const Point3& p = g.vertices[i];
    text += "v " + g17(p.x) + " " + g17(p.y) + "\t" + g17(p.z) + ((rng() % 5 == 0) ? " # a comment" : "") + eol;
    if (rng() % 7 == 0) text += "vt 0.25 0.5" + eol + "vn 0 0 1" + eol;
    if (rng() % 11 == 0) text += "g part" + eol + "s off" + eol + "usemtl m" + eol;
  };
  for (const auto& face : g.faces) {
    const long long needed = *std::max_element(face.begin(), face.end());
    while (static_cast<long long>(written) <= needed) write_vertex(written++);
    text += "f";
    for (long long v : face) {
      const long long index = (rng() % 3 == 0) ? v - static_cast<long long>(written) : v + 1;  // relative or absolute
      const std::string i = std::to_string(index);
      switch (rng() % 4) {
        case 0: text += " " + i; break;
        case 1: text += " " + i + "/1"; break;
        case 2: text += " " + i + "//1"; break;
        default: text += " " + i + "/1/1"; break;
      }
    }
    text += eol;
  }
  while (written < g.vertices.size()) write_vertex(written++);
  return text;
}

std::string to_off(const Generated& g, std::mt19937_64& rng, bool crlf) {
  const std::string eol = crlf ? "\r\n" : "\n";
  std::string text = "OFF" + eol + "# generated" + eol + std::to_string(g.vertices.size()) + " " +
                     std::to_string(g.faces.size()) + " 0" + eol;
  for (const Point3& p : g.vertices) {
    text += g17(p.x) + " " + g17(p.y) + " " + g17(p.z) + eol;
    if (rng() % 9 == 0) text += eol + "# between vertices" + eol;
  }
  for (const auto& face : g.faces) {
    text += std::to_string(face.size());
    for (long long v : face) text += " " + std::to_string(v);
    text += eol;
  }
  return text;
}

TEST_F(MeshIoDouble, GeneratedObjAndOffReadBackBitForBit) {
  std::mt19937_64 rng(20240917);
  for (int round = 0; round < 60; ++round) {
    SCOPED_TRACE("round " + std::to_string(round));
    const Generated g = random_mesh(rng, 3 + static_cast<int>(rng() % 60), 1 + static_cast<int>(rng() % 80));
    ASSERT_TRUE(has_non_float(g));
    const bool crlf = round % 2 == 1;
    expect_same(g, read_mesh_file(write("m.obj", to_obj(g, rng, crlf))));
    expect_same(g, read_mesh_file(write("m.off", to_off(g, rng, crlf))));
  }
}

// The bits of a coordinate are the correctly rounded value of its text, also for texts that are not the
// shortest or the %.17g form (many digits, leading '+', exponents).
TEST_F(MeshIoDouble, CoordinatesAreTheNearestDoubleOfTheirText) {
  const char* texts[] = {"0.1", "+0.3", "-2.5e-3", "1e-320", "123456789012345678901234567890",
                         "0.30000000000000004441", "1.0000000000000002", "9007199254740993", "-0"};
  for (const char* t : texts) {
    SCOPED_TRACE(t);
    const double expected = std::strtod(t, nullptr);  // glibc's strtod rounds correctly
    const RawMesh obj =
        read_mesh_file(write("c.obj", std::string("v ") + t + " " + t + " " + t + "\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
    EXPECT_EQ(bits(obj.vertices[0].x), bits(expected));
    EXPECT_EQ(bits(obj.vertices[0].z), bits(expected));
    const RawMesh off =
        read_mesh_file(write("c.off", std::string("OFF\n3 1 0\n") + t + " 0 " + t + "\n1 0 0\n0 1 0\n3 0 1 2\n"));
    EXPECT_EQ(bits(off.vertices[0].x), bits(expected));
    EXPECT_EQ(bits(off.vertices[0].z), bits(expected));
  }
}

// PLY and STL stay with OpenMesh's readers, which parse floats: the limitation stays pinned down.
TEST_F(MeshIoDouble, PlyCoordinatesArriveInSinglePrecision) {
  const RawMesh mesh = read_mesh_file(write("p.ply",
                                            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                            "property float y\nproperty float z\nelement face 1\n"
                                            "property list uchar int vertex_indices\nend_header\n"
                                            "0.1 0.2 0.3\n1 0 0\n0 1 0\n3 0 1 2\n"));
  ASSERT_EQ(mesh.vertices.size(), 3u);
  EXPECT_EQ(mesh.vertices[0].x, static_cast<double>(0.1f));
  EXPECT_EQ(mesh.vertices[0].z, static_cast<double>(0.3f));
}

TEST_F(MeshIoDouble, ObjNegativeIndicesCountBackFromTheVerticesReadSoFar) {
  // After 3 vertices -1 is vertex 2; after 5, -1 is vertex 4 and -5 is vertex 0.
  const RawMesh mesh = read_mesh_file(write("rel.obj",
                                            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"
                                            "v 1 1 0\nv 2 1 0\nf -5/1 -2//3 -1/2/3 2\n"));
  ASSERT_EQ(mesh.faces.size(), 2u);
  EXPECT_EQ(mesh.faces[0], (std::vector<long long>{0, 1, 2}));
  EXPECT_EQ(mesh.faces[1], (std::vector<long long>{0, 3, 4, 1}));
}

// Faces are passed on as written for validate to judge (corner count, range), in both formats.
TEST_F(MeshIoDouble, FacesKeepAnyCornerCountAndIndexForValidate) {
  const RawMesh obj = read_mesh_file(write("q.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1 3 9\n"));
  ASSERT_EQ(obj.faces.size(), 2u);
  EXPECT_EQ(obj.faces[0], (std::vector<long long>{0, 1, 2, 3}));
  EXPECT_EQ(obj.faces[1], (std::vector<long long>{0, 2, 8}));
  const RawMesh off = read_mesh_file(
      write("q.off", "OFF 4 4 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n2 0 1\n3 0 2 2\n3 0 1 -7 0.5 0.5 0.5\n"));
  ASSERT_EQ(off.faces.size(), 4u);
  EXPECT_EQ(off.faces[1], (std::vector<long long>{0, 1}));
  EXPECT_EQ(off.faces[2], (std::vector<long long>{0, 2, 2}));
  EXPECT_EQ(off.faces[3], (std::vector<long long>{0, 1, -7}));
}

TEST_F(MeshIoDouble, OffVariantsCommentsAndBlankLines) {
  const RawMesh coff = read_mesh_file(write("c.off",
                                            "COFF\r\n# colours\r\n\r\n3 1 3\r\n0 0 0 255 0 0 255\r\n"
                                            "1 0 0 0 255 0 255\r\n0 1 0.5 0 0 255 255 # blue\r\n\r\n3 0 1 2\r\n"));
  ASSERT_EQ(coff.vertices.size(), 3u);
  EXPECT_EQ(coff.vertices[2].z, 0.5);
  EXPECT_EQ(coff.faces[0], (std::vector<long long>{0, 1, 2}));
}

// ---- malformed files: each refused with mesh_file_unreadable on one line naming the file and the line ----

struct Malformed {
  const char* name;  // file name (its extension picks the reader)
  const char* text;
  long line;         // the line the message must name
  const char* says;  // a fragment of the reason
};

const Malformed kMalformed[] = {
    {"two.obj", "v 0 0 0\nv 1 2\nv 0 1 0\nf 1 2 3\n", 2, "2 values"},
    {"word.obj", "v 0 0 0\nv 1 0 0\nv 1 2 x\nf 1 2 3\n", 3, "'x' is not a finite number"},
    {"nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 1, "not a finite number"},
    {"inf.obj", "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n", 3, "not a finite number"},
    {"huge.obj", "v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n", 2, "not a finite number"},
    {"glued.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0.5.5\nf 1 2 3\n", 3, "not a finite number"},
    {"many.obj", "v 0 0 0 1 1 1 1 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 1, "8 values"},
    {"short_face.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", 4, "fewer than 3"},
    {"repeat.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 -1 3\n", 5, "repeats a vertex"},
    {"zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4, "'0'"},
    {"suffix.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2a 3\n", 4, "'2a'"},
    {"float_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2.0 3\n", 4, "'2.0'"},
    {"slash.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/ 2 3\n", 4, "'1/'"},
    {"bad_vt.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/x/1 2 3\n", 4, "'1/x/1'"},
    {"bad_vn.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1// 2 3\n", 4, "'1//'"},
    {"before_first.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 2 3\n", 4, "relative index -4"},
    {"line_element.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nf 1 2 3\n", 4, "'l'"},
    {"crlf.obj", "# a\r\nv 0 0 0\r\nv 1 0 0\r\n\r\nv 0 1\r\nf 1 2 3\r\n", 5, "2 values"},
    {"empty_header.off", "", 0, "empty"},
    {"header.off", "OFX\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", 1, "'OFX'"},
    {"headless.off", "# c\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", 2, "'3'"},
    {"binary.off", "OFF BINARY\n3 1 0\n", 1, "binary"},
    {"no_counts.off", "OFF\n# only a comment\n", 2, "counts"},
    {"counts_word.off", "OFF\n3 one 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", 2, "'one'"},
    {"counts_negative.off", "OFF\n3 -1 0\n0 0 0\n1 0 0\n0 1 0\n", 2, "'-1'"},
    {"counts_four.off", "OFF\n3 1 0 7\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", 2, "counts"},
    {"vertex_two.off", "OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n", 4, "2 values"},
    {"vertex_color.off", "OFF\n3 1 0\n0 0 0 1 1 1\n1 0 0\n0 1 0\n3 0 1 2\n", 3, "6 values"},
    {"vertex_nan.off", "OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", 4, "not a finite number"},
    {"face_count.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", 6, "corner count"},
    {"face_word.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\nthree 0 1 2\n", 6, "'three'"},
    {"face_index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n", 6, "'1.5'"},
    {"face_tail.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 red\n", 6, "'red'"},
    {"face_long_tail.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 1 1 1 1 1\n", 6, "colour"},
    {"few_vertices.off", "OFF\n5 1 0\n0 0 0\n1 0 0\n0 1 0\n", 5, "announces 5 vertices but only 3"},
    {"few_faces.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n\n", 7, "announces 2 faces but only 1"},
    {"trailing.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n", 7, "after the last"},
    {"crlf.off", "OFF\r\n3 1 0\r\n0 0 0\r\n1 0 0\r\n0 1 0 0 \r\n3 0 1 2\r\n", 5, "4 values"},
};

TEST_F(MeshIoDouble, EveryMalformedFormNamesItsLine) {
  for (const Malformed& m : kMalformed) {
    SCOPED_TRACE(m.name);
    const std::string path = write(m.name, m.text);
    try {
      read_mesh_file(path);
      ADD_FAILURE() << "read without error";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(e.code(), "mesh_file_unreadable") << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << "not one line: " << what;
      EXPECT_NE(what.find(path), std::string::npos) << what;
      // The face number, when named, follows the line: "line 4 (face 0): ".
      const bool named = what.find("line " + std::to_string(m.line) + ":") != std::string::npos ||
                         what.find("line " + std::to_string(m.line) + " (face") != std::string::npos;
      EXPECT_TRUE(named) << "wanted line " << m.line << ": " << what;
      EXPECT_NE(what.find(m.says), std::string::npos) << "wanted '" << m.says << "': " << what;
    }
  }
}

// ---- the repository's meshes: what OpenMesh's own readers see, now in doubles ----------------------------

// OpenMesh's stock reader into a polygon mesh with float points (its reader's own precision). Its
// importer drops faces it cannot add (non-manifold, duplicate) and appends copies of non-manifold vertices,
// so faces are compared only when it kept the file as it is.
struct OpenMeshView {
  std::vector<OpenMesh::Vec3f> points;
  std::vector<std::vector<long long>> faces;
};

OpenMeshView read_with_openmesh(const std::string& path) {
  struct Traits : OpenMesh::DefaultTraits {};
  OpenMesh::PolyMesh_ArrayKernelT<Traits> mesh;
  OpenMeshView view;
  if (!OpenMesh::IO::read_mesh(mesh, path)) return view;
  for (auto v : mesh.vertices()) view.points.push_back(mesh.point(v));
  for (auto f : mesh.faces()) {
    std::vector<long long> face;
    for (auto v : mesh.fv_range(f)) face.push_back(v.idx());
    view.faces.push_back(face);
  }
  return view;
}

// The same cyclic sequence (OpenMesh may start a face at another corner).
bool same_cycle(const std::vector<long long>& a, const std::vector<long long>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t s = 0; s < a.size(); ++s) {
    bool all = true;
    for (std::size_t i = 0; i < a.size() && all; ++i) all = a[i] == b[(i + s) % b.size()];
    if (all) return true;
  }
  return false;
}

TEST(MeshIoDoubleRepository, EveryObjAndOffReadsAsOpenMeshReadsIt) {
  int files = 0;
  for (const char* folder : {"/meshes", "/meshes/invalid"}) {
    for (const auto& entry : fs::directory_iterator(data_dir() + folder)) {
      const std::string ext = entry.path().extension().string();
      if (ext != ".obj" && ext != ".off") continue;
      SCOPED_TRACE(entry.path().string());
      ++files;
      const RawMesh mesh = read_mesh_file(entry.path().string());
      const OpenMeshView om = read_with_openmesh(entry.path().string());
      // For a non-manifold vertex the stock importer appends copies: the file's vertices come first.
      ASSERT_LE(mesh.vertices.size(), om.points.size());
      for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        const Point3& p = mesh.vertices[i];
        ASSERT_EQ(static_cast<float>(p.x), om.points[i][0]) << "vertex " << i;
        ASSERT_EQ(static_cast<float>(p.y), om.points[i][1]) << "vertex " << i;
        ASSERT_EQ(static_cast<float>(p.z), om.points[i][2]) << "vertex " << i;
      }
      ASSERT_GE(mesh.faces.size(), om.faces.size());
      if (mesh.faces.size() == om.faces.size() && mesh.vertices.size() == om.points.size()) {
        for (std::size_t f = 0; f < mesh.faces.size(); ++f)
          ASSERT_TRUE(same_cycle(mesh.faces[f], om.faces[f])) << "face " << f;
      }
    }
  }
  EXPECT_GE(files, 10);
}

}  // namespace
}  // namespace lipmap
