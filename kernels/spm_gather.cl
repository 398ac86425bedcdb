/* spm_gather: one work-item per block of 2x2 pixels, spp camera samples per
 * pixel (METHOD.md 5; paper 3.2, eq. 4). From: camera, photon maps and their
 * grids. To: the pass's film (mean radiance of each pixel's samples).
 *
 * A camera ray through the pixel filter follows specular chains (mirror,
 * dielectric) and null boundaries. Along every segment inside a medium it
 * adds the beam radiance estimate over the volumetric stream map (or the
 * stream beams' estimate) and is
 * attenuated by the medium's transmittance (paper eq. 2); at the first diffuse
 * surface it adds the surface photon map's estimate and, by default, direct
 * light by next-event estimation with shadow rays that carry transmittance.
 * When the maps are gathered in parts (too large for the device at once),
 * only the first part's launch adds emission and next-event estimation. */
#include "spm_types.h"
#include "spm_maps.h"
#include "lib/bsdf.h"
#include "lib/camera.h"
#include "lib/lights.h"
#include "lib/maps.h"
#include "lib/rng.h"
#include "lib/walk.h"

/* What the estimates need, bundled for the path loop. */
typedef struct SpmMaps {
  uint direct_terms; /* 0: the photon estimates alone (a later part of the maps) */
  uint terms;        /* SPM_TERM_* bits of the terms to compute (spm_types.h) */
  SpmMapTable table; /* the grids and who reads them (lib/maps.h) */
  float radius;
  float volume_radius; /* the camera's volume kernel radius: the reach of its shared estimate */
  float gather_aim;    /* the share of gather rays aimed at lights (SpmGatherParams) */
  uint estimator;
  uint direct;
  uint final_gather;
  float march_step; /* Delta of heterogeneous media (medium.h) */
} SpmMaps;

/* Transmittance from o towards a light at `dist` along d, through null
 * boundaries (switching the medium at each); 0 when an opaque surface
 * blocks, or past SPM_MAX_SHADOW_CROSSINGS of them. */
inline float3 shadow_transmittance(const SpmScene* s, float3 o, float3 d, float dist, int medium, float step,
                                   SpmRng rng, uint call) {
  float3 tr = (float3)(1.0f);
  SpmWalk w;
  walk_ray(&w, o, d, dist, medium, rng, call);
  while (walk_next(s, &w)) {
    if (w.hit && w.state != SPM_WALK_CROSS) return (float3)(0.0f);
    tr *= walk_transmittance(s, &w, step);
    if (!w.hit) return tr;
  }
  return (float3)(0.0f);
}

/* A light sample for next-event estimation at a surface point x: the
 * light, its pick probability, the radiance it sends to x over the
 * sampling density (sample_light_from) and the shadow ray (wi, dist);
 * *reach: how far the shadow ray goes, short of an area light's own
 * surface. */
typedef struct SpmLightSample {
  const __global SpmLight* light;
  float prob;
  float3 li, wi, p, n;
  float dist, reach;
} SpmLightSample;

inline SpmLightSample surface_light_sample(const SpmScene* s, float3 x, SpmRng rng) {
  SpmLightSample ls;
  float4 u = rng4(rng, SPM_RNG_LIGHT_PICK, 0);
  u.zw = stratify2(rng, SPM_RNG_LIGHT_PICK, 0u);
  ls.light = &s->lights[pick_light(s, u.x, &ls.prob)];
  ls.li = sample_light_from(s, ls.light, ls.prob, x, u.yzw, &ls.wi, &ls.dist, &ls.p, &ls.n);
  /* Point lights have no surface to stop short of. */
  ls.reach = dot(ls.n, ls.n) > 0.0f ? ls.dist * (1.0f - 1e-4f) : ls.dist;
  return ls;
}

/* The transmittance of the shadow ray of light sample ls from surf, which
 * a path reached in `medium`, leaving on the side the ray goes to. */
inline float3 light_sample_transmittance(const SpmScene* s, const SpmSurface* surf, const SpmLightSample* ls,
                                         int medium, float step, SpmRng rng) {
  return shadow_transmittance(s, leave_surface(surf, ls->wi), ls->wi, ls->reach,
                              target_medium(&s->shapes[surf->shape], surf->ng, ls->wi, medium), step, rng,
                              SPM_TR_DIRECT);
}

/* Direct light reflected by a surface's diffuse lobe towards -d; `medium`
 * is the one the camera path arrived in. */
inline float3 direct_diffuse(const SpmScene* s, const SpmSurface* surf, const __global SpmMaterial* m, float3 d,
                             int medium, float step, SpmRng rng) {
  const float3 n = facing_normal(surf, d);
  const SpmLightSample ls = surface_light_sample(s, surf->p, rng);
  const float cos_x = dot(ls.wi, n);
  if (cos_x <= 0.0f || max_comp(ls.li) <= 0.0f) return (float3)(0.0f);
  const float3 tr = light_sample_transmittance(s, surf, &ls, medium, step, rng);
  return diffuse_f_pi(m, n, ls.wi, -d) * SPM_INV_PI * cos_x * ls.li * tr;
}

/* The power heuristic's weight (Veach 1997) of a sample of density a
 * against another strategy's b. */
inline float power_heuristic(float a, float b) { return a * a / (a * a + b * b); }

/* Direct light a glossy lobe (local frame n, wi_local towards the camera
 * side) reflects or transmits towards -d, by a light sample weighted by
 * multiple importance against the lobe's own sampling, which reaches
 * lights too (glossy_turn; METHOD.md 13). */
inline float3 direct_glossy(const SpmScene* s, const SpmSurface* surf, const __global SpmMaterial* m, float3 n,
                            float3 wi_local, int medium, float step, SpmRng rng) {
  const SpmLightSample ls = surface_light_sample(s, surf->p, rng);
  if (max_comp(ls.li) <= 0.0f) return (float3)(0.0f);
  float pdf;
  const float3 f = glossy_eval_local(m, wi_local, to_local(ls.wi, n), true, &pdf);
  if (max_comp(f) <= 0.0f) return (float3)(0.0f);
  const float3 tr = light_sample_transmittance(s, surf, &ls, medium, step, rng);
  const float light_pdf = light_pdf_from(s, ls.light, ls.prob, surf->p, ls.p, ls.n);
  return f * ls.li * tr * (light_pdf > 0.0f ? power_heuristic(light_pdf, pdf) : 1.0f);
}

