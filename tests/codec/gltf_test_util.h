// Helpers shared by the glTF codec tests (tests/codec/test_gltf_codec_*.cpp): the test meshes as float32-exact
// triangle lists, a grid, the error expectation, per-test temp folders and Khronos's validator.
//
// Every glTF written is run through Khronos's validator (tests/tools/gltf_validate.js, npm gltf-validator):
// zero errors. Without node or node_modules/gltf-validator that last check is skipped (scripts/test.sh
// installs both).
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/geometry.h"
#include "server/codec/gltf_codec.h"
#include "tests/support/gltf_fixtures.h"

namespace lipmap::gltfcodectest {

// The names every glTF codec test uses (each test file says `using namespace gltfcodectest`).
using gltf::Asset;
using gltf::Format;
using gltf::GltfError;
using gltftest::FixtureOptions;
using gltftest::make_gltf;
using nlohmann::json;

struct Mesh {
  std::string name;
  std::vector<Point3> vertices;
  std::vector<Triangle> faces;
};

// The attribute interpolation the writer documents for an inserted vertex at t along an edge.
inline double lerp(double x, double y, double t) { return (1 - t) * x + t * y; }

// A file of tests/data/meshes (tests/support/test_meshes.h), read once.
const Mesh& shared_mesh(const std::string& file);

// An n x n grid on [0, 1]^2 with a bump, faces counterclockwise in (x, y).
Mesh grid(int n);

// Runs f, expects a GltfError with this code; returns its message.
std::string expect_gltf_error(const std::function<void()>& f, const std::string& code);

// A fresh folder for the current test's files (under /tmp/lipmap-gltf-PID/, removed at the end of the run
// unless a test failed or LIPMAP_KEEP_GLTF=1).
std::filesystem::path temp_dir(const std::string& name);

// Writes bytes to dir/name; returns the path.
std::string save(const std::filesystem::path& dir, const std::string& name, const std::string& bytes);

// Runs tests/tools/gltf_validate.js on the files; fails the test on any error. Returns false (and says why)
// when the validator is not installed.
bool khronos_validates(const std::vector<std::string>& files);

}  // namespace lipmap::gltfcodectest
