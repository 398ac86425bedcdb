// The gather's segment walker (kernels/lib/walk.h) against paths worked out
// by hand: a null boundary, nested media, glass, a mirror, an escape, a
// shadow ray's reach, and the random-number budget at its caps.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "scene/gpu_scene.h"
#include "scene/loader.h"
#include "test_support.h"

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// One segment: its extent, medium and the material type it ends on (-1: none).
struct Segment {
  float t0, t1;
  int medium;
  int ends;
};

struct Walked {
  std::vector<Segment> segments;
  std::vector<uint32_t> events, lanes;
  bool capped = false;
};

constexpr int kSegments = 512;  // SPM_WALK_TEST_SEGMENTS

// A scene of `shapes` with a far point light, which the walks do not meet.
spm::Scene scene_of(const std::string& body) {
  const std::string xml = R"(<scene version="3.0.0">
  <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/>
    <integer name="height" value="4"/></film></sensor>
  <medium type="homogeneous" id="a"><float name="sigma_t" value="0.1"/></medium>
  <medium type="homogeneous" id="b"><float name="sigma_t" value="0.2"/></medium>
  <emitter type="point"><point name="position" x="0" y="500" z="0"/></emitter>
)" + body + "</scene>";
  return spm::load_scene_string(xml, "walk.xml", {});
}

// spm_walk over one ray from `o` in `medium` along `d` to `reach`.
Walked walk(const spm::Scene& scene, glm::vec3 o, int medium, glm::vec3 d, float reach, bool ray, float u = 0.5f) {
  auto& dev = spm::test::device();
  const spm::SceneTables tables = spm::flatten_scene(scene, 4, 4);
  const spm::GpuScene gpu(dev, tables);
  const cl::Buffer ob = dev.upload("origins", std::vector<cl_float4>{{{o.x, o.y, o.z, float(medium)}}});
  const cl::Buffer db = dev.upload("directions", std::vector<cl_float4>{{{d.x, d.y, d.z, reach}}});
  const spm::DeviceBuffer sb = dev.buffer(sizeof(cl_float4) * kSegments, "segments", CL_MEM_WRITE_ONLY);
  const spm::DeviceBuffer rb = dev.buffer(sizeof(cl_uint2) * kSegments, "draws", CL_MEM_WRITE_ONLY);
  const spm::DeviceBuffer cb = dev.buffer(sizeof(cl_uint), "counts", CL_MEM_WRITE_ONLY);
  cl::Kernel k = dev.kernel("spm_intersect", "spm_walk");
  spm::set_args(k, gpu, spm::arg("origins", ob), spm::arg("directions", db), spm::arg("segments", sb),
                spm::arg("draws", rb), spm::arg("counts", cb), spm::arg("count", cl_uint(1)),
                spm::arg("ray", cl_uint(ray)), spm::arg("u", u));
  dev.launch(k, 1);
  const cl_uint n = dev.download<cl_uint>(cb, 1)[0];
  Walked w;
  w.capped = n >> 31;
  const auto segs = dev.download<cl_float4>(sb, n & 0x7fffffffu);
  const auto draws = dev.download<cl_uint2>(rb, n & 0x7fffffffu);
  for (size_t i = 0; i < segs.size(); ++i) {
    w.segments.push_back({segs[i].s[0], segs[i].s[1], int(segs[i].s[2]), int(segs[i].s[3])});
    w.events.push_back(draws[i].s[0]);
    w.lanes.push_back(draws[i].s[1]);
  }
  return w;
}

// The segments as expected, to 1e-3 (the walk leaves a surface a little
// off it); an infinite t1 exactly.
void expect_segments(const Walked& w, const std::vector<Segment>& want) {
  ASSERT_EQ(w.segments.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    SCOPED_TRACE("segment " + std::to_string(i));
    EXPECT_NEAR(w.segments[i].t0, want[i].t0, 1e-3);
    if (std::isinf(want[i].t1)) {
      EXPECT_TRUE(std::isinf(w.segments[i].t1));
    } else {
      EXPECT_NEAR(w.segments[i].t1, want[i].t1, 1e-3);
    }
    EXPECT_EQ(w.segments[i].medium, want[i].medium);
    EXPECT_EQ(w.segments[i].ends, want[i].ends);
  }
}

const int kNull = SPM_MAT_NULL, kGlass = SPM_MAT_DIELECTRIC, kMirror = SPM_MAT_CONDUCTOR, kNone = -1;

// tr_lane of lib/walk.h, written out: call c, segment i.
uint32_t lane(uint32_t call, uint32_t i) { return ((call << 5) | i) << 16; }

TEST(Walk, CrossesANullBoundaryIntoItsMedium) {
  // The cube [-1, 1]^3 holds medium a (index 0); the ray comes from x = -3.
  const spm::Scene s = scene_of(R"(<shape type="cube"><bsdf type="null"/><ref name="interior" id="a"/></shape>)");
  const Walked w = walk(s, {-3.0f, 0.1f, 0.2f}, -1, {1.0f, 0.0f, 0.0f}, kInf, false);
  expect_segments(w, {{0, 2, -1, kNull}, {0, 2, 0, kNull}, {0, kInf, -1, kNone}});
  // A path: an event per segment from the first's, transmittance lane 0.
  EXPECT_EQ(w.events, (std::vector<uint32_t>{1000, 1001, 1002}));
  EXPECT_EQ(w.lanes, (std::vector<uint32_t>(3, lane(0, 0))));
  EXPECT_FALSE(w.capped);
}

