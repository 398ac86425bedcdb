/* Density estimates of the gather (METHOD.md 5, 11): the beam radiance
 * estimate over the volumetric stream map through its host-built sphere
 * grid, the stream beams' estimate through their capsule grid, and the
 * surface estimate over the surface photon map through its point grid. */
#ifndef SPM_LIB_ESTIMATE_H
#define SPM_LIB_ESTIMATE_H

#include "grid.h"
#include "intersect.h"
#include "medium.h"
#include "phase.h"

/* 2D kernel normalised over the disk of radius r (d2, r2: squared distance
 * and radius): uniform 1/(pi r^2), or Epanechnikov 2/(pi r^2) (1 - d^2/r^2),
 * the smooth kernel the paper leaves to future work. */
inline float kernel_2d(uint density_kernel, float d2, float r2) {
  if (density_kernel == SPM_KERNEL_EPANECHNIKOV) return 2.0f * SPM_INV_PI / r2 * (1.0f - d2 / r2);
  return SPM_INV_PI / r2;
}

/* How beam_estimate weighs a record (SPM_ESTIMATOR_PAPER; bre with the
 * transmittance of a grey or coloured homogeneous medium, or from a
 * heterogeneous medium's table). */
#define SPM_BRE_PAPER 0u
#define SPM_BRE_GREY 1u
#define SPM_BRE_COLOURED 2u
#define SPM_BRE_TABLE 3u

/* In-scattered radiance towards the camera along [t0, t1] of o + t d (unit d)
 * inside medium `m`, with transmittance measured from t0 (the caller applies
 * the throughput up to t0). Each record whose sphere of radius r the segment
 * crosses is counted once: in the cell whose span of the walk holds its
 * closest point on the ray (grid_walk_out).
 * - bre: sum_i K(d_i) T(t_i) albedo p(theta_i) (n phi)_i (Jarosz et al. 2008);
 *   in a heterogeneous medium T and the albedo come from the segment's
 *   table `tab` (tab->n > 0; medium.h), else in closed form;
 * - paper: sum_i (n phi)_i / (pi r^2 (t1 - t0)), eq. (4) literally.
 * Item k lists record records[as_uint(item_pos[k].w)]. Records deeper than
 * max_rec_depth are left out: their paths would be longer than max_depth
 * (METHOD.md 10); records shallower than min_rec_depth too (2: single
 * scattering comes from next-event estimation).
 * A record flagged SPM_RECORD_WALL lies near a wall (host/spm/wall_images.h)
 * and counts only where the ray's point is on its side of the wall's plane
 * (`patches` holds it), so that a ray beyond the wall reads none; one
 * flagged SPM_RECORD_IMAGE too is the mirror image of such a record and
 * counts only on the other side, its record's.
 * *tests counts the records examined (the profile's sphere tests). */
