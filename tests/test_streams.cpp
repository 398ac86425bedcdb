// Stream propagation (METHOD.md 2-4) against closed forms: free-flight
// distances, survival rates, flux conservation, collapse, energy in a sphere,
// the phase function and the respawn distributions. Fixed seeds; every bound
// is a multiple of the standard error or a KS critical value at 0.001.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <tuple>

#include <unistd.h>

#include "scene/loader.h"
#include "spm/propagate.h"
#include "spm/record_order.h"
#include "stats.h"
#include "test_support.h"

namespace {

constexpr double kPi = 3.14159265358979323846;

using spm::test::ks_critical;
using spm::test::ks_statistic;
using spm::test::mean_and_error;

glm::dvec3 v3(const float* p) { return {p[0], p[1], p[2]}; }

struct Traced {
  spm::SceneTables tables;
  spm::PhotonMaps maps;
};

spm::SceneTables tables_of(const std::string& xml) {
  return spm::flatten_scene(spm::load_scene_string(xml, "streams.xml"), 4, 4);
}

Traced trace(const std::string& xml, const spm::StreamSettings& s) {
  Traced t{tables_of(xml), {}};
  spm::GpuScene gpu(spm::test::device(), t.tables);
  t.maps = spm::propagate_streams(spm::test::device(), gpu, s);
  return t;
}

// A point light of intensity 1 at the origin in an unbounded homogeneous medium.
std::string unbounded_medium(const std::string& sigma_t, const std::string& albedo, double g = 0.0) {
  std::ostringstream x;
  x << R"(<scene version="3.0.0">
  <medium type="homogeneous" id="m"><rgb name="sigma_t" value=")"
    << sigma_t << R"("/><rgb name="albedo" value=")" << albedo << R"("/>
    <phase type="hg"><float name="g" value=")"
    << g << R"("/></phase></medium>
  <emitter type="point"><point name="position" x="0" y="0" z="0"/><rgb name="intensity" value="1"/><ref id="m"/></emitter>
</scene>)";
  return x.str();
}

// Volume records grouped by stream, in event order.
std::map<uint32_t, std::vector<SpmVolumeRecord>> by_stream(const std::vector<SpmVolumeRecord>& records) {
  std::map<uint32_t, std::vector<SpmVolumeRecord>> out;
  for (const auto& r : records) out[r.stream].push_back(r);
  return out;
}

spm::StreamSettings settings(uint32_t streams, uint32_t associated, float march_step = 0.0f) {
  spm::StreamSettings s;
  s.streams = streams;
  s.associated = associated;
  s.stream_width = 0.5f;
  s.march_step = march_step;
  s.seed = 1234;
  return s;
}

class FreeFlight : public ::testing::TestWithParam<float> {};

TEST_P(FreeFlight, DistancesFollowTheExponential) {
  const double sigma = 0.5;
  const auto t = trace(unbounded_medium("0.5", "0.5"), settings(4000, 1, GetParam()));
  std::vector<double> first;
  for (const auto& [id, recs] : by_stream(t.maps.volume)) first.push_back(glm::length(v3(recs.front().position)));
  ASSERT_EQ(first.size(), 4000u);
  const double d = ks_statistic(first, [&](double x) { return 1.0 - std::exp(-sigma * x); });
  EXPECT_LT(d, ks_critical(first.size())) << "march_step " << GetParam();
}

// Exact sampling, and steps shorter and longer than the mean free path (2).
INSTANTIATE_TEST_SUITE_P(MarchSteps, FreeFlight, ::testing::Values(0.0f, 0.3f, 5.0f));

TEST(Streams, RgbSigmaMarchesWithTheMeanAndReweights) {
  // Channel-mean sampling with density ratios: the first collision's expected
  // flux per channel is Phi in an unbounded medium. (The ratio's variance is
  // finite only while every sigma_c > mean / 2; these values respect that.)
  const auto t = trace(unbounded_medium("0.5, 0.8, 1.2", "0.5"), settings(20000, 1));
  const auto streams = by_stream(t.maps.volume);
  for (int c = 0; c < 3; ++c) {
    std::vector<double> first;
    for (const auto& [id, recs] : streams) first.push_back(recs.front().flux[c] * 20000.0);
    const auto m = mean_and_error(first);
    EXPECT_NEAR(m.mean, 4 * kPi, 4 * m.error) << "channel " << c;
  }
}

