// The sphere grid lists each record in exactly the cells its ball overlaps
// (checked against every cell of the grid), and a walk along a segment that
// counts each record in the cell of its closest point finds every record within
// r of the segment exactly once (METHOD.md 5). The point grid lists each record
// once, in its cell, and the cells a ball's box touches hold every record in
// the ball.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "spm/record_grid.h"
#include "util/errors.h"

namespace {

using glm::dvec3;
using glm::ivec3;
using glm::vec3;
using spm::RecordGrid;

// Closed box of cell (x, y, z), in double.
void cell_box(const SpmGridInfo& g, const ivec3& c, dvec3& b0, dvec3& b1) {
  for (int k = 0; k < 3; ++k) {
    b0[k] = double(g.lo[k]) + double(c[k]) * g.cell;
    b1[k] = double(g.lo[k]) + double(c[k] + 1) * g.cell;
  }
}

// Plain reference: the closest point of the box to the centre is within r.
bool ball_meets_cell(const SpmGridInfo& g, const ivec3& c, const vec3& centre, float r) {
  dvec3 b0, b1;
  cell_box(g, c, b0, b1);
  const dvec3 p(centre);
  const dvec3 q = glm::clamp(p, b0, b1);
  return glm::dot(p - q, p - q) <= double(r) * r;
}

size_t cell_count(const SpmGridInfo& g) { return size_t(g.dims[0]) * g.dims[1] * g.dims[2]; }

ivec3 cell_coords(const SpmGridInfo& g, size_t index) {
  return ivec3(int(index % g.dims[0]), int(index / g.dims[0] % g.dims[1]), int(index / g.dims[0] / g.dims[1]));
}

std::vector<vec3> random_centres(std::mt19937& rng, size_t n, const vec3& lo, const vec3& hi) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<vec3> centres(n);
  for (vec3& c : centres) c = lo + (hi - lo) * vec3(u(rng), u(rng), u(rng));
  return centres;
}

// CSR shape: sizes, monotone starts, strictly increasing items per cell, the
// grid covering every ball, edge >= 2r.
void check_structure(const RecordGrid& grid, const std::vector<vec3>& centres, float r) {
  const SpmGridInfo& g = grid.info;
  ASSERT_EQ(g.records, centres.size());
  ASSERT_EQ(grid.cell_start.size(), cell_count(g) + 1);
  ASSERT_EQ(grid.cell_start.front(), 0u);
  ASSERT_EQ(grid.cell_start.back(), grid.items.size());
  EXPECT_GE(double(g.cell), 2.0 * r);
  EXPECT_GE(grid.build_seconds, 0.0);
  for (size_t c = 0; c + 1 < grid.cell_start.size(); ++c) {
    ASSERT_LE(grid.cell_start[c], grid.cell_start[c + 1]) << "cell " << c;
    for (uint32_t j = grid.cell_start[c]; j < grid.cell_start[c + 1]; ++j) {
      ASSERT_LT(grid.items[j], centres.size());
      if (j > grid.cell_start[c]) {
        ASSERT_LT(grid.items[j - 1], grid.items[j]) << "cell " << c;
      }
    }
  }
  for (const vec3& c : centres) {
    for (int k = 0; k < 3; ++k) {
      const double extent = double(g.dims[k]) * g.cell;
      EXPECT_LE(double(g.lo[k]), double(c[k]) - r);
      EXPECT_GE(double(g.lo[k]) + extent, double(c[k]) + r - 1e-9 * extent);
    }
  }
}

