// The glossy lobes of roughconductor and roughdielectric, and the plastic's
// diffuse base (kernels/lib/bsdf.h, docs/METHOD.md 13), run on the device
// through kernels/spm_bsdf_test.cl: samples against the density the lobe
// evaluates (a chi-square test), each sample's weight against its
// evaluation over its density, and white furnaces.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "device/device.h"
#include "scene/fresnel.h"
#include "spm_types.h"
#include "stats.h"
#include "test_support.h"

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Lobe {
  std::string name;
  SpmMaterial material;
  float theta_i;  // degrees from the normal; past 90 the direction comes from inside
};

SpmMaterial rough(spm_uint type, spm_uint distribution, float alpha, float eta = 1.5f) {
  SpmMaterial m{};
  m.type = type;
  m.distribution = distribution;
  m.alpha = alpha;
  m.eta = eta;
  for (int c = 0; c < 3; ++c) m.specular[c] = 1.0f;
  // Gold's index (Mitsuba's "Au"), so that the Fresnel term varies.
  const float eta_au[3] = {0.143036f, 0.3753071f, 1.442045f}, k_au[3] = {3.982997f, 2.385556f, 1.603359f};
  for (int c = 0; c < 3; ++c) m.k_eta[c] = eta_au[c], m.k[c] = k_au[c];
  return m;
}

cl_float4 direction(float theta_deg) {
  const float t = float(theta_deg * kPi / 180.0);
  return {{std::sin(t), 0.0f, std::cos(t), 0.0f}};
}

struct Samples {
  std::vector<cl_float4> dirs, weights;
};

Samples sample(const SpmMaterial& m, float theta_i, bool radiance, uint32_t n, uint32_t seed) {
  auto& dev = spm::test::device();
  const spm::DeviceBuffer mb = dev.upload("materials", std::vector<SpmMaterial>{m});
  const spm::DeviceBuffer dirs = dev.buffer(sizeof(cl_float4) * n, "dirs", CL_MEM_WRITE_ONLY);
  const spm::DeviceBuffer weights = dev.buffer(sizeof(cl_float4) * n, "weights", CL_MEM_WRITE_ONLY);
  cl::Kernel k = dev.kernel("spm_bsdf_test", "spm_bsdf_sample_test");
  spm::set_args(k, spm::arg("materials", mb), spm::arg("material", cl_uint(0)), spm::arg("wi", direction(theta_i)),
                spm::arg("radiance", cl_uint(radiance)), spm::arg("seed", cl_uint(seed)), spm::arg("dirs", dirs),
                spm::arg("weights", weights), spm::arg("count", cl_uint(n)));
  dev.launch(k, n);
  return {dev.download<cl_float4>(dirs, n), dev.download<cl_float4>(weights, n)};
}

std::vector<cl_float4> evaluate(const SpmMaterial& m, float theta_i, bool radiance, const std::vector<cl_float4>& wos) {
  auto& dev = spm::test::device();
  const spm::DeviceBuffer mb = dev.upload("materials", std::vector<SpmMaterial>{m});
  const spm::DeviceBuffer in = dev.upload("wos", wos);
  const spm::DeviceBuffer out = dev.buffer(sizeof(cl_float4) * wos.size(), "out", CL_MEM_WRITE_ONLY);
  cl::Kernel k = dev.kernel("spm_bsdf_test", "spm_bsdf_eval_test");
  spm::set_args(k, spm::arg("materials", mb), spm::arg("material", cl_uint(0)), spm::arg("wi", direction(theta_i)),
                spm::arg("radiance", cl_uint(radiance)), spm::arg("wos", in), spm::arg("out", out),
                spm::arg("count", cl_uint(wos.size())));
  dev.launch(k, wos.size());
  return dev.download<cl_float4>(out, wos.size());
}

