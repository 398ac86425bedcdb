// The gather's estimates (kernels/lib/estimate.h) against brute-force sums
// over all records on the host, the surface estimate against a known
// radiance, and the progressive renders' consistency.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "render/render.h"
#include "scene/loader.h"
#include "spm/map_grids.h"
#include "spm/record_grid.h"
#include "spm/wall_images.h"
#include "stats.h"
#include "util/errors.h"
#include "map_table.h"
#include "test_support.h"

namespace {

using glm::dvec3;
using spm::test::beam_reference;
using spm::test::kernel_2d;
using spm::test::kPi;
using spm::test::v3;

// Every record of `records`, as used_surface_records would list them.
std::vector<uint32_t> all_of(const std::vector<SpmSurfaceRecord>& records) {
  std::vector<uint32_t> used(records.size());
  for (size_t i = 0; i < used.size(); ++i) used[i] = uint32_t(i);
  return used;
}

// The patch table and the patch of each query point (SPM_NONE: the plain
// disk sum) of the surface test kernels.
struct PatchBuffers {
  cl::Buffer patches, point_patch;
};

PatchBuffers no_patches(spm::Device& dev, int n) {
  return {dev.upload("patches", std::vector<SpmPatch>(1)), dev.upload("point_patch", std::vector<cl_uint>(n, SPM_NONE))};
}

// spm_surface_test's arguments, by name: the table's grids the camera's
// vertex reads.
void set_surface_test_args(cl::Kernel& k, const spm::test::TableBuffers& table, const cl::Buffer& points,
                           const cl::Buffer& normals, const PatchBuffers& patches, const cl::Buffer& out, int n,
                           int kernel, uint32_t max_depth) {
  spm::set_args(k, table, spm::arg("points", points), spm::arg("normals", normals),
                spm::arg("patches", patches.patches), spm::arg("point_patch", patches.point_patch), spm::arg("out", out),
                spm::arg("count", cl_uint(n)), spm::arg("reader", cl_uint(SPM_READ_VERTEX)),
                spm::arg("density_kernel", cl_uint(kernel)), spm::arg("estimator", cl_uint(SPM_ESTIMATOR_BRE)),
                spm::arg("max_rec_depth", cl_uint(max_depth)));
}

class BeamEstimate : public ::testing::TestWithParam<std::tuple<int, int, uint32_t>> {};

TEST_P(BeamEstimate, EqualsTheBruteForceSum) {
  const auto [kernel, estimator, max_depth] = GetParam();
  // With a depth limit, single scattering left out too (next-event estimation).
  const uint32_t min_depth = max_depth == SPM_NONE ? 0u : 2u;
  std::mt19937 rng(99);
  std::uniform_real_distribution<float> pos(-20.0f, 20.0f), flux(0.0f, 2.0f), unit(-1.0f, 1.0f);
  const SpmMedium medium = spm::test::coloured_medium();
  std::vector<SpmVolumeRecord> records(20000);
  for (auto& r : records) {
    for (int c = 0; c < 3; ++c) {
      r.position[c] = pos(rng);
      r.flux[c] = flux(rng);
    }
    const glm::vec3 d = glm::normalize(glm::vec3(unit(rng), unit(rng), unit(rng)) + glm::vec3(1e-3f));
    for (int c = 0; c < 3; ++c) r.direction[c] = d[c];
    r.medium = rng() % 8 == 0 ? 1 : 0;  // a few records of another medium must be ignored
    r.depth = 1 + rng() % 6;
  }
  const float radius = 0.8f;  // small against the box: long rays cross many cells
  auto& dev = spm::test::device();
  const spm::MapGridData u = spm::test::sphere_table(records, radius);
  const cl::Buffer media = dev.upload("media", std::vector<SpmMedium>{medium, medium});
  const int n = 500;
  std::vector<cl_float4> origins(n), dirs(n);
  for (int i = 0; i < n; ++i) {
    const glm::vec3 o(pos(rng), pos(rng), pos(rng));
    glm::vec3 d = glm::normalize(glm::vec3(unit(rng), unit(rng), unit(rng)) + glm::vec3(1e-3f));
    if (i % 10 == 0) d = glm::vec3(1.0f, 0.0f, 0.0f);  // axis-aligned rays, along cell faces too
    const float t0 = 0.25f * std::abs(pos(rng)), t1 = t0 + 5.0f + 2.0f * std::abs(pos(rng));
    origins[i] = {{o.x, o.y, o.z, t0}};
    dirs[i] = {{d.x, d.y, d.z, t1}};
  }
  const cl::Buffer ob = dev.upload("origins", origins), db = dev.upload("directions", dirs);
  spm::test::VolumeTestSettings t;
  t.kernel = kernel;
  t.estimator = estimator;
  t.min_depth = min_depth;
  t.max_depth = max_depth;
  const auto got = spm::test::volume_test(u, media, ob, db, n, t);
  int nonzero = 0;
  for (int i = 0; i < n; ++i) {
    const dvec3 o(origins[i].s[0], origins[i].s[1], origins[i].s[2]);
    const dvec3 d(dirs[i].s[0], dirs[i].s[1], dirs[i].s[2]);
    const dvec3 ref =
        beam_reference(records, medium, 0, o, d, origins[i].s[3], dirs[i].s[3], radius, kernel, estimator, min_depth,
                       max_depth);
    if (ref.x > 0) ++nonzero;
    for (int c = 0; c < 3; ++c) {
      // Float rounding (Epanechnikov's 1 - d^2/r^2 near the edge) stays well
      // under 1e-4 of the sum; a record counted twice or missed changes it by
      // a whole term, about a tenth of it with the uniform kernel here
      // (some 12 records lie within r of a ray).
      EXPECT_NEAR(got[i].s[c], ref[c], 1e-4 * std::abs(ref[c]) + 1e-9) << "ray " << i << " channel " << c;
    }
  }
  EXPECT_GT(nonzero, n / 2);
}

// What a run of shared estimates must show: estimate i equals own[i]
// (its own brute-force sum) where shares[i] < 0, and otherwise exactly
// estimate shares[i], which its own sum would not have given; and each of
// `distinct` differs from the estimate before it.
void expect_sharing(const std::vector<cl_float4>& got, const std::vector<dvec3>& own, const std::vector<int>& shares,
                    std::initializer_list<int> distinct) {
  for (size_t i = 0; i < got.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      if (shares[i] < 0) {
        EXPECT_NEAR(got[i].s[c], own[i][c], 1e-4 * own[i][c] + 1e-9) << "estimate " << i << " is its own";
      } else {
        EXPECT_EQ(got[i].s[c], got[shares[i]].s[c]) << "estimate " << i << " reads estimate " << shares[i] << "'s";
        // Its own sum would have given another value: the sharing is seen.
        EXPECT_GT(std::abs(own[i][c] - got[i].s[c]), 1e-3 * own[i][c]) << "estimate " << i;
      }
    }
  }
  for (int i : distinct) EXPECT_GT(std::abs(got[i].s[0] - got[i - 1].s[0]), 1e-3 * got[i].s[0]) << i;
}

