// Heterogeneous media (METHOD.md 12; kernels/lib/medium.h): the device's
// grid lookups against the host reference, the majorant grid bounding them,
// delta tracking and ray marching through a linear ramp against its
// closed-form free-flight CDF, spectral tracking's per-channel weights, and
// ratio tracking's transmittance against quadrature.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>
#include <random>

#include "render/render.h"
#include "scene/gpu_scene.h"
#include "scene/loader.h"
#include "scene/volume_grid.h"
#include "spm/propagate.h"
#include "stats.h"
#include "test_support.h"
#include "util/errors.h"

namespace {

using spm::GridVolume;
using spm::SceneTables;
using spm::VolumeGrid;

VolumeGrid random_grid(uint32_t nx, uint32_t ny, uint32_t nz, uint32_t channels, uint32_t seed) {
  VolumeGrid g;
  g.nx = nx;
  g.ny = ny;
  g.nz = nz;
  g.channels = channels;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  g.data.resize(size_t(nx) * ny * nz * channels);
  for (float& v : g.data) v = u(rng);
  return g;
}

// A density rising linearly along x over a box [0, L] x [0, 1] x [0, 1]:
// texel i holds (i + 0.5) / n, so the trilinear lookup is x / L between the
// first and last texel centres and constant within half a texel of the
// faces.
GridVolume ramp(uint32_t n, float length) {
  GridVolume v;
  v.grid.nx = n;
  v.grid.ny = v.grid.nz = 1;
  for (uint32_t i = 0; i < n; ++i) v.grid.data.push_back((float(i) + 0.5f) / float(n));
  v.to_world = glm::scale(glm::mat4(1.0f), glm::vec3(length, 1.0f, 1.0f));
  return v;
}

// Optical depth of the ramp (times `scale`) from x = 0 to x = s.
double ramp_depth(double s, uint32_t n, double length, double scale) {
  const double a = 0.5 / n, b = 1.0 - 0.5 / n, x1 = a * length, x2 = b * length;
  double tau = a * std::min(s, x1);
  if (s > x1) {
    const double m = std::min(s, x2) / length;
    tau += 0.5 * length * (m * m - a * a);
  }
  if (s > x2) tau += b * (s - x2);
  return scale * tau;
}

SpmMedium grid_medium(glm::vec3 sigma_t, int grid) {
  SpmMedium m{};
  for (int c = 0; c < 3; ++c) {
    m.sigma_t[c] = sigma_t[c];
    m.albedo[c] = 1.0f;
  }
  m.sigma_t_grid = grid;
  m.albedo_grid = -1;
  return m;
}

// The tables on the device and a run of one of spm_medium_test.cl's
// flight or transmittance entry points.
struct MediumRig {
  SceneTables t;
  cl::Buffer media, grids, data;

  MediumRig(const std::vector<GridVolume>& volumes, const std::vector<SpmMedium>& m) {
    for (const GridVolume& v : volumes) spm::append_grid(t, v);
    t.media = m;
    auto& dev = spm::test::device();
    media = dev.upload("media", t.media);
    grids = dev.upload("grids", t.grids);
    data = dev.upload("grid data", t.grid_data);
  }

