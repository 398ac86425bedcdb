// Direct lighting against closed forms: a small black square light above a
// large diffuse plane (black, so that no light bounces between the two). The radiance of the point below the light is albedo / pi
// times the irradiance; through an absorbing medium every light path and the
// camera ray are attenuated by exp(-sigma_t d) (paper eq. 2).
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "render/render.h"
#include "scene/loader.h"
#include "test_support.h"

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kSide = 2.0;       // light: kSide x kSide square
constexpr double kHeight = 10.0;    // above the plane
constexpr double kRadiance = 10.0;  // of the light
constexpr double kAlbedo = 0.5;
const double kCamera[3] = {0.0, 6.0, 8.0};  // looks at the origin from 10 units away

// Irradiance at a point below the corner of an a x b rectangle at height h
// (form factor of a differential area to a parallel rectangle, times pi L).
double corner_irradiance(double a, double b, double h, double radiance) {
  const double x = a / h, y = b / h;
  const double f = (x / std::sqrt(1 + x * x) * std::atan(y / std::sqrt(1 + x * x)) +
                    y / std::sqrt(1 + y * y) * std::atan(x / std::sqrt(1 + y * y))) /
                   (2 * kPi);
  return kPi * radiance * f;
}

// Irradiance below the centre of the light with per-path attenuation
// exp(-sigma r), by midpoint quadrature over the light.
double quadrature_irradiance(double sigma) {
  const int n = 1000;
  double sum = 0.0;
  const double cell = kSide / n;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double x = -kSide / 2 + (i + 0.5) * cell, z = -kSide / 2 + (j + 0.5) * cell;
      const double r2 = x * x + z * z + kHeight * kHeight;
      const double cos2 = kHeight * kHeight / r2;
      sum += kRadiance * cos2 / r2 * std::exp(-sigma * std::sqrt(r2)) * cell * cell;
    }
  }
  return sum;
}

std::string scene_xml(double sigma) {
  const bool fog = sigma > 0.0;
  std::ostringstream x;
  x << R"(<scene version="3.0.0">)";
  // Mitsuba resolves references in document order: the medium comes first.
  if (fog) {
    x << R"(
  <medium type="homogeneous" id="fog"><float name="sigma_t" value=")" << sigma
      << R"("/><float name="albedo" value="0"/></medium>
  <shape type="cube"><transform name="to_world"><scale value="500"/></transform>
    <bsdf type="null"/><ref name="interior" id="fog"/></shape>)";
  }
  x << R"(
  <sensor type="perspective">
    <float name="fov" value="1"/>
    <transform name="to_world"><lookat origin=")"
    << kCamera[0] << ", " << kCamera[1] << ", " << kCamera[2] << R"(" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/><rfilter type="box"/></film>
    <sampler type="independent"><integer name="sample_count" value="64"/></sampler>)"
    << (fog ? R"(<ref id="fog"/>)" : "") << R"(
  </sensor>)";
  const char* ext = fog ? R"(<ref name="exterior" id="fog"/>)" : "";
  x << R"(
  <shape type="rectangle">
    <transform name="to_world"><scale value="200"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><float name="reflectance" value=")"
    << kAlbedo << R"("/></bsdf>)" << ext << R"(
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><scale value=")"
    << kSide / 2 << R"("/><rotate x="1" angle="90"/><translate y=")" << kHeight << R"("/></transform>
    <bsdf type="diffuse"><float name="reflectance" value="0"/></bsdf>
    <emitter type="area"><rgb name="radiance" value=")"
    << kRadiance << R"("/></emitter>)" << ext << R"(
  </shape>
</scene>)";
  return x.str();
}

struct Measured {
  double mean, standard_error;
};

Measured render_centre(double sigma) {
  const spm::Scene scene = spm::load_scene_string(scene_xml(sigma), "direct.xml");
  spm::RenderSettings settings;
  settings.seed = 11;
  const spm::Image image = spm::render(scene, settings, spm::test::device());
  // Every pixel is an independent mean of 64 samples of the same (flat to
  // 1e-4 over the footprint) radiance: their spread gives the standard error.
  const int n = image.width * image.height;
  double sum = 0.0, sum2 = 0.0;
  for (int i = 0; i < n; ++i) {
    const double v = image.rgb[3 * i];
    sum += v;
    sum2 += v * v;
  }
  const double mean = sum / n;
  const double var = (sum2 / n - mean * mean) * n / (n - 1);
  return {mean, std::sqrt(var / n)};
}

TEST(DirectLighting, QuadratureMatchesTheClosedForm) {
  const double closed = 4 * corner_irradiance(kSide / 2, kSide / 2, kHeight, kRadiance);
  EXPECT_NEAR(quadrature_irradiance(0.0), closed, 1e-6 * closed);
}

TEST(DirectLighting, DiffusePlaneBelowSquareLight) {
  const double expected = kAlbedo / kPi * 4 * corner_irradiance(kSide / 2, kSide / 2, kHeight, kRadiance);
  const Measured m = render_centre(0.0);
  // The bound is tight enough to catch a 1% error in the estimator.
  EXPECT_GT(m.standard_error, 0.0);
  EXPECT_LT(4 * m.standard_error, 0.01 * expected);
  EXPECT_NEAR(m.mean, expected, 4 * m.standard_error + 1e-4 * expected)
      << "standard error " << m.standard_error;
}

TEST(DirectLighting, ThroughAnAbsorbingMedium) {
  const double sigma = 0.08;
  const double camera_distance = std::sqrt(kCamera[1] * kCamera[1] + kCamera[2] * kCamera[2]);
  const double expected = kAlbedo / kPi * quadrature_irradiance(sigma) * std::exp(-sigma * camera_distance);
  const Measured m = render_centre(sigma);
  EXPECT_LT(4 * m.standard_error, 0.01 * expected);
  EXPECT_NEAR(m.mean, expected, 4 * m.standard_error + 1e-4 * expected)
      << "standard error " << m.standard_error;
  // The attenuation is large enough that ignoring the medium would fail.
  const double unattenuated = kAlbedo / kPi * quadrature_irradiance(0.0);
  EXPECT_GT(unattenuated - expected, 10 * m.standard_error);
}

}  // namespace
