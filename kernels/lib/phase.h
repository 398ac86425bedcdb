/* Phase functions of homogeneous media: isotropic and Henyey-Greenstein. */
#ifndef SPM_LIB_PHASE_H
#define SPM_LIB_PHASE_H

#include "sampling.h"

/* Henyey-Greenstein density of the angle between the direction of travel before
 * and after scattering (cos_theta = 1: straight on); g = 0 is isotropic. */
inline float phase_hg(float cos_theta, float g) {
  const float denom = 1.0f + g * g - 2.0f * g * cos_theta;
  return (1.0f - g * g) / (4.0f * SPM_PI * denom * sqrt(denom));
}

/* New direction of travel after scattering, by inverting the HG CDF in
 * cos(theta); its mean cosine with d is g. */
inline float3 sample_phase(float3 d, float g, float u1, float u2) {
  float cos_theta;
  if (fabs(g) < 1e-3f) {
    cos_theta = 1.0f - 2.0f * u1;
  } else {
    const float sq = (1.0f - g * g) / (1.0f - g + 2.0f * g * u1);
    cos_theta = clamp((1.0f + g * g - sq * sq) / (2.0f * g), -1.0f, 1.0f);
  }
  const float sin_theta = sqrt(fmax(0.0f, 1.0f - cos_theta * cos_theta));
  const float phi = 2.0f * SPM_PI * u2;
  return normalize(to_world(SPM_F3(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta), d));
}

#endif
