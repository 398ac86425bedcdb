/* Surface scattering shared by camera rays and streams (METHOD.md 13): the
 * delta bounces, the diffuse lobe of diffuse and plastic surfaces, the
 * glossy lobes of the rough ones, and the side conventions of Mitsuba 3
 * (one-sided opaque surfaces). */
#ifndef SPM_LIB_BSDF_H
#define SPM_LIB_BSDF_H

#include "microfacet.h"
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

/* Fresnel reflectance of a conductor of complex index eta + i k (Moeller's
 * "Optics" form, as Mitsuba 3 evaluates it). A purely imaginary index
 * (eta 0: Mitsuba's material "none") reflects everything: exactly 1, where
 * the formula would leave the square root of its rounding error. */
inline float fresnel_conductor1(float cos_i, float eta, float k) {
  if (eta == 0.0f) return 1.0f;
  const float c2 = cos_i * cos_i, s2 = 1.0f - c2;
  const float t1 = eta * eta - k * k - s2;
  const float a2b2 = sqrt(fmax(t1 * t1 + 4.0f * k * k * eta * eta, 0.0f));
  const float a = sqrt(fmax(0.5f * (a2b2 + t1), 0.0f));
  const float term1 = a2b2 + c2, term2 = 2.0f * cos_i * a;
  const float rs = (term1 - term2) / (term1 + term2);
  const float term3 = a2b2 * c2 + s2 * s2, term4 = term2 * s2;
  const float rp = rs * (term3 - term4) / (term3 + term4);
  return 0.5f * (rs + rp);
}

inline float3 fresnel_conductor(float cos_i, float3 eta, float3 k) {
  return SPM_F3(fresnel_conductor1(cos_i, eta.x, k.x), fresnel_conductor1(cos_i, eta.y, k.y),
                fresnel_conductor1(cos_i, eta.z, k.z));
}

/* Lobes (METHOD.md 13). Delta only: the surfaces at which streams collapse
 * and camera paths turn (METHOD.md 4); the plastic's coat is a delta lobe
 * too, over a diffuse base. */
inline bool is_specular(uint type) {
  return type == SPM_MAT_CONDUCTOR || type == SPM_MAT_DIELECTRIC || type == SPM_MAT_THIN_DIELECTRIC;
}
inline bool is_glossy(uint type) { return type == SPM_MAT_ROUGH_CONDUCTOR || type == SPM_MAT_ROUGH_DIELECTRIC; }
/* A diffuse lobe: photon records are made and read at such a vertex. */
inline bool has_diffuse(uint type) { return type == SPM_MAT_DIFFUSE || type == SPM_MAT_PLASTIC; }

inline float3 to_local(float3 v, float3 n) {
  float3 t, b;
  make_basis(n, &t, &b);
  return SPM_F3(dot(v, t), dot(v, b), dot(v, n));
}

/* The share of the light through a plastic's coat (1 - F) at cosine c. */
inline float coat_transmission(const __global SpmMaterial* m, float c) {
  float cos_t;
  return 1.0f - fresnel_dielectric(clamp(c, 0.0f, 1.0f), m->eta, &cos_t);
}

/* What the diffuse lobe sends towards a direction at cosine cos_o, per unit
 * of the irradiance that entered it, times pi: the reflectance of a
 * diffuse surface; for a plastic, Mitsuba's base seen through its coat,
 * (1 - F_o) rho / (1 - fdr_int rho) / eta^2 (the light's own 1 - F_i is
 * the caller's: streams enter the base with that probability, shadow
 * and gather rays take it as a factor). */
inline float3 diffuse_exit(const __global SpmMaterial* m, float cos_o) {
  const float3 rho = load3(m->reflectance);
  if (m->type != SPM_MAT_PLASTIC) return rho;
  const float3 inner = m->nonlinear ? rho * m->fdr_int : (float3)(m->fdr_int);
  return rho / (1.0f - inner) * (coat_transmission(m, cos_o) / (m->eta * m->eta));
}

/* The diffuse lobe's BSDF times pi for light arriving along -wi and
 * leaving along wo on the side n faces: diffuse_exit, times the share
 * that entered (diffuse_entry: the plastic's coat transmission). */
inline float diffuse_entry(const __global SpmMaterial* m, float cos_i) {
  return m->type == SPM_MAT_PLASTIC ? coat_transmission(m, cos_i) : 1.0f;
}
inline float3 diffuse_f_pi(const __global SpmMaterial* m, float3 n, float3 wi, float3 wo) {
  return diffuse_exit(m, dot(wo, n)) * diffuse_entry(m, dot(wi, n));
}

