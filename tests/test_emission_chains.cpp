// Emission chains (spm_gather.cl, emission_chains): in pixels whose corners
// see a mirror, glass or a light, the emission a camera sample sees comes
// from `emission_chains` camera rays of its own instead of the sample's
// path. It must keep the image's expectation (the closed form of a sphere
// light seen in a plane mirror; the same mean with and without chains, so
// no emission is counted twice or dropped) and lower the variance where a
// light is seen through glass.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "render/render.h"
#include "scene/loader.h"
#include "test_support.h"

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Seeds : spm::test::Measured {  // of the image means
  std::vector<std::vector<float>> images;  // one pass per seed
};

// One pass of `spp` samples per seed, seeds 100, 101, ...
Seeds render_seeds(const std::string& text, int chains, uint32_t terms, int seeds, int spp) {
  spm::Scene scene = spm::load_scene_string(text, "chains.xml");
  scene.integrator.emission_chains = chains;
  Seeds out;
  std::vector<double> means;
  for (int k = 0; k < seeds; ++k) {
    spm::RenderSettings s;
    s.passes = 1;
    s.spp = spp;
    s.seed = 100 + uint32_t(k);
    s.terms = terms;
    out.images.push_back(spm::render(scene, s, spm::test::device()).rgb);
    means.push_back(spm::test::image_mean(out.images.back()));
  }
  static_cast<spm::test::Measured&>(out) = spm::test::mean_of(means);
  return out;
}

// The sum over pixels and channels of each value's variance across seeds.
double summed_variance(const Seeds& s) {
  double total = 0.0;
  const size_t n = s.images.size();
  for (size_t i = 0; i < s.images[0].size(); ++i) {
    double m = 0.0, m2 = 0.0;
    for (const auto& image : s.images) {
      m += image[i];
      m2 += double(image[i]) * image[i];
    }
    m /= double(n);
    total += (m2 / double(n) - m * m) * double(n) / double(n - 1);
  }
  return total;
}

// A pinhole at the origin looking down -z; `inside`: more of the sensor (a medium).
std::string camera(int res, float fov, const std::string& inside = "") {
  return R"(  <sensor type="perspective">
    <float name="fov" value=")" +
         std::to_string(fov) + R"("/>
    <transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, -1" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value=")" +
         std::to_string(res) + R"("/><integer name="height" value=")" + std::to_string(res) +
         R"("/><rfilter type="box"/></film>
)" + inside + "  </sensor>\n";
}

// A sphere light of radius 2 on the camera's axis 10 behind it, seen in a
// plane mirror 20 in front: its mirror image is a sphere 50 away on the
// axis, which the pinhole projects onto the film plane at distance 1 as a
// disk of radius tan(asin(2 / 50)). With the box filter the image's mean
// emission is the radiance times that disk's share of the film,
// (2 tan(fov / 2))^2.
TEST(EmissionChains, ALightInAMirrorHasItsClosedForm) {
  const float fov = 30.0f;
  const float radiance = 10.0f;
  const std::string text = R"(<scene version="3.0.0">
  <integrator type="spm"><integer name="streams" value="100"/></integrator>
)" + camera(32, fov) + R"(  <shape type="rectangle">
    <transform name="to_world"><scale value="50"/><translate z="-20"/></transform>
    <bsdf type="conductor"/>
  </shape>
  <shape type="sphere">
    <point name="center" x="0" y="0" z="10"/>
    <float name="radius" value="2"/>
    <emitter type="area"><rgb name="radiance" value=")" +
                           std::to_string(radiance) + R"("/></emitter>
  </shape>
</scene>)";
  const double half = std::tan(0.5 * fov * kPi / 180.0);
  const double disk = std::tan(std::asin(2.0 / 50.0));
  const double exact = radiance * kPi * disk * disk / (4.0 * half * half);
  for (int chains : {16, 0}) {
    const Seeds s = render_seeds(text, chains, SPM_TERM_EMISSION, 8, 4);
    std::printf("chains %d: image mean %.6f +- %.6f, closed form %.6f\n", chains, s.mean, s.standard_error, exact);
    EXPECT_GT(s.standard_error, 0.0) << chains;
    // 0.2% for the float sphere test at the silhouette.
    EXPECT_NEAR(s.mean, exact, 4.0 * s.standard_error + 0.002 * exact) << "chains " << chains;
    EXPECT_LT(4.0 * s.standard_error, 0.05 * exact) << "chains " << chains << ": too noisy to tell";
  }
}

