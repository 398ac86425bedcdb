// An indexed triangle mesh in object space, as the mesh readers (OBJ, PLY,
// Mitsuba's serialized format) return it and the loader places it.
#pragma once

#include <glm/glm.hpp>
#include <vector>

namespace spm {

struct Mesh {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;  // per vertex, or empty
  std::vector<glm::vec2> uvs;      // per vertex, or empty
  std::vector<glm::uvec3> triangles;
};

}  // namespace spm
