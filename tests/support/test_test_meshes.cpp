// The mesh catalog (tests/support/test_meshes.h) against the folder it describes: every mesh file of
// tests/data/meshes is listed and every listed file exists; the generated meshes are exactly what
// tests/tools/generate_meshes.js writes today; a mesh said to have coincident boundary vertices has them.
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>

#include "engine/mesh_io.h"
#include "tests/support/data_dir.h"
#include "tests/support/test_meshes.h"

namespace lipmap {
namespace {

namespace fs = std::filesystem;
using testmeshes::MeshEntry;

std::string bytes_of(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(TestMeshCatalog, ListsEveryMeshFileOfTheDataFolder) {
  const fs::path root = data_dir() + "/meshes";
  std::set<std::string> on_disk, listed;
  for (const auto& f : fs::recursive_directory_iterator(root)) {
    const std::string ext = f.path().extension().string();
    if (f.is_regular_file() && (ext == ".obj" || ext == ".off" || ext == ".ply" || ext == ".stl"))
      on_disk.insert(fs::relative(f.path(), root).generic_string());
  }
  for (const MeshEntry& e : testmeshes::catalog()) {
    EXPECT_TRUE(listed.insert(e.file).second) << e.file << " listed twice";
    EXPECT_FALSE(e.extra);
    EXPECT_GE(e.vertices, 3) << e.file;
    EXPECT_GE(e.triangles, 1) << e.file;
    EXPECT_EQ(e.disk, e.error.empty()) << e.file;
  }
  EXPECT_EQ(listed, on_disk);
}

// The extra folder's meshes come after the catalog's disks, and only disks are added.
TEST(TestMeshCatalog, DiskMeshesAreTheCatalogsDisksThenTheExtraOnes) {
  std::vector<std::string> expected;
  for (const MeshEntry& e : testmeshes::catalog())
    if (e.disk) expected.push_back(e.file);
  std::vector<std::string> got;
  for (const MeshEntry& e : testmeshes::disk_meshes())
    if (!e.extra) got.push_back(e.file);
  EXPECT_EQ(got, expected);
  for (const MeshEntry& e : testmeshes::disk_meshes()) {
    EXPECT_TRUE(e.disk);
    if (e.extra) {
      EXPECT_TRUE(fs::path(e.file).is_absolute()) << e.file;
    }
  }
}

// Regenerating into a fresh folder gives the committed bytes, and exactly the files the catalog marks as
// generated. Needs node (as the bats suites do).
TEST(TestMeshCatalog, GeneratorReproducesTheCommittedMeshes) {
  ASSERT_EQ(std::system("command -v node >/dev/null 2>&1"), 0) << "node is needed to run tests/tools/generate_meshes.js";
  const fs::path out = fs::temp_directory_path() / ("lipmap-generated-meshes-" + std::to_string(::getpid()));
  fs::remove_all(out);
  const std::string cmd = "node '" + source_dir() + "/tests/tools/generate_meshes.js' '" + out.string() + "' >/dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::set<std::string> written, generated;
  for (const auto& f : fs::directory_iterator(out)) written.insert(f.path().filename().string());
  for (const MeshEntry& e : testmeshes::catalog()) {
    if (!e.generated) continue;
    generated.insert(e.file);
    EXPECT_TRUE(bytes_of(out / e.file) == bytes_of(testmeshes::mesh_path(e.file)))
        << e.file << " differs from what generate_meshes.js writes (" << (out / e.file).string() << ")";
  }
  EXPECT_EQ(written, generated);
  if (!HasFailure()) fs::remove_all(out);
}

// Independent of validate: a mesh marked as cut open has distinct boundary vertices at one 3D point, and
// the others of the catalog's generated meshes have none.
TEST(TestMeshCatalog, CoincidentBoundaryVerticesWhereTheCatalogSaysSo) {
  for (const MeshEntry& e : testmeshes::catalog()) {
    if (!e.generated) continue;
    const RawMesh raw = read_mesh_file(e.path());
    std::map<std::pair<long long, long long>, int> directed;
    for (const auto& f : raw.faces)
      for (int c = 0; c < 3; ++c) ++directed[{f[c], f[(c + 1) % 3]}];
    std::set<long long> boundary;
    for (const auto& [edge, n] : directed)
      if (!directed.count({edge.second, edge.first})) boundary.insert(edge.first);
    std::set<std::tuple<double, double, double>> seen;
    int coincident = 0;
    for (long long v : boundary) {
      const Point3& p = raw.vertices[static_cast<std::size_t>(v)];
      coincident += seen.insert({p.x, p.y, p.z}).second ? 0 : 1;
    }
    EXPECT_EQ(static_cast<long long>(boundary.size()), e.boundary_vertices) << e.file;
    EXPECT_EQ(coincident > 0, e.coincident_boundary) << e.file << ": " << coincident << " coincident";
  }
}

}  // namespace
}  // namespace lipmap
