// The scene loader: every element and property of the SCENES.md subset, and
// one refusal per kind of bad input, each placed at the right file:line.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <glm/glm.hpp>
#include <map>
#include <string>

#include "scene/loader.h"
#include "test_support.h"
#include "util/errors.h"

namespace spm {
namespace {

using Overrides = std::map<std::string, std::string>;

const std::string kName = "test.xml";
const std::string kData = std::string(SPM_TEST_DATA_DIR) + "/scene";
// Every scene needs a light: tests not about lights get this one, last.
const std::string kLight = "<emitter type=\"point\"/>";

std::string document(const std::string& body) {
  return "<scene version=\"3.0.0\">\n" + body + "\n" + kLight + "\n</scene>\n";
}

Scene load(const std::string& body, const Overrides& overrides = {}) {
  return load_scene_string(document(body), kName, overrides);
}

// Loads `body` as if it were a file in tests/data/scene, so relative OBJ paths
// resolve; quad.obj's deliberate degenerate triangle warns on stderr, kept quiet.
Scene load_in_data(const std::string& body) {
  testing::internal::CaptureStderr();
  Scene s = load_scene_string(document(body), kData + "/inline.xml");
  testing::internal::GetCapturedStderr();
  return s;
}

// Loads a scene file, its warnings (e.g. of degenerate triangles) kept quiet.
Scene load_in_data_file(const std::string& path) {
  testing::internal::CaptureStderr();
  Scene s = load_scene(path);
  testing::internal::GetCapturedStderr();
  return s;
}

using spm::test::marked_line;

// The message of the InputError that loading `text` throws ("" if none).
std::string error_of(const std::string& text, const std::string& name = kName, const Overrides& overrides = {}) {
  try {
    load_scene_string(text, name, overrides);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// Loading `body` must fail at its <!--here--> line, with `keyword` in the message.
void expect_error(const std::string& body, const std::string& keyword, const Overrides& overrides = {},
                  const std::string& name = kName) {
  std::string text = document(body);
  std::string where = name + ":" + std::to_string(marked_line(text)) + ": ";
  std::string message = error_of(text, name, overrides);
  ASSERT_FALSE(message.empty()) << "no error for:\n" << body;
  EXPECT_EQ(message.rfind(where, 0), 0u) << "expected at " << where << " got: " << message;
  EXPECT_NE(message.find(keyword), std::string::npos) << "expected '" << keyword << "' in: " << message;
}

void expect_vec3(const glm::vec3& got, const glm::vec3& want, float tol = 1e-5f) {
  EXPECT_NEAR(got.x, want.x, tol);
  EXPECT_NEAR(got.y, want.y, tol);
  EXPECT_NEAR(got.z, want.z, tol);
}

// `rows` is the expected matrix written row by row, as in the scene format.
void expect_matrix(const glm::mat4& got, const float (&rows)[16], float tol = 1e-5f) {
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(got[c][r], rows[r * 4 + c], tol) << "row " << r << " column " << c;
}

glm::vec3 face_normal(const Shape& s, size_t t) {
  const glm::uvec3& tri = s.triangles[t];
  return glm::normalize(glm::cross(s.positions[tri.y] - s.positions[tri.x], s.positions[tri.z] - s.positions[tri.x]));
}

// The to_world of a point light placed with `steps`, to test transforms alone.
glm::mat4 transform_of(const std::string& steps) {
  Scene s = load("<emitter type=\"point\"><transform name=\"to_world\">" + steps + "</transform></emitter>");
  return s.lights.at(0).to_world;
}

// ---- scene, defaults and substitution --------------------------------------

TEST(SceneParser, MinimalSceneKeepsCameraAndIntegratorDefaults) {
  Scene s = load("");
  EXPECT_EQ(s.path, kName);
  EXPECT_FLOAT_EQ(s.camera.fov, 39.597755f);
  EXPECT_EQ(s.camera.width, 768);
  EXPECT_EQ(s.camera.height, 576);
  EXPECT_EQ(s.camera.spp, 4);
  EXPECT_EQ(s.camera.filter, Camera::Filter::Gaussian);
  EXPECT_EQ(s.camera.medium, -1);
  EXPECT_FALSE(s.integrator.present);
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_TRUE(s.shapes.empty());
}

TEST(SceneParser, DefaultSubstitutesWholeAndPartialValues) {
  Scene s = load(R"(<default name="res" value="64"/>
<default name="n" value="2"/>
<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="$res"/>
<integer name="height" value="1$n"/></film></sensor>)");
  EXPECT_EQ(s.camera.width, 64);
  EXPECT_EQ(s.camera.height, 12);
}

TEST(SceneParser, DefaultSubstitutesInTypeAndNameAttributes) {
  Scene s = load(R"(<default name="kind" value="dielectric"/>
<default name="prop" value="int_ior"/>
<bsdf type="$kind"><float name="$prop" value="1.7"/></bsdf>)");
  ASSERT_EQ(s.materials.size(), 1u);
  EXPECT_EQ(s.materials[0].type, Material::Type::Dielectric);
  EXPECT_FLOAT_EQ(s.materials[0].int_ior, 1.7f);
}

TEST(SceneParser, SubstitutionBuildsFileNames) {
  Scene s = load_in_data(R"(<default name="n" value="quad"/>
<shape type="obj"><string name="filename" value="$n.obj"/></shape>)");
  ASSERT_EQ(s.shapes.size(), 1u);
  EXPECT_EQ(s.shapes[0].triangles.size(), 2u);
}

TEST(SceneParser, OverrideReplacesDefault) {
  std::string body = R"(<default name="spp" value="8"/>
<sensor type="perspective"><sampler type="independent"><integer name="sample_count" value="$spp"/></sampler></sensor>)";
  EXPECT_EQ(load(body).camera.spp, 8);
  EXPECT_EQ(load(body, {{"spp", "32"}}).camera.spp, 32);
}

TEST(SceneParser, FirstDefaultWinsAsInMitsuba) {
  Scene s = load(R"(<default name="w" value="10"/>
<default name="w" value="20"/>
<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="$w"/></film></sensor>)");
  EXPECT_EQ(s.camera.width, 10);
}

TEST(SceneParser, RefusesUnknownParameter) {
  expect_error(R"(<sensor type="perspective">
<float name="fov" value="$nope"/> <!--here-->
</sensor>)",
               "unknown parameter '$nope'");
}

TEST(SceneParser, RefusesParameterUsedBeforeItsDefault) {
  expect_error(R"(<sensor type="perspective"><float name="fov" value="$f"/></sensor> <!--here-->
<default name="f" value="30"/>)",
               "'$f'");
}

TEST(SceneParser, RefusesOverrideWithoutDefault) {
  std::string text = document("<default name=\"a\" value=\"1\"/>");
  std::string message = error_of(text, kName, {{"b", "2"}});
  EXPECT_EQ(message.rfind("test.xml:1: ", 0), 0u) << message;
  EXPECT_NE(message.find("'b'"), std::string::npos) << message;
  EXPECT_NE(message.find("<default"), std::string::npos) << message;
}

TEST(SceneParser, RefusesSceneWithoutLight) {
  std::string message = error_of("<scene version=\"3.0.0\">\n<shape type=\"cube\"/>\n</scene>");
  EXPECT_EQ(message, "test.xml:1: scene has no light (no emitter)");
}

TEST(SceneParser, RefusesMissingVersion) {
  EXPECT_EQ(error_of("<scene>\n" + kLight + "</scene>"), "test.xml:1: <scene> needs the attribute 'version'");
}

TEST(SceneParser, RefusesMalformedOrOldVersion) {
  EXPECT_NE(error_of("<scene version=\"three\">" + kLight + "</scene>").find("malformed scene version"),
            std::string::npos);
  EXPECT_NE(error_of("<scene version=\"0.6.0\">" + kLight + "</scene>").find("unsupported scene version"),
            std::string::npos);
}

TEST(SceneParser, RefusesOtherRootElement) {
  std::string message = error_of("<!-- comment -->\n<world version=\"3.0.0\"/>");
  EXPECT_EQ(message.rfind("test.xml:2: ", 0), 0u) << message;
  EXPECT_NE(message.find("<scene>"), std::string::npos) << message;
}

TEST(SceneParser, RefusesMalformedXmlAtItsLine) {
  std::string message = error_of("<scene version=\"3.0.0\">\n<shape type=\"cube\">\n</bsdf>\n</scene>");
  EXPECT_EQ(message.rfind("test.xml:3: malformed XML: ", 0), 0u) << message;
}

TEST(SceneParser, RefusesUnknownTag) { expect_error("<texture type=\"bitmap\"/> <!--here-->", "<texture>"); }

TEST(SceneParser, RefusesUnknownTagInsidePlugin) {
  expect_error(R"(<bsdf type="diffuse">
<color name="reflectance" value="1"/> <!--here-->
</bsdf>)",
               "unknown or unsupported tag <color>");
}

TEST(SceneParser, RefusesUnknownAttribute) {
  expect_error(R"(<bsdf type="diffuse">
<float name="reflectance" value="0.2" unit="m"/> <!--here-->
</bsdf>)",
               "unknown attribute 'unit'");
}

