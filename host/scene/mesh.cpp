#include "scene/mesh.h"

#include <cmath>

namespace spm {

std::vector<glm::vec3> angle_weighted_normals(const std::vector<glm::vec3>& positions,
                                              const std::vector<glm::uvec3>& triangles) {
  // In double: a mesh of tiny or huge extent must not underflow or overflow.
  std::vector<glm::dvec3> sum(positions.size(), glm::dvec3(0.0));
  for (const glm::uvec3& t : triangles) {
    const glm::dvec3 p[3] = {positions[t.x], positions[t.y], positions[t.z]};
    const glm::dvec3 n = glm::cross(p[1] - p[0], p[2] - p[0]);
    const double len = glm::length(n);
    if (!(len > 0.0)) continue;
    for (int k = 0; k < 3; ++k) {
      const glm::dvec3 a = glm::normalize(p[(k + 1) % 3] - p[k]), b = glm::normalize(p[(k + 2) % 3] - p[k]);
      // atan2 of the sine and cosine: exact for angles near 0 and pi, where acos is not.
      const double angle = std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
      sum[t[k]] += angle * (n / len);
    }
  }
  std::vector<glm::vec3> normals(positions.size());
  for (size_t i = 0; i < sum.size(); ++i) {
    const double len = glm::length(sum[i]);
    normals[i] = len > 0.0 ? glm::vec3(sum[i] / len) : glm::vec3(0.0f, 0.0f, 1.0f);
  }
  return normals;
}

}  // namespace spm
