// The gather's stratified camera samples (kernels/lib/rng.h: permute and
// stratify2), compiled as C++ through cl_compat.h: the same source the
// kernels embed. Each sample must stay uniform on its own, so that no
// estimate changes its mean, while a pixel's samples of a pass fill the
// strata of each coordinate once each.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "cl_compat.h"
#include "stats.h"

namespace {

using spm::clc::float2;
using spm::clc::SpmRng;

// Chi-square critical value at significance 0.001 for `dof` degrees of
// freedom (Wilson and Hilferty's cube-root approximation, z = 3.09).
double chi2_critical(double dof) {
  const double a = 2.0 / (9.0 * dof);
  return dof * std::pow(1.0 - a + 3.09 * std::sqrt(a), 3.0);
}

SpmRng pixel_rng(uint32_t pixel, uint32_t sample, uint32_t samples, uint32_t vertex = 0) {
  SpmRng r = spm::clc::rng_make(7u, 3u, pixel, sample * 256u + vertex);
  r.sample = sample;
  r.samples = samples;
  return r;
}

// The uniforms of one decision (purpose, lane) of a sample, stratified.
float2 strat(uint32_t pixel, uint32_t sample, uint32_t samples, uint32_t purpose, uint32_t lane = 0, uint32_t vertex = 0) {
  const SpmRng r = pixel_rng(pixel, sample, samples, vertex);
  const auto u = spm::clc::rng4(r, purpose, lane);
  return spm::clc::stratify2(r, purpose, lane, float2{u.x, u.y});
}

TEST(Strata, PermuteIsABijection) {
  for (uint32_t n = 1; n <= 130; ++n) {
    for (uint32_t key : {0u, 1u, 0x9e3779b9u, 0xdeadbeefu, 123456789u}) {
      std::vector<int> seen(n, 0);
      for (uint32_t i = 0; i < n; ++i) {
        const uint32_t p = spm::clc::permute(i, n, key);
        ASSERT_LT(p, n);
        ++seen[p];
      }
      for (uint32_t k = 0; k < n; ++k) EXPECT_EQ(seen[k], 1) << "n " << n << " key " << key << " value " << k;
    }
  }
}

TEST(Strata, APixelsSamplesFillEveryStratumOnce) {
  for (uint32_t n : {2u, 3u, 7u, 8u, 16u, 61u}) {
    for (uint32_t pixel = 0; pixel < 50; ++pixel) {
      for (uint32_t vertex : {0u, 5u}) {
        std::vector<int> sx(n, 0), sy(n, 0);
        for (uint32_t i = 0; i < n; ++i) {
          const float2 u = strat(pixel, i, n, 12u, 0u, vertex);
          ASSERT_GE(u.x, 0.0f);
          ASSERT_LT(u.x, 1.0f);
          ASSERT_GE(u.y, 0.0f);
          ASSERT_LT(u.y, 1.0f);
          ++sx[std::min(n - 1, uint32_t(u.x * n))];
          ++sy[std::min(n - 1, uint32_t(u.y * n))];
        }
        for (uint32_t k = 0; k < n; ++k) {
          EXPECT_EQ(sx[k], 1) << "n " << n << " pixel " << pixel << " x stratum " << k;
          EXPECT_EQ(sy[k], 1) << "n " << n << " pixel " << pixel << " y stratum " << k;
        }
      }
    }
  }
}

TEST(Strata, OneSampleIsUniformAndIndependentOfOtherDecisions) {
  // Over many pixels, sample 2 of 7: its two coordinates on an 8 x 8 grid,
  // and its x against the x of another decision of the same sample (the
  // permutations are keyed per decision, so the strata must not line up).
  const int bins = 8, pixels = 40000;
  std::vector<double> own(bins * bins, 0.0), across(bins * bins, 0.0);
  for (int p = 0; p < pixels; ++p) {
    const float2 a = strat(uint32_t(p), 2u, 7u, 12u);
    const float2 b = strat(uint32_t(p), 2u, 7u, 0u);
    own[int(a.x * bins) * bins + int(a.y * bins)] += 1.0;
    across[int(a.x * bins) * bins + int(b.x * bins)] += 1.0;
  }
  const double expected = double(pixels) / (bins * bins);
  double c_own = 0.0, c_across = 0.0;
  for (int k = 0; k < bins * bins; ++k) {
    c_own += (own[k] - expected) * (own[k] - expected) / expected;
    c_across += (across[k] - expected) * (across[k] - expected) / expected;
  }
  EXPECT_LT(c_own, chi2_critical(bins * bins - 1));
  EXPECT_LT(c_across, chi2_critical(bins * bins - 1));
}

TEST(Strata, APixelsMeanKeepsItsExpectationWithLessVariance) {
  // f(x, y) = x + y^2 + x y over a pixel's 8 samples, over many pixels:
  // the mean must match the integral 1/2 + 1/3 + 1/4 within 4 standard
  // errors, and the variance of a pixel's mean must fall well below the
  // independent samples' Var(f) / 8 (a Latin hypercube removes the
  // additive parts x and y^2, leaving the x y term's share).
  const uint32_t n = 8;
  const int pixels = 20000;
  std::vector<double> means(pixels);
  for (int p = 0; p < pixels; ++p) {
    double s = 0.0;
    for (uint32_t i = 0; i < n; ++i) {
      const float2 u = strat(uint32_t(p), i, n, 11u, 1u);
      s += u.x + u.y * u.y + u.x * u.y;
    }
    means[p] = s / n;
  }
  const auto m = spm::test::mean_and_error(means);
  const double exact = 0.5 + 1.0 / 3.0 + 0.25;
  EXPECT_NEAR(m.mean, exact, 4.0 * m.error);
  const double var_mean = m.error * m.error * pixels;
  // Var(f) for independent uniforms x, y: E[f^2] - E[f]^2, in closed form.
  const double ef2 = 1.0 / 3.0 + 1.0 / 5.0 + 1.0 / 9.0 + 2.0 / 6.0 + 2.0 / 6.0 + 2.0 / 8.0;
  const double var_independent = (ef2 - exact * exact) / n;
  EXPECT_LT(var_mean, 0.25 * var_independent);
}

TEST(Strata, ASingleSampleIsLeftAsDrawn) {
  for (uint32_t p = 0; p < 100; ++p) {
    const SpmRng r = pixel_rng(p, 0u, 1u);
    const auto u = spm::clc::rng4(r, 12u, 0u);
    const float2 s = spm::clc::stratify2(r, 12u, 0u, float2{u.x, u.y});
    EXPECT_EQ(s.x, u.x);
    EXPECT_EQ(s.y, u.y);
  }
}

}  // namespace