TEST(SceneParser, RefusesMissingRequiredAttribute) {
  expect_error("<bsdf/> <!--here-->", "needs the attribute 'type'");
  expect_error(R"(<sensor type="perspective">
<float name="fov"/> <!--here-->
</sensor>)",
               "needs the attribute 'value'");
}

TEST(SceneParser, RefusesTextInsideElements) {
  expect_error(R"(<bsdf type="diffuse">
oops <!--here-->
</bsdf>)",
               "unexpected text");
}

TEST(SceneParser, RefusesUnknownPluginType) {
  expect_error("<bsdf type=\"roughplastic\"/> <!--here-->", "unsupported bsdf type 'roughplastic'");
  expect_error("<shape type=\"bsplinecurve\"/> <!--here-->", "unsupported shape type 'bsplinecurve'");
  expect_error("<emitter type=\"sunsky\"/> <!--here-->", "unsupported emitter type 'sunsky'");
  expect_error("<medium type=\"nanovdb\"/> <!--here-->", "unsupported medium type");
  expect_error("<sensor type=\"thinlens\"/> <!--here-->", "unsupported sensor type");
}

TEST(SceneParser, RefusesUnknownPropertyWithExactMessage) {
  std::string text = document(R"(<bsdf type="diffuse">
  <float name="radius" value="1"/>
</bsdf>)");
  EXPECT_EQ(error_of(text), "test.xml:3: unknown property 'radius' of bsdf 'diffuse'");
}

TEST(SceneParser, RefusesWrongPropertyTag) {
  expect_error(R"(<shape type="sphere">
<string name="radius" value="1"/> <!--here-->
</shape>)",
               "must be a <float>, not <string>");
}

TEST(SceneParser, RefusesDuplicateProperty) {
  expect_error(R"(<sensor type="perspective">
<float name="fov" value="30"/>
<float name="fov" value="40"/> <!--here-->
</sensor>)",
               "given twice");
}

TEST(SceneParser, RefusesMalformedNumbers) {
  expect_error(R"(<sensor type="perspective">
<float name="fov" value="1.0abc"/> <!--here-->
</sensor>)",
               "malformed number '1.0abc'");
  expect_error(R"(<sensor type="perspective"><film type="hdrfilm">
<integer name="width" value="12.5"/> <!--here-->
</film></sensor>)",
               "malformed integer");
  expect_error(R"(<shape type="cube">
<boolean name="flip_normals" value="yes"/> <!--here-->
</shape>)",
               "malformed boolean");
  expect_error(R"(<bsdf type="diffuse">
<rgb name="reflectance" value="0.1, 0.2"/> <!--here-->
</bsdf>)",
               "1 or 3 numbers");
}

TEST(SceneParser, RefusesNanAndInfinity) {
  expect_error(R"(<sensor type="perspective">
<float name="fov" value="nan"/> <!--here-->
</sensor>)",
               "non-finite");
  expect_error(R"(<medium type="homogeneous">
<rgb name="sigma_t" value="1, inf, 1"/> <!--here-->
</medium>)",
               "non-finite");
  expect_error(R"(<emitter type="point">
<point name="position" x="1e39"/> <!--here-->
</emitter>)",
               "non-finite");
}

// ---- sensor ------------------------------------------------------------------

TEST(SceneParser, PerspectiveSensorWithFilmSamplerAndFilter) {
  Scene s = load(R"(<sensor type="perspective">
  <float name="fov" value="45"/>
  <string name="fov_axis" value="smaller"/>
  <float name="near_clip" value="0.5"/>
  <float name="far_clip" value="500"/>
  <transform name="to_world"><translate x="1" y="2" z="3"/></transform>
  <film type="hdrfilm">
    <integer name="width" value="320"/>
    <integer name="height" value="240"/>
    <string name="pixel_format" value="rgb"/>
    <string name="component_format" value="float32"/>
    <rfilter type="gaussian"><float name="stddev" value="0.25"/></rfilter>
  </film>
  <sampler type="independent">
    <integer name="sample_count" value="16"/>
    <integer name="seed" value="7"/>
  </sampler>
</sensor>)");
  const Camera& c = s.camera;
  EXPECT_FLOAT_EQ(c.fov, 45.0f);
  EXPECT_EQ(c.fov_axis, Camera::FovAxis::Smaller);
  EXPECT_FLOAT_EQ(c.near_clip, 0.5f);
  EXPECT_FLOAT_EQ(c.far_clip, 500.0f);
  expect_vec3(glm::vec3(c.to_world[3]), {1, 2, 3});
  EXPECT_EQ(c.width, 320);
  EXPECT_EQ(c.height, 240);
  EXPECT_EQ(c.filter, Camera::Filter::Gaussian);
  EXPECT_FLOAT_EQ(c.filter_stddev, 0.25f);
  EXPECT_EQ(c.spp, 16);
  EXPECT_EQ(c.where, "test.xml:2");
}

TEST(SceneParser, FovAxisValues) {
  const std::pair<const char*, Camera::FovAxis> cases[] = {{"x", Camera::FovAxis::X},
                                                           {"y", Camera::FovAxis::Y},
                                                           {"smaller", Camera::FovAxis::Smaller},
                                                           {"larger", Camera::FovAxis::Larger},
                                                           {"diagonal", Camera::FovAxis::Diagonal}};
  for (const auto& [name, axis] : cases) {
    Scene s =
        load(std::string("<sensor type=\"perspective\"><string name=\"fov_axis\" value=\"") + name + "\"/></sensor>");
    EXPECT_EQ(s.camera.fov_axis, axis) << name;
  }
  expect_error(R"(<sensor type="perspective">
<string name="fov_axis" value="z"/> <!--here-->
</sensor>)",
               "unknown fov_axis 'z'");
}

TEST(SceneParser, SensorWithoutFovKeepsDefault) {
  Scene s = load("<sensor type=\"perspective\"/>");
  EXPECT_FLOAT_EQ(s.camera.fov, 39.597755f);
}

TEST(SceneParser, BoxFilter) {
  Scene s = load(R"(<sensor type="perspective"><film type="hdrfilm"><rfilter type="box"/></film></sensor>)");
  EXPECT_EQ(s.camera.filter, Camera::Filter::Box);
  expect_error(R"(<sensor type="perspective"><film type="hdrfilm">
<rfilter type="tent"/> <!--here-->
</film></sensor>)",
               "unsupported rfilter type 'tent'");
}

TEST(SceneParser, SensorMediumNestedOrRef) {
  Scene nested = load(R"(<sensor type="perspective">
<medium type="homogeneous"><float name="sigma_t" value="0.5"/></medium>
</sensor>)");
  ASSERT_EQ(nested.media.size(), 1u);
  EXPECT_EQ(nested.camera.medium, 0);
  Scene ref = load(R"(<medium type="homogeneous" id="fog"/>
<medium type="homogeneous" id="smoke"/>
<sensor type="perspective"><ref id="smoke"/></sensor>)");
  EXPECT_EQ(ref.camera.medium, 1);
}

TEST(SceneParser, RefusesBadSensorValues) {
  expect_error(R"(<sensor type="perspective">
<float name="fov" value="0"/> <!--here-->
</sensor>)",
               "fov must be in (0, 180)");
  expect_error(R"(<sensor type="perspective">
<float name="fov" value="180"/> <!--here-->
</sensor>)",
               "fov");
  expect_error(R"(<sensor type="perspective"><film type="hdrfilm">
<integer name="width" value="0"/> <!--here-->
</film></sensor>)",
               "width must be in [1, 16384]");
  expect_error(R"(<sensor type="perspective"><film type="hdrfilm">
<integer name="height" value="16385"/> <!--here-->
</film></sensor>)",
               "height must be in [1, 16384]");
  expect_error(R"(<sensor type="perspective"><sampler type="independent">
<integer name="sample_count" value="0"/> <!--here-->
</sampler></sensor>)",
               "sample_count must be at least 1");
  expect_error(R"(<sensor type="perspective">
<float name="far_clip" value="0.001"/> <!--here-->
</sensor>)",
               "far_clip");
}

TEST(SceneParser, RefusesTwoSensors) {
  expect_error(R"(<sensor type="perspective"/>
<sensor type="perspective"/> <!--here-->)",
               "second <sensor>");
}

TEST(SceneParser, RefusesUnsupportedSampler) {
  expect_error(R"(<sensor type="perspective">
<sampler type="stratified"/> <!--here-->
</sensor>)",
               "unsupported sampler type 'stratified'");
}

// ---- transforms ----------------------------------------------------------------

TEST(SceneParser, TranslateThenRotateLeftMultiplies) {
  // translate (1,0,0), then rotate 90 degrees about z: M = R * T.
  glm::mat4 m = transform_of(R"(<translate x="1"/><rotate z="1" angle="90"/>)");
  const float want[16] = {0, -1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 1};
  expect_matrix(m, want);
  expect_vec3(glm::vec3(m * glm::vec4(0, 0, 0, 1)), {0, 1, 0});
  expect_vec3(glm::vec3(m * glm::vec4(1, 0, 0, 1)), {0, 2, 0});
}

