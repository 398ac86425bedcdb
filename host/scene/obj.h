// Wavefront OBJ meshes (shape type="obj"), read with tinyobjloader.
#pragma once

#include <string>

#include "scene/mesh.h"

namespace spm {

// Parses the OBJ text of file `name` into one mesh: every object and group of
// the file merged, polygons triangulated, one vertex per distinct (position,
// normal) pair so that normals index like positions; no uvs. `vertex_normals`
// false drops the file's normals (face_normals="true"). Throws InputError(where, ...) for a corrupt
// file: a parse failure, an index out of range, non-finite numbers, normals on
// some faces only, or no triangles at all.
Mesh parse_obj(const std::string& text, const std::string& name, bool vertex_normals, const std::string& where);

}  // namespace spm
