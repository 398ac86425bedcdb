/* spm_intersect: closest hits of a batch of rays, for tests and diagnostics.
 * From: rays (origin xyz + tmax, direction xyz). To: hits (t, prim, u, v).
 * spm_walk: the walk of each ray (lib/walk.h), for tests. From: rays
 * (origin xyz + its medium, direction xyz + its reach). To: up to
 * SPM_WALK_TEST_SEGMENTS segments per ray, (t0, t1, medium, the material
 * type it ends on or -1) and (event, lane), and per ray their number, the
 * top bit set where the walk reached its cap. A `ray` walk (a shadow ray)
 * or a path (a camera ray, turned at mirrors and glass by the uniform `u`:
 * below the Fresnel reflectance reflects). */
#include "spm_types.h"
#include "lib/scene.h"
#include "lib/walk.h"

__kernel void spm_intersect(SPM_SCENE_PARAMS, const __global float4* origins, const __global float4* directions,
                        __global float4* hits, uint count) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  const SpmScene s = SPM_SCENE;
  SpmHit h;
  const bool hit = scene_intersect(&s, origins[i].xyz, directions[i].xyz, origins[i].w, &h);
  hits[i] = (float4)(hit ? h.t : -1.0f, as_float(h.prim), h.u, h.v);
}

#define SPM_WALK_TEST_SEGMENTS 512u

__kernel void spm_walk(SPM_SCENE_PARAMS, const __global float4* origins, const __global float4* directions,
                       __global float4* segments, __global uint2* draws, __global uint* counts, uint count, uint ray,
                       float u) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  const SpmScene s = SPM_SCENE;
  SpmWalk w;
  const SpmRng rng = rng_make(0u, 0u, i, 1000u);
  if (ray) {
    walk_ray(&w, origins[i].xyz, directions[i].xyz, directions[i].w, (int)origins[i].w, rng, SPM_TR_NEE_SHADOW);
  } else {
    walk_path(&w, origins[i].xyz, directions[i].xyz, 0.0f, directions[i].w, (int)origins[i].w, rng, SPM_TR_CAMERA);
  }
  uint n = 0;
  while (n < SPM_WALK_TEST_SEGMENTS && walk_next(&s, &w)) {
    const uint k = i * SPM_WALK_TEST_SEGMENTS + n++;
    segments[k] = (float4)(w.t0, w.t1, (float)w.medium, w.hit ? (float)w.material->type : -1.0f);
    draws[k] = (uint2)(w.rng.event, walk_lane(&w));
    if (w.hit && is_specular(w.material->type)) {
      float3 next;
      if (max_comp(specular_bounce(w.material, &w.surf, w.d, u, true, &next)) > 0.0f) walk_turn(&w, next);
    }
  }
  counts[i] = n | (w.capped ? 0x80000000u : 0u);
}
