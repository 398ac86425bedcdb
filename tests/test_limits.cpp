// Device limits and interrupted renders (reliability): work that does not fit
// is split into batches and tiles, giving the same image; SIGINT finishes the
// pass in flight and writes a complete image.
#include <gtest/gtest.h>

#include <csignal>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "cli_support.h"
#include "device/device.h"
#include "film/image_io.h"
#include "util/errors.h"

namespace {

using Limits = spm::test::CliTest;

nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// The budget counts every live buffer of the device: scene, stream batch,
// film and the maps' grids. A small one gives the same image from more
// stream batches, film tiles and parts of the maps: equal to float rounding,
// since the parts' estimates are summed in another order.
TEST_F(Limits, MemoryCapRendersTheSameImageInMoreBatchesTilesAndParts) {
  const std::string scene = SPM_SCENES_DIR "/cornell_fog.xml";
  const std::string args = " --res 200x150 --spp 1 --passes 2 --streams 2000 --associated 20";
  ASSERT_EQ(run("render " + scene + " -o " + path("a.exr") + args + " --profile-json " + path("a.json")).code, 0);
  // 1.5 MB: a few hundred streams per batch, a few thousand pixels per
  // tile, maps of some 4 MB in parts.
  const auto capped = run("render " + scene + " -o " + path("b.exr") + args + " --profile-json " + path("b.json"),
                          "SPM_DEVICE_MEMORY=1500000");
  ASSERT_EQ(capped.code, 0) << capped.err;
  const spm::Image a = spm::read_exr(path("a.exr")), b = spm::read_exr(path("b.exr"));
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  for (size_t i = 0; i < a.rgb.size(); ++i) ASSERT_NEAR(a.rgb[i], b.rgb[i], 1e-5f * (1.0f + a.rgb[i])) << i;
  const auto ja = read_json(path("a.json")), jb = read_json(path("b.json"));
  EXPECT_EQ(ja["kernels"]["emit"]["launches"], 2);  // one batch per pass
  EXPECT_GT(jb["kernels"]["emit"]["launches"].get<int>(), 4);
  EXPECT_EQ(ja["kernels"]["gather"]["launches"], 2);  // one tile per pass
  EXPECT_GT(jb["kernels"]["gather"]["launches"].get<int>(), 4);
  EXPECT_EQ(ja["passes_detail"][0]["map_parts"], 1);
  EXPECT_GT(jb["passes_detail"][0]["map_parts"].get<int>(), 1);
  // The flag says the same as the environment variable.
  ASSERT_EQ(run("render " + scene + " -o " + path("c.exr") + args + " --device-memory 1500000").code, 0);
  const spm::Image c = spm::read_exr(path("c.exr"));
  EXPECT_EQ(0, std::memcmp(b.rgb.data(), c.rgb.data(), b.rgb.size() * sizeof(float)));
}

// A pass's maps wait on the host only up to SPM_HOST_MEMORY: past it, the
// streams traced so far are gathered and their maps dropped, and the parts
// add up to the same image (to float rounding: another summation order).
TEST_F(Limits, HostMemoryCapGathersAPassInParts) {
  const std::string scene = SPM_SCENES_DIR "/cornell_fog.xml";
  const std::string args =
      " --res 64x48 --spp 1 --passes 2 --streams 2000 --associated 20 --device-memory 1500000 --profile-json ";
  ASSERT_EQ(run("render " + scene + " -o " + path("a.exr") + args + path("a.json")).code, 0);
  const auto capped = run("render " + scene + " -o " + path("b.exr") + args + path("b.json"), "SPM_HOST_MEMORY=200000");
  ASSERT_EQ(capped.code, 0) << capped.err;
  const spm::Image a = spm::read_exr(path("a.exr")), b = spm::read_exr(path("b.exr"));
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  for (size_t i = 0; i < a.rgb.size(); ++i) ASSERT_NEAR(a.rgb[i], b.rgb[i], 1e-5f * (1.0f + a.rgb[i])) << i;
  const auto ja = read_json(path("a.json")), jb = read_json(path("b.json"));
  EXPECT_EQ(ja["passes_detail"][0]["host_parts"], 1);
  EXPECT_GT(jb["passes_detail"][0]["host_parts"].get<int>(), 1);
  EXPECT_EQ(ja["counters"]["records"], jb["counters"]["records"]);
  EXPECT_EQ(run("render " + scene + " -o " + path("c.exr") + args + path("c.json"), "SPM_HOST_MEMORY=x").code, 2);
}

// Every live buffer counts against one budget until its last copy goes.
TEST(DeviceMemory, LiveBuffersShareOneBudget) {
  spm::Device dev(spm::select_device(std::getenv("SPM_TEST_DEVICE") ? std::getenv("SPM_TEST_DEVICE") : ""), "");
  dev.set_memory_budget(10000);
  {
    const spm::DeviceBuffer a = dev.buffer(6000, "a");
    const spm::DeviceBuffer copy = a;
    EXPECT_EQ(dev.memory_in_use(), 6000u);
    EXPECT_EQ(dev.memory_free(), 4000u);
    try {
      dev.buffer(5000, "the second buffer");
      ADD_FAILURE() << "6000 + 5000 bytes fit a budget of 10000";
    } catch (const spm::RuntimeError& e) {
      EXPECT_NE(std::string(e.what()).find("budget of 10000 bytes"), std::string::npos) << e.what();
    }
    const spm::DeviceBuffer b = dev.buffer(4000, "b");
    EXPECT_EQ(dev.memory_free(), 0u);
  }
  EXPECT_EQ(dev.memory_in_use(), 0u);
  EXPECT_NO_THROW(dev.buffer(10000, "all of it"));
}

TEST_F(Limits, AStreamThatCannotFitIsRefusedUpFront) {
  const auto r = run("render " SPM_SCENES_DIR "/cornell_fog.xml -o " + path("o.exr") +
                     " --res 8x8 --spp 1 --associated 1000 --device-memory 1000");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("does not fit"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("budget of 1000 bytes"), std::string::npos) << r.err;
  EXPECT_FALSE(std::ifstream(path("o.exr")).good());
}

TEST_F(Limits, InterruptedRenderWritesTheCompletedPasses) {
  // A render of many passes gets SIGINT once its first pass is done: it
  // finishes the pass in flight, writes a complete, readable image of the
  // completed passes and exits 0 with a note.
  const std::string err = path("err.txt");
  // sh records its pid and execs spm (same pid); the outer subshell records
  // spm's exit code.
  const std::string spm = std::string(SPM_BINARY) + " render " SPM_SCENES_DIR "/cornell_fog.xml -o " +
                          path("i.exr") + " --res 32x24 --spp 1 --passes 100000 --streams 2000 --associated 10";
  const std::string cmd = "( sh -c 'echo $$ > " + path("pid") + "; exec " + spm + "' 2>" + err + " </dev/null; echo $? > " +
                          path("code") + " ) &";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::string pid;
  for (int i = 0; i < 100 && pid.empty(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::ifstream(path("pid")) >> pid;
  }
  ASSERT_FALSE(pid.empty());
  for (int i = 0; i < 1200; ++i) {  // up to a minute for the first pass
    std::stringstream s;
    s << std::ifstream(err).rdbuf();
    if (s.str().find("pass 2/") != std::string::npos) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_EQ(std::system(("kill -INT " + pid).c_str()), 0);
  int code = -1;
  for (int i = 0; i < 1200; ++i) {
    std::ifstream in(path("code"));
    if (in >> code) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(code, 0);
  std::stringstream s;
  s << std::ifstream(err).rdbuf();
  EXPECT_NE(s.str().find("interrupted: writing the image of the"), std::string::npos) << s.str();
  const spm::Image img = spm::read_exr(path("i.exr"));
  EXPECT_EQ(img.width, 32);
  EXPECT_EQ(img.height, 24);
  for (float v : img.rgb) ASSERT_TRUE(std::isfinite(v));
}

}  // namespace
