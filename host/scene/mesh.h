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

// Smooth vertex normals as Mitsuba 3 computes them for a mesh whose file has
// none: each triangle's unit normal weighted by its angle at the vertex
// (Thuermer & Wuethrich 1998, "Computing vertex normals from polygonal
// facets"). A vertex no triangle uses gets +z, so that every normal is unit.
std::vector<glm::vec3> angle_weighted_normals(const std::vector<glm::vec3>& positions,
                                              const std::vector<glm::uvec3>& triangles);

}  // namespace spm