inline float3 beam_estimate(const SpmGrid* grid, const __global SpmVolumeRecord* records,
                            const __global SpmMedium* media, const __global SpmPatch* patches, int m, float3 o,
                            float3 d, float t0, float t1, float r, uint density_kernel, uint estimator,
                            uint min_rec_depth, uint max_rec_depth, const SpmMediumTable* tab, uint* tests) {
  float3 sum = (float3)(0.0f);
  SpmGridWalk walk;
  if (grid->info->records == 0 || !grid_walk_begin(grid->info, o, d, t0, t1, &walk)) return sum;
  const float r2 = r * r;
  const float3 sigma_t = load3(media[m].sigma_t);
  const float g = media[m].phase == SPM_PHASE_HG ? media[m].g : 0.0f;
  /* Decided once, not per record (a grey medium's transmittance is one
   * exponential, not three). */
  const uint kind = estimator == SPM_ESTIMATOR_PAPER
                        ? SPM_BRE_PAPER
                        : (tab->n > 0u ? SPM_BRE_TABLE
                                       : (sigma_t.x == sigma_t.y && sigma_t.y == sigma_t.z ? SPM_BRE_GREY
                                                                                            : SPM_BRE_COLOURED));
  uint examined = 0;
  do {
    const uint c = grid_cell_index(grid->info, walk.cell);
    const float ta = fmax(t0, walk.t_in), tb = fmin(t1, grid_walk_out(&walk));
    for (uint k = grid->cell_start[c]; k < grid->cell_start[c + 1]; ++k) {
      ++examined;
      const float4 item = grid->item_pos[k];
      const float3 x = item.xyz;
      const float t = dot(x - o, d);
      const float3 off = x - (o + t * d);
      const float d2 = dot(off, off);
      /* Every item's record is read (its medium and side of a wall), so
       * its depth comes from there too. */
      const __global SpmVolumeRecord* rec = &records[as_uint(item.w)];
      const uint depth = rec->depth;
      bool in = (t >= ta) & (t < tb) & (d2 < r2) & (depth <= max_rec_depth) & (depth >= min_rec_depth) &
                (rec->medium == m);
      /* Records near walls are a few: a branch, not a select. */
      const uint stream = rec->stream;
      if (in && (stream & SPM_RECORD_WALL)) {
        const __global SpmPatch* wall = &patches[stream & SPM_RECORD_PATCH];
        const float3 c = load3(wall->center), n = cross(load3(wall->u), load3(wall->v));
        const float side = dot(o + t * d - c, n) * dot(x - c, n);
        in = (stream & SPM_RECORD_IMAGE) ? side < 0.0f : side >= 0.0f;
      }
      /* In a homogeneous medium every record's weight is computed and a
       * select keeps those in range: whether a record is in range depends
       * on the data, and branching on it cost more in mispredicted branches
       * than the terms themselves (docs/experiments/gather.md "A branch-free volume estimate").
       * The select picks, rather than multiplies by a 0/1 mask, since a
       * record out of range may have an infinite transmittance (t < t0). */
      if (kind == SPM_BRE_GREY) {
        const float w = in ? kernel_2d(density_kernel, d2, r2) * phase_hg(-dot(load3(rec->direction), d), g) *
                                 exp(-sigma_t.x * (t - t0))
                           : 0.0f;
        sum += w * load3(rec->flux);
      } else if (kind == SPM_BRE_COLOURED) {
        const float w = kernel_2d(density_kernel, d2, r2) * phase_hg(-dot(load3(rec->direction), d), g);
        sum += in ? w * exp(-sigma_t * (t - t0)) * load3(rec->flux) : (float3)(0.0f);
      } else if (kind == SPM_BRE_PAPER) {
        sum += in ? load3(rec->flux) : (float3)(0.0f);
      } else if (in) {
        float3 albedo;
        const float3 tau = medium_table_depth(tab, t, &albedo);
        sum += kernel_2d(density_kernel, d2, r2) * phase_hg(-dot(load3(rec->direction), d), g) * exp(-tau) *
               albedo * load3(rec->flux);
      }
    }
  } while (grid_walk_next(grid->info, &walk));
  *tests += examined;
  if (estimator == SPM_ESTIMATOR_PAPER) return sum / (SPM_PI * r2 * (t1 - t0));
  return tab->n > 0u ? sum : sum * load3(media[m].albedo);
}

/* 1D kernel normalised over [-r, r] (d2: squared distance): uniform
 * 1/(2r), or Epanechnikov 3/(4r) (1 - d^2/r^2). */
inline float kernel_1d(uint density_kernel, float d2, float r) {
  if (density_kernel == SPM_KERNEL_EPANECHNIKOV) return 0.75f / r * (1.0f - d2 / (r * r));
  return 0.5f / r;
}

/* In-scattered radiance towards the camera along [t0, t1] of o + t d (unit
 * d) inside medium `m` from the stream beams (METHOD.md 11), the beam x
 * beam 1D estimate of Jarosz et al. 2011 (their eq. for short beams): over
 * every beam whose closest approach to the ray lies on both, at distance
 * dist < r,
 *   K_1D(dist) / sin(theta) sigma_s T_ray(t_r) p(theta) (n phi) w(s_b),
 * t_r and s_b the closest points' parameters on the ray (from t0) and the
 * beam. A beam ends at the stream's sampled next event, which the stream
 * reached with probability exp(-mean(sigma_t) s) (march's free flight), so
 * instead of the beam's transmittance it carries
 * w(s) = exp(-(sigma_t - mean) s), 1 in a grey medium. In a heterogeneous
 * medium (tab->n > 0; grey, the only kind the host lets beams into) T_ray,
 * sigma_t and the albedo at the ray's point come from the segment's table
 * (medium.h), and w is 1: a point s along the beam is reached with the
 * probability its transmittance gives. Each beam is counted
 * in the one cell of its capsule grid whose span of the walk holds the
 * ray's closest point (grid_walk_out). Item k lists beam
 * beams[as_uint(item_pos[k].w)].
 * Beams deeper than max_rec_depth or shallower than min_rec_depth are left
 * out (METHOD.md 10; as in beam_estimate); beams within
 * 1e-3 of parallel to the ray, whose 1 / sin(theta) has no bound, too.
 * *tests counts the beams examined. */