TEST(Streams, SurvivalPerMediumEventIsTheAlbedo) {
  const double albedo = 0.7;
  const uint32_t n_a = 64, n_s = 2000;
  const auto t = trace(unbounded_medium("1", "0.7"), settings(n_s, n_a));
  // Gray medium: every record's flux is n * phi with the emitted phi, so the
  // second record of a stream counts the survivors of the first event.
  const double phi = 4 * kPi / (double(n_s) * n_a);
  double survivors = 0.0;
  for (const auto& [id, recs] : by_stream(t.maps.volume)) {
    ASSERT_NEAR(recs.front().flux[0] / phi, n_a, 1e-3);
    if (recs.size() > 1) survivors += std::round(recs[1].flux[0] / phi);
  }
  const double trials = double(n_s) * n_a;
  const double p = survivors / trials;
  EXPECT_NEAR(p, albedo, 4 * std::sqrt(albedo * (1 - albedo) / trials));
}

// A closed box of reflectance 0.6 (normals inward) around a point light.
std::string diffuse_box(const std::string& reflectance) {
  return R"(<scene version="3.0.0">
  <shape type="cube"><boolean name="flip_normals" value="true"/>
    <transform name="to_world"><scale value="5"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value=")" +
         reflectance + R"("/></bsdf></shape>
  <emitter type="point"><point name="position" x="0" y="0" z="0"/><rgb name="intensity" value="1"/></emitter>
</scene>)";
}

TEST(Streams, SurvivalPerDiffuseEventIsTheMeanReflectance) {
  const uint32_t n_a = 64, n_s = 2000;
  auto s = settings(n_s, n_a);
  s.max_bounces = 2;
  const auto t = trace(diffuse_box("0.9, 0.6, 0.3"), s);
  // Records per (stream, event): the first deposit has all N_a photons, the
  // second the survivors of the first bounce (survival = mean(0.9, 0.6, 0.3)).
  std::map<uint32_t, std::map<uint32_t, int>> counts;
  for (const auto& r : t.maps.surface) ++counts[r.stream][r.depth_photon >> 16];
  double survivors = 0.0;
  for (const auto& [id, events] : counts) {
    ASSERT_EQ(events.begin()->second, int(n_a));
    if (events.size() > 1) survivors += std::next(events.begin())->second;
  }
  const double p = 0.6, trials = double(n_s) * n_a;
  EXPECT_NEAR(survivors / trials, p, 4 * std::sqrt(p * (1 - p) / trials));
}

TEST(Streams, FluxIsConservedInExpectationForRgbAlbedo) {
  // Unbounded medium: the expected flux summed over all collisions of a
  // stream is Phi / (1 - albedo) per channel, however photons are eliminated.
  // Survival is the mean albedo and survivors are reweighted by c / mean, so
  // the estimator's variance is finite only while c^2 < mean for every
  // channel; these values keep it finite so that the standard error bounds it.
  const double albedo[3] = {0.6, 0.5, 0.4};
  const uint32_t n_s = 4000;
  const auto t = trace(unbounded_medium("0.8, 1.0, 1.3", "0.6, 0.5, 0.4"), settings(n_s, 16));
  const auto streams = by_stream(t.maps.volume);
  ASSERT_EQ(streams.size(), n_s);
  for (int c = 0; c < 3; ++c) {
    std::vector<double> totals;
    for (const auto& [id, recs] : streams) {
      double sum = 0.0;
      for (const auto& r : recs) sum += r.flux[c];
      totals.push_back(sum * n_s);
    }
    const auto m = mean_and_error(totals);
    EXPECT_NEAR(m.mean, 4 * kPi / (1 - albedo[c]), 4 * m.error) << "channel " << c;
  }
}

TEST(Streams, ScatteringStreamRecordsMatchTheClosedFormMean) {
  // Unbounded medium, albedo a, N_a photons: record k + 1 exists iff a photon
  // survived k rounds, so E[records] = sum_k 1 - (1 - a^k)^N_a.
  const double a = 0.5;
  const uint32_t n_a = 8, n_s = 5000;
  auto s = settings(n_s, n_a);
  s.rr_depth = SPM_MAX_EVENTS;  // absorption alone ends the streams here
  const auto t = trace(unbounded_medium("1", "0.5"), s);
  double expected = 0.0;
  for (int k = 0; k < 200; ++k) expected += 1.0 - std::pow(1.0 - std::pow(a, k), n_a);
  std::vector<double> counts;
  for (const auto& [id, recs] : by_stream(t.maps.volume)) counts.push_back(double(recs.size()));
  ASSERT_EQ(counts.size(), n_s);
  const auto m = mean_and_error(counts);
  EXPECT_NEAR(m.mean, expected, 4 * m.error);
}