/* A light picked by power for single scattering along o + t d (METHOD.md
 * 5), and the ray's equi-angular frame (Kulla and Fajardo 2012) about a
 * point y of it: t = delta + D tan(theta), theta uniform between a
 * segment's ends as seen from y, at distance D from the ray. For a sphere
 * that emits outwards, y is its centre and the light is sampled afresh by
 * its cone from the point the distance picks (`cone`; sample_light_from):
 * the cone's solid angle falls as 1 / distance^2 from the centre, as the
 * equi-angular pdf does, so their ratio stays bounded. Any other light's y
 * is a uniform point of it (its primitive picked by area), or the point
 * light, and is the light point itself: a fresh point near the ray where
 * y is far would bring 1 / distance^2 without the pdf that cancels it
 * (fireflies; cornell_fog's ceiling light measured 2.6x the variance). */
typedef struct SpmNeeLight {
  const __global SpmLight* light;
  float3 y, yn;
  float prob;
  float delta, D;
  bool cone;
} SpmNeeLight;

inline SpmNeeLight nee_light(const SpmScene* s, float3 o, float3 d, SpmRng rng) {
  SpmNeeLight n;
  float4 u = rng4(rng, SPM_RNG_MEDIUM_NEE, 0);
  u.zw = stratify2(rng, SPM_RNG_MEDIUM_NEE, 0u);
  n.light = &s->lights[pick_light(s, u.x, &n.prob)];
  n.cone = false;
  n.yn = (float3)(0.0f);
  const bool infinite = n.light->type == SPM_LIGHT_DIRECTIONAL || n.light->type == SPM_LIGHT_ENVMAP;
  if (n.light->type == SPM_LIGHT_AREA) {
    float prim_prob;
    const __global SpmPrim* prim = pick_light_prim(s, n.light, u.y, &prim_prob);
    n.cone = cone_sampled(s, prim);
    if (n.cone) n.y = load3(prim->p0);
    else sample_prim_point(s, prim, u.z, u.w, &n.y, &n.yn);
  } else {
    n.y = load3(n.light->position);
    /* An environment map is sampled afresh at each point, as a cone is. */
    n.cone = n.light->type == SPM_LIGHT_ENVMAP;
  }
  /* A light at infinity has no point to sample distances about: D = 0
   * leaves the equi-angular strategy out. */
  n.delta = infinite ? 0.0f : dot(n.y - o, d);
  n.D = infinite ? 0.0f : length(n.y - (o + n.delta * d));
  return n;
}

/* The light of n's light scattered at x towards -d: from n's point, or a
 * point of its cone from x (the uniforms of `lane`), with the phase
 * function and the shadow ray's transmittance. */
inline float3 nee_arrival(const SpmScene* s, const SpmNeeLight* n, float3 x, float3 d, float g, int medium,
                          float step, SpmRng rng, uint lane) {
  float3 wi, p = n->y, pn = n->yn;
  float dist;
  float3 li;
  if (n->cone) {
    float3 u = rng4(rng, SPM_RNG_MEDIUM_NEE, lane).xyz;
    u.yz = stratify2(rng, SPM_RNG_MEDIUM_NEE, lane);
    li = sample_light_from(s, n->light, n->prob, x, u, &wi, &dist, &p, &pn);
  } else {
    li = light_incident(n->light, x, n->y, n->yn, n->prob, &wi, &dist);
  }
  if (max_comp(li) <= 0.0f) return (float3)(0.0f);
  /* Stop short of an area light's own surface; point lights have none. */
  const float reach = dot(pn, pn) > 0.0f ? dist * (1.0f - 1e-4f) : dist;
  return li * phase_hg(dot(wi, d), g) * shadow_transmittance(s, x, wi, reach, medium, step, rng, SPM_TR_NEE_SHADOW);
}

/* Single scattering towards the camera along [t0, t1] of a ray through
 * `medium`, by next-event estimation (METHOD.md 20): a light point (nee_light),
 * then two distances along the ray, one equi-angular about it (sharp where
 * the ray passes the light) and one by free flight truncated to the segment
 * (where transmittance dominates), combined by the balance heuristic, each
 * with a shadow ray that carries transmittance. The photon records of
 * streams without an earlier event are left out of the volume estimate
 * instead (host/spm/map_grids.cpp). */
inline float3 inscatter_nee(const SpmScene* s, int medium, float3 o, float3 d, float t0, float t1, float step,
                            SpmRng rng) {
  const __global SpmMedium* m = &s->md.media[medium];
  const float3 sigma_t = load3(m->sigma_t);
  const float3 sigma_s = sigma_t * load3(m->albedo);
  if (max_comp(sigma_s) <= 0.0f || !(t1 > t0)) return (float3)(0.0f);
  const float g = m->phase == SPM_PHASE_HG ? m->g : 0.0f;
  const SpmNeeLight n = nee_light(s, o, d, rng);
  const float2 u = stratify2(rng, SPM_RNG_MEDIUM_NEE, 1u);
  const bool angular = n.D > 0.0f;
  const float th0 = atan2(t0 - n.delta, n.D);
  const float th1 = isinf(t1) ? 0.5f * SPM_PI : atan2(t1 - n.delta, n.D);
  /* Free flight with the mean extinction (METHOD.md 3), truncated to the
   * segment: `mass` is its probability of an event within it. */
  const float sigma = mean_comp(sigma_t);
  const float mass = isinf(t1) ? 1.0f : -expm1(-sigma * (t1 - t0));
  const bool flight = sigma > 0.0f && mass > 0.0f;
  float3 sum = (float3)(0.0f);
  for (int k = 0; k < 2; ++k) {
    if (k == 0 ? !angular : !flight) continue;
    const float t = k == 0 ? n.delta + n.D * tan(th0 + u.x * (th1 - th0)) : t0 - log1p(-u.y * mass) / sigma;
    if (!(t >= t0 && t <= t1)) continue;
    const float pdf_angular =
        angular ? n.D / ((th1 - th0) * (n.D * n.D + (t - n.delta) * (t - n.delta))) : 0.0f;
    const float pdf_flight = flight ? sigma * exp(-sigma * (t - t0)) / mass : 0.0f;
    sum += exp(-sigma_t * (t - t0)) * sigma_s * nee_arrival(s, &n, o + t * d, d, g, medium, step, rng, 2u + k) /
           (pdf_angular + pdf_flight);
  }
  return sum;
}

