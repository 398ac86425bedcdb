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
 * ratio of the true to the sampled density per channel. */
#include "spm_types.h"
#include "lib/scene.h"
#include "lib/stream.h"

/* Steps walked before the march gives up on an unbounded ray (an infinite
 * medium with a tiny P per step): the stream then escapes. */
#define SPM_MAX_MARCH_STEPS (1u << 22)

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

__kernel void spm_march(SPM_SCENE_PARAMS, SpmStreamParams params, const __global uint* live,
                        const __global uint* counts SPM_STREAM_PARAMS) {
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
    const float3 sigma = load3(sc.media[m].sigma_t);
    const float mean = mean_comp(sigma);
    float3 weight = (float3)(1.0f);
    const float te = mean > 0.0f ? free_flight(mean, h.t, params.march_step,
                                                   rng_make(params.seed, params.pass, st_id[s], st_events[s]))
                                 : SPM_INF;
    if (te < h.t) {
      event = SPM_EV_MEDIUM;
      t = te;
      weight = sigma / mean * exp(-(sigma - mean) * te);
    } else if (surface) {
      weight = exp(-(sigma - mean) * h.t);
    }
    st_phi[s] *= (float4)(weight, 1.0f);
  }
  st_hit[s] = (float4)(t, as_float(h.prim), h.u, h.v);
  st_event[s] = event;
}
