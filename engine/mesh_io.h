// Reading and writing meshes with OpenMesh's own readers (OBJ, OFF, PLY, STL). Reading yields a RawMesh
// untouched by any repair, so that validate sees exactly what the file says.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "engine/disk_mesh.h"
#include "engine/geometry.h"

namespace lipmap {

// Throws InputError: mesh_file_unreadable (missing, unknown extension, or the reader failed; also an OBJ
// line that OpenMesh's reader would skip or rewrite: a 'v' line that is not three numbers, an 'f' line
// that repeats a vertex or has fewer than 3 corners). OpenMesh 9.0's readers parse coordinates as float,
// so positions read from a file are the single-precision values of the text.
RawMesh read_mesh_file(const std::string& path);

// ---- Writing ------------------------------------------------------------------------------------------
// An OBJ file of a mesh with one texture coordinate per vertex: "v x y z" for every vertex, then (when uv is
// given) "vt u v" for every vertex, then "f a/a b/b c/c" per face (1-based, vertex i uses vt i), or
// "f a b c" without uv. Every number is written in the shortest form that reads back (strtod) to the same
// double. The writer is independent of OpenMesh (whose OBJ writer goes through floats).
// write_obj(ostream) throws InternalError when uv is given with a size other than vertices.size() or a
// face index is out of range; write_obj(path) also throws InputError "output_file_unwritable" when the
// file cannot be created or written.
void write_obj(std::ostream& out, const std::vector<Point3>& vertices, const std::vector<Triangle>& faces,
               const std::vector<Point2>* uv = nullptr);
void write_obj(const std::string& path, const std::vector<Point3>& vertices, const std::vector<Triangle>& faces,
               const std::vector<Point2>* uv = nullptr);

// The shortest decimal text of a finite double that reads back to the same value ("nan"/"inf"/"-inf"
// otherwise). Shared by the OBJ writer and the SVG preview.
std::string shortest_double(double value);

}  // namespace lipmap