TEST(Streams, EnergyThroughAnAbsorbingMediumInABlackSphere) {
  // A point light at the centre of a black sphere of radius R filled with an
  // absorbing medium: the flux deposited on the sphere is Phi exp(-sigma R).
  const double sigma = 0.3, radius = 4.0;
  const uint32_t n_s = 20000, n_a = 4;
  std::ostringstream x;
  x << R"(<scene version="3.0.0">
  <medium type="homogeneous" id="m"><float name="sigma_t" value=")"
    << sigma << R"("/><float name="albedo" value="0"/></medium>
  <shape type="sphere"><float name="radius" value=")"
    << radius << R"("/><boolean name="flip_normals" value="true"/>
    <bsdf type="diffuse"><float name="reflectance" value="0"/></bsdf><ref name="exterior" id="m"/></shape>
  <emitter type="point"><point name="position" x="0" y="0" z="0"/><rgb name="intensity" value="1"/><ref id="m"/></emitter>
</scene>)";
  const auto t = trace(x.str(), settings(n_s, n_a));
  double flux = 0.0;
  for (const auto& r : t.maps.surface) {
    flux += r.flux[0];
    ASSERT_NEAR(glm::length(v3(r.position)), radius, 0.51);  // on the sphere, within the disk of w
  }
  const double phi = 4 * kPi, p = std::exp(-sigma * radius);
  // Each stream reaches the sphere whole or not at all: a binomial over streams.
  EXPECT_NEAR(flux / phi, p, 4 * std::sqrt(p * (1 - p) / n_s));
  // Every stream that did not reach the sphere left exactly one volume record.
  EXPECT_EQ(t.maps.volume.size() + t.maps.surface.size() / n_a, n_s);
}

TEST(Streams, SpecularCollapseKeepsTheFluxInOnePhoton) {
  // A spot light (no falloff inside its cone, so every photon carries the
  // same phi) aims at a mirror tilted 45 degrees, which reflects every stream
  // down onto a diffuse floor.
  const uint32_t n_a = 16, n_s = 2000;
  const std::string xml = R"(<scene version="3.0.0">
  <shape type="rectangle"><transform name="to_world"><scale value="100"/><rotate x="1" angle="-90"/></transform></shape>
  <shape type="rectangle"><bsdf type="conductor"/>
    <transform name="to_world"><scale value="3"/><rotate x="1" angle="45"/><translate y="5" z="-5"/></transform></shape>
  <emitter type="spot"><rgb name="intensity" value="10"/>
    <float name="cutoff_angle" value="10"/><float name="beam_width" value="10"/>
    <transform name="to_world"><lookat origin="0, 5, 5" target="0, 5, -5" up="0, 1, 0"/></transform></emitter>
</scene>)";
  auto s = settings(n_s, n_a);
  s.max_bounces = 1;
  const auto t = trace(xml, s);
  const double power = t.tables.lights[0].power;
  // Before the mirror each stream carries N_a photons of phi = power / (N_s N_a);
  // after it, n = 1 and the one photon carries the stream's whole flux.
  ASSERT_EQ(t.maps.surface.size(), n_s);
  std::map<uint32_t, int> per_stream;
  for (const auto& r : t.maps.surface) {
    ++per_stream[r.stream];
    EXPECT_TRUE(r.flags & SPM_RECORD_HAD_EVENT);
    EXPECT_EQ(r.depth_photon & 0xffffu, 0u);
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(r.flux[c], power / n_s, 1e-5 * power / n_s);
    EXPECT_NEAR(r.position[1], 0.0, 1e-3);
    // Within the beam's footprint (15 units from the spot, 10 degrees).
    EXPECT_LT(std::abs(r.position[0]), 15 * std::tan(10 * kPi / 180) + 1e-3);
  }
  EXPECT_EQ(per_stream.size(), n_s);
  // A collapsed stream has no offsets: its photon lands exactly at the hit.
  const auto tables = tables_of(xml);
  auto& dev = spm::test::device();
  spm::GpuScene gpu(dev, tables);
  s.max_bounces = 2;
  s.stream_width = 0.5f;
  spm::StreamPropagator propagator(dev, gpu, s);
  spm::PhotonMaps maps;
  propagator.emit(0, n_s);
  for (int event = 0; event < 2; ++event) {  // the mirror, then the floor
    propagator.make_room(maps);
    propagator.step();
  }
  const auto hits = dev.download<cl_float4>(propagator.state().event_pos, n_s);
  propagator.flush(maps);
  ASSERT_EQ(maps.surface.size(), n_s);
  for (const auto& r : maps.surface) {
    for (int k = 0; k < 3; ++k) ASSERT_EQ(r.position[k], hits[r.stream].s[k]) << "stream " << r.stream;
  }
}