/* inscatter_nee in a heterogeneous medium (METHOD.md 12): the equi-angular
 * distance alone, on the part of the segment inside the medium's grids
 * (outside them nothing scatters), with sigma_s at the point and the
 * transmittance to it and to the light by medium.h's marching or ratio
 * tracking. A flight-distance strategy would need the inverse of the
 * segment's optical depth; equi-angular sampling already has its pdf. A
 * light at infinity, which has no point to centre it on, gets a uniform
 * distance in that part instead (METHOD.md 14). */
inline float3 inscatter_nee_heterogeneous(const SpmScene* s, int medium, float3 o, float3 d, float t0, float t1,
                                          float step, SpmRng rng) {
  float a = t0, b = t1;
  if (!medium_clip(&s->md, medium, o, d, &a, &b)) return (float3)(0.0f);
  const __global SpmMedium* m = &s->md.media[medium];
  const float g = m->phase == SPM_PHASE_HG ? m->g : 0.0f;
  const SpmNeeLight n = nee_light(s, o, d, rng);
  const float4 u = rng4(rng, SPM_RNG_MEDIUM_NEE, 1);
  float t, pdf;
  if (n.D == 0.0f) {
    if (!(b > a) || isinf(b)) return (float3)(0.0f);
    t = a + u.x * (b - a);
    pdf = 1.0f / (b - a);
  } else {
    if (!(n.D > 0.0f)) return (float3)(0.0f);
    const float th0 = atan2(a - n.delta, n.D);
    const float th1 = atan2(b - n.delta, n.D);
    t = n.delta + n.D * tan(th0 + u.x * (th1 - th0));
    pdf = n.D / ((th1 - th0) * (n.D * n.D + (t - n.delta) * (t - n.delta)));
  }
  if (!(t >= a && t <= b)) return (float3)(0.0f);
  const float3 x = o + t * d;
  const float3 sigma_s = medium_sigma_t(&s->md, medium, x) * medium_albedo(&s->md, medium, x);
  if (max_comp(sigma_s) <= 0.0f) return (float3)(0.0f);
  const float3 arrival = nee_arrival(s, &n, x, d, g, medium, step, rng, 2u);
  if (max_comp(arrival) <= 0.0f) return (float3)(0.0f);
  return medium_transmittance(&s->md, medium, o, d, t0, t, step, rng, tr_lane(SPM_TR_NEE_CAMERA, 0u)) * sigma_s *
         arrival / pdf;
}

/* Single scattering along [t0, t1] by next-event estimation, in either
 * kind of medium, for the camera's segments (the gather rays read it from
 * the volume records, final_gather). */
inline float3 medium_nee(const SpmScene* s, int medium, float3 o, float3 d, float t0, float t1, float step,
                         SpmRng rng) {
  return medium_is_heterogeneous(&s->md.media[medium]) ? inscatter_nee_heterogeneous(s, medium, o, d, t0, t1, step, rng)
                                                       : inscatter_nee(s, medium, o, d, t0, t1, step, rng);
}

/* The volume estimate (records or stream beams) along [t0, t1] in a
 * heterogeneous medium: in pieces of SPM_TABLE_KNOTS knots, each with the
 * table of optical depth and albedo that all its records or beams read
 * (medium.h), attenuated by the depth of the pieces before it. The pieces
 * start where the optical depth from t0 is known: at the sigma_t grid's
 * cube (0 before it), or, for a constant sigma_t, at the albedo grid's
 * (sigma_t times the distance); they end where the medium stops
 * scattering (medium_clip). */
inline float3 heterogeneous_volume_estimate(const SpmScene* s, const SpmMaps* maps, uint reader, int medium,
                                            float3 o, float3 d, float t0, float t1, uint min_depth, uint max_depth,
                                            uint* tests) {
  const __global SpmMedium* m = &s->md.media[medium];
  float a = t0, b = t1, end_a = t0, end = t1;
  if (!grid_clip(&s->md, m->sigma_t_grid >= 0 ? m->sigma_t_grid : m->albedo_grid, o, d, &a, &b) ||
      !medium_clip(&s->md, medium, o, d, &end_a, &end))
    return (float3)(0.0f);
  b = fmin(b, end);
  float voxel = SPM_INF;
  if (m->sigma_t_grid >= 0) voxel = s->md.grids[m->sigma_t_grid].voxel;
  if (m->albedo_grid >= 0) voxel = fmin(voxel, s->md.grids[m->albedo_grid].voxel);
  const float h = maps->march_step > 0.0f ? maps->march_step : 0.5f * voxel;
  float3 tau = m->sigma_t_grid >= 0 ? (float3)(0.0f) : load3(m->sigma_t) * (a - t0);
  float3 sum = (float3)(0.0f);
  SpmMediumTable tab;
  for (float ta = a; ta < b;) {
    const float tb = fmin(b, ta + (float)(SPM_TABLE_KNOTS - 1) * h);
    const uint n = clamp((uint)ceil((tb - ta) / h) + 1u, 2u, (uint)SPM_TABLE_KNOTS);
    medium_table_fill(&s->md, medium, o, d, ta, h, n, &tab);
    sum += exp(-tau) * table_volume_estimate(&maps->table, reader, s->md.media, s->patches, medium, o, d, ta, tb,
                                             min_depth, max_depth, &tab, tests);
    float3 albedo;
    tau += medium_table_depth(&tab, tb, &albedo);
    if (!(tb > ta)) break;
    ta = tb;
  }
  return sum;
}

/* In-scattered radiance along [t0, t1] of o + t d in `medium` from the
 * photon maps, by the pass's volume estimator, from records (or beams) of
 * depths min_depth .. max_depth, over the grids `reader` reads
 * (SPM_READ_CAMERA or SPM_READ_GATHER; lib/maps.h). */
