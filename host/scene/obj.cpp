#include "scene/obj.h"

#include <tiny_obj_loader.h>

#include <cmath>
#include <cstdint>
#include <sstream>
#include <unordered_map>

#include "util/errors.h"

namespace spm {

namespace {

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

std::string first_line(const std::string& s) {
  std::string line = s.substr(0, s.find('\n'));
  return line.empty() ? "unknown error" : line;
}

}  // namespace

ObjMesh parse_obj(const std::string& text, const std::string& name, bool vertex_normals, const std::string& where) {
  auto fail = [&](const std::string& problem) -> void {
    throw InputError(where, "OBJ file '" + name + "': " + problem);
  };

  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> materials;
  std::string warn, err;
  std::istringstream in(text);
  // No material reader: the renderer takes materials from the scene file, so
  // mtllib lines are not followed.
  if (!tinyobj::LoadObj(&attrib, &shapes, &materials, &warn, &err, &in, nullptr, true, false)) fail(first_line(err));
  // tinyobjloader skips, with only a warning, polygons it cannot triangulate
  // and faces with fewer than 3 vertices: a corrupt file here.
  if (warn.find("invalid vertex index") != std::string::npos || warn.find("Degenerated face") != std::string::npos)
    fail(first_line(warn));

  const size_t num_positions = attrib.vertices.size() / 3;
  const size_t num_normals = attrib.normals.size() / 3;
  size_t corners = 0, corners_with_normal = 0;
  for (const tinyobj::shape_t& shape : shapes) {
    for (const tinyobj::index_t& idx : shape.mesh.indices) {
      ++corners;
      if (idx.normal_index >= 0) ++corners_with_normal;
    }
  }
  if (corners == 0) fail("no triangles");
  if (corners_with_normal != 0 && corners_with_normal != corners) fail("vertex normals on some faces only");
  const bool use_normals = vertex_normals && corners_with_normal == corners;

  ObjMesh mesh;
  std::unordered_map<uint64_t, uint32_t> vertex_of;  // (position, normal) index pair -> mesh vertex
  auto vertex = [&](const tinyobj::index_t& idx) -> uint32_t {
    if (idx.vertex_index < 0 || static_cast<size_t>(idx.vertex_index) >= num_positions)
      fail("a face refers to vertex " + std::to_string(idx.vertex_index + 1) + " but the file has " +
           std::to_string(num_positions));
    int n = use_normals ? idx.normal_index : -1;
    if (use_normals && static_cast<size_t>(n) >= num_normals)
      fail("a face refers to normal " + std::to_string(n + 1) + " but the file has " + std::to_string(num_normals));
    uint64_t key = (static_cast<uint64_t>(idx.vertex_index) << 32) | static_cast<uint32_t>(n);
    auto [it, inserted] = vertex_of.emplace(key, static_cast<uint32_t>(mesh.positions.size()));
    if (inserted) {
      const float* p = &attrib.vertices[3 * static_cast<size_t>(idx.vertex_index)];
      mesh.positions.emplace_back(p[0], p[1], p[2]);
      if (!finite(mesh.positions.back())) fail("non-finite vertex position");
      if (use_normals) {
        const float* q = &attrib.normals[3 * static_cast<size_t>(n)];
        mesh.normals.emplace_back(q[0], q[1], q[2]);
        if (!finite(mesh.normals.back())) fail("non-finite vertex normal");
      }
    }
    return it->second;
  };

  for (const tinyobj::shape_t& shape : shapes) {
    size_t offset = 0;
    for (unsigned char count : shape.mesh.num_face_vertices) {
      if (count != 3) fail("a face could not be triangulated");
      const tinyobj::index_t* f = &shape.mesh.indices[offset];
      mesh.triangles.emplace_back(vertex(f[0]), vertex(f[1]), vertex(f[2]));
      offset += count;
    }
  }
  return mesh;
}

}  // namespace spm