TEST(Streams, HenyeyGreensteinMeanCosineIsG) {
  for (const double g : {0.6, -0.3}) {
    const auto t = trace(unbounded_medium("1", "0.95", g), settings(3000, 4));
    std::vector<double> cosines;
    for (const auto& [id, recs] : by_stream(t.maps.volume)) {
      for (size_t k = 1; k < recs.size(); ++k) cosines.push_back(glm::dot(v3(recs[k - 1].direction), v3(recs[k].direction)));
    }
    const auto m = mean_and_error(cosines);
    EXPECT_NEAR(m.mean, g, 4 * m.error + 1e-4) << "g = " << g;
    EXPECT_LT(m.error, 0.01);
  }
}

// One wavefront iteration whose records go to `maps`, and where each
// stream's event happened and the direction it arrived in.
struct Events {
  std::vector<cl_float4> hits, dirs;
};
Events step_and_flush(spm::StreamPropagator& propagator, spm::Device& dev, spm::PhotonMaps& maps, uint32_t n_s) {
  propagator.make_room(maps);
  propagator.step();
  Events e{dev.download<cl_float4>(propagator.state().event_pos, n_s), dev.download<cl_float4>(propagator.state().event_dir, n_s)};
  propagator.flush(maps);
  return e;
}

// The first step of n_s streams over a square floor at y = 0, `half` wide
// each way, under a point light at y = 3: the emitted flux, the events and
// the deposits.
struct FloorStep {
  spm::SceneTables tables;
  std::vector<cl_float4> phi0;
  Events events;
  spm::PhotonMaps maps;
};
FloorStep floor_step(int half, const spm::StreamSettings& s, uint32_t n_s) {
  FloorStep out;
  out.tables = tables_of(R"(<scene version="3.0.0">
  <shape type="rectangle"><transform name="to_world"><scale value=")" +
                         std::to_string(half) + R"("/><rotate x="1" angle="-90"/></transform></shape>
  <emitter type="point"><point name="position" x="0" y="3" z="0"/><rgb name="intensity" value="1"/></emitter>
</scene>)");
  auto& dev = spm::test::device();
  spm::GpuScene gpu(dev, out.tables);
  spm::StreamPropagator propagator(dev, gpu, s);
  propagator.emit(0, n_s);
  out.phi0 = dev.download<cl_float4>(propagator.state().phi, n_s);
  out.events = step_and_flush(propagator, dev, out.maps, n_s);
  return out;
}

// Squeezes a landing `off` (from the hit, in the floor y = 0) by |cos theta|
// along the in-plane direction of travel d: the radius and angle of the
// point of the stream's cross-section it came from, in units of w.
std::pair<double, double> unsqueezed(const glm::dvec3& off, const glm::dvec3& d, double width) {
  const glm::dvec3 along = glm::normalize(glm::dvec3(d.x, 0.0, d.z)), across(-along.z, 0.0, along.x);
  const double a = glm::dot(off, along) * std::abs(d.y) / width, b = glm::dot(off, across) / width;
  return {std::hypot(a, b), std::atan2(b, a)};
}

// After a medium event the survivors' offsets are uniform in the ball of
// radius w (METHOD.md 3, respawn): landed on the floor at the next event and
// squeezed back, their radial CDF is the projected ball's, 1 - (1 - r^2)^1.5,
// and their angle uniform (KS tests).
TEST(Streams, OffsetsAfterAMediumEventFillTheBall) {
  const uint32_t n_a = 32, n_s = 3000;
  auto s = settings(n_s, n_a);
  s.stream_width = 0.5f;
  const std::string xml = R"(<scene version="3.0.0">
  <medium type="homogeneous" id="fog"><float name="sigma_t" value="0.3"/><float name="albedo" value="1"/></medium>
  <sensor type="perspective"><ref id="fog"/></sensor>
  <shape type="rectangle"><transform name="to_world"><scale value="1000"/><rotate x="1" angle="-90"/></transform></shape>
  <emitter type="point"><point name="position" x="0" y="3" z="0"/><rgb name="intensity" value="1"/></emitter>
</scene>)";
  const auto tables = tables_of(xml);
  auto& dev = spm::test::device();
  spm::GpuScene gpu(dev, tables);
  spm::StreamPropagator propagator(dev, gpu, s);
  spm::PhotonMaps first, second;
  propagator.emit(0, n_s);
  propagator.make_room(first);
  propagator.step();
  propagator.flush(first);
  std::set<uint32_t> scattered;  // streams whose first event was in the fog
  for (const auto& r : first.volume) scattered.insert(r.stream);
  const Events e = step_and_flush(propagator, dev, second, n_s);
  std::vector<double> radii, angles;
  for (const auto& r : second.surface) {
    if (!scattered.count(r.stream)) continue;
    const glm::dvec3 x = v3(e.hits[r.stream].s);
    const glm::dvec3 d = v3(e.dirs[r.stream].s);
    if (std::abs(d.y) < 0.05) continue;  // grazing: the footprint runs far, float error grows
    const auto [radius, angle] = unsqueezed(v3(r.position) - x, d, s.stream_width);
    radii.push_back(radius);
    angles.push_back(angle);
  }
  ASSERT_GT(radii.size(), 5000u);
  EXPECT_LT(ks_statistic(radii, [](double r) { return 1.0 - std::pow(std::max(0.0, 1.0 - r * r), 1.5); }),
            ks_critical(radii.size()));
  EXPECT_LT(ks_statistic(angles, [](double t) { return (t + kPi) / (2 * kPi); }), ks_critical(angles.size()));
}