/* A delta bounce: the new direction, and the throughput factor (0:
 * absorbed). Dielectrics pick reflection with probability F, so the factor
 * is 1, except that radiance (camera rays, `radiance` true) is scaled by
 * (eta_i/eta_t)^2 on refraction for the change of solid angle; flux (photons)
 * is not. A thin dielectric is Mitsuba's: a sheet whose two faces reflect
 * F each, with every inner reflection summed, R = 2F / (1 + F) (F at the
 * sheet's eta whichever side the ray comes from); what it lets through goes
 * on undeviated, so no solid angle changes. A conductor reflects its
 * Fresnel reflectance, a plastic's coat F (the base is the caller's). */
inline float3 specular_bounce(const __global SpmMaterial* m, const SpmSurface* surf, float3 d, float u,
                              bool radiance, float3* out) {
  const float3 n = facing_normal(surf, d);
  const float cos_i = clamp(-dot(d, n), 0.0f, 1.0f);
  if (m->type == SPM_MAT_CONDUCTOR || m->type == SPM_MAT_PLASTIC) {
    if (!reflects_from(m, surf, d)) return (float3)(0.0f);
    *out = normalize(d + 2.0f * cos_i * n);
    if (m->type == SPM_MAT_PLASTIC) return load3(m->specular) * (1.0f - coat_transmission(m, cos_i));
    return load3(m->specular) * fresnel_conductor(cos_i, load3(m->k_eta), load3(m->k));
  }
  if (m->type == SPM_MAT_THIN_DIELECTRIC) {
    float cos_t;
    float r = fresnel_dielectric(cos_i, m->eta, &cos_t);
    r *= 2.0f / (1.0f + r);
    *out = u < r ? normalize(d + 2.0f * cos_i * n) : d;
    return (float3)(1.0f);
  }
  const float eta = dot(d, surf->ng) < 0.0f ? m->eta : 1.0f / m->eta;
  float cos_t;
  const float f = fresnel_dielectric(cos_i, eta, &cos_t);
  if (u < f) {
    *out = normalize(d + 2.0f * cos_i * n);
    return (float3)(1.0f);
  }
  *out = normalize(d / eta + (cos_i / eta - cos_t) * n);
  return (float3)(radiance ? 1.0f / (eta * eta) : 1.0f);
}

/* A glossy lobe's local frame at surf for a path arriving along d (wi =
 * -d): the shading normal, turned to the arriving side for a rough
 * conductor (which is black from behind unless twosided) and kept as
 * is for a rough dielectric, whose two sides differ by eta. False: black. */
inline bool glossy_frame(const __global SpmMaterial* m, const SpmSurface* surf, float3 d, float3* n) {
  if (m->type == SPM_MAT_ROUGH_DIELECTRIC) {
    *n = surf->ns;
    return true;
  }
  *n = facing_normal(surf, d);
  return reflects_from(m, surf, d);
}

/* A rough dielectric's Fresnel term at microfacet normal m for wi (local):
 * F, and the relative index eta_t / eta_i on wi's side. */
inline float rough_fresnel(const __global SpmMaterial* mat, float3 wi, float3 m, float* eta_rel, float* cos_t) {
  const float c = dot(wi, m);
  *eta_rel = wi.z > 0.0f ? mat->eta : 1.0f / mat->eta;
  return fresnel_dielectric(fabs(c), *eta_rel, cos_t);
}

/* A glossy lobe's BSDF times |cos(wo)| for local directions wi (towards
 * where the path came from) and wo, with its sampling density in *pdf
 * (Mitsuba 3's roughconductor and roughdielectric; Walter et al. 2007).
 * `radiance`: a camera path, whose refraction scales by (eta_i/eta_t)^2;
 * photons do not. */
