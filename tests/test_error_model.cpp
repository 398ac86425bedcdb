// The error model (host/render/error_model.h, docs/METHOD.md 15) on
// synthetic passes whose variance and bias are known: each value of pass k
// is mu + B r_k^2 plus Gaussian noise, and its probe's difference
// B r_k^2 (1 - s^2) plus noise of its own. Forty independent models give the
// estimate's mean and standard error; the truth must lie within four
// standard errors (plus 1% for the weights, which the model takes from the
// noisy image).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "render/error_model.h"
#include "render/render.h"
#include "stats.h"

namespace {

struct Synthetic {
  double mu = 1.0, bias = 0.2, noise = 0.05, probe_noise = 0.05;
  // With it, the probe's noise is photon_r2 ^ 1/2 / r: the photon maps' kind.
  double photon_r2 = 0.0;
  int passes = 6;
  size_t values = 600;
  bool half_probed = true;  // the probe covers every other value only
};

struct Truth {
  double variance = 0.0, bias = 0.0;
};

Truth truth(const Synthetic& c) {
  std::vector<double> r2(size_t(c.passes));
  double sum[2] = {}, n[2] = {}, all = 0.0;
  for (int k = 0; k < c.passes; ++k) {
    const double r = spm::pass_radius(1.0f, 0.9f, k);
    r2[size_t(k)] = r * r;
    sum[k % 2] += r * r;
    n[k % 2] += 1;
    all += r * r;
  }
  const double N = c.passes, mean_r2 = all / N, mean = c.mu + c.bias * mean_r2;
  const double weight = 1.0 / (mean * mean + 0.01);
  // E[n_a n_b (a - b)^2 / n^2]: the noise's part is sigma^2 / n; the
  // replicates' radii differ, so their means' bias differs by delta.
  const double delta = c.bias * (sum[0] / n[0] - sum[1] / n[1]);
  Truth t;
  t.variance = n[0] * n[1] / (N * N) * (delta * delta + c.noise * c.noise * (1 / n[0] + 1 / n[1])) * weight;
  t.bias = std::pow(c.bias * mean_r2, 2) * weight;
  return t;
}

spm::ErrorModel model_of(const Synthetic& c, uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss;
  spm::ErrorModel model(c.values);
  const double s2 = double(spm::kProbeScale) * spm::kProbeScale;
  for (int k = 0; k < c.passes; ++k) {
    const double r = spm::pass_radius(1.0f, 0.9f, k);
    std::vector<float> image(c.values), probe(c.values);
    for (size_t i = 0; i < c.values; ++i) {
      image[i] = float(c.mu + c.bias * r * r + c.noise * gauss(rng));
      const double probe_noise = c.photon_r2 > 0.0 ? std::sqrt(c.photon_r2) / r : c.probe_noise;
      probe[i] = c.half_probed && i % 2 ? NAN : float(c.bias * r * r * (1 - s2) + probe_noise * gauss(rng));
    }
    model.add(k, image, float(r), probe);
  }
  return model;
}

spm::ErrorEstimate run(const Synthetic& c, uint32_t seed) { return model_of(c, seed).estimate(); }

void check(const Synthetic& c, uint32_t first_seed) {
  std::vector<double> variance, bias;
  for (uint32_t s = 0; s < 40; ++s) {
    const spm::ErrorEstimate e = run(c, first_seed + s);
    ASSERT_EQ(e.passes, c.passes);
    EXPECT_DOUBLE_EQ(e.relmse, e.variance + e.bias);
    variance.push_back(e.variance);
    bias.push_back(e.bias);
  }
  const Truth t = truth(c);
  const spm::test::MeanAndError v = spm::test::mean_and_error(variance), b = spm::test::mean_and_error(bias);
  EXPECT_NEAR(v.mean, t.variance, 4 * v.error + 0.01 * t.variance) << "variance part";
  EXPECT_NEAR(b.mean, t.bias, 4 * b.error + 0.01 * t.bias) << "bias part";
}

TEST(ErrorModel, FindsTheVarianceAndTheBias) { check(Synthetic{}, 1000); }

TEST(ErrorModel, FindsTheBiasWhereItDominates) {
  Synthetic c;
  c.bias = 0.5;
  c.noise = 0.01;
  c.passes = 9;
  check(c, 2000);
}

// Without bias, the probes' noise must not show as bias. The squared mean
// of a value's noisy probes alone would read probe_noise^2 /
// (r^2 (1 - s^2))^2 / passes times (mean r^2)^2 / (mu^2 + 0.01), about 2e-3
// here; the estimate takes the probes' own spread out and is clamped at 0,
// which leaves a fraction of its standard deviation.
TEST(ErrorModel, ProbeNoiseIsNotBias) {
  Synthetic c;
  c.bias = 0.0;
  std::vector<double> bias;
  for (uint32_t s = 0; s < 40; ++s) bias.push_back(run(c, 3000 + s).bias);
  EXPECT_LT(spm::test::mean_and_error(bias).mean, 1e-4);
}

// `term` of the terms of 40 models, seeds first_seed onwards.
std::vector<double> terms_of(const Synthetic& c, uint32_t first_seed, double spm::ErrorTerms::*term) {
  std::vector<double> out;
  for (uint32_t s = 0; s < 40; ++s) {
    const spm::ErrorTerms t = model_of(c, first_seed + s).terms();
    EXPECT_TRUE(t.known);
    out.push_back(t.*term);
  }
  return out;
}

// The weight the model gives a value, 1 / (mean^2 + 0.01): the mean is mu
// plus B times the passes' mean r^2, about 0.8 over 8 or 9 passes.
double weight_of(const Synthetic& c) {
  const double mean = c.mu + c.bias * 0.8;
  return 1.0 / (mean * mean + 0.01);
}

// The planner's terms (render/planner.h): the photon maps' variance times
// r^2 from consecutive probes, whose means differ by the radius's shrinking
// alone (small here, as in a render: bias 0.02).
TEST(ErrorModel, FindsThePhotonVariance) {
  Synthetic c;
  c.bias = 0.02;
  c.photon_r2 = 0.003;
  c.passes = 8;
  const double weight = weight_of(c);
  const spm::test::MeanAndError p = spm::test::mean_and_error(terms_of(c, 4000, &spm::ErrorTerms::photon_r2));
  // The probes' differences also carry B r^3 (1 - s^2)'s change between
  // passes, under 1e-5 of photon_r2 here; the weight's mean varies by 2%.
  EXPECT_NEAR(p.mean, c.photon_r2 * weight, 4 * p.error + 0.03 * c.photon_r2 * weight);
}

// The bias per r^4 a plan reads: the probes' B^2 less kBiasConfidence
// standard errors of its mean over the values. Where the bias dominates
// (B = 0.5 read with noise 0.1 / r^2 per probe, 300 values) that took 8%
// off the truth here, and the bound allows up to 15%; where there is none
// it is 0 unless the noise happens to exceed two standard errors (about one
// model in 40).
TEST(ErrorModel, ThePlansBiasIsWhatTheProbesShow) {
  Synthetic c;
  c.bias = 0.5;
  c.noise = 0.01;
  c.passes = 9;
  const spm::test::MeanAndError b = spm::test::mean_and_error(terms_of(c, 5000, &spm::ErrorTerms::bias_per_r4));
  const double truth = c.bias * c.bias * weight_of(c);
  EXPECT_LT(b.mean, truth) << "it takes standard errors off, never adds them";
  EXPECT_GT(b.mean, 0.85 * truth) << "the seeds' own relative error " << b.error / truth;
  c = Synthetic{};
  c.bias = 0.0;
  const std::vector<double> none = terms_of(c, 6000, &spm::ErrorTerms::bias_per_r4);
  EXPECT_GE(std::count(none.begin(), none.end(), 0.0), 36);
}

TEST(ErrorModel, UnknownUntilBothReplicatesHaveAPass) {
  spm::ErrorModel model(3);
  const std::vector<float> image{1, 2, 3};
  EXPECT_LT(model.estimate().relmse, 0.0);
  model.add(0, image, 1.0f, std::vector<float>{});
  EXPECT_LT(model.estimate().relmse, 0.0);
  model.add(1, image, 1.0f, std::vector<float>{});
  EXPECT_DOUBLE_EQ(model.estimate().relmse, 0.0);
  EXPECT_EQ(model.estimate().passes, 2);
}

}  // namespace
