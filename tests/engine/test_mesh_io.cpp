// read_mesh_file: OpenMesh's readers driven through a recording importer. The shared meshes must arrive
// with exactly the counts of tests/data/meshes/README.md, and faces that OpenMesh's own mesh importer would drop
// (non-manifold, duplicate) must arrive verbatim.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/temp_dir_fixture.h"
#include "tests/support/test_meshes.h"

#include "engine/error.h"
#include "engine/mesh_io.h"

namespace lipmap {
namespace {

// Files in a fresh temporary directory, removed with the fixture.
class MeshIoTest : public TempDirTest {
protected:
  MeshIoTest() : TempDirTest("lipmap_mesh_io_") {}

  static InputError read_error(const std::string& path) {
    try {
      read_mesh_file(path);
    } catch (const InputError& e) {
      return e;
    }
    ADD_FAILURE() << "reading " << path << " did not throw";
    return InputError("none", "");
  }
};

std::vector<long long> face(long long a, long long b, long long c) { return {a, b, c}; }

TEST_F(MeshIoTest, ObjWithTexcoordsNormalsCrlfAndNoiseLinesIsReadVerbatim) {
  // vt and vn outnumber v on purpose: the reader must not make one vertex per v/vt/vn combination.
  std::string path = write("noisy.obj",
                           "# exported\r\nmtllib missing.mtl\r\no thing\r\ns 1\r\n"
                           "v 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\n"
                           "vt 0 0\r\nvt 1 0\r\nvt 1 1\r\nvt 0 1\r\nvt 0.5 0.5\r\nvt 0.25 0.25\r\n"
                           "vn 0 0 1\r\nvn 0 0 1\r\nvn 0 0 1\r\nvn 0 0 1\r\nvn 0 0 1\r\n"
                           "usemtl none\r\ng group\r\n"
                           "f 1/1/1 2/5/2 3/3/3\r\n"
                           "f 1/6/5 3/2/4 4/4/1 # trailing comment\r\n");
  RawMesh mesh = read_mesh_file(path);
  ASSERT_EQ(mesh.vertices.size(), 4u);
  EXPECT_EQ(mesh.vertices[2].x, 1.0);
  EXPECT_EQ(mesh.vertices[2].y, 1.0);
  ASSERT_EQ(mesh.faces.size(), 2u);
  EXPECT_EQ(mesh.faces[0], face(0, 1, 2));
  EXPECT_EQ(mesh.faces[1], face(0, 2, 3));
}

TEST_F(MeshIoTest, ObjNegativeIndicesAndVDoubleSlashVn) {
  std::string path = write("relative.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf -3//1 -2//1 -1//1\n");
  RawMesh mesh = read_mesh_file(path);
  ASSERT_EQ(mesh.faces.size(), 1u);
  EXPECT_EQ(mesh.faces[0], face(0, 1, 2));
}

// OpenMesh's default importer would drop the third face on edge 0-1 ("complex edge") and the duplicate.
TEST_F(MeshIoTest, NonManifoldAndDuplicateFacesSurviveReading) {
  std::string path = write("bad.off",
                           "OFF\n5 4 0\n0 0 0\n1 0 0\n0 1 0\n0 -1 0\n0 0 1\n"
                           "3 0 1 2\n3 1 0 3\n3 0 1 4\n3 0 1 2\n");
  RawMesh mesh = read_mesh_file(path);
  ASSERT_EQ(mesh.faces.size(), 4u);
  EXPECT_EQ(mesh.faces[2], face(0, 1, 4));
  EXPECT_EQ(mesh.faces[3], face(0, 1, 2));
}

TEST_F(MeshIoTest, PolygonsAndOutOfRangeIndicesAreKeptForValidate) {
  std::string path = write("quad.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n3 0 1 7\n");
  RawMesh mesh = read_mesh_file(path);
  ASSERT_EQ(mesh.faces.size(), 2u);
  EXPECT_EQ(mesh.faces[0], (std::vector<long long>{0, 1, 2, 3}));
  EXPECT_EQ(mesh.faces[1], face(0, 1, 7));
}

TEST_F(MeshIoTest, ReadsAsciiPly) {
  std::string path = write("square.ply",
                           "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
                           "end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n");
  RawMesh mesh = read_mesh_file(path);
  ASSERT_EQ(mesh.vertices.size(), 4u);
  EXPECT_EQ(mesh.vertices[3].y, 1.0);
  ASSERT_EQ(mesh.faces.size(), 2u);
  EXPECT_EQ(mesh.faces[1], face(0, 2, 3));
}

TEST_F(MeshIoTest, ReadsAsciiStlAndMergesCornerCopies) {
  std::string path = write("square.stl",
                           "solid square\n"
                           "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nendloop\nendfacet\n"
                           "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\n"
                           "endsolid square\n");
  RawMesh mesh = read_mesh_file(path);
  EXPECT_EQ(mesh.vertices.size(), 4u);  // STL stores corners per facet; the reader shares equal positions
  ASSERT_EQ(mesh.faces.size(), 2u);
  for (const auto& f : mesh.faces) EXPECT_EQ(f.size(), 3u);
}

TEST_F(MeshIoTest, MissingFileIsUnreadableAndNamed) {
  std::string path = (dir_ / "nope.obj").string();
  InputError e = read_error(path);
  EXPECT_EQ(e.code(), "mesh_file_unreadable");
  EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("no such file"), std::string::npos) << e.what();
}

TEST_F(MeshIoTest, DirectoryAndUnknownExtensionAreUnreadable) {
  EXPECT_EQ(read_error(dir_.string()).code(), "mesh_file_unreadable");
  InputError e = read_error(write("mesh.xyz", "1 2 3\n"));
  EXPECT_EQ(e.code(), "mesh_file_unreadable");
  EXPECT_NE(std::string(e.what()).find("extension"), std::string::npos) << e.what();
}

TEST_F(MeshIoTest, OffWithoutHeaderIsRejectedByTheReader) {
  InputError e = read_error(write("headless.off", "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
  EXPECT_EQ(e.code(), "mesh_file_unreadable");
  EXPECT_NE(std::string(e.what()).find("headless.off"), std::string::npos) << e.what();
}

TEST_F(MeshIoTest, TruncatedOffIsUnreadable) {
  InputError e = read_error(write("short.off", "OFF\n5 1 0\n0 0 0\n1 0 0\n0 1 0\n"));
  EXPECT_EQ(e.code(), "mesh_file_unreadable");
  EXPECT_NE(std::string(e.what()).find("announces 5 vertices"), std::string::npos) << e.what();
}

// The OBJ reader would silently skip these lines; that would shift every later vertex index.
TEST_F(MeshIoTest, ObjVertexLineThatIsNotThreeNumbersIsUnreadable) {
  for (const char* bad : {"v nan 0 0", "v 1 2", "v 1e999 0 0"}) {
    SCOPED_TRACE(bad);
    InputError e = read_error(write("v.obj", std::string("v 0 0 0\n") + bad + "\nv 1 0 0\nv 0 1 0\nf 1 3 4\n"));
    EXPECT_EQ(e.code(), "mesh_file_unreadable");
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
}

// The OBJ reader removes repeated corners (and drops the face if fewer than 3 remain); validate must not
// receive a silently repaired face.
TEST_F(MeshIoTest, ObjFaceWithRepeatedCornerIsUnreadable) {
  for (const char* bad : {"f 1 2 1", "f 1 2 2 3", "f 1 2"}) {
    SCOPED_TRACE(bad);
    InputError e = read_error(write("f.obj", std::string("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n") + bad + "\n"));
    EXPECT_EQ(e.code(), "mesh_file_unreadable");
    EXPECT_NE(std::string(e.what()).find("line 5 (face 1)"), std::string::npos) << e.what();
  }
}

// ---- the test meshes: counts from tests/data/meshes/README.md (tests/support/test_meshes.h) ------------

class MeshIoTestCatalog : public ::testing::TestWithParam<testmeshes::MeshEntry> {};

TEST_P(MeshIoTestCatalog, CountsMatchReadme) {
  const testmeshes::MeshEntry& expected = GetParam();
  RawMesh mesh = read_mesh_file(expected.path());
  if (!expected.extra) {  // the README's counts
    EXPECT_EQ(static_cast<long long>(mesh.vertices.size()), expected.vertices);
    EXPECT_EQ(static_cast<long long>(mesh.faces.size()), expected.triangles);
  }
  for (const auto& f : mesh.faces) {
    ASSERT_EQ(f.size(), 3u);
    for (long long v : f) ASSERT_TRUE(v >= 0 && v < static_cast<long long>(mesh.vertices.size()));
  }
  if (expected.planar) {
    for (const Point3& p : mesh.vertices) ASSERT_EQ(p.z, 0.0);
  }
}

std::vector<testmeshes::MeshEntry> catalog_and_extra() {
  std::vector<testmeshes::MeshEntry> all = testmeshes::catalog();
  for (const auto& e : testmeshes::disk_meshes())
    if (e.extra) all.push_back(e);
  return all;
}

INSTANTIATE_TEST_SUITE_P(Readme, MeshIoTestCatalog, ::testing::ValuesIn(catalog_and_extra()),
                         [](const ::testing::TestParamInfo<testmeshes::MeshEntry>& info) { return info.param.name(); });

}  // namespace
}  // namespace lipmap
