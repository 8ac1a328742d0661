// Reading and writing meshes. OBJ and OFF are read by a strict reader of our own in double precision; PLY
// and STL by OpenMesh's readers. Reading yields a RawMesh untouched by any repair, so that validate sees
// exactly what the file says.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "engine/disk_mesh.h"
#include "engine/geometry.h"

namespace lipmap {

// Throws InputError mesh_file_unreadable (missing, a directory, unknown extension, or malformed), with a
// one-line message naming the file and, for OBJ and OFF, the line.
// OBJ and OFF: every coordinate is the double nearest to its decimal text (std::from_chars), so a file
// written with 17 significant digits reads back bit for bit. OBJ: "v x y z [w | r g b]", "f" with corners
// v, v/vt, v//vn, v/vt/vn (negative indices count back from the last vertex read), comments, CRLF; vt, vn,
// vp, g, o, s, mtllib and usemtl lines are skipped, any other statement is an error, as is a 'v' line that
// is not finite numbers or an 'f' line with fewer than 3 corners or a repeated vertex. OFF: the header
// (OFF, or COFF/NOFF/STOFF... whose extra per-vertex values are checked and dropped), counts, comments,
// CRLF; faces keep any corner count and any index, for validate to judge; a file shorter than its counts
// announce, or with text after the last face, is an error.
// PLY and STL: OpenMesh 9.0's readers, which parse coordinates as float, so positions read from them are
// the single-precision values of the text.
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
