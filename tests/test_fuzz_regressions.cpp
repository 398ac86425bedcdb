// Inputs that crashed the scene loader or got through it wrongly, found while
// fuzzing it (tools/fuzz.sh), kept as regression tests: every file in
// tests/data/fuzz/ must be refused with spm::InputError, nothing else.
// fuzz_scene-*.xml go through load_scene_string as the fuzz_scene target
// loads them, fuzz_obj-*.obj through parse_obj as fuzz_obj does.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "scene/loader.h"
#include "scene/obj.h"
#include "util/errors.h"

namespace spm {
namespace {

namespace fs = std::filesystem;

const std::string kFuzzData = std::string(SPM_TEST_DATA_DIR) + "/fuzz";
// The name fuzz_scene gives its input: relative file names resolve to tests/data/scene.
const std::string kFuzzSceneName = std::string(SPM_TEST_DATA_DIR) + "/scene/fuzz.xml";

std::string read(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The message of the InputError `load` throws; "" (and a failure) if it throws none.
template <typename Load>
std::string refusal(const Load& load) {
  try {
    load();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted";
  return "";
}

TEST(FuzzRegressions, EverySavedInputIsRefusedWithInputError) {
  int scenes = 0, objs = 0;
  for (const auto& entry : fs::directory_iterator(kFuzzData)) {
    const std::string name = entry.path().filename().string();
    const std::string text = read(entry.path());
    SCOPED_TRACE(name);
    if (name.rfind("fuzz_scene-", 0) == 0) {
      ++scenes;
      EXPECT_NE(refusal([&] { load_scene_string(text, kFuzzSceneName); }), "");
    } else if (name.rfind("fuzz_obj-", 0) == 0) {
      ++objs;
      for (bool vertex_normals : {true, false})
        EXPECT_NE(refusal([&] { parse_obj(text, name, vertex_normals, "fuzz.xml:1"); }), "");
    } else {
      ADD_FAILURE() << "tests/data/fuzz/" << name << ": name it fuzz_scene-*.xml or fuzz_obj-*.obj";
    }
  }
  EXPECT_GT(scenes, 0);
  EXPECT_GT(objs, 0);
}

TEST(FuzzRegressions, NestedTwosidedIsRefusedAtTheInnerBsdf) {
  const std::string message =
      refusal([&] { load_scene_string(read(kFuzzData + "/fuzz_scene-nested-twosided.xml"), "nested.xml"); });
  EXPECT_EQ(message.rfind("nested.xml:7: ", 0), 0u) << message;
  EXPECT_NE(message.find("cannot wrap another twosided bsdf"), std::string::npos) << message;
}

// 100,000 nested twosided bsdfs (2.5 MB, too big for the fuzzer's inputs
// and for the repository): a stack overflow before, a refusal now.
TEST(FuzzRegressions, DeeplyNestedTwosidedIsRefusedNotAStackOverflow) {
  const int depth = 100000;
  std::string xml = "<scene version=\"3.0.0\"><emitter type=\"point\"/><shape type=\"cube\">";
  xml.reserve(xml.size() + depth * 32);
  for (int i = 0; i < depth; ++i) xml += "<bsdf type=\"twosided\">";
  xml += "<bsdf type=\"diffuse\"/>";
  for (int i = 0; i < depth; ++i) xml += "</bsdf>";
  xml += "</shape></scene>";
  EXPECT_NE(refusal([&] { load_scene_string(xml, "deep.xml"); }).find("cannot wrap another twosided"),
            std::string::npos);
}

TEST(FuzzRegressions, ObjIndexBeyondIntIsRefusedAtItsLine) {
  const std::string message =
      refusal([&] { parse_obj(read(kFuzzData + "/fuzz_obj-huge-index.obj"), "huge.obj", true, "s.xml:3"); });
  EXPECT_EQ(message.rfind("s.xml:3: OBJ file huge.obj:6: a face refers to vertex 99999999999999999999", 0), 0u)
      << message;
}

// fuzz_obj (tests/data/fuzz/fuzz_obj-vw-joint-overflow.obj): tinyobjloader
// read the joint id of a "vw" (skin weight) line, 1e38, into an int, which is
// undefined behaviour. Lines the renderer does not use no longer reach it:
// a mesh with such lines, bad ones included, loads as its faces say.
TEST(FuzzRegressions, ObjLinesTheRendererDoesNotUseNeverReachTinyobjloader) {
  const std::string obj =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nvw 0 1e38 1\nt crease 99999999999/0/0\nl 1 2\np 7\nusemtl x\nf 1 2 3\n";
  try {
    const Mesh mesh = parse_obj(obj, "extra.obj", true, "s.xml:1");
    EXPECT_EQ(mesh.triangles.size(), 1u);
    EXPECT_EQ(mesh.positions.size(), 3u);
  } catch (const InputError& e) {
    ADD_FAILURE() << e.what();
  }
  // Texture coordinates are checked like positions, at their line.
  EXPECT_NE(refusal([&] { parse_obj("v 0 0 0\nvt 0.5 1e39\n", "vt.obj", true, "s.xml:1"); })
                .find("vt.obj:2: malformed or non-finite texture coordinate '1e39'"),
            std::string::npos);
}

// Found while writing the bad-input tests: in float, a mesh scaled by 1e13
// overflowed the singularity test of its to_world (refused as "singular"),
// and one scaled by 1e-13 underflowed the zero-area test of its triangles
// (refused as having none). Both are fine shapes.
TEST(FuzzRegressions, TinyAndHugeScalesAreNeitherSingularNorDegenerate) {
  for (const char* scale : {"1e-13", "1e13"}) {
    SCOPED_TRACE(scale);
    const std::string xml = std::string("<scene version=\"3.0.0\"><emitter type=\"point\"/>") +
                            "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"" + scale +
                            "\"/></transform></shape>" + "<shape type=\"cube\"><transform name=\"to_world\"><scale value=\"" +
                            scale + "\"/></transform></shape></scene>";
    try {
      const Scene s = load_scene_string(xml, "scale.xml");
      ASSERT_EQ(s.shapes.size(), 2u);
      EXPECT_EQ(s.shapes[0].triangles.size(), 2u);
      EXPECT_EQ(s.shapes[1].triangles.size(), 12u);
    } catch (const InputError& e) {
      ADD_FAILURE() << e.what();
    }
  }
}

}  // namespace
}  // namespace spm