// listed <=> overlap, for every (record, cell) pair of the grid.
void check_exact(const RecordGrid& grid, const std::vector<vec3>& centres, float r) {
  const SpmGridInfo& g = grid.info;
  std::vector<uint32_t> times_listed(centres.size(), 0);
  std::vector<char> listed(centres.size());
  size_t mismatches = 0;
  for (size_t c = 0; c < cell_count(g); ++c) {
    std::fill(listed.begin(), listed.end(), 0);
    for (uint32_t j = grid.cell_start[c]; j < grid.cell_start[c + 1]; ++j) {
      listed[grid.items[j]] = 1;
      ++times_listed[grid.items[j]];
    }
    const ivec3 cc = cell_coords(g, c);
    for (size_t i = 0; i < centres.size(); ++i) {
      if (bool(listed[i]) != ball_meets_cell(g, cc, centres[i], r) && ++mismatches <= 10) {
        ADD_FAILURE() << "record " << i << " cell (" << cc.x << ", " << cc.y << ", " << cc.z << "): listed "
                      << bool(listed[i]);
      }
    }
  }
  EXPECT_EQ(mismatches, 0u);
  for (size_t i = 0; i < centres.size(); ++i) {
    EXPECT_GE(times_listed[i], 1u) << "record " << i;
    EXPECT_LE(times_listed[i], 8u) << "record " << i;
  }
}

TEST(RecordGrid, ListsExactlyTheOverlappedCells) {
  std::mt19937 rng(20240611);
  // A flat box, so the three axes get different cell counts, plus a dense clump.
  std::vector<vec3> centres = random_centres(rng, 2500, vec3(-8, -4, -2), vec3(8, 4, 2));
  const std::vector<vec3> clump = random_centres(rng, 500, vec3(1, 1, 0), vec3(1.5f, 1.5f, 0.5f));
  centres.insert(centres.end(), clump.begin(), clump.end());
  for (float r : {0.25f, 0.7f, 1.6f}) {
    SCOPED_TRACE("radius " + std::to_string(r));
    const RecordGrid grid = spm::build_sphere_grid(centres, r);
    check_structure(grid, centres, r);
    check_exact(grid, centres, r);
    // Deterministic: a second build gives the same arrays.
    const RecordGrid again = spm::build_sphere_grid(centres, r);
    EXPECT_EQ(again.cell_start, grid.cell_start);
    EXPECT_EQ(again.items, grid.items);
  }
}

TEST(RecordGrid, RespectsTheCellCap) {
  std::mt19937 rng(7);
  const std::vector<vec3> centres = random_centres(rng, 2000, vec3(-100), vec3(100));
  const float r = 0.01f;
  for (size_t max_cells : {size_t(1), size_t(7), size_t(500), size_t(1000)}) {
    SCOPED_TRACE("max_cells " + std::to_string(max_cells));
    const RecordGrid grid = spm::build_sphere_grid(centres, r, max_cells);
    EXPECT_LE(cell_count(grid.info), max_cells);
    check_structure(grid, centres, r);
    check_exact(grid, centres, r);
  }
  // The default cap, too large for the all-cells check: tiny balls sit in the
  // cell of their centre only.
  const RecordGrid grid = spm::build_sphere_grid(centres, 1e-4f);
  EXPECT_LE(cell_count(grid.info), size_t(1) << 22);
  EXPECT_GT(cell_count(grid.info), size_t(1) << 21);
  check_structure(grid, centres, 1e-4f);
  EXPECT_EQ(grid.items.size(), centres.size());
  for (size_t i = 0; i < centres.size(); ++i) {
    const size_t c = spm::grid_cell_index(grid.info, spm::grid_cell_of(grid.info, centres[i]));
    ASSERT_EQ(grid.cell_start[c + 1] - grid.cell_start[c], 1u) << "record " << i;
    EXPECT_EQ(grid.items[grid.cell_start[c]], i);
  }
}

// Does the segment [a, b] meet the closed box [b0, b1]? Slab test in double.
bool segment_meets_box(const dvec3& a, const dvec3& b, const dvec3& b0, const dvec3& b1) {
  double t0 = 0.0, t1 = 1.0;
  for (int k = 0; k < 3; ++k) {
    const double d = b[k] - a[k];
    if (d == 0.0) {
      if (a[k] < b0[k] || a[k] > b1[k]) return false;
      continue;
    }
    double s0 = (b0[k] - a[k]) / d, s1 = (b1[k] - a[k]) / d;
    if (s0 > s1) std::swap(s0, s1);
    t0 = std::max(t0, s0);
    t1 = std::min(t1, s1);
  }
  return t0 <= t1;
}