TEST(SceneParser, TranslateValueForm) {
  glm::mat4 m = transform_of(R"(<translate value="1, 2 3"/>)");
  const float want[16] = {1, 0, 0, 1, 0, 1, 0, 2, 0, 0, 1, 3, 0, 0, 0, 1};
  expect_matrix(m, want);
}

TEST(SceneParser, RotateValueFormAxis) {
  glm::mat4 m = transform_of(R"(<rotate value="0, 0, 2" angle="90"/>)");
  expect_vec3(glm::vec3(m * glm::vec4(1, 0, 0, 0)), {0, 1, 0});
}

TEST(SceneParser, ScaleForms) {
  const float uniform[16] = {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1};
  expect_matrix(transform_of(R"(<scale value="2"/>)"), uniform);
  const float per_axis[16] = {1, 0, 0, 0, 0, 2, 0, 0, 0, 0, 3, 0, 0, 0, 0, 1};
  expect_matrix(transform_of(R"(<scale value="1 2 3"/>)"), per_axis);
  const float only_x[16] = {2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  expect_matrix(transform_of(R"(<scale x="2"/>)"), only_x);
}

TEST(SceneParser, MatrixIsRowMajor) {
  const float rows[16] = {0, 0, 1, 5, 1, 0, 0, 6, 0, 1, 0, 7, 0, 0, 0, 1};
  glm::mat4 m = transform_of(R"(<matrix value="0 0 1 5  1 0 0 6  0 1 0 7  0 0 0 1"/>)");
  expect_matrix(m, rows);
  expect_vec3(glm::vec3(m * glm::vec4(1, 0, 0, 1)), {5, 7, 7});
}

TEST(SceneParser, LookatColumnsFollowMitsuba) {
  // dir = (1,0,0); left = cross(up, dir) = (0,1,0); new_up = cross(dir, left) = (0,0,1).
  glm::mat4 m = transform_of(R"(<lookat origin="1, 2, 3" target="5, 2, 3" up="0, 0, 1"/>)");
  expect_vec3(glm::vec3(m[0]), {0, 1, 0});
  expect_vec3(glm::vec3(m[1]), {0, 0, 1});
  expect_vec3(glm::vec3(m[2]), {1, 0, 0});
  expect_vec3(glm::vec3(m[3]), {1, 2, 3});
}

TEST(SceneParser, SensorLookat) {
  Scene s = load(R"(<sensor type="perspective"><transform name="to_world">
<lookat origin="0, 0, -10" target="0, 0, 0" up="0, 1, 0"/></transform></sensor>)");
  // dir = +z, left = cross(+y, +z) = +x, up = +y.
  expect_vec3(glm::vec3(s.camera.to_world[0]), {1, 0, 0});
  expect_vec3(glm::vec3(s.camera.to_world[1]), {0, 1, 0});
  expect_vec3(glm::vec3(s.camera.to_world[2]), {0, 0, 1});
  expect_vec3(glm::vec3(s.camera.to_world[3]), {0, 0, -10});
}

TEST(SceneParser, RefusesBadTransforms) {
  expect_error(R"(<sensor type="perspective"><transform name="to_world">
<lookat origin="0, 0, 0" target="0, 1, 0" up="0, 1, 0"/> <!--here-->
</transform></sensor>)",
               "degenerate <lookat>");
  expect_error(R"(<emitter type="point"><transform name="to_world">
<matrix value="1 0 0 0 0 1 0 0 0 0 1 0"/> <!--here-->
</transform></emitter>)",
               "16 numbers");
  expect_error(R"(<emitter type="point"><transform name="to_world">
<shear value="1"/> <!--here-->
</transform></emitter>)",
               "unknown transform step <shear>");
  expect_error(R"(<emitter type="point"><transform name="to_world">
<rotate angle="30"/> <!--here-->
</transform></emitter>)",
               "non-zero axis");
  expect_error(R"(<emitter type="point"><transform name="to_world">
<translate value="1" x="2"/> <!--here-->
</transform></emitter>)",
               "mixes 'value'");
}

TEST(SceneParser, RefusesSingularShapeTransform) {
  expect_error(R"(<shape type="cube">
<transform name="to_world"> <!--here-->
<scale x="2" y="0"/>
</transform>
</shape>)",
               "singular to_world");
}

// ---- shapes ------------------------------------------------------------------

TEST(SceneParser, RectangleVerticesInWorldSpace) {
  Scene s = load(R"(<shape type="rectangle"><transform name="to_world">
<scale x="2"/><translate z="3"/>
</transform></shape>)");
  ASSERT_EQ(s.shapes.size(), 1u);
  const Shape& r = s.shapes[0];
  EXPECT_EQ(r.kind, Shape::Kind::Mesh);
  ASSERT_EQ(r.positions.size(), 4u);
  ASSERT_EQ(r.triangles.size(), 2u);
  expect_vec3(r.positions[0], {-2, -1, 3});
  expect_vec3(r.positions[1], {2, -1, 3});
  expect_vec3(r.positions[2], {2, 1, 3});
  expect_vec3(r.positions[3], {-2, 1, 3});
  for (size_t t = 0; t < 2; ++t) expect_vec3(face_normal(r, t), {0, 0, 1});
  EXPECT_EQ(r.where, "test.xml:2");
}

TEST(SceneParser, RectangleNormalFollowsRotation) {
  Scene s = load(R"(<shape type="rectangle"><transform name="to_world">
<rotate x="1" angle="90"/></transform></shape>)");
  // Rotating +z by 90 degrees about x gives -y.
  for (size_t t = 0; t < 2; ++t) expect_vec3(face_normal(s.shapes[0], t), {0, -1, 0});
}

TEST(SceneParser, MirroredRectangleKeepsTransformedNormal) {
  // Mitsuba's rectangle normal is to_world applied to +z as a normal: a
  // mirror in x leaves it +z, so the winding must follow.
  Scene s = load(R"(<shape type="rectangle"><transform name="to_world"><scale x="-1"/></transform></shape>)");
  for (size_t t = 0; t < 2; ++t) expect_vec3(face_normal(s.shapes[0], t), {0, 0, 1});
}

TEST(SceneParser, RefusesShearedRectangle) {
  expect_error(R"(<shape type="rectangle">
<transform name="to_world"> <!--here-->
<matrix value="1 1 0 0 0 1 0 0 0 0 1 0 0 0 0 1"/>
</transform></shape>)",
               "shear");
}

TEST(SceneParser, CubeHasTwelveOutwardTriangles) {
  Scene s = load(R"(<shape type="cube"><transform name="to_world"><translate x="10"/></transform></shape>)");
  const Shape& c = s.shapes.at(0);
  ASSERT_EQ(c.triangles.size(), 12u);
  EXPECT_TRUE(c.normals.empty());
  const glm::vec3 center(10, 0, 0);
  for (size_t t = 0; t < c.triangles.size(); ++t) {
    glm::vec3 n = face_normal(c, t);
    const glm::uvec3& tri = c.triangles[t];
    glm::vec3 centroid = (c.positions[tri.x] + c.positions[tri.y] + c.positions[tri.z]) / 3.0f - center;
    // The triangle lies on the face where one coordinate is +-1: that axis, outward.
    glm::vec3 outward(0.0f);
    for (int k = 0; k < 3; ++k)
      if (std::abs(centroid[k]) > 0.999f) outward[k] = centroid[k] > 0.0f ? 1.0f : -1.0f;
    expect_vec3(n, outward);
    for (int k = 0; k < 3; ++k) {
      glm::vec3 local = c.positions[tri[k]] - center;
      EXPECT_FLOAT_EQ(std::max({std::abs(local.x), std::abs(local.y), std::abs(local.z)}), 1.0f);
    }
  }
}

TEST(SceneParser, SphereCenterAndRadiusThenToWorld) {
  Scene s = load(R"(<shape type="sphere">
<point name="center" x="1" y="2" z="3"/>
<float name="radius" value="2"/>
<transform name="to_world"><scale value="3"/><rotate y="1" angle="90"/><translate x="1"/></transform>
</shape>)");
  const Shape& sp = s.shapes.at(0);
  EXPECT_EQ(sp.kind, Shape::Kind::Sphere);
  // scale: (3, 6, 9); rotate 90 about y: (x, y, z) -> (z, y, -x) = (9, 6, -3); translate.
  expect_vec3(sp.center, {10, 6, -3}, 1e-4f);
  EXPECT_NEAR(sp.radius, 6.0f, 1e-5f);
}

TEST(SceneParser, SphereDefaults) {
  Scene s = load("<shape type=\"sphere\"/>");
  expect_vec3(s.shapes.at(0).center, {0, 0, 0});
  EXPECT_FLOAT_EQ(s.shapes.at(0).radius, 1.0f);
}

