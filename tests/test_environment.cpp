// Light from infinity, constant and envmap (METHOD.md 14): closed forms
// and white furnaces end to end, the map's lookup against its texels, and
// the loader's refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

#include "film/image_io.h"
#include "scene/loader.h"
#include "test_support.h"
#include "util/errors.h"

namespace {

namespace fs = std::filesystem;

// A camera 2 above the origin looking down through a 1-degree cone.
std::string camera_xml(int size = 8) {
  std::ostringstream x;
  x << R"(<sensor type="perspective"><float name="fov" value="1"/>
    <transform name="to_world"><lookat origin="0, 2, 0" target="0, 0, 0" up="0, 0, -1"/></transform>
    <film type="hdrfilm"><integer name="width" value=")"
    << size << R"("/><integer name="height" value=")" << size << R"("/><rfilter type="box"/></film></sensor>)";
  return x.str();
}

spm::test::Measured means(const std::string& body, int renders) {
  return spm::test::one_pass_means(spm::load_scene_string("<scene version=\"3.0.0\">" + body + "</scene>", "env.xml"),
                                   renders);
}

// A diffuse plane under a constant sky L sees the sky over its whole upper
// hemisphere: its radiance is rho L, by shadow rays to infinity and, with
// direct="photons", by the streams alone, which start on the disk across
// the bounding sphere with flux L pi R^2 4 pi (its records read far from
// the plane's edges, so the radius adds no bias).
TEST(Environment, AConstantSkyOverAPlaneHasItsClosedForm) {
  const double kRho = 0.5, kRadiance = 2.0;
  for (const std::string direct : {"nee", "photons"}) {
    std::ostringstream x;
    x << R"(<integrator type="spm"><string name="direct" value=")" << direct
      << R"("/><integer name="streams" value="100000"/><float name="radius" value="2"/></integrator>)"
      << camera_xml() << R"(<emitter type="constant"><float name="radiance" value=")" << kRadiance
      << R"("/></emitter><shape type="rectangle"><transform name="to_world"><scale value="10"/>
      <rotate x="1" angle="-90"/></transform><bsdf type="diffuse"><float name="reflectance" value=")"
      << kRho << R"("/></bsdf></shape>)";
    const spm::test::Measured m = means(x.str(), 8);
    EXPECT_NEAR(m.mean, kRho * kRadiance, 4.0 * m.standard_error + 1e-3) << direct;
    EXPECT_LT(m.standard_error, 0.02) << direct;
  }
}

// White furnaces: a sphere under a constant sky of radiance 1, seen at its
// centre. Whatever it is made of, if it keeps all the light that meets it
// it looks like the sky: radiance 1 (a white diffuse or plastic sphere
// reflects the sky once, being convex; glass lets it through and back out
// after any number of bounces; Beckmann microfacets of roughness 0.1 lose
// under 0.02%, tools/furnace_albedos.py). Within 1%, and 4 standard errors.
TEST(Environment, WhiteFurnacesLookLikeTheSky) {
  const char* const bsdfs[] = {
      R"(<bsdf type="diffuse"><float name="reflectance" value="1"/></bsdf>)",
      R"(<bsdf type="plastic"><float name="diffuse_reflectance" value="1"/></bsdf>)",
      R"(<bsdf type="conductor"/>)",
      R"(<bsdf type="roughconductor"><float name="alpha" value="0.1"/></bsdf>)",
      R"(<bsdf type="dielectric"/>)",
      R"(<bsdf type="roughdielectric"><float name="alpha" value="0.1"/></bsdf>)",
  };
  for (const char* bsdf : bsdfs) {
    const std::string body = R"(<integrator type="volpath"/>)" + camera_xml() +
                             R"(<emitter type="constant"/><shape type="sphere"><float name="radius" value="0.5"/>)" +
                             bsdf + "</shape>";
    const spm::test::Measured m = means(body, 6);
    EXPECT_NEAR(m.mean, 1.0, 0.01 + 4.0 * m.standard_error) << bsdf;
  }
}

