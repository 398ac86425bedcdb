/* spm_emit: starts a batch of streams (METHOD.md 2).
 * From: nothing. To: the respawn queue, every stream with its N_a photons
 * alive and event SPM_EV_EMIT, so that respawn gives them offsets in the
 * disk of radius w around the origin, in the light's plane (across the
 * direction for point and spot lights). The host sets the queue's size.
 *
 * A light is picked with probability proportional to its power; the leader
 * starts uniformly on it, cosine-weighted about the normal (area), uniform
 * (point) or uniform in the cone (spot); a directional light's starts
 * uniformly on the disk across its direction that covers the scene's
 * bounding sphere, going along that direction, and an environment map's
 * likewise across a direction drawn from the map (METHOD.md 14). Every
 * associated photon carries phi = Phi_light / (p_light N_s N_a); a spot's
 * photons also carry its falloff. */
#include "spm_types.h"
#include "lib/lights.h"
#include "lib/stream.h"

__kernel void spm_emit(SPM_SCENE_PARAMS, SpmStreamParams params, __global uint* respawn_queue, uint count,
                       uint first_stream SPM_STREAM_PARAMS) {
  const uint slot = get_global_id(0);
  if (slot >= count) return;
  const SpmScene sc = SPM_SCENE;
  const uint id = first_stream + slot;
  const SpmRng rng = rng_make(params.seed, params.pass, id, 0);
  const float4 u0 = rng4(rng, SPM_RNG_EMIT, 0);
  const float4 u1 = rng4(rng, SPM_RNG_EMIT, 1);
  float prob;
  const __global SpmLight* l = &sc.lights[pick_light(&sc, u0.x, &prob)];
  float3 p, n, d, power;
  if (l->type == SPM_LIGHT_AREA) {
    sample_area_light_point(&sc, l, u0.yzw, &p, &n);
    d = to_world(sample_cosine_hemisphere(u1.x, u1.y), n);
    power = SPM_PI * l->area * load3(l->emission);
    p = offset_origin(p, n, sc.extent);
  } else if (l->type == SPM_LIGHT_DIRECTIONAL) {
    const float2 q = l->disk_radius * sample_disk(u0.y, u0.z);
    d = load3(l->axis_z);
    p = load3(l->position) + q.x * load3(l->axis_x) + q.y * load3(l->axis_y);
    n = d;
    power = l->area * load3(l->emission);
  } else if (l->type == SPM_LIGHT_ENVMAP) {
    /* A direction from the map; the disk across it that covers the
     * bounding sphere, just outside it; radiance times the disk's area
     * over the direction's density (METHOD.md 14). */
    float pdf;
    const float3 w = env_sample(&sc, l, u1.xy, &pdf);
    d = -w;
    float3 t, b;
    make_basis(d, &t, &b);
    const float2 q = l->disk_radius * sample_disk(u0.y, u0.z);
    p = load3(l->position) + 1.001f * l->disk_radius * w + q.x * t + q.y * b;
    n = d;
    power = pdf > 0.0f ? l->area * env_radiance(&sc, l, w) / pdf : (float3)(0.0f);
  } else if (l->type == SPM_LIGHT_POINT) {
    p = load3(l->position);
    d = sample_uniform_sphere(u1.x, u1.y);
    n = d;
    power = 4.0f * SPM_PI * load3(l->emission);
  } else {
    p = load3(l->position);
    const float3 cone = sample_uniform_cone(u1.x, u1.y, l->cos_cutoff);
    d = normalize(cone.x * load3(l->axis_x) + cone.y * load3(l->axis_y) + cone.z * load3(l->axis_z));
    n = d;
    /* Intensity times falloff over the cone's sampling density. */
    power = load3(l->emission) * spot_falloff(l, cone.z) * (2.0f * SPM_PI * (1.0f - l->cos_cutoff));
  }
  st_origin[slot] = (float4)(p, 0.0f);
  st_direction[slot] = (float4)(d, 0.0f);
  const float3 phi = power / (prob * (float)params.pass_streams * (float)params.associated);
  st_phi[slot] = (float4)(phi, 0.0f);
  st_flux0[slot] = max_comp(phi);
  st_event_normal[slot] = (float4)(n, 0.0f);
  st_alive_next[slot] = params.associated;
  st_medium[slot] = l->medium;
  st_bounces[slot] = 0;
  st_events[slot] = 1; /* event 0 was the emission */
  st_depth[slot] = 0;
  st_medium_events[slot] = 0;
  st_event[slot] = SPM_EV_EMIT;
  st_end[slot] = SPM_END_NONE;
  st_flags[slot] = 0;
  st_id[slot] = id;
  respawn_queue[slot] = slot;
}
