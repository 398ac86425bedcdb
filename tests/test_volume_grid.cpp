// Volume grids: the .vol round trip, every class of bad .vol file, the
// lookup by hand and against Mitsuba 3's gridvolume, OpenVDB float grids, and
// spm vdb2vol.
#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "cli_support.h"
#include "scene/volume_grid.h"
#include "test_support.h"
#include "util/errors.h"

namespace {

namespace fs = std::filesystem;

using Grid = spm::VolumeGrid;
using spm::test::count_lines;

// A .vol header: the fields in file order, each overridable by a test.
struct Header {
  std::string magic = "VOL";
  int version = 3;
  int32_t encoding = 1, nx = 2, ny = 3, nz = 4, channels = 1;
  float box[6] = {0, 0, 0, 1, 1, 1};

  std::string bytes() const {
    std::string s = magic;
    s += static_cast<char>(version);
    for (const int32_t v : {encoding, nx, ny, nz, channels}) s.append(reinterpret_cast<const char*>(&v), 4);
    s.append(reinterpret_cast<const char*>(box), sizeof box);
    return s;
  }
};

std::string floats(const std::vector<float>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float));
}

// The header's grid with all values 1, then `values` written over its start.
std::string vol_file(const Header& h, std::vector<float> values = {}) {
  values.resize(static_cast<size_t>(h.nx) * h.ny * h.nz * h.channels, 1.0f);
  return h.bytes() + floats(values);
}

class VolumeGrid : public spm::test::CliTest {
 protected:
  // The message of the InputError read_vol throws on a file of `bytes`; ""
  // (and a failure) if it throws none. parse_vol must say the same, but for
  // the name.
  std::string refusal(const std::string& bytes) {
    const std::string file = write("bad.vol", bytes);
    std::string from_file, from_bytes;
    try {
      spm::read_vol(file);
      ADD_FAILURE() << "read_vol accepted the file";
    } catch (const spm::InputError& e) {
      from_file = e.what();
    }
    try {
      spm::parse_vol(file, bytes);
      ADD_FAILURE() << "parse_vol accepted the bytes";
    } catch (const spm::InputError& e) {
      from_bytes = e.what();
    }
    EXPECT_EQ(from_file, from_bytes);
    EXPECT_EQ(from_file.rfind(file + ": ", 0), 0u) << from_file;
    EXPECT_EQ(from_file.find('\n'), std::string::npos) << from_file;
    return from_file;
  }

  static Grid random_grid(uint32_t nx, uint32_t ny, uint32_t nz, uint32_t channels, unsigned seed) {
    Grid g;
    g.nx = nx;
    g.ny = ny;
    g.nz = nz;
    g.channels = channels;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1e3f);
    g.bbox_min = glm::vec3(u(rng), -u(rng), 0.5f);
    g.bbox_max = g.bbox_min + glm::vec3(u(rng), 1.0f, 2.0f);
    for (size_t i = 0; i < size_t(nx) * ny * nz * channels; ++i)
      g.data.push_back(i % 5 == 0 ? 0.0f : i % 7 == 0 ? std::numeric_limits<float>::denorm_min() : u(rng));
    return g;
  }
};

TEST_F(VolumeGrid, VolRoundTripIsBitExact) {
  for (const Grid& g : {random_grid(7, 5, 3, 1, 1), random_grid(3, 1, 9, 3, 2), random_grid(1, 1, 1, 3, 3)}) {
    const std::string file = path("round.vol");
    spm::write_vol(file, g);
    EXPECT_EQ(fs::file_size(file), 48 + 4 * g.data.size());
    const Grid back = spm::read_vol(file);
    EXPECT_EQ(back.nx, g.nx);
    EXPECT_EQ(back.ny, g.ny);
    EXPECT_EQ(back.nz, g.nz);
    EXPECT_EQ(back.channels, g.channels);
    EXPECT_EQ(back.bbox_min, g.bbox_min);
    EXPECT_EQ(back.bbox_max, g.bbox_max);
    ASSERT_EQ(back.data.size(), g.data.size());
    EXPECT_EQ(std::memcmp(back.data.data(), g.data.data(), g.data.size() * sizeof(float)), 0);
    EXPECT_EQ(back.max_value(), g.max_value());
  }
  // Nothing but the final file is left in the directory.
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir_)) files += e.path().filename() == "round.vol" ? 1 : 100;
  EXPECT_EQ(files, 1);
}

