/* Sampling points and directions on the scene's lights. */
#ifndef SPM_LIB_LIGHTS_H
#define SPM_LIB_LIGHTS_H

#include "sampling.h"
#include "scene.h"

/* Mitsuba 3's spot profile: 1 inside beam_width, falling linearly in angle to
 * 0 at cutoff_angle. `cos_theta` is measured from the spot's axis. */
inline float spot_falloff(const __global SpmLight* l, float cos_theta) {
  if (cos_theta <= l->cos_cutoff) return 0.0f;
  if (cos_theta >= l->cos_beam) return 1.0f;
  return (l->cutoff - acos(clamp(cos_theta, -1.0f, 1.0f))) / (l->cutoff - l->beam_width);
}

inline uint pick_light(const SpmScene* s, float u, float* prob) {
  const uint i = pick_from_cdf(s->light_cdf, s->num_lights, u);
  *prob = s->light_cdf[i] - (i > 0 ? s->light_cdf[i - 1] : 0.0f);
  return i;
}

/* Uniform point on an area light's surface (pdf 1/area) with its normal on the
 * emitting side. */
inline void sample_area_light_point(const SpmScene* s, const __global SpmLight* l, float3 u, float3* p,
                                    float3* n) {
  uint lo = l->prim_begin, hi = l->prim_begin + l->prim_count - 1;
  while (lo < hi) {
    const uint mid = (lo + hi) / 2;
    if (s->light_prims[mid].cdf > u.x) hi = mid;
    else lo = mid + 1;
  }
  const __global SpmPrim* prim = &s->prims[s->light_prims[lo].prim];
  if (prim->kind == SPM_PRIM_SPHERE) {
    *n = sample_uniform_sphere(u.y, u.z);
    *p = load3(prim->p0) + prim->p1[0] * *n;
  } else {
    const float2 b = sample_triangle(u.y, u.z);
    const float3 p0 = load3(prim->p0);
    const float3 p1 = load3(prim->p1);
    const float3 p2 = load3(prim->p2);
    *p = (1.0f - b.x - b.y) * p0 + b.x * p1 + b.y * p2;
    *n = normalize(cross(p1 - p0, p2 - p0));
  }
  if (s->shapes[prim->shape].flags & SPM_SHAPE_FLIP_NORMALS) *n = -*n;
}

/* A point on a light picked by power (METHOD.md 2): its position and, for
 * an area light, its normal on the emitting side (0 for point and spot
 * lights); *prob is the light's pick probability. */
inline const __global SpmLight* sample_light_point(const SpmScene* s, float4 u, float3* p, float3* n, float* prob) {
  const __global SpmLight* l = &s->lights[pick_light(s, u.x, prob)];
  if (l->type == SPM_LIGHT_AREA) {
    sample_area_light_point(s, l, u.yzw, p, n);
  } else {
    *p = load3(l->position);
    *n = (float3)(0.0f);
  }
  return l;
}

/* The radiance that light point p (normal n, from sample_light_point with
 * pick probability prob) sends to x, divided by the sampling pdf (per unit
 * solid angle at x, cosine at x not included), or 0; *wi and *dist give
 * the shadow ray. */
inline float3 light_incident(const __global SpmLight* l, float3 x, float3 p, float3 n, float prob, float3* wi,
                             float* dist) {
  const float3 to = p - x;
  const float d2 = dot(to, to);
  *dist = sqrt(d2);
  *wi = to / *dist;
  if (l->type == SPM_LIGHT_AREA) {
    const float cos_l = -dot(*wi, n);
    if (cos_l <= 0.0f || d2 == 0.0f) return (float3)(0.0f); /* emits on its front side only */
    return load3(l->emission) * (cos_l * l->area / (d2 * prob));
  }
  float profile = 1.0f;
  if (l->type == SPM_LIGHT_SPOT) profile = spot_falloff(l, -dot(*wi, load3(l->axis_z)));
  return load3(l->emission) * (profile / (d2 * prob));
}

/* Next-event estimation from x: a point on a light chosen by power
 * (light_incident of sample_light_point). */
inline float3 sample_light_incident(const SpmScene* s, float3 x, float4 u, float3* wi, float* dist,
                                    float3* light_p, float3* light_n) {
  float prob;
  const __global SpmLight* l = sample_light_point(s, u, light_p, light_n, &prob);
  return light_incident(l, x, *light_p, *light_n, prob, wi, dist);
}

#endif