inline float3 stream_beam_estimate(const SpmGrid* grid, const __global SpmBeam* beams,
                                   const __global SpmMedium* media, int m, float3 o, float3 d, float t0, float t1,
                                   float r, uint density_kernel, uint min_rec_depth, uint max_rec_depth,
                                   const SpmMediumTable* tab, uint* tests) {
  float3 sum = (float3)(0.0f);
  SpmGridWalk walk;
  const __global SpmGridInfo* info = grid->info;
  if (info->records == 0 || !grid_walk_begin(info, o, d, t0, t1, &walk)) return sum;
  const float r2 = r * r;
  const float3 sigma_t = load3(media[m].sigma_t);
  const float3 excess = sigma_t - mean_comp(sigma_t);
  const float g = media[m].phase == SPM_PHASE_HG ? media[m].g : 0.0f;
  do {
    const uint c = grid_cell_index(info, walk.cell);
    const float ta = fmax(t0, walk.t_in), tb = fmin(t1, grid_walk_out(&walk));
    for (uint k = grid->cell_start[c]; k < grid->cell_start[c + 1]; ++k) {
      ++*tests;
      const __global SpmBeam* b = &beams[as_uint(grid->item_pos[k].w)];
      if (b->medium != m || b->depth > max_rec_depth || b->depth < min_rec_depth) continue;
      const float3 e = vload3(0, b->direction);
      const float3 w0 = o - vload3(0, b->origin);
      const float a = dot(d, e);
      const float sin2 = 1.0f - a * a;
      if (sin2 < 1e-6f) continue;
      const float dw = dot(d, w0), ew = dot(e, w0);
      const float t = (a * ew - dw) / sin2;
      const float sb = (ew - a * dw) / sin2;
      if (!(t >= ta && t < tb) || sb < 0.0f || sb > b->length) continue;
      const float3 off = o + t * d - (vload3(0, b->origin) + sb * e);
      const float d2 = dot(off, off);
      if (d2 >= r2) continue;
      const float w = kernel_1d(density_kernel, d2, r) * rsqrt(sin2) * phase_hg(-a, g);
      if (tab->n > 0u) {
        float3 albedo;
        const float3 tau = medium_table_depth(tab, t, &albedo);
        sum += w * exp(-tau) * medium_table_sigma_t(tab, t) * albedo * vload3(0, b->flux);
      } else {
        sum += w * exp(-sigma_t * (t - t0) - excess * sb) * vload3(0, b->flux);
      }
    }
  } while (grid_walk_next(info, &walk));
  return tab->n > 0u ? sum : sum * sigma_t * load3(media[m].albedo);
}

/* Surface record normals ride in item_pos.w as three 10-bit components
 * q = 512 + round(511 n), which keep 0 exact: enough to tell the side a photon
 * arrived on, and a normal at right angles to the query's stays out. */
inline float3 unpack_normal(uint bits) {
  const int3 q = (int3)((int)(bits & 1023u), (int)((bits >> 10) & 1023u), (int)((bits >> 20) & 1023u));
  return convert_float3(q - 512) * (1.0f / 511.0f);
}

