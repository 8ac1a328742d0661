#include "tests/support/test_meshes.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iostream>
#include <stdexcept>

#include "engine/mesh_io.h"
#include "engine/validate.h"
#include "tests/support/data_dir.h"

namespace lipmap::testmeshes {
namespace {

// Public meshes: counts as published with the files' origins (tests/data/meshes/README.md).
MeshEntry public_disk(const char* file, long long v, long long t, long long b) {
  MeshEntry e;
  e.file = file;
  e.vertices = v, e.triangles = t, e.boundary_vertices = b;
  return e;
}

MeshEntry invalid(const char* file, long long v, long long t, long long b, const char* error) {
  MeshEntry e = public_disk(file, v, t, b);
  e.disk = false;
  e.error = error;
  return e;
}

// Generated meshes: counts from the construction in tests/tools/generate_meshes.js.
MeshEntry generated(const char* file, long long v, long long t, long long b, bool planar) {
  MeshEntry e = public_disk(file, v, t, b);
  e.generated = true;
  e.planar = planar;
  return e;
}

// Ring disks (generate_meshes.js ringDisk): 1 + 3 n (n + 1) vertices, 6 n^2 triangles, 6 n on the boundary.
MeshEntry ring_disk(const char* file, long long n, bool planar) {
  return generated(file, 1 + 3 * n * (n + 1), 6 * n * n, 6 * n, planar);
}

std::vector<MeshEntry> make_catalog() {
  std::vector<MeshEntry> c;
  c.push_back(public_disk("nefertiti.off", 299, 562, 34));
  c.push_back(public_disk("blob.off", 138, 270, 4));
  c.push_back(public_disk("three_peaks.off", 1907, 3671, 141));
  c.push_back(public_disk("camel-head.off", 11381, 22704, 56));
  c.push_back(public_disk("mannequin-devil.off", 12977, 25888, 64));
  c.push_back(public_disk("keenan-ogre.obj", 19985, 39856, 112));
  c.push_back(public_disk("mountain.obj", 25600, 50562, 636));
  c.push_back(public_disk("max-registration-partial.obj", 31894, 63347, 439));
  MeshEntry maze = public_disk("maze.obj", 6120, 9174, 3064);
  maze.long_boundary = true;
  c.push_back(maze);

  // 200 x 15 grid: 3000 vertices, 2 * 199 * 14 triangles, 2 * (199 + 14) boundary vertices.
  c.push_back(generated("wiggly_strip.obj", 3000, 5572, 426, true));
  // 256 cells of 2 x 2 squares (9 lattice points each) and 255 passages of 2 x 1 squares (no new points):
  // 2304 vertices, 2 * (1024 + 510) triangles; interior points: each cell's centre and two per passage.
  MeshEntry corridor = generated("maze_corridor.obj", 2304, 3068, 2304 - 256 - 2 * 255, true);
  corridor.long_boundary = true;
  c.push_back(corridor);
  c.push_back(ring_disk("swirl_blob.obj", 15, true));
  c.push_back(ring_disk("swirl_domain.obj", 36, true));
  // Pole + 30 rings of 65 vertices; 64 + 2 * 64 * 29 triangles; boundary: the rim, both slit sides, the pole.
  MeshEntry bowl = generated("cut_bowl.obj", 1 + 65 * 30, 64 + 2 * 64 * 29, 65 + 2 * 29 + 1, false);
  bowl.coincident_boundary = true;
  c.push_back(bowl);
  c.push_back(ring_disk("bumpy_patch.obj", 92, false));

  c.push_back(invalid("withZeroAreaTri_48.obj", 24510, 48855, 163, "degenerate_face"));
  c.push_back(invalid("invalid/triple_vierbein.obj", 75, 108, 58, "non_manifold_edge"));
  c.push_back(invalid("invalid/blob-closed.off", 140, 276, 0, "no_boundary"));
  c.push_back(invalid("invalid/holes.off", 4291, 8288, 304, "multiple_boundary_loops"));
  c.push_back(invalid("invalid/punctured-torus.obj", 4599, 9184, 16, "not_a_disk"));
  std::stable_sort(c.begin(), c.end(), [](const MeshEntry& a, const MeshEntry& b) { return a.triangles < b.triangles; });
  return c;
}

// The mesh files of $LIPMAP_EXTRA_MESHES that validate accepts, by file name; the others are named once.
std::vector<MeshEntry> extra_meshes() {
  std::vector<MeshEntry> out;
  const char* dir = std::getenv("LIPMAP_EXTRA_MESHES");
  if (!dir || !*dir) return out;
  std::error_code ec;
  std::vector<std::filesystem::path> files;
  for (const auto& f : std::filesystem::directory_iterator(dir, ec)) {
    const std::string ext = f.path().extension().string();
    if (f.is_regular_file() && (ext == ".obj" || ext == ".off" || ext == ".ply" || ext == ".stl")) files.push_back(f.path());
  }
  if (ec) std::cerr << "[ note ] LIPMAP_EXTRA_MESHES=" << dir << ": " << ec.message() << "\n";
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    try {
      validate_mesh(read_mesh_file(f.string()));
    } catch (const std::exception& e) {
      std::cerr << "[ note ] extra mesh " << f.string() << " is not used: " << e.what() << "\n";
      continue;
    }
    MeshEntry e;
    e.file = std::filesystem::absolute(f).string();
    e.extra = true;
    out.push_back(e);
  }
  return out;
}

}  // namespace

std::string MeshEntry::path() const { return extra ? file : mesh_path(file); }

std::string MeshEntry::name() const {
  std::string n = std::filesystem::path(file).stem().string();
  if (extra) n = "extra_" + n;
  for (char& ch : n)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return n;
}

const std::vector<MeshEntry>& catalog() {
  static const std::vector<MeshEntry> c = make_catalog();
  return c;
}

const std::vector<MeshEntry>& disk_meshes() {
  static const std::vector<MeshEntry> disks = [] {
    std::vector<MeshEntry> d;
    for (const MeshEntry& e : catalog())
      if (e.disk) d.push_back(e);
    for (MeshEntry& e : extra_meshes()) d.push_back(std::move(e));
    return d;
  }();
  return disks;
}

std::vector<MeshEntry> disk_meshes_where(const std::function<bool(const MeshEntry&)>& keep) {
  std::vector<MeshEntry> out;
  for (const MeshEntry& e : disk_meshes())
    if (keep(e)) out.push_back(e);
  return out;
}

const MeshEntry& entry(const std::string& file) {
  for (const MeshEntry& e : catalog())
    if (e.file == file) return e;
  throw std::out_of_range("not a test mesh: " + file);
}

std::string mesh_path(const std::string& file) { return data_dir() + "/meshes/" + file; }

}  // namespace lipmap::testmeshes
