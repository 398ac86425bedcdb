// A sequential C++ reference of one photon stream's life (METHOD.md 2-4, 7):
// emit, then march / interact / deposit / absorb until the stream ends, with
// the same Philox counters as the kernels (spm_emit.cl ... spm_respawn.cl) and
// their own sampling, BSDF, phase and intersection helpers (kernels/lib/,
// compiled as C++ by cl_compat.h), so that its records equal the device's up
// to float rounding. What it checks is the kernels' control flow: the order
// of events and draws, the branches, counts and weights. Intersections are a
// brute-force loop over every primitive, which checks the BVH too.
//
// Device and host transcendental functions may differ in the last bits, so a
// discrete decision (a uniform number against a threshold, a ray against a
// triangle edge, the sign of a cosine) can go the other way when it is close.
// The reference records the smallest such margin of each stream, so that a
// comparison can set those few streams aside instead of loosening tolerances.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "scene/gpu_scene.h"
#include "spm/propagate.h"
#include "spm_types.h"

namespace spm::ref {

// How a stream ended (the last event's outcome).
enum class StreamEnd {
  Escaped,       // march found no surface and no medium event
  Absorbed,      // absorb left no associated photon (n = 0)
  MaxBounces,    // the max_bounces-th diffuse event
  BlackSurface,  // the back of a one-sided diffuse surface or mirror
  MediumCap,     // SPM_MAX_MEDIUM_EVENTS medium events
  EventCap,      // SPM_MAX_EVENTS events
  Roulette,      // Russian roulette after rr_depth vertices
  MaxDepth,      // no later vertex within max_depth
};

const char* to_string(StreamEnd end);

// The device's st_end code (SPM_END_*) for `end`.
uint32_t end_code(StreamEnd end);

struct StreamResult {
  std::vector<SpmVolumeRecord> volume;    // ordered by event
  std::vector<SpmSurfaceRecord> surface;  // ordered by (event, photon)

  // Final stream state, as the device's state buffers hold it at the end.
  uint32_t alive = 0;   // st_alive: the photons alive when the stream ended (0: absorbed)
  uint32_t events = 0;  // st_events: the next RNG event index
  float phi[3] = {0, 0, 0};
  StreamEnd end = StreamEnd::Escaped;

  // What happened, for coverage checks; each also counts as an SPM_COUNT_EV_*.
  uint32_t light = 0;  // index of the emitting light
  uint32_t medium_events = 0, diffuse_events = 0, specular_events = 0, null_events = 0;
  uint32_t escape_events = 0, black_events = 0, capped = 0, roulette = 0;
  uint32_t refills = 0;  // respawns that refilled the stream to N_a photons (roulette kept it with q < 0.95)
  uint32_t fresnel_reflections = 0, fresnel_refractions = 0;
  bool collapsed = false;  // a specular event collapsed the stream
  // Diffuse and medium events after the collapse (caustics, volumetric caustics).
  uint32_t collapsed_deposits = 0, collapsed_medium_events = 0;

  // Smallest distance of any decision of this stream to its threshold:
  // |u - threshold| for uniform numbers against a computed threshold,
  // |cos| for the side of a surface, |t_a - t_b| / (1 + t_b) for distance
  // comparisons, barycentric (or disc / r^2) distance to a primitive's
  // outline where missing or hitting it would change the outcome. Decisions
  // between bit-identical operands on host and device (light and light-prim
  // pick, absorb) cannot flip and are not counted.
  float margin = 1.0f;
  std::string margin_what;    // which decision had the smallest margin
  uint32_t margin_event = 0;  // at which event index
};

// Stream `id` of the pass described by `settings` (streams, associated, width,
// max_bounces, max_depth, rr_depth, march_step, seed, pass) in the flattened scene `scene`.
// `ulps` > 0 moves the result of every sqrt, exp, log, sin, cos, ... by that
// many ulps up or down, as another math library might round it: comparing
// such a run with the plain one measures how much float rounding can move
// each record of this stream (its condition), independently of the device.
StreamResult trace_stream(const SceneTables& scene, const StreamSettings& settings, uint32_t id, int ulps = 0);

}  // namespace spm::ref