  std::vector<cl_float4> run(const char* kernel, glm::vec4 origin, glm::vec4 direction, float step, uint32_t n,
                             uint32_t seed = 7) const {
    auto& dev = spm::test::device();
    const spm::DeviceBuffer out = dev.buffer(sizeof(cl_float4) * n, "out", CL_MEM_WRITE_ONLY);
    cl::Kernel k = dev.kernel("spm_medium_test", kernel);
    const cl_float4 o = {{origin.x, origin.y, origin.z, origin.w}};
    const cl_float4 d = {{direction.x, direction.y, direction.z, direction.w}};
    spm::set_args(k, spm::arg("media", media), spm::arg("grids", grids), spm::arg("grid_data", data),
                  spm::arg("origin", o), spm::arg("direction", d), spm::arg("medium", cl_int(0)),
                  spm::arg("march_step", step), spm::arg("seed", cl_uint(seed)), spm::arg("out", out),
                  spm::arg("count", cl_uint(n)));
    dev.launch(k, n);
    return dev.download<cl_float4>(out, n);
  }
};

TEST(Heterogeneous, GridLookupMatchesTheHostReference) {
  for (uint32_t channels : {1u, 3u}) {
    for (bool nearest : {false, true}) {
      GridVolume v;
      v.grid = random_grid(7, 5, 9, channels, 11 + channels);
      v.nearest = nearest;
      MediumRig rig({v}, {grid_medium(glm::vec3(1.0f), 0)});
      std::mt19937 rng(3);
      std::uniform_real_distribution<float> u(0.0f, 1.0f);
      std::vector<cl_float4> points;
      for (int i = 0; i < 400; ++i) points.push_back({{u(rng), u(rng), u(rng), 0.0f}});
      // Texel centres, texel borders and the faces of the cube, where the
      // clamping and the nearest texel's choice change.
      for (int i = 0; i <= 14; ++i) {
        const float a = float(i) / 14.0f, b = float(i) / 10.0f, c = float(i) / 18.0f;
        points.push_back({{a, std::min(b, 1.0f), c, 0.0f}});
        points.push_back({{(float(i % 7) + 0.5f) / 7.0f, 0.0f, 1.0f, 0.0f}});
      }
      // Outside the cube the medium has no density.
      const size_t inside = points.size();
      for (float x : {-0.01f, 1.01f, -3.0f}) {
        points.push_back({{x, 0.5f, 0.5f, 0.0f}});
        points.push_back({{0.5f, x, 0.5f, 0.0f}});
        points.push_back({{0.5f, 0.5f, x, 0.0f}});
      }
      auto& dev = spm::test::device();
      const cl::Buffer pb = dev.upload("points", points);
      const spm::DeviceBuffer out = dev.buffer(sizeof(cl_float4) * points.size(), "out", CL_MEM_WRITE_ONLY);
      cl::Kernel k = dev.kernel("spm_medium_test", "spm_grid_lookup_test");
      spm::set_args(k, spm::arg("grids", rig.grids), spm::arg("grid_data", rig.data), spm::arg("points", pb),
                    spm::arg("out", out), spm::arg("count", cl_uint(points.size())), spm::arg("grid", cl_uint(0)));
      dev.launch(k, points.size());
      const auto got = dev.download<cl_float4>(out, points.size());
      for (size_t i = 0; i < points.size(); ++i) {
        const glm::vec3 p(points[i].s[0], points[i].s[1], points[i].s[2]);
        for (uint32_t c = 0; c < 3; ++c) {
          const float want = i < inside ? spm::grid_lookup(v.grid, p, channels == 3 ? c : 0, nearest) : 0.0f;
          EXPECT_NEAR(got[i].s[c], want, 2e-6f) << "channels " << channels << " nearest " << nearest << " at ("
                                                << p.x << ", " << p.y << ", " << p.z << ") channel " << c;
        }
      }
    }
  }
}

TEST(Heterogeneous, MajorantGridBoundsEveryLookupInItsCell) {
  for (bool nearest : {false, true}) {
    GridVolume v;
    v.grid = random_grid(21, 9, 16, 3, 5);
    v.nearest = nearest;
    SceneTables t;
    spm::append_grid(t, v);
    const SpmGridVolume& g = t.grids[0];
    ASSERT_EQ(g.majorant_dims[0], 3u);
    ASSERT_EQ(g.majorant_dims[1], 2u);
    ASSERT_EQ(g.majorant_dims[2], 2u);
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    double tightest = 0.0;
    for (int i = 0; i < 20000; ++i) {
      const glm::vec3 p(u(rng), u(rng), u(rng));
      uint32_t cell[3];
      for (int a = 0; a < 3; ++a) cell[a] = std::min(uint32_t(p[a] * float(g.majorant_dims[a])), g.majorant_dims[a] - 1);
      const float majorant =
          t.grid_data[g.majorant_offset + (cell[2] * g.majorant_dims[1] + cell[1]) * g.majorant_dims[0] + cell[0]];
      for (uint32_t c = 0; c < 3; ++c) {
        const float value = spm::grid_lookup(v.grid, p, c, nearest);
        ASSERT_LE(value, majorant) << "at (" << p.x << ", " << p.y << ", " << p.z << ")";
        tightest = std::max(tightest, double(value / majorant));
      }
    }
    // A majorant far above the values would make tracking slow, not wrong.
    EXPECT_GT(tightest, 0.9);
  }
}

// Free flights along the ramp from x = 0 (tmax = L): the events' distances
// against the CDF 1 - exp(-tau(t)) conditioned on an event, and the share
// that gets through against exp(-tau(L)).
struct RampFlights {
  double ks = 0.0;
  double escaped = 0.0, escaped_expected = 0.0, escaped_error = 0.0;
};

// An albedo grid of ones over the ramp's first half only: the medium
// scatters there alone, but its extinction is the ramp's everywhere.
GridVolume first_half_albedo(float length) {
  GridVolume v;
  v.grid.nx = v.grid.ny = v.grid.nz = 2;
  v.grid.data.assign(8, 1.0f);
  v.to_world = glm::scale(glm::mat4(1.0f), glm::vec3(0.5f * length, 1.0f, 1.0f));
  return v;
}

RampFlights ramp_flights(float step, uint32_t n, bool half_albedo = false) {
  const uint32_t texels = 16;
  const float length = 2.0f, scale = 2.0f;
  SpmMedium medium = grid_medium(glm::vec3(scale), 0);
  if (half_albedo) medium.albedo_grid = 1;
  MediumRig rig({ramp(texels, length), first_half_albedo(length)}, {medium});
  const auto got = rig.run("spm_flight_test", {0.0f, 0.5f, 0.5f, 0.0f}, {1.0f, 0.0f, 0.0f, length}, step, n);
  std::vector<double> events;
  for (const cl_float4& r : got) {
    if (std::isfinite(r.s[0])) events.push_back(r.s[0]);
    EXPECT_EQ(r.s[1], 1.0f) << "a grey medium needs no weight";
  }
  const double total = ramp_depth(length, texels, length, scale);
  RampFlights out;
  out.ks = spm::test::ks_statistic(events, [&](double t) {
    return -std::expm1(-ramp_depth(t, texels, length, scale)) / -std::expm1(-total);
  });
  out.escaped = 1.0 - double(events.size()) / n;
  out.escaped_expected = std::exp(-total);
  out.escaped_error = std::sqrt(out.escaped_expected * (1.0 - out.escaped_expected) / n);
  return out;
}

TEST(Heterogeneous, DeltaTrackingThroughALinearRampMatchesTheClosedFormCdf) {
  // With an albedo grid over half the ramp too: where the medium does not
  // scatter it still absorbs.
  const uint32_t n = 40000;
  for (bool half_albedo : {false, true}) {
    const RampFlights f = ramp_flights(0.0f, n, half_albedo);
    EXPECT_LT(f.ks, spm::test::ks_critical(n)) << "albedo grid over half the ramp: " << half_albedo;
    EXPECT_NEAR(f.escaped, f.escaped_expected, 4.0 * f.escaped_error) << "half albedo grid: " << half_albedo;
  }
}

TEST(Heterogeneous, RayMarchingBiasShrinksWithTheStep) {
  // The paper's marching takes sigma_t at each step's midpoint and places
  // the event by an exponential of that constant: within a step of the ramp
  // the true density rises, so events come too early in the step. The
  // chance of an event per step is exact for a linear density (the midpoint
  // rule integrates it exactly), so the escapes match at every step.
  const uint32_t n = 40000;
  std::vector<double> ks;
  for (float step : {0.5f, 0.125f, 0.03125f}) {
    const RampFlights f = ramp_flights(step, n);
    EXPECT_NEAR(f.escaped, f.escaped_expected, 4.0 * f.escaped_error) << "step " << step;
    ks.push_back(f.ks);
    std::printf("ray marching, step %.5f: KS %.4f (critical %.4f)\n", step, f.ks, spm::test::ks_critical(n));
  }
  EXPECT_GT(ks[0], spm::test::ks_critical(n)) << "a coarse step's bias is visible";
  EXPECT_GT(ks[0], 2.0 * ks[2]);
  EXPECT_LT(ks[2], spm::test::ks_critical(n));
}

TEST(Heterogeneous, SpectralTrackingWeightsGiveEveryChannelItsTransmittance) {
  // RGB sigma_t sampled with the channel mean (METHOD.md 3): the weighted
  // share of flights that get through is each channel's transmittance, and
  // the weighted share of events before L / 2 its 1 - T(L / 2).
  const uint32_t texels = 16, n = 40000;
  const float length = 2.0f;
  const glm::vec3 factor(0.5f, 1.0f, 2.5f);
  MediumRig rig({ramp(texels, length)}, {grid_medium(factor, 0)});
  for (float step : {0.0f, 0.01f}) {
    const auto got = rig.run("spm_flight_test", {0.0f, 0.5f, 0.5f, 0.0f}, {1.0f, 0.0f, 0.0f, length}, step, n);
    for (int c = 0; c < 3; ++c) {
      std::vector<double> through, early;
      for (const cl_float4& r : got) {
        through.push_back(std::isfinite(r.s[0]) ? 0.0 : r.s[1 + c]);
        early.push_back(r.s[0] < 0.5f * length ? r.s[1 + c] : 0.0);
      }
      const auto a = spm::test::mean_and_error(through), b = spm::test::mean_and_error(early);
      EXPECT_NEAR(a.mean, std::exp(-ramp_depth(length, texels, length, factor[c])), 4.0 * a.error)
          << "step " << step << " channel " << c;
      EXPECT_NEAR(b.mean, -std::expm1(-ramp_depth(0.5 * length, texels, length, factor[c])),
                  4.0 * b.error)
          << "step " << step << " channel " << c;
    }
  }
}

// Optical depth along [t0, t1] of o + t d through grid volume v (density 0
// outside its cube) times `factor`, by the midpoint rule in 20000 steps.
double quadrature_depth(const GridVolume& v, glm::vec3 o, glm::vec3 d, double t0, double t1, double factor) {
  const glm::mat4 to_local = glm::inverse(v.to_world);
  const int steps = 20000;
  const double h = (t1 - t0) / steps;
  double tau = 0.0;
  for (int i = 0; i < steps; ++i) {
    const glm::vec3 x = o + float(t0 + (i + 0.5) * h) * d;
    const glm::vec3 p(to_local * glm::vec4(x, 1.0f));
    if (p.x < 0 || p.x > 1 || p.y < 0 || p.y > 1 || p.z < 0 || p.z > 1) continue;
    tau += spm::grid_lookup(v.grid, p, 0, v.nearest) * h;
  }
  return tau * factor;
}

TEST(Heterogeneous, RatioTrackingTransmittanceMatchesQuadrature) {
  GridVolume box;
  box.grid = random_grid(8, 6, 7, 1, 21);
  box.to_world = glm::translate(glm::mat4(1.0f), glm::vec3(-1.0f, 0.5f, -0.3f)) *
                 glm::rotate(glm::mat4(1.0f), 0.6f, glm::normalize(glm::vec3(1.0f, 2.0f, 0.5f))) *
                 glm::scale(glm::mat4(1.0f), glm::vec3(2.0f, 1.5f, 2.5f));
  const glm::vec3 factor(0.6f, 1.2f, 1.8f);
  struct Case {
    GridVolume v;
    glm::vec3 o, d;
    float t0, t1;
  };
  std::vector<Case> cases = {{ramp(16, 2.0f), {-0.5f, 0.5f, 0.5f}, {1.0f, 0.0f, 0.0f}, 0.0f, 3.0f}};
  const glm::vec3 centre(box.to_world * glm::vec4(0.5f, 0.5f, 0.5f, 1.0f));
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int i = 0; i < 4; ++i) {
    const glm::vec3 d = glm::normalize(glm::vec3(u(rng), u(rng), u(rng)));
    const glm::vec3 o = centre - 3.0f * d + 0.4f * glm::vec3(u(rng), u(rng), u(rng));
    cases.push_back({box, o, d, 0.5f, 5.0f + u(rng)});
  }
  const uint32_t n = 20000;
  for (const Case& c : cases) {
    SpmMedium medium = grid_medium(factor, 0);
    medium.albedo_grid = 1;  // an albedo grid that covers less changes no transmittance
    MediumRig rig({c.v, first_half_albedo(2.0f)}, {medium});
    const auto ratio = rig.run("spm_transmittance_test", {c.o, c.t0}, {c.d, c.t1}, 0.0f, n);
    const auto marched = rig.run("spm_transmittance_test", {c.o, c.t0}, {c.d, c.t1}, 0.002f, 1);
    for (int k = 0; k < 3; ++k) {
      const double want = std::exp(-quadrature_depth(c.v, c.o, c.d, c.t0, c.t1, factor[k]));
      std::vector<double> v;
      for (const cl_float4& r : ratio) v.push_back(r.s[k]);
      const auto m = spm::test::mean_and_error(v);
      EXPECT_NEAR(m.mean, want, 4.0 * m.error + 1e-6) << "channel " << k;
      EXPECT_NEAR(marched[0].s[k], want, 2e-3 * want + 1e-6) << "marching, channel " << k;
    }
  }
}