class EnvironmentFiles : public ::testing::Test {
 protected:
  fs::path dir = fs::temp_directory_path() / ("spm_env_" + std::to_string(::getpid()));
  void SetUp() override { fs::create_directories(dir); }
  void TearDown() override { fs::remove_all(dir); }
  std::string path(const std::string& name) const { return (dir / name).string(); }
};

// The lookup is Mitsuba's: texel-centred in u, rows at theta = j pi / (H -
// 1). A map of three rows, 1 at the top (theta 0, +y), 2 at the horizon
// and 3 at the bottom (-y), is 1 + 2 theta / pi under that lookup; it
// lights a plane facing up from the upper hemisphere alone, whose
// radiance is rho / pi times the irradiance, computed here by quadrature.
TEST_F(EnvironmentFiles, AMapLightsAPlaneAsItsLookupSays) {
  spm::Image map;
  map.width = 4;
  map.height = 3;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 4; ++i) map.rgb.insert(map.rgb.end(), 3, float(j + 1));
  spm::write_exr(path("rows.exr"), map);
  // Irradiance of the upper hemisphere, the map's value at theta being 1 +
  // 2 theta / pi: int (1 + 2 theta / pi) cos sin dtheta dphi over theta < pi/2.
  double e = 0.0;
  constexpr int kSteps = 100000;
  for (int k = 0; k < kSteps; ++k) {
    const double t = (k + 0.5) / kSteps * M_PI / 2;
    e += (1.0 + 2.0 * t / M_PI) * std::cos(t) * std::sin(t) * (M_PI / 2 / kSteps) * 2.0 * M_PI;
  }
  const double kRho = 0.5, expected = kRho / M_PI * e;
  const std::string body = R"(<integrator type="spm"><integer name="streams" value="100000"/></integrator>)" +
                           camera_xml() + R"(<emitter type="envmap"><string name="filename" value=")" +
                           path("rows.exr") + R"("/></emitter><shape type="rectangle"><transform name="to_world">
      <scale value="10"/><rotate x="1" angle="-90"/></transform><bsdf type="diffuse"><float name="reflectance"
      value="0.5"/></bsdf></shape>)";
  const spm::test::Measured m = means(body, 8);
  EXPECT_NEAR(m.mean, expected, 4.0 * m.standard_error + 1e-3 * expected);
}

// Bad maps and emitters are refused at their element's line.
TEST_F(EnvironmentFiles, BadMapsAreRefusedAtTheirLine) {
  std::ofstream(path("notes.png")) << "not an image\n";
  spm::Image tiny;
  tiny.width = tiny.height = 1;
  tiny.rgb = {-1.0f, 0.0f, 0.0f};
  spm::write_exr(path("negative.exr"), tiny);
  const std::pair<std::string, std::string> cases[] = {
      {R"(<emitter type="envmap"><string name="filename" value="missing.exr"/></emitter>)", "missing.exr"},
      {R"(<emitter type="envmap"><string name="filename" value=")" + path("notes.png") + R"("/></emitter>)",
       "cannot read image"},
      {R"(<emitter type="envmap"><string name="filename" value=")" + path("negative.exr") + R"("/></emitter>)",
       "negative or not finite"},
      {R"(<emitter type="envmap"/>)", "needs a filename"},
      {R"(<emitter type="constant"><float name="radiance" value="-1"/></emitter>)", "must not be negative"},
      {R"(<emitter type="constant"><transform name="to_world"><scale value="2, 1, 1"/></transform></emitter>)",
       "must be a rotation"},
  };
  for (const auto& [emitter, keyword] : cases) {
    const std::string text = "<scene version=\"3.0.0\">\n" + camera_xml() +
                             "\n<shape type=\"sphere\"/>\n" + emitter + "\n</scene>";
    try {
      spm::load_scene_string(text, path("scene.xml"));
      ADD_FAILURE() << "no error for " << emitter;
    } catch (const spm::InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(path("scene.xml") + ":6:", 0), 0u) << what;
      EXPECT_NE(what.find(keyword), std::string::npos) << what;
    }
  }
}

}  // namespace
