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

/* An area light's primitive picked by area (u: a uniform), with its
 * probability in *prob (light_prims' cdf runs over the light's area). */
inline const __global SpmPrim* pick_light_prim(const SpmScene* s, const __global SpmLight* l, float u, float* prob) {
  const uint first = l->prim_begin;
  uint lo = first, hi = first + l->prim_count - 1;
  while (lo < hi) {
    const uint mid = (lo + hi) / 2;
    if (s->light_prims[mid].cdf > u) hi = mid;
    else lo = mid + 1;
  }
  *prob = s->light_prims[lo].cdf - (lo > first ? s->light_prims[lo - 1].cdf : 0.0f);
  return &s->prims[s->light_prims[lo].prim];
}

/* Uniform point on primitive `prim` of an area light (pdf 1/its area) with
 * its normal on the emitting side. */
inline void sample_prim_point(const SpmScene* s, const __global SpmPrim* prim, float u1, float u2, float3* p,
                              float3* n) {
  if (prim->kind == SPM_PRIM_SPHERE) {
    *n = sample_uniform_sphere(u1, u2);
    *p = load3(prim->p0) + prim->p1[0] * *n;
  } else {
    const float2 b = sample_triangle(u1, u2);
    const float3 p0 = load3(prim->p0);
    const float3 p1 = load3(prim->p1);
    const float3 p2 = load3(prim->p2);
    *p = (1.0f - b.x - b.y) * p0 + b.x * p1 + b.y * p2;
    *n = normalize(cross(p1 - p0, p2 - p0));
  }
  if (s->shapes[prim->shape].flags & SPM_SHAPE_FLIP_NORMALS) *n = -*n;
}

/* Whether sample_light_from samples primitive `prim` of an area light by
 * the cone it subtends: a sphere that emits outwards. */
inline bool cone_sampled(const SpmScene* s, const __global SpmPrim* prim) {
  return prim->kind == SPM_PRIM_SPHERE && !(s->shapes[prim->shape].flags & SPM_SHAPE_FLIP_NORMALS);
}

/* Uniform point on an area light's surface (pdf 1/area) with its normal on the
 * emitting side. */
inline void sample_area_light_point(const SpmScene* s, const __global SpmLight* l, float3 u, float3* p,
                                    float3* n) {
  float prob;
  sample_prim_point(s, pick_light_prim(s, l, u.x, &prob), u.y, u.z, p, n);
}

/* The radiance that light point p (normal n on the emitting side, 0 for
 * point and spot lights) of light l, picked with probability prob and
 * sampled uniformly by area, sends to x, divided by the sampling pdf (per unit
 * solid angle at x, cosine at x not included), or 0; *wi and *dist give
 * the shadow ray. A directional light has no point: its irradiance over
 * prob, from its direction. */
inline float3 light_incident(const __global SpmLight* l, float3 x, float3 p, float3 n, float prob, float3* wi,
                             float* dist) {
  if (l->type == SPM_LIGHT_DIRECTIONAL) {
    /* From infinity along -axis_z: the shadow ray ends at the disk the
     * streams start from, outside the scene (METHOD.md 14). */
    *wi = -load3(l->axis_z);
    *dist = dot(x - load3(l->position), load3(l->axis_z));
    return *dist > 0.0f ? load3(l->emission) / prob : (float3)(0.0f);
  }
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

/* Next-event estimation from x towards light l, picked with probability
 * prob: the radiance it sends to x divided by the sampling pdf (per unit
 * solid angle at x, the cosine at x not included), or 0, with the light
 * point *p, its normal *n (0 for point and spot lights) and the shadow ray
 * (*wi, *dist). An area light's primitive is picked by area (u.x). A
 * sphere that emits outwards, seen from outside, is sampled uniformly
 * within the cone it subtends at x (u.yz), as pbrt-v4's and Mitsuba 3's
 * spheres are: area sampling would spend half its points on the far side,
 * which x cannot see, and weigh the near cap's points by 1 / distance^2,
 * most unevenly for points near the light, where single scattering in fog
 * is brightest. Other primitives get a uniform point of their area. */
inline float3 sample_light_from(const SpmScene* s, const __global SpmLight* l, float prob, float3 x, float3 u,
                                float3* wi, float* dist, float3* p, float3* n) {
  if (l->type == SPM_LIGHT_AREA) {
    float prim_prob;
    const __global SpmPrim* prim = pick_light_prim(s, l, u.x, &prim_prob);
    const float3 c = load3(prim->p0);
    const float R = prim->p1[0];
    const float3 to = c - x;
    const float dc2 = dot(to, to);
    if (cone_sampled(s, prim) && dc2 > 1.0001f * R * R) {
      /* 1 - cos(theta_max) from sin^2, so that a small cone keeps its
       * precision; the direction's 1 - cos(theta) likewise. */
      const float sin2_max = R * R / dc2;
      const float one_minus_max = sin2_max / (1.0f + sqrt(1.0f - sin2_max));
      const float one_minus_cos = u.y * one_minus_max;
      const float sin2 = one_minus_cos * (2.0f - one_minus_cos);
      const float phi = 2.0f * SPM_PI * u.z;
      const float dc = sqrt(dc2);
      const float sin_t = sqrt(sin2);
      *wi = to_world(SPM_F3(sin_t * cos(phi), sin_t * sin(phi), 1.0f - one_minus_cos), to / dc);
      /* The near intersection of the direction with the sphere. */
      *dist = dc * (1.0f - one_minus_cos) - sqrt(fmax(0.0f, R * R - dc2 * sin2));
      *p = x + *dist * *wi;
      *n = normalize(*p - c);
      return load3(l->emission) * (2.0f * SPM_PI * one_minus_max / (prob * prim_prob));
    }
    sample_prim_point(s, prim, u.y, u.z, p, n);
  } else {
    *p = load3(l->position);
    *n = (float3)(0.0f);
  }
  return light_incident(l, x, *p, *n, prob, wi, dist);
}

/* The probability pick_light gives light i. */
inline float light_prob(const SpmScene* s, uint i) { return s->light_cdf[i] - (i > 0 ? s->light_cdf[i - 1] : 0.0f); }

/* The density per unit solid angle at x with which sample_light_from
 * reaches point p (normal n) of light l, picked with probability prob: by
 * the cone of a sphere that emits outwards (an area light of one sphere),
 * else by area, d^2 / (|cos| area). 0 for point, spot and directional
 * lights, which no ray meets: the sample that reached them needs no
 * multiple importance weight. */
inline float light_pdf_from(const SpmScene* s, const __global SpmLight* l, float prob, float3 x, float3 p, float3 n) {
  if (l->type != SPM_LIGHT_AREA) return 0.0f;
  const __global SpmPrim* prim = &s->prims[s->light_prims[l->prim_begin].prim];
  if (l->prim_count == 1u && cone_sampled(s, prim)) {
    const float3 to = load3(prim->p0) - x;
    const float R = prim->p1[0];
    const float dc2 = dot(to, to);
    if (dc2 > 1.0001f * R * R) {
      const float sin2_max = R * R / dc2;
      return prob / (2.0f * SPM_PI * sin2_max / (1.0f + sqrt(1.0f - sin2_max)));
    }
  }
  const float3 to = p - x;
  const float d2 = dot(to, to);
  const float cos_l = fabs(dot(n, to)) * rsqrt(d2);
  return cos_l > 0.0f ? prob * d2 / (cos_l * l->area) : 0.0f;
}

#endif
