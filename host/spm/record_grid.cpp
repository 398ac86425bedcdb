#include "spm/record_grid.h"

#include <chrono>
#include <limits>
#include <string>

#include "util/errors.h"

namespace spm {

namespace {

// Largest n with n^3 <= m, so cubes of edge extent / n keep every axis at <= n
// cells. m is capped at 2^62, far past any grid that fits in memory, so that
// (n + 1)^3 cannot overflow.
uint64_t cube_root_floor(uint64_t m) {
  m = std::min<uint64_t>(m, uint64_t(1) << 62);
  uint64_t n = static_cast<uint64_t>(std::cbrt(static_cast<double>(m)));
  while (n * n * n > m) --n;
  while ((n + 1) * (n + 1) * (n + 1) <= m) ++n;
  return n;
}

// The grid's corner and edge are stored as float; rounding them outwards keeps
// every ball inside the grid and every edge >= 2r.
float float_down(double d) {
  const float f = static_cast<float>(d);
  return static_cast<double>(f) > d ? std::nextafter(f, -std::numeric_limits<float>::infinity()) : f;
}

float float_up(double d) {
  const float f = static_cast<float>(d);
  return static_cast<double>(f) < d ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

// Calls f(cell index) for every cell whose closed box lies within distance r of
// p, in increasing index order. The box test is separable, so whole slabs of
// cells are skipped as soon as one axis alone is too far.
template <typename F>
void for_each_overlapped_cell(const SpmGridInfo& g, const glm::vec3& p, double r, F&& f) {
  const double r2 = r * r, cell = g.cell;
  int64_t first[3], last[3];
  for (int k = 0; k < 3; ++k) {
    // One cell of slack each side absorbs rounding in the division; the exact
    // test below decides.
    first[k] = std::max<int64_t>(0, static_cast<int64_t>(std::floor((p[k] - r - g.lo[k]) / cell)) - 1);
    last[k] = std::min<int64_t>(int64_t(g.dims[k]) - 1,
                                static_cast<int64_t>(std::floor((p[k] + r - g.lo[k]) / cell)) + 1);
  }
  // Squared distance along axis k from p to the closed interval of cell x.
  auto gap2 = [&](int k, int64_t x) {
    const double b0 = g.lo[k] + double(x) * cell, b1 = g.lo[k] + double(x + 1) * cell;
    const double d = std::max({b0 - p[k], p[k] - b1, 0.0});
    return d * d;
  };
  for (int64_t z = first[2]; z <= last[2]; ++z) {
    const double dz = gap2(2, z);
    if (dz > r2) continue;
    for (int64_t y = first[1]; y <= last[1]; ++y) {
      const double dyz = dz + gap2(1, y);
      if (dyz > r2) continue;
      const size_t row = g.dims[0] * (size_t(y) + g.dims[1] * size_t(z));
      for (int64_t x = first[0]; x <= last[0]; ++x) {
        if (dyz + gap2(0, x) <= r2) f(row + size_t(x));
      }
    }
  }
}

// Squared distance from point c to the segment [p, p + s e] (unit e).
double segment_distance2(const glm::dvec3& c, const glm::dvec3& p, const glm::dvec3& e, double s) {
  const double t = std::clamp(glm::dot(c - p, e), 0.0, s);
  const glm::dvec3 off = c - (p + t * e);
  return glm::dot(off, off);
}

// Calls f(cell index) once for every cell whose closed box lies within
// distance r of the segment from p to q, and for some cells a little
// further: a cell is taken when its centre is within r plus its half
// diagonal of the segment (the ball around the box holds the box). Cells
// are visited slab by slab along x, each slab over the y and z range of the
// part of the segment that can reach it.
template <typename F>
void for_each_capsule_cell(const SpmGridInfo& g, const glm::vec3& pf, const glm::vec3& qf, double r, F&& f) {
  const double cell = g.cell;
  // The slack absorbs the rounding of the float grid and the double test.
  const double reach = (r + 0.5 * std::sqrt(3.0) * cell) * (1.0 + 1e-6);
  const glm::dvec3 p(pf), q(qf), lo(g.lo[0], g.lo[1], g.lo[2]);
  const double length = glm::length(q - p);
  const glm::dvec3 e = length > 0.0 ? (q - p) / length : glm::dvec3(1.0, 0.0, 0.0);
  auto cell_range = [&](int k, double a, double b, int64_t& first, int64_t& last) {
    first = std::max<int64_t>(0, static_cast<int64_t>(std::floor((std::min(a, b) - reach - lo[k]) / cell)) - 1);
    last = std::min<int64_t>(int64_t(g.dims[k]) - 1,
                             static_cast<int64_t>(std::floor((std::max(a, b) + reach - lo[k]) / cell)) + 1);
  };
  int64_t x0, x1;
  cell_range(0, p.x, q.x, x0, x1);
  for (int64_t x = x0; x <= x1; ++x) {
    // The segment's parameters whose x lies within reach of this slab.
    double s0 = 0.0, s1 = length;
    const double a = lo.x + double(x) * cell - reach, b = lo.x + double(x + 1) * cell + reach;
    if (e.x != 0.0) {
      const double ta = (a - p.x) / e.x, tb = (b - p.x) / e.x;
      s0 = std::max(s0, std::min(ta, tb));
      s1 = std::min(s1, std::max(ta, tb));
      if (s0 > s1) continue;
    } else if (p.x < a || p.x > b) {
      continue;
    }
    const glm::dvec3 u = p + s0 * e, v = p + s1 * e;
    int64_t y0, y1, z0, z1;
    cell_range(1, u.y, v.y, y0, y1);
    cell_range(2, u.z, v.z, z0, z1);
    for (int64_t z = z0; z <= z1; ++z) {
      for (int64_t y = y0; y <= y1; ++y) {
        const glm::dvec3 centre = lo + cell * (glm::dvec3(double(x), double(y), double(z)) + 0.5);
        if (segment_distance2(centre, p, e, length) <= reach * reach) {
          f(size_t(x) + g.dims[0] * (size_t(y) + g.dims[1] * size_t(z)));
        }
      }
    }
  }
}

// Throws for the bad inputs both grids share.
void check_centres(const std::vector<glm::vec3>& centres, size_t max_cells) {
  if (max_cells == 0) throw InputError("", "a record grid needs max_cells >= 1");
  if (centres.size() > std::numeric_limits<uint32_t>::max()) {
    throw RuntimeError("record grid: " + std::to_string(centres.size()) + " records exceed 32-bit record indices");
  }
  for (size_t i = 0; i < centres.size(); ++i) {
    const glm::vec3& c = centres[i];
    if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z)) {
      throw RuntimeError("record grid: non-finite record position (" + std::to_string(c.x) + ", " +
                         std::to_string(c.y) + ", " + std::to_string(c.z) + ") at record " + std::to_string(i));
    }
  }
}

// The grid's corner, cubic cells of edge >= min_cell and dims: it covers the
// bounding box of the centres grown by `margin` (an empty map: one cell at the
// origin), with at most max_cells cells.
SpmGridInfo layout(const std::vector<glm::vec3>& centres, double margin, double min_cell, size_t max_cells) {
  glm::dvec3 lo(0.0), hi(std::max(min_cell, 2.0 * margin));
  if (!centres.empty()) {
    lo = glm::dvec3(std::numeric_limits<double>::max());
    hi = -lo;
    for (const glm::vec3& c : centres) {
      lo = glm::min(lo, glm::dvec3(c));
      hi = glm::max(hi, glm::dvec3(c));
    }
    lo -= margin;
    hi += margin;
  }
  SpmGridInfo g{};
  g.records = static_cast<uint32_t>(centres.size());
  double extent = 0.0;
  for (int k = 0; k < 3; ++k) {
    g.lo[k] = float_down(lo[k]);
    extent = std::max(extent, hi[k] - g.lo[k]);
  }
  float cell = float_up(std::max(min_cell, extent / double(cube_root_floor(max_cells))));
  for (;;) {
    if (!std::isfinite(cell)) {
      throw RuntimeError("record grid: cell edge overflows float (extent " + std::to_string(extent) + ")");
    }
    uint64_t cells = 1;
    for (int k = 0; k < 3; ++k) {
      g.dims[k] = static_cast<uint32_t>(std::max(1.0, std::ceil((hi[k] - g.lo[k]) / cell)));
      cells *= g.dims[k];
    }
    if (cells <= max_cells) break;
    // Rounding the edge to float can leave an axis one cell over the cap.
    cell = std::nextafter(cell, std::numeric_limits<float>::infinity());
  }
  g.cell = cell;
  return g;
}

// Counting sort: count each cell's records into cell_start[c + 1], prefix-sum,
// then fill in record order so each cell's list is increasing.
// for_each_cell(centre, f) calls f(cell index) for each cell listing it.
template <class Item, typename ForEachCell>
void fill(RecordGrid& grid, const std::vector<Item>& centres, ForEachCell&& for_each_cell) {
  const size_t cells = size_t(grid.info.dims[0]) * grid.info.dims[1] * grid.info.dims[2];
  grid.cell_start.assign(cells + 1, 0);
  for (const Item& c : centres) {
    for_each_cell(c, [&](size_t cell_index) { ++grid.cell_start[cell_index + 1]; });
  }
  uint64_t total = 0;
  for (size_t c = 1; c <= cells; ++c) {
    total += grid.cell_start[c];
    if (total > std::numeric_limits<uint32_t>::max()) {
      throw RuntimeError("record grid: more than 2^32 (record, cell) pairs; use a smaller radius or fewer records");
    }
    grid.cell_start[c] = static_cast<uint32_t>(total);
  }
  grid.items.resize(total);
  std::vector<uint32_t> next(grid.cell_start.begin(), grid.cell_start.end() - 1);
  for (size_t i = 0; i < centres.size(); ++i) {
    for_each_cell(centres[i], [&](size_t cell_index) { grid.items[next[cell_index]++] = static_cast<uint32_t>(i); });
  }
}

}  // namespace