inline float3 glossy_eval_local(const __global SpmMaterial* mat, float3 wi, float3 wo, bool radiance, float* pdf) {
  *pdf = 0.0f;
  const uint type = mat->distribution;
  const float alpha = mat->alpha;
  if (mat->type == SPM_MAT_ROUGH_CONDUCTOR) {
    if (wi.z <= 0.0f || wo.z <= 0.0f) return (float3)(0.0f);
    const float3 h = normalize(wi + wo);
    const float d = microfacet_d(type, alpha, h);
    if (d == 0.0f) return (float3)(0.0f);
    *pdf = microfacet_pdf(type, alpha, wi, h) / (4.0f * dot(wo, h));
    const float g = microfacet_g1(type, alpha, wi, h) * microfacet_g1(type, alpha, wo, h);
    return load3(mat->specular) * fresnel_conductor(dot(wi, h), load3(mat->k_eta), load3(mat->k)) *
           (d * g / (4.0f * wi.z));
  }
  if (wi.z == 0.0f) return (float3)(0.0f);
  const bool reflect = wi.z * wo.z > 0.0f;
  const float eta = wi.z > 0.0f ? mat->eta : 1.0f / mat->eta;
  float3 h = normalize(wi + wo * (reflect ? 1.0f : eta));
  if (h.z < 0.0f) h = -h;
  const float ci = dot(wi, h), co = dot(wo, h);
  if (ci * wi.z <= 0.0f || co * wo.z <= 0.0f) return (float3)(0.0f);
  float eta_rel, cos_t;
  const float f = rough_fresnel(mat, wi, h, &eta_rel, &cos_t);
  const float d = microfacet_d(type, alpha, h);
  const float g = microfacet_g1(type, alpha, wi, h) * microfacet_g1(type, alpha, wo, h);
  const float3 wi_up = wi.z > 0.0f ? wi : -wi;
  const float visible = microfacet_pdf(type, alpha, wi_up, h);
  if (reflect) {
    *pdf = visible * f / (4.0f * fabs(co));
    return (float3)(f * d * g / (4.0f * fabs(wi.z)));
  }
  const float denom = (ci + eta * co) * (ci + eta * co);
  *pdf = visible * (1.0f - f) * fabs(eta * eta * co / denom);
  const float scale = radiance ? 1.0f / (eta * eta) : 1.0f;
  return (float3)(fabs(scale * (1.0f - f) * d * g * eta * eta * ci * co / (wi.z * denom)));
}

/* A glossy lobe sampled from local wi by the uniforms u (x: reflect or
 * refract; yz: the visible normal): wo, the density in *pdf, and the
 * weight f |cos(wo)| / pdf, 0 where the sample is lost (below the
 * surface, or shadowed). */
inline float3 glossy_sample_local(const __global SpmMaterial* mat, float3 wi, float3 u, bool radiance, float3* wo,
                                  float* pdf) {
  *pdf = 0.0f;
  const uint type = mat->distribution;
  const float alpha = mat->alpha;
  if (wi.z == 0.0f || (mat->type == SPM_MAT_ROUGH_CONDUCTOR && wi.z < 0.0f)) return (float3)(0.0f);
  const float3 wi_up = wi.z > 0.0f ? wi : -wi;
  const float3 h = microfacet_sample(type, alpha, wi_up, SPM_F2(u.y, u.z));
  const float visible = microfacet_pdf(type, alpha, wi_up, h);
  if (!(visible > 0.0f)) return (float3)(0.0f);
  const float ci = dot(wi, h);
  if (mat->type == SPM_MAT_ROUGH_CONDUCTOR) {
    *wo = 2.0f * ci * h - wi;
    if (wo->z <= 0.0f) return (float3)(0.0f);
    *pdf = visible / (4.0f * dot(*wo, h));
    return load3(mat->specular) * fresnel_conductor(ci, load3(mat->k_eta), load3(mat->k)) *
           microfacet_g1(type, alpha, *wo, h);
  }
  float eta_rel, cos_t;
  const float f = rough_fresnel(mat, wi, h, &eta_rel, &cos_t);
  float weight;
  if (u.x <= f) {
    *wo = 2.0f * ci * h - wi;
    *pdf = visible * f / (4.0f * fabs(dot(*wo, h)));
    weight = 1.0f;
  } else {
    /* Refraction through the microfacet, on the far side of wi's. */
    const float sign = ci > 0.0f ? 1.0f : -1.0f;
    *wo = normalize(-wi / eta_rel + (ci / eta_rel - sign * cos_t) * h);
    const float co = dot(*wo, h);
    const float eta = wi.z > 0.0f ? mat->eta : 1.0f / mat->eta;
    *pdf = visible * (1.0f - f) * fabs(eta * eta * co / ((ci + eta * co) * (ci + eta * co)));
    weight = radiance ? 1.0f / (eta * eta) : 1.0f;
  }
  return (float3)(weight * microfacet_g1(type, alpha, *wo, h));
}

/* Origin for a ray leaving surf along d, on the side d points to. */
inline float3 leave_surface(const SpmSurface* surf, float3 d) {
  return offset_origin(surf->p, dot(d, surf->ng) > 0.0f ? surf->ng : -surf->ng, surf->extent);
}

#endif