TEST_F(VolumeGrid, WritingAnInconsistentGridFails) {
  Grid g = random_grid(2, 2, 2, 1, 4);
  g.data.pop_back();
  EXPECT_THROW(spm::write_vol(path("bad.vol"), g), spm::RuntimeError);
  EXPECT_FALSE(fs::exists(path("bad.vol")));
}

TEST_F(VolumeGrid, MissingFile) {
  try {
    spm::read_vol(path("none.vol"));
    FAIL() << "read_vol accepted a missing file";
  } catch (const spm::InputError& e) {
    EXPECT_EQ(std::string(e.what()), path("none.vol") + ": file does not exist");
  }
  fs::create_directories(path("dir.vol"));
  EXPECT_THROW(spm::read_vol(path("dir.vol")), spm::InputError);
}

TEST_F(VolumeGrid, EmptyFile) { EXPECT_NE(refusal("").find("empty file"), std::string::npos); }

TEST_F(VolumeGrid, TruncatedHeader) {
  EXPECT_NE(refusal(Header().bytes().substr(0, 20)).find("truncated header: 20 of 48 bytes"), std::string::npos);
  EXPECT_NE(refusal("VO").find("truncated header: 2 of 48 bytes"), std::string::npos);
}

TEST_F(VolumeGrid, WrongMagic) {
  Header h;
  h.magic = "VOX";
  EXPECT_NE(refusal(vol_file(h)).find("not a .vol file: it does not start with 'VOL'"), std::string::npos);
  EXPECT_NE(refusal("<scene/>").find("not a .vol file"), std::string::npos);
}

TEST_F(VolumeGrid, WrongVersion) {
  Header h;
  h.version = 2;
  EXPECT_NE(refusal(vol_file(h)).find("version 2 is not read, only version 3"), std::string::npos);
}

TEST_F(VolumeGrid, EncodingNotFloat32) {
  Header h;
  h.encoding = 3;
  EXPECT_NE(refusal(vol_file(h)).find("encoding 3 (uint8) is not read, only 1 (float32)"), std::string::npos);
  h.encoding = 77;
  EXPECT_NE(refusal(vol_file(h)).find("encoding 77 is not read"), std::string::npos);
}

TEST_F(VolumeGrid, ZeroOrNegativeDimensions) {
  Header h;
  h.ny = 0;
  EXPECT_NE(refusal(h.bytes()).find("grid size 2 x 0 x 4 is not positive"), std::string::npos);
  h.ny = 3;
  h.nz = -4;
  EXPECT_NE(refusal(h.bytes()).find("grid size 2 x 3 x -4 is not positive"), std::string::npos);
}

TEST_F(VolumeGrid, AbsurdDimensions) {
  // 2^31 - 1 cubed overflows 64 bits: the product must be guarded, not computed.
  Header h;
  h.nx = h.ny = h.nz = std::numeric_limits<int32_t>::max();
  EXPECT_NE(refusal(h.bytes()).find("exceeds the limit of 2147483648 values"), std::string::npos);
  h.nx = 1 << 16;
  h.ny = 1 << 15;
  h.nz = 1;
  h.channels = 3;  // 2^31 voxels, 3 * 2^31 values
  EXPECT_NE(refusal(h.bytes()).find("65536 x 32768 x 1 voxels x 3 channel(s) exceeds"), std::string::npos);
}

TEST_F(VolumeGrid, FileSizeDisagreesWithDimensions) {
  const Header h;  // 2 x 3 x 4 x 1: 48 + 96 bytes
  const std::string whole = vol_file(h);
  EXPECT_NE(refusal(whole.substr(0, whole.size() - 4))
                .find("file is 140 bytes, but a 2 x 3 x 4 grid of 1 channel(s) takes 144 (48 header + 96 values)"),
            std::string::npos);
  EXPECT_NE(refusal(whole + "x").find("file is 145 bytes, but"), std::string::npos);
}

