/* Warps from uniform numbers to the distributions the method samples. */
#ifndef SPM_LIB_SAMPLING_H
#define SPM_LIB_SAMPLING_H

#include "math.h"

/* Cosine-weighted direction about +z (Malley's method): pdf cos(theta)/pi. */
inline float3 sample_cosine_hemisphere(float u1, float u2) {
  const float r = sqrt(u1);
  const float phi = 2.0f * SPM_PI * u2;
  return SPM_F3(r * cos(phi), r * sin(phi), sqrt(fmax(0.0f, 1.0f - u1)));
}

/* Uniform direction on the unit sphere: pdf 1/(4 pi). */
inline float3 sample_uniform_sphere(float u1, float u2) {
  const float z = 1.0f - 2.0f * u1;
  const float r = sqrt(fmax(0.0f, 1.0f - z * z));
  const float phi = 2.0f * SPM_PI * u2;
  return SPM_F3(r * cos(phi), r * sin(phi), z);
}

/* Uniform direction in the cone cos(theta) >= cos_max about +z. */
inline float3 sample_uniform_cone(float u1, float u2, float cos_max) {
  const float z = 1.0f - u1 * (1.0f - cos_max);
  const float r = sqrt(fmax(0.0f, 1.0f - z * z));
  const float phi = 2.0f * SPM_PI * u2;
  return SPM_F3(r * cos(phi), r * sin(phi), z);
}

/* Uniform point in the unit disk (radial CDF r^2). */
inline float2 sample_disk(float u1, float u2) {
  const float r = sqrt(u1);
  const float phi = 2.0f * SPM_PI * u2;
  return SPM_F2(r * cos(phi), r * sin(phi));
}

/* Uniform point in the unit ball (radial CDF r^3). */
inline float3 sample_ball(float u1, float u2, float u3) {
  return cbrt(u1) * sample_uniform_sphere(u2, u3);
}

/* Uniform barycentrics (b1, b2) on a triangle. */
inline float2 sample_triangle(float u1, float u2) {
  const float s = sqrt(u1);
  return SPM_F2(1.0f - s, u2 * s);
}

/* Inverse error function, single precision (M. Giles, "Approximating the erfinv
 * function", GPU Computing Gems, 2011). */
inline float erfinv_approx(float x) {
  float w = -log(fmax((1.0f - x) * (1.0f + x), 1e-30f));
  float p;
  if (w < 5.0f) {
    w -= 2.5f;
    p = 2.81022636e-08f;
    p = 3.43273939e-07f + p * w;
    p = -3.5233877e-06f + p * w;
    p = -4.39150654e-06f + p * w;
    p = 0.00021858087f + p * w;
    p = -0.00125372503f + p * w;
    p = -0.00417768164f + p * w;
    p = 0.246640727f + p * w;
    p = 1.50140941f + p * w;
  } else {
    w = sqrt(w) - 3.0f;
    p = -0.000200214257f;
    p = 0.000100950558f + p * w;
    p = 0.00134934322f + p * w;
    p = -0.00367342844f + p * w;
    p = 0.00573950773f + p * w;
    p = -0.0076224613f + p * w;
    p = 0.00943887047f + p * w;
    p = 1.00167406f + p * w;
    p = 2.83297682f + p * w;
  }
  return p * x;
}

/* Normal(0, stddev) truncated to [-radius, radius], by inverting its CDF. */
inline float sample_truncated_gaussian(float u, float stddev, float radius) {
  const float k = erf(radius / (stddev * sqrt(2.0f)));
  return stddev * sqrt(2.0f) * erfinv_approx((2.0f * u - 1.0f) * k);
}

#endif
