// The gather's grid table (host/spm/map_grids.cpp, kernels/lib/maps.h):
// every role's grid lists exactly the records its rule selects, and every
// reader's estimate over the grids it reads equals a brute-force sum over
// those records with the radius the table gives it, role by role.
#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>

#include "map_table.h"
#include "spm/map_grids.h"
#include "test_support.h"

namespace {

using glm::dvec3;
using spm::test::v3;

// A scene's worth of records: volume records in a box of half-edge 2 and a
// fifth of them far outside it, a fifth flagged caustic, depths 1 to 5;
// surface records on the plane y = 0, some of streams without an earlier
// event and some caustic; stream beams. Each record's `stream` is its
// index here, so that a grid's items can be traced back.
struct Records {
  std::vector<SpmVolumeRecord> volume;
  std::vector<SpmSurfaceRecord> surface;
  std::vector<SpmBeam> beams;
};

Records make_records(uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> box(-2.0f, 2.0f), far(-60.0f, 60.0f), unit(-1.0f, 1.0f), flux(0.1f, 2.0f);
  Records r;
  r.volume.resize(12000);
  for (size_t i = 0; i < r.volume.size(); ++i) {
    SpmVolumeRecord& v = r.volume[i];
    for (int c = 0; c < 3; ++c) {
      v.position[c] = i % 5 == 0 ? far(rng) : box(rng);
      v.flux[c] = flux(rng);
    }
    const glm::vec3 d = glm::normalize(glm::vec3(unit(rng), unit(rng), unit(rng)) + glm::vec3(1e-3f));
    for (int c = 0; c < 3; ++c) v.direction[c] = d[c];
    v.stream = uint32_t(i);
    v.depth = 1 + uint32_t(rng() % 5);
    v.flags = rng() % 5 == 0 ? SPM_RECORD_CAUSTIC : 0u;
  }
  r.surface.resize(12000);
  for (size_t i = 0; i < r.surface.size(); ++i) {
    SpmSurfaceRecord& s = r.surface[i];
    s.position[0] = box(rng);
    s.position[2] = box(rng);
    s.normal[1] = 1.0f;
    for (int c = 0; c < 3; ++c) s.flux[c] = flux(rng);
    s.stream = uint32_t(i);
    s.depth_photon = (1u + uint32_t(rng() % 5)) << 16;
    s.flags = (rng() % 4 != 0 ? SPM_RECORD_HAD_EVENT : 0u) | (rng() % 3 == 0 ? SPM_RECORD_CAUSTIC : 0u);
  }
  r.beams.resize(1500);
  for (size_t i = 0; i < r.beams.size(); ++i) {
    SpmBeam& b = r.beams[i];
    const glm::vec3 d = glm::normalize(glm::vec3(unit(rng), unit(rng), unit(rng)) + glm::vec3(1e-3f));
    for (int c = 0; c < 3; ++c) {
      b.origin[c] = box(rng);
      b.direction[c] = d[c];
      b.flux[c] = flux(rng);
    }
    b.length = 0.5f + std::abs(box(rng));
    b.stream = uint32_t(i);
    b.depth = 1 + uint32_t(rng() % 5);
  }
  return r;
}

// The rule each role's grid follows, written out from map_grids.h's
// description with next-event estimation (skip_direct): which records it
// lists, by their index in `Records`.
std::set<uint32_t> expected(const std::string& role, const Records& rec, const spm::PassRadii& p,
                            const spm::QueryBounds& reach) {
  std::set<uint32_t> out;
  if (role == "beams") {
    for (const SpmBeam& b : rec.beams) {
      if (p.final_gather || b.depth > 1) out.insert(b.stream);
    }
    return out;
  }
  if (role == "surface" || role == "caustic") {
    for (const SpmSurfaceRecord& s : rec.surface) {
      if (!(s.flags & SPM_RECORD_HAD_EVENT) || !reach.contains(s.position)) continue;
      if (role == "caustic" && !(s.flags & SPM_RECORD_CAUSTIC)) continue;
      out.insert(s.stream);
    }
    return out;
  }
  std::vector<const SpmVolumeRecord*> kept;
  for (const SpmVolumeRecord& v : rec.volume) {
    if (p.final_gather || v.depth > 1) kept.push_back(&v);
  }
  const spm::QueryBounds core = spm::volume_core(reach, kept.size(), p.volume_radius);
  const bool split = p.caustic_volume_radius < p.volume_radius;
  for (const SpmVolumeRecord* v : kept) {
    const bool in = core.contains(v->position), caustic = split && (v->flags & SPM_RECORD_CAUSTIC);
    if ((role == "outer" && !in) || (role == "gather_volume" && in) || (role == "volume" && in && !caustic) ||
        (role == "volume_caustic" && in && caustic))
      out.insert(v->stream);
  }
  return out;
}

// `table` with every row's radii but reader `reader` of row `row` set to 0:
// what that reader reads of that role alone.
spm::MapGridData only(spm::MapGridData table, size_t row, cl_uint reader) {
  for (size_t g = 0; g < table.grids.size(); ++g) {
    for (cl_uint k = 0; k < SPM_READERS; ++k) {
      if (g != row || k != reader) table.grids[g].radius[k] = 0.0f;
    }
  }
  return table;
}

// The surface estimate at x (normal +y, on the records' plane) written out
// over `records` with the uniform kernel: METHOD.md 5.
dvec3 surface_reference(const std::vector<SpmSurfaceRecord>& records, const std::set<uint32_t>& listed, dvec3 x,
                        double r) {
  dvec3 sum(0.0);
  for (const SpmSurfaceRecord& s : records) {
    if (!listed.count(s.stream)) continue;
    const dvec3 off = v3(s.position) - x;
    if (glm::dot(off, off) >= r * r) continue;
    sum += v3(s.flux) / (spm::test::kPi * r * r);
  }
  return sum;
}

// A pass's radii, and who reads each role with what radius: role, then
// {camera, gather, vertex, gather end, gather hop} (SPM_READ_*).
struct Case {
  const char* what;
  spm::PassRadii radii;
  std::map<std::string, spm::MapGridData::Radii> readers;
};

class GridTable : public ::testing::TestWithParam<int> {};

TEST_P(GridTable, EveryRolesGridFindsWhatABruteForceSearchFinds) {
  // Final gather or not, the gather rays' own grid (radius below the
  // volume radius) or not, caustic volume records apart or not, stream
  // beams instead of records.
  const std::vector<Case> cases = {
      {"final gather, own gather grid, caustic records apart",
       {0.08f, 0.24f, 0.12f, 0.1f, true, false},
       {{"surface", {0, 0, 0, 0.08f, 0}},
        {"caustic", {0, 0, 0.08f, 0, 0.08f}},
        {"volume", {0.24f, 0, 0, 0, 0}},
        {"gather_volume", {0, 0.08f, 0, 0, 0}},
        {"outer", {0.24f, 0.08f, 0, 0, 0}},
        {"volume_caustic", {0.12f, 0, 0, 0, 0}},
        {"beams", {}}}},
      {"no final gather, caustic records apart",
       {0.08f, 0.2f, 0.12f, 0.1f, false, false},
       {{"surface", {0, 0, 0.08f, 0, 0}},
        {"caustic", {}},
        {"volume", {0.2f, 0, 0, 0, 0}},
        {"gather_volume", {}},
        {"outer", {0.2f, 0, 0, 0, 0}},
        {"volume_caustic", {0.12f, 0, 0, 0, 0}},
        {"beams", {}}}},
      {"final gather, one volume radius",
       {0.1f, 0.1f, 0.15f, 0.1f, true, false},
       {{"surface", {0, 0, 0, 0.1f, 0}},
        {"caustic", {0, 0, 0.1f, 0, 0.1f}},
        {"volume", {0.1f, 0.1f, 0, 0, 0}},
        {"gather_volume", {}},
        {"outer", {0.1f, 0.1f, 0, 0, 0}},
        {"volume_caustic", {}},
        {"beams", {}}}},
      {"stream beams, final gather",
       {0.1f, 0.1f, 0.1f, 0.12f, true, true},
       {{"surface", {0, 0, 0, 0.1f, 0}},
        {"caustic", {0, 0, 0.1f, 0, 0.1f}},
        {"volume", {}},
        {"gather_volume", {}},
        {"outer", {}},
        {"volume_caustic", {}},
        {"beams", {0.12f, 0.12f, 0, 0, 0}}}}};
  const Case& c = cases[size_t(GetParam())];
  SCOPED_TRACE(c.what);
  const Records rec = make_records(11 + uint32_t(GetParam()));
  spm::QueryBounds reach;
  reach.lo = glm::vec3(-2.1f);
  reach.hi = glm::vec3(2.1f);
  spm::MapParts parts;
  if (c.radii.beams) {
    parts.beams = rec.beams;
  } else {
    parts.volume = rec.volume;
  }
  parts.surface = rec.surface.data();
  parts.surface_count = rec.surface.size();
  const spm::MapGridData data = spm::map_grid_data(parts, c.radii, true, reach);
  const std::vector<spm::GridRole>& roles = spm::grid_roles();
  ASSERT_EQ(data.grids.size(), roles.size());

  auto& dev = spm::test::device();
  SpmMedium clear{};
  clear.albedo[0] = clear.albedo[1] = clear.albedo[2] = 1.0f;
  const cl::Buffer media = dev.upload("media", std::vector<SpmMedium>{clear});
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> box(-1.9f, 1.9f), unit(-1.0f, 1.0f);
  const int n = 200;
  std::vector<cl_float4> origins(n), dirs(n), points(n), normals(n, cl_float4{{0.0f, 1.0f, 0.0f, 0.0f}});
  for (int i = 0; i < n; ++i) {
    const glm::vec3 d = glm::normalize(glm::vec3(unit(rng), unit(rng), unit(rng)) + glm::vec3(1e-3f));
    // Rays from inside the box out past it: they reach the outer records too.
    origins[i] = {{box(rng), box(rng), box(rng), 0.0f}};
    dirs[i] = {{d.x, d.y, d.z, i % 2 == 0 ? 3.0f : 80.0f}};
    points[i] = {{box(rng), 0.0f, box(rng), 0.0f}};
  }
  const cl::Buffer ob = dev.upload("origins", origins), db = dev.upload("directions", dirs);
  const cl::Buffer pb = dev.upload("points", points), nb = dev.upload("normals", normals);
  const cl::Buffer patches = dev.upload("patches", std::vector<SpmPatch>(1)),
                   point_patch = dev.upload("point_patch", std::vector<cl_uint>(n, SPM_NONE));

  int reads = 0;
  for (size_t row = 0; row < roles.size(); ++row) {
    SCOPED_TRACE(roles[row].name);
    const SpmMapGrid& g = data.grids[row];
    ASSERT_EQ(g.kind, roles[row].kind);
    ASSERT_EQ(c.readers.count(roles[row].name), 1u);
    for (cl_uint reader = 0; reader < SPM_READERS; ++reader) {
      EXPECT_EQ(g.radius[reader], c.readers.at(roles[row].name)[reader]) << "reader " << reader;
    }
    bool read = false;
    for (float r : g.radius) read = read || r > 0.0f;
    const std::set<uint32_t> want = expected(roles[row].name, rec, c.radii, reach);
    if (!read) {
      // A role nothing reads builds no grid.
      EXPECT_EQ(g.info.records, 0u);
      continue;
    }
    EXPECT_EQ(g.info.records, want.size());
    if (g.kind != SPM_GRID_DISKS) {
      // The records or beams the grid lists, traced back by their stream.
      std::set<uint32_t> got;
      for (uint32_t i : spm::test::listed(data, row)) {
        got.insert(g.kind == SPM_GRID_SPHERES ? data.volume_records[i].stream : data.beams[i].stream);
      }
      EXPECT_EQ(got, want);
    }
    if (g.kind == SPM_GRID_CAPSULES) continue;  // their estimate: test_stream_beams.cpp
    std::vector<SpmVolumeRecord> listed_volume;
    for (const SpmVolumeRecord& v : rec.volume) {
      if (want.count(v.stream)) listed_volume.push_back(v);
    }
    for (cl_uint reader = 0; reader < SPM_READERS; ++reader) {
      const float r = g.radius[reader];
      if (!(r > 0.0f)) continue;
      ++reads;
      const spm::MapGridData one = only(data, row, reader);
      if (g.kind == SPM_GRID_SPHERES) {
        spm::test::VolumeTestSettings t;
        t.reader = reader;
        const auto got = spm::test::volume_test(one, media, ob, db, n, t);
        for (int i = 0; i < n; ++i) {
          const dvec3 ref = spm::test::beam_reference(listed_volume, clear, 0, v3(origins[i].s), v3(dirs[i].s), 0.0,
                                                      dirs[i].s[3], r, 0, 0, 0u, SPM_NONE);
          for (int k = 0; k < 3; ++k) ASSERT_NEAR(got[i].s[k], ref[k], 1e-4 * ref[k] + 1e-9) << "ray " << i;
        }
      } else {
        const spm::test::TableBuffers table(dev, one);
        const spm::DeviceBuffer out = dev.buffer(sizeof(cl_float4) * n, "estimates", CL_MEM_WRITE_ONLY);
        cl::Kernel k = dev.kernel("spm_estimate", "spm_surface_test");
        spm::set_args(k, table, spm::arg("points", pb), spm::arg("normals", nb), spm::arg("patches", patches),
                      spm::arg("point_patch", point_patch), spm::arg("out", out), spm::arg("count", cl_uint(n)),
                      spm::arg("reader", reader), spm::arg("density_kernel", cl_uint(SPM_KERNEL_UNIFORM)),
                      spm::arg("estimator", cl_uint(SPM_ESTIMATOR_BRE)), spm::arg("max_rec_depth", cl_uint(SPM_NONE)));
        dev.launch(k, n);
        const auto got = dev.download<cl_float4>(out, n);
        for (int i = 0; i < n; ++i) {
          const dvec3 ref = surface_reference(rec.surface, want, v3(points[i].s), r);
          for (int k = 0; k < 3; ++k) ASSERT_NEAR(got[i].s[k], ref[k], 1e-4 * ref[k] + 1e-9) << "point " << i;
        }
      }
    }
  }
  // Every case reads the surface map and some volume grid.
  EXPECT_GE(reads, 2);
}

INSTANTIATE_TEST_SUITE_P(Passes, GridTable, ::testing::Range(0, 4));

// The readers' sums add their grids in the table's order, and the disk
// grids come first, so that surface_flux runs parallel to grid_pos.
TEST(GridTable, DiskGridsComeFirst) {
  bool others = false;
  for (const spm::GridRole& role : spm::grid_roles()) {
    if (role.kind != SPM_GRID_DISKS) others = true;
    EXPECT_FALSE(others && role.kind == SPM_GRID_DISKS) << role.name;
  }
  spm::MapGridData d;
  const std::vector<SpmVolumeRecord> one(1);
  d.volume_records.append(one);
  d.add_spheres(spm::build_sphere_grid({glm::vec3(0.0f)}, 1.0f), one, {});
  EXPECT_THROW(d.add_disks(spm::build_point_grid({}, 1.0f), nullptr, {}, {}), std::logic_error);
}

}  // namespace