// A small sphere light behind a glass ball on the camera's axis, seen
// through the ball, beside a diffuse floor the light also lights, in thin
// fog nested in the sensor.
std::string ball_scene() {
  return R"(<scene version="3.0.0">
  <integrator type="spm">
    <integer name="streams" value="2000"/>
    <integer name="associated" value="4"/>
    <float name="radius" value="2"/>
  </integrator>
)" + camera(24, 20.0f,
                R"(    <medium type="homogeneous"><float name="sigma_t" value="0.005"/><float name="albedo" value="0.5"/></medium>
)") + R"(  <shape type="sphere">
    <point name="center" x="0" y="0" z="-40"/>
    <float name="radius" value="4"/>
    <bsdf type="dielectric"/>
  </shape>
  <shape type="sphere">
    <point name="center" x="0" y="1" z="-70"/>
    <float name="radius" value="1.5"/>
    <emitter type="area"><rgb name="radiance" value="100"/></emitter>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><scale value="60"/><rotate x="1" angle="-90"/><translate y="-6" z="-50"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf>
  </shape>
</scene>)";
}

// The light through the ball is an image a few pixels wide that a pixel's
// 4 samples often miss; 16 chains per sample must take its variance down by
// far more than 4 (independent rays would give 16; the chains' points of the
// pixel are stratified as well), and keep its mean: that of many more
// samples without chains.
TEST(EmissionChains, LowerTheVarianceOfALightSeenThroughGlass) {
  const int seeds = 16;
  const Seeds with = render_seeds(ball_scene(), 16, SPM_TERM_EMISSION, seeds, 4);
  const Seeds without = render_seeds(ball_scene(), 0, SPM_TERM_EMISSION, seeds, 4);
  const Seeds many = render_seeds(ball_scene(), 0, SPM_TERM_EMISSION, 32, 64);
  const double v_with = summed_variance(with), v_without = summed_variance(without);
  std::printf("emission: mean %.5f +- %.5f with chains, %.5f +- %.5f without at 16x the samples; summed variance "
              "%.4g against %.4g\n",
              with.mean, with.standard_error, many.mean, many.standard_error, v_with, v_without);
  ASSERT_GT(many.mean, 0.0);
  EXPECT_LT(v_with, v_without / 4.0);
  const double se = std::hypot(with.standard_error, many.standard_error);
  EXPECT_NEAR(with.mean, many.mean, 4.0 * se);
  EXPECT_LT(4.0 * se, 0.1 * many.mean) << "too noisy to tell";
}

// With every term, the sample's path leaves out the emission the chains
// bring and adds everything else: the image means with chains and without
// them (at 8x the samples, whose emission is then less noisy) agree.
// Counting the emission twice would move the mean by three quarters.
TEST(EmissionChains, CountTheEmissionOnceInTheWholeImage) {
  const int seeds = 16;
  const Seeds with = render_seeds(ball_scene(), 16, SPM_TERMS_ALL, seeds, 4);
  const Seeds without = render_seeds(ball_scene(), 0, SPM_TERMS_ALL, seeds, 32);
  const Seeds emission = render_seeds(ball_scene(), 16, SPM_TERM_EMISSION, 4, 4);
  std::printf("whole image: mean %.5f +- %.5f with chains, %.5f +- %.5f without; emission alone %.5f\n", with.mean,
              with.standard_error, without.mean, without.standard_error, emission.mean);
  const double se = std::hypot(with.standard_error, without.standard_error);
  EXPECT_NEAR(with.mean, without.mean, 4.0 * se);
  EXPECT_LT(4.0 * se, 0.25 * emission.mean) << "too noisy to tell a doubled emission";
}

}  // namespace