inline float3 volume_estimate(const SpmScene* s, const SpmMaps* maps, uint reader, int medium, float3 o, float3 d,
                              float t0, float t1, uint min_depth, uint max_depth, uint* tests) {
  if (maps->estimator != SPM_ESTIMATOR_PAPER && medium_is_heterogeneous(&s->md.media[medium]))
    return heterogeneous_volume_estimate(s, maps, reader, medium, o, d, t0, t1, min_depth, max_depth, tests);
  SpmMediumTable homogeneous;
  homogeneous.n = 0u;
  return table_volume_estimate(&maps->table, reader, s->md.media, s->patches, medium, o, d, t0, t1, min_depth,
                               max_depth, &homogeneous, tests);
}

/* The camera segment's volume estimate, shared by a block's samples
 * (volume_reuse_hit, lib/maps.h). */
inline float3 camera_volume_estimate(SpmVolumeReuse* reuse, const SpmScene* s, const SpmMaps* maps, int medium,
                                     float3 o, float3 d, float t0, float t1, uint min_depth, uint max_depth,
                                     uint* tests) {
  if (volume_reuse_hit(reuse, o, d, t0, t1, medium, min_depth, max_depth, maps->volume_radius)) return reuse->L;
  const float3 L = volume_estimate(s, maps, SPM_READ_CAMERA, medium, o, d, t0, t1, min_depth, max_depth, tests);
  if (!isinf(t1)) reuse->L = L;
  return L;
}

/* Largest depth of a photon record that a camera path with `specular`
 * specular vertices may use: the path then has depth + specular + 1
 * segments, at most max_depth (METHOD.md 10; SPM_NONE: unlimited). */
inline uint record_depth_limit(uint max_depth, uint specular) {
  if (max_depth == SPM_NONE) return SPM_NONE;
  return max_depth > specular + 1u ? max_depth - specular - 1u : 0u;
}

/* Whether a path of `segments` segments is within max_depth. */
inline bool within_depth(uint segments, uint max_depth) { return max_depth == SPM_NONE || segments <= max_depth; }

/* Density, in solid angle, of the directions gather_direction aims about
 * the light at `c` from x: uniform in the angle alpha from the light's
 * direction up to SPM_AIM_CONE and in the azimuth, 1 / (2 pi
 * SPM_AIM_CONE sin alpha). */
inline float aim_pdf(float3 x, float3 c, float3 w) {
  const float3 to = c - x;
  const float len = length(to);
  if (!(len > 0.0f)) return 0.0f;
  const float cos_a = clamp(dot(w, to / len), -1.0f, 1.0f);
  if (cos_a <= cos(SPM_AIM_CONE)) return 0.0f;
  const float sin_a = sqrt(fmax(0.0f, 1.0f - cos_a * cos_a));
  return 1.0f / (2.0f * SPM_PI * SPM_AIM_CONE * fmax(sin_a, 1e-6f));
}

/* A final-gather ray's direction at x with normal n, and in *weight its
 * cosine over pi divided by its density, the factor that turns the light
 * arriving along it into the light reflected, over the reflectance.
 * With aim == 0, cosine-weighted: weight 1. Else one of two strategies,
 * picked by u.x (Veach's one-sample model, the balance heuristic): with
 * probability 1 - aim cosine-weighted, with probability aim towards a
 * light picked by its `aim` (u_light), at an angle alpha from its centre
 * uniform up to SPM_AIM_CONE (aim_pdf). A light in a medium lights the
 * medium around it, and the light scattered once there reaches x with a
 * radiance of about 1 / sin alpha, whose square the cosine's density does
 * not bound: the floor under caustic_area's light took 86% of the gather
 * rays' volume variance from it (docs/experiments/caustics.md "Gather rays aimed at the glow").
 * The aimed density follows it, so the weight stays bounded there. */
inline float3 gather_direction(const SpmScene* s, float aim, float3 x, float3 n, float2 u, float u_light,
                               float* weight) {
  if (aim <= 0.0f) {
    *weight = 1.0f;
    return to_world(sample_cosine_hemisphere(u.x, u.y), n);
  }
  float3 w;
  if (u.x < aim) {
    /* The light by its `aim` (a few lights: a scan, not a CDF), the last
     * aimed one should rounding leave u_light past their sum. */
    uint k = 0;
    float acc = 0.0f;
    for (uint i = 0; i < s->num_lights; ++i) {
      if (s->lights[i].aim <= 0.0f) continue;
      k = i;
      acc += s->lights[i].aim;
      if (u_light < acc) break;
    }
    const __global SpmLight* l = &s->lights[k];
    const float3 to = load3(l->position) - x;
    const float alpha = (u.x / aim) * SPM_AIM_CONE, phi = 2.0f * SPM_PI * u.y;
    const float3 v = (float3)(sin(alpha) * cos(phi), sin(alpha) * sin(phi), cos(alpha));
    w = length(to) > 0.0f ? to_world(v, normalize(to)) : to_world(v, n);
  } else {
    w = to_world(sample_cosine_hemisphere((u.x - aim) / (1.0f - aim), u.y), n);
  }
  const float cos_n = dot(w, n);
  if (!(cos_n > 0.0f)) {
    *weight = 0.0f;
    return w;
  }
  float aimed = 0.0f;
  for (uint i = 0; i < s->num_lights; ++i) {
    if (s->lights[i].aim > 0.0f) aimed += s->lights[i].aim * aim_pdf(x, load3(s->lights[i].position), w);
  }
  const float cosine = cos_n * SPM_INV_PI;
  *weight = cosine / ((1.0f - aim) * cosine + aim * aimed);
  return w;
}

