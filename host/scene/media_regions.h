// Which medium a light sits in when it names none (METHOD.md 9): the medium
// of the region it is in, as Mitsuba 3 carries media along a camera path.
#pragma once

#include <glm/glm.hpp>

#include "scene/scene.h"

namespace spm {

// The medium of the region around `p`, or kUndecided: rays from p in a fixed
// set of directions each meet a first medium-transition shape (one naming an
// interior or exterior medium) and take the medium of the side they meet it
// on, or meet none and take the sensor's medium; the region is decided when
// they all agree.
inline constexpr int kUndecided = -2;
int region_medium(const Scene& scene, glm::vec3 p);

// Gives every light with Light::medium_given false the medium of its region
// (an area light: of the point just in front of its shape). Throws
// InputError naming the light's file:line where the region is undecided.
void resolve_light_media(Scene& scene);

}  // namespace spm
