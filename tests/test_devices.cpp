// The same image everywhere (METHOD.md 6-7): the same device twice, two
// devices at once, and a second OpenCL implementation (oclgrind).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <utility>

#include "cli_support.h"
#include "film/image_io.h"
#include "scene/volume_grid.h"

namespace {

using Devices = spm::test::CliTest;

using spm::test::kFogGlassScene;
using spm::test::kSmokeGlassScene;

// kSmokeGlassScene's grid: 9 x 7 x 5 texels of density in [0, 3), not a
// multiple of the majorant cells' 8 texels on any axis.
void write_smoke_grid(const std::string& path) {
  spm::VolumeGrid g;
  g.nx = 9;
  g.ny = 7;
  g.nz = 5;
  for (uint32_t i = 0; i < g.nx * g.ny * g.nz; ++i) g.data.push_back(float((i * 7919u) % 300u) / 100.0f);
  spm::write_vol(path, g);
}

bool same_pixels(const spm::Image& a, const spm::Image& b) {
  return a.width == b.width && a.height == b.height &&
         std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0;
}

TEST_F(Devices, SameDeviceSameSeedIsBitIdentical) {
  const std::string scene = write("s.xml", kFogGlassScene);
  const std::string args = " --spp 2 --passes 3 --streams 400 --associated 8 --res 16x12";
  ASSERT_EQ(run("render " + scene + " -o " + path("a.exr") + args + " --seed 5").code, 0);
  ASSERT_EQ(run("render " + scene + " -o " + path("b.exr") + args + " --seed 5").code, 0);
  EXPECT_TRUE(same_pixels(spm::read_exr(path("a.exr")), spm::read_exr(path("b.exr"))));
  // A different seed is a different image: the comparison can fail.
  ASSERT_EQ(run("render " + scene + " -o " + path("c.exr") + args + " --seed 6").code, 0);
  EXPECT_FALSE(same_pixels(spm::read_exr(path("a.exr")), spm::read_exr(path("c.exr"))));
}

TEST_F(Devices, WorkGroupSizeDoesNotChangeTheImage) {
  // Random numbers are counted by (stream or pixel, event, purpose), never by
  // work-item order (METHOD.md 7).
  const std::string scene = write("s.xml", kFogGlassScene);
  const std::string args = " --spp 2 --passes 2 --streams 400 --associated 8 --res 16x12";
  ASSERT_EQ(run("render " + scene + " -o " + path("a.exr") + args, "SPM_WORK_GROUP_SIZE=64").code, 0);
  ASSERT_EQ(run("render " + scene + " -o " + path("b.exr") + args, "SPM_WORK_GROUP_SIZE=1").code, 0);
  ASSERT_EQ(run("render " + scene + " -o " + path("c.exr") + args, "SPM_WORK_GROUP_SIZE=24").code, 0);
  EXPECT_TRUE(same_pixels(spm::read_exr(path("a.exr")), spm::read_exr(path("b.exr"))));
  EXPECT_TRUE(same_pixels(spm::read_exr(path("a.exr")), spm::read_exr(path("c.exr"))));
}

TEST_F(Devices, TwoDevicesGiveTheSingleDeviceImageBitForBit) {
  // PoCL exposes two CPU devices; passes go to whichever is free, and are
  // summed in pass order, so the split does not change a bit.
  const std::string scene = write("s.xml", kFogGlassScene);
  const std::string args = " --spp 2 --passes 6 --streams 400 --associated 8 --res 16x12";
  ASSERT_EQ(run("render " + scene + " -o " + path("one.exr") + args).code, 0);
  const auto two = run("render " + scene + " -o " + path("two.exr") + args + " --device all --profile-json " +
                           path("two.json"),
                       "POCL_DEVICES='pthread pthread'");
  ASSERT_EQ(two.code, 0) << two.err;
  // Both devices did passes.
  EXPECT_NE(two.err.find("device 0 ("), std::string::npos) << two.err;
  EXPECT_NE(two.err.find("device 1 ("), std::string::npos) << two.err;
  EXPECT_TRUE(same_pixels(spm::read_exr(path("one.exr")), spm::read_exr(path("two.exr"))));

  // The two devices are one model: each program is compiled from the source
  // once, and the other device loads that binary (the image above is then
  // also the check that the binary computes what the source does).
  std::ifstream in(path("two.json"));
  const nlohmann::json host = nlohmann::json::parse(in).at("host");
  std::map<std::string, std::pair<int, int>> programs;  // source builds, binary loads
  for (const auto& [key, value] : host.items()) {
    for (const bool from_binary : {false, true}) {
      const std::string kind = from_binary ? "program_binary_s." : "program_build_s.";
      if (key.rfind(kind, 0) != 0) continue;
      const std::string program = key.substr(key.find('.', kind.size()) + 1);  // after "<device>."
      auto& [source, binary] = programs[program];
      ++(from_binary ? binary : source);
    }
  }
  EXPECT_GE(programs.size(), 7u);
  for (const auto& [program, counts] : programs) {
    EXPECT_EQ(counts, std::make_pair(1, 1)) << program << ": (source builds, binary loads)";
  }
}

TEST_F(Devices, DeviceListsAreValidated) {
  const std::string scene = write("s.xml", kFogGlassScene);
  EXPECT_EQ(run("render " + scene + " -o " + path("o.exr") + " --device 0:0,0:0").code, 2);
  EXPECT_EQ(run("render " + scene + " -o " + path("o.exr") + " --device 0:0,7:7").code, 2);
}

TEST_F(Devices, OclgrindFindsNoDataRaceAndMatchesPocl) {
  // oclgrind runs every kernel on a simulator with its own compiler: no data
  // race may be reported, and the image must match PoCL's to float rounding
  // (measured: max relative difference 7e-7; the bound is 1e-4 of each pixel
  // plus 1e-6). Its --uninitialized check cannot run these kernels in
  // oclgrind 21.10 (docs/TESTING.md "Tests"); the two tests below check for
  // uninitialised data instead.
  // Both volume estimates: the stream beams add march's beam appends and
  // their own gather loop.
  // A heterogeneous medium adds its lookups, delta and ratio tracking
  // (--march-step 0) and ray marching.
  // oclgrind's simulator allocates for every work-item: under AddressSanitizer's
  // allocator these renders take 5x as long (223 s against 45 s), and what they
  // check is the kernels, so a sanitized suite runs the Release spm where
  // tools/test.sh names one. Without it, the sanitized spm runs them.
  std::string spm = SPM_BINARY;
#ifdef SPM_SANITIZED
  if (std::getenv("SPM_RELEASE_BINARY")) spm = std::getenv("SPM_RELEASE_BINARY");
#endif
  write("s.xml", kFogGlassScene);
  write("smoke.xml", kSmokeGlassScene);
  write_smoke_grid(path("smoke.vol"));
  for (const std::string run_case : {"s.xml bre", "s.xml beams", "smoke.xml bre 0", "smoke.xml bre 0.1"}) {
    std::istringstream words(run_case);
    std::string file, estimator, step = "0";
    words >> file >> estimator >> step;
    const std::string scene = path(file);
    const std::string args =
        " --spp 2 --streams 200 --associated 4 --estimator " + estimator + " --march-step " + step;
    const auto sim = run("render " + scene + " -o " + path("sim.exr") + args, "oclgrind --data-races", spm);
    ASSERT_EQ(sim.code, 0) << sim.err;
    EXPECT_NE(sim.err.find("Oclgrind"), std::string::npos) << "not run on oclgrind: " << sim.err;
    // The settings line names target_error: not one of oclgrind's reports.
    const std::string reports = std::regex_replace(sim.err, std::regex("target_error"), "");
    for (const char* word : {"race", "Invalid", "Uninitialized", "error"}) {
      EXPECT_EQ(reports.find(word), std::string::npos) << run_case << ": " << sim.err;
    }
    ASSERT_EQ(run("render " + scene + " -o " + path("pocl.exr") + args, "", spm).code, 0);
    const spm::Image a = spm::read_exr(path("sim.exr")), b = spm::read_exr(path("pocl.exr"));
    ASSERT_EQ(a.rgb.size(), b.rgb.size());
    double peak = 0.0;
    for (size_t i = 0; i < a.rgb.size(); ++i) {
      EXPECT_NEAR(a.rgb[i], b.rgb[i], 1e-4 * std::abs(b.rgb[i]) + 1e-6) << run_case << ": value " << i;
      peak = std::max(peak, double(b.rgb[i]));
    }
    EXPECT_GT(peak, 0.0);
  }
}

TEST_F(Devices, UnwrittenDeviceMemoryIsNeverRead) {
  // OpenCL leaves new buffers undefined. Filling every buffer with another
  // byte first (SPM_FILL_BUFFERS) must not change a bit of the image: no
  // kernel, and no download, reads device memory before it was written. A
  // small memory cap adds stream batches, mid-batch flushes and gather tiles.
  // This works on any device (SPM_TEST_DEVICE); dropping the host's reset of
  // the stream counters makes the 0xff render fail.
  write("s.xml", kFogGlassScene);
  write("smoke.xml", kSmokeGlassScene);
  write_smoke_grid(path("smoke.vol"));
  const std::string args = " --spp 2 --passes 2 --streams 400 --associated 8 --res 16x12 --device-memory 150000";
  for (const std::string estimator : {"bre", "beams", "smoke"}) {
    const std::string scene = path(estimator == "smoke" ? "smoke.xml" : "s.xml");
    for (const char* fill : {"0", "0xff", "0x5a"}) {
      const auto r = run("render " + scene + " -o " + path(estimator + "fill" + fill + ".exr") + args +
                             " --estimator " + (estimator == "smoke" ? "bre" : estimator),
                         std::string("SPM_FILL_BUFFERS=") + fill);
      ASSERT_EQ(r.code, 0) << fill << ": " << r.err;
    }
    const spm::Image zero = spm::read_exr(path(estimator + "fill0.exr"));
    EXPECT_TRUE(same_pixels(zero, spm::read_exr(path(estimator + "fill0xff.exr")))) << estimator;
    EXPECT_TRUE(same_pixels(zero, spm::read_exr(path(estimator + "fill0x5a.exr")))) << estimator;
  }
  EXPECT_EQ(run("render " + path("s.xml") + " -o " + path("bad.exr") + args, "SPM_FILL_BUFFERS=256").code, 2);
}

TEST_F(Devices, MemcheckFindsNoUninitialisedValueInARender) {
  // PoCL runs the kernels as native code in spm's process, and its buffers
  // are host memory, so valgrind's memcheck follows every value through every
  // kernel (emit to gather) and the host: a value computed from memory nobody
  // wrote that reaches a branch, an address or the EXR is an error. This
  // covers what oclgrind's --uninitialized would. PoCL is asked for generic
  // x86-64 code (valgrind 3.19 cannot run AVX-512); the first render fills
  // PoCL's kernel cache, so the one under valgrind does not compile LLVM.
  std::string spm = SPM_BINARY;
#ifdef SPM_SANITIZED
  // valgrind cannot run an AddressSanitizer build: this build's suite runs
  // the Release spm tools/test.sh built beside it, named by SPM_RELEASE_BINARY.
  if (!std::getenv("SPM_RELEASE_BINARY")) GTEST_SKIP() << "valgrind cannot run an AddressSanitizer build";
  spm = std::getenv("SPM_RELEASE_BINARY");
#endif
#ifndef __x86_64__
  GTEST_SKIP() << "the PoCL settings below name x86-64 code";
#endif
  const std::string scene = write("s.xml", kFogGlassScene);
  const std::string args = " --spp 1 --passes 2 --streams 100 --associated 4 --res 12x8";
  const std::string generic = "POCL_LLVM_CPU_NAME=x86-64 POCL_KERNELLIB_NAME=sse2";
  ASSERT_EQ(run("render " + scene + " -o " + path("warm.exr") + args, generic, spm).code, 0);
  const auto r = run("render " + scene + " -o " + path("memcheck.exr") + args,
                     generic + " valgrind --error-exitcode=99 --suppressions=" + std::string(SPM_SOURCE_DIR) +
                         "/tools/valgrind.supp",
                     spm);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("Memcheck"), std::string::npos) << "not run under valgrind: " << r.err;
  EXPECT_NE(r.err.find("ERROR SUMMARY: 0 errors"), std::string::npos) << r.err;
  EXPECT_TRUE(same_pixels(spm::read_exr(path("warm.exr")), spm::read_exr(path("memcheck.exr"))));
}

}  // namespace