// A block's camera samples share the volume estimate along their first
// segment (volume_reuse_hit): a segment whose two ends lie within 0.25 r of
// the last estimated segment's, with the same record depths, reads it; any
// other sums its own records.
TEST(BeamEstimate, ABlocksSegmentsShareOnlyANearbyEstimate) {
  std::mt19937 rng(31);
  std::uniform_real_distribution<float> pos(-10.0f, 10.0f), flux(0.0f, 2.0f), unit(-1.0f, 1.0f);
  const SpmMedium medium = spm::test::coloured_medium();
  std::vector<SpmVolumeRecord> records(40000);
  for (auto& r : records) {
    for (int c = 0; c < 3; ++c) {
      r.position[c] = pos(rng);
      r.flux[c] = flux(rng);
    }
    const glm::vec3 d = glm::normalize(glm::vec3(unit(rng), unit(rng), unit(rng)) + glm::vec3(1e-3f));
    for (int c = 0; c < 3; ++c) r.direction[c] = d[c];
    r.medium = 0;
    r.depth = 1 + rng() % 6;
  }
  const float radius = 1.0f;
  const int kernel = 1;  // Epanechnikov: the estimate moves with the segment
  const dvec3 o(-8, 0.1, 0.2), x(1, 0, 0);
  const auto dir = [&](double dy) { return glm::normalize(dvec3(1, dy, 0)); };
  struct Segment {
    dvec3 o, d;
    double t0, t1;
    uint32_t limit;
    int shares;  // the segment whose estimate this one reads; -1: its own
  };
  // The ray along x from o to 16 and rays turned by small angles: at
  // t = 16 a turn of dy moves the end by about 16 dy.
  const std::vector<Segment> q = {{o, x, 0.0, 16.0, SPM_NONE, -1},
                                  {o, dir(0.012), 0.0, 16.0, SPM_NONE, 0},  // end 0.19 r away: shared
                                  {o, dir(0.02), 0.0, 16.0, SPM_NONE, -1},  // end 0.32 r from segment 0's
                                  {o, dir(0.02), 0.0, 16.3, SPM_NONE, -1},  // 0.3 r longer, same start
                                  {o, dir(0.02), 0.0, 16.3, 3u, -1},        // another depth limit
                                  {o + dvec3(0, 0, 0.1), dir(0.02), 0.0, 16.3, 3u, 4},  // both ends 0.1 r away
                                  {o - dvec3(0, 0, 0.15), dir(0.02), 0.0, 16.3, 3u, 4},  // 0.15 r from 4
                                  {o, dir(0.02), 0.0, 1e30, 3u, -1}};        // escaping: its own
  std::vector<cl_float4> origins, dirs;
  std::vector<cl_uint> limits;
  for (const auto& e : q) {
    const float t1 = e.t1 > 1e29 ? std::numeric_limits<float>::infinity() : float(e.t1);
    origins.push_back(cl_float4{{float(e.o.x), float(e.o.y), float(e.o.z), float(e.t0)}});
    dirs.push_back(cl_float4{{float(e.d.x), float(e.d.y), float(e.d.z), t1}});
    limits.push_back(e.limit);
  }
  auto& dev = spm::test::device();
  const spm::test::TableBuffers u(dev, spm::test::sphere_table(records, radius));
  const cl::Buffer media = dev.upload("media", std::vector<SpmMedium>{medium});
  const int n = int(q.size());
  const cl::Buffer ob = dev.upload("origins", origins), db = dev.upload("directions", dirs),
                   lb = dev.upload("depth_limits", limits);
  const spm::DeviceBuffer out = dev.buffer(sizeof(cl_float4) * n, "estimates", CL_MEM_WRITE_ONLY);
  cl::Kernel k = dev.kernel("spm_estimate", "spm_shared_volume_test");
  const cl::Buffer patches = dev.upload("patches", std::vector<SpmPatch>(1));
  spm::set_args(k, u, spm::arg("media", media), spm::arg("patches", patches), spm::arg("origins", ob),
                spm::arg("directions", db), spm::arg("depth_limits", lb), spm::arg("out", out),
                spm::arg("count", cl_uint(n)), spm::arg("medium", cl_int(0)),
                spm::arg("reader", cl_uint(SPM_READ_CAMERA)), spm::arg("radius", radius),
                spm::arg("density_kernel", cl_uint(kernel)), spm::arg("estimator", cl_uint(SPM_ESTIMATOR_BRE)));
  dev.launch(k, 1);
  const auto got = dev.download<cl_float4>(out, n);
  std::vector<dvec3> own;
  std::vector<int> shares;
  for (const auto& e : q) {
    own.push_back(beam_reference(records, medium, 0, e.o, e.d, e.t0, e.t1, radius, kernel, 0, 0u, e.limit));
    shares.push_back(e.shares);
  }
  // Segments 2 .. 4 sum their own records, each unlike the one before it.
  expect_sharing(got, own, shares, {2, 3, 4});
}

// Depth limits: none, and 2 .. 3 of the records' depths 1 .. 6.
INSTANTIATE_TEST_SUITE_P(KernelsAndEstimators, BeamEstimate,
                         ::testing::Combine(::testing::Values(0, 1), ::testing::Values(0, 1),
                                            ::testing::Values(SPM_NONE, 3u)));

