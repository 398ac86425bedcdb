/* spm_respawn: survivors re-placed around the leader (METHOD.md 3; paper 3.1
 * step 3). From: streams with SPM_ACT_SPHERE or SPM_ACT_DISK. To: photon
 * positions [slot * associated, + alive_next).
 * After a medium event each surviving associated photon is placed uniformly
 * in the sphere of radius w around the leader's new position; after emission
 * and diffuse events, uniformly in the disk of radius w in the surface's (or
 * light's) plane. */
#include "spm_types.h"
#include "lib/sampling.h"
#include "lib/stream.h"

__kernel void spm_respawn(const __global uint* queue, uint count SPM_STREAM_PARAMS, __global float4* photons,
                          uint associated, float width, uint seed, uint pass) {
  uint q, j;
  if (!photon_item(get_global_id(0), count, associated, &q, &j)) return;
  const uint s = queue[q];
  const uint act = st_state[s];
  if (!(act & (SPM_ACT_SPHERE | SPM_ACT_DISK)) || j >= st_alive_next[s]) return;
  const float4 u = rng4(STREAM_EVENT_RNG(s, seed, pass), SPM_RNG_RESPAWN, j);
  const float3 x = st_event_pos[s].xyz;
  const float3 p = (act & SPM_ACT_SPHERE) ? x + width * sample_ball(u.x, u.y, u.z)
                                          : in_tangent_disk(x, st_event_normal[s].xyz, sample_disk(u.x, u.y), width);
  photons[(size_t)s * associated + j] = (float4)(p, 0.0f);
}
