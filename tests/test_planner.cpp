// The planner (host/render/planner.h, docs/METHOD.md 15) against the closed
// forms of its prediction: with no passes done and costs that do not follow
// the radius, N passes at scale s have error Vp / (N s^2) + bias s^4, least
// at s^6 = Vp / (2 N bias); a timed render's passes of fixed cost T0 plus
// m samples of cost c have error (T0 + m c) (Vc / m + Vp) / T, least at
// m^2 = T0 Vc / (c Vp); and where the cost follows the radius, least where
// its derivative balances the bias's.
#include <gtest/gtest.h>

#include <cmath>

#include "render/planner.h"

namespace {

spm::PlanInputs inputs(double pass_variance, double photon, double bias) {
  spm::PlanInputs in;
  in.terms.known = true;
  in.terms.pass_variance = pass_variance;
  in.terms.photon_r2 = photon;  // at radius 1: Vp itself
  in.terms.bias_per_r4 = bias;
  in.radius = 1.0f;
  in.spp = 1.0;
  return in;
}

TEST(Planner, ScaleBalancesPhotonNoiseAgainstBias) {
  for (const double bias : {1e-4, 1e-3, 1e-2}) {
    spm::PlanInputs in = inputs(0.01, 0.01, bias);
    in.passes = 16;
    in.fixed_seconds = in.sample_seconds = 1.0;
    const spm::Plan plan = spm::plan_passes(in);
    const double best = std::pow(0.01 / (2.0 * 16 * bias), 1.0 / 6.0);
    // The scales step by an eighth of an octave; a pass count keeps them at most 1.
    EXPECT_NEAR(std::log2(plan.scale), std::log2(std::min(best, 1.0)), 1.0 / 16 + 1e-9) << "bias " << bias;
    EXPECT_LE(plan.scale, 1.0f);
    EXPECT_EQ(plan.spp, 1);
  }
}

TEST(Planner, SamplesBalanceTheCameraAgainstThePhotons) {
  // Vc = 0.09 per sample, Vp = 0.01, T0 = 1 s, c = 0.1 s: m* = sqrt(90) = 9.5.
  spm::PlanInputs in = inputs(0.1, 0.01, 0.0);
  in.seconds = 100.0;
  in.fixed_seconds = 1.0;
  in.sample_seconds = 0.1;
  in.choose_scale = false;
  in.choose_spp = true;
  in.max_spp = 64;
  const spm::Plan plan = spm::plan_passes(in);
  EXPECT_TRUE(plan.spp == 9 || plan.spp == 10) << plan.spp;
  EXPECT_FLOAT_EQ(plan.scale, 1.0f);
  EXPECT_NEAR(plan.predicted, (1.0 + plan.spp * 0.1) * (0.09 / plan.spp + 0.01) / 100.0, 1e-12);
}

TEST(Planner, ATimedRenderWeighsTheRadiusAgainstItsCost) {
  // One sample per pass of cost c(s), T = 100 s, Vp = 0.01, bias 1e-4, no
  // camera noise: error Vp c(s) / (T s^2) + bias s^4. A cost that does not
  // follow the radius (c = 1.01) is least at s^6 = Vp c / (2 T bias); one
  // that grows as 0.01 + s^2 (fitted to 1.01 at s = 1, 0.26 at s = 1/2) at
  // s^6 = 0.01 Vp / (2 T bias).
  spm::PlanInputs in = inputs(0.01, 0.01, 1e-4);
  in.seconds = 100.0;
  in.sample_seconds = 1.01;
  const spm::Plan flat = spm::plan_passes(in);
  EXPECT_NEAR(std::log2(flat.scale), std::log2(std::pow(0.01 * 1.01 / (2 * 100 * 1e-4), 1.0 / 6)), 1.0 / 16 + 1e-9);
  in.sample_seconds_scaled = 0.26;
  const spm::Plan grows = spm::plan_passes(in);
  EXPECT_NEAR(std::log2(grows.scale), std::log2(std::pow(0.01 * 0.01 / (2 * 100 * 1e-4), 1.0 / 6)), 1.0 / 16 + 1e-9);
  EXPECT_NEAR(grows.sample_seconds, 0.01 + double(grows.scale) * grows.scale, 1e-6);
  // One that cost more at the smaller radius (2.02 at s = 1/2: a ray walks
  // cells of the radius's size), a + c / s with a = 0, c = 1.01: least at
  // s^7 = 3 Vp c / (4 T bias).
  in.sample_seconds_scaled = 2.02;
  const spm::Plan walks = spm::plan_passes(in);
  EXPECT_NEAR(std::log2(walks.scale), std::log2(std::pow(3 * 0.01 * 1.01 / (4 * 100 * 1e-4), 1.0 / 7)),
              1.0 / 16 + 1e-9);
  EXPECT_NEAR(walks.sample_seconds, 1.01 / walks.scale, 1e-6);
  // Camera noise only and a cost that grows with the radius: the smallest wins.
  in = inputs(0.01, 0.0, 0.0);
  in.seconds = 100.0;
  in.sample_seconds = 1.0;
  in.sample_seconds_scaled = 0.5;
  EXPECT_FLOAT_EQ(spm::plan_passes(in).scale, std::exp2(-float(spm::kPlanOctavesDown)));
}

TEST(Planner, NoPlanWithoutTerms) {
  spm::PlanInputs in;
  in.spp = 3.0;
  in.passes = 8;
  const spm::Plan plan = spm::plan_passes(in);
  EXPECT_LT(plan.predicted, 0.0);
  EXPECT_FLOAT_EQ(plan.scale, 1.0f);
  EXPECT_EQ(plan.spp, 3);
}

}  // namespace
