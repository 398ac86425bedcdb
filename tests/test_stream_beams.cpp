// Stream beams (METHOD.md 11): the beams march writes against the stream's
// own records, the capsule grid's estimate against a brute-force sum over
// every beam, and one beam against the closed form of its in-scattering.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <sstream>

#include "render/render.h"
#include "scene/loader.h"
#include "spm/map_grids.h"
#include "spm/propagate.h"
#include "spm/record_grid.h"
#include "map_table.h"
#include "test_support.h"

namespace {

constexpr double kPi = 3.14159265358979323846;
using glm::dvec3;

dvec3 v3(const float* p) { return {p[0], p[1], p[2]}; }

double kernel_1d(int kernel, double d2, double r) { return kernel == 1 ? 0.75 / r * (1.0 - d2 / (r * r)) : 0.5 / r; }

double phase_hg(double cos_theta, double g) {
  const double denom = 1 + g * g - 2 * g * cos_theta;
  return (1 - g * g) / (4 * kPi * denom * std::sqrt(denom));
}

// The sum of METHOD.md 11 over every beam, in double, as bounds: `lo` holds
// the terms clearly inside every limit, `hi` adds those within `margin` of
// one (a parameter at an end of the ray segment or the beam, a distance at
// the radius, a direction at the parallel cut-off), where float rounding in
// the kernel may fall either way.
struct Bounds {
  dvec3 lo{0.0}, hi{0.0};
};

Bounds beam_reference(const std::vector<SpmBeam>& beams, const SpmMedium& m, int medium, dvec3 o, dvec3 d, double t0,
                      double t1, double r, int kernel, uint32_t min_depth, uint32_t max_depth) {
  Bounds out;
  const double margin = 1e-3;
  const dvec3 sigma = v3(m.sigma_t), albedo = v3(m.albedo);
  const double mean = (sigma.x + sigma.y + sigma.z) / 3.0;
  const double g = m.phase == SPM_PHASE_HG ? m.g : 0.0;
  for (const SpmBeam& b : beams) {
    if (b.medium != medium || b.depth > max_depth || b.depth < min_depth) continue;
    const dvec3 e = v3(b.direction), w0 = o - v3(b.origin);
    const double a = glm::dot(d, e), sin2 = 1.0 - a * a;
    if (sin2 < 1e-6 * (1.0 - margin)) continue;
    const double t = (a * glm::dot(e, w0) - glm::dot(d, w0)) / sin2;
    const double s = (glm::dot(e, w0) - a * glm::dot(d, w0)) / sin2;
    const double slack = margin / std::sqrt(sin2);
    if (t < t0 - slack || t > t1 + slack || s < -slack || s > b.length + slack) continue;
    const dvec3 off = (o + t * d) - (v3(b.origin) + s * e);
    const double d2 = glm::dot(off, off);
    if (d2 >= r * r * (1.0 + margin)) continue;
    dvec3 term;
    for (int c = 0; c < 3; ++c) {
      term[c] = kernel_1d(kernel, std::min(d2, r * r), r) / std::sqrt(sin2) * sigma[c] * albedo[c] *
                std::exp(-sigma[c] * (t - t0) - (sigma[c] - mean) * s) * phase_hg(-a, g) * b.flux[c];
    }
    const bool edge = sin2 < 1e-6 * (1.0 + margin) || t < t0 + slack || t > t1 - slack || s < slack ||
                      s > b.length - slack || d2 > r * r * (1.0 - margin);
    out.hi += term;
    if (!edge) out.lo += term;
  }
  return out;
}

// Runs spm_volume_test over the rays (origin xyz + t0, direction xyz
// + t1) through a table of the beams' capsule grid alone; per ray the
// estimate (xyz) and the beams examined (w).
std::vector<cl_float4> estimate(const std::vector<SpmBeam>& beams, const std::vector<SpmMedium>& media,
                                const std::vector<cl_float4>& origins, const std::vector<cl_float4>& dirs, float radius,
                                int kernel, uint32_t min_depth, uint32_t max_depth) {
  auto& dev = spm::test::device();
  const cl::Buffer mb = dev.upload("media", media);
  const cl::Buffer ob = dev.upload("origins", origins), db = dev.upload("directions", dirs);
  spm::test::VolumeTestSettings t;
  t.kernel = kernel;
  t.estimator = SPM_ESTIMATOR_BEAMS;
  t.min_depth = min_depth;
  t.max_depth = max_depth;
  return spm::test::volume_test(spm::test::capsule_table(beams, radius), mb, ob, db, int(origins.size()), t);
}

class StreamBeamEstimate : public ::testing::TestWithParam<std::tuple<int, uint32_t>> {};

TEST_P(StreamBeamEstimate, EqualsTheBruteForceSum) {
  const auto [kernel, max_depth] = GetParam();
  const uint32_t min_depth = max_depth == SPM_NONE ? 0u : 2u;
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> pos(-20.0f, 20.0f), unit(-1.0f, 1.0f), len(0.0f, 30.0f);
  std::vector<SpmBeam> beams(3000);
  for (SpmBeam& b : beams) {
    const glm::vec3 d = glm::normalize(glm::vec3(unit(rng), unit(rng), unit(rng)) + glm::vec3(1e-3f));
    for (int c = 0; c < 3; ++c) {
      b.origin[c] = pos(rng);
      b.direction[c] = d[c];
      b.flux[c] = 0.5f + std::abs(unit(rng));
    }
    // Every tenth beam along an axis, on cell faces of the grid too.
    if (&b - beams.data() < 300) {
      b.direction[0] = 1.0f;
      b.direction[1] = b.direction[2] = 0.0f;
    }
    b.length = len(rng);
    b.medium = rng() % 8 == 0 ? 1 : 0;  // beams of another medium must be ignored
    b.depth = 1 + rng() % 6;
  }
  const float radius = 0.8f;  // small against the box: long rays and beams cross many cells
  const int n = 400;
  std::vector<cl_float4> origins(n), dirs(n);
  for (int i = 0; i < n; ++i) {
    const glm::vec3 o(pos(rng), pos(rng), pos(rng));
    glm::vec3 d = glm::normalize(glm::vec3(unit(rng), unit(rng), unit(rng)) + glm::vec3(1e-3f));
    if (i % 10 == 0) d = glm::vec3(0.0f, 0.0f, 1.0f);
    const float t0 = 0.25f * std::abs(pos(rng)), t1 = t0 + 5.0f + 2.0f * std::abs(pos(rng));
    origins[i] = {{o.x, o.y, o.z, t0}};
    dirs[i] = {{d.x, d.y, d.z, t1}};
  }
  const SpmMedium m = spm::test::coloured_medium();
  const auto got = estimate(beams, {m, m}, origins, dirs, radius, kernel, min_depth, max_depth);
  int nonzero = 0;
  for (int i = 0; i < n; ++i) {
    const dvec3 o(origins[i].s[0], origins[i].s[1], origins[i].s[2]);
    const dvec3 d(dirs[i].s[0], dirs[i].s[1], dirs[i].s[2]);
    const Bounds ref = beam_reference(beams, m, 0, o, d, origins[i].s[3], dirs[i].s[3], radius, kernel, min_depth, max_depth);
    if (ref.lo.x > 0) ++nonzero;
    for (int c = 0; c < 3; ++c) {
      // Float rounding stays under 1e-4 of the sum; a beam counted twice or
      // missed changes it by a whole term.
      const double tol = 1e-4 * ref.hi[c] + 1e-9;
      EXPECT_GE(got[i].s[c], ref.lo[c] - tol) << "ray " << i << " channel " << c;
      EXPECT_LE(got[i].s[c], ref.hi[c] + tol) << "ray " << i << " channel " << c;
    }
  }
  EXPECT_GT(nonzero, n / 2);
}

INSTANTIATE_TEST_SUITE_P(KernelsAndDepths, StreamBeamEstimate,
                         ::testing::Combine(::testing::Values(0, 1), ::testing::Values(SPM_NONE, 3u)));

// One beam of flux phi along x through a grey isotropic medium, seen by rays
// in the plane z = 0 ... at angle theta to it, each passing it at offset h
// along y. A thin beam's in-scattered radiance is a line in the image: its
// integral over the offsets is sigma_s phi p T(t) / sin(theta) with
// p = 1/(4 pi) and T(t) the transmittance from the ray's start to the
// crossing (the 1D kernel spreads it over |h| < r and keeps its integral).
TEST(StreamBeamEstimate, OneBeamsIntegralOverOffsetsIsTheClosedForm) {
  SpmMedium m{};
  for (int c = 0; c < 3; ++c) {
    m.sigma_t[c] = 0.05f;
    m.albedo[c] = 0.6f;
  }
  m.phase = SPM_PHASE_ISOTROPIC;
  m.sigma_t_grid = m.albedo_grid = -1;  // homogeneous
  SpmBeam b{};
  b.origin[0] = -50.0f;
  b.direction[0] = 1.0f;
  b.length = 100.0f;
  for (int c = 0; c < 3; ++c) b.flux[c] = 2.0f;
  b.depth = 2;
  const float radius = 0.5f, dist = 30.0f;
  for (const double theta : {kPi / 2, kPi / 3}) {
    for (const int kernel : {0, 1}) {
      // Rays from `dist` before the crossing at x = 0, offsets h across
      // [-2r, 2r] by the midpoint rule.
      const int n = 2000;
      const double dh = 4.0 * radius / n;
      std::vector<cl_float4> origins(n), dirs(n);
      const dvec3 d(std::cos(theta), 0.0, std::sin(theta));
      for (int i = 0; i < n; ++i) {
        const double h = -2.0 * radius + (i + 0.5) * dh;
        const dvec3 o = dvec3(0.0, h, 0.0) - double(dist) * d;
        origins[i] = {{float(o.x), float(o.y), float(o.z), 0.0f}};
        dirs[i] = {{float(d.x), float(d.y), float(d.z), 2.0f * dist}};
      }
      const auto got = estimate({b}, {m}, origins, dirs, radius, kernel, 0, SPM_NONE);
      double integral = 0.0;
      for (int i = 0; i < n; ++i) {
        const double h = -2.0 * radius + (i + 0.5) * dh;
        const double expected = std::abs(h) < radius ? kernel_1d(kernel, h * h, radius) / std::sin(theta) * 0.05 *
                                                            0.6 * std::exp(-0.05 * dist) / (4 * kPi) * 2.0
                                                      : 0.0;
        EXPECT_NEAR(got[i].s[1], expected, 1e-4 * expected + 1e-9) << "offset " << h << " theta " << theta;
        integral += got[i].s[1] * dh;
      }
      const double closed = 0.05 * 0.6 * 2.0 * std::exp(-0.05 * dist) / (4 * kPi) / std::sin(theta);
      // The midpoint rule on [-r, r] is exact for the uniform kernel and
      // within (dh / r)^2 for Epanechnikov's parabola.
      EXPECT_NEAR(integral, closed, 1e-3 * closed) << "theta " << theta << " kernel " << kernel;
    }
  }
}

// Where the beam's medium is coloured, its flux at distance s along it is
// weighed by exp(-(sigma_t - mean) s): the march sampled the flight with
// the channels' mean.
TEST(StreamBeamEstimate, ColouredMediumWeighsTheBeamByTheTransmittanceRatio) {
  const SpmMedium m = spm::test::coloured_medium();
  SpmBeam b{};
  b.direction[0] = 1.0f;
  b.length = 40.0f;
  for (int c = 0; c < 3; ++c) b.flux[c] = 1.0f;
  b.depth = 2;
  const double s = 25.0, dist = 10.0;
  const std::vector<cl_float4> o{{{float(s), 0.1f, float(-dist), 0.0f}}}, d{{{0.0f, 0.0f, 1.0f, float(2 * dist)}}};
  const float radius = 0.5f;
  const auto got = estimate({b}, {m}, o, d, radius, 0, 0, SPM_NONE);
  const double mean = (0.02 + 0.05 + 0.1) / 3.0;
  for (int c = 0; c < 3; ++c) {
    const double sigma = m.sigma_t[c];
    // phase_hg(cos 90 degrees) with g = 0.4.
    const double expected = 0.5 / radius * sigma * m.albedo[c] * std::exp(-sigma * dist - (sigma - mean) * s) *
                            phase_hg(0.0, 0.4);
    EXPECT_NEAR(got[0].s[c], expected, 1e-4 * expected) << "channel " << c;
  }
}

// Every beam list a cell it overlaps: a point within r of a beam lies in a
// cell that lists it, for random segments and points.
TEST(CapsuleGrid, EveryPointWithinTheRadiusFindsTheBeamInItsCell) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> pos(-10.0f, 10.0f), unit(-1.0f, 1.0f);
  std::vector<glm::vec3> a(200), b(200);
  for (size_t i = 0; i < a.size(); ++i) {
    a[i] = {pos(rng), pos(rng), pos(rng)};
    b[i] = i % 5 == 0 ? a[i] + glm::vec3(7.0f, 0.0f, 0.0f) : glm::vec3(pos(rng), pos(rng), pos(rng));
  }
  const float r = 0.7f;
  for (const float cell : {0.3f, 1.05f, 4.0f}) {
    const spm::RecordGrid g = spm::build_capsule_grid(a, b, r, cell);
    int checked = 0;
    for (size_t i = 0; i < a.size(); ++i) {
      for (int k = 0; k < 50; ++k) {
        // A point at distance < r from a random point of the segment.
        const float u = std::abs(unit(rng));
        glm::vec3 off(unit(rng), unit(rng), unit(rng));
        if (glm::length(off) < 1e-3f) continue;
        off = glm::normalize(off) * (r * 0.999f * std::abs(unit(rng)));
        const glm::vec3 p = a[i] + u * (b[i] - a[i]) + off;
        const size_t c = spm::grid_cell_index(g.info, spm::grid_cell_of(g.info, p));
        bool listed = false;
        for (uint32_t j = g.cell_start[c]; j < g.cell_start[c + 1]; ++j) listed |= g.items[j] == i;
        EXPECT_TRUE(listed) << "segment " << i << " cell edge " << cell;
        ++checked;
      }
    }
    EXPECT_GT(checked, 9000);
    // Lists hold increasing indices, each at most once.
    for (size_t c = 0; c + 1 < g.cell_start.size(); ++c) {
      for (uint32_t j = g.cell_start[c] + 1; j < g.cell_start[c + 1]; ++j) ASSERT_LT(g.items[j - 1], g.items[j]);
    }
  }
}

