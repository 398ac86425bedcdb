// The volume records' own kernel radius (integrator volume_radius): the
// camera segments' volume estimate reads it and nothing else does; the
// gather rays read the volume records with the radius when that is smaller,
// through a grid of their own. With the stream width held, the photon maps
// are the same whatever the radii, so a pass of cornell_fog's camera volume
// term with radius 2.5 and volume radius 4 is, to the bit, the pass with
// radius 4 and volume radius 4; its surface terms are those of the pass
// with volume radius 2.5, and its gather rays' volume term is too, up to
// the order of the sums (the grids list the records in other cells). Left
// out, the volume radius is 3 radii in homogeneous media with the bre
// estimate and single scattering by next-event estimation, else the radius,
// and there the caustic records (light focused by glass or a mirror) keep
// 1.5 radii, through a grid of their own (render/defaults.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "render/defaults.h"
#include "render/render.h"
#include "spm/map_grids.h"
#include "scene/loader.h"
#include "map_table.h"
#include "test_support.h"

namespace {

std::vector<float> one_pass(float radius, std::optional<float> volume_radius, uint32_t terms) {
  spm::Scene scene = spm::load_scene(SPM_SCENES_DIR "/cornell_fog.xml",
                                     {{"res", "24"}, {"streams", "2000"}, {"associated", "4"}});
  scene.integrator.radius = radius;
  scene.integrator.stream_width = 2.5f;
  if (volume_radius) scene.integrator.volume_radius = *volume_radius;
  return spm::test::render_terms(scene, 1, 4, 9, terms);
}

TEST(VolumeRadius, IsTheRadiusTheVolumeEstimateReads) {
  const std::vector<float> wide = one_pass(2.5f, 4.0f, SPM_TERM_VOLUME);
  const std::vector<float> same = one_pass(4.0f, 4.0f, SPM_TERM_VOLUME);
  const std::vector<float> narrow = one_pass(2.5f, 2.5f, SPM_TERM_VOLUME);
  ASSERT_GT(spm::test::image_mean(wide), 0.0);
  EXPECT_EQ(wide, same);
  EXPECT_NE(wide, narrow);
  EXPECT_EQ(one_pass(2.5f, 4.0f, SPM_TERM_SURFACE | SPM_TERM_GATHER_DIRECT | SPM_TERM_GATHER_SURFACE),
            one_pass(2.5f, 2.5f, SPM_TERM_SURFACE | SPM_TERM_GATHER_DIRECT | SPM_TERM_GATHER_SURFACE));
}

TEST(VolumeRadius, GatherRaysKeepTheSmallerRadius) {
  const std::vector<float> wide = one_pass(2.5f, 4.0f, SPM_TERM_GATHER_VOLUME);
  const std::vector<float> narrow = one_pass(2.5f, 2.5f, SPM_TERM_GATHER_VOLUME);
  const std::vector<float> both_wide = one_pass(4.0f, 4.0f, SPM_TERM_GATHER_VOLUME);
  ASSERT_EQ(wide.size(), narrow.size());
  double largest = 0.0, apart = 0.0;
  for (size_t i = 0; i < wide.size(); ++i) {
    largest = std::max(largest, double(std::abs(wide[i] - narrow[i])) / (std::abs(narrow[i]) + 1e-6));
    apart = std::max(apart, double(std::abs(both_wide[i] - narrow[i])) / (std::abs(narrow[i]) + 1e-6));
  }
  EXPECT_LT(largest, 1e-4);
  EXPECT_GT(apart, 1e-2);  // the radius 4 estimate is another one
}

TEST(VolumeRadius, LeftOutItIsThreeRadiiInHomogeneousMedia) {
  EXPECT_EQ(one_pass(2.5f, std::nullopt, SPM_TERM_VOLUME), one_pass(2.5f, 7.5f, SPM_TERM_VOLUME));
  spm::Scene fog = spm::load_scene(SPM_SCENES_DIR "/cornell_fog.xml", {});
  EXPECT_FLOAT_EQ(spm::derived_volume_radius(fog), 3.0f * fog.integrator.radius);
  EXPECT_FLOAT_EQ(spm::derived_caustic_volume_radius(fog), 1.5f * fog.integrator.radius);
  fog.integrator.volume_radius = 1.0f;
  EXPECT_FLOAT_EQ(spm::derived_volume_radius(fog), 1.0f);
  EXPECT_FLOAT_EQ(spm::derived_caustic_volume_radius(fog), 1.0f);  // never wider than the volume radius
  fog.integrator.volume_radius = 0.0f;
  fog.integrator.estimator = "paper";
  EXPECT_FLOAT_EQ(spm::derived_volume_radius(fog), fog.integrator.radius);
  EXPECT_FLOAT_EQ(spm::derived_caustic_volume_radius(fog), fog.integrator.radius);
  fog.integrator.estimator = "bre";
  fog.integrator.direct = "photons";  // single scattering around the lights, read from the records
  EXPECT_FLOAT_EQ(spm::derived_volume_radius(fog), fog.integrator.radius);
  EXPECT_FLOAT_EQ(spm::derived_caustic_volume_radius(fog), fog.integrator.radius);
  const spm::Scene smoke = spm::load_scene(SPM_SCENES_DIR "/smoke_cornell.xml", {});
  EXPECT_FLOAT_EQ(spm::derived_volume_radius(smoke), smoke.integrator.radius);
  EXPECT_FLOAT_EQ(spm::derived_caustic_volume_radius(smoke), smoke.integrator.radius);
}

// map_grid_data lists the core's records flagged SPM_RECORD_CAUSTIC in the
// caustic grid, of the caustic volume radius, and the others in the volume
// grid, each exactly once, with item indices into volume_records; the
// gather rays' grid lists them all. With a caustic radius not below the
// volume radius it leaves the caustic grid empty.
TEST(VolumeRadius, CausticRecordsGetAGridOfTheirOwn) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  spm::MapParts parts;
  parts.volume.resize(5000);
  size_t flagged = 0;
  for (size_t i = 0; i < parts.volume.size(); ++i) {
    SpmVolumeRecord& r = parts.volume[i];
    for (int c = 0; c < 3; ++c) r.position[c] = u(rng);
    r.stream = uint32_t(i);
    r.depth = 3;
    r.flags = i % 7 == 0 ? SPM_RECORD_CAUSTIC : 0u;
    flagged += i % 7 == 0;
  }
  spm::QueryBounds reach;
  reach.lo = glm::vec3(-1.2f);
  reach.hi = glm::vec3(1.2f);
  const float radius = 0.02f, volume_radius = 0.06f, caustic_radius = 0.03f;
  spm::PassRadii radii;
  radii.radius = radii.beam_radius = radius;
  radii.volume_radius = volume_radius;
  radii.caustic_volume_radius = caustic_radius;
  radii.final_gather = true;
  const spm::MapGridData d = spm::map_grid_data(parts, radii, true, reach);
  ASSERT_EQ(d.volume_records.size(), parts.volume.size());
  using spm::test::distinct;
  using spm::test::listed;
  using spm::test::role_row;
  EXPECT_TRUE(listed(d, role_row("outer")).empty());
  const size_t caustic_row = role_row("volume_caustic"), volume_row = role_row("volume");
  const std::vector<uint32_t> caustic = distinct(listed(d, caustic_row)), rest = distinct(listed(d, volume_row));
  EXPECT_EQ(caustic.size(), flagged);
  EXPECT_EQ(rest.size(), parts.volume.size() - flagged);
  for (uint32_t i : caustic) EXPECT_TRUE(d.volume_records[i].flags & SPM_RECORD_CAUSTIC);
  for (uint32_t i : rest) EXPECT_FALSE(d.volume_records[i].flags & SPM_RECORD_CAUSTIC);
  EXPECT_EQ(distinct(listed(d, role_row("gather_volume"))).size(), parts.volume.size());
  // Cells of twice each grid's radius (record_grid.h), read with that radius.
  EXPECT_NEAR(d.grids[caustic_row].info.cell, 2.0f * caustic_radius, 1e-6f);
  EXPECT_NEAR(d.grids[volume_row].info.cell, 2.0f * volume_radius, 1e-6f);
  EXPECT_EQ(d.grids[caustic_row].radius[SPM_READ_CAMERA], caustic_radius);
  EXPECT_EQ(d.grids[volume_row].radius[SPM_READ_CAMERA], volume_radius);
  // An item's position is its record's.
  const SpmMapGrid& g = d.grids[caustic_row];
  const uint32_t first = g.first_item + d.grid_cells[g.first_cell];
  const std::vector<uint32_t> items = listed(d, caustic_row);
  for (size_t k = 0; k < items.size(); ++k) {
    EXPECT_EQ(d.grid_pos[first + k].s[0], d.volume_records[items[k]].position[0]);
  }
  radii.caustic_volume_radius = volume_radius;
  const spm::MapGridData one = spm::map_grid_data(parts, radii, true, reach);
  EXPECT_EQ(one.grids[caustic_row].info.records, 0u);
  EXPECT_EQ(distinct(listed(one, volume_row)).size(), parts.volume.size());
}

