// Running the spm executable from tests: a scratch directory per test, the
// exit code and standard error of each run.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace spm::test {

// Fog, a glass sphere and a diffuse floor around a point light: every stream
// and gather path of the renderer in a scene small enough for a simulator.
inline const char* kFogGlassScene = R"(<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="0, 1, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
  </sensor>
  <medium type="homogeneous" id="fog"><float name="sigma_t" value="0.3"/><float name="albedo" value="0.8"/></medium>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform>
    <ref name="exterior" id="fog"/></shape>
  <shape type="sphere"><point name="center" x="0.5" y="0.5" z="0"/><float name="radius" value="0.4"/>
    <bsdf type="dielectric"/><ref name="exterior" id="fog"/></shape>
  <emitter type="point"><point name="position" x="0" y="2" z="0"/><rgb name="intensity" value="5"/>
    <ref id="fog"/></emitter>
</scene>
)";

// kFogGlassScene with its fog made heterogeneous: sigma_t from smoke.vol
// (beside the scene file; write_smoke_grid) over the null cube [-1.5, 1.5]^3
// around the light, the sphere and the floor, which hold the medium.
inline const char* kSmokeGlassScene = R"(<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="0, 1, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
  </sensor>
  <medium type="heterogeneous" id="smoke">
    <volume name="sigma_t" type="gridvolume"><string name="filename" value="smoke.vol"/>
      <transform name="to_world"><scale value="3"/><translate value="-1.5, -1.5, -1.5"/></transform></volume>
    <float name="scale" value="0.6"/><rgb name="albedo" value="0.9, 0.8, 0.7"/>
  </medium>
  <shape type="cube"><transform name="to_world"><scale value="1.5"/></transform><bsdf type="null"/>
    <ref name="interior" id="smoke"/></shape>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform></shape>
  <shape type="sphere"><point name="center" x="0.5" y="0.5" z="0"/><float name="radius" value="0.4"/>
    <bsdf type="dielectric"/></shape>
  <emitter type="point"><point name="position" x="0" y="1" z="0"/><rgb name="intensity" value="5"/></emitter>
</scene>
)";

// A plane under a point light, width x height pixels: the smallest scene that
// renders. `body` goes after the plane; `light` false leaves the light out.
inline std::string plane_scene(const std::string& body = "", bool light = true, int width = 8, int height = 8) {
  return std::string(R"(<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="0, 1, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value=")") +
         std::to_string(width) + R"("/><integer name="height" value=")" + std::to_string(height) + R"("/></film>
  </sensor>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform></shape>
)" + (light ? "  <emitter type=\"point\"><point name=\"position\" x=\"0\" y=\"2\" z=\"0\"/>"
                "<rgb name=\"intensity\" value=\"5\"/></emitter>\n"
              : "") +
         body + "\n</scene>\n";
}

struct Outcome {
  int code;
  std::string err;
  std::string out;
};

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("spm_" + std::to_string(::getpid()) + "_" + std::string(info->test_suite_name()) + "_" +
            std::string(info->name()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name)) << text;
    return path(name);
  }

  // Runs `prefix spm args` (prefix: environment or a wrapper such as
  // oclgrind), spm being this build's unless `binary` names another.
  Outcome run(const std::string& args, const std::string& prefix = "", const std::string& binary = SPM_BINARY) const {
    // Not named *out*: the bad-input tests check that no output file is left.
    const std::string err = path("stderr.txt"), out = path("printed.txt");
    const std::string cmd = prefix + " " + binary + " " + args + " >" + out + " 2>" + err + " </dev/null";
    const int status = std::system(cmd.c_str());
    const auto read = [](const std::string& file) {
      std::ifstream in(file);
      std::stringstream s;
      s << in.rdbuf();
      return s.str();
    };
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read(err), read(out)};
  }

  std::filesystem::path dir_;
};

}  // namespace spm::test