RecordGrid build_sphere_grid(const std::vector<glm::vec3>& centres, float radius, size_t max_cells) {
  const auto start = std::chrono::steady_clock::now();
  if (!(radius > 0.0f) || !std::isfinite(radius)) {
    throw InputError("", "the gather radius must be positive and finite, got " + std::to_string(radius));
  }
  check_centres(centres, max_cells);
  const double r = radius;
  RecordGrid grid;
  // Edge >= 2r keeps a record in at most 8 cells (barring exact tangency); the
  // margin r keeps every ball inside the grid.
  grid.info = layout(centres, r, 2.0 * r, max_cells);
  fill(grid, centres, [&](const glm::vec3& c, auto&& f) { for_each_overlapped_cell(grid.info, c, r, f); });
  grid.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return grid;
}

RecordGrid build_point_grid(const std::vector<glm::vec3>& centres, float cell, size_t max_cells) {
  const auto start = std::chrono::steady_clock::now();
  if (!(cell > 0.0f) || !std::isfinite(cell)) {
    throw InputError("", "the point grid's cell edge must be positive and finite, got " + std::to_string(cell));
  }
  check_centres(centres, max_cells);
  RecordGrid grid;
  grid.info = layout(centres, 0.0, cell, max_cells);
  fill(grid, centres, [&](const glm::vec3& c, auto&& f) { f(grid_cell_index(grid.info, grid_cell_of(grid.info, c))); });
  grid.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return grid;
}

