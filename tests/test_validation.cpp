// Validation against Mitsuba 3 (issue 7): spm's bre renders of the project's
// scenes against the committed volpath references in tests/data/reference/
// (made by tools/reference.py; each EXR's SHA-256 is recorded in the JSON
// beside it and checked here; the test never regenerates them).
//
// For each scene: N passes have a relMSE (eps 1e-2) against the reference
// below a threshold set from measurements (each test's comment gives the
// measured values and the margin), and 4N passes have a lower
// relMSE than N passes (consistency: the progressive radius shrinks, the
// error falls). The whole file runs in about a minute on 2 cores with PoCL.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "film/image_io.h"
#include "render/render.h"
#include "scene/loader.h"
#include "test_support.h"

namespace {

// SHA-256 of a file by coreutils' sha256sum, rather than a hand-written digest.
std::string sha256_of(const std::string& path) {
  std::string out;
  if (FILE* p = ::popen(("sha256sum '" + path + "'").c_str(), "r")) {
    char buf[65] = {};
    if (std::fread(buf, 1, 64, p) == 64) out = buf;
    ::pclose(p);
  }
  return out;
}

// ---- references -----------------------------------------------------------

struct Reference {
  spm::Image image;
  std::map<std::string, std::string> defines;  // the -D overrides it was made with
};

// Reads tests/data/reference/NAME.exr after checking its SHA-256 against the
// one NAME.json records.
Reference load_reference(const std::string& name) {
  const std::string dir = SPM_TEST_DATA_DIR "/reference/";
  const std::string exr = dir + name + ".exr";
  std::ifstream js(dir + name + ".json");
  if (!js) ADD_FAILURE() << "missing " << dir << name << ".json";
  const nlohmann::json meta = nlohmann::json::parse(js);
  EXPECT_EQ(sha256_of(exr), meta.at("sha256").get<std::string>())
      << exr << " does not match the SHA-256 recorded in " << name << ".json: it was changed or damaged";
  Reference ref;
  ref.image = spm::read_exr(exr);
  for (const auto& [k, v] : meta.at("request").at("defines").items()) ref.defines[k] = v.get<std::string>();
  return ref;
}

// Pixels a comparison covers: all, or those outside an image-space rectangle.
struct Region {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // excluded [x0, x1) x [y0, y1); empty: none
  bool inside(int x, int y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
};

// relMSE (eps 1e-2) over the pixels outside `skip` (tools/compare.py's).
double rel_mse(const spm::Image& a, const spm::Image& ref, const Region& skip = {}) {
  double sum = 0.0;
  size_t n = 0;
  for (int y = 0; y < a.height; ++y) {
    for (int x = 0; x < a.width; ++x) {
      if (skip.inside(x, y)) continue;
      for (int c = 0; c < 3; ++c) {
        const size_t i = (size_t(y) * a.width + x) * 3 + c;
        const double d = double(a.rgb[i]) - ref.rgb[i];
        sum += d * d / (double(ref.rgb[i]) * ref.rgb[i] + 1e-2);
        ++n;
      }
    }
  }
  return sum / n;
}

// Ratio of the images' means over the pixels inside (`in_region`) or
// outside `r`.
double mean_ratio(const spm::Image& a, const spm::Image& ref, const Region& r = {}, bool in_region = false) {
  double sa = 0.0, sr = 0.0;
  for (int y = 0; y < a.height; ++y) {
    for (int x = 0; x < a.width; ++x) {
      if (r.inside(x, y) != in_region) continue;
      for (int c = 0; c < 3; ++c) {
        const size_t i = (size_t(y) * a.width + x) * 3 + c;
        sa += a.rgb[i];
        sr += ref.rgb[i];
      }
    }
  }
  return sa / sr;
}

struct Case {
  const char* scene;
  int passes;        // N
  double threshold;  // relMSE bound for N passes (the test's comment says how it was set)
  Region skip;       // pixels the reference cannot be trusted in (none: compare all)
  const char* estimator = nullptr;  // the scene's own when null
  bool final_gather = true;         // the default
  float radius = 0.0f;              // > 0: this radius, not the scene's or the derived one
  // Seeds of the N-pass renders; the bound applies to the median of their
  // relMSEs, which a rare firefly in one of them does not move. The first
  // seed also renders the 4N passes.
  std::vector<uint32_t> seeds = {7};
};

struct Renders {
  spm::Image n, n4, ref;
};

Renders validate(const Case& c) {
  const Reference ref = load_reference(c.scene);
  auto scene = spm::load_scene(std::string(SPM_SCENES_DIR "/") + c.scene + ".xml", ref.defines);
  EXPECT_EQ(scene.camera.width, ref.image.width);
  EXPECT_EQ(scene.camera.height, ref.image.height);
  // volpath's paths end only by Russian roulette (max_depth 64); spm's
  // streams end after max_bounces diffuse bounces (the scenes say 4, which
  // loses about 1% of cornell_fog's light), so the comparison lifts the cap.
  scene.integrator.max_bounces = 32;
  if (c.estimator) scene.integrator.estimator = c.estimator;
  scene.integrator.final_gather = c.final_gather;
  if (c.radius > 0.0f) scene.integrator.radius = c.radius;
  auto render = [&](int passes, uint32_t seed) {
    spm::RenderSettings s;
    s.passes = passes;
    s.seed = seed;
    return spm::render(scene, s, spm::test::device());
  };
  Renders r{render(c.passes, c.seeds[0]), render(4 * c.passes, c.seeds[0]), ref.image};
  std::vector<double> errors{rel_mse(r.n, r.ref, c.skip)};
  for (size_t i = 1; i < c.seeds.size(); ++i) errors.push_back(rel_mse(render(c.passes, c.seeds[i]), r.ref, c.skip));
  std::sort(errors.begin(), errors.end());
  const double e = errors[errors.size() / 2], e4 = rel_mse(r.n4, r.ref, c.skip);
  ::testing::Test::RecordProperty("relmse_N", std::to_string(e));
  ::testing::Test::RecordProperty("relmse_4N", std::to_string(e4));
  EXPECT_LT(e, c.threshold) << c.scene << ": relMSE after " << c.passes << " passes " << e << " (the median of "
                            << errors.size() << " seeds; seed " << c.seeds[0] << "'s mean ratio "
                            << mean_ratio(r.n, r.ref, c.skip) << ")";
  EXPECT_LT(e4, e) << c.scene << ": relMSE after " << 4 * c.passes << " passes " << e4 << " is not below " << e
                   << " after " << c.passes;
  const std::string which = errors.size() > 1 ? "the median of " + std::to_string(errors.size()) + " seeds; " : "";
  std::printf("%s: relMSE %.5f after %d passes (%sseed %u's mean ratio %.4f), %.5f after %d (mean ratio %.4f)\n",
              c.scene, e, c.passes, which.c_str(), c.seeds[0], mean_ratio(r.n, r.ref, c.skip), e4, 4 * c.passes,
              mean_ratio(r.n4, r.ref, c.skip));
  return r;
}

// After the 4N passes of validate: relMSE below `bound`, and the image's
// mean within `tolerance` of volpath's (outside `skip` for both).
void expect_converged(const Renders& r, double bound, double tolerance, const Region& skip = {}) {
  EXPECT_LT(rel_mse(r.n4, r.ref, skip), bound) << "relMSE after 4N passes";
  const double ratio = mean_ratio(r.n4, r.ref, skip);
  EXPECT_NEAR(ratio, 1.0, tolerance) << "spm/volpath after 4N passes: " << ratio;
}

// Measured (64x64, the file's 10000 streams x 100 and 61 samples per pass,
// max_bounces 32), with the final gather (the default): relMSE after 2
// passes 0.00208 (seed 7, the one used here; seeds 11 and 13: 0.00203,
// 0.00200), after 8 passes 0.00067 (0.00066, 0.00067). The bound 0.0037 is
// 1.75x the worst seed. Without it, reading the maps at the camera's vertex
// (METHOD.md 5 as written): 0.0101 (0.0111, 0.0110), after 8 passes 0.0041
// (0.0040, 0.0044), bound 0.0194. A missing factor (e.g. the albedo or the phase
// function's 1/(4 pi) in the beam estimate) moves the mean by tens of
// percent and the relMSE far past both: the paper estimator stays at 0.033
// even after 64 passes.
TEST(Validation, CornellFogConvergesToMitsuba) { validate({"cornell_fog", 2, 0.0037, {}}); }

TEST(Validation, CornellFogWithoutFinalGatherConvergesToMitsuba) {
  validate({"cornell_fog", 2, 0.0194, {}, nullptr, false});
}

// Measured (with the final gather): 0.00147 after 2 passes (seed 7; seeds 11
// and 13: 0.00135, 0.00141), 0.00040 after 8 (0.00043, 0.00047); the bound
// 0.0026 is 1.75x the worst seed.
TEST(Validation, CornellFogWithStreamBeamsConvergesToMitsuba) {
  validate({"cornell_fog", 2, 0.0026, {}, "beams"});
}

// Mitsuba's volpath cannot sample the caustic: the light comes from a delta
// spot light and its first vertex is the glass sphere, so no next-event
// connection reaches the light through the glass and no BSDF-sampled path
// hits a delta light. The volpath reference lacks the focused cone under the
// sphere and the spot on the floor (spm: about 2x the light in all). The
// comparison skips that part of the image, a rectangle around the sphere,
// the cone and the floor spot, and checks that spm does show the caustic
// there.
TEST(Validation, VolumetricCausticConvergesToMitsubaOutsideTheCaustic) {
  // Measured outside the rectangle: relMSE 0.00036 after 2 passes (seeds 7,
  // 11, 13 alike), 0.00030 after 8; small because the image is dark next to
  // eps = 1e-2 (mean 0.004). Bound: 0.0006, 1.7x. Mean ratio spm/volpath
  // there 1.33: the light that went through the sphere (most of the spot's
  // power) and then lit the fog and walls is missing from volpath too. With
  // the sphere removed from the scene both renderers are complete and agree
  // (mean ratio 0.9994 after 8 passes), so the difference is volpath's.
  const Region caustic{16, 28, 48, 56};
  const Renders r = validate({"volumetric_caustic", 2, 0.0006, caustic});
  const double inside = mean_ratio(r.n4, r.ref, caustic, true);
  EXPECT_GT(inside, 1.5) << "spm/volpath in the caustic's region: " << inside
                         << "; volpath cannot render this caustic, so a ratio near 1 means spm lost it too";
  std::printf("volumetric_caustic: spm/volpath mean ratio in the caustic's region %.3f\n", inside);
}

// A volumetric caustic that volpath can render (issue 14, item 5): the glass
// sphere in fog lit by a small spherical area light instead of a spot.
// The light's image seen through the sphere covers 0.04% of a few pixels;
// before emission chains (spm_gather.cl) one camera sample in a few hundred
// found it and made a firefly, so the bound applies to the median of seeds
// 7, 11, 13, 17, 19, which a rare firefly in one of them does not move.
// Measured against the 4,194,304-sample reference (64x64, the file's
// settings, max_bounces 32; issue 14, seventh session), relMSE after 2
// passes over seeds 7, 11, 13, 17, 19, 23, 29, 31: 0.00086, 0.00092,
// 0.00081, 0.00106, 0.00100, 0.00084, 0.00102, 0.00075 (the worst two
// pixels at most 14% of a seed's error: no fireflies left), median of the
// five 0.00092; the bound 0.0019 is 1.75x the worst seed. After 8 passes
// (seeds 7, 11, 13): 0.00028, 0.00028, 0.00024, which the test asks to fall
// below the 2-pass median; mean ratio spm/volpath over the image 0.992 to
// 1.008 after 2 passes, 0.999 to 1.001 after 8. In the floor caustic under
// the sphere (about 5x the floor's radiance) spm/volpath is 0.97 to 1.02
// after 2 passes over the seeds and 0.98 to 1.02 after 8 (the reference's
// first half differs from it there by 0.27%); a caustic lost (no collapse
// at the glass) or doubled would leave 0.85 to 1.1.
TEST(Validation, AreaLitCausticConvergesToMitsuba) {
  const Region caustic{26, 46, 38, 54};
  Case c{"caustic_area", 2, 0.0019, {}};
  c.seeds = {7, 11, 13, 17, 19};
  const Renders r = validate(c);
  const double inside = mean_ratio(r.n4, r.ref, caustic, true);
  EXPECT_GT(inside, 0.85) << "spm/volpath in the floor caustic: " << inside;
  EXPECT_LT(inside, 1.1) << "spm/volpath in the floor caustic: " << inside;
  std::printf("caustic_area: spm/volpath mean ratio in the floor caustic %.3f\n", inside);
}

// A volumetric caustic off a mirror that volpath can render (issue 14, item
// 5): the tilted mirror of mirror_caustic.xml in fog, lit by a small
// spherical area light in a black box aimed at it; the floor sees the light
// only through the mirror. volpath reaches the mirrored light only by
// hitting the light after the mirror, so its reference is slow to converge:
// 1,048,576 samples (issue 14, seventh session; 98,304, then 524,288, whose
// chunks it continues), whose own noise, from its difference with the
// 524,288-sample half, is a relMSE of about 0.0017. Measured against it
// (64x64, max_bounces 32): relMSE after 2 passes 0.00619 (seed 7, the one
// used here; seeds 11, 13: 0.00602, 0.00633), after 8 passes 0.00288
// (0.00286, 0.00293), more than half of it the reference's noise; mean
// ratio spm/volpath 0.991 to 1.018 after 2 passes, 0.996 to 1.000 after 8.
// The bound 0.0111 is 1.75x the worst seed. The light is hidden from the
// camera, so no pixel sees it. The floor patch the mirror lights (the
// rectangle below, inside it; 6.5x the light left there without the
// mirror) checks the caustic itself: spm/volpath there is 0.94 to 1.04
// after 2 passes over the seeds and 1.008 to 1.020 after 8; the caustic
// lost leaves 0.16, half of it 0.58, doubled 1.8 (measured against the
// first reference), and 0.85 to 1.1 takes in the seeds.
TEST(Validation, MirrorAreaCausticConvergesToMitsuba) {
  const Region patch{34, 41, 56, 49};
  const Renders r = validate({"mirror_area", 2, 0.0111, {}});
  const double inside = mean_ratio(r.n4, r.ref, patch, true);
  EXPECT_GT(inside, 0.85) << "spm/volpath in the floor patch the mirror lights: " << inside;
  EXPECT_LT(inside, 1.1) << "spm/volpath in the floor patch the mirror lights: " << inside;
  std::printf("mirror_area: spm/volpath mean ratio in the mirror's floor patch %.3f\n", inside);
}

// A mesh as Mitsuba's data ships it (issue 45): the glass Stanford bunny, a
// binary PLY without normals (Mitsuba and spm give it the same smooth ones),
// in fog under a disk light, in a file written for Mitsuba (volpath: every
// spm setting derived). Its reference has 217,828 samples (40 minutes of
// volpath). The pixels that see the light's disk, few and partly covered,
// are left out: they carry most of the error at low sample counts in both
// renderers. Measured (64x64, 32 bounces), outside them: relMSE after 2
// passes 0.0410 (seed 7), 0.0356 and 0.0416 (seeds 11, 13); after 8 passes
// 0.0114, 0.0101, 0.0102; mean ratio spm/volpath 0.979 to 1.011 after 2
// passes, 0.987 to 0.997 after 8. The bounds: 0.073 after 2 passes (1.75x
// the worst seed), 0.017 after 8 (1.5x). After 8 passes, the bunny with flat
// facets (face_normals, instead of the smooth normals) reads 0.0203, and
// the scene without it 0.0394.
TEST(Validation, GlassBunnyFromAPlyConvergesToMitsuba) {
  const Region light{22, 0, 38, 10};
  Case c{"bunny_fog", 2, 0.073, light};
  c.seeds = {7, 11, 13};
  expect_converged(validate(c), 0.017, 0.03, light);
}

// Glossy and layered surfaces (METHOD.md 13): a rough copper sphere (GGX),
// a frosted glass one (Beckmann) and a plastic floor in fog, in a file
// written for Mitsuba. Its reference has 220,864 samples (20 minutes of
// volpath). Measured (64x64, 32 bounces): relMSE after 2 passes 0.0132
// (seed 7), 0.0338 and 0.0132 (seeds 11, 13); after 8 passes 0.0030, 0.0042
// and 0.0095 (seed 13 keeps a bright pixel); mean ratio spm/volpath 0.990
// after 8 passes (0.995 after 64: the glossy spheres' surroundings read
// 1-1.7% dark). Bounds: the median after 2 passes 0.023 (1.75x), seed 7's
// after 8 passes 0.0075 (2.5x), the mean ratio within 3%.
TEST(Validation, GlossyFogConvergesToMitsuba) {
  Case c{"glossy_fog", 2, 0.023, {}};
  c.seeds = {7, 11, 13};
  expect_converged(validate(c), 0.0075, 0.03);
}

// A directional light (METHOD.md 14): the sun through a window in a roof
// above a box of fog, in a file written for Mitsuba. Its reference has
// 232,388 samples (10 minutes of volpath). Few streams pass the window (it
// is 0.3% of the disk they start from), so the maps are noisy; the shaft
// and the sunlit patch come mostly from shadow rays. Measured (64x64, 32
// bounces): relMSE after 4 passes 0.0287 (seed 7), 0.0279 and 0.0315
// (seeds 11, 13); after 16 passes 0.0060, 0.0100, 0.0061; mean ratio
// spm/volpath after 16 passes 1.009, 1.068 and 1.026 (the sunlit patch's
// edge pixels, partly lit, move it). Bounds: 0.055 after 4 passes (1.75x
// the worst seed), 0.015 after 16 (1.5x), the mean ratio within 10%.
TEST(Validation, SunShaftConvergesToMitsuba) {
  Case c{"sun_shaft", 4, 0.055, {}};
  c.seeds = {7, 11, 13};
  expect_converged(validate(c), 0.015, 0.1);
}

// An environment map (METHOD.md 14): a box of fog, a rough aluminium
// sphere and the ground under scenes/textures/sky.exr, a sky with a small
// sun, in a file written for Mitsuba. Its reference has 285,096 samples (10
// minutes of volpath). The derived radius (4.0, volume radius 12.1, set by
// the 80-unit ground) blurs the 14-unit box of fog: its top reads 5-9% dark
// and its base 2-7% bright even after 256 passes, while the sky matches to
// 0.1% and the ground to 0.5% (issue 44's derived settings, not the
// environment's light; docs/experiments/glossy-and-sky.md). The test sets
// radius 0.6, which that bias does not hide behind. Measured (64x64, 32
// bounces): relMSE after 8 passes 0.0210 (seed 7), 0.0188, 0.0223 (seeds 11,
// 13); after 32 passes 0.0053 (seed 7; 0.0051, 0.0051); mean ratio
// spm/volpath after 32 passes 0.998, 0.996, 1.003. Bounds: the median after
// 8 passes 0.037 (1.75x), seed 7's after 32 0.0093 (1.75x), the mean ratio
// within 2%.
TEST(Validation, SkyFogConvergesToMitsuba) {
  Case c{"sky_fog", 8, 0.037, {}};
  c.seeds = {7, 11, 13};
  c.radius = 0.6f;
  expect_converged(validate(c), 0.0093, 0.02);
}

// A heterogeneous medium (METHOD.md 12): the smoke plume of
// scenes/volumes/plume.vol in the Cornell box, delta and ratio tracking
// (march_step 0). Measured (64x64, the file's settings, 32 bounces): relMSE
// after 2 passes 0.00263 (seed 7, the one used here; seeds 11, 13: 0.00243,
// 0.00251), after 8 passes 0.00090 (0.00093, 0.00090). The bound 0.0046 is
// 1.75x the worst seed.
TEST(Validation, SmokePlumeConvergesToMitsuba) { validate({"smoke_cornell", 2, 0.0046, {}}); }

// The stream beams in the smoke (grey sigma_t): measured relMSE after 2
// passes 0.0061 (seed 7), 0.0052 and 0.0057 (seeds 11, 13), after 8 0.0020
// (0.0026, 0.0022); bound 0.0106, 1.75x the worst.
TEST(Validation, SmokePlumeWithStreamBeamsConvergesToMitsuba) {
  validate({"smoke_cornell", 2, 0.0106, {}, "beams"});
}

// The global fog box written the usual Mitsuba way (issue 12): no spm
// settings, the fog nested in the sensor; and the same scene with the fog
// also on every shape. Both render the same image (bit for bit here: the
// same media everywhere) and match volpath's. Measured, 64x64, defaults
// (10,000 streams x 4, derived radius 0.143, 2 samples per pass, final
// gather): relMSE after 4 passes 0.0025 (seed 7), 0.0027 and 0.0026 (seeds
// 11, 13), mean ratio 0.992 to 0.997; the bound 0.0047 is 1.75x the worst
// seed (without the final gather 0.0024, seed 7). Streams starting in
// vacuum, as before the region rule, lose about a third of the light (issue
// 12), far past it.
TEST(Validation, FogBoxWrittenEitherWayMatchesMitsuba) {
  const Reference ref = load_reference("fog_box");
  const std::string sensor = SPM_SCENES_DIR "/fog_box.xml", exterior = SPM_TEST_DATA_DIR "/scene/fog_box_exterior.xml";
  std::vector<spm::Image> images;
  for (const std::string& file : {sensor, exterior}) {
    const auto scene = spm::load_scene(file, ref.defines);
    EXPECT_EQ(scene.camera.width, ref.image.width);
    spm::RenderSettings s;
    s.passes = 4;
    s.seed = 7;
    images.push_back(spm::render(scene, s, spm::test::device()));
    const double e = rel_mse(images.back(), ref.image);
    EXPECT_LT(e, 0.0047) << file << ": relMSE " << e << " (mean ratio " << mean_ratio(images.back(), ref.image) << ")";
    std::printf("%s: relMSE %.5f after 4 passes (mean ratio %.4f)\n", file.c_str(), e,
                mean_ratio(images.back(), ref.image));
  }
  EXPECT_LT(rel_mse(images[0], images[1]), 1e-8) << "the two forms of the scene";
  spm::RenderSettings s;
  s.passes = 16;
  s.seed = 7;
  const double e16 = rel_mse(spm::render(spm::load_scene(sensor, ref.defines), s, spm::test::device()), ref.image);
  EXPECT_LT(e16, rel_mse(images[0], ref.image)) << "16 passes: relMSE " << e16;
}

// The render's own error estimate (docs/METHOD.md 15) against the error
// the reference measures: within [0.5, 2] after 4 and after 16 passes.
// Measured here (docs/experiments/error-estimate.md): fog_box 0.97 and 0.98
// at 4 passes, 1.07 and 1.17 at 16; cornell_fog (max_bounces lifted as
// above) 0.81 and 0.95; caustic_area 1.06 and 0.90. Samples per pass
// are cut to 4 here to keep the test short: the estimate must hold for any.
// A cornell_fog whose estimate left out the bias reads 0.68 where the
// radius is 7 (derived, docs/experiments/error-estimate.md); one that took
// the spread between passes for the variance, 2.4 on the fog box.
TEST(Validation, TheErrorEstimateMatchesTheReferencesError) {
  struct Calibration {
    const char* scene;
    std::vector<uint32_t> seeds;
  };
  for (const Calibration& c : {Calibration{"fog_box", {1, 2}}, Calibration{"cornell_fog", {1}},
                               Calibration{"caustic_area", {1}}}) {
    const Reference ref = load_reference(c.scene);
    auto scene = spm::load_scene(std::string(SPM_SCENES_DIR "/") + c.scene + ".xml", ref.defines);
    scene.integrator.max_bounces = 32;
    for (const uint32_t seed : c.seeds) {
      for (const int passes : {4, 16}) {
        spm::RenderSettings s;
        s.passes = passes;
        s.spp = 4;
        s.seed = seed;
        spm::RenderStats stats;
        const spm::Image image = spm::render(scene, s, spm::test::device(), &stats);
        const double actual = rel_mse(image, ref.image), ratio = stats.error.relmse / actual;
        EXPECT_GE(ratio, 0.5) << c.scene << " seed " << seed << ", " << passes << " passes: estimated "
                              << stats.error.relmse << ", actual " << actual;
        EXPECT_LE(ratio, 2.0) << c.scene << " seed " << seed << ", " << passes << " passes: estimated "
                              << stats.error.relmse << ", actual " << actual;
        std::printf("%s seed %u, %d passes: estimated relMSE %.3g (variance %.3g, bias %.3g), actual %.3g, "
                    "ratio %.2f\n",
                    c.scene, seed, passes, stats.error.relmse, stats.error.variance, stats.error.bias, actual, ratio);
      }
    }
  }
}

// scenes/NAME.xml in the form a Mitsuba 3 user has it (tools/mitsuba_form.py):
// its integrator block replaced by volpath, so that every spm setting is
// derived; written to a temporary file, whose path is returned.
std::string mitsuba_form(const std::string& name) {
  std::ifstream in(std::string(SPM_SCENES_DIR "/") + name + ".xml");
  std::stringstream text;
  text << in.rdbuf();
  std::string xml = text.str();
  const size_t first = xml.find("<integrator"), last = xml.find("</integrator>");
  EXPECT_NE(first, std::string::npos);
  EXPECT_NE(last, std::string::npos);
  xml.replace(first, last + std::string("</integrator>").size() - first,
              "<integrator type=\"volpath\"><integer name=\"max_depth\" value=\"64\"/>"
              "<integer name=\"rr_depth\" value=\"5\"/></integrator>");
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("spm_" + std::to_string(::getpid()) + "_mitsuba_" + name + ".xml"))
                               .string();
  std::ofstream(path) << xml;
  return path;
}

// Self-tuning against hand-tuning (issue 44): each scene in its Mitsuba
// form, 8 passes at 64x64, seed 1. The derived render's relMSE is within
// 1.25 times the best of the same render with the radius set by hand to
// 0.5, 0.71, 1.41 and 2 times the derived one (volume radius and stream
// width derived from it, as in the derived render). Measured here: caustic_area
// 0.00217 derived (the pilot's 8.98 planned down to 4.49) against 0.00207
// at 1.41x, 0.00320 at 0.5x; fog_box 0.00112 against 0.00111 at 1.41x.
// cornell_fog's curve is flat at a pass count (camera noise: 0.0082-0.0086
// over the sweep), so it would test nothing; its radius matters at equal
// time, where the plan weighs its cost (docs/experiments/self-tuning.md).
TEST(Validation, TheDerivedRadiusIsWithinTheSweepsBest) {
  for (const std::string name : {"caustic_area", "fog_box"}) {
    const Reference ref = load_reference(name);
    const std::string file = mitsuba_form(name);
    spm::RenderSettings s;
    s.passes = 8;
    s.seed = 1;
    float radius = 0.0f;
    s.announce = [&](const spm::Scene& used, double) { radius = used.integrator.radius; };
    const double derived = rel_mse(spm::render(spm::load_scene(file, ref.defines), s, spm::test::device()), ref.image);
    s.announce = {};
    double best = INFINITY;
    for (const float f : {0.5f, 0.70710678f, 1.41421356f, 2.0f}) {
      auto scene = spm::load_scene(file, ref.defines);
      scene.integrator.radius = radius * f;
      const double e = rel_mse(spm::render(scene, s, spm::test::device()), ref.image);
      std::printf("%s: radius %.4g (%.2f x derived): relMSE %.4g\n", name.c_str(), radius * f, f, e);
      best = std::min(best, e);
    }
    std::filesystem::remove(file);
    std::printf("%s: derived radius %.4g: relMSE %.4g, best of the sweep %.4g\n", name.c_str(), radius, derived, best);
    EXPECT_LE(derived, 1.25 * best) << name << ": derived radius " << radius;
  }
}

// --target-error E stops once the estimate is below E, and the image's
// actual error is then below 2E.
TEST(Validation, ATargetErrorStopsWhereItIsMet) {
  const Reference ref = load_reference("fog_box");
  auto scene = spm::load_scene(SPM_SCENES_DIR "/fog_box.xml", ref.defines);
  const float target = 1.5e-3f;
  scene.integrator.target_error = target;
  spm::RenderSettings s;
  s.spp = 4;
  s.seed = 3;
  spm::RenderStats stats;
  std::vector<double> estimates;
  const spm::Image image = spm::render(scene, s, std::vector<spm::Device*>{&spm::test::device()}, &stats,
                                       [&](int, int total, const spm::ErrorEstimate& e) {
                                         EXPECT_EQ(total, 0);
                                         estimates.push_back(e.relmse);
                                       });
  ASSERT_GE(estimates.size(), 3u);
  EXPECT_EQ(int(estimates.size()), stats.passes);
  EXPECT_LT(stats.error.relmse, target);
  EXPECT_GE(estimates[estimates.size() - 2], target) << "it went on after the target was met";
  const double actual = rel_mse(image, ref.image);
  EXPECT_LT(actual, 2.0 * target) << stats.passes << " passes";
  std::printf("target %.3g: %d passes, estimated %.3g, actual %.3g\n", target, stats.passes, stats.error.relmse,
              actual);
}

}  // namespace
