#include "scene/media_regions.h"

#include <cmath>
#include <limits>
#include <string>

#include "scene/light_power.h"
#include "util/errors.h"

namespace spm {

namespace {

using glm::dvec3;

// First hit of o + t d (t > 0) on shape `s` and the side it lands on: +1 the
// side the normal points to (exterior), -1 the other; 0 when none.
struct ShapeHit {
  double t = std::numeric_limits<double>::infinity();
  int side = 0;
};

void hit_triangle(dvec3 o, dvec3 d, dvec3 a, dvec3 b, dvec3 c, bool flip, ShapeHit& best) {
  const dvec3 e1 = b - a, e2 = c - a, pv = glm::cross(d, e2);
  const double det = glm::dot(e1, pv);
  if (std::abs(det) < 1e-300) return;
  const dvec3 tv = o - a;
  const double u = glm::dot(tv, pv) / det;
  if (u < 0.0 || u > 1.0) return;
  const dvec3 qv = glm::cross(tv, e1);
  const double v = glm::dot(d, qv) / det;
  if (v < 0.0 || u + v > 1.0) return;
  const double t = glm::dot(e2, qv) / det;
  if (!(t > 0.0) || t >= best.t) return;
  const double facing = glm::dot(glm::cross(e1, e2), d) * (flip ? -1.0 : 1.0);
  best = {t, facing < 0.0 ? 1 : -1};
}

void hit_sphere(dvec3 o, dvec3 d, const Shape& s, ShapeHit& best) {
  const dvec3 oc = o - dvec3(s.center);
  const double b = glm::dot(oc, d), c = glm::dot(oc, oc) - double(s.radius) * s.radius;
  const double disc = b * b - c;
  if (disc < 0.0) return;
  const double root = std::sqrt(disc);
  for (const double t : {-b - root, -b + root}) {
    if (t > 0.0 && t < best.t) {
      const double outward = glm::dot(o + t * d - dvec3(s.center), d) * (s.flip_normals ? -1.0 : 1.0);
      best = {t, outward < 0.0 ? 1 : -1};
      return;
    }
  }
}

// Directions of the 3 axes, 6 face diagonals' halves and 4 space diagonals,
// each tilted a little so that no ray runs along a box's edge or face.
std::vector<dvec3> probe_directions() {
  std::vector<dvec3> out;
  for (int x = -1; x <= 1; ++x) {
    for (int y = -1; y <= 1; ++y) {
      for (int z = -1; z <= 1; ++z) {
        if (x == 0 && y == 0 && z == 0) continue;
        out.push_back(glm::normalize(dvec3(x + 0.0123, y + 0.0371, z - 0.0219)));
      }
    }
  }
  return out;
}

// The medium on the near side of the first medium-transition shape that
// o + t d meets, or `none` when it meets none.
int first_transition_medium(const Scene& scene, dvec3 o, dvec3 d, int none) {
  ShapeHit best;
  int medium = none;
  for (const Shape& s : scene.shapes) {
    if (s.interior < 0 && s.exterior < 0) continue;
    const double before = best.t;
    if (s.kind == Shape::Kind::Sphere) {
      hit_sphere(o, d, s, best);
    } else {
      for (const glm::uvec3& tri : s.triangles) {
        hit_triangle(o, d, dvec3(s.positions[tri.x]), dvec3(s.positions[tri.y]), dvec3(s.positions[tri.z]),
                     s.flip_normals, best);
      }
    }
    if (best.t < before) medium = best.side > 0 ? s.exterior : s.interior;
  }
  return medium;
}

// The medium around the scene's shapes, where a directional light's streams
// start (`start`, outside the bounding sphere, going along d): the one on the
// near side of the first medium boundary they meet. When they meet none, a
// fog nested in the sensor with no medium on any shape fills all space
// (METHOD.md 9), and any other scene has vacuum there.
int medium_at_infinity(const Scene& scene, dvec3 start, dvec3 d) {
  bool bounded = false;
  for (const Shape& s : scene.shapes) bounded = bounded || s.interior >= 0 || s.exterior >= 0;
  return first_transition_medium(scene, start, d, bounded ? -1 : scene.camera.medium);
}

}  // namespace

int region_medium(const Scene& scene, glm::vec3 p) {
  int found = kUndecided;
  for (const dvec3& d : probe_directions()) {
    const int medium_of_best = first_transition_medium(scene, dvec3(p), d, scene.camera.medium);
    if (found == kUndecided) {
      found = medium_of_best;
    } else if (found != medium_of_best) {
      return kUndecided;
    }
  }
  return found;
}

void resolve_light_media(Scene& scene) {
  for (Light& light : scene.lights) {
    if (light.type == Light::Type::Directional || light.type == Light::Type::Envmap) {
      // Its streams start on a disk outside the bounding sphere
      // (METHOD.md 14), in the medium around the scene's shapes.
      const BoundingSphere bounds = scene_bounding_sphere(scene);
      const glm::dvec3 d = light.type == Light::Type::Directional ? glm::dvec3(light.direction) : glm::dvec3(0, -1, 0);
      light.medium = medium_at_infinity(scene, bounds.center - d * (2.0 * bounds.radius + 1.0), d);
      if (light.medium != -1) {
        throw InputError(light.where,
                         std::string(light.type == Light::Type::Directional ? "a directional light" : "an environment") +
                             " shines from infinity, and a medium fills all space around the scene: no light of it "
                             "arrives (Mitsuba renders it black); give the medium a boundary shape");
      }
      continue;
    }
    if (light.medium_given) continue;
    glm::vec3 p = light.position;
    if (light.type == Light::Type::Area) {
      // Just in front of the first triangle's centre (or above the sphere),
      // on the side an area light emits to.
      const Shape& s = scene.shapes[size_t(light.shape)];
      glm::vec3 n;
      if (s.kind == Shape::Kind::Sphere) {
        n = glm::vec3(0.0f, 1.0f, 0.0f) * (s.flip_normals ? -1.0f : 1.0f);
        p = s.center + s.radius * glm::vec3(0.0f, 1.0f, 0.0f);
      } else {
        const glm::uvec3 t = s.triangles.front();
        const glm::vec3 a = s.positions[t.x], b = s.positions[t.y], c = s.positions[t.z];
        p = (a + b + c) / 3.0f;
        n = glm::normalize(glm::cross(b - a, c - a)) * (s.flip_normals ? -1.0f : 1.0f);
      }
      const float scale = 1.0f + glm::length(p);
      p += 1e-4f * scale * n;
    }
    const int m = region_medium(scene, p);
    if (m == kUndecided) {
      throw InputError(light.where,
                       "cannot tell which medium this emitter sits in: rays from it reach different media (an open "
                       "or inconsistent medium boundary); name its medium, or close the boundary (METHOD.md 9)");
    }
    light.medium = m;
  }
}

}  // namespace spm