// ---- scenes ---------------------------------------------------------------

// A scratch directory with the grid files a test's scenes name.
class HeterogeneousScene : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("spm-heterogeneous-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  void write_grid(const std::string& name, const VolumeGrid& g) const { spm::write_vol((dir_ / name).string(), g); }

  spm::Scene load(const std::string& xml) const {
    return spm::load_scene_string(xml, (dir_ / "scene.xml").string());
  }

  std::string error_of(const std::string& xml) const {
    try {
      load(xml);
    } catch (const spm::InputError& e) {
      return e.what();
    }
    return "";
  }

  std::filesystem::path dir_;
};

// A cube of medium `medium` (the interior of a null cube [-1, 1]^3) with a
// point light inside it over a diffuse floor at y = -0.9, seen from outside.
std::string box_scene(const std::string& medium, int size = 16) {
  return R"(<scene version="3.0.0">
  <integrator type="spm"><integer name="streams" value="2000"/><integer name="associated" value="16"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="50"/>
    <transform name="to_world"><lookat origin="0, 0.5, 4" target="0, -0.3, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value=")" +
         std::to_string(size) + R"("/><integer name="height" value=")" + std::to_string(size) + R"("/></film>
  </sensor>
)" + medium + R"(
  <shape type="cube"><bsdf type="null"/><ref name="interior" id="smoke"/></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.9"/><rotate x="1" angle="-90"/>
    <translate y="-0.9"/></transform></shape>
  <emitter type="point"><point name="position" x="0" y="0.3" z="0"/><rgb name="intensity" value="4"/></emitter>
</scene>
)";
}

