// Validation against Mitsuba 3 (issue 7): spm's bre renders of the project's
// scenes against the committed volpath references in tests/data/reference/
// (made by tools/reference.py; each EXR's SHA-256 is recorded in the JSON
// beside it and checked here; the test never regenerates them).
//
// For each scene: N passes have a relMSE (eps 1e-2) against the reference
// below a threshold set from measurements (tests/data/reference/README.md
// gives the measured values and the margins), and 4N passes have a lower
// relMSE than N passes (consistency: the progressive radius shrinks, the
// error falls). The whole file runs in about a minute on 2 cores with PoCL.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "film/image_io.h"
#include "render/render.h"
#include "scene/loader.h"
#include "test_support.h"

namespace {

// ---- SHA-256 (FIPS 180-4), for the references' recorded digests ----------

std::string sha256_hex(const std::vector<unsigned char>& data) {
  static const uint32_t k[64] = {
      0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
      0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
      0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
      0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
      0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
      0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
      0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
      0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};
  uint32_t h[8] = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
  std::vector<unsigned char> m = data;
  const uint64_t bits = uint64_t(data.size()) * 8;
  m.push_back(0x80);
  while (m.size() % 64 != 56) m.push_back(0);
  for (int i = 7; i >= 0; --i) m.push_back(static_cast<unsigned char>(bits >> (8 * i)));
  const auto rotr = [](uint32_t x, int n) { return (x >> n) | (x << (32 - n)); };
  for (size_t off = 0; off < m.size(); off += 64) {
    uint32_t w[64];
    for (int i = 0; i < 16; ++i) {
      w[i] = uint32_t(m[off + 4 * i]) << 24 | uint32_t(m[off + 4 * i + 1]) << 16 | uint32_t(m[off + 4 * i + 2]) << 8 |
             uint32_t(m[off + 4 * i + 3]);
    }
    for (int i = 16; i < 64; ++i) {
      const uint32_t s0 = rotr(w[i - 15], 7) ^ rotr(w[i - 15], 18) ^ (w[i - 15] >> 3);
      const uint32_t s1 = rotr(w[i - 2], 17) ^ rotr(w[i - 2], 19) ^ (w[i - 2] >> 10);
      w[i] = w[i - 16] + s0 + w[i - 7] + s1;
    }
    uint32_t a = h[0], b = h[1], c = h[2], d = h[3], e = h[4], f = h[5], g = h[6], hh = h[7];
    for (int i = 0; i < 64; ++i) {
      const uint32_t t1 = hh + (rotr(e, 6) ^ rotr(e, 11) ^ rotr(e, 25)) + ((e & f) ^ (~e & g)) + k[i] + w[i];
      const uint32_t t2 = (rotr(a, 2) ^ rotr(a, 13) ^ rotr(a, 22)) + ((a & b) ^ (a & c) ^ (b & c));
      hh = g;
      g = f;
      f = e;
      e = d + t1;
      d = c;
      c = b;
      b = a;
      a = t1 + t2;
    }
    h[0] += a, h[1] += b, h[2] += c, h[3] += d, h[4] += e, h[5] += f, h[6] += g, h[7] += hh;
  }
  std::string hex;
  char buf[9];
  for (uint32_t v : h) {
    std::snprintf(buf, sizeof buf, "%08x", v);
    hex += buf;
  }
  return hex;
}

std::vector<unsigned char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(Sha256, KnownDigests) {
  EXPECT_EQ(sha256_hex({}), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  const std::string abc = "abc";
  EXPECT_EQ(sha256_hex({abc.begin(), abc.end()}),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  const std::string two = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";  // two blocks
  EXPECT_EQ(sha256_hex({two.begin(), two.end()}),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
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
  const std::vector<unsigned char> bytes = read_bytes(exr);
  EXPECT_FALSE(bytes.empty()) << "missing " << exr;
  EXPECT_EQ(sha256_hex(bytes), meta.at("sha256").get<std::string>())
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
  double threshold;  // relMSE bound for N passes (see tests/data/reference/README.md)
  Region skip;       // pixels the reference cannot be trusted in (none: compare all)
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
  auto render = [&](int passes) {
    spm::RenderSettings s;
    s.passes = passes;
    s.seed = 7;
    return spm::render(scene, s, spm::test::device());
  };
  Renders r{render(c.passes), render(4 * c.passes), ref.image};
  const double e = rel_mse(r.n, r.ref, c.skip), e4 = rel_mse(r.n4, r.ref, c.skip);
  ::testing::Test::RecordProperty("relmse_N", std::to_string(e));
  ::testing::Test::RecordProperty("relmse_4N", std::to_string(e4));
  EXPECT_LT(e, c.threshold) << c.scene << ": relMSE after " << c.passes << " passes " << e << " (mean ratio "
                            << mean_ratio(r.n, r.ref, c.skip) << ")";
  EXPECT_LT(e4, e) << c.scene << ": relMSE after " << 4 * c.passes << " passes " << e4 << " is not below " << e
                   << " after " << c.passes;
  std::printf("%s: relMSE %.5f after %d passes (mean ratio %.4f), %.5f after %d (mean ratio %.4f)\n", c.scene, e,
              c.passes, mean_ratio(r.n, r.ref, c.skip), e4, 4 * c.passes, mean_ratio(r.n4, r.ref, c.skip));
  return r;
}

// Measured (64x64, 4 spp, 10000 streams x 100, max_bounces 32): relMSE after
// 2 passes 0.0184 (seed 7, the one used here; seeds 11 and 13: 0.0186,
// 0.0225), after 8 passes 0.0066 (0.0064, 0.0068); mean ratio spm/volpath
// 0.993 and 1.000. The bound 0.035 is 1.9x the measured value, 1.55x the
// worst seed. A missing factor (e.g. the albedo or the phase function's
// 1/(4 pi) in the beam estimate) moves the mean by tens of percent and the
// relMSE far past it: the paper estimator stays at 0.033 even after 64 passes.
TEST(Validation, CornellFogConvergesToMitsuba) { validate({"cornell_fog", 2, 0.035, {}}); }

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

}  // namespace
