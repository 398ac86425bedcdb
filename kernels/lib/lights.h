/* Sampling points and directions on the scene's lights. */
#ifndef SPM_LIB_LIGHTS_H
#define SPM_LIB_LIGHTS_H

#include "sampling.h"
#include "scene.h"

/* Environment maps (envmap, and constant as a map of one texel; METHOD.md
 * 14). A map of W x H texels (W: prim_count, H: map_height) lies in the
 * scene's light data from prim_begin: its RGB texels row by row, the top
 * row first (theta 0, the map's +y); then the inclusive CDF over its H
 * rows of cells; then each row's inclusive CDF over its W cells. Cell (i,
 * j) spans u in [i, i+1] / W and theta in [j, j+1] pi / H, and is picked by
 * the largest luminance that the bilinear lookup can take in it, times
 * its solid angle; within it the direction is uniform in phi and cos
 * theta, so that its density is constant there. Directions map to the
 * image as Mitsuba 3's do: u = atan2(x, -z) / 2 pi, theta = acos(y) in
 * the map's frame (axis_x, axis_y, axis_z: its to_world rotation). */
inline float3 env_local(const __global SpmLight* l, float3 w) {
  return SPM_F3(dot(w, load3(l->axis_x)), dot(w, load3(l->axis_y)), dot(w, load3(l->axis_z)));
}

/* The radiance the map sends along -w (w: towards the sky), Mitsuba's
 * lookup: bilinear, texel-centred and periodic in u, rows at theta = j pi
 * / (H - 1) clamped at the poles; times the emitter's scale. */
inline float3 env_radiance(const SpmScene* s, const __global SpmLight* l, float3 w) {
  const float3 v = env_local(l, w);
  const uint W = l->prim_count, H = l->map_height;
  float u = atan2(v.x, -v.z) * (0.5f * SPM_INV_PI);
  u -= floor(u);
  const float theta = acos(clamp(v.y, -1.0f, 1.0f)) * SPM_INV_PI;
  const float xf = u * (float)W - 0.5f;
  const float x0 = floor(xf), fx = xf - x0;
  const uint ix0 = (uint)((int)x0 + (int)W) % W, ix1 = (ix0 + 1u) % W;
  const float yf = theta * (float)(H - 1u);
  const uint iy0 = min((uint)yf, H - 1u), iy1 = min(iy0 + 1u, H - 1u);
  const float fy = yf - (float)iy0;
  const __global float* t = s->light_data + l->prim_begin;
  const float3 c00 = vload3(iy0 * W + ix0, t), c10 = vload3(iy0 * W + ix1, t);
  const float3 c01 = vload3(iy1 * W + ix0, t), c11 = vload3(iy1 * W + ix1, t);
  return load3(l->emission) *
         ((1.0f - fy) * ((1.0f - fx) * c00 + fx * c10) + fy * ((1.0f - fx) * c01 + fx * c11));
}

/* The solid angle of a cell of row j. */
inline float env_cell_solid_angle(uint j, uint W, uint H) {
  return 2.0f * SPM_PI / (float)W * (cos(SPM_PI * (float)j / (float)H) - cos(SPM_PI * (float)(j + 1u) / (float)H));
}

/* A direction towards the sky, drawn cell by cell by the uniforms u, with
 * its density per unit solid angle in *pdf. */
inline float3 env_sample(const SpmScene* s, const __global SpmLight* l, float2 u, float* pdf) {
  const uint W = l->prim_count, H = l->map_height;
  const __global float* rows = s->light_data + l->prim_begin + 3u * W * H;
  const uint j = pick_from_cdf(rows, H, u.x);
  const float r0 = j > 0u ? rows[j - 1u] : 0.0f;
  const __global float* cols = rows + H + j * W;
  const uint i = pick_from_cdf(cols, W, u.y);
  const float c0 = i > 0u ? cols[i - 1u] : 0.0f;
  const float pj = rows[j] - r0, pc = cols[i] - c0;
  /* The uniforms' place within the picked row and cell, for the point in it. */
  const float a = clamp((u.x - r0) / pj, 0.0f, 1.0f), b = clamp((u.y - c0) / pc, 0.0f, 1.0f);
  const float phi = 2.0f * SPM_PI * ((float)i + b) / (float)W;
  const float ct0 = cos(SPM_PI * (float)j / (float)H), ct1 = cos(SPM_PI * (float)(j + 1u) / (float)H);
  const float ct = ct0 + a * (ct1 - ct0), st = sqrt(fmax(0.0f, 1.0f - ct * ct));
  *pdf = pj * pc / env_cell_solid_angle(j, W, H);
  const float3 v = SPM_F3(sin(phi) * st, ct, -cos(phi) * st);
  return v.x * load3(l->axis_x) + v.y * load3(l->axis_y) + v.z * load3(l->axis_z);
}

/* env_sample's density for direction w. */
inline float env_pdf(const SpmScene* s, const __global SpmLight* l, float3 w) {
  const uint W = l->prim_count, H = l->map_height;
  const float3 v = env_local(l, w);
  float u = atan2(v.x, -v.z) * (0.5f * SPM_INV_PI);
  u -= floor(u);
  const uint i = min((uint)(u * (float)W), W - 1u);
  const uint j = min((uint)(acos(clamp(v.y, -1.0f, 1.0f)) * SPM_INV_PI * (float)H), H - 1u);
  const __global float* rows = s->light_data + l->prim_begin + 3u * W * H;
  const __global float* cols = rows + H + j * W;
  const float pj = rows[j] - (j > 0u ? rows[j - 1u] : 0.0f), pc = cols[i] - (i > 0u ? cols[i - 1u] : 0.0f);
  return pj * pc / env_cell_solid_angle(j, W, H);
}

/* The radiance of every environment light along -w, for a ray that
 * escapes the scene outside any medium. */
inline float3 env_seen(const SpmScene* s, float3 w) {
  float3 sum = (float3)(0.0f);
  for (uint k = 0; k < s->num_lights; ++k)
    if (s->lights[k].type == SPM_LIGHT_ENVMAP) sum += env_radiance(s, &s->lights[k], w);
  return sum;
}

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
  if (l->type == SPM_LIGHT_ENVMAP) {
    /* A direction of the map; the shadow ray goes to infinity, and *p is
     * a point along it, which light_pdf_from reads the direction from. */
    float pdf;
    *wi = env_sample(s, l, SPM_F2(u.y, u.z), &pdf);
    *dist = SPM_INF;
    *p = x + *wi;
    *n = (float3)(0.0f);
    return pdf > 0.0f ? env_radiance(s, l, *wi) / (pdf * prob) : (float3)(0.0f);
  }
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
 * else by area, d^2 / (|cos| area); an environment map's for the
 * direction from x to p. 0 for point, spot and directional
 * lights, which no ray meets: the sample that reached them needs no
 * multiple importance weight. */
inline float light_pdf_from(const SpmScene* s, const __global SpmLight* l, float prob, float3 x, float3 p, float3 n) {
  if (l->type == SPM_LIGHT_ENVMAP) return prob * env_pdf(s, l, normalize(p - x));
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
