// Wavefront OBJ meshes (shape type="obj"), read with tinyobjloader.
#pragma once

#include <glm/glm.hpp>
#include <string>
#include <vector>

namespace spm {

// One indexed triangle mesh in object space: every object and group of the
// file merged, polygons triangulated, one vertex per distinct (position,
// normal) pair so that normals index like positions.
struct ObjMesh {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;  // per vertex, or empty
  std::vector<glm::uvec3> triangles;
};

// Parses the OBJ text of file `name`. `vertex_normals` false drops the file's
// normals (face_normals="true"). Throws InputError(where, ...) for a corrupt
// file: a parse failure, an index out of range, non-finite numbers, normals on
// some faces only, or no triangles at all.
ObjMesh parse_obj(const std::string& text, const std::string& name, bool vertex_normals, const std::string& where);

}  // namespace spm