TEST_F(VolumeGrid, BadValuesNameTheVoxel) {
  Header h;
  h.channels = 3;
  // Value index ((z * ny + y) * nx + x) * 3 + c: voxel (1, 2, 3) channel 2 is 3 * 23 + 2.
  std::vector<float> v(72, 1.0f);
  v[71] = std::nanf("");
  EXPECT_NE(refusal(vol_file(h, v)).find("value at voxel (1, 2, 3) channel 2 is NaN"), std::string::npos);
  v[71] = std::numeric_limits<float>::infinity();
  EXPECT_NE(refusal(vol_file(h, v)).find("value at voxel (1, 2, 3) channel 2 is infinite"), std::string::npos);
  v[71] = 1.0f;
  v[4] = -0.5f;  // voxel (1, 0, 0) channel 1
  EXPECT_NE(refusal(vol_file(h, v)).find("value at voxel (1, 0, 0) channel 1 is negative (-0.5)"), std::string::npos);
}

TEST_F(VolumeGrid, ChannelsOtherThanOneOrThree) {
  for (const int32_t channels : {0, 2, 6, -1}) {
    Header h;
    h.channels = channels;
    EXPECT_NE(refusal(h.bytes()).find(std::to_string(channels) + " channels, only 1 or 3 are read"), std::string::npos);
  }
}

TEST_F(VolumeGrid, NonFiniteBoundingBox) {
  Header h;
  h.box[4] = std::numeric_limits<float>::infinity();
  EXPECT_NE(refusal(vol_file(h)).find("bounding box (0, 0, 0) .. (1, inf, 1) is not finite"), std::string::npos);
}

// v(x, y, z) = 1 + x + 2y + 4z on 2 x 2 x 2 texels: linear, so that trilinear
// gives 1 + u.x + 2 u.y + 4 u.z with u = clamp(2p - 0.5, 0, 1), texel centres
// at 0.25 and 0.75.
Grid ramp() {
  Grid g;
  g.nx = g.ny = g.nz = 2;
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x) g.data.push_back(1.0f + x + 2.0f * y + 4.0f * z);
  return g;
}

TEST_F(VolumeGrid, TrilinearLookup) {
  const Grid g = ramp();
  const auto at = [&](float x, float y, float z) { return spm::grid_lookup(g, glm::vec3(x, y, z), 0, false); };
  // Texel centres.
  EXPECT_FLOAT_EQ(at(0.25f, 0.25f, 0.25f), 1.0f);
  EXPECT_FLOAT_EQ(at(0.75f, 0.25f, 0.75f), 6.0f);
  EXPECT_FLOAT_EQ(at(0.75f, 0.75f, 0.75f), 8.0f);
  // Midway between centres.
  EXPECT_FLOAT_EQ(at(0.5f, 0.25f, 0.25f), 1.5f);
  EXPECT_FLOAT_EQ(at(0.5f, 0.5f, 0.5f), 4.5f);
  EXPECT_FLOAT_EQ(at(0.375f, 0.625f, 0.5f), 1.25f + 1.5f + 2.0f);
  // Within half a texel of a face: no change along its normal.
  EXPECT_FLOAT_EQ(at(0.1f, 0.25f, 0.25f), 1.0f);
  EXPECT_FLOAT_EQ(at(0.0f, 0.0f, 0.0f), 1.0f);
  EXPECT_FLOAT_EQ(at(1.0f, 1.0f, 1.0f), 8.0f);
  EXPECT_FLOAT_EQ(at(0.9f, 0.6f, 0.3f), 1.0f + 1.0f + 1.4f + 0.4f);
  // Outside the cube: the lookup at the nearest point of the cube, not 0.
  EXPECT_FLOAT_EQ(at(-5.0f, 0.5f, 0.5f), 1.0f + 1.0f + 2.0f);
  EXPECT_FLOAT_EQ(at(2.0f, 2.0f, 2.0f), 8.0f);
  EXPECT_FLOAT_EQ(at(0.5f, -1e30f, 7.0f), 1.5f + 4.0f);
  EXPECT_FLOAT_EQ(at(std::numeric_limits<float>::infinity(), 0.25f, 0.25f), 2.0f);
  EXPECT_TRUE(std::isfinite(at(std::nanf(""), 0.5f, 0.5f)));
}