// A fog that fills all space spreads its records far beyond the scene: a
// single grid over all of them, capped in cells, would have cells far wider
// than 2r. map_grid_data puts the records outside volume_core (the query
// bounds grown) in a grid of their own; the two estimates together must
// equal the brute-force sum over every record, for rays that start in the
// scene and run far out.
TEST(BeamEstimate, RecordsFarFromTheSceneGetAGridOfTheirOwn) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> core(-1.0f, 1.0f), far(-300.0f, 300.0f), flux(0.0f, 2.0f);
  const SpmMedium medium = spm::test::coloured_medium();
  std::vector<SpmVolumeRecord> records(30000);
  for (size_t i = 0; i < records.size(); ++i) {
    SpmVolumeRecord& r = records[i];
    for (int c = 0; c < 3; ++c) {
      // A quarter far out: half of those in a cloud 150 away, which the
      // long rays below aim at, the rest scattered.
      r.position[c] = i % 4 != 0 ? core(rng) : i % 8 == 0 ? far(rng) : (c == 0 ? 150.0f : 0.0f) + core(rng);
      r.flux[c] = flux(rng);
    }
    const glm::vec3 d = glm::normalize(glm::vec3(core(rng), core(rng), core(rng)) + glm::vec3(1e-3f));
    for (int c = 0; c < 3; ++c) r.direction[c] = d[c];
    r.medium = 0;
    r.depth = 2;
  }
  const float radius = 0.05f;
  spm::QueryBounds reach;
  reach.lo = glm::vec3(-1.0f - radius);
  reach.hi = glm::vec3(1.0f + radius);
  spm::MapParts parts;
  parts.volume = records;
  spm::PassRadii radii;
  radii.radius = radii.volume_radius = radii.caustic_volume_radius = radii.beam_radius = radius;
  const spm::MapGridData data = spm::map_grid_data(parts, radii, false, reach);
  ASSERT_EQ(data.volume_records.size(), records.size());
  const size_t volume_row = spm::test::role_row("volume"), outer_row = spm::test::role_row("outer");
  const std::vector<uint32_t> inner = spm::test::distinct(spm::test::listed(data, volume_row)),
                              outer = spm::test::distinct(spm::test::listed(data, outer_row));
  ASSERT_EQ(inner.size() + outer.size(), records.size());
  // The core: the bounds grown to cbrt(30,000) = 31 cells of 2r, +-1.55.
  const spm::QueryBounds fine = spm::volume_core(reach, records.size(), radius);
  EXPECT_NEAR(fine.hi.x, 0.5f * std::cbrt(30000.0f) * 2.0f * radius, 1e-5f);
  EXPECT_EQ(fine.lo.y, -fine.hi.y);
  std::vector<SpmVolumeRecord> core_records;
  for (uint32_t i : inner) {
    EXPECT_TRUE(fine.contains(data.volume_records[i].position));
    core_records.push_back(data.volume_records[i]);
  }
  for (uint32_t i : outer) EXPECT_FALSE(fine.contains(data.volume_records[i].position));
  EXPECT_GT(outer.size(), records.size() / 5);
  // The scene's grid keeps cells of 2r; one grid over everything would not.
  EXPECT_LE(data.grids[volume_row].info.cell, 2.0f * radius * 1.001f);
  EXPECT_GT(spm::volume_grid(records, 0, records.size(), radius).info.cell, 20.0f * radius);

  auto& dev = spm::test::device();
  const cl::Buffer media = dev.upload("media", std::vector<SpmMedium>{medium});
  const int n = 400;
  std::vector<cl_float4> origins(n), dirs(n);
  for (int i = 0; i < n; ++i) {
    // Short rays inside the scene, and rays from it through the far cloud.
    const glm::vec3 o(0.8f * core(rng), 0.8f * core(rng), 0.8f * core(rng));
    const glm::vec3 aim = glm::vec3(150.0f, 0.0f, 0.0f) + 0.8f * glm::vec3(core(rng), core(rng), core(rng));
    const glm::vec3 d = i % 2 == 0 ? glm::normalize(glm::vec3(core(rng), core(rng), core(rng)) + glm::vec3(1e-3f))
                                   : glm::normalize(aim - o);
    const float t1 = i % 2 == 0 ? 1.5f : 400.0f;
    origins[i] = {{o.x, o.y, o.z, 0.0f}};
    dirs[i] = {{d.x, d.y, d.z, t1}};
  }
  const cl::Buffer ob = dev.upload("origins", origins), db = dev.upload("directions", dirs);
  // The camera reads both grids (map_grids.cpp's roles).
  const auto sum = spm::test::volume_test(data, media, ob, db, n, spm::test::VolumeTestSettings{});
  int outer_rays = 0;
  for (int i = 0; i < n; ++i) {
    const dvec3 o(origins[i].s[0], origins[i].s[1], origins[i].s[2]);
    const dvec3 d(dirs[i].s[0], dirs[i].s[1], dirs[i].s[2]);
    const dvec3 ref = beam_reference(records, medium, 0, o, d, 0.0, dirs[i].s[3], radius, 0, 0, 0u, SPM_NONE);
    const dvec3 core_only =
        beam_reference(core_records, medium, 0, o, d, 0.0, dirs[i].s[3], radius, 0, 0, 0u, SPM_NONE);
    if (ref.x > core_only.x * (1.0 + 1e-3)) ++outer_rays;
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(sum[i].s[c], ref[c], 1e-4 * std::abs(ref[c]) + 1e-9) << "ray " << i << " channel " << c;
    }
  }
  // Some rays must meet outer records, or the second grid went untested.
  EXPECT_GT(outer_rays, n / 4);
}

// The wall of the tests below: a 20 x 20 diffuse rectangle in the plane
// z = 0, its normal +z, as flatten_scene would list it; and a null sheet
// beside it (x in 30 .. 50) with medium 0 on both sides, which light
// crosses, so it mirrors nothing.
spm::SceneTables wall_tables() {
  spm::SceneTables t;
  SpmPatch wall{};
  wall.u[0] = 1.0f;
  wall.v[1] = 1.0f;
  wall.half_u = wall.half_v = 10.0f;
  SpmPatch sheet = wall;
  sheet.center[0] = 40.0f;
  t.patches = {wall, sheet};
  t.patch_shapes = {0, 1};
  t.shapes.resize(2);
  t.shapes[1].material = 1;
  t.materials.resize(2);
  t.materials[0].type = SPM_MAT_DIFFUSE;
  t.materials[1].type = SPM_MAT_NULL;
  return t;
}

// The same rectangle in the plane z = 0 as the boundary where medium 0
// ends: a null shape with the medium on one side and none on the other.
spm::SceneTables boundary_tables() {
  spm::SceneTables t = wall_tables();
  t.patches.resize(1);
  t.patch_shapes = {1};
  t.shapes[1].interior = -1;
  return t;
}

SpmVolumeRecord record_at(glm::vec3 p, glm::vec3 d, uint32_t stream) {
  SpmVolumeRecord r{};
  for (int c = 0; c < 3; ++c) {
    r.position[c] = p[c];
    r.direction[c] = d[c];
    r.flux[c] = 1.0f + float(c);
  }
  r.stream = stream;
  r.depth = 3;
  r.medium = 0;
  return r;
}

