// The test meshes: every file of tests/data/meshes with what tests may rely on, from an independent source
// (the origin's published counts or the generator's construction; tests/data/meshes/README.md), and the
// optional extra folder $LIPMAP_EXTRA_MESHES, whose files that validate accepts join the disk meshes.
//
// Tests take their meshes from here instead of listing file names: a mesh added to tests/data/meshes is added
// to the catalog (tests/support/test_test_meshes.cpp fails otherwise) and then reaches every test.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace lipmap::testmeshes {

struct MeshEntry {
  std::string file;  // relative to tests/data/meshes; an absolute path for an extra mesh
  // Counts of the file; -1 when not known (extra meshes).
  long long vertices = -1, triangles = -1, boundary_vertices = -1;
  bool disk = true;   // validate accepts it
  std::string error;  // validate's error code when it does not
  bool planar = false;               // every z is exactly 0
  bool generated = false;            // written by tests/tools/generate_meshes.js
  bool coincident_boundary = false;  // boundary vertices at equal 3D positions (a surface cut open)
  bool long_boundary = false;        // a third or more of the vertices on the boundary (narrow corridors)
  bool extra = false;                // from $LIPMAP_EXTRA_MESHES

  std::string path() const;  // the file's full path
  std::string name() const;  // a test-name-safe identifier: the file's stem, "extra_" prefixed for extras
};

// Every file of tests/data/meshes (invalid/ included), in order of size.
const std::vector<MeshEntry>& catalog();

// The catalog's disk meshes, then the extra meshes that validate accepts.
const std::vector<MeshEntry>& disk_meshes();

// The disk meshes for which keep(entry) holds.
std::vector<MeshEntry> disk_meshes_where(const std::function<bool(const MeshEntry&)>& keep);

// The catalog entry of a file of tests/data/meshes (throws std::out_of_range for an unknown file).
const MeshEntry& entry(const std::string& file);

// The full path of a file of tests/data/meshes.
std::string mesh_path(const std::string& file);

}  // namespace lipmap::testmeshes
