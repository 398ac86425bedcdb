// The spm executable: exit codes (0 success, 2 bad input, 1 runtime failure),
// one clear line for bad input, and complete output files.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "cli_support.h"
#include "test_support.h"
#include "film/image_io.h"

namespace {

namespace fs = std::filesystem;

using Cli = spm::test::CliTest;
using spm::test::Outcome;

const std::string kTinyScene = spm::test::plane_scene("", true, 16, 12);

using spm::test::count_lines;

TEST_F(Cli, RendersATinySceneToCompleteFiles) {
  const std::string scene = write("tiny.xml", kTinyScene);
  const Outcome r = run("render " + scene + " -o " + path("out/tiny.exr") + " --spp 2 --passes 2");
  ASSERT_EQ(r.code, 0) << r.err;
  const spm::Image img = spm::read_exr(path("out/tiny.exr"));
  EXPECT_EQ(img.width, 16);
  EXPECT_EQ(img.height, 12);
  EXPECT_TRUE(fs::exists(path("out/tiny.png")));
  double sum = 0;
  for (float v : img.rgb) sum += v;
  EXPECT_GT(sum, 0.0);  // the point light lights the plane
  for (const auto& e : fs::directory_iterator(path("out"))) {
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();
  }
}

TEST_F(Cli, ResolutionOverride) {
  const std::string scene = write("tiny.xml", kTinyScene);
  ASSERT_EQ(run("render " + scene + " -o " + path("r.exr") + " --res 7x5 --spp 1").code, 0);
  const spm::Image img = spm::read_exr(path("r.exr"));
  EXPECT_EQ(img.width, 7);
  EXPECT_EQ(img.height, 5);
}

TEST_F(Cli, MissingSceneFileIsBadInput) {
  const Outcome r = run("render " + path("nope.xml") + " -o " + path("o.exr"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("nope.xml"), std::string::npos) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_FALSE(fs::exists(path("o.exr")));
}

TEST_F(Cli, MalformedXmlNamesFileAndLine) {
  const std::string scene = write("bad.xml", "<scene version=\"3.0.0\">\n  <shape type=\"cube\">\n</scene>\n");
  const Outcome r = run("render " + scene + " -o " + path("o.exr"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("bad.xml:"), std::string::npos) << r.err;
  EXPECT_EQ(count_lines(r.err), 1) << r.err;
  EXPECT_FALSE(fs::exists(path("o.exr")));
}

TEST_F(Cli, UnknownPluginNamesFileAndLine) {
  const std::string scene = write("bad.xml", std::string(kTinyScene).replace(
      kTinyScene.find("rectangle"), 9, "torus"));
  const Outcome r = run("render " + scene + " -o " + path("o.exr"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("bad.xml:7"), std::string::npos) << r.err;
}

TEST_F(Cli, BadDeviceSelectorIsBadInput) {
  const std::string scene = write("tiny.xml", kTinyScene);
  const Outcome r = run("render " + scene + " -o " + path("o.exr") + " --device 9:9");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("9:9"), std::string::npos) << r.err;
  EXPECT_EQ(run("render " + scene + " -o " + path("o.exr") + " --device no-such-device").code, 2);
}

TEST_F(Cli, UsageErrorsAreBadInput) {
  EXPECT_EQ(run("").code, 2);
  EXPECT_EQ(run("render").code, 2);
  EXPECT_EQ(run("render x.xml -o o.exr --spp 0").code, 2);
  EXPECT_EQ(run("render x.xml -o o.exr --no-such-flag").code, 2);
  const std::string scene = write("tiny.xml", kTinyScene);
  EXPECT_EQ(run("render " + scene + " -o " + path("o.exr") + " --res 0x10").code, 2);
  EXPECT_EQ(run("render " + scene + " -o " + path("o.exr") + " -D nodefault=3").code, 2);
}

TEST_F(Cli, StreamOptionsAreValidated) {
  const std::string scene = write("tiny.xml", kTinyScene);
  const std::string base = "render " + scene + " -o " + path("o.exr") + " --spp 1 ";
  EXPECT_EQ(run(base + "--streams 100 --associated 4 --stream-width 0.1 --bounces 2 --march-step 0.5").code, 0);
  for (const char* bad : {"--streams 0", "--associated 0", "--associated 70000", "--stream-width -1", "--bounces 0",
                          "--march-step -0.5", "--stream-width nan"}) {
    const Outcome r = run(base + bad);
    EXPECT_EQ(r.code, 2) << bad;
    EXPECT_EQ(count_lines(r.err), 1) << bad << ": " << r.err;
  }
}

// Reads a binary PLY written by --dump-maps: its vertex count, checking that
// the header declares what the renderer writes and the body has that size.
long ply_vertices(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  std::string line, header;
  long vertices = -1;
  while (std::getline(in, line) && line != "end_header") {
    header += line + "\n";
    if (line.rfind("element vertex ", 0) == 0) vertices = std::stol(line.substr(15));
  }
  EXPECT_NE(header.find("format binary_little_endian 1.0"), std::string::npos);
  EXPECT_NE(header.find("property float flux_g"), std::string::npos);
  const std::streampos body = in.tellg();
  in.seekg(0, std::ios::end);
  EXPECT_EQ(static_cast<long>(in.tellg() - body), vertices * (6 * 4 + 3)) << file;
  return vertices;
}

TEST_F(Cli, DumpMapsWritesPlyPointClouds) {
  std::string scene = kTinyScene;
  // Put the light and the plane in fog, so both maps get records.
  scene.replace(scene.find("<shape"), 0,
                "<medium type=\"homogeneous\" id=\"fog\"><float name=\"sigma_t\" value=\"0.3\"/></medium>");
  scene.replace(scene.find("</shape>"), 0, "<ref name=\"exterior\" id=\"fog\"/>");
  scene.replace(scene.find("</emitter>"), 0, "<ref id=\"fog\"/>");
  const std::string file = write("fog.xml", scene);
  const Outcome r = run("render " + file + " -o " + path("o.exr") + " --spp 1 --streams 500 --associated 4 --dump-maps " +
                        path("maps/m"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_GT(ply_vertices(path("maps/m_volume.ply")), 0);
  EXPECT_GT(ply_vertices(path("maps/m_surface.ply")), 0);
}

TEST_F(Cli, TimeBudgetRendersPassesUntilItIsSpent) {
  // Functional, not a speed test: a pass of this scene takes milliseconds, so
  // an 8 s budget (which also covers loading the kernel programs on a loaded
  // machine) holds many; the first pass always runs, however small the budget.
  const std::string scene = write("tiny.xml", kTinyScene);
  const std::string base = "render " + scene + " -o " + path("t.exr") + " --spp 1 --streams 50 --associated 2 ";
  Outcome r = run(base + "--time 8");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto passes = [](const std::string& err) {
    const auto at = err.find("spm: wrote ");
    const auto open = err.find('(', at);
    return std::stoi(err.substr(open + 1));
  };
  EXPECT_GE(passes(r.err), 2) << r.err;
  r = run(base + "--time 0.000001");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(passes(r.err), 1) << r.err;
  // A pass count given with it wins.
  r = run(base + "--time 3 --passes 2");
  EXPECT_EQ(passes(r.err), 2) << r.err;
}

TEST_F(Cli, HelpAndDevicesSucceed) {
  EXPECT_EQ(run("--help").code, 0);
  EXPECT_EQ(run("render --help").code, 0);
  EXPECT_EQ(run("devices --help").code, 0);
  EXPECT_EQ(run("devices").code, 0);
}

TEST_F(Cli, KernelCompileErrorIsRuntimeFailureWithBuildLog) {
  const std::string scene = write("tiny.xml", kTinyScene);
  fs::copy(SPM_KERNEL_SOURCE_DIR, path("kernels"), fs::copy_options::recursive);
  write("kernels/spm_gather.cl", "__kernel void spm_gather(__global float* x) { this is not C; }\n");
  const Outcome r = run("render " + scene + " -o " + path("o.exr") + " --kernel-dir " + path("kernels"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("CL_BUILD_PROGRAM_FAILURE"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("spm_gather.cl:1"), std::string::npos) << r.err;  // the device's build log
  EXPECT_FALSE(fs::exists(path("o.exr")));
}

}  // namespace

namespace {

// spm compare prints the measures of tools/compare.py: here on two 2x1
// images whose relMSE is worked out by hand.
TEST_F(Cli, CompareMeasuresAgainstAReference) {
  spm::Image a{2, 1, {1.0f, 1.0f, 1.0f, 0.5f, 0.5f, 0.5f}};
  spm::Image b{2, 1, {1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f}};
  spm::write_exr(path("a.exr"), a);
  spm::write_exr(path("b.exr"), b);
  const auto r = run("compare " + path("a.exr") + " " + path("b.exr"));
  ASSERT_EQ(r.code, 0) << r.err;
  // Three channels of pixel 1 differ by 0.5: relMSE = 3 * 0.25 / 1.01 / 6.
  const double relmse = 3 * 0.25 / 1.01 / 6, rmse = std::sqrt(3 * 0.25 / 6);
  double got_relmse = 0, got_rmse = 0;
  ASSERT_EQ(std::sscanf(r.out.c_str(), "RMSE %lf relMSE %lf", &got_rmse, &got_relmse), 2) << r.out;
  EXPECT_NEAR(got_relmse, relmse, 1e-5 * relmse);
  EXPECT_NEAR(got_rmse, rmse, 1e-5 * rmse);
  EXPECT_NE(r.out.find("mean    image 0.75 0.75 0.75"), std::string::npos) << r.out;
  // Another size is bad input, named.
  spm::write_exr(path("c.exr"), spm::Image{1, 1, {1.0f, 1.0f, 1.0f}});
  const auto bad = run("compare " + path("c.exr") + " " + path("b.exr"));
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("1x1 but the reference is 2x1"), std::string::npos) << bad.err;
  EXPECT_EQ(count_lines(bad.err), 1) << bad.err;
}

}  // namespace
