// Helpers shared by the glTF codec tests (tests/codec/test_gltf_codec_*.cpp).
#include "tests/codec/gltf_test_util.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <unistd.h>

#include <gtest/gtest.h>

#include "engine/error.h"
#include "engine/mesh_io.h"
#include "server/codec/gltf_codec.h"
#include "tests/support/data_dir.h"
#include "tests/support/gltf_fixtures.h"
#include "tests/support/grid_cells.h"
#include "tests/support/test_meshes.h"

namespace lipmap::gltfcodectest {

const Mesh& shared_mesh(const std::string& file) {
  static std::mutex mu;
  static std::map<std::string, std::unique_ptr<Mesh>> cache;
  std::lock_guard<std::mutex> lock(mu);
  auto& slot = cache[file];
  if (!slot) {
    const testmeshes::MeshEntry& entry = testmeshes::entry(file);
    const RawMesh raw = read_mesh_file(entry.path());
    slot = std::make_unique<Mesh>();
    slot->name = entry.name();
    // glTF POSITION is float32: the meshes are taken at float precision (OBJ/OFF are read in doubles).
    for (const Point3& p : raw.vertices)
      slot->vertices.push_back({gltftest::f32(p.x), gltftest::f32(p.y), gltftest::f32(p.z)});
    for (const auto& f : raw.faces) slot->faces.push_back({int(f[0]), int(f[1]), int(f[2])});
  }
  return *slot;
}

// An n x n grid on [0, 1]^2 with a bump, faces counterclockwise in (x, y).
Mesh grid(int n) {
  Mesh m;
  m.name = "grid";
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = double(i) / (n - 1), y = double(j) / (n - 1);
      m.vertices.push_back({gltftest::f32((x)), gltftest::f32((y)), gltftest::f32((0.2 * std::sin(3 * x) * std::sin(3 * y)))});
    }
  m.faces = testgen::grid_triangles(n - 1, n - 1, [](int, int) { return true; });
  return m;
}

std::string expect_gltf_error(const std::function<void()>& f, const std::string& code) {
  try {
    f();
  } catch (const GltfError& e) {
    EXPECT_EQ(e.code(), code) << e.what();
    return e.what();
  } catch (const InputError& e) {
    ADD_FAILURE() << "InputError " << e.code() << " (wanted GltfError " << code << "): " << e.what();
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "exception (wanted GltfError " << code << "): " << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no error (wanted " << code << ")";
  return {};
}

// ---- Khronos's validator ------------------------------------------------------------------------------

std::filesystem::path temp_dir(const std::string& name) {
  const auto* info = testing::UnitTest::GetInstance()->current_test_info();
  std::string test = std::string(info->test_suite_name()) + "_" + info->name();
  for (char& c : test)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  const auto dir = std::filesystem::temp_directory_path() / ("lipmap-gltf-" + std::to_string(::getpid())) / test / name;
  std::filesystem::create_directories(dir);
  return dir;
}

std::string save(const std::filesystem::path& dir, const std::string& name, const std::string& bytes) {
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

// The files of a run go to /tmp/lipmap-gltf-PID/<test>/; removed at the end unless a test failed or
// LIPMAP_KEEP_GLTF=1 (then the path is printed).
namespace {
class TempFiles : public testing::Environment {
public:
  void TearDown() override {
    const auto root = std::filesystem::temp_directory_path() / ("lipmap-gltf-" + std::to_string(::getpid()));
    if (!std::filesystem::exists(root)) return;
    const char* keep = std::getenv("LIPMAP_KEEP_GLTF");
    if ((keep && std::string(keep) == "1") || testing::UnitTest::GetInstance()->failed_test_count() > 0) {
      std::cout << "[ note ] glTF files kept in " << root.string() << "\n";
      return;
    }
    std::error_code ec;
    std::filesystem::remove_all(root, ec);
  }
};
}  // namespace
namespace {
[[maybe_unused]] testing::Environment* const temp_files = testing::AddGlobalTestEnvironment(new TempFiles);
}  // namespace

// Runs tests/tools/gltf_validate.js on the files; fails the test on any error. Returns false (and says why)
// when the validator is not installed.
bool khronos_validates(const std::vector<std::string>& files) {
  const std::string root = source_dir();
  if (!std::filesystem::exists(root + "/node_modules/gltf-validator/package.json") ||
      std::system("command -v node >/dev/null 2>&1") != 0) {
    std::cout << "[ note ] Khronos glTF validator not installed (npm ci): " << files.size() << " file(s) not validated\n";
    return false;
  }
  if (files.empty()) return true;
  const std::string log = files.front() + ".validator.txt";
  std::string cmd = "node '" + root + "/tests/tools/gltf_validate.js'";
  for (const std::string& f : files) cmd += " '" + f + "'";
  cmd += " >'" + log + "' 2>&1";
  const int rc = std::system(cmd.c_str());
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(rc, 0) << "gltf-validator reported errors:\n" << text.str();
  return true;
}

}  // namespace lipmap::gltfcodectest
