#include "scene/light_power.h"

#include <algorithm>
#include <cmath>

namespace spm {

namespace {

constexpr double kPi = 3.14159265358979323846;

double shape_area(const Shape& s) {
  if (s.kind == Shape::Kind::Sphere) return 4.0 * kPi * double(s.radius) * double(s.radius);
  double area = 0.0;
  for (const glm::uvec3& t : s.triangles) {
    const glm::dvec3 a(s.positions[t.x]), b(s.positions[t.y]), c(s.positions[t.z]);
    area += 0.5 * glm::length(glm::cross(b - a, c - a));
  }
  return area;
}

// 2 pi int falloff(theta) sin(theta) dtheta for Mitsuba's spot profile: 1 inside
// beam_width, falling linearly in angle to 0 at cutoff (midpoint rule).
double spot_solid_angle(double cutoff, double beam) {
  const int steps = 4096;
  double sum = 0.0;
  for (int i = 0; i < steps; ++i) {
    const double theta = (i + 0.5) * cutoff / steps;
    const double f = theta <= beam ? 1.0 : (cutoff - theta) / (cutoff - beam);
    sum += f * std::sin(theta);
  }
  return 2.0 * kPi * sum * cutoff / steps;
}

}  // namespace

ShapeBounds shape_bounds(const Scene& scene) {
  ShapeBounds b;
  for (const Shape& sh : scene.shapes) {
    for (const glm::vec3& p : sh.positions) {
      b.lo = glm::min(b.lo, p);
      b.hi = glm::max(b.hi, p);
    }
    if (sh.kind == Shape::Kind::Sphere) {
      b.lo = glm::min(b.lo, sh.center - sh.radius);
      b.hi = glm::max(b.hi, sh.center + sh.radius);
    }
  }
  return b;
}

BoundingSphere scene_bounding_sphere(const Scene& scene) {
  const ShapeBounds b = shape_bounds(scene);
  if (!(b.lo.x <= b.hi.x)) return {};
  const glm::dvec3 lo(b.lo), hi(b.hi);
  return {0.5 * (lo + hi), 0.5 * glm::length(hi - lo)};
}

glm::vec3 environment_mean(const Light& light) {
  // Each row of texels weighed by the solid angle of its band of theta,
  // the rows at theta = j pi / (H - 1) as the lookup places them.
  const int w = light.map_width, h = light.map_height;
  glm::dvec3 sum(0.0);
  double weight = 0.0;
  for (int j = 0; j < h; ++j) {
    const double band = h == 1 ? 1.0
                               : std::cos(std::max(0.0, (j - 0.5) / (h - 1)) * kPi) -
                                     std::cos(std::min(1.0, (j + 0.5) / (h - 1)) * kPi);
    for (int i = 0; i < w; ++i) sum += band * glm::dvec3(light.map[size_t(j) * w + i]);
    weight += band * w;
  }
  return weight > 0.0 ? glm::vec3(sum / weight) : glm::vec3(0.0f);
}

glm::vec3 light_emission(const Light& light) {
  switch (light.type) {
    case Light::Type::Area:
      return light.radiance;
    case Light::Type::Directional:
      return light.irradiance;
    case Light::Type::Envmap:
      return light.scale * environment_mean(light);
    default:
      return light.intensity;
  }
}

double light_extent(const Scene& scene, const Light& light) {
  switch (light.type) {
    case Light::Type::Directional: {
      const double r = scene_bounding_sphere(scene).radius;
      return kPi * r * r;
    }
    case Light::Type::Envmap: {
      // Radiance from all 4 pi steradians through the disk across each
      // direction (METHOD.md 14).
      const double r = scene_bounding_sphere(scene).radius;
      return 4.0 * kPi * kPi * r * r;
    }
    case Light::Type::Point:
      return 4.0 * kPi;
    case Light::Type::Spot:
      return spot_solid_angle(double(light.cutoff_angle) * kPi / 180.0, double(light.beam_width) * kPi / 180.0);
    case Light::Type::Area:
    default:
      return kPi * shape_area(scene.shapes.at(static_cast<size_t>(light.shape)));
  }
}

glm::dvec3 light_power(const Scene& scene, const Light& light) {
  return glm::dvec3(light_emission(light)) * light_extent(scene, light);
}

}  // namespace spm
