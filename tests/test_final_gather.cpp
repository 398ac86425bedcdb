// The final gather (spm_gather.cl, final_gather) moves the photon lookup one
// vertex away from the camera; it must not count any light twice or drop
// any: with and without it, renders of a scene with fog, a glass sphere's
// caustic, and light bouncing between two planes agree on the mean within
// the standard error of independent seeds; so do they between two planes so
// close that most gather rays are short and the path goes on from where
// they end (SPM_GATHER_NEAR).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "render/render.h"
#include "render/terms.h"
#include "scene/gpu_scene.h"
#include "scene/loader.h"
#include "test_support.h"

namespace {

std::string num(float v) { return std::to_string(v); }

// An area light: a square of half-edge `half` at (x, y, 0), facing down
// (`down`) or up.
std::string square_light(float half, bool down, float x, float y, float radiance) {
  return "  <shape type=\"rectangle\">\n    <transform name=\"to_world\"><scale value=\"" + num(half) +
         "\"/><rotate x=\"1\" angle=\"" + (down ? "90" : "-90") + "\"/><translate x=\"" + num(x) + "\" y=\"" + num(y) +
         "\"/></transform>\n    <emitter type=\"area\"><rgb name=\"radiance\" value=\"" + num(radiance) +
         "\"/></emitter>\n  </shape>\n";
}

// A floor and a ceiling `gap` apart, both white, a small area light (half
// edge `light`, centred at x = light_x, y = light_y) under the ceiling
// facing down, thin global fog (nested in the sensor) and a camera at height
// `eye` looking down at the floor through a field of view of `fov`
// degrees; `extra`: more shapes.
std::string planes_scene(float gap, float eye, float fov, float light, float light_x, float light_y,
                         const std::string& extra) {
  return R"(<scene version="3.0.0">
  <integrator type="spm">
    <integer name="streams" value="4000"/>
    <integer name="associated" value="4"/>
    <float name="radius" value="3"/>
  </integrator>
  <sensor type="perspective">
    <float name="fov" value=")" + num(fov) + R"("/>
    <transform name="to_world"><lookat origin="0, )" + num(eye) + R"(, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="24"/></film>
    <medium type="homogeneous"><float name="sigma_t" value="0.01"/><float name="albedo" value="0.8"/></medium>
  </sensor>
  <bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.8"/></bsdf>
  <shape type="rectangle">
    <transform name="to_world"><scale value="100"/><rotate x="1" angle="-90"/></transform>
    <ref id="white"/>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><scale value="100"/><rotate x="1" angle="90"/><translate y=")" + num(gap) + R"("/></transform>
    <ref id="white"/>
  </shape>
)" + square_light(light, true, light_x, light_y, 40.0f) + extra + "</scene>";
}

// Planes 50 apart with a glass sphere, the camera at 40: it sees the
// floor's direct light, its indirect light from the ceiling, the sphere's
// caustic (light through a specular chain, which the gather ray cannot
// bring) and the fog's single and multiple scattering.
std::string far_scene() {
  return planes_scene(50.0f, 40.0f, 50.0f, 5.0f, 0.0f, 49.0f, R"(  <shape type="sphere">
    <point name="center" x="5" y="14" z="0"/>
    <float name="radius" value="5"/>
    <bsdf type="dielectric"/>
  </shape>
)");
}

// Two planes 8 apart, under 4 radii (3): about half the gather rays from
// either plane end within SPM_GATHER_NEAR radii, so their ends are
// vertices with direct light, caustic records and a gather ray of their
// own, up to SPM_GATHER_HOPS times. Dropping that vertex's direct light,
// or counting the photons there as well, moves the mean by far more than
// the bound.
std::string near_scene() { return planes_scene(8.0f, 6.0f, 60.0f, 2.0f, 6.0f, 7.9f, ""); }

// The image mean (all channels) of one pass per seed, over `seeds` seeds:
// the passes are independent, so their spread gives the standard error.
spm::test::Measured image_means(const std::string& text, bool final_gather, int seeds) {
  spm::Scene scene = spm::load_scene_string(text, "final_gather.xml");
  scene.integrator.final_gather = final_gather;
  std::vector<double> means;
  for (int k = 0; k < seeds; ++k) {
    spm::RenderSettings s;
    s.passes = 1;
    s.seed = 100 + k;
    means.push_back(spm::test::image_mean(spm::render(scene, s, spm::test::device()).rgb));
  }
  return spm::test::mean_of(means);
}

// Asserts that the final gather's and the direct lookup's image means agree.
void expect_same_mean(const std::string& text) {
  const int seeds = 48;
  const spm::test::Measured with = image_means(text, true, seeds), without = image_means(text, false, seeds);
  const double se = std::sqrt(with.standard_error * with.standard_error +
                              without.standard_error * without.standard_error);
  std::printf("final gather %.5f +- %.5f, direct lookup %.5f +- %.5f\n", with.mean, with.standard_error,
              without.mean, without.standard_error);
  ASSERT_GT(se, 0.0);
  // The two differ in their density estimates' bias, which the radius (3,
  // against planes 50 apart) keeps near 1%; the bound also catches the
  // caustic counted twice or dropped, or the fog's single scattering along
  // the gather rays, which their volume records of depth 1 carry, left out
  // of the grid or added again by next-event estimation (each moves the
  // two scenes' means by 3-5%, past bounds of about 3% and 2%).
  EXPECT_NEAR(with.mean, without.mean, 4 * se + 0.01 * without.mean);
  EXPECT_LT(4 * se, 0.03 * without.mean) << "too noisy to tell";
}

