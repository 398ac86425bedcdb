/* spm_gather: one work-item per pixel, spp camera samples each (METHOD.md 5).
 * From: camera. To: the pass's film (mean radiance of the pixel's samples).
 *
 * This version carries the frame the photon estimates plug into: jittered
 * camera rays through the pixel filter, specular chains (mirror, dielectric),
 * null boundaries switching the medium, transmittance of every medium crossed
 * (paper eq. 2), emission seen directly or through specular chains, and direct
 * lighting at the first diffuse surface by next-event estimation with shadow
 * rays that carry transmittance. */
#include "spm_types.h"
#include "lib/bsdf.h"
#include "lib/camera.h"
#include "lib/lights.h"
#include "lib/rng.h"

/* Null boundaries a shadow ray may cross before it counts as blocked; scenes
 * nest media a few levels deep at most. */
#define SPM_MAX_SHADOW_CROSSINGS 16

/* Transmittance from o towards a light at `dist` along d, through null
 * boundaries (switching the medium at each); 0 when an opaque surface blocks. */
inline float3 shadow_transmittance(const SpmScene* s, float3 o, float3 d, float dist, int medium) {
  float3 tr = (float3)(1.0f);
  float remaining = dist;
  for (int i = 0; i < SPM_MAX_SHADOW_CROSSINGS; ++i) {
    SpmHit h;
    if (!scene_trace(s, o, d, remaining, &h)) return tr * medium_transmittance(s, medium, remaining);
    const SpmSurface surf = scene_surface(s, o, d, h);
    const __global SpmShape* shape = &s->shapes[surf.shape];
    if (s->materials[shape->material].type != SPM_MAT_NULL) return (float3)(0.0f);
    tr *= medium_transmittance(s, medium, h.t);
    medium = target_medium(shape, surf.ng, d);
    o = leave_surface(&surf, d);
    remaining -= h.t;
  }
  return (float3)(0.0f);
}

/* Direct light reflected by a diffuse surface towards -d. */
inline float3 direct_diffuse(const SpmScene* s, const SpmSurface* surf, const __global SpmMaterial* m, float3 d,
                             SpmRng rng) {
  const float3 n = facing_normal(surf, d);
  float3 wi, lp, ln;
  float dist;
  const float3 li = sample_light_incident(s, surf->p, rng4(rng, SPM_RNG_LIGHT_PICK, 0), &wi, &dist, &lp, &ln);
  const float cos_x = dot(wi, n);
  if (cos_x <= 0.0f || max_comp(li) <= 0.0f) return (float3)(0.0f);
  const float3 o = leave_surface(surf, wi);
  /* Stop short of an area light's own surface; point lights have none. */
  const float reach = dot(ln, ln) > 0.0f ? dist * (1.0f - 1e-4f) : dist;
  const int medium = target_medium(&s->shapes[surf->shape], surf->ng, wi);
  const float3 tr = shadow_transmittance(s, o, wi, reach, medium);
  return load3(m->reflectance) * SPM_INV_PI * cos_x * li * tr;
}

/* One camera sample's radiance. */
inline float3 radiance(const SpmScene* s, const __global SpmCamera* cam, float3 o, float3 d, float tmin, float tmax,
                       uint max_depth, SpmRng rng) {
  float3 L = (float3)(0.0f);
  float3 beta = (float3)(1.0f);
  int medium = cam->medium;
  bool count_emission = true; /* only for paths with no diffuse vertex, as NEE covers the rest */
  uint specular = 0;
  const uint first_event = rng.event;
  for (uint vertex = 0; vertex < 4 * max_depth + 4; ++vertex) {
    rng.event = first_event + vertex;
    SpmHit h;
    const bool hit = scene_trace(s, o + tmin * d, d, tmax - tmin, &h);
    if (!hit) {
      /* Escaping inside a medium attenuates to nothing; outside there is no
       * environment light in the supported subset. */
      break;
    }
    h.t += tmin;
    beta *= medium_transmittance(s, medium, h.t - tmin);
    const SpmSurface surf = scene_surface(s, o, d, h);
    const __global SpmShape* shape = &s->shapes[surf.shape];
    const __global SpmMaterial* m = &s->materials[shape->material];
    if (count_emission && shape->light >= 0 && dot(d, surf.ng) < 0.0f) {
      L += beta * load3(s->lights[shape->light].emission);
    }
    tmin = 0.0f;
    tmax = SPM_INF;
    if (m->type == SPM_MAT_NULL) {
      medium = target_medium(shape, surf.ng, d);
      o = leave_surface(&surf, d);
      continue;
    }
    if (m->type == SPM_MAT_DIFFUSE) {
      if (reflects_from(m, &surf, d)) L += beta * direct_diffuse(s, &surf, m, d, rng);
      break;
    }
    if (++specular > max_depth) break;
    float3 next;
    const float f = specular_bounce(m, &surf, d, rng4(rng, SPM_RNG_BSDF, 0).x, true, &next);
    if (f == 0.0f) break;
    beta *= f;
    medium = target_medium(shape, surf.ng, next);
    o = leave_surface(&surf, next);
    d = next;
  }
  return L;
}

__kernel void spm_gather(SPM_SCENE_PARAMS, const __global SpmCamera* camera, __global float4* film, uint spp,
                         uint max_depth, uint seed, uint pass) {
  const uint pixel = get_global_id(0);
  if (pixel >= camera->width * camera->height) return;
  const SpmScene s = SPM_SCENE;
  const uint px = pixel % camera->width;
  const uint py = pixel / camera->width;
  float3 sum = (float3)(0.0f);
  for (uint i = 0; i < spp; ++i) {
    /* Event index: a block of 256 per sample, one per path vertex (the host
     * caps max_depth so that 4 max_depth + 4 < 256). */
    SpmRng rng = rng_make(seed, pass, pixel, i * 256u);
    const float4 u = rng4(rng, SPM_RNG_CAMERA, 0);
    const float2 off = sample_filter(camera, u.x, u.y);
    float3 o;
    float tmin, tmax;
    const float3 d = camera_ray(camera, (float)px + 0.5f + off.x, (float)py + 0.5f + off.y, &o, &tmin, &tmax);
    sum += radiance(&s, camera, o, d, tmin, tmax, max_depth, rng);
  }
  film[pixel] = (float4)(sum / (float)spp, 1.0f);
}
