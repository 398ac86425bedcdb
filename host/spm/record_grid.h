// Uniform grids over map records, built on the host as a counting sort into
// two flat arrays that upload as they are (after SmallVCM's hashgrid).
// - Sphere grid, for the volume map (METHOD.md 5): each record is listed in
//   every cell its ball of radius r overlaps. A gather ray walks the cells it
//   crosses and counts each record in the one cell that holds the record's
//   closest point on the ray, so every record within r of the ray is found
//   exactly once.
// - Point grid, for the surface map: each record is listed once, in the cell
//   holding it. A surface query visits the cells its ball touches; on a
//   surface that examines about (2r + cell)^2 of area per query instead of
//   the sphere grid's (2r + 2r)^2, and lists a record once instead of up to
//   8 times.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "spm_types.h"

namespace spm {

struct RecordGrid {
  SpmGridInfo info{};                // info.records = number of centres
  std::vector<uint32_t> cell_start;  // size = cells + 1
  std::vector<uint32_t> items;       // record indices, each cell's list in increasing record index
  double build_seconds = 0.0;
};

// Every sphere of radius `radius` around centres[i] is listed in exactly the
// cells its ball overlaps (squared distance from the centre to the closed cell
// box <= radius^2), not in its whole bounding box. Cells are cubes of edge
// max(2 radius, extent / floor(cbrt(max_cells))), so a ball meets at most two
// cells per axis (three only when exactly tangent to two faces) and the grid
// never exceeds max_cells cells; the grid covers the bounding box of all balls. An empty input gives a 1x1x1 grid with no items.
// Throws InputError for a radius that is not positive and finite or a zero
// max_cells, RuntimeError for a non-finite centre or more items than 32-bit
// indices hold.
RecordGrid build_sphere_grid(const std::vector<glm::vec3>& centres, float radius,
                             size_t max_cells = size_t(1) << 22);

// Every centre is listed in exactly the cell grid_cell_of gives for it. Cells
// are cubes of edge max(cell, extent / floor(cbrt(max_cells))) covering the
// bounding box of the centres. Throws as build_sphere_grid does (InputError
// for a cell edge that is not positive and finite).
RecordGrid build_point_grid(const std::vector<glm::vec3>& centres, float cell, size_t max_cells = size_t(1) << 22);

// Capsule grid, for the stream beams (METHOD.md 11): segment i, from
// starts[i] to ends[i], is listed in every cell its capsule of radius
// `radius` overlaps (and in some cells just beyond: a cell is taken when its
// centre is within radius plus half its diagonal of the segment). A gather
// ray counts a beam in the one cell holding the ray's point closest to the
// beam, which lies inside the capsule, so each beam within the radius is
// found exactly once. Cubic cells of edge max(cell, extent /
// floor(cbrt(max_cells))) cover the bounding box of the segments grown by
// the radius. Throws as build_sphere_grid does.
RecordGrid build_capsule_grid(const std::vector<glm::vec3>& starts, const std::vector<glm::vec3>& ends, float radius,
                              float cell, size_t max_cells = size_t(1) << 22);

// Cell coordinates of point p, clamped to the grid; p must be finite. Float
// arithmetic, as in the kernels, so host and device agree on a point's cell.
inline glm::ivec3 grid_cell_of(const SpmGridInfo& g, const glm::vec3& p) {
  glm::ivec3 c;
  for (int k = 0; k < 3; ++k) {
    const float u = std::floor((p[k] - g.lo[k]) / g.cell);
    c[k] = static_cast<int>(std::clamp(u, 0.0f, static_cast<float>(g.dims[k] - 1)));
  }
  return c;
}

// Index of cell c in cell_start: x + dims[0] * (y + dims[1] * z).
inline size_t grid_cell_index(const SpmGridInfo& g, const glm::ivec3& c) {
  return static_cast<size_t>(c.x) + g.dims[0] * (static_cast<size_t>(c.y) + g.dims[1] * static_cast<size_t>(c.z));
}

}  // namespace spm
