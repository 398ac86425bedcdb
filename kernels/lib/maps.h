/* The photon maps as the gather reads them: the grid table of
 * kernels/spm_maps.h and the buffers its rows share, and each reader's
 * estimate (SPM_READ_*: a camera segment, a gather ray, the camera's
 * vertex, ...) as the sum over every grid the table says it reads, with
 * the radius it says (METHOD.md 5, 17). Which grids there are and who reads
 * them is the host's table (host/spm/map_grids.cpp); nothing here names a
 * grid. */
#ifndef SPM_LIB_MAPS_H
#define SPM_LIB_MAPS_H

#include "../spm_maps.h"
#include "estimate.h"

typedef struct SpmMapTable {
  const __global SpmMapGrid* grids;
  uint rows;
  const __global uint* cells;
  const __global float4* pos;
  const __global float4* surface_flux;
  const __global SpmVolumeRecord* volume_records;
  const __global SpmBeam* beams;
  uint density_kernel; /* SPM_KERNEL_* */
  uint estimator;      /* SPM_ESTIMATOR_*: the sphere grids' weights (beam_estimate) */
  float scale;         /* every row's radius times this (SpmGatherParams.radius_scale) */
  /* Per reader, a bit per row it reads, so that an estimate visits those
   * rows alone; at most 32 rows. */
  uint reads[SPM_READERS];
} SpmMapTable;

inline SpmMapTable make_map_table(const __global SpmMapGrid* grids, uint rows, const __global uint* cells,
                                  const __global float4* pos, const __global float4* surface_flux,
                                  const __global SpmVolumeRecord* volume_records, const __global SpmBeam* beams,
                                  uint density_kernel, uint estimator, float scale) {
  SpmMapTable t;
  t.grids = grids;
  t.rows = rows;
  t.cells = cells;
  t.pos = pos;
  t.surface_flux = surface_flux;
  t.volume_records = volume_records;
  t.beams = beams;
  t.density_kernel = density_kernel;
  t.estimator = estimator;
  t.scale = scale;
  for (uint r = 0; r < SPM_READERS; ++r) t.reads[r] = 0u;
  for (uint g = 0; g < rows; ++g) {
    for (uint r = 0; r < SPM_READERS; ++r) t.reads[r] |= grids[g].radius[r] > 0.0f ? 1u << g : 0u;
  }
  return t;
}

/* The lowest row of a reader's bits (OpenCL C 1.2 has clz, not ctz). */
inline uint lowest_row(uint bits) { return 31u - clz(bits & (~bits + 1u)); }

/* Row g's grid. Filled through a pointer, not returned: a struct returned
 * from a function inlined in a loop leaves LLVM's noalias scope
 * declarations behind, which oclgrind 21.10 cannot run. */
inline void table_grid(const SpmMapTable* t, uint g, SpmGrid* grid) {
  grid->info = &t->grids[g].info;
  grid->cell_start = t->cells + t->grids[g].first_cell;
  grid->item_pos = t->pos + t->grids[g].first_item;
}

/* In-scattered radiance towards the camera along [t0, t1] of o + t d in
 * `medium` from every sphere or capsule grid `reader` reads, summed in the
 * table's order (beam_estimate, stream_beam_estimate); `tab` as they take
 * it, *tests counts the records examined. */
inline float3 table_volume_estimate(const SpmMapTable* t, uint reader, const __global SpmMedium* media,
                                    const __global SpmPatch* patches, int medium, float3 o, float3 d, float t0,
                                    float t1, uint min_depth, uint max_depth, const SpmMediumTable* tab,
                                    uint* tests) {
  float3 sum = (float3)(0.0f);
  for (uint bits = t->reads[reader]; bits != 0u; bits &= bits - 1u) {
    const uint g = lowest_row(bits);
    const __global SpmMapGrid* row = &t->grids[g];
    const float r = row->radius[reader] * t->scale;
    if (row->kind == SPM_GRID_DISKS) continue;
    SpmGrid grid;
    table_grid(t, g, &grid);
    if (row->kind == SPM_GRID_SPHERES) {
      sum += beam_estimate(&grid, t->volume_records, media, patches, medium, o, d, t0, t1, r, t->density_kernel,
                           t->estimator, min_depth, max_depth, tab, tests);
    } else {
      sum += stream_beam_estimate(&grid, t->beams, media, medium, o, d, t0, t1, r, t->density_kernel, min_depth,
                                  max_depth, tab, tests);
    }
  }
  return sum;
}

/* Photon flux density at x on a surface seen from the side of n, from
 * every disk grid `reader` reads (surface_estimate). */
