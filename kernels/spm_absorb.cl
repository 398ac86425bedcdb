/* spm_absorb: elimination of associated photons (METHOD.md 3; paper 3.1
 * step 3). From: streams with SPM_ACT_ABSORB. To: alive_next = survivors.
 * One work-item per alive photon: it survives with probability a = scale.w
 * (mean albedo or reflectance); survivors' phi is multiplied by scale.rgb =
 * c / a per channel, so the expected flux is conserved for RGB. A collapsed
 * stream (n = 1) is ordinary Russian roulette. */
#include "spm_types.h"
#include "lib/stream.h"

__kernel void spm_absorb(const __global uint* queue, uint count SPM_STREAM_PARAMS,
                         uint associated, uint seed, uint pass) {
  uint q, j;
  if (!photon_item(get_global_id(0), count, associated, &q, &j)) return;
  const uint s = queue[q];
  if (!(st_state[s] & SPM_ACT_ABSORB) || j >= st_alive[s]) return;
  const float4 scale = st_scale[s];
  const float4 u = rng4(STREAM_EVENT_RNG(s, seed, pass), SPM_RNG_ABSORB, j / 4);
  const float uj = (j % 4 == 0) ? u.x : (j % 4 == 1) ? u.y : (j % 4 == 2) ? u.z : u.w;
  if (uj < scale.w) atomic_inc(&st_alive_next[s]);
  if (j == 0) st_phi[s] *= (float4)(scale.xyz, 1.0f);
}