TEST_F(VolumeGrid, NearestLookup) {
  const Grid g = ramp();
  const auto at = [&](float x, float y, float z) { return spm::grid_lookup(g, glm::vec3(x, y, z), 0, true); };
  EXPECT_EQ(at(0.25f, 0.25f, 0.25f), 1.0f);
  EXPECT_EQ(at(0.49f, 0.51f, 0.99f), 7.0f);  // texel (0, 1, 1)
  EXPECT_EQ(at(0.5f, 0.0f, 0.0f), 2.0f);     // a border belongs to the texel above it
  EXPECT_EQ(at(1.0f, 1.0f, 1.0f), 8.0f);
  EXPECT_EQ(at(-1.0f, 2.0f, 0.25f), 3.0f);   // clamped to texel (0, 1, 0)
}

TEST_F(VolumeGrid, LookupReadsTheChannel) {
  // 3 x 1 x 1 texels of 3 channels: (x, 10 x, 100 + x).
  Grid g;
  g.nx = 3;
  g.ny = g.nz = 1;
  g.channels = 3;
  for (int x = 0; x < 3; ++x) g.data.insert(g.data.end(), {float(x), 10.0f * x, 100.0f + x});
  EXPECT_FLOAT_EQ(spm::grid_lookup(g, glm::vec3(0.5f, 0.9f, 0.1f), 1, false), 10.0f);
  EXPECT_FLOAT_EQ(spm::grid_lookup(g, glm::vec3(1.0f / 3.0f, 0.5f, 0.5f), 2, false), 100.5f);
  EXPECT_FLOAT_EQ(spm::grid_lookup(g, glm::vec3(0.9f, 0.5f, 0.5f), 0, true), 2.0f);
}

// Mitsuba 3's own lookups, written by tools/check_gridvolume.py: its grids
// (VolumeGrid.write) and gridvolume's values at every kind of point. The
// script points SPM_GRIDVOLUME_REFERENCE at a fresh set; the suite reads the
// committed one.
TEST_F(VolumeGrid, MatchesMitsubaGridvolume) {
  const char* env = std::getenv("SPM_GRIDVOLUME_REFERENCE");
  const fs::path dir = env && *env ? fs::path(env) : fs::path(SPM_TEST_DATA_DIR) / "volume";
  std::ifstream in(dir / "lookups.txt");
  ASSERT_TRUE(in) << "no " << (dir / "lookups.txt") << " (tools/check_gridvolume.py --update writes it)";
  std::map<std::string, Grid> grids;
  std::map<std::string, double> worst, largest;  // by filter
  int lookups = 0;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    std::string name, filter;
    glm::vec3 p;
    s >> name >> filter >> p.x >> p.y >> p.z;
    ASSERT_TRUE(s && (filter == "trilinear" || filter == "nearest")) << line;
    if (!grids.count(name)) grids[name] = spm::read_vol((dir / name).string());
    const Grid& g = grids[name];
    for (uint32_t c = 0; c < g.channels; ++c) {
      float expected;
      ASSERT_TRUE(s >> expected) << line;
      const float got = spm::grid_lookup(g, p, c, filter == "nearest");
      worst[filter] = std::max(worst[filter], double(std::fabs(got - expected)));
      largest[filter] = std::max(largest[filter], double(std::fabs(expected)));
      ++lookups;
    }
  }
  ASSERT_GT(lookups, 1000);
  std::printf("grid_lookup vs Mitsuba gridvolume: %d lookups (values up to %.3g), max |difference| trilinear %.3g, "
              "nearest %.3g\n",
              lookups, largest["trilinear"], worst["trilinear"], worst["nearest"]);
  ::testing::Test::RecordProperty("max_difference_trilinear", std::to_string(worst["trilinear"]));
  ::testing::Test::RecordProperty("max_difference_nearest", std::to_string(worst["nearest"]));
  // The same float operations, fused where the Mitsuba 3.9.1 wheel fuses them.
  EXPECT_EQ(worst["nearest"], 0.0);
  EXPECT_EQ(worst["trilinear"], 0.0);
}

// OpenVDB files, written here with OpenVDB's API.
openvdb::FloatGrid::Ptr float_grid(const std::string& name, float background = 0.0f) {
  openvdb::initialize();
  openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(background);
  g->setName(name);
  return g;
}

void write_vdb(const std::string& file, const openvdb::GridPtrVec& grids) {
  openvdb::io::File out(file);
  out.write(grids);
  out.close();
}

