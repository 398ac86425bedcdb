// The volume records' own kernel radius (integrator volume_radius): the
// volume estimates, the camera's and the gather rays', read it and nothing
// else does. With the stream width held, the photon maps are the same
// whatever the radii, so a pass of cornell_fog's camera volume term with
// radius 2.5 and volume radius 4 is, to the bit, the pass with radius 4;
// and its surface terms are those of the pass without a volume radius.
#include <gtest/gtest.h>

#include <optional>
#include <vector>

#include "render/render.h"
#include "scene/loader.h"
#include "test_support.h"

namespace {

std::vector<float> one_pass(float radius, std::optional<float> volume_radius, uint32_t terms) {
  spm::Scene scene = spm::load_scene(SPM_SCENES_DIR "/cornell_fog.xml",
                                     {{"res", "24"}, {"streams", "2000"}, {"associated", "4"}});
  scene.integrator.radius = radius;
  scene.integrator.stream_width = 2.5f;
  if (volume_radius) scene.integrator.volume_radius = *volume_radius;
  spm::RenderSettings s;
  s.passes = 1;
  s.spp = 4;
  s.seed = 9;
  s.terms = terms;
  return spm::render(scene, s, spm::test::device()).rgb;
}

TEST(VolumeRadius, IsTheRadiusTheVolumeEstimateReads) {
  const std::vector<float> wide = one_pass(2.5f, 4.0f, SPM_TERM_VOLUME);
  const std::vector<float> same = one_pass(4.0f, std::nullopt, SPM_TERM_VOLUME);
  const std::vector<float> narrow = one_pass(2.5f, std::nullopt, SPM_TERM_VOLUME);
  ASSERT_GT(spm::test::image_mean(wide), 0.0);
  EXPECT_EQ(wide, same);
  EXPECT_NE(wide, narrow);
  EXPECT_EQ(one_pass(2.5f, 4.0f, SPM_TERM_SURFACE | SPM_TERM_GATHER_DIRECT | SPM_TERM_GATHER_SURFACE),
            one_pass(2.5f, std::nullopt, SPM_TERM_SURFACE | SPM_TERM_GATHER_DIRECT | SPM_TERM_GATHER_SURFACE));
}

}  // namespace
