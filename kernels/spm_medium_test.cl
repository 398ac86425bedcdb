/* Test entry points of the media functions (kernels/lib/medium.h), so that
 * lookups, flights and transmittance can be compared with closed forms and
 * host references (tests/test_heterogeneous.cpp).
 * spm_grid_lookup_test: one work-item per local point (xyz) of grid `grid`.
 * spm_flight_test: one per sample of the flight from `origin` along
 *   `direction` (w: tmax) in medium `medium`: (t or infinity, weight).
 * spm_transmittance_test: one per sample of the transmittance over
 *   [origin.w, direction.w] of the same ray. */
#include "spm_types.h"
#include "lib/medium.h"

inline SpmMedia media_tables(const __global SpmMedium* media, const __global SpmGridVolume* grids,
                             const __global float* grid_data) {
  SpmMedia md;
  md.media = media;
  md.grids = grids;
  md.grid_data = grid_data;
  return md;
}

__kernel void spm_grid_lookup_test(const __global SpmGridVolume* grids, const __global float* grid_data,
                                   const __global float4* points, __global float4* out, uint count, uint grid) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  out[i] = (float4)(grid_value(&grids[grid], grid_data, points[i].xyz), 0.0f);
}

__kernel void spm_flight_test(const __global SpmMedium* media, const __global SpmGridVolume* grids,
                              const __global float* grid_data, float4 origin, float4 direction, int medium,
                              float march_step, uint seed, __global float4* out, uint count) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  const SpmMedia md = media_tables(media, grids, grid_data);
  float3 w = (float3)(1.0f);
  const float t =
      heterogeneous_flight(&md, medium, origin.xyz, direction.xyz, direction.w, march_step, rng_make(seed, 0u, i, 0u), &w);
  out[i] = (float4)(t, w);
}

__kernel void spm_transmittance_test(const __global SpmMedium* media, const __global SpmGridVolume* grids,
                                     const __global float* grid_data, float4 origin, float4 direction, int medium,
                                     float march_step, uint seed, __global float4* out, uint count) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  const SpmMedia md = media_tables(media, grids, grid_data);
  out[i] = (float4)(medium_transmittance(&md, medium, origin.xyz, direction.xyz, origin.w, direction.w, march_step,
                                         rng_make(seed, 0u, i, 0u), 0u),
                    0.0f);
}