// METHOD.md 1: a point light's streams leave with their photons' offsets
// uniform in the disk of radius w across the direction; on the floor each
// photon lands where the line through its offset along the direction meets
// the plane, an ellipse of semi-axes w and w / |cos theta| (area pi w^2 /
// |cos theta|). Squeezed by |cos theta| along the in-plane direction of
// travel, the landings are uniform in the disk of radius w again (KS on the
// radial CDF r^2 and on the angle), every one in the plane, and the
// deposit carries the stream's whole flux.
TEST(Streams, DepositsAreTheStreamsCrossSectionOnTheSurface) {
  const uint32_t n_a = 32, n_s = 500;
  auto s = settings(n_s, n_a);
  s.stream_width = 1.5f;
  const FloorStep f = floor_step(1000, s, n_s);
  const auto& [phi0, e, maps] = std::tie(f.phi0, f.events, f.maps);
  std::vector<double> radii, angles;
  std::map<uint32_t, double> flux;
  for (const auto& r : maps.surface) {
    const glm::dvec3 x = v3(e.hits[r.stream].s);
    const glm::dvec3 d = v3(e.dirs[r.stream].s);
    const glm::dvec3 off = v3(r.position) - x;
    ASSERT_NEAR(off.y, 0.0, 1e-4 * (1.0 + glm::length(off)));  // in the tangent plane
    const auto [radius, angle] = unsqueezed(off, d, s.stream_width);
    radii.push_back(radius);
    angles.push_back(angle);
    flux[r.stream] += r.flux[0];
  }
  ASSERT_GT(radii.size(), 5000u);  // about half the streams hit the floor
  EXPECT_LT(ks_statistic(radii, [](double r) { return r * r; }), ks_critical(radii.size()));
  EXPECT_LT(ks_statistic(angles, [](double t) { return (t + kPi) / (2 * kPi); }), ks_critical(angles.size()));
  for (const auto& [id, f] : flux) ASSERT_NEAR(f, n_a * phi0[id].s[0], 1e-5 * n_a * phi0[id].s[0]) << id;
}

// An area light's photons leave with offsets in the disk of radius w in the
// light's plane; on a floor parallel to it they land in the disk of radius w
// around each hit, uniform (radial CDF r^2), whatever the direction.
TEST(Streams, AnAreaLightsDiskLandsWholeOnAParallelFloor) {
  const uint32_t n_a = 32, n_s = 400;
  auto s = settings(n_s, n_a);
  s.stream_width = 0.25f;
  const std::string xml = R"(<scene version="3.0.0">
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="90"/><translate y="2"/></transform>
    <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="1000"/><rotate x="1" angle="-90"/></transform></shape>
</scene>)";
  const auto tables = tables_of(xml);
  auto& dev = spm::test::device();
  spm::GpuScene gpu(dev, tables);
  spm::StreamPropagator propagator(dev, gpu, s);
  spm::PhotonMaps maps;
  propagator.emit(0, n_s);
  const Events e = step_and_flush(propagator, dev, maps, n_s);
  std::vector<double> radii;
  for (const auto& r : maps.surface) {
    const glm::dvec3 off = v3(r.position) - v3(e.hits[r.stream].s);
    ASSERT_NEAR(off.y, 0.0, 1e-5);
    radii.push_back(std::hypot(off.x, off.z) / s.stream_width);
  }
  ASSERT_GT(radii.size(), 5000u);
  EXPECT_LT(ks_statistic(radii, [](double r) { return r * r; }), ks_critical(radii.size()));
}