std::vector<Lobe> lobes() {
  const spm_uint C = SPM_MAT_ROUGH_CONDUCTOR, D = SPM_MAT_ROUGH_DIELECTRIC;
  const spm_uint B = SPM_MICROFACET_BECKMANN, G = SPM_MICROFACET_GGX;
  return {
      {"conductor GGX 0.3 at 40", rough(C, G, 0.3f), 40.0f},
      {"conductor Beckmann 0.3 at 60", rough(C, B, 0.3f), 60.0f},
      {"conductor GGX 0.6 at 80", rough(C, G, 0.6f), 80.0f},
      {"conductor Beckmann 0.15 at 10", rough(C, B, 0.15f), 10.0f},
      {"dielectric GGX 0.3 at 45", rough(D, G, 0.3f), 45.0f},
      {"dielectric Beckmann 0.4 from inside at 30", rough(D, B, 0.4f), 150.0f},
      {"dielectric GGX 0.2 from inside at 50", rough(D, G, 0.2f), 130.0f},
      {"dielectric Beckmann 0.25 at 75", rough(D, B, 0.25f, 1.33f), 75.0f},
  };
}

// Wilson and Hilferty's normal approximation of the chi-square distribution
// with k degrees of freedom: the z-score of x.
double chi2_z(double x, double k) {
  const double v = 2.0 / (9.0 * k);
  return (std::cbrt(x / k) - (1.0 - v)) / std::sqrt(v);
}

// The sampled directions, binned in (cos theta, phi), against the lobe's
// density integrated over each bin (16 x 16 midpoints), scaled to the
// samples the lobe keeps; the ones it loses (weight 0: below the surface
// or shadowed) against what the density's integral leaves of 1. Bins
// expecting fewer than 5 samples are pooled. z < 3.7 is a p-value above
// 1e-4.
TEST(Glossy, SamplesFollowTheDensityTheLobeEvaluates) {
  constexpr int kCos = 24, kPhi = 24, kSub = 16, kPolar = 8;
  const uint32_t kSamples = getenv("NS") ? atoi(getenv("NS")) : 200000;
  for (const Lobe& lobe : lobes()) {
    const Samples s = sample(lobe.material, lobe.theta_i, true, kSamples, getenv("SEED") ? atoi(getenv("SEED")) : 11);
    std::vector<double> observed(kCos * kPhi + 1, 0.0);
    for (uint32_t i = 0; i < kSamples; ++i) {
      const cl_float4& w = s.weights[i];
      if (!(std::max({w.s[0], w.s[1], w.s[2]}) > 0.0f)) {
        observed.back() += 1.0;
        continue;
      }
      const cl_float4& d = s.dirs[i];
      const double phi = std::atan2(double(d.s[1]), double(d.s[0])) + kPi;
      const int a = std::min(kCos - 1, int((double(d.s[2]) + 1.0) * 0.5 * kCos));
      const int b = std::min(kPhi - 1, int(phi / (2.0 * kPi) * kPhi));
      observed[a * kPhi + b] += 1.0;
    }
    // The density as a function of cos theta has an infinite slope at the
    // poles, where the midpoint rule converges slowly: the two polar rows
    // of bins take kPolar times the rows of midpoints, in t, 1 -+ cos theta
    // = t^2, instead.
    std::vector<cl_float4> points;
    std::vector<std::pair<int, double>> cells;  // the bin and the solid angle of each point
    const double dphi = 2.0 * kPi / kPhi / kSub, dc = 2.0 / kCos / kSub;
    const double t_max = std::sqrt(2.0 / kCos), dt = t_max / (kPolar * kSub);
    for (int a = 0; a < kCos; ++a)
      for (int b = 0; b < kPhi; ++b)
        for (int i = 0; i < (a == 0 || a == kCos - 1 ? kPolar * kSub : kSub); ++i)
          for (int j = 0; j < kSub; ++j) {
            double c = -1.0 + (a * kSub + i + 0.5) * dc, weight = dc;
            if (a == 0 || a == kCos - 1) {
              const double t = (i + 0.5) * dt;
              c = a == 0 ? -1.0 + t * t : 1.0 - t * t;
              weight = 2.0 * t * dt;
            }
            const double phi = (b * kSub + j + 0.5) * dphi - kPi;
            const double r = std::sqrt(std::max(0.0, 1.0 - c * c));
            points.push_back({{float(r * std::cos(phi)), float(r * std::sin(phi)), float(c), 0.0f}});
            cells.emplace_back(a * kPhi + b, weight * dphi);
          }
    const std::vector<cl_float4> f = evaluate(lobe.material, lobe.theta_i, true, points);
    std::vector<double> expected(observed.size() - 1, 0.0);
    double mass = 0.0;
    for (size_t p = 0; p < points.size(); ++p) {
      const double m = f[p].s[3] * cells[p].second;
      expected[cells[p].first] += m;
      mass += m;
    }
    const double lost = observed.back(), kept = kSamples - lost;
    double chi2 = 0.0, pooled_o = 0.0, pooled_e = 0.0;
    int bins = 0;
    for (size_t i = 0; i < expected.size(); ++i) {
      const double e = expected[i] / mass * kept;
      if (e < 5.0) {
        pooled_o += observed[i];
        pooled_e += e;
        continue;
      }
      chi2 += (observed[i] - e) * (observed[i] - e) / e;
      ++bins;
    }
    if (pooled_e > 0.0) {
      chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / std::max(pooled_e, 1.0);
      ++bins;
    }
    const double z = chi2_z(chi2, bins - 1);
    EXPECT_LT(z, 3.7) << lobe.name << ": chi2 " << chi2 << " over " << bins << " bins";
    // The share of samples lost, against what the density's integral
    // leaves of 1: within 4 standard errors and the quadrature's 1e-3.
    const double p_lost = std::clamp(1.0 - mass, 0.0, 1.0);
    EXPECT_NEAR(lost / kSamples, p_lost, 4.0 * std::sqrt(p_lost * (1.0 - p_lost) / kSamples) + 1e-3)
        << lobe.name << ": density mass " << mass;
    EXPECT_GT(mass, 0.5) << lobe.name;
  }
}

