/* Test entry points of the gather's estimates over a grid table
 * (kernels/lib/maps.h), so that they can be compared with a brute-force
 * sum on the host. Each reads the grids of `rows` rows that `reader` reads
 * (SPM_READ_*), as spm_gather does.
 * spm_volume_test: one work-item per ray segment (origin xyz + t0,
 * direction xyz + t1), the estimate in xyz and the records or beams
 * examined in w.
 * spm_surface_test: one per query point (xyz) with normal (xyz) and patch.
 * spm_shared_surface_test: one work-item through all the queries in order,
 * as a block's samples are, each with its own record depth limit;
 * spm_shared_volume_test likewise through ray segments, each with its own
 * maximum record depth (volume_reuse_hit). */
#include "spm_types.h"
#include "lib/maps.h"

#define SPM_TEST_TABLE \
  make_map_table(grids, rows, grid_cells, grid_pos, surface_flux, volume_records, beams, density_kernel, estimator, 1.0f)

__kernel void spm_volume_test(uint rows SPM_MAP_PARAMS, const __global SpmMedium* media,
                              const __global SpmPatch* patches, const __global float4* origins,
                              const __global float4* directions, __global float4* out, uint count, int medium,
                              uint reader, uint density_kernel, uint estimator, uint min_rec_depth,
                              uint max_rec_depth) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  const SpmMapTable t = SPM_TEST_TABLE;
  uint tests = 0;
  SpmMediumTable homogeneous;
  homogeneous.n = 0;
  const float3 l = table_volume_estimate(&t, reader, media, patches, medium, origins[i].xyz, directions[i].xyz,
                                         origins[i].w, directions[i].w, min_rec_depth, max_rec_depth, &homogeneous,
                                         &tests);
  out[i] = (float4)(l, (float)tests);
}

__kernel void spm_surface_test(uint rows SPM_MAP_PARAMS, const __global float4* points,
                               const __global float4* normals, const __global SpmPatch* patches,
                               const __global uint* point_patch, __global float4* out, uint count, uint reader,
                               uint density_kernel, uint estimator, uint max_rec_depth) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  const SpmMapTable t = SPM_TEST_TABLE;
  const SpmPatchFrame patch = patch_frame(patches, point_patch[i]);
  out[i] = (float4)(table_surface_estimate(&t, reader, points[i].xyz, normals[i].xyz, max_rec_depth, &patch), 0.0f);
}

__kernel void spm_shared_surface_test(uint rows SPM_MAP_PARAMS, const __global float4* points,
                                      const __global float4* normals, const __global uint* depth_limits,
                                      const __global SpmPatch* patches, const __global uint* point_patch,
                                      __global float4* out, uint count, uint reader, float radius,
                                      uint density_kernel, uint estimator) {
  if (get_global_id(0) != 0) return;
  const SpmMapTable t = SPM_TEST_TABLE;
  SpmSurfaceReuse reuse = surface_reuse_empty();
  for (uint i = 0; i < count; ++i) {
    out[i] = (float4)(pixel_surface_estimate(&reuse, &t, reader, points[i].xyz, normals[i].xyz, radius,
                                             depth_limits[i], patches, point_patch[i]),
                      0.0f);
  }
}

__kernel void spm_shared_volume_test(uint rows SPM_MAP_PARAMS, const __global SpmMedium* media,
                                     const __global SpmPatch* patches, const __global float4* origins,
                                     const __global float4* directions, const __global uint* depth_limits,
                                     __global float4* out, uint count, int medium, uint reader, float radius,
                                     uint density_kernel, uint estimator) {
  if (get_global_id(0) != 0) return;
  const SpmMapTable t = SPM_TEST_TABLE;
  SpmMediumTable homogeneous;
  homogeneous.n = 0;
  SpmVolumeReuse reuse = volume_reuse_empty();
  for (uint i = 0; i < count; ++i) {
    const float3 o = origins[i].xyz, d = directions[i].xyz;
    const float t0 = origins[i].w, t1 = directions[i].w;
    uint tests = 0;
    if (!volume_reuse_hit(&reuse, o, d, t0, t1, medium, 0u, depth_limits[i], radius)) {
      reuse.L = table_volume_estimate(&t, reader, media, patches, medium, o, d, t0, t1, 0u, depth_limits[i],
                                      &homogeneous, &tests);
    }
    out[i] = (float4)(reuse.L, (float)tests);
  }
}