/* Indirect light reflected towards the camera at a diffuse vertex, by a
 * final-gather ray (Jensen 1996): a cosine-weighted direction, along which
 * the light scattered in every medium segment and the light leaving the
 * first diffuse surface it meets arrive, attenuated by the transmittance.
 * At its end, as at the camera's own vertex, next-event estimation gives
 * the direct light (direct_diffuse) and the surface map the rest, the
 * records of streams with an earlier event (host/spm/map_grids.cpp): the
 * disks that reach past walls and edges then miss only that rest. Along
 * it the volume records or beams give all the light scattered in the
 * medium, single scattering (depth 1) included: a shadow ray there
 * (inscatter_nee) measured a quarter of cornell_fog's variance for 4% of
 * its light, and the records, which one pass's gather rays share, carry
 * it with a tenth of that (docs/experiments/gather.md "Single scattering along the gather
 * rays"). The ray's direction comes from gather_direction, and what it
 * brings is scaled by its weight, the BSDF of `material`'s diffuse lobe
 * times the cosine over the density, less diffuse_exit, which the caller
 * applies (1 for a cosine-weighted ray into a diffuse surface; a
 * plastic's coat takes its share, diffuse_entry). Emission and
 * delta or glossy surfaces the ray meets add nothing: direct light comes from
 * next-event estimation, and light through a delta or glossy vertex from the
 * caustic records read at the vertex itself (SPM_RECORD_CAUSTIC), so no
 * light is counted twice. Where the ray ends near its start
 * (SPM_GATHER_NEAR) its end is a vertex of the same kind: its caustic
 * records and the next gather ray instead of its surface estimate.
 * `segments`: the path's segments up to the first vertex, for max_depth
 * (METHOD.md 10): the records read at the end of hop j's ray have at most
 * max_depth - segments - 1 - j vertices. */
inline float3 final_gather(const SpmScene* s, const SpmMaps* maps, const SpmSurface* surf,
                           const __global SpmMaterial* material, float3 d, int medium, uint segments, uint max_depth,
                           SpmRng rng, uint* tests) {
  float3 tr = (float3)(1.0f);
  float3 li = (float3)(0.0f);
  SpmSurface x = *surf;
  for (uint hop = 0;; ++hop) {
    /* Hop j's ray ends at a vertex segments + 1 + j segments from the camera. */
    const uint depth_limit = record_depth_limit(max_depth, segments + hop);
    const float2 u = stratify2(rng, SPM_RNG_FINAL_GATHER, 0u);
    float weight;
    const float3 xn = facing_normal(&x, d);
    const float3 wi =
        gather_direction(s, maps->gather_aim, x.p, xn, u, rng4(rng, SPM_RNG_FINAL_GATHER, 0u).x, &weight);
    if (!(weight > 0.0f)) return li;
    tr *= weight * diffuse_entry(material, dot(wi, xn));
    SpmWalk w;
    walk_ray(&w, leave_surface(&x, wi), wi, SPM_INF, target_medium(&s->shapes[x.shape], x.ng, wi, medium), rng,
             SPM_TR_FINAL_GATHER);
    /* The direct light at the ray's end: events of its own, as the camera
     * vertex's are its own. */
    SpmRng own;
    hop_rng(&own, rng, hop);
    const bool direct =
        maps->direct_terms && (maps->terms & SPM_TERM_GATHER_DIRECT) && within_depth(segments + hop + 2u, max_depth);
    const bool surface = (maps->terms & SPM_TERM_GATHER_SURFACE) != 0u;
    float reach = 0.0f;
    bool next = false;
    while (walk_next(s, &w)) {
      if (w.medium >= 0 && (maps->terms & SPM_TERM_GATHER_VOLUME)) {
        li += tr * volume_estimate(s, maps, SPM_READ_GATHER, w.medium, w.o, wi, w.t0, w.t1, 1u, depth_limit, tests);
      }
      if (!w.hit) break;
      tr *= walk_transmittance(s, &w, maps->march_step);
      reach += w.t1;
      if (w.state == SPM_WALK_CROSS) continue;
      const __global SpmMaterial* m = w.material;
      if (!has_diffuse(m->type) || !reflects_from(m, &w.surf, wi)) break;
      const float3 n = facing_normal(&w.surf, wi);
      const float3 exit = diffuse_exit(m, -dot(wi, n));
      rng = own;
      medium = w.medium;
      if (direct) li += tr * direct_diffuse(s, &w.surf, m, wi, medium, maps->march_step, rng);
      const SpmPatchFrame patch = patch_frame(s->patches, w.surf.patch);
      if (hop < SPM_GATHER_HOPS && reach < SPM_GATHER_NEAR * maps->radius) {
        tr *= exit;
        if (surface) {
          li += tr * SPM_INV_PI *
                table_surface_estimate(&maps->table, SPM_READ_GATHER_HOP, w.surf.p, n, depth_limit, &patch);
        }
        x = w.surf;
        material = m;
        d = wi;
        next = true;
      } else if (surface) {
        li += tr * exit * SPM_INV_PI *
              table_surface_estimate(&maps->table, SPM_READ_GATHER_END, w.surf.p, n, depth_limit, &patch);
      }
      break;
    }
    if (!next) return li;
  }
}

/* The emission a camera path sees at surf, arriving along d after
 * `specular` specular vertices: the light's radiance where surf emits
 * towards the path and the path is within max_depth, else 0. */
inline float3 seen_emission(const SpmScene* s, const __global SpmShape* shape, const SpmSurface* surf, float3 d,
                            uint specular, uint max_depth) {
  if (shape->light < 0 || dot(d, surf->ng) >= 0.0f || !within_depth(specular + 1u, max_depth)) return (float3)(0.0f);
  return load3(s->lights[shape->light].emission);
}

/* The light of the environment maps that a path escaping the scene along
 * d (outside any medium) sees after `specular` delta or glossy vertices;
 * glossy_pdf > 0: the density with which the last vertex, glossy, sampled
 * d, weighed against its next-event estimation of each map. */
inline float3 escaped_emission(const SpmScene* s, float3 d, uint specular, uint max_depth, float glossy_pdf) {
  float3 sum = (float3)(0.0f);
  if (!within_depth(specular + 1u, max_depth)) return sum;
  for (uint k = 0; k < s->num_lights; ++k) {
    const __global SpmLight* l = &s->lights[k];
    if (l->type != SPM_LIGHT_ENVMAP) continue;
    const float w = glossy_pdf > 0.0f ? power_heuristic(glossy_pdf, light_prob(s, k) * env_pdf(s, l, d)) : 1.0f;
    sum += w * env_radiance(s, l, d);
  }
  return sum;
}

/* A camera path's turn at the mirror or glass its walk's segment ended on
 * (METHOD.md 3), by the uniform of (rng, purpose, lane), counting the
 * specular vertex. False where the path ends: past the specular cap or
 * max_depth, or where the bounce has no weight. */