// Each sample's weight is f |cos| / pdf of the very direction it took, and
// the density the sample reports is the one the evaluation gives, in both
// transports.
TEST(Glossy, WeightsAreTheEvaluationOverTheDensity) {
  constexpr uint32_t kSamples = 20000;
  for (const Lobe& lobe : lobes()) {
    for (const bool radiance : {true, false}) {
      const Samples s = sample(lobe.material, lobe.theta_i, radiance, kSamples, 5);
      const std::vector<cl_float4> f = evaluate(lobe.material, lobe.theta_i, radiance, s.dirs);
      int checked = 0;
      for (uint32_t i = 0; i < kSamples; ++i) {
        const float pdf = s.dirs[i].s[3];
        if (!(std::max({s.weights[i].s[0], s.weights[i].s[1], s.weights[i].s[2]}) > 0.0f)) continue;
        ++checked;
        ASSERT_NEAR(f[i].s[3], pdf, 2e-3f * pdf) << lobe.name << " sample " << i;
        for (int c = 0; c < 3; ++c)
          ASSERT_NEAR(f[i].s[c], s.weights[i].s[c] * pdf, 2e-3f * f[i].s[c] + 1e-7f)
              << lobe.name << " radiance " << radiance << " sample " << i << " channel " << c;
      }
      EXPECT_GT(checked, int(kSamples / 2)) << lobe.name;
    }
  }
}

