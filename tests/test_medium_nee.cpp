// Single scattering in a medium by next-event estimation (METHOD.md 20):
// the radiance along a camera ray that passes a point light in an infinite
// homogeneous medium, against the integral along the ray by quadrature.
// With max_depth 2 only single scattering counts, so a volume estimate that
// also kept the photon records of streams without an earlier event would
// count it twice, and fail. The photon maps alone (--direct photons) must
// estimate the same integral.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <vector>

#include "render/render.h"
#include "scene/loader.h"
#include "test_support.h"

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kSigmaT = 0.5, kAlbedo = 0.8, kG = 0.5;  // forward scattering: a phase sign error shows
constexpr double kIntensity = 10.0;
constexpr double kD = 1.0, kDelta = 2.0;  // the light: D from the ray, Delta along it
constexpr double kNear = 0.01;            // the camera's near clip: the ray starts there

double hg(double cos_theta, double g) {
  const double denom = 1 + g * g - 2 * g * cos_theta;
  return (1 - g * g) / (4 * kPi * denom * std::sqrt(denom));
}

// sigma_s I / D times the integral over theta of exp(-sigma_t (t - near +
// r)) p, with t = Delta + D tan(theta) along the ray, r = D / cos(theta) to
// the light, and the cosine between the light's photons and the direction
// to the camera -sin(theta); Simpson's rule. As in Mitsuba, the ray (and its
// transmittance) starts at the near clip plane.
double single_scattering() {
  const double a = std::atan((kNear - kDelta) / kD), b = 0.5 * kPi;
  const int n = 200000;
  const double h = (b - a) / n;
  double sum = 0.0;
  for (int i = 0; i <= n; ++i) {
    const double th = std::min(a + i * h, b - 1e-12);
    const double t = kDelta + kD * std::tan(th), r = kD / std::cos(th);
    const double f = std::exp(-kSigmaT * (t - kNear + r)) * hg(-std::sin(th), kG);
    sum += f * (i == 0 || i == n ? 1 : (i % 2 ? 4 : 2));
  }
  return kSigmaT * kAlbedo * kIntensity / kD * sum * h / 3;
}

// A sphere light of radius kR and radiance kRadiance at the point light's
// place: about the same power, seen from the ray under a cone of up to 24
// degrees, so that sampling it by area would waste half its points.
constexpr double kR = 0.4, kRadiance = 20.0;

// As single_scattering(), with the light the sphere: at each point of the
// ray, the radiance through the cone the sphere subtends there, attenuated
// to the sphere's near surface, by the midpoint rule in 1 - cos(alpha) (the
// solid angle's measure) and the azimuth; along the ray, Simpson's rule in
// theta about the sphere's centre as before.
double sphere_single_scattering() {
  const double a = std::atan((kNear - kDelta) / kD), b = 0.5 * kPi;
  const int n = 4000, cone = 64, azimuths = 64;
  const double h = (b - a) / n;
  double sum = 0.0;
  for (int i = 0; i <= n; ++i) {
    const double th = std::min(a + i * h, b - 1e-12);
    const double t = kDelta + kD * std::tan(th);
    // From x = (0, 0, t) to the centre (0, D, Delta): the cone's axis w and
    // a frame (e1, e2) about it; the ray's direction is d = +z.
    const double wy = kD, wz = kDelta - t, dc = std::hypot(wy, wz);
    const double w[3] = {0.0, wy / dc, wz / dc}, e1[3] = {1.0, 0.0, 0.0}, e2[3] = {0.0, -w[2], w[1]};
    const double sin2_max = kR * kR / (dc * dc), one_minus_max = 1.0 - std::sqrt(1.0 - sin2_max);
    double in = 0.0;
    for (int j = 0; j < cone; ++j) {
      const double one_minus_cos = (j + 0.5) / cone * one_minus_max, cos_a = 1.0 - one_minus_cos;
      const double sin_a = std::sqrt(one_minus_cos * (2.0 - one_minus_cos));
      const double r = dc * cos_a - std::sqrt(std::max(0.0, kR * kR - dc * dc * sin_a * sin_a));
      for (int k = 0; k < azimuths; ++k) {
        const double phi = 2.0 * kPi * (k + 0.5) / azimuths;
        const double cos_d = cos_a * w[2] + sin_a * (std::cos(phi) * e1[2] + std::sin(phi) * e2[2]);
        in += std::exp(-kSigmaT * r) * hg(cos_d, kG);
      }
    }
    in *= kRadiance * 2.0 * kPi * one_minus_max / (cone * azimuths);
    const double f = std::exp(-kSigmaT * (t - kNear)) * in * kD / (std::cos(th) * std::cos(th));
    sum += f * (i == 0 || i == n ? 1 : (i % 2 ? 4 : 2));
  }
  return kSigmaT * kAlbedo * sum * h / 3;
}

std::string point_light() {
  std::ostringstream x;
  x << R"(<emitter type="point"><point name="position" x="0" y=")" << kD << R"(" z=")" << kDelta
    << R"("/><rgb name="intensity" value=")" << kIntensity << R"("/></emitter>)";
  return x.str();
}