inline bool specular_turn(SpmWalk* w, SpmRng rng, uint purpose, uint lane, uint max_depth, uint* specular,
                          float3* beta) {
  if (++*specular > SPM_MAX_CAMERA_SPECULAR || !within_depth(*specular + 1u, max_depth)) return false;
  float3 next;
  const float3 f = specular_bounce(w->material, &w->surf, w->d, rng4(rng, purpose, lane).x, true, &next);
  if (max_comp(f) <= 0.0f) return false;
  *beta *= f;
  walk_turn(w, next);
  return true;
}

/* A camera path's turn at the glossy surface its walk's segment ended on
 * (METHOD.md 13): next-event estimation there (direct_glossy, into *L,
 * when `nee`), then a direction sampled from the lobe, whose density goes
 * to *pdf for the weight of the emission it meets next (glossy_emission).
 * Counted as a specular vertex is; false where the path ends. */
inline bool glossy_turn(const SpmScene* s, const SpmMaps* maps, SpmWalk* w, SpmRng rng, uint max_depth, bool nee,
                        uint* specular, float3* beta, float* pdf, float3* L) {
  if (++*specular > SPM_MAX_CAMERA_SPECULAR || !within_depth(*specular + 1u, max_depth)) return false;
  float3 n;
  if (!glossy_frame(w->material, &w->surf, w->d, &n)) return false;
  const float3 wi = to_local(-w->d, n);
  if (nee) *L += *beta * direct_glossy(s, &w->surf, w->material, n, wi, w->medium, maps->march_step, rng);
  float3 wo;
  const float3 f = glossy_sample_local(w->material, wi, rng4(rng, SPM_RNG_BSDF, 0).xyz, true, &wo, pdf);
  if (max_comp(f) <= 0.0f) return false;
  *beta *= f;
  walk_turn(w, to_world(wo, n));
  return true;
}

/* The weight of emission that a camera path meets at surf right after a
 * glossy vertex at x, sampled with density pdf: the power heuristic
 * against next-event estimation from x, which reaches the same light
 * (direct_glossy). */
inline float glossy_emission(const SpmScene* s, const __global SpmShape* shape, const SpmSurface* surf, float3 x,
                             float pdf) {
  const uint i = (uint)shape->light;
  const float light_pdf = light_pdf_from(s, &s->lights[i], light_prob(s, i), x, surf->p, surf->ng);
  return power_heuristic(pdf, light_pdf);
}

/* Whether the camera ray through film point (fx, fy), past null
 * boundaries, first meets a mirror or glass. */
inline bool sees_chain_start(const SpmScene* s, const __global SpmCamera* cam, float fx, float fy) {
  float3 o;
  float tmin, tmax;
  const float3 d = camera_ray(cam, fx, fy, &o, &tmin, &tmax);
  SpmWalk w;
  walk_begin(&w, o, d, tmin, tmax, cam->medium, SPM_WALK_PATH, rng_make(0u, 0u, 0u, 0u), SPM_TR_CAMERA,
             SPM_MAX_SHADOW_CROSSINGS, false);
  while (walk_next(s, &w)) {
    if (!w.hit) return false;
    if (w.state == SPM_WALK_CROSS) continue;
    return is_specular(w.material->type);
  }
  return false;
}

/* The emission camera sample `rng` sees through pixel (px, py), directly
 * or through specular chains, by `chains` camera rays of its own: each
 * with its own point of the pixel filter (the chains of all the render's
 * samples of the pixel read one stratified sequence, stratify2) and its
 * own reflect-or-refract choices, each weighted 1 / chains. A light seen
 * through glass or in a curved mirror is an image much smaller than a
 * pixel (caustic_area's light through the sphere: 0.04% of one), which a
 * pixel's few samples find only now and then, each time as a firefly; the
 * chains are a few rays each, against the thousands of records a sample's
 * estimates read, so the pixels where they start (sees_chain_start) take
 * many. The mean is the sample path's own emission term, which leaves it
 * out there (radiance's `emission`). */
inline float3 emission_chains(const SpmScene* s, const SpmMaps* maps, const __global SpmCamera* cam, uint px,
                              uint py, uint max_depth, SpmRng rng, uint chains) {
  float3 sum = (float3)(0.0f);
  for (uint j = 0; j < chains; ++j) {
    SpmRng r = rng;
    r.sample = rng.sample * chains + j;
    const float2 u = stratify2(r, SPM_RNG_EMISSION, 0u);
    const float2 off = sample_filter(cam, u.x, u.y);
    float3 o;
    float tmin, tmax;
    const float3 d = camera_ray(cam, (float)px + 0.5f + off.x, (float)py + 0.5f + off.y, &o, &tmin, &tmax);
    float3 beta = (float3)(1.0f);
    uint specular = 0;
    SpmWalk w;
    walk_path(&w, o, d, tmin, tmax, cam->medium, r, SPM_TR_EMISSION + j);
    while (walk_next(s, &w)) {
      if (!w.hit) {
        if (w.medium < 0) sum += beta * escaped_emission(s, w.d, specular, max_depth, 0.0f);
        break;
      }
      beta *= walk_transmittance(s, &w, maps->march_step);
      sum += beta * seen_emission(s, w.shape, &w.surf, w.d, specular, max_depth);
      if (w.state == SPM_WALK_CROSS) continue;
      if (w.material->type == SPM_MAT_DIFFUSE || is_glossy(w.material->type) ||
          !specular_turn(&w, w.rng, SPM_RNG_EMISSION, j, max_depth, &specular, &beta))
        break;
    }
  }
  return sum / (float)chains;
}

/* One camera sample's radiance; `emission`: whether it adds the emission it
 * sees through delta chains (emission_chains), `volume_weight`: the weight
 * of its camera segments' volume estimate, 0 to leave it out (spm_gather).
 * Path depths count as Mitsuba's volpath counts them: emission seen after
 * `specular` delta or glossy vertices has specular + 1 segments, direct
 * light at the diffuse vertex that ends the chain specular + 2. A path goes
 * on past a plastic's diffuse base along its coat (METHOD.md 13), and past
 * a glossy vertex by sampling its lobe. */
