// Shared helpers of the test suite.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "device/device.h"
#include "render/render.h"
#include "spm_types.h"

namespace spm::test {

// The OpenCL device the tests run on: $SPM_TEST_DEVICE (a --device selector)
// or the default choice; one per test binary, so kernels build once.
inline Device& device() {
  static Device d(select_device(std::getenv("SPM_TEST_DEVICE") ? std::getenv("SPM_TEST_DEVICE") : ""), "");
  return d;
}

inline std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Lines of `s` (newline characters).
inline int count_lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

// Line (1-based) of the comment <!--here--> in `text`: where an error must be
// reported.
inline int marked_line(const std::string& text) {
  const size_t at = text.find("<!--here-->");
  EXPECT_NE(at, std::string::npos) << "text without <!--here-->";
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

// The film of `passes` passes of `spp` samples each, seed `seed`, of the
// gather's `terms` alone (SPM_TERM_* bits).
inline std::vector<float> render_terms(const Scene& scene, int passes, int spp, uint32_t seed, uint32_t terms) {
  RenderSettings s;
  s.passes = passes;
  s.spp = spp;
  s.seed = seed;
  s.terms = terms;
  return render(scene, s, device()).rgb;
}

// The mean over pixels and channels of an image's values.
inline double image_mean(const std::vector<float>& rgb) {
  double m = 0.0;
  for (float v : rgb) m += v;
  return m / double(rgb.size());
}
inline double image_mean(const Image& image) { return image_mean(image.rgb); }

// The mean of independent draws and its standard error.
struct Measured {
  double mean = 0.0, standard_error = 0.0;
};

inline Measured mean_of(const std::vector<double>& draws) {
  const double n = double(draws.size());
  double sum = 0.0, sum2 = 0.0;
  for (double x : draws) {
    sum += x;
    sum2 += x * x;
  }
  const double mean = sum / n;
  return {mean, std::sqrt(std::max(0.0, sum2 / n - mean * mean) / (n - 1.0))};
}

// The image means of `renders` renders of `scene`, one pass of 4 samples per
// pixel each, seeds 1, 2, ...: independent draws of its estimate.
inline Measured one_pass_means(const Scene& scene, int renders) {
  std::vector<double> means;
  for (int i = 0; i < renders; ++i) {
    RenderSettings settings;
    settings.passes = 1;
    settings.spp = 4;
    settings.seed = static_cast<uint32_t>(i + 1);
    means.push_back(image_mean(render(scene, settings, device())));
  }
  return mean_of(means);
}

// A coloured Henyey-Greenstein medium for the estimates' brute-force tests:
// sigma_t and albedo differ per channel, so a channel mixed up shows.
inline SpmMedium coloured_medium() {
  SpmMedium m{};
  m.sigma_t[0] = 0.02f;
  m.sigma_t[1] = 0.05f;
  m.sigma_t[2] = 0.1f;
  m.albedo[0] = 0.9f;
  m.albedo[1] = 0.5f;
  m.albedo[2] = 0.3f;
  m.phase = SPM_PHASE_HG;
  m.g = 0.4f;
  m.sigma_t_grid = m.albedo_grid = -1;  // homogeneous
  return m;
}

}  // namespace spm::test
