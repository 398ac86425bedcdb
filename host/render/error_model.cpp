#include "render/error_model.h"

#include <algorithm>
#include <cmath>

namespace spm {

ErrorModel::ErrorModel(size_t values)
    : bias_(values, 0.0), bias2_(values, 0.0), probes_(values, 0), last_(values, 0.0f), photon_(values, 0.0) {
  for (auto& s : sum_) s.assign(values, 0.0);
}

void ErrorModel::add(int pass, const std::vector<float>& image, float radius, const std::vector<float>& probe) {
  std::vector<double>& sum = sum_[pass % kReplicates];
  for (size_t i = 0; i < sum.size(); ++i) sum[i] += image[i];
  ++passes_[pass % kReplicates];
  const double r2 = double(radius) * radius;
  radius2_ += r2;
  if (probe.empty()) return;
  // The probe's difference is B r^2 (1 - kProbeScale^2).
  const double per_r2 = 1.0 / (r2 * (1.0 - double(kProbeScale) * kProbeScale));
  for (size_t i = 0; i < bias_.size(); ++i) {
    if (std::isnan(probe[i])) continue;
    const double b = probe[i] * per_r2;
    const double u = double(probe[i]) * radius;
    if (probes_[i] > 0) photon_[i] += 0.5 * (u - last_[i]) * (u - last_[i]);
    last_[i] = float(u);
    bias_[i] += b;
    bias2_[i] += b * b;
    ++probes_[i];
  }
}

double ErrorModel::bias2(size_t i) const {
  // B^2 less the variance of B's own mean over the probes, which would
  // otherwise count the probe's noise as bias.
  const double m = probes_[i], mb = bias_[i] / m;
  const double noise = std::max(0.0, (bias2_[i] - bias_[i] * mb) / (m - 1.0)) / m;
  return mb * mb - noise;
}

double ErrorModel::weight_of(size_t i) const {
  const double mean = (sum_[0][i] + sum_[1][i]) / (passes_[0] + passes_[1]);
  return 1.0 / (mean * mean + 0.01);
}

ErrorEstimate ErrorModel::estimate() const {
  ErrorEstimate e;
  for (int r = 0; r < kReplicates; ++r) e.passes += passes_[r];
  static_assert(kReplicates == 2, "the variance below is the two replicates'");
  const double na = passes_[0], nb = passes_[1], n = na + nb;
  if (na == 0 || nb == 0) return e;
  const double mean_r2 = radius2_ / n;
  double bias = 0.0;
  size_t probed = 0;
  for (size_t i = 0; i < bias_.size(); ++i) {
    const double a = sum_[0][i] / na, b = sum_[1][i] / nb, weight = weight_of(i);
    // The image weighs the replicates' means by their passes; with each
    // mean's variance inversely proportional to its passes, E[(a - b)^2]
    // (1/na + 1/nb)^-1 is the variance of one pass's worth, and the image's
    // is that over n: na nb (a - b)^2 / n^2.
    e.variance += na * nb * (a - b) * (a - b) / (n * n) * weight;
    if (probes_[i] < 2) continue;
    bias += bias2(i) * mean_r2 * mean_r2 * weight;
    ++probed;
  }
  e.variance /= double(bias_.size());
  // The probed pixels stand for the image.
  e.bias = probed ? std::max(0.0, bias / double(probed)) : 0.0;
  e.relmse = e.variance + e.bias;
  return e;
}

ErrorTerms ErrorModel::terms() const {
  ErrorTerms t;
  const double na = passes_[0], nb = passes_[1], n = na + nb;
  if (na == 0 || nb == 0) return t;
  t.pass_variance = estimate().variance * n;
  double bias = 0.0, bias_sq = 0.0, photon = 0.0;
  size_t probed = 0;
  for (size_t i = 0; i < bias_.size(); ++i) {
    const double m = probes_[i];
    if (m < 2) continue;
    const double weight = weight_of(i);
    const double b = bias2(i) * weight;
    bias += b;
    bias_sq += b * b;
    photon += photon_[i] / (m - 1.0) * weight;
    ++probed;
  }
  if (!probed) return t;
  t.known = true;
  // The mean over the probed values less kBiasConfidence standard errors of
  // it: a plan acts on a bias the probes have shown, not on their noise
  // (mirror_area's heavy-tailed caustic read a bias in one plan and none in
  // the next, and the radius swung by 4x between them).
  const double k = double(probed), mean_bias = bias / k;
  const double spread = k > 1.0 ? std::max(0.0, (bias_sq - bias * mean_bias) / (k - 1.0)) : 0.0;
  t.bias_per_r4 = std::max(0.0, mean_bias - kBiasConfidence * std::sqrt(spread / k));
  t.photon_r2 = photon / k;
  return t;
}

}  // namespace spm