TEST(SceneParser, RefusesBadSpheres) {
  expect_error(R"(<shape type="sphere">
<float name="radius" value="0"/> <!--here-->
</shape>)",
               "radius must be positive");
  expect_error(R"(<shape type="sphere">
<float name="radius" value="-1"/> <!--here-->
</shape>)",
               "radius must be positive");
  expect_error(R"(<shape type="sphere">
<transform name="to_world"> <!--here-->
<scale x="1" y="2" z="1"/></transform>
</shape>)",
               "scale uniformly");
}

TEST(SceneParser, FlipNormals) {
  Scene s = load(R"(<shape type="cube"><boolean name="flip_normals" value="true"/></shape>
<shape type="cube"/>)");
  EXPECT_TRUE(s.shapes.at(0).flip_normals);
  EXPECT_FALSE(s.shapes.at(1).flip_normals);
}

// The readers' own tests (test_ply.cpp, test_serialized.cpp) check the files;
// these check that the loader finds, places and refuses them.
TEST(SceneParser, PlyAndSerializedMeshesLoad) {
  Scene s = load_in_data(R"(<shape type="ply"><string name="filename" value="../ply/quad_binary_le.ply"/>
<transform name="to_world"><translate z="2"/></transform></shape>
<shape type="serialized"><string name="filename" value="../serialized/two_shapes.serialized"/>
<integer name="shape_index" value="1"/></shape>
<shape type="serialized"><string name="filename" value="../serialized/two_shapes.serialized"/></shape>)");
  ASSERT_EQ(s.shapes.size(), 3u);
  EXPECT_EQ(s.shapes[0].triangles.size(), 3u);  // a quad and a triangle
  EXPECT_FLOAT_EQ(s.shapes[0].positions.at(0).z, 2.0f);
  EXPECT_EQ(s.shapes[1].triangles.size(), 2u);  // the quad, which has no normals: smooth ones, all +z
  ASSERT_EQ(s.shapes[1].normals.size(), 4u);
  for (const glm::vec3& n : s.shapes[1].normals) expect_vec3(n, {0, 0, 1});
  EXPECT_EQ(s.shapes[2].triangles.size(), 4u);  // the tetrahedron
}

TEST(SceneParser, RefusesBadMeshFiles) {
  expect_error(R"(<shape type="ply"> <!--here-->
<string name="filename" value="nothing.ply"/></shape>)",
               "PLY file", {}, kData + "/inline.xml");
  expect_error(R"(<shape type="ply"> <!--here-->
<string name="filename" value="quad.obj"/></shape>)",
               "quad.obj", {}, kData + "/inline.xml");
  expect_error(R"(<shape type="serialized"> <!--here-->
<string name="filename" value="../serialized/two_shapes.serialized"/>
<integer name="shape_index" value="2"/></shape>)",
               "shape", {}, kData + "/inline.xml");
  expect_error(R"(<shape type="serialized"/> <!--here-->)", "needs a 'filename'");
}

// ---- OBJ -----------------------------------------------------------------------

TEST(SceneParser, ObjKeepsNormalsAndDropsDegenerateTriangleWithOneWarning) {
  testing::internal::CaptureStderr();
  Scene s = load_scene_string(document(R"(<shape type="obj">
<string name="filename" value="quad.obj"/>
<transform name="to_world"><translate z="1"/></transform>
</shape>)"),
                              kData + "/inline.xml");
  std::string warnings = testing::internal::GetCapturedStderr();
  const Shape& m = s.shapes.at(0);
  ASSERT_EQ(m.triangles.size(), 2u);
  ASSERT_EQ(m.normals.size(), m.positions.size());
  for (const glm::vec3& n : m.normals) expect_vec3(n, {0, 0, 1});
  for (const glm::vec3& p : m.positions) EXPECT_FLOAT_EQ(p.z, 1.0f);
  for (size_t t = 0; t < 2; ++t) expect_vec3(face_normal(m, t), {0, 0, 1});
  std::string where = kData + "/inline.xml:2: warning: dropped 1 degenerate";
  EXPECT_NE(warnings.find(where), std::string::npos) << warnings;
  EXPECT_EQ(warnings.find("warning", warnings.find("warning") + 1), std::string::npos) << "one warning only";
}

TEST(SceneParser, ObjFaceNormalsDropsVertexNormals) {
  Scene s = load_in_data(R"(<shape type="obj">
<string name="filename" value="quad.obj"/>
<boolean name="face_normals" value="true"/>
</shape>)");
  EXPECT_TRUE(s.shapes.at(0).normals.empty());
  EXPECT_EQ(s.shapes.at(0).triangles.size(), 2u);
}

// Mitsuba 3 computes smooth normals for a mesh file without any: each face
// normal weighted by the face's angle at the vertex. tent.obj is two faces
// meeting at a right angle along the x axis, normals +y and +z. On the ridge,
// vertex 0 has angle pi/2 in both; vertex 1 has pi/4 in the first and
// atan(2) in the second (weights by area, 1:2, or none would differ); the
// other two lie in one face only.
TEST(SceneParser, MeshWithoutNormalsGetsMitsubasSmoothNormals) {
  Scene s = load_in_data(R"(<shape type="obj"><string name="filename" value="tent.obj"/></shape>)");
  const Shape& m = s.shapes.at(0);
  ASSERT_EQ(m.normals.size(), 4u);
  const float pi = 3.14159265f;
  auto blend = [&](float wy, float wz) { return glm::normalize(glm::vec3(0.0f, wy, wz)); };
  // The OBJ reader numbers vertices its own way: find each by its position.
  auto normal_at = [&](const glm::vec3& p) {
    for (size_t i = 0; i < m.positions.size(); ++i)
      if (m.positions[i] == p) return m.normals[i];
    ADD_FAILURE() << "no vertex at " << p.x << " " << p.y << " " << p.z;
    return glm::vec3(0.0f);
  };
  expect_vec3(normal_at({0, 0, 0}), blend(pi / 2, pi / 2));
  expect_vec3(normal_at({1, 0, 0}), blend(pi / 4, std::atan(2.0f)));
  expect_vec3(normal_at({0, 0, -1}), {0, 1, 0});
  expect_vec3(normal_at({0, 2, 0}), {0, 0, 1});
  Scene flat = load_in_data(R"(<shape type="obj"><string name="filename" value="tent.obj"/>
<boolean name="face_normals" value="true"/></shape>)");
  EXPECT_TRUE(flat.shapes.at(0).normals.empty());
}

// Mitsuba's disk (the unit disk in XY, normal +z) and cylinder (an open tube,
// normals outward): meshes whose area, outline and normals are the shapes'.
TEST(SceneParser, DiskAndCylinderAreTheAnalyticShapes) {
  Scene s = load(R"(<shape type="disk"><transform name="to_world"><scale value="2"/><translate z="1"/></transform>
</shape>
<shape type="cylinder"><point name="p0" x="0" y="0" z="-1"/><point name="p1" x="0" y="0" z="3"/>
<float name="radius" value="0.5"/></shape>
<shape type="disk"><transform name="to_world"><scale x="-1"/></transform></shape>)");
  ASSERT_EQ(s.shapes.size(), 3u);
  auto area = [](const Shape& m) {
    double a = 0.0;
    for (const glm::uvec3& t : m.triangles)
      a += 0.5 * glm::length(glm::cross(glm::dvec3(m.positions[t.y] - m.positions[t.x]),
                                        glm::dvec3(m.positions[t.z] - m.positions[t.x])));
    return a;
  };
  const double pi = 3.14159265358979;
  const Shape& disk = s.shapes[0];
  EXPECT_NEAR(area(disk), pi * 4.0, 3e-5 * pi * 4.0);
  for (const glm::vec3& p : disk.positions) {
    EXPECT_FLOAT_EQ(p.z, 1.0f);
    EXPECT_LE(glm::length(glm::vec2(p)), 2.0f * (1.0f + 1e-6f));
  }
  for (size_t t = 0; t < disk.triangles.size(); t += 97) expect_vec3(face_normal(disk, t), {0, 0, 1});
  // A mirroring to_world keeps the normal to_world(+z) as a normal, as for the rectangle.
  for (size_t t = 0; t < s.shapes[2].triangles.size(); t += 97) expect_vec3(face_normal(s.shapes[2], t), {0, 0, 1});
  const Shape& tube = s.shapes[1];
  EXPECT_NEAR(area(tube), 2.0 * pi * 0.5 * 4.0, 3e-5 * 2.0 * pi * 0.5 * 4.0);
  ASSERT_EQ(tube.normals.size(), tube.positions.size());
  for (size_t i = 0; i < tube.positions.size(); ++i) {
    const glm::vec3 radial(tube.positions[i].x, tube.positions[i].y, 0.0f);
    EXPECT_NEAR(glm::length(radial), 0.5f, 1e-6f);
    expect_vec3(tube.normals[i], radial / 0.5f);
  }
  for (size_t t = 0; t < tube.triangles.size(); t += 97) {
    const glm::vec3 c = (tube.positions[tube.triangles[t].x] + tube.positions[tube.triangles[t].y] +
                         tube.positions[tube.triangles[t].z]) / 3.0f;
    EXPECT_GT(glm::dot(face_normal(tube, t), glm::vec3(c.x, c.y, 0.0f)), 0.0f) << "triangle " << t << " faces in";
  }
}