// Voxels at index (-1, 0, 2) .. (2, 3, 4), world = index * (0.5, 0.25, 2) + (1, 2, 3).
openvdb::FloatGrid::Ptr density() {
  openvdb::FloatGrid::Ptr g = float_grid("density", 0.125f);
  openvdb::math::Transform::Ptr t = openvdb::math::Transform::createLinearTransform(1.0);
  t->postScale(openvdb::Vec3d(0.5, 0.25, 2.0));
  t->postTranslate(openvdb::Vec3d(1.0, 2.0, 3.0));
  g->setTransform(t);
  openvdb::FloatGrid::Accessor acc = g->getAccessor();
  acc.setValue(openvdb::Coord(-1, 0, 2), 1.5f);
  acc.setValue(openvdb::Coord(2, 3, 4), 4.0f);
  acc.setValue(openvdb::Coord(0, 1, 3), 0.0f);
  acc.setValueOff(openvdb::Coord(1, 2, 3), 9.0f);  // inactive: read as the background
  return g;
}

TEST_F(VolumeGrid, ReadsAnOpenVdbFloatGrid) {
  openvdb::Vec3SGrid::Ptr velocity = openvdb::Vec3SGrid::create();
  velocity->setName("velocity");
  write_vdb(path("smoke.vdb"), {velocity, density()});
  const Grid g = spm::read_vdb(path("smoke.vdb"), "density");
  ASSERT_EQ(g.nx, 4u);
  ASSERT_EQ(g.ny, 4u);
  ASSERT_EQ(g.nz, 3u);
  EXPECT_EQ(g.channels, 1u);
  ASSERT_EQ(g.data.size(), 48u);
  // The box of the voxels: index (-1.5, -0.5, 1.5) .. (2.5, 3.5, 4.5) mapped.
  EXPECT_EQ(g.bbox_min, glm::vec3(0.25f, 1.875f, 6.0f));
  EXPECT_EQ(g.bbox_max, glm::vec3(2.25f, 2.875f, 12.0f));
  const auto at = [&](int x, int y, int z) { return g.data[(size_t(z - 2) * 4 + y) * 4 + (x + 1)]; };
  EXPECT_EQ(at(-1, 0, 2), 1.5f);
  EXPECT_EQ(at(2, 3, 4), 4.0f);
  EXPECT_EQ(at(0, 1, 3), 0.0f);
  EXPECT_EQ(at(1, 2, 3), 0.125f);
  EXPECT_EQ(at(2, 0, 2), 0.125f);
  EXPECT_EQ(g.max_value(), 4.0f);
}

TEST_F(VolumeGrid, VdbGridMissing) {
  openvdb::Vec3SGrid::Ptr velocity = openvdb::Vec3SGrid::create();
  velocity->setName("velocity");
  write_vdb(path("smoke.vdb"), {velocity, density()});
  try {
    spm::read_vdb(path("smoke.vdb"), "heat");
    FAIL() << "read_vdb found a grid 'heat'";
  } catch (const spm::InputError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind(path("smoke.vdb") + ": no grid named 'heat' (grids: ", 0), 0u) << m;
    EXPECT_NE(m.find("'density'"), std::string::npos) << m;
    EXPECT_NE(m.find("'velocity'"), std::string::npos) << m;
  }
}

// The message of the InputError read_vdb throws; "" (and a failure) if none.
std::string vdb_refusal(const std::string& file, const std::string& grid) {
  try {
    spm::read_vdb(file, grid);
    ADD_FAILURE() << "read_vdb accepted grid '" << grid << "' of " << file;
  } catch (const spm::InputError& e) {
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    return e.what();
  }
  return "";
}

