/* Media (METHOD.md 3, 12): coefficients at a point, free flights and
 * transmittance. A homogeneous medium has them in closed form. A
 * heterogeneous one (Mitsuba 3's `heterogeneous` with `gridvolume`s) looks
 * sigma_t and albedo up in grids, which are 0 outside their unit cube, and
 * walks a coarse grid of majorants for delta and ratio tracking (pbrt-v4's
 * DDA majorant iterator) or marches in steps of Delta, the paper's step 1.
 * RGB sigma_t is sampled with the channel mean, as in the homogeneous case,
 * the ratio of true to sampled density carried as a per-channel weight. */
#ifndef SPM_LIB_MEDIUM_H
#define SPM_LIB_MEDIUM_H

#include "../spm_types.h"
#include "math.h"
#include "rng.h"
#include "scene.h"

/* Steps or tentative collisions a flight takes at most (an infinite medium
 * with a tiny P per step): past them it has no event. */
#define SPM_MAX_MARCH_STEPS (1u << 22)

inline bool medium_is_heterogeneous(const __global SpmMedium* m) {
  return m->sigma_t_grid >= 0 || m->albedo_grid >= 0;
}

/* World point and vector in the grid's unit-cube coordinates. */
inline float3 grid_point(const __global SpmGridVolume* g, float3 x) {
  const __global float* r = g->to_local;
  return SPM_F3(r[0] * x.x + r[1] * x.y + r[2] * x.z + r[3], r[4] * x.x + r[5] * x.y + r[6] * x.z + r[7],
                r[8] * x.x + r[9] * x.y + r[10] * x.z + r[11]);
}

inline float3 grid_vector(const __global SpmGridVolume* g, float3 v) {
  const __global float* r = g->to_local;
  return SPM_F3(r[0] * v.x + r[1] * v.y + r[2] * v.z, r[4] * v.x + r[5] * v.y + r[6] * v.z,
                r[8] * v.x + r[9] * v.y + r[10] * v.z);
}

/* Channels of voxel (x, y, z) (in range); one channel reads as grey. */
inline float3 grid_voxel(const __global SpmGridVolume* g, const __global float* data, uint x, uint y, uint z) {
  const __global float* v = data + g->offset + ((z * g->dims[1] + y) * g->dims[0] + x) * g->channels;
  return g->channels == 3u ? SPM_F3(v[0], v[1], v[2]) : SPM_F3(v[0], v[0], v[0]);
}

/* The grid's value at local point p: trilinear between texel centres at
 * (i + 0.5) / n, clamped to the border texels, or the nearest texel; 0
 * outside the unit cube, where the medium has no density. */
inline float3 grid_value(const __global SpmGridVolume* g, const __global float* data, float3 p) {
  if (!(p.x >= 0.0f && p.x <= 1.0f && p.y >= 0.0f && p.y <= 1.0f && p.z >= 0.0f && p.z <= 1.0f))
    return SPM_F3(0.0f, 0.0f, 0.0f);
  const int nx = (int)g->dims[0], ny = (int)g->dims[1], nz = (int)g->dims[2];
  if (g->filter == SPM_GRID_NEAREST) {
    return grid_voxel(g, data, (uint)min((int)(p.x * (float)nx), nx - 1), (uint)min((int)(p.y * (float)ny), ny - 1),
                      (uint)min((int)(p.z * (float)nz), nz - 1));
  }
  const float qx = p.x * (float)nx - 0.5f, qy = p.y * (float)ny - 0.5f, qz = p.z * (float)nz - 0.5f;
  const float fx = floor(qx), fy = floor(qy), fz = floor(qz);
  const float wx = qx - fx, wy = qy - fy, wz = qz - fz;
  const uint x0 = (uint)clamp((int)fx, 0, nx - 1), x1 = (uint)clamp((int)fx + 1, 0, nx - 1);
  const uint y0 = (uint)clamp((int)fy, 0, ny - 1), y1 = (uint)clamp((int)fy + 1, 0, ny - 1);
  const uint z0 = (uint)clamp((int)fz, 0, nz - 1), z1 = (uint)clamp((int)fz + 1, 0, nz - 1);
  const float3 c00 = mix(grid_voxel(g, data, x0, y0, z0), grid_voxel(g, data, x1, y0, z0), wx);
  const float3 c10 = mix(grid_voxel(g, data, x0, y1, z0), grid_voxel(g, data, x1, y1, z0), wx);
  const float3 c01 = mix(grid_voxel(g, data, x0, y0, z1), grid_voxel(g, data, x1, y0, z1), wx);
  const float3 c11 = mix(grid_voxel(g, data, x0, y1, z1), grid_voxel(g, data, x1, y1, z1), wx);
  return mix(mix(c00, c10, wy), mix(c01, c11, wy), wz);
}