TEST(SceneParser, RefusesBadCylinders) {
  expect_error(R"(<shape type="cylinder">
<float name="radius" value="0"/> <!--here-->
</shape>)",
               "cylinder radius must be positive");
  expect_error(R"(<shape type="cylinder">
<point name="p1" x="0" y="0" z="0"/> <!--here-->
</shape>)",
               "p0 and p1 are the same point");
}

TEST(SceneParser, NormalsUseInverseTransposeUnderNonUniformScale) {
  // The triangle lies in x + z = 0 with matching vertex normals; after
  // scaling x by 2 the plane is x/2 + z = 0, and the transformed normals must
  // still be the (normalized) face normal, which is what the inverse
  // transpose gives and the plain matrix does not.
  Scene s = load_in_data(R"(<shape type="obj">
<string name="filename" value="slanted.obj"/>
<transform name="to_world"><scale x="2"/></transform>
</shape>)");
  const Shape& m = s.shapes.at(0);
  ASSERT_EQ(m.normals.size(), 3u);
  glm::vec3 want = glm::normalize(glm::vec3(0.5f, 0.0f, 1.0f));
  expect_vec3(face_normal(m, 0), want);
  for (const glm::vec3& n : m.normals) expect_vec3(n, want);
}

TEST(SceneParser, RefusesCorruptObj) {
  std::string data = kData + "/inline.xml";
  expect_error(R"(<shape type="obj"> <!--here-->
<string name="filename" value="bad_index.obj"/></shape>)",
               "refers to vertex 9", {}, data);
  expect_error(R"(<shape type="obj"> <!--here-->
<string name="filename" value="zero_index.obj"/></shape>)",
               "zero_index.obj", {}, data);
  expect_error(R"(<shape type="obj"> <!--here-->
<string name="filename" value="no_faces.obj"/></shape>)",
               "no triangles", {}, data);
  expect_error(R"(<shape type="obj"> <!--here-->
<string name="filename" value="partial_normals.obj"/></shape>)",
               "some faces only", {}, data);
}

TEST(SceneParser, RefusesMeshWithOnlyDegenerateTriangles) {
  testing::internal::CaptureStderr();
  expect_error(R"(<shape type="obj"> <!--here-->
<string name="filename" value="degenerate.obj"/></shape>)",
               "no triangles of non-zero area", {}, kData + "/inline.xml");
  testing::internal::GetCapturedStderr();
}

TEST(SceneParser, RefusesMissingAndUnreadableObj) {
  std::string data = kData + "/inline.xml";
  expect_error(R"(<shape type="obj"> <!--here-->
<string name="filename" value="missing.obj"/></shape>)",
               "does not exist", {}, data);
  expect_error(R"(<shape type="obj"> <!--here-->
<string name="filename" value="."/></shape>)",
               "is a directory", {}, data);
  expect_error("<shape type=\"obj\"/> <!--here-->", "needs a 'filename'");
}

// ---- bsdfs -------------------------------------------------------------------

TEST(SceneParser, DiffuseReflectanceForms) {
  Scene s = load(R"(<bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.2 0.3"/></bsdf>
<bsdf type="diffuse"><rgb name="reflectance" value="0.4"/></bsdf>
<bsdf type="diffuse"><float name="reflectance" value="0.6"/></bsdf>
<bsdf type="diffuse"><spectrum name="reflectance" value="0.7"/></bsdf>
<bsdf type="diffuse"/>)");
  ASSERT_EQ(s.materials.size(), 5u);
  for (const Material& m : s.materials) EXPECT_EQ(m.type, Material::Type::Diffuse);
  expect_vec3(s.materials[0].reflectance, {0.1f, 0.2f, 0.3f});
  expect_vec3(s.materials[1].reflectance, glm::vec3(0.4f));
  expect_vec3(s.materials[2].reflectance, glm::vec3(0.6f));
  expect_vec3(s.materials[3].reflectance, glm::vec3(0.7f));
  expect_vec3(s.materials[4].reflectance, glm::vec3(0.5f));
  EXPECT_EQ(s.materials[1].where, "test.xml:3");
}

// Mitsuba 3 gives a shape without bsdf a diffuse 0.5, and an emitter shape
// a black one: its light must not reflect (Shape's constructor; a volpath
// render of cornell_fog is the same with the light's bsdf black or absent).
TEST(SceneParser, ShapeWithoutBsdfIsDiffuseHalfAndBlackWhenItEmits) {
  Scene s = load(R"(<shape type="rectangle"/>
<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
<shape type="rectangle"><bsdf type="diffuse"/><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>)");
  ASSERT_EQ(s.shapes.size(), 3u);
  const auto material = [&](int i) { return s.materials[static_cast<size_t>(s.shapes[i].material)]; };
  for (int i = 0; i < 3; ++i) EXPECT_EQ(material(i).type, Material::Type::Diffuse);
  expect_vec3(material(0).reflectance, glm::vec3(0.5f));
  expect_vec3(material(1).reflectance, glm::vec3(0.0f));
  expect_vec3(material(2).reflectance, glm::vec3(0.5f));
}

TEST(SceneParser, RefusesSpectrumOtherThanGray) {
  expect_error(R"(<bsdf type="diffuse">
<spectrum name="reflectance" value="400:0.1, 700:0.5"/> <!--here-->
</bsdf>)",
               "gray value");
  expect_error(R"(<bsdf type="diffuse">
<spectrum name="reflectance" filename="data.spd"/> <!--here-->
</bsdf>)",
               "gray value");
}

TEST(SceneParser, RefusesReflectanceOutsideUnitRange) {
  expect_error(R"(<bsdf type="diffuse">
<rgb name="reflectance" value="0.5, 1.2, 0.5"/> <!--here-->
</bsdf>)",
               "reflectance must be in [0, 1]");
}

TEST(SceneParser, ConductorWithoutMaterialIsMirror) {
  Scene s = load(R"(<bsdf type="conductor"/>
<bsdf type="conductor"><string name="material" value="none"/></bsdf>)");
  for (const Material& m : s.materials) {
    EXPECT_EQ(m.type, Material::Type::Conductor);
    expect_vec3(m.eta, glm::vec3(0.0f));
    expect_vec3(m.k, glm::vec3(1.0f));
    expect_vec3(m.specular, glm::vec3(1.0f));
  }
}

// Mitsuba 3.9.1's values for its named conductors (tools/conductor_iors.py).
TEST(SceneParser, ConductorMaterialsAndIndices) {
  Scene s = load(R"(<bsdf type="conductor"><string name="material" value="Au"/></bsdf>
<bsdf type="roughconductor"><string name="material" value="Cu"/><float name="alpha" value="0.3"/>
  <string name="distribution" value="ggx"/></bsdf>
<bsdf type="conductor"><rgb name="eta" value="0.2, 0.9, 1.1"/><rgb name="k" value="3.9, 2.4, 2.1"/>
  <rgb name="specular_reflectance" value="0.5"/></bsdf>
<bsdf type="roughconductor"><float name="alpha_u" value="0.2"/><float name="alpha_v" value="0.2"/></bsdf>)");
  ASSERT_EQ(s.materials.size(), 4u);
  expect_vec3(s.materials[0].eta, glm::vec3(0.143036f, 0.375307f, 1.442045f));
  expect_vec3(s.materials[0].k, glm::vec3(3.982997f, 2.385556f, 1.603359f));
  EXPECT_EQ(s.materials[1].type, Material::Type::RoughConductor);
  EXPECT_EQ(s.materials[1].distribution, Material::Distribution::GGX);
  EXPECT_FLOAT_EQ(s.materials[1].alpha, 0.3f);
  expect_vec3(s.materials[1].eta, glm::vec3(0.201005f, 0.923750f, 1.102215f));
  expect_vec3(s.materials[2].eta, glm::vec3(0.2f, 0.9f, 1.1f));
  expect_vec3(s.materials[2].k, glm::vec3(3.9f, 2.4f, 2.1f));
  expect_vec3(s.materials[2].specular, glm::vec3(0.5f));
  // Mitsuba's defaults: Beckmann, alpha 0.1, a perfect mirror's index.
  EXPECT_EQ(s.materials[3].distribution, Material::Distribution::Beckmann);
  EXPECT_FLOAT_EQ(s.materials[3].alpha, 0.2f);
  expect_vec3(s.materials[3].k, glm::vec3(1.0f));
  const std::pair<const char*, const char*> refused[] = {
      {R"(<bsdf type="conductor">
<string name="material" value="Unobtainium"/> <!--here-->
</bsdf>)",
       "unknown conductor material 'Unobtainium'"},
      {R"(<bsdf type="conductor">
<string name="material" value="Au"/> <!--here-->
<rgb name="eta" value="1"/></bsdf>)",
       "either eta and k or a material"},
      {R"(<bsdf type="roughconductor">
<string name="distribution" value="phong"/> <!--here-->
</bsdf>)",
       "unknown distribution 'phong'"},
      {R"(<bsdf type="roughconductor">
<float name="alpha_u" value="0.1"/> <!--here-->
<float name="alpha_v" value="0.3"/></bsdf>)",
       "anisotropic roughness"},
      {R"(<bsdf type="roughdielectric">
<float name="alpha" value="-1"/> <!--here-->
</bsdf>)",
       "alpha must be >= 0"},
  };
  for (const auto& [body, keyword] : refused) expect_error(body, keyword);
}

