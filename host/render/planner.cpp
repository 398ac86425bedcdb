#include "render/planner.h"

#include <algorithm>

namespace spm {

namespace {

// A stage's cost at scale `s`, through (1, at_one) and (kCostScale,
// at_scaled): a + b s^2 where the smaller radius cost less (a query meets
// records in proportion to its area), a + c / s where it cost more (a ray
// walks cells of the radius's size, mirror_area's gather); at_one alone
// without a second measurement.
double cost_at(double at_one, double at_scaled, double s) {
  if (!(at_scaled > 0.0)) return at_one;
  const double k = kCostScale;
  if (at_scaled <= at_one) {
    const double b = (at_one - at_scaled) / (1.0 - k * k);
    return std::max(at_one + b * (s * s - 1.0), 0.0);
  }
  const double c = (at_scaled - at_one) / (1.0 / k - 1.0);
  return at_one + c * (1.0 / s - 1.0);
}

}  // namespace

Plan plan_passes(const PlanInputs& in) {
  Plan best;
  best.spp = std::max(1, int(std::lround(in.spp)));
  if (!in.terms.known || !(in.radius > 0.0f)) return best;
  const double r2 = double(in.radius) * in.radius;
  const double v0 = in.terms.pass_variance;
  // The probe gathers one camera sample, so its photon variance may exceed
  // the pass's, whose samples share one set of maps: the camera's part is
  // what is left, if anything.
  const double done2 = double(in.done_scale) * in.done_scale;
  const double vp = std::min(in.terms.photon_r2 / (r2 * done2), v0) * done2;  // at scale 1
  const double vc = (v0 - vp / done2) * in.spp;
  const double bias = in.terms.bias_per_r4 * r2 * r2;
  const bool timed = in.passes <= 0;
  const int steps = kPlanStepsPerOctave;
  const int lowest = in.choose_scale ? -kPlanOctavesDown * steps : 0;
  const int highest = in.choose_scale && timed ? kPlanOctavesUp * steps : 0;
  const int fewest = in.choose_spp ? 1 : best.spp, most = in.choose_spp ? in.max_spp : best.spp;
  for (int step = lowest; step <= highest; ++step) {
    const double s = std::exp2(step / double(steps)), s2 = s * s;
    const double fixed = cost_at(in.fixed_seconds, in.fixed_seconds_scaled, s);
    const double sample = cost_at(in.sample_seconds, in.sample_seconds_scaled, s);
    for (int m = fewest; m <= most; ++m) {
      const double pass_seconds = fixed + m * sample;
      if (timed && m > 1 && pass_seconds > in.max_pass_seconds) break;
      const double future = timed ? in.seconds / std::max(pass_seconds, 1e-9) : double(in.passes - in.done);
      const double n = in.done + std::max(future, 0.0);
      if (!(n > 0.0)) continue;
      const double variance = (in.done * v0 + future * (vc / m + vp / s2)) / (n * n);
      const double mean_bias = (in.done * done2 + future * s2) / n;
      const double predicted = variance + bias * mean_bias * mean_bias;
      if (best.predicted < 0.0 || predicted < best.predicted) {
        best.predicted = predicted;
        best.scale = float(s);
        best.spp = m;
        best.fixed_seconds = fixed;
        best.sample_seconds = sample;
      }
    }
  }
  return best;
}

}  // namespace spm
