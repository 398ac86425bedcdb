/* Test entry points of the gather's estimates (kernels/lib/estimate.h), so
 * that they can be compared with a brute-force sum on the host.
 * spm_beam_test: one work-item per ray segment (origin xyz + t0, direction
 * xyz + t1); spm_stream_beam_test likewise over stream beams.
 * spm_surface_test: one per query point (xyz) with normal (xyz).
 * spm_shared_surface_test: one work-item through all the queries in order,
 * as a block's samples are, each with its own record depth limit;
 * spm_shared_beam_test likewise through ray segments, each with its own
 * maximum record depth (volume_reuse_hit). */
#include "spm_types.h"
#include "lib/estimate.h"

__kernel void spm_beam_test(const __global SpmGridInfo* info, const __global uint* cell_start,
                            const __global float4* item_pos, const __global uint* items,
                            const __global SpmVolumeRecord* records, const __global SpmMedium* media,
                            const __global SpmPatch* patches, const __global float4* origins,
                            const __global float4* directions, __global float4* out, uint count, int medium,
                            float radius, uint density_kernel, uint estimator, uint min_rec_depth,
                            uint max_rec_depth) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  const SpmGrid grid = make_grid(info, cell_start, item_pos);
  uint tests = 0;
  SpmMediumTable homogeneous;
  homogeneous.n = 0;
  const float3 l = beam_estimate(&grid, items, records, media, patches, medium, origins[i].xyz, directions[i].xyz,
                                 origins[i].w, directions[i].w, radius, density_kernel, estimator, min_rec_depth,
                                 max_rec_depth, &homogeneous, &tests);
  out[i] = (float4)(l, (float)tests);
}

__kernel void spm_stream_beam_test(const __global SpmGridInfo* info, const __global uint* cell_start,
                                   const __global uint* items, const __global SpmBeam* beams,
                                   const __global SpmMedium* media, const __global float4* origins,
                                   const __global float4* directions, __global float4* out, uint count, int medium,
                                   float radius, uint density_kernel, uint min_rec_depth, uint max_rec_depth) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  uint tests = 0;
  SpmMediumTable homogeneous;
  homogeneous.n = 0;
  const float3 l =
      stream_beam_estimate(info, cell_start, items, beams, media, medium, origins[i].xyz, directions[i].xyz,
                           origins[i].w, directions[i].w, radius, density_kernel, min_rec_depth, max_rec_depth,
                           &homogeneous, &tests);
  out[i] = (float4)(l, (float)tests);
}

__kernel void spm_surface_test(const __global SpmGridInfo* info, const __global uint* cell_start,
                               const __global float4* item_pos, const __global float4* item_flux,
                               const __global float4* points, const __global float4* normals,
                               const __global SpmPatch* patches, const __global uint* point_patch,
                               __global float4* out, uint count, float radius, uint density_kernel,
                               uint max_rec_depth) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  const SpmGrid grid = make_grid(info, cell_start, item_pos);
  const SpmPatchFrame patch = patch_frame(patches, point_patch[i]);
  out[i] = (float4)(surface_estimate(&grid, item_flux, points[i].xyz, normals[i].xyz, radius, density_kernel,
                                     max_rec_depth, &patch),
                    0.0f);
}

__kernel void spm_shared_surface_test(const __global SpmGridInfo* info, const __global uint* cell_start,
                                      const __global float4* item_pos, const __global float4* item_flux,
                                      const __global float4* points, const __global float4* normals,
                                      const __global uint* depth_limits, const __global SpmPatch* patches,
                                      const __global uint* point_patch, __global float4* out, uint count,
                                      float radius, uint density_kernel) {
  if (get_global_id(0) != 0) return;
  const SpmGrid grid = make_grid(info, cell_start, item_pos);
  SpmSurfaceReuse reuse = surface_reuse_empty();
  for (uint i = 0; i < count; ++i) {
    out[i] = (float4)(pixel_surface_estimate(&reuse, &grid, item_flux, points[i].xyz, normals[i].xyz, radius,
                                             density_kernel, depth_limits[i], patches, point_patch[i]),
                      0.0f);
  }
}

__kernel void spm_shared_beam_test(const __global SpmGridInfo* info, const __global uint* cell_start,
                                   const __global float4* item_pos, const __global uint* items,
                                   const __global SpmVolumeRecord* records, const __global SpmMedium* media,
                                   const __global SpmPatch* patches, const __global float4* origins,
                                   const __global float4* directions, const __global uint* depth_limits,
                                   __global float4* out, uint count, int medium, float radius,
                                   uint density_kernel) {
  if (get_global_id(0) != 0) return;
  const SpmGrid grid = make_grid(info, cell_start, item_pos);
  SpmMediumTable homogeneous;
  homogeneous.n = 0;
  SpmVolumeReuse reuse = volume_reuse_empty();
  for (uint i = 0; i < count; ++i) {
    const float3 o = origins[i].xyz, d = directions[i].xyz;
    const float t0 = origins[i].w, t1 = directions[i].w;
    uint tests = 0;
    if (!volume_reuse_hit(&reuse, o, d, t0, t1, medium, 0u, depth_limits[i], radius)) {
      reuse.L = beam_estimate(&grid, items, records, media, patches, medium, o, d, t0, t1, radius, density_kernel,
                              SPM_ESTIMATOR_BRE, 0u, depth_limits[i], &homogeneous, &tests);
    }
    out[i] = (float4)(reuse.L, (float)tests);
  }
}