// On a rectangle the photons that would land beyond an edge are reflected
// back across it (fold_into_patch; docs/experiments/gather.md "Surface estimates that stop at
// edges"): with a stream as wide as the floor, every record still lies on
// the floor, and each stream's records keep its flux.
TEST(Streams, DepositsStayOnTheirRectangle) {
  const uint32_t n_a = 32, n_s = 1000;
  auto s = settings(n_s, n_a);
  s.stream_width = 1.5f;
  const FloorStep f = floor_step(2, s, n_s);
  ASSERT_EQ(f.tables.patches.size(), 1u);
  const auto& [phi0, e, maps] = std::tie(f.phi0, f.events, f.maps);
  std::map<uint32_t, double> flux;
  size_t near_edge = 0;
  for (const auto& r : maps.surface) {
    const glm::dvec3 p = v3(r.position);
    ASSERT_NEAR(p.y, 0.0, 1e-5);
    ASSERT_LE(std::abs(p.x), 2.0 + 1e-5) << "stream " << r.stream;
    ASSERT_LE(std::abs(p.z), 2.0 + 1e-5) << "stream " << r.stream;
    // Hits within w of an edge send photons past it before the fold.
    const glm::dvec3 x = v3(e.hits[r.stream].s);
    near_edge += std::max(std::abs(x.x), std::abs(x.z)) > 2.0 - s.stream_width;
    flux[r.stream] += r.flux[0];
  }
  ASSERT_GT(maps.surface.size(), 3000u);
  EXPECT_GT(near_edge, maps.surface.size() / 4);
  for (const auto& [id, f] : flux) ASSERT_NEAR(f, n_a * phi0[id].s[0], 1e-5 * n_a * phi0[id].s[0]) << id;
}

// The open bit of the edge of patch p that faces direction d (along u or v).
spm_uint edge_towards(const SpmPatch& p, const glm::dvec3& d) {
  const double du = glm::dot(v3(p.u), d), dv = glm::dot(v3(p.v), d);
  if (std::abs(du) > std::abs(dv)) return du > 0 ? SPM_PATCH_OPEN_U_HI : SPM_PATCH_OPEN_U_LO;
  return dv > 0 ? SPM_PATCH_OPEN_V_HI : SPM_PATCH_OPEN_V_LO;
}

// flatten_scene makes each rectangle, and each face of a cube, a patch, and
// marks the edges where another coplanar triangle goes on open: the two
// halves of a floor are not reflected at the line they share.
TEST(Streams, RectanglesAndCubeFacesArePatches) {
  const auto tables = tables_of(R"(<scene version="3.0.0">
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform></shape>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/><translate x="2"/></transform></shape>
  <shape type="cube"><transform name="to_world"><scale x="0.5" y="1" z="2"/><translate y="5"/></transform></shape>
  <shape type="cube"><transform name="to_world"><rotate y="1" angle="30"/><scale x="3"/><translate y="-9"/></transform></shape>
  <shape type="sphere"><point name="center" x="0" y="9" z="0"/></shape>
  <emitter type="point"><point name="position" x="0" y="3" z="0"/><rgb name="intensity" value="1"/></emitter>
</scene>)");
  // Two rectangles, six faces, and the sheared cube's four upright faces:
  // its top and bottom are parallelograms.
  ASSERT_EQ(tables.patches.size(), 12u);
  // The two rectangles meet at x = 1: the first is open on its +x edge,
  // the second on its -x edge, whichever way their u and v point.
  EXPECT_EQ(tables.patches[0].open, edge_towards(tables.patches[0], {1, 0, 0}));
  EXPECT_EQ(tables.patches[1].open, edge_towards(tables.patches[1], {-1, 0, 0}));
  EXPECT_FLOAT_EQ(tables.patches[1].center[0], 2.0f);
  std::set<std::pair<float, float>> halves;
  for (size_t i = 2; i < 8; ++i) {
    EXPECT_EQ(tables.patches[i].open, 0u);
    halves.insert(std::minmax(tables.patches[i].half_u, tables.patches[i].half_v));
  }
  EXPECT_EQ(halves, (std::set<std::pair<float, float>>{{0.5f, 1.0f}, {0.5f, 2.0f}, {1.0f, 2.0f}}));
  size_t on_patch = 0;
  for (const SpmPrim& p : tables.prims) {
    if (p.kind == SPM_PRIM_SPHERE || p.normals == SPM_NONE || !(p.normals & SPM_PRIM_PATCH)) continue;
    ASSERT_LT(p.normals & ~SPM_PRIM_PATCH, tables.patches.size());
    ++on_patch;
  }
  EXPECT_EQ(on_patch, 24u);
}