inline float3 radiance(const SpmScene* s, const SpmMaps* maps, const __global SpmCamera* cam, float3 o, float3 d,
                       float tmin, float tmax, uint max_depth, bool emission, float volume_weight, SpmRng rng,
                       SpmSurfaceReuse* reuse, SpmVolumeReuse* volume_reuse, uint* tests) {
  float3 L = (float3)(0.0f);
  float3 beta = (float3)(1.0f);
  uint specular = 0;
  bool crossed_medium = false;
  /* Past a glossy vertex the emission a path meets is its own whatever
   * `emission` says (emission_chains stop there); glossy_pdf: the last
   * vertex's sampling density while it was glossy, else 0, and glossy_x
   * where it was. */
  const bool direct_emission = maps->direct_terms && (maps->terms & SPM_TERM_EMISSION);
  bool glossy = false;
  float glossy_pdf = 0.0f;
  float3 glossy_x = (float3)(0.0f);
  SpmWalk w;
  walk_path(&w, o, d, tmin, tmax, cam->medium, rng, SPM_TR_CAMERA);
  while (walk_next(s, &w)) {
    const SpmRng r = w.rng;
    if (w.medium >= 0) {
      /* With next-event estimation single scattering (depth 1) is its. */
      const uint min_depth = maps->direct == SPM_DIRECT_NEE ? 2u : 0u;
      const uint depth_limit = record_depth_limit(max_depth, specular);
      /* The first medium segment of the straight camera ray is shared
       * (camera_volume_estimate); null boundaries before it leave it straight. */
      const bool first = specular == 0u && !crossed_medium;
      crossed_medium = true;
      if ((maps->terms & SPM_TERM_VOLUME) && volume_weight > 0.0f) {
        L += beta * volume_weight *
             (first ? camera_volume_estimate(volume_reuse, s, maps, w.medium, w.o, w.d, w.t0, w.t1, min_depth,
                                             depth_limit, tests)
                    : volume_estimate(s, maps, SPM_READ_CAMERA, w.medium, w.o, w.d, w.t0, w.t1, min_depth,
                                      depth_limit, tests));
      }
      /* Single scattering makes the path specular + 2 segments long. */
      if (maps->direct_terms && (maps->terms & SPM_TERM_INSCATTER) && maps->direct == SPM_DIRECT_NEE &&
          within_depth(specular + 2u, max_depth)) {
        L += beta * medium_nee(s, w.medium, w.o, w.d, w.t0, w.t1, maps->march_step, r);
      }
    }
    /* Escaping: outside a medium the path sees the environment maps
     * (METHOD.md 14), as it sees emission on a surface; inside one, which
     * then has no boundary, nothing reaches infinity. */
    if (!w.hit) {
      if (w.medium < 0 && (glossy ? direct_emission : emission))
        L += beta * escaped_emission(s, w.d, specular, max_depth, glossy_pdf);
      break;
    }
    beta *= walk_transmittance(s, &w, maps->march_step);
    const SpmSurface surf = w.surf;
    const __global SpmMaterial* m = w.material;
    /* Emission seen directly or through delta chains, unless the pixel's
     * emission chains bring it (emission_chains); past a glossy vertex,
     * weighed against that vertex's next-event estimation. Paths read
     * the maps at diffuse vertices, whose light NEE and the photon maps
     * provide. */
    if (glossy ? direct_emission : emission) {
      const float3 le = seen_emission(s, w.shape, &surf, w.d, specular, max_depth);
      if (max_comp(le) > 0.0f)
        L += beta * le * (glossy_pdf > 0.0f ? glossy_emission(s, w.shape, &surf, glossy_x, glossy_pdf) : 1.0f);
    }
    if (w.state == SPM_WALK_CROSS) continue;
    if (has_diffuse(m->type) && reflects_from(m, &surf, w.d)) {
      const float3 n = facing_normal(&surf, w.d);
      const float3 exit = diffuse_exit(m, -dot(w.d, n));
      const bool nee = maps->direct_terms && (maps->terms & SPM_TERM_DIRECT) && maps->direct == SPM_DIRECT_NEE &&
                       within_depth(specular + 2u, max_depth);
      if (nee) L += beta * direct_diffuse(s, &surf, m, w.d, w.medium, maps->march_step, r);
      const uint depth_limit = record_depth_limit(max_depth, specular);
      if (maps->final_gather) {
        float3 caustic = (float3)(0.0f), gathered = (float3)(0.0f);
        if (maps->terms & SPM_TERM_SURFACE) {
          caustic = pixel_surface_estimate(reuse, &maps->table, SPM_READ_VERTEX, surf.p, n, maps->radius,
                                           depth_limit, s->patches, surf.patch);
        }
        if (maps->terms & SPM_TERMS_GATHER) {
          gathered = final_gather(s, maps, &surf, m, w.d, w.medium, specular + 1u, max_depth, r, tests);
        }
        L += beta * exit * (SPM_INV_PI * caustic + gathered);
      } else if (maps->terms & SPM_TERM_SURFACE) {
        const float3 flux = pixel_surface_estimate(reuse, &maps->table, SPM_READ_VERTEX, surf.p, n, maps->radius,
                                                   depth_limit, s->patches, surf.patch);
        L += beta * exit * SPM_INV_PI * flux;
      }
    }
    if (m->type == SPM_MAT_DIFFUSE) break;
    if (is_glossy(m->type)) {
      /* Without next-event estimation (direct photons) the lobe's samples
       * bring all of the light they meet. */
      const bool nee_strategy = maps->direct == SPM_DIRECT_NEE;
      const bool nee = nee_strategy && maps->direct_terms && (maps->terms & SPM_TERM_DIRECT);
      glossy_x = surf.p;
      if (!glossy_turn(s, maps, &w, r, max_depth, nee, &specular, &beta, &glossy_pdf, &L)) break;
      if (!nee_strategy) glossy_pdf = 0.0f;
      glossy = true;
      continue;
    }
    glossy_pdf = 0.0f;
    if (!specular_turn(&w, r, SPM_RNG_BSDF, 0u, max_depth, &specular, &beta)) break;
  }
  return L;
}

/* Pixels are gathered in blocks of SPM_GATHER_BLOCK x SPM_GATHER_BLOCK, one
 * block per work-item (spm_types.h), so that neighbouring pixels' samples
 * share surface estimates (pixel_surface_estimate) and the volume estimate
 * of the camera ray's first medium segment (volume_reuse_hit, both in
 * lib/maps.h): at 1 sample per pixel the 2x2 pixels then read one disk
 * instead of four while the disk spans several pixels. */