TEST(Walk, NestedMediaSwitchAtEachBoundary) {
  // Cube of half-edge 2 holding a, and in it the unit cube holding b.
  const spm::Scene s = scene_of(R"(
  <shape type="cube"><transform name="to_world"><scale value="2"/></transform><bsdf type="null"/>
    <ref name="interior" id="a"/></shape>
  <shape type="cube"><bsdf type="null"/><ref name="interior" id="b"/><ref name="exterior" id="a"/></shape>)");
  const Walked w = walk(s, {-3.0f, 0.1f, 0.2f}, -1, {1.0f, 0.0f, 0.0f}, kInf, false);
  expect_segments(w, {{0, 1, -1, kNull}, {0, 1, 0, kNull}, {0, 2, 1, kNull}, {0, 1, 0, kNull}, {0, kInf, -1, kNone}});
}

TEST(Walk, GlassRefractsOrReflectsByTheUniform) {
  const spm::Scene s = scene_of(R"(<shape type="sphere"><bsdf type="dielectric"/></shape>)");
  // Head-on through the unit sphere's centre: straight through, or back.
  const Walked through = walk(s, {-3.0f, 0.0f, 0.0f}, -1, {1.0f, 0.0f, 0.0f}, kInf, false, 0.9f);
  expect_segments(through, {{0, 2, -1, kGlass}, {0, 2, -1, kGlass}, {0, kInf, -1, kNone}});
  const Walked back = walk(s, {-3.0f, 0.0f, 0.0f}, -1, {1.0f, 0.0f, 0.0f}, kInf, false, 0.001f);
  expect_segments(back, {{0, 2, -1, kGlass}, {0, kInf, -1, kNone}});
}

TEST(Walk, AMirrorTurnsThePathBack) {
  // A mirror cube; the ray meets its face x = -1 at 45 degrees in the xz plane.
  const spm::Scene s = scene_of(R"(<shape type="cube"><bsdf type="conductor"/></shape>)");
  const float c = std::sqrt(0.5f);
  const Walked w = walk(s, {-3.0f, 0.0f, -2.0f}, -1, {c, 0.0f, c}, kInf, false);
  expect_segments(w, {{0, 2.0f / c, -1, kMirror}, {0, kInf, -1, kNone}});
}

TEST(Walk, AnEscapingRayIsOneSegmentInItsMedium) {
  const spm::Scene s = scene_of(R"(<shape type="sphere"><bsdf type="diffuse"/></shape>)");
  const Walked w = walk(s, {0.0f, 5.0f, 0.0f}, 1, {0.0f, 1.0f, 0.0f}, kInf, false);
  expect_segments(w, {{0, kInf, 1, kNone}});
  // And a path stops at a diffuse surface: the caller ends it there.
  const Walked stop = walk(s, {0.0f, 5.0f, 0.0f}, -1, {0.0f, -1.0f, 0.0f}, kInf, false);
  expect_segments(stop, {{0, 4, -1, SPM_MAT_DIFFUSE}});
}

TEST(Walk, AShadowRayCarriesItsReachAcrossBoundaries) {
  const spm::Scene s = scene_of(R"(<shape type="cube"><bsdf type="null"/><ref name="interior" id="a"/></shape>)");
  const Walked w = walk(s, {-3.0f, 0.1f, 0.2f}, -1, {1.0f, 0.0f, 0.0f}, 5.0f, true);
  expect_segments(w, {{0, 2, -1, kNull}, {0, 2, 0, kNull}, {0, 1, -1, kNone}});
  // One vertex's ray: its event throughout, a lane per segment of call 3
  // (SPM_TR_NEE_SHADOW).
  EXPECT_EQ(w.events, (std::vector<uint32_t>(3, 1000)));
  EXPECT_EQ(w.lanes, (std::vector<uint32_t>{lane(3, 0), lane(3, 1), lane(3, 2)}));
}

// 300 null sheets one unit apart: the walks stop at their caps, and the
// random numbers they drew stay inside their budgets: a path's events below
// the gather hops' (SPM_GATHER_EVENT) of the sample's block, a ray's lanes
// within the 5 bits tr_lane gives the segment.
TEST(Walk, TheRandomNumberBudgetHoldsAtTheCaps) {
  std::string sheets;
  for (int i = 0; i < 300; ++i) {
    sheets += "<shape type=\"rectangle\"><transform name=\"to_world\"><rotate y=\"1\" angle=\"90\"/>"
              "<translate x=\"" + std::to_string(i + 1) + "\"/></transform><bsdf type=\"null\"/></shape>\n";
  }
  const spm::Scene s = scene_of(sheets);
  const Walked path = walk(s, {0.0f, 0.1f, 0.2f}, -1, {1.0f, 0.0f, 0.0f}, kInf, false);
  EXPECT_TRUE(path.capped);
  ASSERT_EQ(path.segments.size(), 4u * SPM_MAX_CAMERA_SPECULAR + 4u);
  for (size_t i = 0; i < path.segments.size(); ++i) {
    EXPECT_EQ(path.events[i], 1000u + i);
    EXPECT_LT(path.events[i] - 1000u, SPM_GATHER_EVENT);
    // The offset off each sheet grows with the scene's extent (300 here).
    EXPECT_NEAR(path.segments[i].t1, 1.0f, 1e-2) << i;
  }
  const Walked ray = walk(s, {0.0f, 0.1f, 0.2f}, -1, {1.0f, 0.0f, 0.0f}, 1000.0f, true);
  EXPECT_TRUE(ray.capped);
  ASSERT_EQ(ray.segments.size(), size_t(SPM_MAX_SHADOW_CROSSINGS));
  for (size_t i = 0; i < ray.segments.size(); ++i) {
    EXPECT_EQ(ray.events[i], 1000u);
    EXPECT_EQ(ray.lanes[i], lane(3, uint32_t(i)));
    EXPECT_LT(i, 32u);
  }
}

}  // namespace
