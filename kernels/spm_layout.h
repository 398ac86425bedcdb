/* Every shared struct and field, listed once: the host static_asserts the
 * sizes (host/device/layout.cpp) and the layout test compares the host's
 * sizeof/offsetof with what kernels/spm_layout.cl reports from the device. */
#ifndef SPM_LAYOUT_H
#define SPM_LAYOUT_H

#include "spm_types.h"

/* S(struct, expected size in bytes) */
#define SPM_LAYOUT_STRUCTS(S) \
  S(SpmPrim, 48)              \
  S(SpmPrimNormals, 48)       \
  S(SpmPatch, 48)             \
  S(SpmBvhNode, 32)           \
  S(SpmShape, 32)             \
  S(SpmMaterial, 80)          \
  S(SpmMedium, 48)            \
  S(SpmGridVolume, 96)        \
  S(SpmLight, 112)            \
  S(SpmLightPrim, 8)          \
  S(SpmCamera, 96)            \
  S(SpmVolumeRecord, 64)      \
  S(SpmBeam, 64)              \
  S(SpmSurfaceRecord, 64)     \
  S(SpmStreamParams, 64)      \
  S(SpmGatherParams, 96)      \
  S(SpmGridInfo, 32)          \
  S(SpmMapGrid, 64)

/* F(struct, field) */
#define SPM_LAYOUT_FIELDS(F)                                                                    \
  F(SpmPrim, p0) F(SpmPrim, shape) F(SpmPrim, p1) F(SpmPrim, kind) F(SpmPrim, p2)               \
  F(SpmPrim, normals)                                                                           \
  F(SpmPrimNormals, n0) F(SpmPrimNormals, n1) F(SpmPrimNormals, n2)                             \
  F(SpmPatch, center) F(SpmPatch, half_u) F(SpmPatch, u) F(SpmPatch, half_v) F(SpmPatch, v)     \
  F(SpmPatch, open)                                                                             \
  F(SpmBvhNode, lo) F(SpmBvhNode, offset) F(SpmBvhNode, hi) F(SpmBvhNode, count_axis)          \
  F(SpmShape, material) F(SpmShape, interior) F(SpmShape, exterior) F(SpmShape, light)          \
  F(SpmShape, flags)                                                                            \
  F(SpmMaterial, reflectance) F(SpmMaterial, type) F(SpmMaterial, eta) F(SpmMaterial, twosided) \
  F(SpmMaterial, alpha) F(SpmMaterial, distribution) F(SpmMaterial, specular)                   \
  F(SpmMaterial, fdr_int) F(SpmMaterial, k_eta) F(SpmMaterial, nonlinear) F(SpmMaterial, k)     \
  F(SpmMedium, sigma_t) F(SpmMedium, g) F(SpmMedium, albedo) F(SpmMedium, phase)                \
  F(SpmMedium, sigma_t_grid) F(SpmMedium, albedo_grid)                                          \
  F(SpmGridVolume, to_local) F(SpmGridVolume, dims) F(SpmGridVolume, channels)                  \
  F(SpmGridVolume, majorant_dims) F(SpmGridVolume, filter) F(SpmGridVolume, offset)             \
  F(SpmGridVolume, majorant_offset) F(SpmGridVolume, voxel)                                     \
  F(SpmLight, emission) F(SpmLight, type) F(SpmLight, position) F(SpmLight, power)              \
  F(SpmLight, axis_x) F(SpmLight, cos_cutoff) F(SpmLight, axis_y) F(SpmLight, cos_beam)         \
  F(SpmLight, axis_z) F(SpmLight, cutoff) F(SpmLight, prim_begin) F(SpmLight, prim_count)       \
  F(SpmLight, area) F(SpmLight, beam_width) F(SpmLight, medium) F(SpmLight, aim)               \
  F(SpmLight, disk_radius) F(SpmLight, map_height)                                              \
  F(SpmLightPrim, prim) F(SpmLightPrim, cdf)                                                    \
  F(SpmCamera, origin) F(SpmCamera, tan_half_x) F(SpmCamera, axis_x) F(SpmCamera, tan_half_y)   \
  F(SpmCamera, axis_y) F(SpmCamera, near_clip) F(SpmCamera, axis_z) F(SpmCamera, far_clip)      \
  F(SpmCamera, width) F(SpmCamera, height) F(SpmCamera, medium) F(SpmCamera, filter)            \
  F(SpmCamera, filter_stddev) F(SpmCamera, filter_radius)                                       \
  F(SpmVolumeRecord, position) F(SpmVolumeRecord, stream) F(SpmVolumeRecord, direction)         \
  F(SpmVolumeRecord, depth) F(SpmVolumeRecord, flux) F(SpmVolumeRecord, medium)                \
  F(SpmVolumeRecord, flags)                                                                     \
  F(SpmBeam, origin) F(SpmBeam, stream) F(SpmBeam, direction) F(SpmBeam, depth) F(SpmBeam, flux) \
  F(SpmBeam, medium) F(SpmBeam, length)                                                         \
  F(SpmSurfaceRecord, position) F(SpmSurfaceRecord, stream) F(SpmSurfaceRecord, direction)      \
  F(SpmSurfaceRecord, depth_photon) F(SpmSurfaceRecord, flux) F(SpmSurfaceRecord, flags)        \
  F(SpmSurfaceRecord, normal)                                                                   \
  F(SpmStreamParams, seed) F(SpmStreamParams, pass) F(SpmStreamParams, pass_streams)           \
  F(SpmStreamParams, associated) F(SpmStreamParams, stream_width) F(SpmStreamParams, march_step) \
  F(SpmStreamParams, max_bounces) F(SpmStreamParams, max_depth) F(SpmStreamParams, rr_depth)     \
  F(SpmStreamParams, volume_capacity) F(SpmStreamParams, surface_capacity)                       \
  F(SpmStreamParams, beam_capacity) F(SpmStreamParams, beam_streams)                             \
  F(SpmGatherParams, seed) F(SpmGatherParams, pass) F(SpmGatherParams, spp)                     \
  F(SpmGatherParams, max_depth) F(SpmGatherParams, radius) F(SpmGatherParams, density_kernel)    \
  F(SpmGatherParams, estimator) F(SpmGatherParams, direct) F(SpmGatherParams, direct_terms)      \
  F(SpmGatherParams, final_gather) F(SpmGatherParams, march_step)                               \
  F(SpmGatherParams, first_sample) F(SpmGatherParams, strata_seed) F(SpmGatherParams, terms)     \
  F(SpmGatherParams, emission_chains) F(SpmGatherParams, volume_samples)                         \
  F(SpmGatherParams, volume_radius) F(SpmGatherParams, gather_aim) F(SpmGatherParams, grids)   \
  F(SpmGatherParams, first_pixel) F(SpmGatherParams, count)                                     \
  F(SpmGridInfo, lo) F(SpmGridInfo, cell) F(SpmGridInfo, dims) F(SpmGridInfo, records)           \
  F(SpmMapGrid, info) F(SpmMapGrid, first_cell) F(SpmMapGrid, first_item) F(SpmMapGrid, kind)            \
  F(SpmMapGrid, radius)

#endif