/* A coefficient at world point x: its factor times grid `grid`'s value
 * there, or the factor alone (grid < 0). */
inline float3 coefficient_at(const SpmMedia* md, const __global float* factor, int grid, float3 x) {
  const float3 f = load3(factor);
  if (grid < 0) return f;
  const __global SpmGridVolume* g = &md->grids[grid];
  return f * grid_value(g, md->grid_data, grid_point(g, x));
}

inline float3 medium_sigma_t(const SpmMedia* md, int m, float3 x) {
  return coefficient_at(md, md->media[m].sigma_t, md->media[m].sigma_t_grid, x);
}

inline float3 medium_albedo(const SpmMedia* md, int m, float3 x) {
  return coefficient_at(md, md->media[m].albedo, md->media[m].albedo_grid, x);
}

/* Clips [*t0, *t1] of the local ray p + t v to the unit cube; false when
 * nothing is left. */
inline bool clip_unit_cube(float3 p, float3 v, float* t0, float* t1) {
  const float3 inv = 1.0f / v;
  const float3 ta = -p * inv, tb = (1.0f - p) * inv;
  const float3 tn = fmin(ta, tb), tf = fmax(ta, tb);
  /* An axis the ray does not move along bounds no t (its slab gives 0 * inf
   * = NaN at a face), but the ray must lie within that slab. */
  const float enter = fmax(fmax(v.x != 0.0f ? tn.x : -SPM_INF, v.y != 0.0f ? tn.y : -SPM_INF),
                           fmax(v.z != 0.0f ? tn.z : -SPM_INF, *t0));
  const float leave = fmin(fmin(v.x != 0.0f ? tf.x : SPM_INF, v.y != 0.0f ? tf.y : SPM_INF),
                           fmin(v.z != 0.0f ? tf.z : SPM_INF, *t1));
  if ((v.x == 0.0f && !(p.x >= 0.0f && p.x <= 1.0f)) || (v.y == 0.0f && !(p.y >= 0.0f && p.y <= 1.0f)) ||
      (v.z == 0.0f && !(p.z >= 0.0f && p.z <= 1.0f)))
    return false;
  *t0 = enter;
  *t1 = leave;
  return enter < leave;
}

/* Clips [*t0, *t1] of o + t d to grid gi's unit cube, outside which its
 * value is 0; gi < 0 (a constant) clips nothing. */
inline bool grid_clip(const SpmMedia* md, int gi, float3 o, float3 d, float* t0, float* t1) {
  if (gi < 0) return *t0 < *t1;
  const __global SpmGridVolume* g = &md->grids[gi];
  return clip_unit_cube(grid_point(g, o), grid_vector(g, d), t0, t1);
}

/* The part of [*t0, *t1] of o + t d where medium m can scatter: inside the
 * cubes of both its grids. Extinction needs only sigma_t's (grid_clip). */
inline bool medium_clip(const SpmMedia* md, int m, float3 o, float3 d, float* t0, float* t1) {
  return grid_clip(md, md->media[m].sigma_t_grid, o, d, t0, t1) &&
         grid_clip(md, md->media[m].albedo_grid, o, d, t0, t1);
}

/* DDA over the majorant cells a local ray crosses (METHOD.md 12). */
typedef struct SpmMajorantWalk {
  int3 cell;
  int3 step;
  float3 t_next;
  float3 t_delta;
  float t;     /* where the current cell starts */
  float t_end; /* where the walk ends */
} SpmMajorantWalk;