// A light inside a glass sphere in fog: every stream leaves the glass at
// its first vertex, so its first medium event (depth 2) is a caustic
// record, and with max_depth 3 (the camera reads records of depth 2 at
// most, METHOD.md 10) the camera's volume term holds caustic records
// alone, and reads them with the caustic radius
// whatever the volume radius: the term with volume radius 4.5 (caustic
// radius 1.5 radii, 2.25) is the term with volume radius 2.25, up to the
// order of the sums. With every depth, the records after a diffuse event
// take the volume radius, and the terms differ.
TEST(VolumeRadius, CausticRecordsKeepTheCausticRadius) {
  std::string text = spm::test::read_file(SPM_SCENES_DIR "/caustic_area.xml");
  const std::string light = "<point name=\"center\" x=\"0\" y=\"80\" z=\"0\"/>";
  ASSERT_NE(text.find(light), std::string::npos);
  text.replace(text.find(light), light.size(), "<point name=\"center\" x=\"0\" y=\"24\" z=\"0\"/>");
  // The light sits in the glass's clear inside, not in the fog.
  const std::string fog = "<ref name=\"exterior\" id=\"fog\"/>";
  text.erase(text.rfind(fog), fog.size());
  const auto term = [&](float volume_radius, int max_depth) {
    spm::Scene scene = spm::load_scene_string(text, "glass_light.xml", {{"res", "24"}, {"streams", "4000"}});
    scene.integrator.volume_radius = volume_radius;
    scene.integrator.max_depth = max_depth;
    return spm::test::render_terms(scene, 1, 2, 5, SPM_TERM_VOLUME);
  };
  ASSERT_FLOAT_EQ(spm::derived_caustic_volume_radius(spm::load_scene_string(text, "glass_light.xml", {})), 2.25f);
  const std::vector<float> wide = term(4.5f, 3), narrow = term(2.25f, 3);
  ASSERT_GT(spm::test::image_mean(narrow), 0.0);
  ASSERT_EQ(wide.size(), narrow.size());
  double largest = 0.0;
  for (size_t i = 0; i < wide.size(); ++i) {
    largest = std::max(largest, double(std::abs(wide[i] - narrow[i])) / (std::abs(narrow[i]) + 1e-6));
  }
  EXPECT_LT(largest, 1e-4);
  const std::vector<float> wide_all = term(4.5f, -1), narrow_all = term(2.25f, -1);
  double apart = 0.0;
  for (size_t i = 0; i < wide_all.size(); ++i) {
    apart = std::max(apart, double(std::abs(wide_all[i] - narrow_all[i])) / (std::abs(narrow_all[i]) + 1e-6));
  }
  EXPECT_GT(apart, 1e-2);
}

}  // namespace