inline float3 table_surface_estimate(const SpmMapTable* t, uint reader, float3 x, float3 n, uint max_depth,
                                     const SpmPatchFrame* patch) {
  float3 sum = (float3)(0.0f);
  for (uint bits = t->reads[reader]; bits != 0u; bits &= bits - 1u) {
    const uint g = lowest_row(bits);
    const __global SpmMapGrid* row = &t->grids[g];
    const float r = row->radius[reader] * t->scale;
    if (row->kind != SPM_GRID_DISKS) continue;
    SpmGrid grid;
    table_grid(t, g, &grid);
    sum += surface_estimate(&grid, t->surface_flux + row->first_item, x, n, r, t->density_kernel, max_depth, patch);
  }
  return sum;
}

/* The surface estimate the samples of a block of pixels share (one block
 * per work-item, spm_gather.cl). A sample whose diffuse vertex lies within
 * SPM_REUSE_DISTANCE r of the point the last estimate was made at, on a
 * surface facing the same way, with the same record depth limit, reads
 * that estimate instead of summing the disk again: the disk of radius r is
 * far larger than a pixel's footprint once r spans several pixels (Fig. 3
 * (b): a pixel is 0.13 r on the back wall), so the estimates at the block's
 * samples differ by the few records at the disks' rims, and each sample
 * reads an estimate whose disk lies within (1 + SPM_REUSE_DISTANCE) r of
 * its own vertex. The reach scales with r, so as the passes shrink r below
 * a few pixels the reuse stops and the estimate stays consistent
 * (METHOD.md 21). */

typedef struct SpmSurfaceReuse {
  float3 p, n, flux;
  uint depth_limit; /* SPM_NONE - 1 marks an empty entry: no path uses it */
  uint patch;
} SpmSurfaceReuse;

inline SpmSurfaceReuse surface_reuse_empty(void) {
  SpmSurfaceReuse r;
  r.p = r.n = r.flux = (float3)(0.0f);
  r.depth_limit = SPM_NONE - 1u;
  r.patch = SPM_NONE;
  return r;
}

/* Shared only on the same patch: the estimates of two patches differ by
 * their edges' images even where the patches meet in one plane. `r`: the
 * pass's radius, whose SPM_REUSE_DISTANCE is the reach. */
inline float3 pixel_surface_estimate(SpmSurfaceReuse* reuse, const SpmMapTable* t, uint reader, float3 x, float3 n,
                                     float r, uint depth_limit, const __global SpmPatch* patches, uint patch) {
  const float3 off = x - reuse->p;
  const float reach = SPM_REUSE_DISTANCE * r;
  if (reuse->depth_limit == depth_limit && reuse->patch == patch && dot(off, off) < reach * reach &&
      dot(n, reuse->n) > SPM_REUSE_COS)
    return reuse->flux;
  reuse->p = x;
  reuse->n = n;
  reuse->depth_limit = depth_limit;
  reuse->patch = patch;
  const SpmPatchFrame frame = patch_frame(patches, patch);
  reuse->flux = table_surface_estimate(t, reader, x, n, depth_limit, &frame);
  return reuse->flux;
}

/* The volume estimate along a camera ray's first medium segment, shared
 * by a block's samples as surface estimates are
 * (pixel_surface_estimate; spm_gather.cl): a segment whose two
 * ends lie within SPM_REUSE_DISTANCE r of the last estimated segment's, in
 * the same medium with the same record depths, reads that estimate. Both
 * segments are straight, so every point of one lies within that distance
 * of the other, and the records the two estimates read differ only at the
 * rims of their cylinders of radius r. As with surfaces the reach scales
 * with r, so the reuse stops once r spans a few pixels' footprint and the
 * estimate stays consistent. A segment that escapes (t1 infinite) is never
 * shared. */
typedef struct SpmVolumeReuse {
  float3 a, b, L; /* the segment's ends and its estimate */
  int medium;     /* -2 marks an empty entry: no segment has it */
  uint min_depth, max_depth;
} SpmVolumeReuse;

inline SpmVolumeReuse volume_reuse_empty(void) {
  SpmVolumeReuse r;
  r.a = r.b = r.L = (float3)(0.0f);
  r.medium = -2;
  r.min_depth = r.max_depth = 0u;
  return r;
}

/* Whether segment [t0, t1] of o + t d may read reuse->L; if not, and the
 * segment ends, the entry now describes it and the caller stores its
 * estimate in reuse->L. */
inline bool volume_reuse_hit(SpmVolumeReuse* reuse, float3 o, float3 d, float t0, float t1, int medium,
                             uint min_depth, uint max_depth, float r) {
  if (isinf(t1)) return false;
  const float3 a = o + t0 * d, b = o + t1 * d;
  const float reach = SPM_REUSE_DISTANCE * r;
  const float3 da = a - reuse->a, db = b - reuse->b;
  if (reuse->medium == medium && reuse->min_depth == min_depth && reuse->max_depth == max_depth &&
      dot(da, da) < reach * reach && dot(db, db) < reach * reach)
    return true;
  reuse->a = a;
  reuse->b = b;
  reuse->medium = medium;
  reuse->min_depth = min_depth;
  reuse->max_depth = max_depth;
  return false;
}

#endif