TEST(SceneParser, PlasticAndRoughDielectric) {
  Scene s = load(R"(<bsdf type="plastic"/>
<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/>
  <float name="int_ior" value="1.6"/><boolean name="nonlinear" value="true"/></bsdf>
<bsdf type="roughdielectric"><string name="int_ior" value="water"/><float name="alpha" value="0.05"/></bsdf>)");
  ASSERT_EQ(s.materials.size(), 3u);
  EXPECT_EQ(s.materials[0].type, Material::Type::Plastic);
  EXPECT_FLOAT_EQ(s.materials[0].int_ior, 1.49f);  // polypropylene, Mitsuba's default
  expect_vec3(s.materials[0].reflectance, glm::vec3(0.5f));
  EXPECT_FALSE(s.materials[0].nonlinear);
  expect_vec3(s.materials[1].reflectance, glm::vec3(0.1f, 0.2f, 0.3f));
  EXPECT_FLOAT_EQ(s.materials[1].int_ior, 1.6f);
  EXPECT_TRUE(s.materials[1].nonlinear);
  EXPECT_EQ(s.materials[2].type, Material::Type::RoughDielectric);
  EXPECT_FLOAT_EQ(s.materials[2].int_ior, 1.333f);
  EXPECT_FLOAT_EQ(s.materials[2].alpha, 0.05f);
  expect_error(R"(<bsdf type="plastic">
<rgb name="diffuse_reflectance" value="1.5"/> <!--here-->
</bsdf>)",
               "diffuse_reflectance must be in [0, 1]");
  expect_error(R"(<bsdf type="twosided">
<bsdf type="roughdielectric"/> <!--here-->
</bsdf>)",
               "cannot wrap a transmissive bsdf");
}

TEST(SceneParser, DielectricIorAsNumbersAndNames) {
  Scene s = load(R"(<bsdf type="dielectric"/>
<bsdf type="dielectric"><float name="int_ior" value="1.7"/><float name="ext_ior" value="1.1"/></bsdf>
<bsdf type="dielectric"><string name="int_ior" value="diamond"/><string name="ext_ior" value="water"/></bsdf>
<bsdf type="dielectric"><string name="int_ior" value="carbon tetrachloride"/></bsdf>)");
  ASSERT_EQ(s.materials.size(), 4u);
  EXPECT_EQ(s.materials[0].type, Material::Type::Dielectric);
  EXPECT_FLOAT_EQ(s.materials[0].int_ior, 1.5046f);
  EXPECT_FLOAT_EQ(s.materials[0].ext_ior, 1.000277f);
  EXPECT_FLOAT_EQ(s.materials[1].int_ior, 1.7f);
  EXPECT_FLOAT_EQ(s.materials[1].ext_ior, 1.1f);
  EXPECT_FLOAT_EQ(s.materials[2].int_ior, 2.419f);
  EXPECT_FLOAT_EQ(s.materials[2].ext_ior, 1.333f);
  EXPECT_FLOAT_EQ(s.materials[3].int_ior, 1.461f);
}

TEST(SceneParser, RefusesBadIor) {
  expect_error(R"(<bsdf type="dielectric">
<float name="int_ior" value="0"/> <!--here-->
</bsdf>)",
               "int_ior must be positive");
  expect_error(R"(<bsdf type="dielectric">
<float name="ext_ior" value="-1.5"/> <!--here-->
</bsdf>)",
               "ext_ior must be positive");
  expect_error(R"(<bsdf type="dielectric">
<string name="int_ior" value="unobtainium"/> <!--here-->
</bsdf>)",
               "unknown int_ior material 'unobtainium'");
}

TEST(SceneParser, NullBsdf) {
  Scene s = load("<bsdf type=\"null\"/>");
  EXPECT_EQ(s.materials.at(0).type, Material::Type::Null);
}

TEST(SceneParser, TwosidedWrapsOneBsdf) {
  Scene s = load(R"(<bsdf type="diffuse" id="gray"><float name="reflectance" value="0.3"/></bsdf>
<bsdf type="twosided" id="both">
  <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.4, 0.6"/></bsdf>
</bsdf>
<bsdf type="twosided"><ref id="gray"/></bsdf>
<shape type="cube"><ref id="both"/></shape>)");
  ASSERT_EQ(s.materials.size(), 3u);
  EXPECT_FALSE(s.materials[0].twosided);
  EXPECT_TRUE(s.materials[1].twosided);
  EXPECT_EQ(s.materials[1].type, Material::Type::Diffuse);
  expect_vec3(s.materials[1].reflectance, {0.2f, 0.4f, 0.6f});
  EXPECT_EQ(s.materials[1].where, "test.xml:3");
  EXPECT_TRUE(s.materials[2].twosided);
  expect_vec3(s.materials[2].reflectance, glm::vec3(0.3f));
  EXPECT_EQ(s.shapes.at(0).material, 1);
}

TEST(SceneParser, NestedBsdfWithIdIsReferencable) {
  Scene s = load(R"(<bsdf type="twosided"><bsdf type="conductor" id="mirror"/></bsdf>
<shape type="cube"><bsdf type="diffuse" id="inner"/></shape>
<shape type="cube"><ref id="mirror"/></shape>
<shape type="cube"><ref id="inner"/></shape>)");
  ASSERT_EQ(s.shapes.size(), 3u);
  EXPECT_EQ(s.materials.at(s.shapes[1].material).type, Material::Type::Conductor);
  EXPECT_FALSE(s.materials.at(s.shapes[1].material).twosided);
  EXPECT_EQ(s.shapes[2].material, s.shapes[0].material);
}

TEST(SceneParser, RefusesBadTwosided) {
  expect_error(R"(<bsdf type="twosided"> <!--here-->
<bsdf type="diffuse"/><bsdf type="diffuse"/>
</bsdf>)",
               "exactly one nested bsdf");
  expect_error(R"(<bsdf type="twosided">
<bsdf type="dielectric"/> <!--here-->
</bsdf>)",
               "transmissive");
}

TEST(SceneParser, ShapeWithoutBsdfGetsNewDefaultDiffuse) {
  Scene s = load(R"(<shape type="cube"/>
<shape type="cube"/>)");
  ASSERT_EQ(s.materials.size(), 2u);
  EXPECT_EQ(s.shapes[0].material, 0);
  EXPECT_EQ(s.shapes[1].material, 1);
  EXPECT_EQ(s.materials[0].type, Material::Type::Diffuse);
  expect_vec3(s.materials[0].reflectance, glm::vec3(0.5f));
  EXPECT_EQ(s.materials[1].where, "test.xml:3");
}

TEST(SceneParser, ShapeWithNestedBsdf) {
  Scene s = load(R"(<shape type="cube"><bsdf type="dielectric"/></shape>)");
  EXPECT_EQ(s.materials.at(s.shapes.at(0).material).type, Material::Type::Dielectric);
}

// ---- ids and refs ---------------------------------------------------------------

TEST(SceneParser, RefsToMediaByRole) {
  Scene s = load(R"(<medium type="homogeneous" id="fog"/>
<medium type="homogeneous" id="water"/>
<shape type="sphere">
  <ref name="interior" id="water"/>
  <ref name="exterior" id="fog"/>
</shape>
<shape type="cube">
  <medium type="homogeneous" name="interior"><float name="sigma_t" value="3"/></medium>
</shape>)");
  EXPECT_EQ(s.shapes.at(0).interior, 1);
  EXPECT_EQ(s.shapes.at(0).exterior, 0);
  EXPECT_EQ(s.shapes.at(1).interior, 2);
  EXPECT_EQ(s.shapes.at(1).exterior, -1);
  expect_vec3(s.media.at(2).sigma_t, glm::vec3(3.0f));
}

TEST(SceneParser, RefusesUnknownRef) {
  expect_error(R"(<shape type="cube">
<ref id="nowhere"/> <!--here-->
</shape>)",
               "unknown id 'nowhere'");
}

TEST(SceneParser, RefusesRefToWrongKind) {
  expect_error(R"(<bsdf type="diffuse" id="white"/>
<shape type="cube">
<ref name="interior" id="white"/> <!--here-->
</shape>)",
               "names a bsdf where a medium is expected");
  expect_error(R"(<medium type="homogeneous" id="fog"/>
<bsdf type="twosided">
<ref id="fog"/> <!--here-->
</bsdf>)",
               "names a medium where a bsdf is expected");
}

TEST(SceneParser, RefusesUnnamedMediumInShape) {
  expect_error(R"(<shape type="cube">
<medium type="homogeneous"/> <!--here-->
</shape>)",
               "name=\"interior\" or name=\"exterior\"");
}