// White furnaces: a rough conductor that reflects everything (eta 0, k 1)
// and a rough dielectric carrying photons, at roughness 0.1, keep the light
// but for what their microfacets' single scattering loses; the mean weight
// matches Mitsuba 3.9.1's (tools/furnace_albedos.py, 4M samples each) to
// 4 standard errors and 1e-3, the share by which Mitsuba's fitted Beckmann
// shadowing may differ from the exact one spm uses (kernels/lib/microfacet.h).
// GGX's long tail loses up to 3% at 60 degrees in both.
TEST(Glossy, WhiteFurnacesMatchMitsuba) {
  struct Furnace {
    spm_uint type, distribution;
    float theta, mitsuba;
  };
  const spm_uint C = SPM_MAT_ROUGH_CONDUCTOR, D = SPM_MAT_ROUGH_DIELECTRIC;
  const spm_uint B = SPM_MICROFACET_BECKMANN, G = SPM_MICROFACET_GGX;
  const Furnace furnaces[] = {
      {C, B, 0, 1.0f},       {C, B, 30, 1.0f},      {C, B, 60, 0.999854f}, {D, B, 0, 1.0f},
      {D, B, 30, 1.0f},      {D, B, 60, 0.999966f}, {D, B, 150, 1.0f},     {C, G, 0, 0.988354f},
      {C, G, 30, 0.986142f}, {C, G, 60, 0.969177f}, {D, G, 0, 0.998826f},  {D, G, 30, 0.998213f},
      {D, G, 60, 0.992238f}, {D, G, 150, 0.985201f},
  };
  constexpr uint32_t kSamples = 200000;
  for (const Furnace& f : furnaces) {
    SpmMaterial m = rough(f.type, f.distribution, 0.1f);
    for (int c = 0; c < 3; ++c) m.k_eta[c] = 0.0f, m.k[c] = 1.0f;
    const Samples s = sample(m, f.theta, false, kSamples, 3);
    std::vector<double> w(kSamples);
    for (uint32_t i = 0; i < kSamples; ++i) w[i] = s.weights[i].s[0];
    const spm::test::MeanAndError e = spm::test::mean_and_error(w);
    EXPECT_NEAR(e.mean, f.mitsuba, 4.0 * e.error + 1e-3)
        << (f.type == C ? "conductor" : "dielectric") << " distribution " << f.distribution << " at " << f.theta;
  }
}

// The plastic's base, white, lets out all it takes in: the cosine-weighted
// mean of diffuse_exit over the hemisphere is (1 - fdr_ext) / ((1 -
// fdr_int) eta^2), which is 1 for every eta (the two diffuse Fresnel
// reflectances are so related), to the quadrature's 1e-4; so white plastic
// loses nothing.
TEST(Glossy, AWhitePlasticsBaseLetsAllOut) {
  for (const float eta : {1.33f, 1.49f, 2.0f}) {
    EXPECT_NEAR(1.0 - spm::fresnel_diffuse_reflectance(eta),
                eta * eta * (1.0 - spm::fresnel_diffuse_reflectance(1.0 / eta)), 1e-5)
        << eta;
    SpmMaterial m{};
    m.type = SPM_MAT_PLASTIC;
    m.eta = eta;
    for (int c = 0; c < 3; ++c) m.reflectance[c] = 1.0f;
    m.fdr_int = float(spm::fresnel_diffuse_reflectance(1.0 / eta));
    constexpr int kSteps = 4096;
    std::vector<float> cosines(kSteps);
    for (int i = 0; i < kSteps; ++i) cosines[i] = (i + 0.5f) / kSteps;
    auto& dev = spm::test::device();
    const spm::DeviceBuffer mb = dev.upload("materials", std::vector<SpmMaterial>{m});
    const spm::DeviceBuffer cb = dev.upload("cosines", cosines);
    const spm::DeviceBuffer out = dev.buffer(sizeof(cl_float4) * kSteps, "out", CL_MEM_WRITE_ONLY);
    cl::Kernel k = dev.kernel("spm_bsdf_test", "spm_diffuse_exit_test");
    spm::set_args(k, spm::arg("materials", mb), spm::arg("material", cl_uint(0)), spm::arg("cosines", cb),
                  spm::arg("out", out), spm::arg("count", cl_uint(kSteps)));
    dev.launch(k, kSteps);
    const std::vector<cl_float4> e = dev.download<cl_float4>(out, kSteps);
    double sum = 0.0;
    for (int i = 0; i < kSteps; ++i) sum += e[i].s[0] * cosines[i];
    EXPECT_NEAR(2.0 * sum / kSteps, 1.0, 1e-4) << eta;
  }
}

}  // namespace
