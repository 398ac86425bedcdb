// Stanford PLY meshes (shape type="ply"), read by our own reader.
#pragma once

#include <string>

#include "scene/mesh.h"

namespace spm {

// Parses the PLY bytes of file `name` (ascii, binary_little_endian or
// binary_big_endian) into one mesh, as Mitsuba 3 reads it: positions from x,
// y, z; normals from nx, ny, nz when the file has them and `vertex_normals`
// is true (false drops them: face_normals="true"); uvs from u,v (or
// texture_u,texture_v, s,t, texture_s,texture_t), stored as given; polygons
// of the face element's vertex_indices (or vertex_index) list
// fan-triangulated. Other elements and properties are skipped. No normals in
// the file gives empty normals: the caller computes smooth ones.
//
// Throws InputError(where, ...) for a corrupt file, naming the header or
// ascii data line ("PLY file bunny.ply:12: vertex 3: ...") or, in binary
// data, the element and its 0-based index ("PLY file bunny.ply: face 17:
// ..."): a bad header, a count the file is too short for, truncated or
// trailing data, a face of fewer than 3 vertices or with an index out of
// range, a non-finite value, or no faces at all.
Mesh parse_ply(const std::string& bytes, const std::string& name, bool vertex_normals, const std::string& where);

}  // namespace spm
