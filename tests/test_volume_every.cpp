// The camera segments' volume estimate for one sample in `volume_every`
// (spm_gather.cl): the first ceil(spp / volume_every) samples of a pixel in
// a pass add it, weighted spp over their count. It must keep each pixel's
// expectation. With the same seed both renders read the same photon maps
// and the same camera samples, so their difference holds only which
// samples add the estimate: its mean over seeds must be 0 within its
// standard error, for a count of samples that volume_every divides and for
// one it does not.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "render/render.h"
#include "scene/loader.h"
#include "test_support.h"

namespace {

// The volume term's image mean of one pass of cornell_fog at 24x24.
double volume_mean(int every, int spp, uint32_t seed) {
  spm::Scene scene = spm::load_scene(SPM_SCENES_DIR "/cornell_fog.xml",
                                     {{"res", "24"}, {"streams", "3000"}, {"associated", "4"}});
  scene.integrator.volume_every = every;
  spm::RenderSettings s;
  s.passes = 1;
  s.spp = spp;
  s.seed = seed;
  s.terms = SPM_TERM_VOLUME;
  return spm::test::image_mean(spm::render(scene, s, spm::test::device()).rgb);
}

TEST(VolumeEvery, KeepsTheVolumeEstimatesMean) {
  const int seeds = 12;
  for (int spp : {8, 6}) {
    std::vector<double> differences;
    double base = 0.0;
    for (int k = 0; k < seeds; ++k) {
      const double all = volume_mean(1, spp, 200 + uint32_t(k));
      differences.push_back(volume_mean(4, spp, 200 + uint32_t(k)) - all);
      base += all / seeds;
    }
    const auto [mean, se] = spm::test::mean_of(differences);
    std::printf("spp %d: volume term %.6f, every 4 minus every sample %.3g +- %.3g\n", spp, base, mean, se);
    ASSERT_GT(base, 0.0);
    EXPECT_NEAR(mean, 0.0, 4.0 * se + 1e-6 * base) << "spp " << spp;
    // A weight of 1 instead of spp / count would move it by 50-75%.
    EXPECT_LT(4.0 * se, 0.05 * base) << "spp " << spp << ": too noisy to tell";
  }
}

}  // namespace