// The quads of an OBJ file become patches wherever they are rectangles: a
// floor of 2 x 2 quads, with and without flat vertex normals, whose edges
// inside the floor are open and whose outer ones closed, a rectangle
// shape beside a coplanar OBJ triangle (that edge open), a trapezoid and a
// quad with curved normals (no patches).
TEST(Streams, ObjQuadsArePatches) {
  const auto dir = std::filesystem::temp_directory_path() / ("spm_obj_quads_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto write = [&](const std::string& name, const std::string& text) { std::ofstream(dir / name) << text; };
  const std::string grid =
      "v -2 0 -2\nv 0 0 -2\nv 2 0 -2\nv -2 0 0\nv 0 0 0\nv 2 0 0\nv -2 0 2\nv 0 0 2\nv 2 0 2\n";
  write("floor.obj", grid + "f 1 4 5 2\nf 2 5 6 3\nf 4 7 8 5\nf 5 8 9 6\n");
  write("floor_n.obj", grid + "vn 0 1 0\nf 1//1 4//1 5//1 2//1\nf 2//1 5//1 6//1 3//1\n"
                              "f 4//1 7//1 8//1 5//1\nf 5//1 8//1 9//1 6//1\n");
  write("skirt.obj", "v 1 -5 -1\nv 3 -5 0\nv 1 -5 1\nf 1 3 2\n");
  write("trapezoid.obj", "v 0 0 0\nv 4 0 0\nv 3 0 1\nv 1 0 1\nf 1 4 3 2\n");
  write("curved.obj", "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nvn 0 1 0\nvn 0.3 0.95 0\nf 1//1 4//2 3//2 2//1\n");
  const std::string light =
      R"(<emitter type="point"><point name="position" x="0" y="3" z="0"/><rgb name="intensity" value="1"/></emitter>)";
  const auto load = [&](const std::string& body) {
    const std::string xml = R"(<scene version="3.0.0">)" + body + light + "</scene>";
    return spm::flatten_scene(spm::load_scene_string(xml, (dir / "inline.xml").string()), 4, 4);
  };
  const auto obj = [](const std::string& file) {
    return R"(<shape type="obj"><string name="filename" value=")" + file + R"("/></shape>)";
  };
  for (const std::string file : {"floor.obj", "floor_n.obj"}) {
    SCOPED_TRACE(file);
    const auto tables = load(obj(file));
    ASSERT_EQ(tables.patches.size(), 4u);
    for (const SpmPatch& p : tables.patches) {
      EXPECT_FLOAT_EQ(p.half_u, 1.0f);
      EXPECT_FLOAT_EQ(p.half_v, 1.0f);
      // Each quad of the 2 x 2 floor is continued across its two edges
      // that lie inside the floor, one along each direction.
      const glm::dvec3 c = v3(p.center);
      const spm_uint expected = edge_towards(p, {-c.x, 0, 0}) | edge_towards(p, {0, 0, -c.z});
      EXPECT_EQ(p.open, expected);
    }
    // Every triangle is on a patch, so none keeps its normals' index.
    for (const SpmPrim& p : tables.prims) EXPECT_TRUE(p.normals != SPM_NONE && (p.normals & SPM_PRIM_PATCH));
  }
  {
    // A 2 x 2 rectangle at y = -5 around x = 0; the triangle continues it
    // beyond x = +1, at the edge's midpoint.
    const auto tables = load(R"(<shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/>)"
                             R"(<translate y="-5"/></transform></shape>)" +
                             obj("skirt.obj"));
    ASSERT_EQ(tables.patches.size(), 1u);
    EXPECT_EQ(tables.patches[0].open, edge_towards(tables.patches[0], {1, 0, 0}));
  }
  EXPECT_TRUE(load(obj("trapezoid.obj")).patches.empty());
  const auto curved = load(obj("curved.obj"));
  EXPECT_TRUE(curved.patches.empty());
  for (const SpmPrim& p : curved.prims) EXPECT_LT(p.normals, curved.normals.size());
  std::filesystem::remove_all(dir);
}

}  // namespace

