// Reading and writing meshes with OpenMesh's own readers (OBJ, OFF, PLY, STL). Reading yields a RawMesh
// untouched by any repair, so that validate sees exactly what the file says.
#pragma once

#include <string>

#include "engine/disk_mesh.h"

namespace lipmap {

// Throws InputError: mesh_file_unreadable (missing, unknown extension, or the reader failed).
RawMesh read_mesh_file(const std::string& path);

}  // namespace lipmap
