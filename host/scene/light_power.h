// Emitted power of a light (METHOD.md 2), in double precision: lights are
// picked by it, the loader refuses a light without any, and emission divides
// by it.
#pragma once

#include <cmath>
#include <glm/glm.hpp>

#include "scene/scene.h"

namespace spm {

// The box around the scene's shapes, their vertices and spheres (lo > hi for
// a scene without shapes).
struct ShapeBounds {
  glm::vec3 lo{INFINITY}, hi{-INFINITY};
};
ShapeBounds shape_bounds(const Scene& scene);

// The sphere around the scene's shapes, which a light from infinity lights
// (METHOD.md 14): the centre of shape_bounds and half its diagonal; radius 0
// for a scene without shapes.
struct BoundingSphere {
  glm::dvec3 center{0.0};
  double radius = 0.0;
};
BoundingSphere scene_bounding_sphere(const Scene& scene);

// What the emission is multiplied by: pi times the area of an area light's
// shape, 4 pi for a point light, Mitsuba's spot falloff integrated over the
// sphere for a spot light, the area pi R^2 of the disk across the bounding
// sphere that a directional light's streams start from, and 4 pi of them
// for an environment map.
double light_extent(const Scene& scene, const Light& light);

// Radiance (area), intensity (point, spot), irradiance (directional), or the
// mean radiance over all directions (envmap, environment_mean times scale).
glm::vec3 light_emission(const Light& light);

// An environment map's mean texel over the sphere of directions.
glm::vec3 environment_mean(const Light& light);

// Per RGB channel: the emission times the extent.
glm::dvec3 light_power(const Scene& scene, const Light& light);

}  // namespace spm
