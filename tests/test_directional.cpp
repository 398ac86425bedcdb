// A directional light (METHOD.md 14) against closed forms: a diffuse plane
// lit from infinity, in vacuum and under an absorbing slab of fog. Its
// radiance is albedo / pi times the irradiance E cos(theta), attenuated by
// exp(-sigma_t d) along the light's path through the slab and along the
// camera's (paper eq. 2). Next-event estimation checks the shadow ray to
// infinity; the photon maps alone (direct="photons") check that streams
// start on the disk across the bounding sphere with flux E pi R^2.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <string>

#include "scene/loader.h"
#include "test_support.h"

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kIrradiance = 2.0;
constexpr double kAlbedo = 0.5;
constexpr double kSigma = 0.1;       // the slab's extinction, absorption only
constexpr double kSlabTop = 3.0;     // the plane lies at y = 0, the slab's top at y = 3
constexpr double kCameraHeight = 2.0;
const double kCosTheta = 2.0 / std::sqrt(5.0);  // the light travels along (1, -2, 0)

std::string scene_xml(bool fog, const std::string& direct) {
  std::ostringstream x;
  x << R"(<scene version="3.0.0">
  <integrator type="spm"><string name="direct" value=")"
    << direct << R"("/><integer name="streams" value="200000"/><float name="radius" value="1"/></integrator>)";
  if (fog) {
    x << R"(
  <medium type="homogeneous" id="fog"><float name="sigma_t" value=")"
      << kSigma << R"("/><float name="albedo" value="0"/></medium>
  <shape type="cube"><transform name="to_world"><scale x="4.5" y="2" z="4.5"/><translate y="1"/></transform>
    <bsdf type="null"/><ref name="interior" id="fog"/></shape>)";
  }
  x << R"(
  <sensor type="perspective">
    <float name="fov" value="1"/>
    <transform name="to_world"><lookat origin="0, )"
    << kCameraHeight << R"(, 0" target="0, 0, 0" up="0, 0, -1"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/><rfilter type="box"/></film>)"
    << (fog ? R"(<ref id="fog"/>)" : "") << R"(
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><float name="reflectance" value=")"
    << kAlbedo << R"("/></bsdf>)" << (fog ? R"(<ref name="exterior" id="fog"/>)" : "") << R"(
  </shape>
  <emitter type="directional"><vector name="direction" x="1" y="-2" z="0"/>
    <rgb name="irradiance" value=")"
    << kIrradiance << R"("/></emitter>
</scene>)";
  return x.str();
}

// The camera's rays start at its near clip plane, 0.01 away (Mitsuba's
// default; its perspective sensor skips that stretch too).
double expected_radiance(bool fog) {
  const double camera_path = kCameraHeight - 0.01;
  const double attenuation = fog ? std::exp(-kSigma * (kSlabTop / kCosTheta + camera_path)) : 1.0;
  return kAlbedo / kPi * kIrradiance * kCosTheta * attenuation;
}

spm::test::Measured render_means(bool fog, const std::string& direct, int renders) {
  return spm::test::one_pass_means(spm::load_scene_string(scene_xml(fog, direct), "directional.xml"), renders);
}

// Every camera sample sees the same flat plane and takes one shadow ray to
// infinity along the light's one direction: the estimate is exact.
TEST(DirectionalLight, NextEventEstimationGivesTheClosedForm) {
  for (bool fog : {false, true}) {
    const double expected = expected_radiance(fog);
    const spm::test::Measured m = render_means(fog, "nee", 2);
    EXPECT_NEAR(m.mean, expected, 1e-4 * expected) << (fog ? "under the slab" : "in vacuum");
  }
}

// The maps alone: streams from the disk across the bounding sphere deposit
// E cos(theta) per unit area of the plane, attenuated through the slab. The
// irradiance is the same all over the plane's middle, so a radius of 1 (set,
// not derived) costs no bias and keeps the noise low.
TEST(DirectionalLight, ThePhotonMapsAloneGiveTheClosedForm) {
  for (bool fog : {false, true}) {
    const double expected = expected_radiance(fog);
    const spm::test::Measured m = render_means(fog, "photons", 12);
    EXPECT_GT(m.standard_error, 0.0);
    // Tight enough to catch a 3% error in the flux.
    EXPECT_LT(4.0 * m.standard_error, 0.03 * expected) << (fog ? "under the slab" : "in vacuum");
    EXPECT_NEAR(m.mean, expected, 4.0 * m.standard_error) << (fog ? "under the slab" : "in vacuum");
  }
}

}  // namespace
