// Statistics for the sampling tests: bounds come from the variance, seeds are fixed.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

namespace spm::test {

// Kolmogorov-Smirnov statistic of `samples` against the continuous CDF `cdf`.
inline double ks_statistic(std::vector<double> samples, const std::function<double(double)>& cdf) {
  std::sort(samples.begin(), samples.end());
  const double n = static_cast<double>(samples.size());
  double d = 0.0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const double f = cdf(samples[i]);
    d = std::max({d, (i + 1) / n - f, f - i / n});
  }
  return d;
}

// Critical value of the KS statistic at significance 0.001 (asymptotic).
inline double ks_critical(size_t n) { return 1.949 / std::sqrt(static_cast<double>(n)); }

struct MeanAndError {
  double mean = 0.0;
  double error = 0.0;  // standard error of the mean
};

inline MeanAndError mean_and_error(const std::vector<double>& v) {
  double s = 0.0, s2 = 0.0;
  for (double x : v) {
    s += x;
    s2 += x * x;
  }
  const double n = static_cast<double>(v.size());
  const double mean = s / n;
  const double var = std::max(0.0, (s2 - n * mean * mean) / (n - 1));
  return {mean, std::sqrt(var / n)};
}

}  // namespace spm::test
