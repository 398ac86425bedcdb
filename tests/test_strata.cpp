// The gather's stratified camera samples (kernels/lib/rng.h: stratify2, a
// shuffled, Owen-scrambled Sobol' (0,2)-sequence per pixel and decision),
// compiled as C++ through cl_compat.h: the same source the kernels embed.
// Each sample must stay uniform on its own, so that no estimate changes its
// mean, while every aligned run of 2^k of a pixel's samples is a (0,k,2)-net.
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

// The uniforms of one decision (purpose, lane) of the pixel's sample
// `sample` at `vertex`, in pass `pass` (which must not matter).
float2 strat(uint32_t pixel, uint32_t sample, uint32_t purpose, uint32_t lane = 0, uint32_t vertex = 0,
             uint32_t strata = 1, uint32_t pass = 3) {
  SpmRng r = spm::clc::rng_make(7u, pass, pixel, (sample % 64u) * 256u + vertex);
  r.sample = sample;
  r.strata = strata;
  return spm::clc::stratify2(r, purpose, lane);
}

TEST(Strata, EveryAlignedRunOfSamplesIsANet) {
  // Runs of 2^k samples starting at multiples of 2^k (a pass of 8 samples,
  // the whole render's first 512): each elementary box of area 2^-k, of
  // every shape 2^-a x 2^-(k - a), holds exactly one point.
  for (uint32_t pixel = 0; pixel < 12; ++pixel) {
    for (uint32_t vertex : {0u, 4u}) {
      for (uint32_t k = 1; k <= 9; ++k) {
        const uint32_t n = 1u << k;
        for (uint32_t run = 0; run < 3; ++run) {
          std::vector<float2> pts;
          for (uint32_t i = 0; i < n; ++i) pts.push_back(strat(pixel, run * n + i, 12u, 0u, vertex));
          for (uint32_t a = 0; a <= k; ++a) {
            const uint32_t nx = 1u << a, ny = n >> a;
            std::vector<int> boxes(n, 0);
            for (const float2& p : pts) {
              ASSERT_GE(p.x, 0.0f);
              ASSERT_LT(p.x, 1.0f);
              ASSERT_GE(p.y, 0.0f);
              ASSERT_LT(p.y, 1.0f);
              ++boxes[uint32_t(p.x * nx) * ny + uint32_t(p.y * ny)];
            }
            for (uint32_t b = 0; b < n; ++b) {
              ASSERT_EQ(boxes[b], 1) << "pixel " << pixel << " run " << run << " of " << n << ", boxes " << nx
                                     << " x " << ny << ", box " << b;
            }
          }
        }
      }
    }
  }
}

TEST(Strata, ThePassDoesNotChooseTheSequence) {
  for (uint32_t s = 0; s < 64; ++s) {
    const float2 a = strat(5u, s, 11u, 1u, 2u, 1u, 0u), b = strat(5u, s, 11u, 1u, 2u, 1u, 9u);
    EXPECT_EQ(a.x, b.x);
    EXPECT_EQ(a.y, b.y);
  }
}

// Chi-square of `pairs` (coordinates in [0, 1)) on an 8 x 8 grid.
double chi2_8x8(const std::vector<std::pair<float, float>>& pairs) {
  const int bins = 8;
  std::vector<double> count(bins * bins, 0.0);
  for (const auto& [x, y] : pairs) count[int(x * bins) * bins + int(y * bins)] += 1.0;
  const double expected = double(pairs.size()) / (bins * bins);
  double c = 0.0;
  for (double v : count) c += (v - expected) * (v - expected) / expected;
  return c;
}

