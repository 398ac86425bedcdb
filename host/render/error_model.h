// The render's error, estimated from its own passes (docs/METHOD.md 15): a
// pixel's expected squared error is the variance of its value plus the
// square of the estimates' bias.
//
// Variance. A pixel's camera samples are stratified across passes
// (kernels/lib/rng.h, stratify2), so the passes are not independent and
// their spread overstates the variance of their mean (the fog box at 4
// passes: 2.4 times). The passes therefore alternate between kReplicates
// independently scrambled sequences, each stratified across its own passes,
// and the variance comes from the spread between the replicates' means, as
// for any randomized quasi-Monte Carlo estimate (Owen 1997).
//
// Bias. The bias of a density estimate of radius r is about B r^2 where
// the integrand is smooth (Hachisuka, Jarosz & Jensen 2010). A pass
// measures B where the image is made, with a probe: its photon terms
// gathered twice for one camera sample per pixel of some rows, from the
// same records along the same camera paths, once with every radius and once
// with every radius times kProbeScale, whose difference is
// B r^2 (1 - kProbeScale^2). The probe rows are the same in every pass, so
// that the spread of a pixel's measurements over passes removes their own
// noise from B^2.
//
// Photon noise. For a kernel over a disk (the beam estimate's cross-section,
// a surface estimate), the records within r / sqrt(2) are a subset of
// those within r, so the probe's difference D has the variance of the
// estimate at r itself less nothing but its own subset: Var(D) =
// Var(estimate at r), which grows as 1/r^2. Consecutive probes of a value,
// each times its pass's radius, differ by noise alone (their means differ
// by the radius's shrinking, a few per cent of B r^2), so half their
// squared difference is Q = Var(estimate at r) r^2: the photon maps' part
// of a pass's variance at any radius (ErrorTerms, render/planner.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace spm {

// Independently scrambled camera-sample sequences the passes alternate between.
constexpr int kReplicates = 2;

// Standard errors of its mean over the probed values that ErrorTerms takes
// off the bias per r^4.
constexpr double kBiasConfidence = 2.0;

// The radius scale of the probe's second gather.
constexpr float kProbeScale = 0.70710678f;

struct ErrorEstimate {
  int passes = 0;
  // Mean over pixels and channels of error^2 / (value^2 + 0.01), the
  // relMSE tools/compare.py computes against a reference, with the image
  // itself standing for the reference; and its two parts.
  double relmse = -1.0;  // -1: not yet known (a replicate without passes)
  double variance = 0.0;
  double bias = 0.0;  // the bias part, squared
};

// What the planner (render/planner.h) reads of the model: per pass, in the
// weighted relMSE units of ErrorEstimate, over the passes added so far.
struct ErrorTerms {
  bool known = false;           // both replicates have a pass and values have two probes
  double pass_variance = 0.0;   // the variance of one pass's image
  double photon_r2 = 0.0;       // Q: the photon maps' variance of one pass times r^2
  double bias_per_r4 = 0.0;     // beta^2, the bias part over r^4, less kBiasConfidence standard errors
};

class ErrorModel {
 public:
  explicit ErrorModel(size_t values);

  // Adds pass `pass`'s image (values as the film holds them) with its
  // radius and its probe's difference (the full radii's photon terms less
  // the scaled radii's, per value, NaN off the probe's rows; empty where
  // the pass ran no probe). Passes come in pass order.
  void add(int pass, const std::vector<float>& image, float radius, const std::vector<float>& probe);

  // The estimate for the mean of the passes added so far.
  ErrorEstimate estimate() const;

  ErrorTerms terms() const;

 private:
  double bias2(size_t value) const;  // B^2 of a value with two probes or more
  // A value's weight in the relMSE, 1 / (mean^2 + 0.01), the passes' mean
  // standing for the reference.
  double weight_of(size_t value) const;

  std::vector<double> sum_[kReplicates];  // per value, the replicate's passes summed
  int passes_[kReplicates] = {};
  std::vector<double> bias_, bias2_;  // per value, over its probes: B and B^2
  std::vector<uint32_t> probes_;      // per value, its probes
  std::vector<float> last_;           // per value, its last probe's D r
  std::vector<double> photon_;        // per value, over consecutive probes: (D r - D' r')^2 / 2
  double radius2_ = 0.0;              // over passes, r^2
};

}  // namespace spm