// The beams march writes: for every stream, the beam of depth k ends where
// its record of depth k lies (the medium event it flew to) and carries the
// flux the record does (a grey medium: no reweighting), scaled by
// N_s / beam_streams; streams past beam_streams write none. The records
// come from the same streams propagated without beams (beams draw no random
// numbers), since a propagation with beams writes no records: the gather
// would not read them.
TEST(StreamBeams, EachBeamEndsAtTheStreamsNextEvent) {
  const std::string xml = R"(<scene version="3.0.0">
  <medium type="homogeneous" id="m"><float name="sigma_t" value="0.2"/><float name="albedo" value="0.8"/>
    <phase type="isotropic"/></medium>
  <emitter type="point"><point name="position" x="0" y="0" z="0"/><rgb name="intensity" value="1"/><ref id="m"/></emitter>
</scene>)";
  const spm::SceneTables tables = spm::flatten_scene(spm::load_scene_string(xml, "beams.xml"), 4, 4);
  spm::GpuScene gpu(spm::test::device(), tables);
  spm::StreamSettings s;
  s.streams = 2000;
  s.associated = 3;
  s.stream_width = 0.5f;
  s.seed = 5;
  s.beams = true;
  s.beam_streams = 500;
  const spm::PhotonMaps maps = spm::propagate_streams(spm::test::device(), gpu, s);
  ASSERT_GT(maps.beams.size(), 1000u);
  EXPECT_EQ(maps.stats.counters[SPM_COUNT_BEAMS], maps.beams.size());
  EXPECT_TRUE(maps.volume.empty());
  s.beams = false;
  const spm::PhotonMaps points = spm::propagate_streams(spm::test::device(), gpu, s);
  EXPECT_TRUE(points.beams.empty());
  std::map<std::pair<uint32_t, uint32_t>, const SpmVolumeRecord*> records;
  for (const SpmVolumeRecord& r : points.volume) records[{r.stream, r.depth}] = &r;
  size_t matched = 0;
  for (const SpmBeam& b : maps.beams) {
    ASSERT_LT(b.stream, s.beam_streams);
    const auto it = records.find({b.stream, b.depth});
    // A stream's last flight ends at the record of the event that ended it;
    // every flight in an unbounded medium ends at a medium event.
    ASSERT_NE(it, records.end()) << "stream " << b.stream << " depth " << b.depth;
    const SpmVolumeRecord& r = *it->second;
    const dvec3 end = v3(b.origin) + double(b.length) * v3(b.direction);
    EXPECT_LT(glm::length(end - v3(r.position)), 1e-4 * (1.0 + glm::length(v3(r.position))));
    EXPECT_LT(glm::length(v3(b.direction) - v3(r.direction)), 1e-6);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(b.flux[c], 4.0f * r.flux[c], 1e-5f * b.flux[c]);
    ++matched;
  }
  // Every record of the streams that write beams has its beam.
  size_t owned = 0;
  for (const SpmVolumeRecord& r : points.volume) owned += r.stream < s.beam_streams;
  EXPECT_EQ(matched, owned);
}

}  // namespace