// Which records get an image: those within r of the wall's plane, on either
// side, whose foot lies on the rectangle; not those farther, beside it, or
// at the null boundary. The image is the mirror position and direction, with
// the record's flux, depth and medium, and names the wall's patch; the
// record names it too, and the others keep their stream ids.
TEST(WallImages, MirrorRecordsNearAWallOnly) {
  const spm::WallImages walls(wall_tables(), 1.0f);
  EXPECT_EQ(walls.walls(), 1u);
  const glm::vec3 d = glm::normalize(glm::vec3(1.0f, 2.0f, -3.0f));
  std::vector<SpmVolumeRecord> records = {
      record_at({1.0f, 2.0f, 0.4f}, d, 0),     // in front, within r
      record_at({-9.5f, 9.5f, -0.7f}, d, 1),   // behind, within r, near a corner
      record_at({1.0f, 2.0f, 1.2f}, d, 2),     // farther than r
      record_at({10.5f, 0.0f, 0.3f}, d, 3),    // beside the rectangle
      record_at({40.0f, 0.0f, 0.3f}, d, 4)};   // at the null boundary
  walls.add(records, 1.0f);
  ASSERT_EQ(records.size(), 7u);
  std::vector<SpmVolumeRecord> copy = records;
  EXPECT_THROW(walls.add(copy, 2.0f), spm::RuntimeError) << "a radius beyond the walls' index";
  for (uint32_t k = 2; k < 5; ++k) EXPECT_EQ(records[k].stream, k);
  const float expect_z[2] = {-0.4f, 0.7f};
  for (int k = 0; k < 2; ++k) {
    const SpmVolumeRecord& image = records[5 + k];
    const SpmVolumeRecord& source = records[k];
    EXPECT_EQ(image.stream, SPM_RECORD_WALL | SPM_RECORD_IMAGE | 0u);
    EXPECT_EQ(source.stream, SPM_RECORD_WALL | 0u) << "the record counts only on its side of the wall";
    EXPECT_EQ(image.position[0], source.position[0]);
    EXPECT_EQ(image.position[1], source.position[1]);
    EXPECT_NEAR(image.position[2], expect_z[k], 1e-6f);
    EXPECT_NEAR(image.direction[0], d.x, 1e-6f);
    EXPECT_NEAR(image.direction[1], d.y, 1e-6f);
    EXPECT_NEAR(image.direction[2], -d.z, 1e-6f);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(image.flux[c], source.flux[c]);
    EXPECT_EQ(image.depth, source.depth);
    EXPECT_EQ(image.medium, source.medium);
  }
}

// Where a medium ends at a null boundary its records' density ends as at a
// wall (the fog box of caustic_area, the open front of cornell_fog), so
// records near it are mirrored across it too, though not where an opaque
// wall stands between (a boundary just outside a room's wall: the wall's
// own image fills that side), and not across a sheet with the medium on
// both sides. A boundary does not name itself on the record: no estimate
// is asked for beyond it, where there is no medium.
TEST(WallImages, MirrorRecordsAcrossTheMediumsBoundary) {
  spm::SceneTables t = wall_tables();  // the wall at z = 0 and the sheet beside it
  SpmPatch behind = t.patches[0];      // a boundary just behind the wall
  behind.center[2] = -0.5f;
  SpmPatch beside = t.patches[0];      // a boundary in the wall's plane, beside it
  beside.center[0] = -40.0f;
  t.patches.push_back(behind);
  t.patches.push_back(beside);
  t.patch_shapes = {0, 1, 2, 2};
  t.shapes.resize(3);
  t.shapes[2].material = 1;
  t.shapes[2].interior = -1;
  const spm::WallImages walls(t, 1.0f);
  EXPECT_EQ(walls.walls(), 3u) << "the wall and the two boundaries, not the sheet";
  const glm::vec3 d = glm::normalize(glm::vec3(1.0f, 2.0f, -3.0f));
  std::vector<SpmVolumeRecord> records = {
      record_at({-40.0f, 2.0f, 0.4f}, d, 0),  // near the boundary beside the wall
      record_at({1.0f, 2.0f, 0.4f}, d, 1),    // near the wall, the boundary behind it
      record_at({1.0f, 2.0f, -0.2f}, d, 2),   // between the wall and the boundary
      record_at({40.0f, 2.0f, 0.4f}, d, 3)};  // near the sheet
  walls.add(records, 1.0f);
  ASSERT_EQ(records.size(), 8u);
  EXPECT_EQ(records[0].stream, 0u) << "a boundary leaves the record's side to its walls";
  EXPECT_EQ(records[1].stream, SPM_RECORD_WALL | 0u);
  EXPECT_EQ(records[2].stream, SPM_RECORD_WALL | 0u);
  EXPECT_EQ(records[3].stream, 3u);
  struct Expected {
    uint32_t source, patch;
    float z;
  };
  const Expected expected[4] = {{0, 3, -0.4f}, {1, 0, -0.4f}, {2, 0, 0.2f}, {2, 2, -0.8f}};
  for (int k = 0; k < 4; ++k) {
    const SpmVolumeRecord& image = records[4 + k];
    const SpmVolumeRecord& source = records[expected[k].source];
    EXPECT_EQ(image.stream, SPM_RECORD_WALL | SPM_RECORD_IMAGE | expected[k].patch) << "image " << k;
    EXPECT_EQ(image.position[0], source.position[0]) << "image " << k;
    EXPECT_NEAR(image.position[2], expected[k].z, 1e-6f) << "image " << k;
    EXPECT_NEAR(image.direction[2], -d.z, 1e-6f) << "image " << k;
    for (int c = 0; c < 3; ++c) EXPECT_EQ(image.flux[c], source.flux[c]);
  }
}

// A medium that neither absorbs nor attenuates: sigma_t 0, albedo 1,
// isotropic.
cl::Buffer clear_medium(spm::Device& dev) {
  SpmMedium clear{};
  clear.albedo[0] = clear.albedo[1] = clear.albedo[2] = 1.0f;
  clear.phase = SPM_PHASE_ISOTROPIC;
  return dev.upload("media", std::vector<SpmMedium>{clear});
}

