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
#include "film/image_io.h"

namespace {

using Limits = spm::test::CliTest;

nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

TEST_F(Limits, MemoryCapRendersTheSameImageInMoreBatchesAndTiles) {
  const std::string scene = SPM_SCENES_DIR "/cornell_fog.xml";
  const std::string args = " --res 200x150 --spp 1 --passes 2 --streams 2000 --associated 20";
  ASSERT_EQ(run("render " + scene + " -o " + path("a.exr") + args + " --profile-json " + path("a.json")).code, 0);
  // 150 kB: a few dozen streams per batch, 7,500 of the 30,000 pixels per tile.
  const auto capped = run("render " + scene + " -o " + path("b.exr") + args + " --profile-json " + path("b.json"),
                          "SPM_DEVICE_MEMORY=150000");
  ASSERT_EQ(capped.code, 0) << capped.err;
  const spm::Image a = spm::read_exr(path("a.exr")), b = spm::read_exr(path("b.exr"));
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  EXPECT_EQ(0, std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)));
  const auto ja = read_json(path("a.json")), jb = read_json(path("b.json"));
  EXPECT_EQ(ja["kernels"]["emit"]["launches"], 2);  // one batch per pass
  EXPECT_GT(jb["kernels"]["emit"]["launches"].get<int>(), 10);
  EXPECT_EQ(ja["kernels"]["gather"]["launches"], 2);  // one tile per pass
  EXPECT_GT(jb["kernels"]["gather"]["launches"].get<int>(), 2);
  // The flag says the same as the environment variable.
  ASSERT_EQ(run("render " + scene + " -o " + path("c.exr") + args + " --device-memory 150000").code, 0);
  const spm::Image c = spm::read_exr(path("c.exr"));
  EXPECT_EQ(0, std::memcmp(a.rgb.data(), c.rgb.data(), a.rgb.size() * sizeof(float)));
}

TEST_F(Limits, AStreamThatCannotFitIsRefusedUpFront) {
  const auto r = run("render " SPM_SCENES_DIR "/cornell_fog.xml -o " + path("o.exr") +
                     " --res 8x8 --spp 1 --associated 1000 --device-memory 1000");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("does not fit"), std::string::npos) << r.err;
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
