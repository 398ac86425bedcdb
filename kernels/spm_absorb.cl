/* spm_absorb: elimination of associated photons (METHOD.md 3; paper 3.1
 * step 3). From: the absorb list, one entry per alive photon of the streams
 * interact (medium events) and deposit (diffuse events) sent on. To: the
 * respawn queue (each stream once, by its photon 0), with alive_next = the
 * survivors.
 * Photon j survives with probability a = scale.w (mean albedo or
 * reflectance); survivors' phi is multiplied by scale.rgb = c / a per
 * channel, so the expected flux is conserved for RGB. The random numbers
 * are those of the stream's event (interact advanced the index past it). A collapsed stream
 * (n = 1) is ordinary Russian roulette. */
#include "spm_types.h"
#include "lib/stream.h"

__kernel void spm_absorb(SpmStreamParams params, const __global uint* absorb_list, __global uint* respawn_queue,
                         __global uint* counts SPM_STREAM_PARAMS) {
  const uint g = get_global_id(0);
  if (g >= counts[SPM_COUNT_ABSORB]) return;
  const uint s = absorb_list[g];
  const uint j = g - st_absorb_base[s];
  const float4 scale = st_scale[s];
  const float4 u = rng4(rng_make(params.seed, params.pass, st_id[s], st_events[s] - 1u), SPM_RNG_ABSORB, j / 4);
  const float uj = (j % 4 == 0) ? u.x : (j % 4 == 1) ? u.y : (j % 4 == 2) ? u.z : u.w;
  if (uj < scale.w) atomic_inc(&st_alive_next[s]);
  if (j == 0) {
    st_phi[s] *= (float4)(scale.xyz, 1.0f);
    push_stream(respawn_queue, counts, SPM_COUNT_RESPAWN, s);
  }
}
