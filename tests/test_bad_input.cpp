// Bad input through the spm executable: one test per class of bad input. Each
// run must exit with code 2, print exactly one line on standard error, name
// the file and line (file:line) when the problem has a line, name the
// problem, and leave no output file behind.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "cli_support.h"
#include "test_support.h"

namespace {

namespace fs = std::filesystem;

using spm::test::count_lines;
using spm::test::plane_scene;
using spm::test::marked_line;
using spm::test::Outcome;

class BadInput : public spm::test::CliTest {
 protected:
  void TearDown() override {
    std::error_code ec;
    fs::permissions(dir_ / "unreadable.xml", fs::perms::owner_all, ec);
    CliTest::TearDown();
  }

  // A tiny render of `scene` to out.exr; `extra` flags go last.
  Outcome render(const std::string& scene, const std::string& extra = "", const std::string& prefix = "") const {
    return run("render " + scene + " -o " + path("out.exr") + " --res 8x8 --spp 1 --streams 100 --associated 2 " +
                   extra,
               prefix);
  }

  // Writes `text` as bad.xml, renders it, and expects the refusal at the
  // line of its <!--here--> marker, naming every one of `keywords`.
  template <typename... Keywords>
  void expect_scene_refused(const std::string& text, const Keywords&... keywords) {
    const std::string file = write("bad.xml", text);
    expect_refused(render(file), file + ":" + std::to_string(marked_line(text)) + ":", keywords...);
  }