TEST(FinalGather, AgreesWithTheDirectLookupOnTheMean) { expect_same_mean(far_scene()); }

// The gather's terms (spm render --terms, render/terms.h) partition the
// radiance: one pass of far_scene with a small light on the floor that the
// camera sees, rendered with each term alone, adds up to the pass rendered
// whole, pixel by pixel, up to float rounding, with the final gather and
// without it. Each term is computed only when asked for, so each must also
// add something of its own where the scene has it (without the final
// gather the gather rays' terms have nothing to add).
TEST(FinalGather, TheTermsAddUpToTheWholeImage) {
  const std::string text = planes_scene(50.0f, 40.0f, 50.0f, 5.0f, 0.0f, 49.0f, R"(  <shape type="sphere">
    <point name="center" x="5" y="14" z="0"/>
    <float name="radius" value="5"/>
    <bsdf type="dielectric"/>
  </shape>
)" + square_light(2.0f, false, -10.0f, 0.5f, 5.0f));
  for (bool final_gather : {true, false}) {
    spm::Scene scene = spm::load_scene_string(text, "terms.xml");
    scene.integrator.final_gather = final_gather;
    spm::RenderSettings s;
    s.passes = 1;
    s.seed = 7;
    const spm::Image whole = spm::render(scene, s, spm::test::device());
    std::vector<double> sum(whole.rgb.size(), 0.0);
    for (const spm::OptionValue& term : spm::kGatherTerms.values) {
      s.terms = term.code;
      spm::RenderStats stats;
      const spm::Image part = spm::render(scene, s, spm::test::device(), &stats);
      // Shadow rays and emission read no photon map: such a pass propagates nothing.
      if (term.code & SPM_TERMS_PHOTONS) {
        EXPECT_GT(stats.propagate_seconds, 0.0) << term.name;
      } else {
        EXPECT_EQ(stats.propagate_seconds, 0.0) << term.name;
      }
      ASSERT_EQ(part.rgb.size(), whole.rgb.size());
      double total = 0.0;
      for (size_t i = 0; i < part.rgb.size(); ++i) {
        sum[i] += part.rgb[i];
        total += part.rgb[i];
      }
      const bool gather_term = (term.code & SPM_TERMS_GATHER) != 0;
      if (final_gather || !gather_term) {
        EXPECT_GT(total, 0.0) << term.name << (final_gather ? " with" : " without") << " the final gather";
      } else {
        EXPECT_EQ(total, 0.0) << term.name << " without the final gather";
      }
    }
    for (size_t i = 0; i < sum.size(); ++i) {
      ASSERT_NEAR(sum[i], whole.rgb[i], 1e-5 * std::fabs(whole.rgb[i]) + 1e-6)
          << "value " << i << (final_gather ? " with" : " without") << " the final gather";
    }
  }
}

TEST(FinalGather, ShortGatherRaysGoOnAndAgreeOnTheMean) { expect_same_mean(near_scene()); }

// Final-gather rays aim at the lights in a medium no larger than
// kAimedLightSize of the scene's diagonal (SpmLight::aim, each light's share
// of those lights' power), and at no other: far_scene's light (half-edge 5,
// 2.5% of its diagonal) is aimed at, so AgreesWithTheDirectLookupOnTheMean
// checks the aimed rays' weights; so is caustic_area's sphere light, while
// cornell_fog's and the fog box's lights are too large, and a light out of
// any medium lights none around it.
TEST(FinalGather, AimsAtSmallLightsInAMedium) {
  const auto aims = [](const spm::Scene& scene) {
    std::vector<float> out;
    for (const SpmLight& l : spm::flatten_scene(scene, 8, 8).lights) out.push_back(l.aim);
    return out;
  };
  EXPECT_EQ(aims(spm::load_scene_string(far_scene(), "far.xml")), std::vector<float>{1.0f});
  EXPECT_EQ(aims(spm::load_scene(SPM_SCENES_DIR "/caustic_area.xml", {})), std::vector<float>{1.0f});
  EXPECT_EQ(aims(spm::load_scene(SPM_SCENES_DIR "/cornell_fog.xml", {})), std::vector<float>{0.0f});
  EXPECT_EQ(aims(spm::load_scene(SPM_SCENES_DIR "/fog_box.xml", {})), std::vector<float>{0.0f});
  // A second light, as small, three times as bright, and a large one.
  const std::string two = planes_scene(50.0f, 40.0f, 50.0f, 5.0f, 0.0f, 49.0f,
                                       square_light(5.0f, true, 30.0f, 49.0f, 120.0f) +
                                           square_light(30.0f, true, -50.0f, 49.5f, 1.0f));
  const std::vector<float> a = aims(spm::load_scene_string(two, "two.xml"));
  ASSERT_EQ(a.size(), 3u);
  EXPECT_NEAR(a[0], 0.25f, 1e-6f);
  EXPECT_NEAR(a[1], 0.75f, 1e-6f);
  EXPECT_EQ(a[2], 0.0f);
  // Without the fog.
  std::string clear = far_scene();
  const size_t fog = clear.find("<medium");
  clear.erase(fog, clear.find("</medium>", fog) + 9 - fog);
  EXPECT_EQ(aims(spm::load_scene_string(clear, "clear.xml")), std::vector<float>{0.0f});
}

}  // namespace
