/* spm_intersect: closest hits of a batch of rays, for tests and diagnostics.
 * From: rays (origin xyz + tmax, direction xyz). To: hits (t, prim, u, v). */
#include "spm_types.h"
#include "lib/scene.h"

__kernel void spm_intersect(SPM_SCENE_PARAMS, const __global float4* origins, const __global float4* directions,
                        __global float4* hits, uint count) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  const SpmScene s = SPM_SCENE;
  SpmHit h;
  const bool hit = scene_intersect(&s, origins[i].xyz, directions[i].xyz, origins[i].w, &h);
  hits[i] = (float4)(hit ? h.t : -1.0f, as_float(h.prim), h.u, h.v);
}
