// Several processes (host/mpi/): `mpirun -np 2` renders the one process's
// image bit for bit (passes summed in pass order on rank 0), and a failure on
// any rank ends the whole job with a non-zero code instead of a hang.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_support.h"
#include "film/image_io.h"

namespace {

// Open MPI's mpirun on any machine (--oversubscribe: more ranks than cores),
// as root too (CI), each run ended after 60 s: exit code 124 is a hang. Under
// tools/sanitize.sh, LeakSanitizer would report what Open MPI never frees
// (its plugins' allocations, Open MPI 4.1): those stacks, unwound in full
// through Open MPI's libraries, are suppressed by tools/lsan.supp; spm's own
// leaks still count.
class Mpi : public spm::test::CliTest {
 protected:
  std::string mpirun(const std::string& options) const {
    return "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 LSAN_OPTIONS=suppressions=" +
           std::string(SPM_SOURCE_DIR) + "/tools/lsan.supp:print_suppressions=0:fast_unwind_on_malloc=0" +
           " timeout -k 5 60 mpirun --oversubscribe " + options;
  }
};

const std::string kArgs = " --spp 2 --passes 6 --streams 400 --associated 8 --res 16x12";

// Empty when the test can run, else why not.
std::string why_skip() {
#ifndef SPM_HAVE_MPI
  return "spm was built without MPI (install libopenmpi-dev and openmpi-bin, then reconfigure)";
#else
  if (std::system("command -v mpirun >/dev/null 2>&1") != 0) return "mpirun is not on the PATH (openmpi-bin)";
  if (std::system("mpirun --version 2>&1 | grep -q 'Open MPI'") != 0) {
    return "mpirun is not Open MPI's (the test uses --oversubscribe and OMPI_ALLOW_RUN_AS_ROOT)";
  }
  return "";
#endif
}

bool same_pixels(const spm::Image& a, const spm::Image& b) {
  return a.width == b.width && a.height == b.height && !a.rgb.empty() &&
         std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0;
}

TEST_F(Mpi, TwoRanksGiveTheOneProcessImageBitForBit) {
  if (const std::string why = why_skip(); !why.empty()) GTEST_SKIP() << why;
  const std::string scene = write("s.xml", spm::test::kFogGlassScene);
  const auto one = run("render " + scene + " -o " + path("one.exr") + kArgs);
  ASSERT_EQ(one.code, 0) << one.err;
  const auto two = run("render " + scene + " -o " + path("two.exr") + kArgs + " --profile-json " + path("p.json"),
                       mpirun("-np 2"));
  ASSERT_EQ(two.code, 0) << two.err;
  // Both ranks rendered their half of the passes; only rank 0 printed.
  EXPECT_NE(two.err.find("rank 0 device 0 ("), std::string::npos) << two.err;
  EXPECT_NE(two.err.find("rank 1 device 0 ("), std::string::npos) << two.err;
  EXPECT_EQ(two.err.find("spm: rank 1:"), std::string::npos) << two.err;
  EXPECT_TRUE(same_pixels(spm::read_exr(path("one.exr")), spm::read_exr(path("two.exr"))));

  // The profile: rank 0's at the top level, every rank's under "ranks".
  std::ifstream in(path("p.json"));
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j.at("passes"), 6);
  ASSERT_EQ(j.at("ranks").size(), 2u);
  for (int r = 0; r < 2; ++r) {
    const auto& rank = j.at("ranks")[r];
    EXPECT_EQ(rank.at("rank"), r);
    EXPECT_EQ(rank.at("passes"), 3);
    EXPECT_TRUE(rank.at("kernels").contains("gather")) << rank.dump();
    EXPECT_EQ(rank.at("devices")[0].at("passes"), 3);
  }
  EXPECT_EQ(j.at("devices")[0].at("passes"), 3);
}

TEST_F(Mpi, TimeBudgetKeepsThePassesBeforeTheFirstMissingOne) {
  // Each rank renders its passes (rank r: r, r + 2, ...) for the budget; the
  // image holds passes 0 .. P - 1 with P the first pass no rank finished.
  if (const std::string why = why_skip(); !why.empty()) GTEST_SKIP() << why;
  const std::string scene = write("s.xml", spm::test::kFogGlassScene);
  const auto out = run("render " + scene + " -o " + path("t.exr") +
                           " --spp 2 --streams 400 --associated 8 --res 16x12 --time 1.5 --profile-json " +
                           path("p.json"),
                       mpirun("-np 2"));
  ASSERT_EQ(out.code, 0) << out.err;
  std::ifstream in(path("p.json"));
  const nlohmann::json j = nlohmann::json::parse(in);
  const int n0 = j.at("ranks")[0].at("passes"), n1 = j.at("ranks")[1].at("passes");
  EXPECT_GE(n0, 1);
  EXPECT_GE(n1, 1);
  EXPECT_EQ(j.at("passes"), std::min(2 * n0, 2 * n1 + 1)) << n0 << " and " << n1 << " passes";
  // Every rank's passes end within the budget plus 5%, by its own clock.
  for (const auto& rank : j.at("ranks")) EXPECT_LE(rank.at("seconds").get<double>(), 1.5 * 1.05);
}

TEST_F(Mpi, AFailureOnAnyRankEndsEveryRankWithoutAHang) {
  if (const std::string why = why_skip(); !why.empty()) GTEST_SKIP() << why;
  const std::string scene = write("s.xml", spm::test::kFogGlassScene);
  const std::string rank1 = " : -np 1 " + std::string(SPM_BINARY) + " render " + scene + " -o " + path("o.exr") + kArgs;

  // Rank 0 cannot write its image (the directory is a file) after rank 1 is done.
  const auto unwritable = run("render " + scene + " -o " + path("s.xml") + "/o.exr" + kArgs, mpirun("-np 2"));
  EXPECT_EQ(unwritable.code, 1) << unwritable.err;
  EXPECT_NE(unwritable.err.find("cannot write"), std::string::npos) << unwritable.err;

  // No such device on any rank: bad input, exit code 2.
  const auto device = run("render " + scene + " -o " + path("o.exr") + kArgs + " --device 7:7", mpirun("-np 2"));
  EXPECT_EQ(device.code, 2) << device.err;

  // Only rank 1 fails (different arguments per rank), while rank 0 renders and
  // waits for rank 1's passes.
  const auto one_rank = run("render " + scene + " -o " + path("o.exr") + kArgs + rank1 + " --device 7:7",
                            mpirun("-np 1"));
  EXPECT_EQ(one_rank.code, 2) << one_rank.err;
  EXPECT_NE(one_rank.err.find("spm: rank 1: --device"), std::string::npos) << one_rank.err;

  // Rank 1 fails in the middle of its render (its device memory budget is too
  // small for one stream): a runtime failure, exit code 1.
  const auto memory = run("render " + scene + " -o " + path("o.exr") + kArgs + rank1 + " --device-memory 1",
                          mpirun("-np 1"));
  EXPECT_EQ(memory.code, 1) << memory.err;
  EXPECT_NE(memory.err.find("spm: rank 1:"), std::string::npos) << memory.err;

  // Rank 1 renders other passes (another seed): rank 0 refuses to mix them.
  const auto seed = run("render " + scene + " -o " + path("o.exr") + kArgs + rank1 + " --seed 9", mpirun("-np 1"));
  EXPECT_EQ(seed.code, 2) << seed.err;
  EXPECT_NE(seed.err.find("other settings"), std::string::npos) << seed.err;
  EXPECT_FALSE(std::ifstream(path("o.exr")).good());
}

}  // namespace