inline bool majorant_begin(const __global SpmGridVolume* g, float3 p, float3 v, float t0, float t1,
                           SpmMajorantWalk* w) {
  if (!clip_unit_cube(p, v, &t0, &t1)) return false;
  const float3 n = SPM_F3((float)g->majorant_dims[0], (float)g->majorant_dims[1], (float)g->majorant_dims[2]);
  const float3 q = (p + t0 * v) * n;
  w->cell = (int3)(clamp((int)q.x, 0, (int)g->majorant_dims[0] - 1), clamp((int)q.y, 0, (int)g->majorant_dims[1] - 1),
                   clamp((int)q.z, 0, (int)g->majorant_dims[2] - 1));
  w->step = (int3)(v.x < 0.0f ? -1 : 1, v.y < 0.0f ? -1 : 1, v.z < 0.0f ? -1 : 1);
  const float3 bound = (convert_float3(w->cell) + SPM_F3(v.x < 0.0f ? 0.0f : 1.0f, v.y < 0.0f ? 0.0f : 1.0f,
                                                        v.z < 0.0f ? 0.0f : 1.0f)) / n;
  w->t_next = SPM_F3(v.x != 0.0f ? (bound.x - p.x) / v.x : SPM_INF, v.y != 0.0f ? (bound.y - p.y) / v.y : SPM_INF,
                     v.z != 0.0f ? (bound.z - p.z) / v.z : SPM_INF);
  w->t_delta = SPM_F3(v.x != 0.0f ? 1.0f / (n.x * fabs(v.x)) : SPM_INF, v.y != 0.0f ? 1.0f / (n.y * fabs(v.y)) : SPM_INF,
                      v.z != 0.0f ? 1.0f / (n.z * fabs(v.z)) : SPM_INF);
  w->t = t0;
  w->t_end = t1;
  return true;
}

/* Where the current cell ends along the ray. */
inline float majorant_exit(const SpmMajorantWalk* w) {
  return fmin(w->t_end, fmin(w->t_next.x, fmin(w->t_next.y, w->t_next.z)));
}

/* Moves to the next cell; false past the walk's end or the grid. */
inline bool majorant_next(const __global SpmGridVolume* g, SpmMajorantWalk* w) {
  w->t = majorant_exit(w);
  if (w->t >= w->t_end) return false;
  const int axis = w->t_next.x <= w->t_next.y && w->t_next.x <= w->t_next.z ? 0 : (w->t_next.y <= w->t_next.z ? 1 : 2);
  if (axis == 0) {
    w->cell.x += w->step.x;
    w->t_next.x += w->t_delta.x;
    return w->cell.x >= 0 && w->cell.x < (int)g->majorant_dims[0];
  }
  if (axis == 1) {
    w->cell.y += w->step.y;
    w->t_next.y += w->t_delta.y;
    return w->cell.y >= 0 && w->cell.y < (int)g->majorant_dims[1];
  }
  w->cell.z += w->step.z;
  w->t_next.z += w->t_delta.z;
  return w->cell.z >= 0 && w->cell.z < (int)g->majorant_dims[2];
}

inline float majorant_of(const __global SpmGridVolume* g, const __global float* data, int3 c) {
  return data[g->majorant_offset + ((uint)c.z * g->majorant_dims[1] + (uint)c.y) * g->majorant_dims[0] + (uint)c.x];
}

/* Tentative collisions of delta and ratio tracking along a ray through a
 * medium's sigma_t grid: exponential steps against each majorant cell's
 * bound, a fresh one where a step leaves its cell (the exponential has no
 * memory). Draw k uses lane `lane + k` of `purpose`, one float4 each. */
typedef struct SpmTracking {
  SpmMajorantWalk walk;
  const __global SpmGridVolume* grid;
  float scale; /* max_comp of the medium's sigma_t factor: the majorant bounds every channel */
  float mu;    /* majorant of the current cell */
  float t;     /* the current tentative collision */
  uint k;      /* draws so far */
} SpmTracking;

/* Starts on [t0, t1] of o + t d; false when it misses the grid. Medium m
 * must have a sigma_t grid. */
