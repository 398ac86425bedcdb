/* spm_irradiance: the surface estimate precomputed at a subset of the
 * surface records (Christensen 1999), for the final gather's lookups.
 * From: the surface map's point grid and the chosen points (position, and
 * the packed normal in w), in the order of their own point grid. To: each
 * point's photon flux density, which a final-gather ray that ends near the
 * point reads instead of summing the records again (spm_gather.cl). */
#include "spm_types.h"
#include "lib/estimate.h"

__kernel void spm_irradiance(const __global SpmGridInfo* surface_info, const __global uint* surface_start,
                             const __global float4* surface_pos, const __global float4* surface_flux,
                             const __global float4* irradiance_pos, __global float4* irradiance, uint count,
                             float radius, uint density_kernel) {
  const uint i = get_global_id(0);
  if (i >= count) return;
  const SpmGrid grid = make_grid(surface_info, surface_start, surface_pos);
  const float4 p = irradiance_pos[i];
  const float3 e = surface_estimate(&grid, surface_flux, p.xyz, unpack_normal(as_uint(p.w)), radius, density_kernel,
                                    SPM_NONE);
  irradiance[i] = (float4)(e, 0.0f);
}
