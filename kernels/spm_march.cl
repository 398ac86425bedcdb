/* spm_march: the leader to its next event (METHOD.md 3, paper 3.1 step 1).
 * From: the live queue. To: the live queue for interact, with the event
 * (SPM_EV_MEDIUM, SPM_EV_SURFACE or SPM_EV_ESCAPE), its distance and the
 * surface hit in `hit`.
 *
 * Inside a medium the ray is walked in steps of length march_step, each
 * interacting with probability P = 1 - exp(-sigma_t step), the event placed by
 * the exponential truncated to the step; march_step = 0 samples the free
 * flight directly. For a homogeneous medium both give Exp(sigma_t) exactly.
 * RGB sigma_t is sampled with the channel mean; phi is multiplied by the
 * ratio of the true to the sampled density per channel. A heterogeneous
 * medium's flights are medium.h's: marching with sigma_t at each step's
 * midpoint, or delta tracking for march_step = 0 (METHOD.md 12).
 *
 * When the gather reads stream beams (beam_capacity > 0), the flight to the
 * event inside a medium is also appended as a beam (METHOD.md 11) with the
 * flux the stream set off with: the segment ends at the sampled event, so
 * a point at distance t on it is reached with probability exp(-mean t),
 * and the gather weighs the flux there by exp(-(sigma_t - mean) t). Only
 * the pass's first beam_streams streams write beams, their flux scaled by
 * N_s / beam_streams: a beam gathers light along its whole length, so far
 * fewer of them than of the streams the surfaces need make a smooth
 * estimate, and the gather's cost grows with their number. */
#include "spm_types.h"
#include "lib/medium.h"
#include "lib/scene.h"
#include "lib/stream.h"

inline float free_flight(float sigma, float tmax, float step, SpmRng rng) {
  if (step <= 0.0f) return -log(1.0f - rng4(rng, SPM_RNG_DISTANCE, 0).x) / sigma;
  const float p = -expm1(-sigma * step);
  /* Each Philox draw serves two steps: (interact?, where) twice. */
  for (uint k = 0; k < SPM_MAX_MARCH_STEPS && (float)k * step < tmax; k += 2) {
    const float4 u = rng4(rng, SPM_RNG_DISTANCE, k / 2);
    if (u.x < p) return (float)k * step - log1p(-u.y * p) / sigma;
    if (u.z < p) return (float)(k + 1) * step - log1p(-u.w * p) / sigma;
  }
  return SPM_INF;
}

/* Appends stream s's flight of length t from o along d in medium m as a
 * beam, unless no scattering on it could count within max_depth. */
inline void append_beam(const SpmStreamParams* p, __global SpmBeam* beams, __global uint* counts, uint s, float3 o,
                        float3 d, float t, int m, float3 flux, uint id, uint depth) {
  if (!depth_counts(depth + 1u, p->max_depth) || !isfinite(t) || max_comp(flux) <= 0.0f) return;
  const uint slot = atomic_inc(&counts[SPM_COUNT_BEAMS]);
  if (slot >= p->beam_capacity) {
    atomic_or(&counts[SPM_COUNT_ERRORS], SPM_ERROR_BEAM_OVERFLOW);
    return;
  }
  __global SpmBeam* b = &beams[slot];
  vstore3(o, 0, b->origin);
  vstore3(d, 0, b->direction);
  vstore3(flux, 0, b->flux);
  b->stream = id;
  b->depth = depth + 1u;
  b->medium = m;
  b->length = t;
}

__kernel void spm_march(SPM_SCENE_PARAMS, SpmStreamParams params, const __global uint* live, __global uint* counts,
                        __global SpmBeam* beams SPM_STREAM_PARAMS) {
  const uint q = get_global_id(0);
  if (q >= counts[SPM_COUNT_LIVE]) return;
  const uint s = live[q];
  const SpmScene sc = SPM_SCENE;
  const float3 o = st_origin[s].xyz;
  const float3 d = st_direction[s].xyz;
  SpmHit h;
  const bool surface = scene_intersect(&sc, o, d, SPM_INF, &h);
  uint event = surface ? SPM_EV_SURFACE : SPM_EV_ESCAPE;
  float t = h.t;
  const int m = st_medium[s];
  if (m >= 0) {
    const SpmRng rng = rng_make(params.seed, params.pass, st_id[s], st_events[s]);
    float3 weight = (float3)(1.0f);
    if (sc.md.media[m].sigma_t_grid >= 0) {
      const float te = heterogeneous_flight(&sc.md, m, o, d, h.t, params.march_step, rng, &weight);
      if (te < h.t) {
        event = SPM_EV_MEDIUM;
        t = te;
      }
    } else {
      const float3 sigma = load3(sc.md.media[m].sigma_t);
      const float mean = mean_comp(sigma);
      const float te = mean > 0.0f ? free_flight(mean, h.t, params.march_step, rng) : SPM_INF;
      if (te < h.t) {
        event = SPM_EV_MEDIUM;
        t = te;
        weight = sigma / mean * exp(-(sigma - mean) * te);
      } else if (surface) {
        weight = exp(-(sigma - mean) * h.t);
      }
    }
    if (params.beam_capacity > 0 && st_id[s] < params.beam_streams && max_comp(load3(sc.md.media[m].albedo)) > 0.0f) {
      const float share = (float)params.pass_streams / (float)params.beam_streams;
      append_beam(&params, beams, counts, s, o, d, t, m, share * (float)st_alive[s] * st_phi[s].xyz, st_id[s],
                  st_depth[s]);
    }
    st_phi[s] *= (float4)(weight, 1.0f);
  }
  st_hit[s] = (float4)(t, as_float(h.prim), h.u, h.v);
  st_event[s] = event;
}