inline bool tracking_begin(const SpmMedia* md, int m, float3 o, float3 d, float t0, float t1, SpmTracking* tr) {
  const __global SpmMedium* med = &md->media[m];
  tr->grid = &md->grids[med->sigma_t_grid];
  if (!majorant_begin(tr->grid, grid_point(tr->grid, o), grid_vector(tr->grid, d), t0, t1, &tr->walk)) return false;
  tr->scale = max_comp(load3(med->sigma_t));
  tr->mu = tr->scale * majorant_of(tr->grid, md->grid_data, tr->walk.cell);
  tr->t = tr->walk.t;
  tr->k = 0;
  return true;
}

/* Moves to the next tentative collision, tr->t, and gives the draw that
 * placed it (u->x made the step; the others are the caller's); false past
 * the walk's end or SPM_MAX_MARCH_STEPS draws. */
inline bool tracking_next(const SpmMedia* md, SpmTracking* tr, SpmRng rng, uint purpose, uint lane, float4* u) {
  for (;;) {
    if (tr->k >= SPM_MAX_MARCH_STEPS) return false;
    if (tr->mu > 0.0f) {
      *u = rng4(rng, purpose, lane + tr->k++);
      tr->t -= log(1.0f - u->x) / tr->mu;
      if (tr->t < majorant_exit(&tr->walk)) return true;
    }
    if (!majorant_next(tr->grid, &tr->walk)) return false;
    tr->t = tr->walk.t;
    tr->mu = tr->scale * majorant_of(tr->grid, md->grid_data, tr->walk.cell);
  }
}

/* Whether sigma_t is grey everywhere, so that no channel weight is needed. */
inline bool medium_grey(const SpmMedia* md, int m) {
  const __global SpmMedium* med = &md->media[m];
  const bool factor = med->sigma_t[0] == med->sigma_t[1] && med->sigma_t[1] == med->sigma_t[2];
  return factor && (med->sigma_t_grid < 0 || md->grids[med->sigma_t_grid].channels == 1u);
}

/* Distance to the next event of a flight along o + t d, t in [0, tmax), in
 * medium m, which has a sigma_t grid, or SPM_INF when it gets through; *weight is
 * multiplied by the per-channel ratio of the true to the sampled flight
 * density (1 in a grey medium). step > 0: the paper's ray marching from
 * the grids' cube, sigma_t at each step's midpoint, an event in a step with
 * P = 1 - exp(-mean sigma_t step), placed by the exponential truncated to the
 * step. step = 0: delta tracking against the majorant grid; a tentative
 * collision is real with probability mean sigma_t / majorant, and with RGB
 * the weights of spectral tracking (Kutz et al. 2017) keep it unbiased per
 * channel, the majorant bounding every channel. */
inline float heterogeneous_flight(const SpmMedia* md, int m, float3 o, float3 d, float tmax, float step, SpmRng rng,
                                  float3* weight) {
  float t0 = 0.0f, t1 = tmax;
  if (!grid_clip(md, md->media[m].sigma_t_grid, o, d, &t0, &t1)) return SPM_INF;
  const bool grey = medium_grey(md, m);
  if (step > 0.0f) {
    for (uint k = 0; k < SPM_MAX_MARCH_STEPS; ++k) {
      const float a = t0 + (float)k * step;
      if (a >= t1) break;
      const float len = fmin(step, t1 - a);
      const float3 sigma = medium_sigma_t(md, m, o + (a + 0.5f * len) * d);
      const float mean = mean_comp(sigma);
      const float4 u = rng4(rng, SPM_RNG_DISTANCE, k / 2u);
      const float2 uk = (k & 1u) ? u.zw : u.xy;
      const float p = -expm1(-mean * len);
      if (mean > 0.0f && uk.x < p) {
        const float s = -log1p(-uk.y * p) / mean;
        if (!grey) *weight *= sigma / mean * exp(-(sigma - mean) * s);
        return a + s;
      }
      if (!grey) *weight *= exp(-(sigma - mean) * len);
    }
    return SPM_INF;
  }
  SpmTracking tr;
  if (!tracking_begin(md, m, o, d, t0, t1, &tr)) return SPM_INF;
  float4 u;
  while (tracking_next(md, &tr, rng, SPM_RNG_DISTANCE, 0u, &u)) {
    const float3 sigma = medium_sigma_t(md, m, o + tr.t * d);
    const float mean = mean_comp(sigma);
    if (u.y * tr.mu < mean) {
      if (!grey) *weight *= sigma / mean;
      return tr.t;
    }
    if (!grey) *weight *= (tr.mu - sigma) / (tr.mu - mean);
  }
  return SPM_INF;
}