TEST_F(VolumeGrid, BadVdbFiles) {
  EXPECT_NE(vdb_refusal(path("none.vdb"), "density").find("file does not exist"), std::string::npos);
  EXPECT_NE(vdb_refusal(write("text.vdb", "not a vdb file\n"), "density").find("cannot read as an OpenVDB file"),
            std::string::npos);

  openvdb::Vec3SGrid::Ptr velocity = openvdb::Vec3SGrid::create();
  velocity->setName("velocity");
  openvdb::FloatGrid::Ptr empty = float_grid("empty");
  openvdb::FloatGrid::Ptr level_set = float_grid("sdf", 0.3f);
  level_set->setGridClass(openvdb::GRID_LEVEL_SET);
  level_set->tree().setValue(openvdb::Coord(0), -0.1f);
  openvdb::FloatGrid::Ptr negative = float_grid("negative");
  negative->tree().setValue(openvdb::Coord(3, -2, 5), -2.0f);
  openvdb::FloatGrid::Ptr bad_background = float_grid("bad_background", -1.0f);
  bad_background->tree().setValue(openvdb::Coord(0), 1.0f);
  bad_background->tree().setValue(openvdb::Coord(2, 0, 0), 1.0f);
  openvdb::FloatGrid::Ptr rotated = float_grid("rotated");
  rotated->transform().postRotate(0.3, openvdb::math::Y_AXIS);
  rotated->tree().setValue(openvdb::Coord(0), 1.0f);
  openvdb::FloatGrid::Ptr frustum = float_grid("frustum");
  frustum->setTransform(openvdb::math::Transform::createFrustumTransform(
      openvdb::BBoxd(openvdb::Vec3d(0.0), openvdb::Vec3d(10.0)), 0.5, 2.0));
  frustum->tree().setValue(openvdb::Coord(0), 1.0f);
  write_vdb(path("bad.vdb"), {velocity, empty, level_set, negative, bad_background, rotated, frustum});

  const std::string file = path("bad.vdb");
  EXPECT_NE(vdb_refusal(file, "velocity").find("grid 'velocity' holds vec3s values, not float"), std::string::npos);
  EXPECT_NE(vdb_refusal(file, "empty").find("grid 'empty' has no active voxels"), std::string::npos);
  EXPECT_NE(vdb_refusal(file, "sdf").find("grid 'sdf' is a level set"), std::string::npos);
  EXPECT_NE(vdb_refusal(file, "negative").find("grid 'negative''s value at voxel (3, -2, 5) is negative (-2)"),
            std::string::npos);
  EXPECT_NE(vdb_refusal(file, "bad_background")
                .find("grid 'bad_background''s background, which its inactive voxel (1, 0, 0) takes, is negative (-1)"),
            std::string::npos);
  EXPECT_NE(vdb_refusal(file, "rotated").find("grid 'rotated' has a transform that rotates, shears or mirrors"),
            std::string::npos);
  EXPECT_NE(vdb_refusal(file, "frustum").find("grid 'frustum' has a non-linear transform"), std::string::npos);
}

TEST_F(VolumeGrid, Vdb2VolThroughTheCli) {
  write_vdb(path("smoke.vdb"), {density()});
  const spm::test::Outcome ok = run("vdb2vol " + path("smoke.vdb") + " " + path("smoke.vol"));
  ASSERT_EQ(ok.code, 0) << ok.err;
  const Grid vdb = spm::read_vdb(path("smoke.vdb"), "density");
  const Grid vol = spm::read_vol(path("smoke.vol"));
  EXPECT_EQ(vol.data, vdb.data);
  EXPECT_EQ(vol.bbox_min, vdb.bbox_min);
  EXPECT_EQ(vol.bbox_max, vdb.bbox_max);
  EXPECT_EQ(vol.nx, vdb.nx);
  EXPECT_EQ(vol.nz, vdb.nz);

  const spm::test::Outcome named = run("vdb2vol " + path("smoke.vdb") + " " + path("named.vol") + " --grid density");
  EXPECT_EQ(named.code, 0) << named.err;

  const spm::test::Outcome missing = run("vdb2vol " + path("smoke.vdb") + " " + path("out.vol") + " --grid heat");
  EXPECT_EQ(missing.code, 2);
  EXPECT_EQ(count_lines(missing.err), 1) << missing.err;
  EXPECT_EQ(missing.err, "spm: " + path("smoke.vdb") + ": no grid named 'heat' (grids: 'density')\n");
  EXPECT_FALSE(fs::exists(path("out.vol")));

  const spm::test::Outcome absent = run("vdb2vol " + path("none.vdb") + " " + path("out.vol"));
  EXPECT_EQ(absent.code, 2);
  EXPECT_EQ(absent.err, "spm: " + path("none.vdb") + ": file does not exist\n");
  EXPECT_FALSE(fs::exists(path("out.vol")));
}

}  // namespace