TEST(Strata, OneSampleIsUniformAndIndependentOfOtherDecisionsAndSequences) {
  // Over many pixels, one sample index: its two coordinates; its x against
  // the x of another decision of the same sample; and against the same
  // decision in another process's sequence (strata 2).
  for (uint32_t sample : {0u, 5u, 1000u}) {
    std::vector<std::pair<float, float>> own, decisions, sequences;
    for (uint32_t p = 0; p < 40000; ++p) {
      const float2 a = strat(p, sample, 12u);
      own.emplace_back(a.x, a.y);
      decisions.emplace_back(a.x, strat(p, sample, 0u).x);
      sequences.emplace_back(a.x, strat(p, sample, 12u, 0u, 0u, 2u).x);
    }
    EXPECT_LT(chi2_8x8(own), chi2_critical(63)) << "sample " << sample;
    EXPECT_LT(chi2_8x8(decisions), chi2_critical(63)) << "sample " << sample;
    EXPECT_LT(chi2_8x8(sequences), chi2_critical(63)) << "sample " << sample;
  }
}

TEST(Strata, APixelsMeanKeepsItsExpectationWithLessVariance) {
  // f(x, y) = x + y^2 + x y over a pixel's first 64 samples (8 passes of 8),
  // over many pixels: the mean must match the integral 1/2 + 1/3 + 1/4
  // within 4 standard errors, and the variance of a pixel's mean must fall
  // far below the independent samples' Var(f) / 64 (a scrambled net's
  // variance for a smooth integrand falls as n^-3).
  const uint32_t n = 64;
  const int pixels = 20000;
  std::vector<double> means(pixels);
  for (int p = 0; p < pixels; ++p) {
    double s = 0.0;
    for (uint32_t i = 0; i < n; ++i) {
      const float2 u = strat(uint32_t(p), i, 11u, 1u);
      s += u.x + u.y * u.y + u.x * u.y;
    }
    means[p] = s / n;
  }
  const auto m = spm::test::mean_and_error(means);
  const double exact = 0.5 + 1.0 / 3.0 + 0.25;
  EXPECT_NEAR(m.mean, exact, 4.0 * m.error + 1e-6);
  const double var_mean = m.error * m.error * pixels;
  // Var(f) for independent uniforms x, y: E[f^2] - E[f]^2, in closed form.
  const double ef2 = 1.0 / 3.0 + 1.0 / 5.0 + 1.0 / 9.0 + 2.0 / 6.0 + 2.0 / 6.0 + 2.0 / 8.0;
  const double var_independent = (ef2 - exact * exact) / n;
  EXPECT_LT(var_mean, 0.01 * var_independent);
}

TEST(Strata, TheCameraSamplesDrawApartFromTheStreams) {
  // A pixel's counter (pixel, 256 sample + vertex, purpose, lane) equals a
  // stream's (id, event, purpose, lane) whenever pixel = id and sample 0's
  // vertex = event. Under one key the two would draw the same uniform;
  // rng_gather's key keeps them apart: no pair coincides, and over many
  // pairs their correlation is within 4 standard errors (1 / sqrt(n)) of 0.
  std::vector<double> a, b;
  for (uint32_t id = 0; id < 4096; ++id) {
    for (uint32_t event : {0u, 1u, 2u, 5u}) {
      for (uint32_t purpose : {SPM_RNG_BSDF, SPM_RNG_PHASE, SPM_RNG_DISTANCE, SPM_RNG_LIGHT_PICK}) {
        const auto s = spm::clc::rng4(spm::clc::rng_make(7u, 3u, id, event), purpose, 0u);
        const auto g = spm::clc::rng4(spm::clc::rng_gather(7u, 3u, id, event), purpose, 0u);
        ASSERT_FALSE(s.x == g.x && s.y == g.y && s.z == g.z && s.w == g.w)
            << "pixel and stream " << id << ", event " << event << ", purpose " << purpose;
        a.push_back(s.x);
        b.push_back(g.x);
      }
    }
  }
  const double n = double(a.size());
  double ma = 0.0, mb = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    ma += a[i] / n;
    mb += b[i] / n;
  }
  double sab = 0.0, saa = 0.0, sbb = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  EXPECT_LT(std::fabs(sab / std::sqrt(saa * sbb)), 4.0 / std::sqrt(n));
}

}  // namespace
