/* Surface scattering: specular bounces shared by camera rays and streams, and
 * the side conventions of Mitsuba 3 (one-sided diffuse and mirror). */
#ifndef SPM_LIB_BSDF_H
#define SPM_LIB_BSDF_H

#include "scene.h"

/* Unpolarised Fresnel reflectance for relative index eta = eta_t / eta_i;
 * sets *cos_t, returns 1 on total internal reflection. */
inline float fresnel_dielectric(float cos_i, float eta, float* cos_t) {
  const float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.0f) {
    *cos_t = 0.0f;
    return 1.0f;
  }
  *cos_t = sqrt(1.0f - sin2_t);
  const float rs = (cos_i - eta * *cos_t) / (cos_i + eta * *cos_t);
  const float rp = (eta * cos_i - *cos_t) / (eta * cos_i + *cos_t);
  return 0.5f * (rs * rs + rp * rp);
}

/* Does the ray arriving along d see the side of the surface that reflects?
 * Mitsuba's diffuse and conductor are black from behind unless twosided. */
inline bool reflects_from(const __global SpmMaterial* m, const SpmSurface* surf, float3 d) {
  return m->twosided || dot(d, surf->ng) < 0.0f;
}

/* Shading normal turned to the side the ray arrives from. */
inline float3 facing_normal(const SpmSurface* surf, float3 d) {
  return dot(d, surf->ng) < 0.0f ? surf->ns : -surf->ns;
}

/* Mirror, glass or a thin sheet of glass: the surfaces whose bounce is a
 * delta direction, at which streams collapse (METHOD.md 4). */
inline bool is_specular(uint type) {
  return type == SPM_MAT_MIRROR || type == SPM_MAT_DIELECTRIC || type == SPM_MAT_THIN_DIELECTRIC;
}

/* A specular bounce: the new direction, and the throughput factor (0:
 * absorbed). Dielectrics pick reflection with probability F, so the factor
 * is 1, except that radiance (camera rays, `radiance` true) is scaled by
 * (eta_i/eta_t)^2 on refraction for the change of solid angle; flux (photons)
 * is not. A thin dielectric is Mitsuba's: a sheet whose two faces reflect
 * F each, with every inner reflection summed, R = 2F / (1 + F) (F at the
 * sheet's eta whichever side the ray comes from); what it lets through goes
 * on undeviated, so no solid angle changes. */
inline float specular_bounce(const __global SpmMaterial* m, const SpmSurface* surf, float3 d, float u,
                             bool radiance, float3* out) {
  const float3 n = facing_normal(surf, d);
  const float cos_i = clamp(-dot(d, n), 0.0f, 1.0f);
  if (m->type == SPM_MAT_MIRROR) {
    if (!reflects_from(m, surf, d)) return 0.0f;
    *out = normalize(d + 2.0f * cos_i * n);
    return 1.0f;
  }
  if (m->type == SPM_MAT_THIN_DIELECTRIC) {
    float cos_t;
    float r = fresnel_dielectric(cos_i, m->eta, &cos_t);
    r *= 2.0f / (1.0f + r);
    *out = u < r ? normalize(d + 2.0f * cos_i * n) : d;
    return 1.0f;
  }
  const float eta = dot(d, surf->ng) < 0.0f ? m->eta : 1.0f / m->eta;
  float cos_t;
  const float f = fresnel_dielectric(cos_i, eta, &cos_t);
  if (u < f) {
    *out = normalize(d + 2.0f * cos_i * n);
    return 1.0f;
  }
  *out = normalize(d / eta + (cos_i / eta - cos_t) * n);
  return radiance ? 1.0f / (eta * eta) : 1.0f;
}

/* Origin for a ray leaving surf along d, on the side d points to. */
inline float3 leave_surface(const SpmSurface* surf, float3 d) {
  return offset_origin(surf->p, dot(d, surf->ng) > 0.0f ? surf->ng : -surf->ng, surf->extent);
}

#endif