// Records spread evenly over the slab 0 < z < 4 above the plane z = 0 of
// `tables`' first patch (a wall, or the boundary where the medium ends),
// each of flux phi, in a medium that neither absorbs nor attenuates
// (sigma_t 0, albedo 1, isotropic): the beam radiance estimate along a
// segment of length L is rho phi L / (4 pi), its standard error the
// Poisson error of the k records in the segment's tube. Along rays beside
// the patch (at 0.1 r to 0.9 r) and rays that end on it at 45 degrees, the
// plain estimate is the part of each disk above it, averaged along the ray,
// while with the images it is rho phi L / (4 pi); both within 4 standard
// errors. With `wall`, a ray beyond it reads neither the images nor the
// records near it, which without them leak through it. Rays sit 2 r apart,
// so their estimates are independent.
void expect_disks_given_back(const spm::SceneTables& tables, bool wall) {
  const float radius = 1.0f, phi = 0.01f, depth = 4.0f;
  const double rho = 50.0;
  const int count = int(rho * 20.0 * 20.0 * depth);
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<SpmVolumeRecord> records(count);
  for (auto& r : records) {
    r = record_at({-10.0f + 20.0f * u(rng), -10.0f + 20.0f * u(rng), depth * u(rng)}, {0.0f, 0.0f, 1.0f}, 0);
    for (float& f : r.flux) f = phi;
  }
  std::vector<SpmVolumeRecord> mirrored = records;
  spm::WallImages(tables, radius).add(mirrored, radius);
  ASSERT_GT(mirrored.size(), records.size() + records.size() / 5);

  // Groups of rays: x from -7 to 7 at heights 0.1, 0.5 and 0.9 (9 each, at
  // y = -8, -6, ..., 8); 27 from z = 1.5 down at 45 degrees to the wall;
  // 9 at z = -0.5, beyond the wall.
  struct Ray {
    glm::vec3 o, d;
    float t1;
  };
  std::vector<Ray> rays;
  std::vector<int> groups = {0};
  const float heights[3] = {0.1f, 0.5f, 0.9f};
  for (float h : heights) {
    for (int k = 0; k < 9; ++k) rays.push_back({{-7.0f, -8.0f + 2.0f * k, h}, {1.0f, 0.0f, 0.0f}, 14.0f});
    groups.push_back(int(rays.size()));
  }
  const float s = std::sqrt(0.5f);
  for (float x : {-8.0f, -2.0f, 4.0f})
    for (int k = 0; k < 9; ++k) rays.push_back({{x, -8.0f + 2.0f * k, 1.5f}, {s, 0.0f, -s}, 1.5f / s});
  groups.push_back(int(rays.size()));
  const int beyond = int(rays.size());
  for (int k = 0; k < 9; ++k) rays.push_back({{-7.0f, -8.0f + 2.0f * k, -0.5f}, {1.0f, 0.0f, 0.0f}, 14.0f});
  const int n = int(rays.size());
  std::vector<cl_float4> origins(n), dirs(n);
  for (int i = 0; i < n; ++i) {
    origins[i] = {{rays[i].o.x, rays[i].o.y, rays[i].o.z, 0.0f}};
    dirs[i] = {{rays[i].d.x, rays[i].d.y, rays[i].d.z, rays[i].t1}};
  }
  auto& dev = spm::test::device();
  const cl::Buffer media = clear_medium(dev);
  const cl::Buffer ob = dev.upload("origins", origins), db = dev.upload("directions", dirs);
  spm::test::VolumeTestSettings t;
  const auto plain = spm::test::volume_test(spm::test::sphere_table(records, radius), media, ob, db, n, t);
  t.walls = tables.patches;
  const auto with = spm::test::volume_test(spm::test::sphere_table(mirrored, radius), media, ob, db, n, t);

  // The part of a disk of radius r around a point at height z above the
  // wall, its plane at angle a to the wall, that lies above z = 0 (a
  // circular segment; the whole disk when the wall does not cut it).
  const auto above = [&](double z, double sin_a) {
    const double h = sin_a > 0.0 ? std::min(1.0, z / (sin_a * radius)) : 1.0;
    return (kPi - std::acos(h) + h * std::sqrt(1.0 - h * h)) / kPi;
  };
  for (size_t g = 0; g + 1 < groups.size(); ++g) {
    double with_mean = 0.0, plain_mean = 0.0, part = 0.0, tube = 0.0;
    for (int i = groups[g]; i < groups[g + 1]; ++i) {
      const double full = rho * phi * rays[i].t1 / (4.0 * kPi);
      with_mean += with[i].s[0] / full;
      plain_mean += plain[i].s[0] / full;
      // Along the ray, the disk's part above the wall, by the midpoint rule.
      const double sin_a = std::sqrt(1.0 - double(rays[i].d.z) * rays[i].d.z);
      const int steps = 1000;
      double sum = 0.0;
      for (int j = 0; j < steps; ++j) sum += above(rays[i].o.z + (j + 0.5) / steps * rays[i].t1 * rays[i].d.z, sin_a);
      part += sum / steps;
      tube += rho * kPi * radius * radius * rays[i].t1;
    }
    const double rays_in = groups[g + 1] - groups[g];
    const double error = 1.0 / std::sqrt(tube);  // of the group's mean, relative
    EXPECT_NEAR(with_mean / rays_in, 1.0, 4.0 * error) << "group " << g;
    EXPECT_NEAR(plain_mean / rays_in, part / rays_in, 4.0 * error) << "group " << g;
    if (g == 0 || g == 3) EXPECT_LT(part / rays_in, 1.0 - 6.0 * error) << "group " << g << " tells them apart";
  }
  if (!wall) return;
  for (int i = beyond; i < n; ++i) {
    EXPECT_GT(plain[i].s[0], 0.0f) << "ray " << i << ": without images, the disks leak through the wall";
    EXPECT_EQ(with[i].s[0], 0.0f) << "ray " << i << " beyond the wall";
  }
}

TEST(BeamEstimate, WallImagesGiveBackTheDiskBeyondAWall) { expect_disks_given_back(wall_tables(), true); }

TEST(BeamEstimate, BoundaryImagesGiveBackTheDiskWhereTheMediumEnds) {
  expect_disks_given_back(boundary_tables(), false);
}

// A sheet with fog on both sides (a mirror or a lamp's box hanging in fog):
// records spread evenly over -4 < z < 4, three times as dense below the
// wall at z = 0 as above it. Along rays beside the wall on either side (at
// 0.1 r to 0.9 r), each side's estimate is its own density's rho phi L /
// (4 pi), within 4 standard errors: the images stand in for the other
// side's records, which the disks no longer read through the sheet.
TEST(BeamEstimate, WallImagesKeepEachSideOfASheetToItself) {
  const float radius = 1.0f, phi = 0.01f, depth = 4.0f;
  const double rho[2] = {50.0, 150.0};  // above, below
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<SpmVolumeRecord> records;
  for (int side = 0; side < 2; ++side) {
    const int count = int(rho[side] * 20.0 * 20.0 * depth);
    for (int i = 0; i < count; ++i) {
      const float z = depth * u(rng);
      records.push_back(record_at({-10.0f + 20.0f * u(rng), -10.0f + 20.0f * u(rng), side == 0 ? z : -z},
                                  {0.0f, 0.0f, 1.0f}, uint32_t(i)));
      for (float& f : records.back().flux) f = phi;
    }
  }
  const spm::SceneTables tables = wall_tables();
  spm::WallImages(tables, radius).add(records, radius);

  // 9 rays at each height (y = -8, -6, ..., 8), x from -7 to 7.
  const float heights[6] = {0.1f, 0.5f, 0.9f, -0.1f, -0.5f, -0.9f};
  const int per = 9, n = 6 * per;
  std::vector<cl_float4> origins, dirs;
  for (float h : heights)
    for (int k = 0; k < per; ++k) {
      origins.push_back({{-7.0f, -8.0f + 2.0f * k, h, 0.0f}});
      dirs.push_back({{1.0f, 0.0f, 0.0f, 14.0f}});
    }
  auto& dev = spm::test::device();
  const cl::Buffer media = clear_medium(dev);
  const cl::Buffer ob = dev.upload("origins", origins), db = dev.upload("directions", dirs);
  spm::test::VolumeTestSettings t;
  t.walls = tables.patches;
  const auto got = spm::test::volume_test(spm::test::sphere_table(records, radius), media, ob, db, n, t);
  for (int g = 0; g < 6; ++g) {
    const double density = rho[g < 3 ? 0 : 1];
    double mean = 0.0;
    for (int i = g * per; i < (g + 1) * per; ++i) mean += got[i].s[0] / (density * phi * 14.0 / (4.0 * kPi));
    const double error = 1.0 / std::sqrt(per * density * kPi * radius * radius * 14.0);
    EXPECT_NEAR(mean / per, 1.0, 4.0 * error) << "height " << heights[g];
  }
}