  // Exit code 2, one line on stderr that holds `where` (file:line, or the
  // option) and the keywords, and no output file.
  template <typename... Keywords>
  void expect_refused(const Outcome& r, const std::string& where, const Keywords&... keyword_list) const {
    const std::vector<std::string> keywords{std::string(keyword_list)...};
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << "one line expected, got:\n" << r.err;
    EXPECT_EQ(r.err.rfind("spm: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(where), std::string::npos) << "expected '" << where << "' in: " << r.err;
    for (const std::string& keyword : keywords)
      EXPECT_NE(r.err.find(keyword), std::string::npos) << "expected '" << keyword << "' in: " << r.err;
    expect_no_output();
  }

  // Neither the image, its preview nor a temporary file of them exists.
  void expect_no_output() const {
    for (const auto& e : fs::directory_iterator(dir_)) {
      const std::string name = e.path().filename().string();
      EXPECT_TRUE(name.find("out") == std::string::npos && name.find(".tmp") == std::string::npos)
          << "output left after a failed run: " << name;
    }
  }
};

TEST_F(BadInput, ControlTinySceneRenders) {
  const Outcome r = render(write("ok.xml", plane_scene("")));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(path("out.exr")));
  EXPECT_TRUE(fs::exists(path("out.png")));
}

TEST_F(BadInput, MissingSceneFile) {
  expect_refused(render(path("nope.xml")), path("nope.xml"), "does not exist");
}

TEST_F(BadInput, DeviceInsteadOfFile) {
  // Reading /dev/zero would never end.
  expect_refused(render("/dev/zero"), "/dev/zero", "is a device, not a file");
  const std::string text =
      plane_scene("<shape type=\"obj\"> <!--here-->\n  <string name=\"filename\" value=\"/dev/zero\"/>\n</shape>");
  const std::string file = write("bad.xml", text);
  expect_refused(render(file), file + ":" + std::to_string(marked_line(text)) + ":", "OBJ file '/dev/zero' is a device");
}

TEST_F(BadInput, UnreadableSceneFile) {
  const std::string file = write("unreadable.xml", plane_scene(""));
  fs::permissions(file, fs::perms::none);
  std::string prefix;
  if (::access(file.c_str(), R_OK) == 0) {
    // Root reads a chmod 000 file. Run spm as nobody instead when that user
    // can run it (setpriv from util-linux), otherwise there is nothing to test.
    const std::string as_nobody = "setpriv --reuid=65534 --regid=65534 --clear-groups -- ";
    const std::string probe = as_nobody + "sh -c 'test -x " + std::string(SPM_BINARY) + " && ! test -r " + file +
                              "' >/dev/null 2>&1 </dev/null";
    if (::geteuid() != 0 || std::system(probe.c_str()) != 0)
      GTEST_SKIP() << "a chmod 000 file is readable here (running as root) and spm cannot run as nobody";
    prefix = as_nobody;
  }
  const Outcome r = render(file, "", prefix);
  expect_refused(r, file, "cannot read");
  EXPECT_NE(r.err.find("Permission denied"), std::string::npos) << r.err;
}

TEST_F(BadInput, MalformedXml) {
  // An element left open: pugixml reports it where the closing tag is wrong.
  expect_scene_refused(plane_scene("  <shape type=\"cube\">\n<!--here--></scene>"), "malformed XML");
  // Not XML at all.
  const std::string file = write("binary.xml", std::string("\x7f" "ELF\x02\x01\x01\0\0\0", 10));
  expect_refused(render(file), file + ":1:", "malformed XML");
}

TEST_F(BadInput, UnknownPlugin) {
  const std::pair<const char*, const char*> cases[] = {
      {"<shape type=\"torus\"/>", "unsupported shape type 'torus'"},
      {"<bsdf type=\"roughplastic\"/>", "unsupported bsdf type 'roughplastic'"},
      {"<emitter type=\"sunsky\"/>", "unsupported emitter type 'sunsky'"},
      {"<medium type=\"nanovdb\"/>", "unsupported medium type 'nanovdb'"},
      {"<texture type=\"bitmap\"/>", "unknown or unsupported tag <texture>"},
  };
  for (const auto& [element, keyword] : cases) {
    SCOPED_TRACE(element);
    expect_scene_refused(plane_scene(std::string(element) + " <!--here-->"), keyword);
  }
}

TEST_F(BadInput, UnknownProperty) {
  // The README's example, word for word.
  expect_scene_refused(plane_scene("<bsdf type=\"diffuse\">\n<float name=\"radius\" value=\"1\"/> <!--here-->\n</bsdf>"),
                       "unknown property 'radius' of bsdf 'diffuse'");
  // A property Mitsuba's medium has but the subset does not read.
  expect_scene_refused(
      plane_scene("<medium type=\"homogeneous\">\n<float name=\"sample_emitters\" value=\"1\"/> <!--here-->\n</medium>"),
      "unknown property 'sample_emitters'");
}

TEST_F(BadInput, WrongPropertyType) {
  expect_scene_refused(plane_scene("<bsdf type=\"diffuse\">\n<string name=\"reflectance\" value=\"red\"/> <!--here-->\n</bsdf>"),
                       "property 'reflectance' of bsdf 'diffuse' must be an <rgb>");
  expect_scene_refused(
      plane_scene("<shape type=\"sphere\">\n<integer name=\"center\" value=\"1\"/> <!--here-->\n</shape>"),
      "must be a <point>");
  // The right tag with a value of the wrong type.
  expect_scene_refused(plane_scene("<shape type=\"sphere\">\n<float name=\"radius\" value=\"big\"/> <!--here-->\n</shape>"),
                       "malformed number 'big'");
  expect_scene_refused(
      plane_scene("<shape type=\"cube\">\n<boolean name=\"flip_normals\" value=\"yes\"/> <!--here-->\n</shape>"),
      "malformed boolean 'yes'");
}

// A negative or NaN value of each coefficient, in the element that holds it.
TEST_F(BadInput, NegativeOrNanCoefficients) {
  struct Case {
    const char* property;
    const char* element;  // printf-like: %s is the value
    const char* negative_keyword;
  };
  const Case cases[] = {
      {"sigma_t", "<medium type=\"homogeneous\"><rgb name=\"sigma_t\" value=\"%s\"/></medium>", "must not be negative"},
      {"albedo", "<medium type=\"homogeneous\"><rgb name=\"albedo\" value=\"%s\"/></medium>", "must be in [0, 1]"},
      {"reflectance", "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"%s\"/></bsdf>", "must be in [0, 1]"},
      {"radiance",
       "<shape type=\"sphere\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"%s\"/></emitter></shape>",
       "must not be negative"},
      {"intensity", "<emitter type=\"point\"><rgb name=\"intensity\" value=\"%s\"/></emitter>",
       "must not be negative"},
  };
  for (const Case& c : cases) {
    for (const char* value : {"-0.5", "0.5, -1, 0.5", "nan", "0.5, NaN, 0.5", "inf"}) {
      SCOPED_TRACE(std::string(c.property) + " = " + value);
      std::string element = c.element;
      element.replace(element.find("%s"), 2, value);
      if (std::string(value).find('-') != std::string::npos) {
        expect_scene_refused(plane_scene(element + " <!--here-->"), std::string(c.property) + " " + c.negative_keyword);
      } else {
        expect_scene_refused(plane_scene(element + " <!--here-->"),
                             "non-finite number", "in property '" + std::string(c.property) + "'");
      }
    }
  }
}

TEST_F(BadInput, HgAsymmetryOutsideOpenInterval) {
  for (const char* g : {"1", "-1", "1.5", "-7"}) {
    SCOPED_TRACE(g);
    expect_scene_refused(plane_scene(std::string("<medium type=\"homogeneous\"><phase type=\"hg\">\n"
                                                "<float name=\"g\" value=\"") +
                                    g + "\"/> <!--here-->\n</phase></medium>"),
                         "g of the hg phase function must be in (-1, 1)");
  }
  expect_scene_refused(plane_scene("<medium type=\"homogeneous\"><phase type=\"hg\">\n"
                                  "<float name=\"g\" value=\"nan\"/> <!--here-->\n</phase></medium>"),
                       "non-finite number 'nan' in property 'g'");
}

TEST_F(BadInput, PathDepthsOutOfRange) {
  expect_scene_refused(plane_scene("<integrator type=\"spm\">\n<integer name=\"max_depth\" value=\"-2\"/> "
                                   "<!--here-->\n</integrator>"),
                       "max_depth must be at least -1");
  expect_scene_refused(plane_scene("<integrator type=\"spm\">\n<integer name=\"rr_depth\" value=\"0\"/> "
                                   "<!--here-->\n</integrator>"),
                       "rr_depth must be at least 1");
}

TEST_F(BadInput, UndecidableMediumRegion) {
  // An open rectangle names fog on its front side only: rays from the light
  // that meet its front are in fog, the others in the sensor's vacuum.
  expect_scene_refused(plane_scene("<medium type=\"homogeneous\" id=\"fog\"/>\n"
                                   "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"3\"/>"
                                   "<translate y=\"1\" z=\"-1\"/></transform><ref name=\"exterior\" id=\"fog\"/>"
                                   "</shape>\n<emitter type=\"point\"> <!--here-->\n"
                                   "<point name=\"position\" x=\"0\" y=\"1\" z=\"0\"/></emitter>",
                                   false),
                       "cannot tell which medium this emitter sits in");
}

TEST_F(BadInput, ZeroAreaLight) {
  // A rectangle scaled to zero in one axis, with an area emitter.
  expect_scene_refused(plane_scene(R"(<shape type="rectangle">
  <transform name="to_world"> <!--here-->
    <scale x="0"/>
  </transform>
  <emitter type="area"><rgb name="radiance" value="1"/></emitter>
</shape>)"),
                       "zero area");
  // Scaled to 1e-20: every triangle is zero-area in float and dropped.
  expect_scene_refused(plane_scene(R"(<shape type="rectangle"> <!--here-->
  <transform name="to_world"><scale y="1e-20"/></transform>
  <emitter type="area"><rgb name="radiance" value="1"/></emitter>
</shape>)"),
                       "no triangles of non-zero area");
  // A sphere of radius 0.
  expect_scene_refused(plane_scene(R"(<shape type="sphere">
  <float name="radius" value="0"/> <!--here-->
  <emitter type="area"><rgb name="radiance" value="1"/></emitter>
</shape>)"),
                       "radius must be positive");
}

TEST_F(BadInput, ZeroPowerLight) {
  expect_scene_refused(plane_scene(R"(<shape type="rectangle">
  <emitter type="area"> <!--here-->
    <rgb name="radiance" value="0"/>
  </emitter>
</shape>)"),
                       "light emits no power: its radiance is zero");
  expect_scene_refused(plane_scene(R"(<emitter type="spot"> <!--here-->
  <rgb name="intensity" value="0, 0, 0"/>
</emitter>)"),
                       "light emits no power: its intensity is zero");
  // Non-zero radiance, but an area too small for the power to be a float.
  expect_scene_refused(plane_scene(R"(<shape type="sphere">
  <float name="radius" value="1e-30"/>
  <emitter type="area"> <!--here-->
    <rgb name="radiance" value="1"/>
  </emitter>
</shape>)"),
                       "light emits no power: its area is zero or too small");
  // The other way: more power than a float holds.
  expect_scene_refused(plane_scene(R"(<shape type="rectangle">
  <transform name="to_world"><scale value="1e18"/></transform>
  <emitter type="area"> <!--here-->
    <rgb name="radiance" value="1e10"/>
  </emitter>
</shape>)"),
                       "light power overflows");
}

TEST_F(BadInput, SceneWithoutLight) {
  const std::string text = plane_scene("", false);
  const std::string file = write("dark.xml", text);
  expect_refused(render(file), file + ":1:", "scene has no light");
}

TEST_F(BadInput, AbsurdResolutions) {
  const std::string file = write("ok.xml", plane_scene(""));
  for (const char* res : {"0x8", "8x0", "-8x8", "8x-8", "100000x8", "8x100000", "100000x100000", "8x", "x8", "eight"}) {
    SCOPED_TRACE(res);
    expect_refused(run("render " + file + " -o " + path("out.exr") + " --res " + res), "--res:", res);
  }
  // And in the scene file.
  for (const char* value : {"0", "-8", "100000"}) {
    SCOPED_TRACE(value);
    const std::string width = "<integer name=\"width\" value=\"8\"/>";
    std::string text = plane_scene("");
    text.replace(text.find(width), width.size(),
                 std::string("\n<integer name=\"width\" value=\"") + value + "\"/> <!--here-->\n");
    const std::string scene = write("res.xml", text);
    // Without --res, so that the file's value counts.
    expect_refused(run("render " + scene + " -o " + path("out.exr") + " --spp 1 --streams 100 --associated 2"),
                   scene + ":" + std::to_string(marked_line(text)) + ":", "width must be in [1, 16384]");
  }
}

TEST_F(BadInput, UnknownGatherTerms) {
  const std::string file = write("ok.xml", plane_scene(""));
  for (const char* terms : {"bogus", "direct,bogus", "Direct"}) {
    SCOPED_TRACE(terms);
    expect_refused(render(file, std::string("--terms ") + terms), "--terms:", "unknown term", "gather_surface");
  }
}

TEST_F(BadInput, InvalidDeviceSelectors) {
  const std::string file = write("ok.xml", plane_scene(""));
  for (const char* selector : {"9:9", "0:99", "-1:0", "no-such-device", "1:2:3"}) {
    SCOPED_TRACE(selector);
    const Outcome r = render(file, std::string("--device '") + selector + "'");
    expect_refused(r, "--device:", std::string(selector));
    EXPECT_NE(r.err.find("spm devices"), std::string::npos) << r.err;
  }
}

// The OBJ named by a shape at line 9 of the scene (the <!--here--> marker).
class BadObj : public BadInput {
 protected:
  void expect_obj_refused(const std::string& obj, const std::string& keyword, int obj_line = 0) {
    const std::string mesh = write("mesh.obj", obj);
    const std::string text =
        plane_scene("<shape type=\"obj\"> <!--here-->\n  <string name=\"filename\" value=\"mesh.obj\"/>\n</shape>");
    const std::string scene = write("bad.xml", text);
    const Outcome r = render(scene);
    expect_refused(r, scene + ":" + std::to_string(marked_line(text)) + ":", keyword);
    // The OBJ file, and its line when the problem has one.
    EXPECT_NE(r.err.find(obj_line > 0 ? mesh + ":" + std::to_string(obj_line) + ":" : mesh), std::string::npos)
        << r.err;
  }
};

TEST_F(BadObj, GarbageBytes) {
  std::string garbage;
  uint32_t x = 12345;
  for (int i = 0; i < 4096; ++i) {
    x = x * 1664525u + 1013904223u;  // a fixed pseudo-random byte string
    garbage += static_cast<char>(x >> 24);
  }
  // Whatever lines the bytes happen to form, nothing in them is a triangle.
  garbage.erase(std::remove(garbage.begin(), garbage.end(), 'f'), garbage.end());
  expect_obj_refused(garbage, "no triangles");
}

TEST_F(BadObj, GarbageInsideVertexAndFaceLines) {
  expect_obj_refused("v 0 0 0\nv 1 0 \x01\xff\nv 0 1 0\nf 1 2 3\n", "malformed or non-finite vertex position", 2);
  expect_obj_refused("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 \x03\x04\n", "malformed face corner", 5);
  expect_obj_refused("v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n", "non-finite vertex position 'nan'", 2);
}

TEST_F(BadObj, OutOfRangeIndex) {
  expect_obj_refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "a face refers to vertex 9 but the file has 3", 4);
  expect_obj_refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "a face refers to vertex 0 (OBJ indices start at 1)", 4);
  expect_obj_refused("v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n", "vertex -3 (relative) but only 2 precede it", 3);
  expect_obj_refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n", "refers to normal 2 but the file has 1",
                     5);
  expect_obj_refused("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n", "refers to vertex 99999999999999999999",
                     4);
  // A polygon, which tinyobjloader would skip or triangulate past the end.
  expect_obj_refused("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 2 0\nf 1 2 3 4 7\n", "refers to vertex 7", 6);
}

TEST_F(BadObj, FaceWithTwoVertices) { expect_obj_refused("v 0 0 0\nv 1 0 0\nf 1 2\n", "a face has 2 vertices", 3); }

TEST_F(BadInput, DegenerateObjTrianglesAreDroppedWithOneWarning) {
  write("mesh.obj",
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nv 0 0 -1\n"
        "f 1 3 2\nf 1 4 3\n"  // the floor, facing up
        "f 1 5 2\nf 2 2 3\n");  // zero-area: collinear, a repeated vertex
  const std::string text = plane_scene("<shape type=\"obj\"> <!--here-->\n  <string name=\"filename\" value=\"mesh.obj\"/>\n</shape>");
  const std::string scene = write("ok.xml", text);
  const Outcome r = render(scene);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(path("out.exr")));
  int warnings = 0;
  std::istringstream lines(r.err);
  for (std::string line; std::getline(lines, line);) {
    if (line.find("warning") == std::string::npos) continue;
    ++warnings;
    EXPECT_NE(line.find(scene + ":" + std::to_string(marked_line(text)) + ": warning: dropped 2 degenerate"),
              std::string::npos)
        << line;
  }
  EXPECT_EQ(warnings, 1) << r.err;
}

}  // namespace