/* Transmittance of medium m along [t0, t1] of o + t d (paper eq. 2):
 * closed form when sigma_t is constant; else the same marching as the
 * flights for step > 0 (sigma_t at each step's midpoint), or ratio tracking
 * against the majorant grid for step = 0 (Novak et al. 2014), an unbiased
 * estimate. `lane` picks this call's numbers among the sample's. */
inline float3 medium_transmittance(const SpmMedia* md, int m, float3 o, float3 d, float t0, float t1, float step,
                                   SpmRng rng, uint lane) {
  if (m < 0 || !(t1 > t0)) return SPM_F3(1.0f, 1.0f, 1.0f);
  const __global SpmMedium* med = &md->media[m];
  if (med->sigma_t_grid < 0) return exp(-load3(med->sigma_t) * (t1 - t0));
  if (!grid_clip(md, med->sigma_t_grid, o, d, &t0, &t1)) return SPM_F3(1.0f, 1.0f, 1.0f);
  if (step > 0.0f) {
    float3 tau = SPM_F3(0.0f, 0.0f, 0.0f);
    for (uint k = 0; k < SPM_MAX_MARCH_STEPS; ++k) {
      const float a = t0 + (float)k * step;
      if (a >= t1) break;
      const float len = fmin(step, t1 - a);
      tau += medium_sigma_t(md, m, o + (a + 0.5f * len) * d) * len;
    }
    return exp(-tau);
  }
  float3 transmittance = SPM_F3(1.0f, 1.0f, 1.0f);
  SpmTracking tr;
  if (!tracking_begin(md, m, o, d, t0, t1, &tr)) return transmittance;
  float4 u;
  while (tracking_next(md, &tr, rng, SPM_RNG_TRANSMITTANCE, lane, &u)) {
    transmittance *= fmax(1.0f - medium_sigma_t(md, m, o + tr.t * d) / tr.mu, 0.0f);
    if (max_comp(transmittance) <= 0.0f) break;
  }
  return transmittance;
}

/* Optical depth from `t` and albedo along one piece of a camera segment in
 * a heterogeneous medium, at knots t + k h: computed once for the piece
 * and read by every record on it (METHOD.md 12), never marched per record.
 * tau by the midpoint rule with h = Delta, or half a voxel for Delta = 0;
 * both are linear between the knots. */
typedef struct SpmMediumTable {
  float t;
  float h;
  uint n;
  float3 tau[SPM_TABLE_KNOTS];
  float3 albedo[SPM_TABLE_KNOTS];
} SpmMediumTable;

inline void medium_table_fill(const SpmMedia* md, int m, float3 o, float3 d, float t, float h, uint n,
                              SpmMediumTable* tab) {
  tab->t = t;
  tab->h = h;
  tab->n = n;
  float3 tau = SPM_F3(0.0f, 0.0f, 0.0f);
  for (uint k = 0; k < n; ++k) {
    tab->tau[k] = tau;
    tab->albedo[k] = medium_albedo(md, m, o + (t + (float)k * h) * d);
    tau += medium_sigma_t(md, m, o + (t + ((float)k + 0.5f) * h) * d) * h;
  }
}

/* sigma_t at t: the midpoint value of the table's step holding t, the
 * slope of its optical depth. */
inline float3 medium_table_sigma_t(const SpmMediumTable* tab, float t) {
  const uint k = min((uint)clamp((t - tab->t) / tab->h, 0.0f, (float)(tab->n - 1u)), tab->n - 2u);
  return (tab->tau[k + 1u] - tab->tau[k]) / tab->h;
}

/* Optical depth from the table's start to t, and the albedo at t. */
inline float3 medium_table_depth(const SpmMediumTable* tab, float t, float3* albedo) {
  const float x = clamp((t - tab->t) / tab->h, 0.0f, (float)(tab->n - 1u));
  const uint k = min((uint)x, tab->n - 2u);
  const float f = x - (float)k;
  *albedo = mix(tab->albedo[k], tab->albedo[k + 1u], f);
  return mix(tab->tau[k], tab->tau[k + 1u], f);
}

#endif