namespace {

// Byte-for-byte equality; memcmp must not see the null data() of an empty map.
template <class T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// Batches and flushes change only when records are downloaded, never what
// they are: the sorted maps are bit-identical, and the counters agree with them.
void expect_same_maps_in_batches(const std::string& xml, uint32_t associated, uint32_t min_flushes) {
  auto s = settings(3000, associated);
  s.stream_width = 2.5f;
  const auto whole = trace(xml, s);
  s.memory_budget = 200 * 1024;  // a few hundred streams per batch
  const auto split = trace(xml, s);
  EXPECT_EQ(whole.maps.stats.batches, 1u);
  EXPECT_GT(split.maps.stats.batches, 3u);
  EXPECT_GE(split.maps.stats.flushes, min_flushes);
  ASSERT_EQ(whole.maps.volume.size(), split.maps.volume.size());
  ASSERT_EQ(whole.maps.surface.size(), split.maps.surface.size());
  EXPECT_TRUE(same_bytes(whole.maps.volume, split.maps.volume));
  EXPECT_TRUE(same_bytes(whole.maps.surface, split.maps.surface));
  EXPECT_EQ(split.maps.stats.counters[SPM_COUNT_VOLUME], split.maps.volume.size());
  EXPECT_EQ(split.maps.stats.counters[SPM_COUNT_SURFACE], split.maps.surface.size());
  EXPECT_EQ(split.maps.stats.counters[SPM_COUNT_EV_MEDIUM], split.maps.volume.size());
}

TEST(Streams, SmallMemoryBudgetGivesTheSameMapsInMoreBatches) {
  expect_same_maps_in_batches(spm::test::read_file(SPM_SCENES_DIR "/cornell_fog.xml"), 20, 0);
}

TEST(Streams, FullMapBuffersAreFlushedNotDropped) {
  // In a closed bright box every event deposits: the surface buffer (room for
  // one iteration) fills within a batch and must be downloaded mid-batch.
  expect_same_maps_in_batches(diffuse_box("0.9"), 20, 1);
}

// The order the maps are put in (host/spm/record_order.h) rests on the
// kernels appending each stream's records in (event, photon) order: here the
// records come back as the device appended them, across mid-batch flushes,
// and grouping them by stream alone must give strictly increasing keys, the
// order a full sort by (stream, event, photon) gives.
TEST(Streams, DeviceAppendsEachStreamsRecordsInOrder) {
  const Traced t{tables_of(diffuse_box("0.9")), {}};
  spm::GpuScene gpu(spm::test::device(), t.tables);
  const auto s = settings(3000, 20);
  spm::StreamPropagator propagator(spm::test::device(), gpu, s);
  ASSERT_GE(propagator.batch_capacity(), s.streams);
  spm::PhotonMaps raw;
  propagator.run_batch(0, s.streams, raw);
  EXPECT_GE(raw.stats.flushes, 1u) << "the test needs a mid-batch flush";
  const auto volume_key = [](const SpmVolumeRecord& r) { return uint64_t(r.stream) << 32 | r.depth; };
  const auto surface_key = [](const SpmSurfaceRecord& r) { return uint64_t(r.stream) << 32 | r.depth_photon; };
  auto volume = raw.volume;
  auto surface = raw.surface;
  ASSERT_GT(surface.size(), 10000u);
  ASSERT_FALSE(std::is_sorted(surface.begin(), surface.end(),
                              [&](const auto& a, const auto& b) { return surface_key(a) < surface_key(b); }))
      << "the device's order should be scrambled by its atomics";
  spm::order_by_stream(volume, 0, s.streams);
  spm::order_by_stream(surface, 0, s.streams);
  for (size_t i = 1; i < volume.size(); ++i) ASSERT_LT(volume_key(volume[i - 1]), volume_key(volume[i])) << i;
  for (size_t i = 1; i < surface.size(); ++i) ASSERT_LT(surface_key(surface[i - 1]), surface_key(surface[i])) << i;
  // And propagate() gives those maps.
  const auto whole = propagator.propagate(0, s.stream_width);
  EXPECT_TRUE(same_bytes(whole.volume, volume));
  EXPECT_TRUE(same_bytes(whole.surface, surface));
}

TEST(RecordOrder, GroupsByStreamStably) {
  struct Rec {
    uint32_t stream, seq;
  };
  std::mt19937 rng(11);
  std::vector<Rec> recs(5000);
  for (uint32_t i = 0; i < recs.size(); ++i) recs[i] = {100 + uint32_t(rng() % 300), i};
  auto want = recs;
  std::stable_sort(want.begin(), want.end(), [](const Rec& a, const Rec& b) { return a.stream < b.stream; });
  spm::order_by_stream(recs, 100, 300);
  ASSERT_EQ(recs.size(), want.size());
  for (size_t i = 0; i < recs.size(); ++i) {
    ASSERT_EQ(recs[i].stream, want[i].stream) << i;
    ASSERT_EQ(recs[i].seq, want[i].seq) << i;
  }
  std::vector<Rec> outside{{99, 0}};
  EXPECT_THROW(spm::order_by_stream(outside, 100, 300), spm::RuntimeError);
  std::vector<Rec> none;
  spm::order_by_stream(none, 0, 0);
  EXPECT_TRUE(none.empty());
}

}  // namespace
