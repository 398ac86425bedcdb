// Volume grids (volume type="gridvolume"): Mitsuba's binary .vol files and
// OpenVDB float grids, read into one dense layout, and the lookup the
// kernels do on them, as Mitsuba 3 does it.
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <string>
#include <vector>

namespace spm {

// A grid of float values, as Mitsuba 3's gridvolume holds it.
struct VolumeGrid {
  uint32_t nx = 0, ny = 0, nz = 0, channels = 1;
  glm::vec3 bbox_min{0.0f}, bbox_max{1.0f};  // as the .vol file stores it
  std::vector<float> data;                   // data[((z * ny + y) * nx + x) * channels + c]
  float max_value() const;                   // over every voxel and channel; 0 for an empty grid
};

// The most values (voxels x channels) a grid may hold: 8 GiB of float32.
constexpr uint64_t kMaxVolumeValues = uint64_t(1) << 31;

// Mitsuba's binary .vol (Mitsuba 0.6 and 3): "VOL", version 3, int32
// encoding 1 (float32), int32 xres, yres, zres, channels, float32 xmin, ymin,
// zmin, xmax, ymax, zmax, then the values in the order of VolumeGrid::data,
// all little endian. Throws InputError(path, ...) naming what is wrong: the
// file missing or unreadable, a truncated header, wrong magic or version, an
// encoding other than float32, zero or more than kMaxVolumeValues values, a
// file size other than the header's, a NaN, infinite or negative value, a
// channel count other than 1 or 3, a non-finite bounding box. A degenerate
// bounding box is read as it is: it matters only to use_grid_bbox.
VolumeGrid read_vol(const std::string& path);

// read_vol on the bytes of a file named `name` (the fuzz target's entry).
VolumeGrid parse_vol(const std::string& name, const std::string& bytes);

// Writes `g` as a .vol file through a temporary name (util/temp_file.h).
// Throws RuntimeError when it cannot write, or when `g` is inconsistent
// (no voxels, data not nx * ny * nz * channels values).
void write_vol(const std::string& path, const VolumeGrid& g);

// The float grid `grid_name` of an OpenVDB file, densely over its active
// voxels' bounding box; voxels there that are not active hold the grid's
// background. Channels 1; bbox_min/bbox_max the world-space box of those
// voxels (index box min - 0.5 .. max + 0.5 through the grid's transform,
// which must be a scale and translation). Throws InputError(path, ...) for a
// file that is not OpenVDB, no grid of that name (listing those there), a
// grid that is not a float grid, is a level set or has no active voxels, a
// transform that rotates, shears, mirrors or is not linear, too many voxels,
// or a NaN, infinite or negative value or background.
VolumeGrid read_vdb(const std::string& path, const std::string& grid_name);

// Host reference of the lookup the kernels will do: p in the grid's local
// unit cube [0,1]^3, as Mitsuba 3.9's gridvolume with wrap_mode "clamp" (its
// default) evaluates it, bit for bit (tools/check_gridvolume.py). Texel
// (i, j, k) is centred at ((i, j, k) + 0.5) / (nx, ny, nz). Trilinear blends
// the 8 texels around p; nearest takes the texel containing p. Texel indices
// clamp to the grid: within half a texel of a face, trilinear does not change
// along the face's normal, and outside the cube a lookup is (up to rounding)
// the one at the nearest point of the cube, not 0.
float grid_lookup(const VolumeGrid& g, glm::vec3 p, uint32_t channel, bool nearest);

}  // namespace spm
