// <transform name=".."> elements of the scene format.
#pragma once

#include <glm/glm.hpp>
#include <pugixml.hpp>

#include "scene/xml_context.h"

namespace spm::xml {

// The matrix of a <transform>: its steps (translate, scale, rotate, matrix,
// lookat) in document order, each left-multiplied (M = step * M) as in Mitsuba.
glm::mat4 parse_transform(const Context& ctx, const pugi::xml_node& node);

// False when the linear part of `m` is singular (or nearly, relative to the
// lengths of its columns), so normals or the inverse cannot be computed.
bool is_invertible(const glm::mat4& m);

}  // namespace spm::xml
