// Reading and writing meshes with OpenMesh's own readers (OBJ, OFF, PLY, STL). Reading yields a RawMesh
// untouched by any repair, so that validate sees exactly what the file says.
#pragma once

#include <string>

#include "engine/disk_mesh.h"

namespace lipmap {

// Throws InputError: mesh_file_unreadable (missing, unknown extension, or the reader failed; also an OBJ
// line that OpenMesh's reader would skip or rewrite: a 'v' line that is not three numbers, an 'f' line
// that repeats a vertex or has fewer than 3 corners). OpenMesh 9.0's readers parse coordinates as float,
// so positions read from a file are the single-precision values of the text.
RawMesh read_mesh_file(const std::string& path);

}  // namespace lipmap