// The heterogeneous medium over the cube [-1, 1]^3 with sigma_t from
// `file`, scaled by `scale`.
std::string grid_medium_xml(const std::string& file, float scale, const std::string& extra = "") {
  return R"(<medium type="heterogeneous" id="smoke">
    <volume name="sigma_t" type="gridvolume"><string name="filename" value=")" +
         file + R"("/>
      <transform name="to_world"><scale value="2"/><translate value="-1, -1, -1"/></transform>
    </volume>
    <float name="scale" value=")" +
         std::to_string(scale) + R"("/><float name="albedo" value="0.8"/>)" + extra + R"(
  </medium>)";
}

VolumeGrid constant_grid(uint32_t n, float value) {
  VolumeGrid g;
  g.nx = g.ny = g.nz = n;
  g.data.assign(size_t(n) * n * n, value);
  return g;
}

TEST_F(HeterogeneousScene, ReadsMitsubasHeterogeneousMedium) {
  VolumeGrid g = random_grid(4, 3, 2, 1, 1);
  g.bbox_min = {-1.0f, 0.0f, 2.0f};
  g.bbox_max = {1.0f, 3.0f, 6.0f};
  write_grid("density.vol", g);
  write_grid("albedo.vol", random_grid(2, 2, 2, 3, 2));
  const spm::Scene s = load(box_scene(R"(<medium type="heterogeneous" id="smoke">
    <volume name="sigma_t" type="gridvolume"><string name="filename" value="density.vol"/>
      <boolean name="use_grid_bbox" value="true"/><string name="filter_type" value="nearest"/></volume>
    <volume name="albedo" type="gridvolume"><string name="filename" value="albedo.vol"/></volume>
    <float name="scale" value="3"/><phase type="hg"><float name="g" value="0.4"/></phase>
  </medium>)"));
  ASSERT_EQ(s.media.size(), 1u);
  const spm::Medium& m = s.media[0];
  EXPECT_TRUE(m.heterogeneous());
  EXPECT_EQ(m.sigma_t, glm::vec3(3.0f));
  EXPECT_EQ(m.albedo, glm::vec3(1.0f));
  ASSERT_EQ(s.volumes.size(), 2u);
  EXPECT_EQ(s.volumes[m.sigma_t_grid].grid.data, g.data);
  EXPECT_TRUE(s.volumes[m.sigma_t_grid].nearest);
  EXPECT_FALSE(s.volumes[m.albedo_grid].nearest);
  // use_grid_bbox: the unit cube maps to the file's box.
  const glm::vec4 far = s.volumes[m.sigma_t_grid].to_world * glm::vec4(1.0f);
  EXPECT_EQ(glm::vec3(far), g.bbox_max);
  EXPECT_TRUE(m.hg);
  EXPECT_FLOAT_EQ(m.g, 0.4f);

  // A constvolume, or a plain float, sets the coefficient alone.
  const spm::Scene c = load(box_scene(R"(<medium type="heterogeneous" id="smoke">
    <volume name="sigma_t" type="constvolume"><rgb name="value" value="1, 2, 3"/></volume>
    <float name="scale" value="0.5"/><float name="albedo" value="0.25"/>
  </medium>)"));
  EXPECT_FALSE(c.media[0].heterogeneous());
  EXPECT_EQ(c.media[0].sigma_t, glm::vec3(0.5f, 1.0f, 1.5f));
  EXPECT_EQ(c.media[0].albedo, glm::vec3(0.25f));
}

TEST_F(HeterogeneousScene, BadVolumesGetOneLineNamingTheSceneLineAndTheProblem) {
  write_grid("ok.vol", constant_grid(2, 0.5f));
  write_grid("bright.vol", constant_grid(2, 1.5f));
  {
    std::ofstream bad(dir_ / "truncated.vol", std::ios::binary);
    bad << "VOL";
  }
  struct Case {
    std::string medium, expect;
  };
  const std::vector<Case> cases = {
      {grid_medium_xml("missing.vol", 1.0f), "missing.vol"},
      {grid_medium_xml("truncated.vol", 1.0f), "truncated.vol"},
      {R"(<medium type="heterogeneous" id="smoke"><volume name="albedo" type="gridvolume">
         <string name="filename" value="bright.vol"/></volume></medium>)",
       "albedo must be in [0, 1]"},
      {grid_medium_xml("ok.vol", 1.0f, R"(<volume name="density" type="constvolume"/>)"), "sigma_t or albedo"},
      {R"(<medium type="heterogeneous" id="smoke"><volume name="albedo" type="checkerboard"/></medium>)",
       "unsupported volume type 'checkerboard'"},
      {R"(<medium type="heterogeneous" id="smoke"><float name="sigma_t" value="1"/>
         <volume name="sigma_t" type="constvolume"/></medium>)",
       "given twice"},
      {R"(<medium type="heterogeneous" id="smoke"><volume name="sigma_t" type="gridvolume">
         <string name="filename" value="ok.vol"/><string name="wrap_mode" value="repeat"/></volume></medium>)",
       "wrap_mode 'repeat' is not supported"},
      {R"(<medium type="heterogeneous" id="smoke"><volume name="sigma_t" type="gridvolume">
         <string name="filename" value="ok.vol"/><string name="grid" value="density"/></volume></medium>)",
       "OpenVDB"},
      {R"(<medium type="homogeneous" id="smoke"><volume name="sigma_t" type="constvolume"/></medium>)",
       "is not allowed in medium 'homogeneous'"},
  };
  for (const Case& c : cases) {
    const std::string xml = box_scene(c.medium);
    const std::string e = error_of(xml);
    EXPECT_NE(e.find(c.expect), std::string::npos) << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
    EXPECT_EQ(e.rfind((dir_ / "scene.xml").string() + ":", 0), 0u) << "names the scene's file and line: " << e;
  }
}

