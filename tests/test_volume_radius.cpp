// The volume records' own kernel radius (integrator volume_radius): the
// camera segments' volume estimate reads it and nothing else does; the
// gather rays read the volume records with the radius when that is smaller,
// through a grid of their own. With the stream width held, the photon maps
// are the same whatever the radii, so a pass of cornell_fog's camera volume
// term with radius 2.5 and volume radius 4 is, to the bit, the pass with
// radius 4 and volume radius 4; its surface terms are those of the pass
// with volume radius 2.5, and its gather rays' volume term is too, up to
// the order of the sums (the grids list the records in other cells). Left
// out, the volume radius is 1.5 radii in homogeneous media with the bre
// estimate and single scattering by next-event estimation, else the radius
// (render/defaults.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "render/defaults.h"
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
  return spm::test::render_terms(scene, 1, 4, 9, terms);
}

TEST(VolumeRadius, IsTheRadiusTheVolumeEstimateReads) {
  const std::vector<float> wide = one_pass(2.5f, 4.0f, SPM_TERM_VOLUME);
  const std::vector<float> same = one_pass(4.0f, 4.0f, SPM_TERM_VOLUME);
  const std::vector<float> narrow = one_pass(2.5f, 2.5f, SPM_TERM_VOLUME);
  ASSERT_GT(spm::test::image_mean(wide), 0.0);
  EXPECT_EQ(wide, same);
  EXPECT_NE(wide, narrow);
  EXPECT_EQ(one_pass(2.5f, 4.0f, SPM_TERM_SURFACE | SPM_TERM_GATHER_DIRECT | SPM_TERM_GATHER_SURFACE),
            one_pass(2.5f, 2.5f, SPM_TERM_SURFACE | SPM_TERM_GATHER_DIRECT | SPM_TERM_GATHER_SURFACE));
}

TEST(VolumeRadius, GatherRaysKeepTheSmallerRadius) {
  const std::vector<float> wide = one_pass(2.5f, 4.0f, SPM_TERM_GATHER_VOLUME);
  const std::vector<float> narrow = one_pass(2.5f, 2.5f, SPM_TERM_GATHER_VOLUME);
  const std::vector<float> both_wide = one_pass(4.0f, 4.0f, SPM_TERM_GATHER_VOLUME);
  ASSERT_EQ(wide.size(), narrow.size());
  double largest = 0.0, apart = 0.0;
  for (size_t i = 0; i < wide.size(); ++i) {
    largest = std::max(largest, double(std::abs(wide[i] - narrow[i])) / (std::abs(narrow[i]) + 1e-6));
    apart = std::max(apart, double(std::abs(both_wide[i] - narrow[i])) / (std::abs(narrow[i]) + 1e-6));
  }
  EXPECT_LT(largest, 1e-4);
  EXPECT_GT(apart, 1e-2);  // the radius 4 estimate is another one
}

TEST(VolumeRadius, LeftOutItIsOneAndAHalfRadiiInHomogeneousMedia) {
  EXPECT_EQ(one_pass(2.5f, std::nullopt, SPM_TERM_VOLUME), one_pass(2.5f, 3.75f, SPM_TERM_VOLUME));
  spm::Scene fog = spm::load_scene(SPM_SCENES_DIR "/cornell_fog.xml", {});
  EXPECT_FLOAT_EQ(spm::derived_volume_radius(fog), 1.5f * fog.integrator.radius);
  fog.integrator.volume_radius = 1.0f;
  EXPECT_FLOAT_EQ(spm::derived_volume_radius(fog), 1.0f);
  fog.integrator.volume_radius = 0.0f;
  fog.integrator.estimator = "paper";
  EXPECT_FLOAT_EQ(spm::derived_volume_radius(fog), fog.integrator.radius);
  fog.integrator.estimator = "bre";
  fog.integrator.direct = "photons";  // single scattering around the lights, read from the records
  EXPECT_FLOAT_EQ(spm::derived_volume_radius(fog), fog.integrator.radius);
  const spm::Scene smoke = spm::load_scene(SPM_SCENES_DIR "/smoke_cornell.xml", {});
  EXPECT_FLOAT_EQ(spm::derived_volume_radius(smoke), smoke.integrator.radius);
}

}  // namespace