TEST(SurfaceEstimate, EqualsTheBruteForceSum) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  // Records on the floor (y = 0) and on a wall (x = 0), facing into the
  // positive octant; some flagged as direct light.
  std::vector<SpmSurfaceRecord> records(30000);
  for (auto& r : records) {
    const bool floor = u(rng) < 0.5f;
    const float a = 20 * u(rng), b = 20 * u(rng);
    r.position[0] = floor ? a : 0.0f;
    r.position[1] = floor ? 0.0f : a;
    r.position[2] = b;
    r.normal[0] = floor ? 0.0f : 1.0f;
    r.normal[1] = floor ? 1.0f : 0.0f;
    for (int c = 0; c < 3; ++c) r.flux[c] = u(rng);
    r.flags = u(rng) < 0.3f ? 0u : SPM_RECORD_HAD_EVENT;
    r.depth_photon = (1u + rng() % 6) << 16;
  }
  const float radius = 1.0f;
  auto& dev = spm::test::device();
  const int n = 400;
  std::vector<cl_float4> points(n), normals(n);
  for (int i = 0; i < n; ++i) {
    const bool floor = i % 2 == 0;
    const float a = 20 * u(rng), b = 20 * u(rng);
    points[i] = floor ? cl_float4{{a, 0.0f, b, 0.0f}} : cl_float4{{0.0f, a, b, 0.0f}};
    normals[i] = floor ? cl_float4{{0.0f, 1.0f, 0.0f, 0.0f}} : cl_float4{{1.0f, 0.0f, 0.0f, 0.0f}};
  }
  const cl::Buffer pb = dev.upload("points", points), nb = dev.upload("normals", normals);
  const spm::DeviceBuffer out = dev.buffer(sizeof(cl_float4) * n, "estimates", CL_MEM_WRITE_ONLY);
  cl::Kernel k = dev.kernel("spm_estimate", "spm_surface_test");
  const PatchBuffers none = no_patches(dev, n);
  // The gather's grid (cells of kSurfaceCell r), and point grids of cells
  // smaller and larger than r, which the query must handle alike.
  for (const float cell : {spm::kSurfaceCell, 0.3f, 3.0f}) {
    for (const int kernel : {0, 1}) {
      for (const bool skip : {false, true}) {
        // Records deeper than the limit are left out (METHOD.md 10).
        const uint32_t max_depth = skip ? 3u : SPM_NONE;
        // The gather's grid holds only the records it uses (used_surface_records).
        const auto used = spm::used_surface_records(records.data(), records.size(), skip);
        std::vector<glm::vec3> centres;
        for (uint32_t i : used) centres.push_back(glm::vec3(v3(records[i].position)));
        const spm::RecordGrid grid = cell == spm::kSurfaceCell ? spm::surface_grid(records.data(), used, radius)
                                                               : spm::build_point_grid(centres, cell * radius);
        const spm::test::TableBuffers up(dev, spm::test::disk_table(records, used, grid, radius));
        set_surface_test_args(k, up, pb, nb, none, out, n, kernel, max_depth);
        dev.launch(k, n);
        const auto got = dev.download<cl_float4>(out, n);
        for (int i = 0; i < n; ++i) {
          const dvec3 x(points[i].s[0], points[i].s[1], points[i].s[2]);
          const dvec3 nq(normals[i].s[0], normals[i].s[1], normals[i].s[2]);
          dvec3 ref(0.0);
          for (const auto& r : records) {
            if ((skip && !(r.flags & SPM_RECORD_HAD_EVENT)) || (r.depth_photon >> 16) > max_depth) continue;
            if (glm::dot(v3(r.normal), nq) <= 0) continue;
            const dvec3 off = v3(r.position) - x;
            const double h = glm::dot(off, nq), d3 = glm::dot(off, off);
            if (d3 >= radius * radius || std::abs(h) > 0.1 * radius) continue;
            ref += kernel_2d(kernel, d3 - h * h, radius * radius) * v3(r.flux);
          }
          for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(got[i].s[c], ref[c], 1e-4 * ref[c] + 1e-9) << "query " << i << ", cell " << cell << " r";
          }
        }
      }
    }
  }
}