TEST_F(HeterogeneousScene, StreamBeamsRefuseHeterogeneousMediaWithColouredSigmaT) {
  write_grid("rgb.vol", random_grid(2, 2, 2, 3, 4));
  spm::Scene s = load(box_scene(grid_medium_xml("rgb.vol", 1.0f), 4));
  s.integrator.estimator = "beams";
  spm::RenderSettings r;
  r.passes = 1;
  try {
    spm::render(s, r, spm::test::device());
    FAIL() << "rendered";
  } catch (const spm::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("grey sigma_t only"), std::string::npos) << e.what();
  }
}

TEST_F(HeterogeneousScene, AGridLargerThanTheDeviceBudgetFailsNamingIt) {
  write_grid("big.vol", constant_grid(64, 0.5f));
  const spm::Scene s = load(box_scene(grid_medium_xml("big.vol", 1.0f), 4));
  spm::RenderSettings r;
  r.passes = 1;
  r.memory_budget = 600000;  // less than the grid's 1 MiB of values
  // A device of its own: the budget stays set on it after the failure.
  spm::Device dev(spm::select_device(std::getenv("SPM_TEST_DEVICE") ? std::getenv("SPM_TEST_DEVICE") : ""), "");
  try {
    spm::render(s, r, dev);
    FAIL() << "rendered";
  } catch (const spm::RuntimeError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("volume grid values"), std::string::npos) << m;
    EXPECT_NE(m.find("--device-memory"), std::string::npos) << m;
  }
}

