// Mitsuba's thindielectric against closed forms: a sheet of glass whose two
// faces reflect F each, every inner reflection summed, reflects
// R = 2F / (1 + F) and lets T = 1 - R through undeviated. A camera looks
// through a pane at a diffuse plane lit by a directional light (in vacuum):
// the plane's radiance times T at the camera's incidence. Then the pane lies
// over the plane instead, in the light's path: shadow rays stop at glass, so
// the plane's light comes from the streams that pass it (collapsed, as at
// any specular vertex; METHOD.md 4), E cos(theta) T(theta) per unit area.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <string>

#include "scene/loader.h"
#include "test_support.h"

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kIrradiance = 2.0;
// Dark, so that the light the plane sends up and the pane reflects back
// down stays below the noise: at albedo 0.5 it added 3.4% here, at 0.05 it
// adds a tenth of that.
constexpr double kAlbedo = 0.05;
constexpr double kEta = 1.5;
const double kCosLight = 2.0 / std::sqrt(5.0);  // the light travels along (1, -2, 0)

// Unpolarised Fresnel reflectance of one face at cos_i, relative index eta.
double fresnel(double cos_i, double eta) {
  const double sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
  const double cos_t = std::sqrt(1.0 - sin2_t);
  const double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  const double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

double sheet_transmittance(double cos_i) {
  const double f = fresnel(cos_i, kEta);
  return 1.0 - 2.0 * f / (1.0 + f);
}

// The pane: a rectangle at height `pane_y` (camera side: between the camera
// at y = 2 and the plane; light side: the same, but the camera sits below
// it). The camera looks straight down at the plane's middle.
std::string scene_xml(double camera_y) {
  std::ostringstream x;
  x << R"(<scene version="3.0.0">
  <integrator type="spm"><integer name="streams" value="200000"/><float name="radius" value="1"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="1"/>
    <transform name="to_world"><lookat origin="0, )"
    << camera_y << R"(, 0" target="0, 0, 0" up="0, 0, -1"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/><rfilter type="box"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><float name="reflectance" value=")"
    << kAlbedo << R"("/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/><translate y="1.5"/></transform>
    <bsdf type="thindielectric"><float name="int_ior" value=")"
    << kEta << R"("/><float name="ext_ior" value="1"/></bsdf>
  </shape>
  <emitter type="directional"><vector name="direction" x="1" y="-2" z="0"/>
    <rgb name="irradiance" value=")"
    << kIrradiance << R"("/></emitter>
</scene>)";
  return x.str();
}

spm::test::Measured render_means(double camera_y, int renders) {
  return spm::test::one_pass_means(spm::load_scene_string(scene_xml(camera_y), "thin.xml"), renders);
}

// The camera at y = 1 sits under the pane (at y = 1.5): the plane is lit
// only through it, by the maps. The camera at y = 3 looks through it too: T
// at normal incidence once more.
TEST(ThinDielectric, LetsThroughWhatItsFacesDoNotReflect) {
  const double lit = kAlbedo / kPi * kIrradiance * kCosLight * sheet_transmittance(kCosLight);
  for (const double camera_y : {1.0, 3.0}) {
    const double expected = lit * (camera_y > 1.5 ? sheet_transmittance(1.0) : 1.0);
    const spm::test::Measured m = render_means(camera_y, 12);
    EXPECT_GT(m.standard_error, 0.0);
    // Tight enough to catch the sheet taken for one face (T 0.96 at normal
    // incidence, not 0.923) or for glass that bends the light.
    EXPECT_LT(4.0 * m.standard_error, 0.035 * expected) << "camera at y = " << camera_y;
    EXPECT_NEAR(m.mean, expected, 4.0 * m.standard_error) << "camera at y = " << camera_y;
  }
}

}  // namespace
