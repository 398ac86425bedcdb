// Fresnel terms the host needs to set materials up (docs/METHOD.md 13);
// the kernels evaluate their own (kernels/lib/bsdf.h).
#pragma once

#include <cmath>

namespace spm {

// Unpolarised reflectance at cosine cos_i for relative index eta = eta_t /
// eta_i; 1 past the critical angle.
inline double fresnel_dielectric(double cos_i, double eta) {
  const double sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.0) return 1.0;
  const double cos_t = std::sqrt(1.0 - sin2_t);
  const double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  const double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

// The share of uniformly diffuse light that a boundary of relative index
// eta reflects, 2 int_0^1 F(mu) mu dmu, by the midpoint rule (the integrand
// is smooth but for the kink at the critical angle; 4096 points put it
// within 1e-6). Mitsuba 3 uses fits to it (Egan and Hilgeman 1973; d'Eon
// and Irving 2011), within 0.1% for the indices of plastics.
inline double fresnel_diffuse_reflectance(double eta) {
  constexpr int kSteps = 1 << 16;
  double sum = 0.0;
  for (int i = 0; i < kSteps; ++i) {
    const double mu = (i + 0.5) / kSteps;
    sum += fresnel_dielectric(mu, eta) * mu;
  }
  return 2.0 * sum / kSteps;
}

}  // namespace spm