// A pixel's samples share a surface estimate (pixel_surface_estimate): a
// query within 0.25 r of the last estimate's point, facing the same way,
// with the same depth limit, reads it; any other query sums its own disk.
TEST(SurfaceEstimate, APixelsSamplesShareOnlyANearbyEstimate) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<SpmSurfaceRecord> records(20000);
  for (auto& r : records) {
    r.position[0] = 20 * u(rng);
    r.position[2] = 20 * u(rng);
    r.normal[1] = 1.0f;
    for (int c = 0; c < 3; ++c) r.flux[c] = u(rng);
    r.flags = SPM_RECORD_HAD_EVENT;
    r.depth_photon = (1u + rng() % 6) << 16;
  }
  const float radius = 1.0f;
  const int kernel = 1;  // Epanechnikov: the estimate moves with the query's point and normal
  const auto brute = [&](const dvec3& x, const dvec3& n, uint32_t max_depth) {
    dvec3 sum(0.0);
    for (const auto& r : records) {
      if ((r.depth_photon >> 16) > max_depth || glm::dot(v3(r.normal), n) <= 0) continue;
      const dvec3 off = v3(r.position) - x;
      const double h = glm::dot(off, n), d3 = glm::dot(off, off);
      if (d3 >= radius * radius || std::abs(h) > 0.1 * radius) continue;
      sum += kernel_2d(kernel, d3 - h * h, radius * radius) * v3(r.flux);
    }
    return sum;
  };
  const dvec3 up(0, 1, 0), tilted(std::sin(0.5236), std::cos(0.5236), 0);  // 30 degrees
  const dvec3 x0(10, 0, 10), x1 = x0 + dvec3(0.2, 0, 0.1), x2 = x0 + dvec3(0.3, 0, 0.05), x5 = x2 + dvec3(0, 0, 0.1);
  struct Query {
    dvec3 x, n;
    uint32_t limit;
    int shares;  // the query whose estimate this one reads; -1: its own
  };
  const std::vector<Query> q = {{x0, up, SPM_NONE, -1}, {x1, up, SPM_NONE, 0},   // 0.22 r away: shared
                                {x2, up, SPM_NONE, -1},                          // 0.3 r from x0
                                {x2, tilted, SPM_NONE, -1},                      // facing another way
                                {x2, tilted, 3u, -1},                            // another depth limit
                                {x5, tilted, 3u, 4}};                            // 0.1 r away: shared
  std::vector<cl_float4> points, normals;
  std::vector<cl_uint> limits;
  for (const auto& e : q) {
    points.push_back(cl_float4{{float(e.x.x), float(e.x.y), float(e.x.z), 0.0f}});
    normals.push_back(cl_float4{{float(e.n.x), float(e.n.y), float(e.n.z), 0.0f}});
    limits.push_back(e.limit);
  }
  auto& dev = spm::test::device();
  const auto used = spm::used_surface_records(records.data(), records.size(), false);
  const spm::test::TableBuffers table(
      dev, spm::test::disk_table(records, used, spm::surface_grid(records.data(), used, radius), radius));
  const int n = int(q.size());
  const cl::Buffer pb = dev.upload("points", points), nb = dev.upload("normals", normals),
                   lb = dev.upload("depth_limits", limits);
  const spm::DeviceBuffer out = dev.buffer(sizeof(cl_float4) * n, "estimates", CL_MEM_WRITE_ONLY);
  cl::Kernel k = dev.kernel("spm_estimate", "spm_shared_surface_test");
  const PatchBuffers none = no_patches(dev, n);
  spm::set_args(k, table, spm::arg("points", pb), spm::arg("normals", nb), spm::arg("depth_limits", lb),
                spm::arg("patches", none.patches), spm::arg("point_patch", none.point_patch), spm::arg("out", out),
                spm::arg("count", cl_uint(n)), spm::arg("reader", cl_uint(SPM_READ_VERTEX)),
                spm::arg("radius", radius), spm::arg("density_kernel", cl_uint(kernel)),
                spm::arg("estimator", cl_uint(SPM_ESTIMATOR_BRE)));
  dev.launch(k, 1);
  const auto got = dev.download<cl_float4>(out, n);
  std::vector<dvec3> own;
  std::vector<int> shares;
  for (const auto& e : q) {
    own.push_back(brute(e.x, e.n, e.limit));
    shares.push_back(e.shares);
  }
  // Queries 2 .. 4 sum their own disks, each unlike the one before it.
  expect_sharing(got, own, shares, {2, 3, 4});
}

// A grazing stream's photons can land on their tangent plane far outside
// the scene (METHOD.md 1); the grid leaves out those beyond the scene's
// bounds grown by r, which no query can reach, and keeps the rest.
TEST(SurfaceEstimate, RecordsBeyondTheQueriesReachAreLeftOut) {
  std::vector<SpmSurfaceRecord> records(4);
  const float xs[4] = {0.0f, 10.9f, 11.1f, -1e6f};
  for (int i = 0; i < 4; ++i) {
    records[i].position[0] = xs[i];
    records[i].flags = SPM_RECORD_HAD_EVENT;
  }
  spm::QueryBounds reach;
  reach.lo = glm::vec3(-11.0f);
  reach.hi = glm::vec3(11.0f);
  const auto used = spm::used_surface_records(records.data(), records.size(), true, reach);
  ASSERT_EQ(used.size(), 2u);
  EXPECT_EQ(records[used[0]].position[0], 0.0f);
  EXPECT_EQ(records[used[1]].position[0], 10.9f);
  EXPECT_EQ(spm::used_surface_records(records.data(), records.size(), true).size(), 4u);
}

TEST(SurfaceEstimate, UniformPhotonsOnAPlaneGiveTheirFluxDensity) {
  // N photons of flux phi spread uniformly over an A x A square: the estimate
  // of the flux density is N phi / A^2 within its standard error, which for a
  // uniform kernel is the Poisson error sqrt(k) / k of the k photons in the disk.
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float side = 100.0f, radius = 2.0f, phi = 0.01f;
  const int photons = 400000;
  std::vector<SpmSurfaceRecord> records(photons);
  for (auto& r : records) {
    r.position[0] = side * u(rng);
    r.position[2] = side * u(rng);
    r.normal[1] = 1.0f;
    r.flux[0] = r.flux[1] = r.flux[2] = phi;
    r.flags = SPM_RECORD_HAD_EVENT;
  }
  auto& dev = spm::test::device();
  const std::vector<uint32_t> all = all_of(records);
  const spm::RecordGrid grid = spm::surface_grid(records.data(), all, radius);
  const spm::test::TableBuffers up(dev, spm::test::disk_table(records, all, grid, radius));
  const int n = 200;
  std::vector<cl_float4> points(n), normals(n, cl_float4{{0.0f, 1.0f, 0.0f, 0.0f}});
  for (auto& p : points) p = {{radius + (side - 2 * radius) * u(rng), 0.0f, radius + (side - 2 * radius) * u(rng), 0}};
  const cl::Buffer pb = dev.upload("points", points), nb = dev.upload("normals", normals);
  const spm::DeviceBuffer out = dev.buffer(sizeof(cl_float4) * n, "estimates", CL_MEM_WRITE_ONLY);
  cl::Kernel k = dev.kernel("spm_estimate", "spm_surface_test");
  const PatchBuffers none = no_patches(dev, n);
  set_surface_test_args(k, up, pb, nb, none, out, n, 0, SPM_NONE);
  dev.launch(k, n);
  const auto got = dev.download<cl_float4>(out, n);
  std::vector<double> estimates;
  for (const auto& g : got) estimates.push_back(g.s[0]);
  const double expected = photons * phi / (side * side);
  const auto m = spm::test::mean_and_error(estimates);
  const double in_disk = photons * kPi * radius * radius / (side * side);  // ~503 photons
  EXPECT_NEAR(m.mean, expected, 4 * m.error);
  // The spread between query points is the Poisson error of one disk.
  EXPECT_NEAR(m.error * std::sqrt(double(n)), expected / std::sqrt(in_disk), 0.25 * expected / std::sqrt(in_disk));
}