// Closest point of the segment [a, b] to p.
dvec3 closest_on_segment(const dvec3& a, const dvec3& b, const dvec3& p) {
  const dvec3 d = b - a;
  const double len2 = glm::dot(d, d);
  const double t = len2 > 0.0 ? glm::clamp(glm::dot(p - a, d) / len2, 0.0, 1.0) : 0.0;
  return a + t * d;
}

TEST(RecordGrid, SegmentWalkFindsEachNearbyRecordOnce) {
  std::mt19937 rng(99);
  const std::vector<vec3> centres = random_centres(rng, 3000, vec3(-8, -4, -2), vec3(8, 4, 2));
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const vec3 lo(-10, -6, -4), hi(10, 6, 4);  // endpoints may lie outside the grid
  size_t found_total = 0;
  for (float r : {0.25f, 0.7f}) {
    SCOPED_TRACE("radius " + std::to_string(r));
    const RecordGrid grid = spm::build_sphere_grid(centres, r);
    const SpmGridInfo& g = grid.info;
    for (int s = 0; s < 300; ++s) {
      const dvec3 a(lo + (hi - lo) * vec3(u(rng), u(rng), u(rng)));
      dvec3 b(lo + (hi - lo) * vec3(u(rng), u(rng), u(rng)));
      // A third of the segments are short (shorter than a cell), one is a point.
      if (s % 3 == 1) b = a + (b - a) * double(u(rng)) * 0.1;
      if (s == 2) b = a;

      std::vector<uint32_t> count(centres.size(), 0);
      // Reference walk: every cell whose box the segment meets.
      for (size_t c = 0; c < cell_count(g); ++c) {
        dvec3 b0, b1;
        cell_box(g, cell_coords(g, c), b0, b1);
        if (!segment_meets_box(a, b, b0, b1)) continue;
        for (uint32_t j = grid.cell_start[c]; j < grid.cell_start[c + 1]; ++j) {
          const uint32_t i = grid.items[j];
          const dvec3 p(centres[i]);
          const dvec3 q = closest_on_segment(a, b, p);
          if (glm::dot(p - q, p - q) > double(r) * r) continue;
          // Counted only in the cell of its closest point.
          if (spm::grid_cell_index(g, spm::grid_cell_of(g, vec3(q))) == c) ++count[i];
        }
      }
      for (size_t i = 0; i < centres.size(); ++i) {
        const dvec3 p(centres[i]);
        const dvec3 q = closest_on_segment(a, b, p);
        const bool near = glm::dot(p - q, p - q) <= double(r) * r;
        ASSERT_EQ(count[i], near ? 1u : 0u) << "segment " << s << " record " << i;
        found_total += near;
      }
    }
  }
  EXPECT_GT(found_total, 5000u);  // the segments do pass near many records
}

TEST(RecordGrid, EmptyInputGivesOneEmptyCell) {
  const RecordGrid grid = spm::build_sphere_grid({}, 0.5f);
  EXPECT_EQ(grid.info.records, 0u);
  EXPECT_EQ(grid.info.dims[0], 1u);
  EXPECT_EQ(grid.info.dims[1], 1u);
  EXPECT_EQ(grid.info.dims[2], 1u);
  EXPECT_GE(grid.info.cell, 1.0f);
  EXPECT_EQ(grid.cell_start, (std::vector<uint32_t>{0, 0}));
  EXPECT_TRUE(grid.items.empty());
}

TEST(RecordGrid, SingleCentre) {
  // Exactly representable bounds: one cell of edge 2r around the ball.
  const std::vector<vec3> one{vec3(1, 2, 3)};
  const RecordGrid grid = spm::build_sphere_grid(one, 0.5f);
  EXPECT_EQ(grid.info.dims[0] * grid.info.dims[1] * grid.info.dims[2], 1u);
  EXPECT_EQ(grid.info.lo[0], 0.5f);
  EXPECT_EQ(grid.info.lo[1], 1.5f);
  EXPECT_EQ(grid.info.lo[2], 2.5f);
  EXPECT_EQ(grid.info.cell, 1.0f);
  EXPECT_EQ(grid.cell_start, (std::vector<uint32_t>{0, 1}));
  EXPECT_EQ(grid.items, (std::vector<uint32_t>{0}));

  // Arbitrary values: rounding may add a cell, the listing stays exact.
  const std::vector<vec3> other{vec3(0.1f, -7.3f, 1e3f)};
  const RecordGrid g2 = spm::build_sphere_grid(other, 0.3f);
  EXPECT_LE(cell_count(g2.info), 8u);
  check_structure(g2, other, 0.3f);
  check_exact(g2, other, 0.3f);
}