RecordGrid build_capsule_grid(const std::vector<glm::vec3>& starts, const std::vector<glm::vec3>& ends, float radius,
                              float cell, size_t max_cells) {
  const auto start = std::chrono::steady_clock::now();
  if (!(radius > 0.0f) || !std::isfinite(radius)) {
    throw InputError("", "the beam radius must be positive and finite, got " + std::to_string(radius));
  }
  if (!(cell > 0.0f) || !std::isfinite(cell)) {
    throw InputError("", "the capsule grid's cell edge must be positive and finite, got " + std::to_string(cell));
  }
  if (starts.size() != ends.size()) throw RuntimeError("capsule grid: segment starts and ends differ in number");
  check_centres(starts, max_cells);
  check_centres(ends, max_cells);
  std::vector<glm::vec3> corners(starts);
  corners.insert(corners.end(), ends.begin(), ends.end());
  RecordGrid grid;
  // The margin r keeps every capsule inside the grid.
  grid.info = layout(corners, radius, cell, max_cells);
  grid.info.records = static_cast<uint32_t>(starts.size());
  std::vector<uint32_t> index(starts.size());
  for (size_t i = 0; i < index.size(); ++i) index[i] = static_cast<uint32_t>(i);
  fill(grid, index, [&](uint32_t i, auto&& f) { for_each_capsule_cell(grid.info, starts[i], ends[i], radius, f); });
  grid.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return grid;
}

}  // namespace spm