// A grid of ones times sigma_t is the homogeneous medium of that sigma_t.
// Delta tracking's majorant is then sigma_t itself, every tentative
// collision is real, and the flights draw the numbers the homogeneous
// free flight draws: the photon maps are the same records up to float
// rounding.
TEST_F(HeterogeneousScene, ConstantGridPropagatesTheHomogeneousMediumsRecords) {
  write_grid("ones.vol", constant_grid(4, 1.0f));
  const float sigma = 1.3f;
  const spm::Scene het = load(box_scene(grid_medium_xml("ones.vol", sigma)));
  const spm::Scene hom = load(box_scene(R"(<medium type="homogeneous" id="smoke"><float name="sigma_t" value=")" +
                                        std::to_string(sigma) + R"("/><float name="albedo" value="0.8"/></medium>)"));
  auto& dev = spm::test::device();
  std::vector<spm::PhotonMaps> maps;
  for (const spm::Scene* s : {&hom, &het}) {
    const spm::SceneTables t = spm::flatten_scene(*s, 16, 16);
    const spm::GpuScene gpu(dev, t);
    spm::RenderSettings r;
    maps.push_back(spm::propagate_streams(dev, gpu, spm::stream_settings(*s, spm::resolve_settings(*s, r), 0)));
  }
  ASSERT_GT(maps[0].volume.size(), 1000u);
  // A float's last bit can flip a discrete choice (event or wall) and send
  // that stream elsewhere; almost all records must agree.
  size_t same = 0;
  for (size_t i = 0; i < std::min(maps[0].volume.size(), maps[1].volume.size()); ++i) {
    const SpmVolumeRecord &a = maps[0].volume[i], &b = maps[1].volume[i];
    bool close = a.stream == b.stream && a.depth == b.depth;
    for (int c = 0; c < 3; ++c) close = close && std::abs(a.position[c] - b.position[c]) < 1e-4f;
    same += close;
  }
  EXPECT_GT(double(same), 0.99 * double(maps[0].volume.size()));
  EXPECT_NEAR(double(maps[1].volume.size()), double(maps[0].volume.size()), 0.01 * double(maps[0].volume.size()));
}