/* Photon flux density at x on a surface seen from the side of `n`: sum over
 * records in the disk of radius r around x in its tangent plane, arriving on
 * the same side, of K(d) phi. The grid is a point grid (each record once, in
 * its cell) holding only the records to use (with next-event estimation, not
 * those of streams without an earlier event); item_flux[k] is the flux of
 * item k's record, and item_flux[k].w its depth: deeper records than
 * max_rec_depth are left out (METHOD.md 10). The query visits every cell the
 * box [x - r, x + r] touches; the cells of one row are consecutive, and so
 * are their items.
 * When x lies on a patch whose edge the disk crosses, the part of the disk
 * beyond the edge holds no photons, and the plain sum would fall towards
 * half the density at an edge and a quarter at a corner. There the records
 * of the patch also count at their mirror images across each crossed edge
 * (and across both at a corner), the reflection method of kernel density
 * estimation (Silverman 1986, 2.10) that spm_deposit's fold matches, and
 * records beyond a crossed edge, on another surface in the same plane, are
 * left out. An image is never nearer x than its record, so the box
 * holds every record whose image reaches the disk. */
inline float3 surface_estimate(const SpmGrid* grid, const __global float4* item_flux, float3 x, float3 n, float r,
                               uint density_kernel, uint max_rec_depth, const SpmPatchFrame* patch) {
  float3 sum = (float3)(0.0f);
  if (grid->info->records == 0) return sum;
  const float r2 = r * r;
  const float2 q = patch_coords(patch, x);
  /* The crossed edges; an open bound is never crossed. */
  const int lo_u = patch->valid && q.x - r < patch->lo.x, hi_u = patch->valid && q.x + r > patch->hi.x;
  const int lo_v = patch->valid && q.y - r < patch->lo.y, hi_v = patch->valid && q.y + r > patch->hi.y;
  const int edges = lo_u || hi_u || lo_v || hi_v;
  /* Records this far beyond a bound still belong to the patch: they lie on
   * it up to float rounding. */
  const float slack = 1e-4f * r;
  /* Grown by a relative 1e-5: float rounding of x +- r must not drop the
   * cell of a record just inside the disk. */
  const float reach = r * 1.00001f;
  const int3 c0 = grid_cell_of(grid->info, x - reach);
  const int3 c1 = grid_cell_of(grid->info, x + reach);
  for (int z = c0.z; z <= c1.z; ++z) {
    for (int y = c0.y; y <= c1.y; ++y) {
      const uint row = grid_cell_index(grid->info, (int3)(c0.x, y, z));
      const uint end = grid->cell_start[row + (uint)(c1.x - c0.x) + 1u];
      for (uint k = grid->cell_start[row]; k < end; ++k) {
        const float4 p = grid->item_pos[k];
        const float3 off = p.xyz - x;
        const float h = dot(off, n);
        const float d3 = dot(off, off);
        if (d3 >= r2 || fabs(h) > SPM_DISK_THICKNESS * r) continue;
        if (dot(unpack_normal(as_uint(p.w)), n) <= 0.0f) continue;
        const float4 flux = item_flux[k];
        if (flux.w > (float)max_rec_depth) continue;
        if (!edges) {
          sum += kernel_2d(density_kernel, d3 - h * h, r2) * flux.xyz;
          continue;
        }
        const float2 e = patch_coords(patch, p.xyz);
        if ((lo_u && e.x < patch->lo.x - slack) || (hi_u && e.x > patch->hi.x + slack) ||
            (lo_v && e.y < patch->lo.y - slack) || (hi_v && e.y > patch->hi.y + slack))
          continue;
        /* The record's coordinates and their images across the crossed
         * edges, u and v apart: an image pairs one of each. */
        const float su[3] = {e.x, lo_u ? 2.0f * patch->lo.x - e.x : e.x, hi_u ? 2.0f * patch->hi.x - e.x : e.x};
        const float sv[3] = {e.y, lo_v ? 2.0f * patch->lo.y - e.y : e.y, hi_v ? 2.0f * patch->hi.y - e.y : e.y};
        const int nu[3] = {1, lo_u, hi_u}, nv[3] = {1, lo_v, hi_v};
        const float h2 = h * h;
        float w = 0.0f;
        for (int a = 0; a < 3; ++a) {
          for (int b = 0; b < 3; ++b) {
            if (!nu[a] || !nv[b]) continue;
            const float du = q.x - su[a], dv = q.y - sv[b];
            const float d2 = du * du + dv * dv;
            if (d2 + h2 < r2) w += kernel_2d(density_kernel, d2, r2);
          }
        }
        sum += w * flux.xyz;
      }
    }
  }
  return sum;
}

#endif