TEST(SceneParser, RefusesDuplicateId) {
  expect_error(R"(<bsdf type="diffuse" id="a"/>
<shape type="cube" id="a"/> <!--here-->)",
               "duplicate id 'a'");
}

// ---- emitters ------------------------------------------------------------------

TEST(SceneParser, AreaEmitterOnShape) {
  Scene s = load(R"(<medium type="homogeneous" id="fog"/>
<shape type="cube"/>
<shape type="rectangle">
  <emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter>
  <ref name="exterior" id="fog"/>
</shape>)");
  ASSERT_EQ(s.lights.size(), 2u);
  const Light& l = s.lights[0];
  EXPECT_EQ(l.type, Light::Type::Area);
  expect_vec3(l.radiance, {1, 2, 3});
  EXPECT_EQ(l.shape, 1);
  EXPECT_EQ(l.medium, 0);
  EXPECT_EQ(l.where, "test.xml:5");
  EXPECT_EQ(s.shapes.at(1).light, 0);
  EXPECT_EQ(s.shapes.at(0).light, -1);
}

TEST(SceneParser, PointEmitterPositionOrToWorld) {
  Scene s = load(R"(<medium type="homogeneous" id="fog"/>
<emitter type="point">
  <rgb name="intensity" value="5"/>
  <point name="position" value="1, 2, 3"/>
  <ref name="medium" id="fog"/>
</emitter>
<emitter type="point">
  <transform name="to_world"><translate x="4" y="5" z="6"/></transform>
</emitter>)");
  ASSERT_EQ(s.lights.size(), 3u);
  EXPECT_EQ(s.lights[0].type, Light::Type::Point);
  expect_vec3(s.lights[0].intensity, glm::vec3(5.0f));
  expect_vec3(s.lights[0].position, {1, 2, 3});
  EXPECT_EQ(s.lights[0].medium, 0);
  expect_vec3(s.lights[1].position, {4, 5, 6});
  EXPECT_EQ(s.lights[1].medium, -1);
  expect_error(R"(<emitter type="point">
<transform name="to_world"><translate x="1"/></transform>
<point name="position" x="1"/> <!--here-->
</emitter>)",
               "either 'position' or 'to_world'");
}

TEST(SceneParser, PointAndVectorForms) {
  Scene s = load(R"(<emitter type="point"><point name="position" y="2"/></emitter>
<emitter type="point"><vector name="position" value="3"/></emitter>)");
  expect_vec3(s.lights.at(0).position, {0, 2, 0});
  expect_vec3(s.lights.at(1).position, {3, 3, 3});
}

TEST(SceneParser, SpotEmitter) {
  Scene s = load(R"(<emitter type="spot">
  <rgb name="intensity" value="2, 3, 4"/>
  <float name="cutoff_angle" value="40"/>
  <transform name="to_world"><lookat origin="0, 5, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
</emitter>
<emitter type="spot"><float name="beam_width" value="10"/></emitter>)");
  const Light& a = s.lights.at(0);
  EXPECT_EQ(a.type, Light::Type::Spot);
  expect_vec3(a.intensity, {2, 3, 4});
  EXPECT_FLOAT_EQ(a.cutoff_angle, 40.0f);
  EXPECT_FLOAT_EQ(a.beam_width, 30.0f);
  expect_vec3(a.position, {0, 5, 0});
  expect_vec3(glm::vec3(a.to_world[2]), {0, -1, 0});  // shines along local +z
  const Light& b = s.lights.at(1);
  EXPECT_FLOAT_EQ(b.cutoff_angle, 20.0f);
  EXPECT_FLOAT_EQ(b.beam_width, 10.0f);
  EXPECT_FLOAT_EQ(load("<emitter type=\"spot\"/>").lights.at(0).beam_width, 15.0f);
}

TEST(SceneParser, RefusesBadEmitters) {
  expect_error("<emitter type=\"area\"/> <!--here-->", "must be nested in a <shape>");
  expect_error(R"(<shape type="cube"><emitter type="area">
<rgb name="radiance" value="1, -1, 1"/> <!--here-->
</emitter></shape>)",
               "radiance must not be negative");
  expect_error(R"(<emitter type="point">
<float name="intensity" value="-2"/> <!--here-->
</emitter>)",
               "intensity must not be negative");
  expect_error(R"(<emitter type="spot">
<float name="beam_width" value="30"/> <!--here-->
</emitter>)",
               "beam_width");
  expect_error(R"(<shape type="cube">
<emitter type="point"/> <!--here-->
</shape>)",
               "only 'area'");
}

// ---- media -------------------------------------------------------------------

TEST(SceneParser, HomogeneousMedium) {
  Scene s = load(R"(<medium type="homogeneous" id="fog">
  <rgb name="sigma_t" value="1, 2, 4"/>
  <rgb name="albedo" value="0.5, 0.25, 1"/>
  <float name="scale" value="0.5"/>
  <phase type="hg"><float name="g" value="-0.3"/></phase>
</medium>
<medium type="homogeneous">
  <float name="sigma_t" value="0.2"/>
  <float name="albedo" value="0.9"/>
  <phase type="isotropic"/>
</medium>
<medium type="homogeneous"><phase type="hg"/></medium>
<medium type="homogeneous"/>)");
  ASSERT_EQ(s.media.size(), 4u);
  expect_vec3(s.media[0].sigma_t, {0.5f, 1.0f, 2.0f});
  expect_vec3(s.media[0].albedo, {0.5f, 0.25f, 1.0f});
  EXPECT_TRUE(s.media[0].hg);
  EXPECT_FLOAT_EQ(s.media[0].g, -0.3f);
  EXPECT_EQ(s.media[0].where, "test.xml:2");
  expect_vec3(s.media[1].sigma_t, glm::vec3(0.2f));
  expect_vec3(s.media[1].albedo, glm::vec3(0.9f));
  EXPECT_FALSE(s.media[1].hg);
  EXPECT_TRUE(s.media[2].hg);
  EXPECT_FLOAT_EQ(s.media[2].g, 0.8f);  // Mitsuba's default
  expect_vec3(s.media[3].sigma_t, glm::vec3(1.0f));
  expect_vec3(s.media[3].albedo, glm::vec3(0.75f));
  EXPECT_FALSE(s.media[3].hg);
}

TEST(SceneParser, RefusesBadMedia) {
  expect_error(R"(<medium type="homogeneous">
<float name="sigma_t" value="-0.1"/> <!--here-->
</medium>)",
               "sigma_t must not be negative");
  expect_error(R"(<medium type="homogeneous">
<rgb name="albedo" value="0.5, 1.5, 0.5"/> <!--here-->
</medium>)",
               "albedo must be in [0, 1]");
  expect_error(R"(<medium type="homogeneous"><phase type="hg">
<float name="g" value="1"/> <!--here-->
</phase></medium>)",
               "g of the hg phase function must be in (-1, 1)");
  expect_error(R"(<medium type="homogeneous"><phase type="hg">
<float name="g" value="-1"/> <!--here-->
</phase></medium>)",
               "(-1, 1)");
  expect_error(R"(<medium type="homogeneous">
<float name="march_step" value="1"/> <!--here-->
</medium>)",
               "unknown property 'march_step' of medium 'homogeneous'");
  expect_error(R"(<medium type="homogeneous">
<bsdf type="diffuse"/> <!--here-->
</medium>)",
               "only <phase>");
  expect_error(R"(<medium type="homogeneous">
<phase type="rayleigh"/> <!--here-->
</medium>)",
               "unsupported phase type 'rayleigh'");
}

// ---- integrator ----------------------------------------------------------------

TEST(SceneParser, SpmIntegratorSettings) {
  Scene s = load(R"(<integrator type="spm">
  <integer name="streams" value="1000"/>
  <integer name="associated" value="10"/>
  <integer name="max_bounces" value="6"/>
  <integer name="passes" value="3"/>
  <integer name="max_depth" value="8"/>
  <float name="radius" value="1.5"/>
  <float name="width" value="2"/>
  <float name="march_step" value="0.25"/>
  <float name="time" value="60"/>
  <string name="estimator" value="paper"/>
</integrator>)");
  const IntegratorSettings& i = s.integrator;
  EXPECT_TRUE(i.present);
  EXPECT_EQ(i.streams, 1000);
  EXPECT_EQ(i.associated, 10);
  EXPECT_EQ(i.max_bounces, 6);
  EXPECT_EQ(i.passes, 3);
  EXPECT_EQ(i.max_depth, 8);
  EXPECT_FLOAT_EQ(i.radius, 1.5f);
  EXPECT_FLOAT_EQ(i.stream_width, 2.0f);
  EXPECT_FLOAT_EQ(i.march_step, 0.25f);
  EXPECT_FLOAT_EQ(i.time, 60.0f);
  EXPECT_EQ(i.estimator, "paper");
  EXPECT_EQ(i.where, "test.xml:2");
}