// The same two media rendered: the photon maps agree (above), so the images
// differ only by the gather's ratio tracking (a 0-or-1 estimate of the
// transmittance when the majorant is sigma_t) and its equi-angular-only
// in-scattering, and by the tables the estimates read; their means over
// seeds agree within the noise, with the records and with stream beams.
class ConstantGrid : public HeterogeneousScene, public ::testing::WithParamInterface<const char*> {};

TEST_P(ConstantGrid, RendersTheHomogeneousImage) {
  write_grid("ones.vol", constant_grid(4, 1.0f));
  spm::Scene het = load(box_scene(grid_medium_xml("ones.vol", 1.3f), 16));
  spm::Scene hom = load(box_scene(
      R"(<medium type="homogeneous" id="smoke"><float name="sigma_t" value="1.3"/><float name="albedo" value="0.8"/></medium>)",
      16));
  het.integrator.estimator = hom.integrator.estimator = GetParam();
  std::vector<double> diff;
  double level = 0.0;
  for (uint32_t seed = 1; seed <= 6; ++seed) {
    double mean[2] = {0.0, 0.0};
    int k = 0;
    for (const spm::Scene* s : {&hom, &het}) {
      spm::RenderSettings r;
      r.passes = 1;
      r.spp = 16;
      r.seed = seed;
      const spm::Image img = spm::render(*s, r, spm::test::device());
      for (float v : img.rgb) mean[k] += v / img.rgb.size();
      ++k;
    }
    diff.push_back(mean[1] - mean[0]);
    level += mean[0] / 6.0;
  }
  const auto d = spm::test::mean_and_error(diff);
  EXPECT_GT(level, 0.01);
  std::printf("image mean %.5f, difference %.6f +- %.6f\n", level, d.mean, d.error);
  EXPECT_NEAR(d.mean, 0.0, 4.0 * d.error + 1e-3 * level) << "image mean " << level;
}

INSTANTIATE_TEST_SUITE_P(HeterogeneousScene, ConstantGrid, ::testing::Values("bre", "beams"));

}  // namespace
