// Emitted power of a light (METHOD.md 2), in double precision: lights are
// picked by it, the loader refuses a light without any, and emission divides
// by it.
#pragma once

#include <glm/glm.hpp>

#include "scene/scene.h"

namespace spm {

// What the emission is multiplied by: pi times the area of an area light's
// shape, 4 pi for a point light, Mitsuba's spot falloff integrated over the
// sphere for a spot light.
double light_extent(const Scene& scene, const Light& light);

// Per RGB channel: radiance (area) or intensity (point, spot) times the extent.
glm::dvec3 light_power(const Scene& scene, const Light& light);

}  // namespace spm
