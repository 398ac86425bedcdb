// The passes to come, planned from the error model (docs/METHOD.md 15): the
// radius scale and, for a timed render, the camera samples per pass that
// minimise the error predicted at the end of the budget.
//
// The prediction. A pass at radius scale s (s = 1: the passes measured so
// far) with m camera samples per pixel has variance Vc / m + Vp / s^2: the
// camera's part Vc per sample, and the photon maps' part Vp (ErrorTerms
// photon_r2 over r^2), which the pass's samples share. Its bias part is
// beta^2 r^4 s^4. N passes' mean has the mean of their variances over N and
// the square of the mean of their biases. A timed render's pass costs its
// photon stages plus m times a sample's gather, each fitted to a pass at
// s = 1 and one at s = kCostScale: a + b s^2 where the smaller radius cost
// less (the records a query meets), a + c / s where it cost more (the
// cells a ray walks); the seconds left buy the passes. A pass count is a
// budget of passes, not time: the scale then minimises the error alone and
// stays at most 1, since the pilot's radius already bounds what a pass's
// gather can afford. The radius's progressive shrinking within the budget
// is left out of the prediction: over a budget's passes it moves r^2 by
// tens of per cent, and the chosen scale with the sixth root of that.
#pragma once

#include <cmath>

#include "render/error_model.h"
#include "render/tuning.h"

namespace spm {

struct PlanInputs {
  ErrorTerms terms;
  float radius = 0.0f;  // the radius of scale 1
  double spp = 1.0;     // the passes' mean camera samples per pixel so far
  int done = 0;         // passes in the image so far
  float done_scale = 1.0f;  // their radius scale (the latest's)
  // The budget: passes in all, or with passes 0, the seconds left.
  int passes = 0;
  double seconds = 0.0;
  // A pass's costs at scale 1 and at kCostScale (0: not measured, costs
  // that do not follow the radius): what does not grow with its samples
  // (propagation, grids, the probe), and the gather per camera sample per pixel.
  double fixed_seconds = 0.0, sample_seconds = 0.0;
  double fixed_seconds_scaled = 0.0, sample_seconds_scaled = 0.0;
  int max_spp = 1;
  double max_pass_seconds = INFINITY;
  bool choose_scale = true;  // false: samples only, at scale 1
  bool choose_spp = false;   // false: the passes keep `spp`
};

struct Plan {
  float scale = 1.0f;
  int spp = 1;
  double predicted = -1.0;  // relMSE at the end of the budget; -1: no plan (terms unknown)
  // A pass's predicted costs at `scale`, as PlanInputs has them.
  double fixed_seconds = 0.0, sample_seconds = 0.0;
};

Plan plan_passes(const PlanInputs& in);

}  // namespace spm