// Photons spread evenly over a rectangle: at its edges and corners the
// estimate with the rectangle's patch is the flux density within its
// standard error (the reflection across the edges gives back the disk's part
// beyond them), while the plain disk sum falls to a half at an edge and a
// quarter at a corner. Across an open edge (another patch continues the
// plane) the photons beyond it count as they are. Query points sit at most
// 0.3 r inside the edge, a fixed 2 r apart, so their estimates are
// independent.
TEST(SurfaceEstimate, PatchEdgesReflectTheDisk) {
  const float half = 10.0f, radius = 1.0f, phi = 0.01f;
  const int photons = 40000;
  SpmPatch patch{};
  patch.u[0] = 1.0f;
  patch.v[2] = 1.0f;
  patch.half_u = patch.half_v = half;
  SpmPatch open_patch = patch;  // a second rectangle goes on beyond x = +half
  open_patch.open = SPM_PATCH_OPEN_U_HI;
  auto& dev = spm::test::device();
  cl::Kernel k = dev.kernel("spm_estimate", "spm_surface_test");
  const double expected = photons * phi / (4.0 * half * half);
  // Query points: along the four edges, and at the four corners.
  std::vector<cl_float4> edge_points, corner_points;
  std::mt19937 rng(31);
  std::uniform_real_distribution<float> inset(0.0f, 0.3f * radius);
  for (float t = -half + 2.0f * radius; t <= half - 2.0f * radius; t += 2.0f * radius) {
    for (const float sign : {-1.0f, 1.0f}) {
      edge_points.push_back({{sign * (half - inset(rng)), 0.0f, t, 0.0f}});
      edge_points.push_back({{t, 0.0f, sign * (half - inset(rng)), 0.0f}});
    }
  }
  struct Run {
    std::vector<double> edge, corner, open_edge, plain_edge, plain_corner;
  } run;
  for (uint32_t seed = 0; seed < 12; ++seed) {
    std::mt19937 place(1000 + seed);
    std::uniform_real_distribution<float> u(-half, half);
    std::vector<SpmSurfaceRecord> records(photons);
    for (auto& r : records) {
      r.position[0] = u(place);
      r.position[2] = u(place);
      r.normal[1] = 1.0f;
      r.flux[0] = r.flux[1] = r.flux[2] = phi;
      r.flags = SPM_RECORD_HAD_EVENT;
    }
    // The open case: as many photons again on the rectangle beyond +x.
    std::vector<SpmSurfaceRecord> both = records;
    for (const auto& r : records) {
      SpmSurfaceRecord o = r;
      o.position[0] += 2.0f * half;
      both.push_back(o);
    }
    corner_points.clear();
    for (const float sx : {-1.0f, 1.0f})
      for (const float sz : {-1.0f, 1.0f}) corner_points.push_back({{sx * (half - inset(rng)), 0.0f, sz * (half - inset(rng)), 0.0f}});
    const auto estimate = [&](const std::vector<SpmSurfaceRecord>& recs, const std::vector<cl_float4>& points,
                              const SpmPatch* p) {
      const std::vector<uint32_t> all = all_of(recs);
      const spm::RecordGrid grid = spm::surface_grid(recs.data(), all, radius);
      const spm::test::TableBuffers up(dev, spm::test::disk_table(recs, all, grid, radius));
      const int n = int(points.size());
      const std::vector<cl_float4> normals(n, cl_float4{{0.0f, 1.0f, 0.0f, 0.0f}});
      const PatchBuffers patches{dev.upload("patches", std::vector<SpmPatch>{p ? *p : SpmPatch{}}),
                                 dev.upload("point_patch", std::vector<cl_uint>(n, p ? 0u : SPM_NONE))};
      const cl::Buffer pb = dev.upload("points", points), nb = dev.upload("normals", normals);
      const spm::DeviceBuffer out = dev.buffer(sizeof(cl_float4) * n, "estimates", CL_MEM_WRITE_ONLY);
      set_surface_test_args(k, up, pb, nb, patches, out, n, int(seed % 2), SPM_NONE);
      dev.launch(k, n);
      std::vector<double> v;
      for (const auto& g : dev.download<cl_float4>(out, n)) v.push_back(g.s[0]);
      return v;
    };
    const auto append = [](std::vector<double>& to, const std::vector<double>& v) { to.insert(to.end(), v.begin(), v.end()); };
    append(run.edge, estimate(records, edge_points, &patch));
    append(run.corner, estimate(records, corner_points, &patch));
    append(run.plain_edge, estimate(records, edge_points, nullptr));
    append(run.plain_corner, estimate(records, corner_points, nullptr));
    // Only the points on the open edge (x near +half) see the photons beyond it.
    std::vector<cl_float4> open_points;
    for (const auto& q : edge_points)
      if (q.s[0] > half - radius) open_points.push_back(q);
    append(run.open_edge, estimate(both, open_points, &open_patch));
  }
  for (const auto* v : {&run.edge, &run.corner, &run.open_edge}) {
    const auto m = spm::test::mean_and_error(*v);
    EXPECT_NEAR(m.mean, expected, 4 * m.error) << v->size() << " queries";
    EXPECT_LT(m.error, 0.03 * expected);  // the test can tell a few per cent
  }
  // A disk at most 0.3 r inside an edge keeps 50-69% of its area (10-32% at a corner).
  EXPECT_LT(spm::test::mean_and_error(run.plain_edge).mean, 0.75 * expected);
  EXPECT_LT(spm::test::mean_and_error(run.plain_corner).mean, 0.4 * expected);
}

double rel_mse(const spm::Image& a, const spm::Image& ref) {
  double sum = 0.0;
  for (size_t i = 0; i < a.rgb.size(); ++i) {
    const double d = a.rgb[i] - ref.rgb[i];
    sum += d * d / (ref.rgb[i] * ref.rgb[i] + 1e-2);
  }
  return sum / a.rgb.size();
}

TEST(Progressive, RelativeErrorFallsWithPasses) {
  // METHOD.md 6: independent passes with shrinking radii converge. The
  // relMSE of N passes against an independent 16 N-pass render (another seed)
  // falls as N grows.
  auto scene = spm::load_scene(SPM_SCENES_DIR "/cornell_fog.xml", {{"res", "24"}, {"spp", "2"}});
  scene.integrator.streams = 2000;
  scene.integrator.associated = 10;
  auto& dev = spm::test::device();
  auto render = [&](int passes, uint32_t seed) {
    spm::RenderSettings s;
    s.passes = passes;
    s.seed = seed;
    return spm::render(scene, s, dev);
  };
  const double e1 = rel_mse(render(1, 1), render(16, 2));
  const double e4 = rel_mse(render(4, 3), render(64, 4));
  EXPECT_LT(e4, 0.5 * e1) << "relMSE " << e1 << " (1 pass) vs " << e4 << " (4 passes)";
}

TEST(Progressive, RadiusScheduleFollowsKnausZwicker) {
  EXPECT_FLOAT_EQ(spm::pass_radius(2.5f, 2.0f / 3, 0), 2.5f);
  EXPECT_NEAR(spm::pass_radius(2.5f, 2.0f / 3, 1), 2.5 * std::sqrt((1 + 2.0 / 3) / 2), 1e-6);
  // r_k^2 falls like k^(alpha - 1): the ratio over passes 100 -> 1000.
  const double r100 = spm::pass_radius(1.0f, 0.5f, 100), r1000 = spm::pass_radius(1.0f, 0.5f, 1000);
  EXPECT_NEAR(r1000 * r1000 / (r100 * r100), std::pow(10.0, -0.5), 0.01);
}

}  // namespace
