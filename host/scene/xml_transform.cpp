#include "scene/xml_transform.h"

#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <string>

namespace spm::xml {

namespace {

glm::mat4 matrix_step(const Context& ctx, const pugi::xml_node& node) {
  ctx.check_attributes(node, {"value"});
  std::vector<float> v = ctx.parse_floats(node, ctx.attr(node, "value"), "value of <matrix>");
  glm::mat4 m(1.0f);
  // The file is row-major; glm indexes m[column][row].
  if (v.size() == 16) {
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m[c][r] = v[r * 4 + c];
  } else if (v.size() == 9) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m[c][r] = v[r * 3 + c];
  } else {
    ctx.fail(node, "<matrix> needs 16 numbers (row-major 4x4) or 9 (3x3), got " + std::to_string(v.size()));
  }
  return m;
}

// Mitsuba's look_at: camera space +z looks at the target, +x is "left".
glm::mat4 lookat_step(const Context& ctx, const pugi::xml_node& node) {
  ctx.check_attributes(node, {"origin", "target", "up"});
  glm::vec3 origin = ctx.parse_triple(node, ctx.attr(node, "origin"), "'origin' of <lookat>");
  glm::vec3 target = ctx.parse_triple(node, ctx.attr(node, "target"), "'target' of <lookat>");
  glm::vec3 up = ctx.parse_triple(node, ctx.attr(node, "up"), "'up' of <lookat>");
  glm::vec3 to_target = target - origin;
  if (glm::length(to_target) == 0.0f) ctx.fail(node, "degenerate <lookat>: origin and target coincide");
  glm::vec3 dir = glm::normalize(to_target);
  glm::vec3 left = glm::cross(up, dir);
  if (!(glm::length(left) > 1e-6f * glm::length(up)))
    ctx.fail(node, "degenerate <lookat>: 'up' is zero or parallel to the view direction");
  left = glm::normalize(left);
  glm::vec3 new_up = glm::cross(dir, left);
  return glm::mat4(glm::vec4(left, 0.0f), glm::vec4(new_up, 0.0f), glm::vec4(dir, 0.0f), glm::vec4(origin, 1.0f));
}

glm::mat4 step(const Context& ctx, const pugi::xml_node& node) {
  std::string tag = node.name();
  // A step holds its values in attributes; anything inside would be skipped.
  if (pugi::xml_node child = node.first_child())
    ctx.fail(child.type() == pugi::node_element ? child : node, "<" + tag + "> takes no content");
  if (tag == "translate") {
    ctx.check_attributes(node, {"value", "x", "y", "z"});
    return glm::translate(glm::mat4(1.0f), ctx.parse_xyz(node, 0.0f, "<" + tag + ">"));
  }
  if (tag == "scale") {
    ctx.check_attributes(node, {"value", "x", "y", "z"});
    return glm::scale(glm::mat4(1.0f), ctx.parse_xyz(node, 1.0f, "<" + tag + ">"));
  }
  if (tag == "rotate") {
    ctx.check_attributes(node, {"value", "x", "y", "z", "angle"});
    glm::vec3 axis = ctx.parse_xyz(node, 0.0f, "<" + tag + ">");
    float angle = ctx.parse_float(node, ctx.attr(node, "angle"), "'angle' of <rotate>");
    if (glm::length(axis) == 0.0f) ctx.fail(node, "<rotate> needs a non-zero axis");
    return glm::rotate(glm::mat4(1.0f), glm::radians(angle), glm::normalize(axis));
  }
  if (tag == "matrix") return matrix_step(ctx, node);
  if (tag == "lookat") return lookat_step(ctx, node);
  ctx.fail(node, "unknown transform step <" + tag + "> (translate, scale, rotate, matrix, lookat)");
}

}  // namespace

glm::mat4 parse_transform(const Context& ctx, const pugi::xml_node& node) {
  ctx.check_attributes(node, {"name"});
  glm::mat4 m(1.0f);
  for (const pugi::xml_node& child : ctx.elements(node)) {
    m = step(ctx, child) * m;
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r)
        if (!std::isfinite(m[c][r])) ctx.fail(child, "the transform is no longer finite after this step");
  }
  return m;
}

bool is_invertible(const glm::mat4& m) {
  // In double: the product of three float lengths overflows a float (and
  // their determinant too) for scales beyond about 1e12.
  glm::dmat3 l(glm::mat3{m});
  double scale = glm::length(l[0]) * glm::length(l[1]) * glm::length(l[2]);
  // |det| / product of column lengths is the volume of the unit-column
  // parallelepiped: 1 for orthogonal axes, 0 for a flat one, whatever the scale.
  return scale > 0.0 && std::abs(glm::determinant(l)) > 1e-6 * scale;
}

}  // namespace spm::xml