// An integrator that is neither spm's nor one of Mitsuba's path tracers is
// left to the renderer it is written for.
TEST(SceneParser, OtherIntegratorIsIgnoredUnchecked) {
  Scene s = load(R"(<integrator type="ptracer">
  <integer name="max_depth" value="3"/>
  <whatever name="x"/>
</integrator>)");
  EXPECT_FALSE(s.integrator.present);
  EXPECT_EQ(s.integrator.max_depth, -1);
  EXPECT_EQ(s.integrator.integrator_type, "spm");
}

// Mitsuba's directional emitter: irradiance, travelling along `direction` or
// to_world's +z; it takes no medium, and one fog filling all space would
// leave it dark (Mitsuba renders that black), which is refused.
TEST(SceneParser, DirectionalLights) {
  Scene s = load(R"(<shape type="rectangle"/>
<emitter type="directional"><vector name="direction" x="0" y="-2" z="0"/><rgb name="irradiance" value="3"/></emitter>
<emitter type="directional"><transform name="to_world"><rotate x="1" angle="90"/></transform></emitter>)");
  ASSERT_EQ(s.lights.size(), 3u);
  EXPECT_EQ(s.lights[0].type, Light::Type::Directional);
  expect_vec3(s.lights[0].direction, {0, -1, 0});
  expect_vec3(s.lights[0].irradiance, glm::vec3(3.0f));
  EXPECT_EQ(s.lights[0].medium, -1);
  expect_vec3(s.lights[1].direction, {0, -1, 0});  // +z rotated by 90 degrees about x
  expect_vec3(s.lights[1].irradiance, glm::vec3(1.0f));
  expect_error(R"(<shape type="rectangle"/>
<emitter type="directional"><transform name="to_world"><rotate x="1" angle="90"/></transform>
<vector name="direction" x="0" y="-1" z="0"/> <!--here-->
</emitter>)",
               "either 'direction' or 'to_world'");
  expect_error(R"(<shape type="rectangle"/>
<emitter type="directional">
<vector name="direction" value="0"/> <!--here-->
</emitter>)",
               "must be non-zero");
  expect_error(R"(<shape type="rectangle"/>
<emitter type="directional"><medium type="homogeneous"/> <!--here-->
</emitter>)",
               "<medium> is not allowed in emitter 'directional'");
  expect_error(R"(<sensor type="perspective"><medium type="homogeneous"/></sensor>
<shape type="rectangle"/>
<emitter type="directional"/> <!--here-->)",
               "a medium fills all space");
  expect_error(R"(<emitter type="directional"/> <!--here-->)", "no shape to light");
}

// moment and aov only add outputs: the integrator they wrap is read.
TEST(SceneParser, WrapperIntegratorsAreReadAsTheOneTheyWrap) {
  Scene moment = load(R"(<integrator type="moment">
<integrator type="volpath"><integer name="max_depth" value="3"/></integrator>
</integrator>)");
  EXPECT_EQ(moment.integrator.integrator_type, "volpath");
  EXPECT_EQ(moment.integrator.max_depth, 3);
  Scene aov = load(R"(<integrator type="aov"><string name="aovs" value="dd.y:depth,nn:sh_normal"/>
<integrator type="path"><integer name="max_depth" value="5"/></integrator>
</integrator>)");
  EXPECT_EQ(aov.integrator.integrator_type, "path");
  EXPECT_EQ(aov.integrator.max_depth, 5);
  Scene bare = load(R"(<integrator type="aov"><string name="aovs" value="dd.y:depth"/></integrator>)");
  EXPECT_EQ(bare.integrator.max_depth, -1);
  expect_error(R"(<integrator type="moment">
<bsdf type="diffuse"/> <!--here-->
</integrator>)",
               "<bsdf> is not allowed in integrator 'moment'");
  expect_error(R"(<integrator type="moment"><integrator type="path">
<integer name="rr_depth" value="0"/> <!--here-->
</integrator></integrator>)",
               "rr_depth must be at least 1");
}

// Mitsuba's path tracers are read: their depths, checked like spm's own.
TEST(SceneParser, PathTracerIntegratorsGiveTheirDepths) {
  Scene s = load(R"(<integrator type="volpath"><integer name="max_depth" value="7"/></integrator>)");
  EXPECT_FALSE(s.integrator.present);
  EXPECT_EQ(s.integrator.max_depth, 7);
  EXPECT_EQ(s.integrator.integrator_type, "volpath");
  EXPECT_EQ(s.integrator.source("max_depth"), SettingSource::Scene);
  expect_error(R"(<integrator type="path">
<integer name="rr_depth" value="0"/> <!--here-->
</integrator>)",
               "rr_depth must be at least 1");
  expect_error(R"(<integrator type="volpathmis">
<whatever name="x"/> <!--here-->
</integrator>)",
               "unknown or unsupported tag <whatever> in integrator 'volpathmis'");
}

TEST(SceneParser, IntegratorTypeFromParameter) {
  std::string body = R"(<default name="integrator" value="spm"/>
<integrator type="$integrator"><integer name="max_depth" value="5"/></integrator>)";
  EXPECT_TRUE(load(body).integrator.present);
  EXPECT_FALSE(load(body, {{"integrator", "volpath"}}).integrator.present);
  EXPECT_EQ(load(body, {{"integrator", "volpath"}}).integrator.max_depth, 5);
}

TEST(SceneParser, RefusesBadSpmIntegrator) {
  expect_error(R"(<integrator type="spm">
<integer name="photons" value="5"/> <!--here-->
</integrator>)",
               "unknown property 'photons' of integrator 'spm'");
  expect_error(R"(<integrator type="spm">
<float name="radius" value="0"/> <!--here-->
</integrator>)",
               "radius must be positive");
  expect_error(R"(<integrator type="spm">
<integer name="streams" value="0"/> <!--here-->
</integrator>)",
               "streams must be at least 1");
  expect_error(R"(<integrator type="spm">
<string name="estimator" value="guess"/> <!--here-->
</integrator>)",
               "unknown estimator 'guess'");
  expect_error(R"(<integrator type="volpath"/>
<integrator type="spm"/> <!--here-->)",
               "second <integrator>");
}

// ---- files and includes ----------------------------------------------------------

TEST(SceneParser, LoadsFileWithInclude) {
  testing::internal::CaptureStderr();
  Scene s = load_scene(kData + "/with_include.xml");
  Scene brighter = load_scene(kData + "/with_include.xml", {{"power", "9"}});
  testing::internal::GetCapturedStderr();
  EXPECT_EQ(s.path, kData + "/with_include.xml");
  ASSERT_EQ(s.shapes.size(), 2u);
  ASSERT_EQ(s.lights.size(), 1u);
  expect_vec3(s.lights[0].radiance, glm::vec3(7.0f));
  EXPECT_EQ(s.lights[0].where, kData + "/included.xml:7");
  EXPECT_EQ(s.shapes[0].material, 0);
  EXPECT_EQ(s.shapes[1].material, 0);
  expect_vec3(s.materials[0].reflectance, {0.8f, 0.1f, 0.1f});
  expect_vec3(brighter.lights.at(0).radiance, glm::vec3(9.0f));
}

// search/scene.xml's comment says what Mitsuba 3.9.1 finds (checked with it).
TEST(SceneParser, FindsFilesAsMitsubaDoes) {
  Scene s = load_in_data_file(kData + "/search/scene.xml");
  ASSERT_EQ(s.shapes.size(), 2u);
  for (const Shape& m : s.shapes) EXPECT_EQ(m.triangles.size(), 2u) << m.where << " read the decoy";
  ASSERT_EQ(s.lights.size(), 1u);
  expect_vec3(s.lights[0].intensity, glm::vec3(3.0f));
  EXPECT_EQ(s.lights[0].where, kData + "/search/include/lights.xml:2");
  expect_error(R"(<path value="nowhere"/> <!--here-->)", "<path> folder", {}, kData + "/inline.xml");
  expect_error(R"(<path value="quad.obj"/> <!--here-->)", "does not exist", {}, kData + "/inline.xml");
}

TEST(SceneParser, RefusesIncludeProblems) {
  expect_error("<include filename=\"nothing.xml\"/> <!--here-->", "does not exist");
  try {
    load_scene(kData + "/self_include.xml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    std::string message = e.what();
    EXPECT_EQ(message.rfind(kData + "/self_include.xml:2: ", 0), 0u) << message;
    EXPECT_NE(message.find("includes itself"), std::string::npos) << message;
  }
}

TEST(SceneParser, RefusesMissingOrUnreadableSceneFile) {
  try {
    load_scene(kData + "/missing.xml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  try {
    load_scene(kData);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("is a directory"), std::string::npos) << e.what();
  }
}

// The scenes the project ships must load.
TEST(SceneParser, ShippedScenesLoad) {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(SPM_SCENES_DIR, ec)) {
    if (entry.path().extension() != ".xml") continue;
    SCOPED_TRACE(entry.path().string());
    testing::internal::CaptureStderr();
    EXPECT_NO_THROW(load_scene(entry.path().string()));
    testing::internal::GetCapturedStderr();
  }
}

}  // namespace
}  // namespace spm