TEST(RecordGrid, GridCellOfClampsToTheGrid) {
  SpmGridInfo g{};
  g.lo[0] = -1.0f, g.lo[1] = 0.0f, g.lo[2] = 2.0f;
  g.cell = 0.5f;
  g.dims[0] = 4, g.dims[1] = 3, g.dims[2] = 2;
  EXPECT_EQ(spm::grid_cell_of(g, vec3(-0.9f, 0.1f, 2.1f)), ivec3(0, 0, 0));
  EXPECT_EQ(spm::grid_cell_of(g, vec3(0.75f, 1.25f, 2.6f)), ivec3(3, 2, 1));
  EXPECT_EQ(spm::grid_cell_of(g, vec3(-50.0f, 50.0f, 2.3f)), ivec3(0, 2, 0));
  EXPECT_EQ(spm::grid_cell_of(g, vec3(1.0f, 1.5f, 3.0f)), ivec3(3, 2, 1));  // the far corner
  EXPECT_EQ(spm::grid_cell_index(g, ivec3(3, 2, 1)), size_t(3 + 4 * (2 + 3 * 1)));
}

TEST(PointGrid, ListsEachRecordOnceInItsCell) {
  std::mt19937 rng(23);
  // Random points, and points on the planes x = 0 and y = 3 (cell faces when
  // the cell edge divides the offsets).
  std::vector<vec3> centres = random_centres(rng, 3000, vec3(-4.0f), vec3(6.0f));
  std::uniform_real_distribution<float> u(-4.0f, 6.0f);
  for (int i = 0; i < 500; ++i) centres.emplace_back(0.0f, u(rng), u(rng));
  for (int i = 0; i < 500; ++i) centres.emplace_back(u(rng), 3.0f, u(rng));
  for (const float cell : {0.25f, 1.0f, 3.0f}) {
    const RecordGrid grid = spm::build_point_grid(centres, cell);
    const SpmGridInfo& g = grid.info;
    EXPECT_GE(g.cell, cell);
    EXPECT_EQ(g.records, centres.size());
    ASSERT_EQ(grid.cell_start.size(), cell_count(g) + 1);
    ASSERT_EQ(grid.items.size(), centres.size());
    std::vector<int> seen(centres.size(), 0);
    for (size_t c = 0; c < cell_count(g); ++c) {
      for (uint32_t j = grid.cell_start[c]; j < grid.cell_start[c + 1]; ++j) {
        const uint32_t i = grid.items[j];
        ASSERT_LT(i, centres.size());
        ++seen[i];
        EXPECT_EQ(spm::grid_cell_index(g, spm::grid_cell_of(g, centres[i])), c) << "record " << i;
        if (j > grid.cell_start[c]) EXPECT_LT(grid.items[j - 1], i) << "cell " << c;
        // Inside the grid, not only clamped into it.
        for (int k = 0; k < 3; ++k) {
          EXPECT_GE(double(centres[i][k]), double(g.lo[k]));
          EXPECT_LE(double(centres[i][k]), double(g.lo[k]) + double(g.dims[k]) * g.cell);
        }
      }
    }
    for (size_t i = 0; i < centres.size(); ++i) EXPECT_EQ(seen[i], 1) << "record " << i;
  }
}

