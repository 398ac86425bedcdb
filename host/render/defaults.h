// Settings a scene leaves out, derived from the scene rather than fixed in
// its units (docs/experiments/defaults.md "Defaults that follow the scene"): the same scene scaled
// by any factor gets the same image.
#pragma once

#include <glm/glm.hpp>

#include <vector>

#include "device/device.h"
#include "render/tuning.h"
#include "render/render.h"
#include "scene/scene.h"

namespace spm {

int derived_streams(const IntegratorSettings& in);
int derived_beam_streams(const IntegratorSettings& in);
int derived_associated(const IntegratorSettings& in);

// The first pass's volume radius: the scene's, else kVolumeRadiusFactor or
// 1 times the radius (above).
float derived_volume_radius(const Scene& scene);

// The first pass's kernel radius for caustic volume records: where the
// volume radius is widened (above), kCausticVolumeRadiusFactor radii when
// that is smaller than the volume radius; else the volume radius.
float derived_caustic_volume_radius(const Scene& scene);

// Camera samples per pixel in one pass when none is given: one camera
// sample per kPhotonsPerSample photons, at least 1 and at most kMaxPassSpp.
int samples_per_pass(const Scene& scene, int width, int height);

// Median over up to `queries` evenly spaced points of the distance to their
// k-th nearest other point; 0 when there are at most k points.
float neighbour_radius(const std::vector<glm::vec3>& points, int k, int queries = 256);

// What a scale pilot measured: the leaders' event positions of one pass's
// streams, which do not depend on the stream width.
struct ScalePilot {
  std::vector<glm::vec3> volume;   // medium events
  std::vector<glm::vec3> surface;  // diffuse events
  double seconds = 0.0;
};

// The first search radius for a pilot's events: the smaller of the volume
// and surface neighbour radii where both maps have more than
// kScaleNeighbours events, else the one that has; 0 when neither has.
float pilot_radius(const ScalePilot& pilot);

// Fills every setting of `scene` that is still derived (0) with the value
// the render uses, marking it Derived: streams, associated photons, beam
// streams, the volume radius, and, from `s` (resolve_settings), the camera
// samples and passes. Radius and width come from derive_scale before.
void fill_derived(Scene& scene, const RenderSettings& s);

// `scene` with radius and width derived where they are 0: the radius from
// the scale pilot's events (pilot_radius; the scene's bounding-box diagonal
// times kFallbackRadius where it found too few), and the stream width
// follows the radius (METHOD.md 8: r = w). The pilot (PassRenderer::pilot)
// traces pass 0's streams with one associated photon and no width: the
// leaders' paths, which the width does not change; one photon ends by
// absorption sooner than N_a do, so it sees somewhat fewer deep events and
// errs towards a larger radius.
Scene derive_scale(const Scene& scene, const ScalePilot& pilot);

}  // namespace spm
