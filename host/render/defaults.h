// Settings a scene leaves out, derived from the scene rather than fixed in
// its units (docs/experiments/defaults.md "Defaults that follow the scene"): the same scene scaled
// by any factor gets the same image.
#pragma once

#include <glm/glm.hpp>

#include <vector>

#include "device/device.h"
#include "scene/scene.h"

namespace spm {

// Photon streams per pass and associated photons per stream when the scene
// and the command line name none. Counts carry no unit. Measured here at
// equal time (10 s, 64x64, docs/experiments/defaults.md "Defaults that
// follow the scene"): fewer associated photons make cheaper
// passes, and more passes (fresh maps, a shrinking radius) beat more photons
// per stream; 4 was within noise of 1 and 2 on the fog box and far better
// than 16 or 100 on it and on cornell_fog. With the final gather, 5,000
// streams did as well at 10 s, but their larger derived radius left the
// fog box 5% dark after 4 passes, so 10,000 stay.
inline constexpr int kDefaultStreams = 10000;
inline constexpr int kDefaultAssociated = 4;

// Distinct streams' records a density estimate aims to gather: the radius
// is the distance to the kScaleNeighbours-th nearest record
// (docs/experiments/defaults.md "Defaults that follow the scene").
inline constexpr int kScaleNeighbours = 32;

// Streams the scale pilot traces untimed before its timed run, so that the
// kernels' first launches (a driver's lazy compilation) stay out of the
// time that sizes a timed render's passes.
inline constexpr uint32_t kPilotWarmStreams = 64;

// Streams of a pass that write stream beams (METHOD.md 11) when the gather
// reads them and the scene names no number: a beam gathers along its whole
// length, so a few hundred make a smooth estimate, while the gather's cost
// grows with their number (docs/experiments/equal-time.md "Stream beams").
inline constexpr int kDefaultBeamStreams = 1000;

int derived_streams(const IntegratorSettings& in);
int derived_beam_streams(const IntegratorSettings& in);
int derived_associated(const IntegratorSettings& in);

// The volume records' kernel radius against the radius when the scene names
// none, in scenes whose media are all homogeneous, with the beam radiance
// estimate (bre) and single scattering by next-event estimation (direct
// nee): the camera's volume estimate then holds multiple scattering only,
// which varies over the medium's mean free path, far more slowly than a
// caustic on a surface or the single scattering around a light, and since
// the volume records' images stop the estimate at walls, a wider kernel
// costs little bias. Light focused by glass or a mirror does not vary
// slowly: the records of its first scattering (SPM_RECORD_CAUSTIC) keep
// kCausticVolumeRadiusFactor radii. Measured at 10 and 30 s (docs/experiments/volume-kernels.md "A
// wider volume kernel by default", "A kernel for focused light"): with one
// kernel for all records, 1.5 radii gave 9-13% less error at 30 s than 1 on
// cornell_fog and the fog box and 21% on caustic_area, 3 less, the
// caustic's cone blurred; with the caustic records apart, 3 radii for the
// rest gave caustic_area 31% less error than 1.5 at 10 s (2 radii 25%),
// and cornell_fog and the fog box the same within their runs' spread. In
// smoke the light follows the density, and on smoke_cornell 1.5 gave 11%
// more error, so heterogeneous media keep the radius.
inline constexpr float kVolumeRadiusFactor = 3.0f;
inline constexpr float kCausticVolumeRadiusFactor = 1.5f;

// The share of final-gather rays aimed at the small lights in a medium
// (host/scene/gpu_scene.h, kAimedLightSize) where the scene has any:
// caustic_area at 10 s, seeds 1 to 3, had 20% less error with 1/4 and the
// gather rays' volume term 2.5 times less variance; with 1/2 the term had
// 3.7 times less, but its rays, aimed into the light's bright surroundings,
// read more records, and timed renders were no better (docs/experiments/caustics.md "Gather rays
// aimed at the glow").
inline constexpr float kGatherAim = 0.25f;

// The first pass's volume radius: the scene's, else kVolumeRadiusFactor or
// 1 times the radius (above).
float derived_volume_radius(const Scene& scene);

// The first pass's kernel radius for caustic volume records: where the
// volume radius is widened (above), kCausticVolumeRadiusFactor radii when
// that is smaller than the volume radius; else the volume radius.
float derived_caustic_volume_radius(const Scene& scene);

// Camera samples per pixel in one pass when none is given: about one camera
// sample per four photons, so that the gather and the stream propagation
// take comparable time (measured here: a camera sample costs about four
// times a photon), at least 1 and at most 64.
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

// `scene` with radius and width derived where they are 0: a pilot traces
// the pass's streams with one associated photon and no width on `device`
// (the leaders' paths, which the width does not change; one photon ends
// by absorption sooner than N_a do, so the pilot sees somewhat fewer deep
// events and errs towards a larger radius)
// (deterministic: keyed by `seed` like pass 0), and the stream width
// follows the radius (METHOD.md 8: r = w). The scene's bounding-box
// diagonal / 100 stands in when the pilot finds no event.
Scene derive_scale(const Scene& scene, Device& device, uint32_t seed, ScalePilot* pilot = nullptr);

}  // namespace spm