TEST(PointGrid, TheBoxOfABallHoldsEveryRecordInTheBall) {
  // The surface query (kernels/lib/estimate.h) visits the cells from
  // grid_cell_of(x - 1.00001 r) to grid_cell_of(x + 1.00001 r); every record
  // within r of x must be in one of them, for queries inside and outside the
  // grid and records exactly r away along an axis.
  std::mt19937 rng(29);
  const std::vector<vec3> centres = random_centres(rng, 4000, vec3(-5.0f), vec3(5.0f));
  std::uniform_real_distribution<float> u(-7.0f, 7.0f);
  for (const float r : {0.3f, 1.0f}) {
    for (const float cell : {0.3f * r, r, 3.0f * r}) {
      const RecordGrid grid = spm::build_point_grid(centres, cell);
      const SpmGridInfo& g = grid.info;
      size_t found = 0;
      for (int q = 0; q < 300; ++q) {
        const vec3 x = q % 3 == 0 ? centres[q] + vec3(r, 0.0f, 0.0f) * 0.999999f : vec3(u(rng), u(rng), u(rng));
        const float reach = r * 1.00001f;
        const ivec3 c0 = spm::grid_cell_of(g, x - vec3(reach)), c1 = spm::grid_cell_of(g, x + vec3(reach));
        for (size_t i = 0; i < centres.size(); ++i) {
          const vec3 d = centres[i] - x;
          if (glm::dot(d, d) >= r * r) continue;
          ++found;
          const ivec3 c = spm::grid_cell_of(g, centres[i]);
          EXPECT_TRUE(glm::all(glm::greaterThanEqual(c, c0)) && glm::all(glm::lessThanEqual(c, c1)))
              << "record " << i << " query " << q << " cell " << cell;
        }
      }
      EXPECT_GE(found, 100u);  // the check ran on records in range (a third of the queries have one)
    }
  }
}

TEST(PointGrid, EmptyInputAndCap) {
  const RecordGrid empty = spm::build_point_grid({}, 0.5f);
  EXPECT_EQ(cell_count(empty.info), 1u);
  EXPECT_EQ(empty.cell_start, (std::vector<uint32_t>{0, 0}));
  std::mt19937 rng(31);
  const std::vector<vec3> centres = random_centres(rng, 1000, vec3(0.0f), vec3(100.0f));
  const RecordGrid capped = spm::build_point_grid(centres, 0.01f, 1000);
  EXPECT_LE(cell_count(capped.info), 1000u);
  EXPECT_EQ(capped.items.size(), centres.size());
}

TEST(RecordGrid, RefusesBadInput) {
  const std::vector<vec3> centres{vec3(0.0f)};
  const float inf = std::numeric_limits<float>::infinity();
  for (float r : {0.0f, -1.0f, inf, std::numeric_limits<float>::quiet_NaN()}) {
    EXPECT_THROW(spm::build_sphere_grid(centres, r), spm::InputError) << "radius " << r;
    EXPECT_THROW(spm::build_sphere_grid({}, r), spm::InputError) << "radius " << r;
  }
  EXPECT_THROW(spm::build_sphere_grid(centres, 1.0f, 0), spm::InputError);
  for (float cell : {0.0f, -1.0f, inf, std::numeric_limits<float>::quiet_NaN()}) {
    EXPECT_THROW(spm::build_point_grid(centres, cell), spm::InputError) << "cell " << cell;
  }
  EXPECT_THROW(spm::build_point_grid(centres, 1.0f, 0), spm::InputError);
  using Build = RecordGrid (*)(const std::vector<vec3>&);
  const Build builds[] = {[](const std::vector<vec3>& c) { return spm::build_sphere_grid(c, 1.0f); },
                          [](const std::vector<vec3>& c) { return spm::build_point_grid(c, 1.0f); }};
  for (const Build build : builds) {
    for (const vec3& bad : {vec3(std::nanf(""), 0, 0), vec3(0, inf, 0), vec3(0, 0, -inf)}) {
      try {
        build({vec3(1.0f), bad});
        ADD_FAILURE() << "a non-finite centre was accepted";
      } catch (const spm::RuntimeError& e) {
        EXPECT_NE(std::string(e.what()).find("non-finite record position"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("record 1"), std::string::npos) << e.what();
      }
    }
  }
}

}  // namespace
