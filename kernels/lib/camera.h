/* Primary rays of the pinhole camera (SpmCamera), with the pixel filter
 * sampled directly (SCENES.md: no splatting). */
#ifndef SPM_LIB_CAMERA_H
#define SPM_LIB_CAMERA_H

#include "../spm_types.h"
#include "sampling.h"

/* Film offset from the pixel centre, drawn from the reconstruction filter:
 * box over the pixel, or Mitsuba's Gaussian (separable, truncated at 4 sigma). */
inline float2 sample_filter(const __global SpmCamera* c, float u1, float u2) {
  if (c->filter == SPM_FILTER_BOX) return (float2)(u1 - 0.5f, u2 - 0.5f);
  return (float2)(sample_truncated_gaussian(u1, c->filter_stddev, c->filter_radius),
                  sample_truncated_gaussian(u2, c->filter_stddev, c->filter_radius));
}

/* Ray through film position (px, py) in pixels; *tmin is the near clip along
 * the unit direction. */
inline float3 camera_ray(const __global SpmCamera* c, float px, float py, float3* origin, float* tmin,
                         float* tmax) {
  const float u = px / (float)c->width;
  const float v = py / (float)c->height;
  const float3 dir_cam = (float3)((1.0f - 2.0f * u) * c->tan_half_x, (1.0f - 2.0f * v) * c->tan_half_y, 1.0f);
  const float3 d = dir_cam.x * load3(c->axis_x) + dir_cam.y * load3(c->axis_y) + dir_cam.z * load3(c->axis_z);
  const float len = length(d);
  *origin = load3(c->origin);
  /* Clip distances are measured along the camera's axis, as in Mitsuba. */
  const float z_per_t = length(load3(c->axis_z)) / len;
  *tmin = c->near_clip / z_per_t;
  *tmax = c->far_clip / z_per_t;
  return d / len;
}

#endif