std::string sphere_light() {
  std::ostringstream x;
  x << R"(<shape type="sphere"><point name="center" x="0" y=")" << kD << R"(" z=")" << kDelta
    << R"("/><float name="radius" value=")" << kR << R"("/>
    <emitter type="area"><rgb name="radiance" value=")"
    << kRadiance << R"("/></emitter><ref name="exterior" id="fog"/></shape>)";
  return x.str();
}

std::string scene_xml(const char* direct, int streams, double radius, int res, int samples,
                      const std::string& light = point_light()) {
  std::ostringstream x;
  x << R"(<scene version="3.0.0">
  <integrator type="spm"><integer name="max_depth" value="2"/><string name="direct" value=")"
    << direct << R"("/>
    <integer name="streams" value=")" << streams << R"("/><integer name="associated" value="1"/>
    <float name="radius" value=")" << radius << R"("/></integrator>
  <medium type="homogeneous" id="fog"><float name="sigma_t" value=")"
    << kSigmaT << R"("/><float name="albedo" value=")" << kAlbedo << R"("/>
    <phase type="hg"><float name="g" value=")"
    << kG << R"("/></phase></medium>
  <sensor type="perspective">
    <float name="fov" value="0.05"/><float name="near_clip" value=")"
    << kNear << R"("/>
    <transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, 1" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value=")"
    << res << R"("/><integer name="height" value=")" << res << R"("/><rfilter type="box"/></film>
    <sampler type="independent"><integer name="sample_count" value=")"
    << samples << R"("/></sampler>
    <ref id="fog"/>
  </sensor>
  )" << light << R"(
</scene>)";
  return x.str();
}

double image_mean(const spm::Image& image) {
  double sum = 0.0;
  for (int i = 0; i < image.width * image.height; ++i) sum += image.rgb[3 * i];
  return sum / (image.width * image.height);
}

// Renders one pass of 1024 samples of the scene (a 16x16 film whose pixels
// all see the same ray) and expects its mean within 4 standard errors (and
// 0.2%) of `expected`. Every pixel is an independent mean of 1024 samples
// of that ray (the field of view is 0.05 degrees): their spread gives the
// standard error, which must be small enough to catch a 1% error.
void expect_single_scattering(const std::string& xml, uint32_t seed, double expected) {
  const spm::Scene scene = spm::load_scene_string(xml, "halo.xml");
  spm::RenderSettings settings;
  settings.seed = seed;
  settings.passes = 1;
  settings.spp = 1024;
  const spm::Image image = spm::render(scene, settings, spm::test::device());
  const int n = image.width * image.height;
  const double mean = image_mean(image);
  double var = 0.0;
  for (int i = 0; i < n; ++i) var += (image.rgb[3 * i] - mean) * (image.rgb[3 * i] - mean);
  const double se = std::sqrt(var / (n - 1) / n);
  EXPECT_GT(se, 0.0);
  EXPECT_LT(4 * se, 0.01 * expected) << "the bound must catch a 1% error";
  EXPECT_NEAR(mean, expected, 4 * se + 2e-3 * expected) << "standard error " << se;
}

// Enough streams that about 500 records of their first events lie within r
// of the ray: kept by mistake, they would add the integral again.
TEST(MediumNee, SingleScatteringOfAPointLightMatchesTheIntegral) {
  expect_single_scattering(scene_xml("nee", 200000, 0.1, 16, 1024), 5, single_scattering());
}

// The same with a sphere light, which next-event estimation samples by the
// cone it subtends (lib/lights.h, sample_light_from): a wrong solid angle
// or a point off the sphere's near side shows in the mean.
TEST(MediumNee, SingleScatteringOfASphereLightMatchesTheIntegral) {
  expect_single_scattering(scene_xml("nee", 200000, 0.1, 16, 1024, sphere_light()), 7, sphere_single_scattering());
}

TEST(MediumNee, PhotonMapsAloneEstimateTheSameIntegral) {
  const double expected = single_scattering();
  const spm::Scene scene = spm::load_scene_string(scene_xml("photons", 1000000, 0.15, 4, 4), "halo.xml");
  // Neighbouring pixels share photons, so the standard error comes from the
  // spread of independent renders (seeds) instead.
  std::vector<double> means;
  for (uint32_t seed = 1; seed <= 6; ++seed) {
    spm::RenderSettings settings;
    settings.seed = seed;
    settings.passes = 1;
    settings.spp = 1;
    means.push_back(image_mean(spm::render(scene, settings, spm::test::device())));
  }
  double mean = 0.0, var = 0.0;
  for (double m : means) mean += m / means.size();
  for (double m : means) var += (m - mean) * (m - mean) / (means.size() - 1);
  const double se = std::sqrt(var / means.size());
  // The radius (0.15 against the light's distance of 1 from the ray) blurs
  // the field by about (r / D)^2 / 8, under 1%.
  EXPECT_NEAR(mean, expected, 4 * se + 0.01 * expected) << "standard error " << se;
  EXPECT_LT(4 * se, 0.05 * expected);
}

}  // namespace