__kernel void spm_gather(SPM_SCENE_PARAMS, SpmGatherParams params, const __global SpmCamera* camera,
                         __global float4* film, __global uint* errors,
                         const __global uchar* chain_pixels SPM_MAP_PARAMS) {
  /* A tile of `count` pixels from first_pixel: the film of a whole image may
   * not fit one allocation. A block that straddles the tile's ends is
   * gathered whole and writes only its pixels in the tile, so that every
   * pixel's value, reuse included, is the same however the image is tiled. */
  const uint first_pixel = params.first_pixel, count = params.count;
  const uint width = camera->width;
  const uint blocks_x = (width + SPM_GATHER_BLOCK - 1u) / SPM_GATHER_BLOCK;
  const uint block_row0 = first_pixel / width / SPM_GATHER_BLOCK;
  const uint last = first_pixel + count - 1u;
  const uint item = get_global_id(0);
  if (item >= (last / width / SPM_GATHER_BLOCK - block_row0 + 1u) * blocks_x) return;
  const uint bx = item % blocks_x;
  const uint by = block_row0 + item / blocks_x;
  const SpmScene s = SPM_SCENE;
  SpmMaps maps;
  maps.table = make_map_table(grids, params.grids, grid_cells, grid_pos, surface_flux, volume_records, beams,
                              params.density_kernel, params.estimator, params.radius_scale);
  maps.final_gather = params.final_gather;
  maps.march_step = params.march_step;
  maps.radius = params.radius;
  maps.volume_radius = params.volume_radius;
  maps.gather_aim = params.gather_aim;
  maps.estimator = params.estimator;
  maps.direct = params.direct;
  maps.direct_terms = params.direct_terms;
  maps.terms = params.terms;
  SpmSurfaceReuse reuse = surface_reuse_empty();
  SpmVolumeReuse volume_reuse = volume_reuse_empty();
  const bool emission = params.direct_terms && (params.terms & SPM_TERM_EMISSION);
  for (uint q = 0; q < SPM_GATHER_BLOCK * SPM_GATHER_BLOCK; ++q) {
    const uint px = SPM_GATHER_BLOCK * bx + q % SPM_GATHER_BLOCK;
    const uint py = SPM_GATHER_BLOCK * by + q / SPM_GATHER_BLOCK;
    if (px >= width || py >= camera->height) continue;
    const uint pixel = py * width + px;
    /* A pixel of the block outside the tile writes nothing, so its emission
     * needs no flag. */
    const bool in_tile = pixel >= first_pixel && pixel <= last;
    const bool chains = emission && params.emission_chains > 0u && in_tile && chain_pixels[pixel - first_pixel];
    uint tests = 0;
    float3 sum = (float3)(0.0f);
    for (uint i = 0; i < params.spp; ++i) {
      /* Events: a block of SPM_SAMPLE_EVENTS per sample, which its walks
       * share out (lib/walk.h). */
      SpmRng rng = rng_gather(params.seed, params.pass, pixel, i * SPM_SAMPLE_EVENTS);
      rng.sample = params.first_sample + i;
      rng.strata = params.strata_seed;
      const float2 u = stratify2(rng, SPM_RNG_CAMERA, 0u);
      const float2 off = sample_filter(camera, u.x, u.y);
      float3 o;
      float tmin, tmax;
      const float3 d = camera_ray(camera, (float)px + 0.5f + off.x, (float)py + 0.5f + off.y, &o, &tmin, &tmax);
      /* The camera segments' volume estimate reads the same pass's records
       * for every sample of the pixel, so its noise is the pass's photon
       * noise, which more samples do not average away, while it is the
       * gather's costliest term: the first volume_samples samples add it
       * for all (each sample's point of the pixel is uniform, so the mean
       * stays; docs/experiments/volume-kernels.md "Camera volume estimates for one sample in four"). */
      const float volume_weight = i < params.volume_samples ? (float)params.spp / (float)params.volume_samples : 0.0f;
      sum += radiance(&s, &maps, camera, o, d, tmin, tmax, params.max_depth, emission && !chains, volume_weight, rng,
                      &reuse, &volume_reuse, &tests);
      if (chains) sum += emission_chains(&s, &maps, camera, px, py, params.max_depth, rng, params.emission_chains);
    }
    if (!in_tile) continue;
    /* A NaN or infinity is a bug to find, not a value to clamp: the host
     * fails the render when this bit is set. */
    if (!all(isfinite(sum))) atomic_or(errors, SPM_ERROR_NONFINITE);
    /* w: the sphere tests of the pixel's samples, for the profile. */
    film[pixel - first_pixel] = (float4)(sum / (float)params.spp, as_float(tests));
  }
}

/* spm_chain_pixels: one work-item per pixel of a tile of `count` from
 * first_pixel. To: chain_pixels, 1 where a corner of the pixel sees a
 * mirror or glass (sees_chain_start), whose emission spm_gather then
 * takes from emission_chains. The probe draws no random numbers and does
 * not depend on the pass, so each pixel's emission has the same estimator
 * in every pass and on every device, and the gather's estimate stays
 * unbiased whichever pixels it flags. Run once per tile, not per pass, and
 * not at all in a scene without mirrors or glass (PassRenderer). A light
 * seen directly is left to the samples' own paths: their points of the
 * pixel are stratified across the render, so its silhouette converges
 * fast, and the probe alone cost Fig. 3 (b)'s one pass 13%. */
__kernel void spm_chain_pixels(SPM_SCENE_PARAMS, const __global SpmCamera* camera, __global uchar* chain_pixels,
                               uint first_pixel, uint count) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  const SpmScene s = SPM_SCENE;
  const uint pixel = first_pixel + i;
  const float px = (float)(pixel % camera->width), py = (float)(pixel / camera->width);
  chain_pixels[i] = (uchar)(sees_chain_start(&s, camera, px, py) || sees_chain_start(&s, camera, px + 1.0f, py) ||
                            sees_chain_start(&s, camera, px, py + 1.0f) ||
                            sees_chain_start(&s, camera, px + 1.0f, py + 1.0f));
}
