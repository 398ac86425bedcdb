// read_vdb, apart from volume_grid.cpp so that only this file compiles
// OpenVDB's headers.
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <cmath>
#include <filesystem>
#include <sstream>

#include "scene/volume_grid.h"
#include "util/errors.h"

namespace spm {

namespace {

namespace fs = std::filesystem;

std::string coord_text(const openvdb::Coord& c) {
  return "(" + std::to_string(c.x()) + ", " + std::to_string(c.y()) + ", " + std::to_string(c.z()) + ")";
}

std::string number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// The dense box of a grid lives in an axis-aligned VolumeGrid, so the
// transform may only scale each axis (by a positive factor) and translate.
void check_transform(const std::string& path, const std::string& where, const openvdb::math::Transform& t) {
  if (!t.isLinear())
    throw InputError(path, where + " has a non-linear transform (" + t.mapType() + "), only linear ones are read");
  const openvdb::Vec3d origin = t.indexToWorld(openvdb::Vec3d(0.0));
  for (int a = 0; a < 3; ++a) {
    openvdb::Vec3d unit(0.0);
    unit[a] = 1.0;
    const openvdb::Vec3d axis = t.indexToWorld(unit) - origin;
    const double off = std::fabs(axis[(a + 1) % 3]) + std::fabs(axis[(a + 2) % 3]);
    if (!(axis[a] > 0.0) || off > 1e-6 * axis[a])
      throw InputError(path, where + " has a transform that rotates, shears or mirrors (index axis " +
                                 std::to_string(a) + " maps to (" + number(axis[0]) + ", " + number(axis[1]) + ", " +
                                 number(axis[2]) + ")), only scale and translation are read");
  }
}

VolumeGrid dense_grid(const std::string& path, const std::string& where, const openvdb::FloatGrid& grid) {
  if (grid.getGridClass() == openvdb::GRID_LEVEL_SET)
    throw InputError(path, where + " is a level set (signed distances), not a density: convert it to a fog volume");
  if (grid.activeVoxelCount() == 0) throw InputError(path, where + " has no active voxels");
  check_transform(path, where, grid.transform());
  const openvdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
  const openvdb::Coord dim = box.dim();
  uint64_t values = 1;
  for (int a = 0; a < 3; ++a) {
    const uint64_t d = static_cast<uint64_t>(dim[a]);
    if (values > kMaxVolumeValues / d)
      throw InputError(path, where + "'s active voxels span " + std::to_string(dim.x()) + " x " +
                                 std::to_string(dim.y()) + " x " + std::to_string(dim.z()) +
                                 " voxels, more than the limit of " + std::to_string(kMaxVolumeValues));
    values *= d;
  }
  VolumeGrid g;
  g.nx = static_cast<uint32_t>(dim.x());
  g.ny = static_cast<uint32_t>(dim.y());
  g.nz = static_cast<uint32_t>(dim.z());
  g.data.resize(static_cast<size_t>(values));
  const float background = grid.background();
  const bool background_valid = std::isfinite(background) && background >= 0.0f;
  const auto problem = [](float v) {
    return std::isnan(v) ? std::string("NaN") : std::isinf(v) ? std::string("infinite") : "negative (" + number(v) + ")";
  };
  openvdb::FloatGrid::ConstAccessor acc = grid.getConstAccessor();
  size_t i = 0;
  for (uint32_t z = 0; z < g.nz; ++z) {
    for (uint32_t y = 0; y < g.ny; ++y) {
      for (uint32_t x = 0; x < g.nx; ++x) {
        const openvdb::Coord c = box.min() + openvdb::Coord(int32_t(x), int32_t(y), int32_t(z));
        float v;
        const bool active = acc.probeValue(c, v);
        if (!active) {
          if (!background_valid)
            throw InputError(path, where + "'s background, which its inactive voxel " + coord_text(c) + " takes, is " +
                                       problem(background));
          v = background;
        } else if (!(std::isfinite(v) && v >= 0.0f)) {
          throw InputError(path, where + "'s value at voxel " + coord_text(c) + " is " + problem(v));
        }
        g.data[i++] = v;
      }
    }
  }
  // Voxel i covers index space [i - 0.5, i + 0.5] (OpenVDB's cell-centred
  // convention), as texel i covers [i, i + 1] / n of the unit cube.
  const openvdb::Vec3d lo = grid.indexToWorld(box.min().asVec3d() - openvdb::Vec3d(0.5));
  const openvdb::Vec3d hi = grid.indexToWorld(box.max().asVec3d() + openvdb::Vec3d(0.5));
  g.bbox_min = glm::vec3(lo.x(), lo.y(), lo.z());
  g.bbox_max = glm::vec3(hi.x(), hi.y(), hi.z());
  return g;
}

}  // namespace

VolumeGrid read_vdb(const std::string& path, const std::string& grid_name) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, "file does not exist");
  if (!fs::is_regular_file(path, ec)) throw InputError(path, "not a regular file");
  const std::string where = "grid '" + grid_name + "'";
  openvdb::initialize();
  openvdb::GridBase::Ptr base;
  try {
    openvdb::io::File file(path);
    // Read at once (no delayed loading): the file is closed before the values are.
    file.open(false);
    if (!file.hasGrid(grid_name)) {
      std::string names;
      for (auto it = file.beginName(); it != file.endName(); ++it) names += (names.empty() ? "'" : ", '") + *it + "'";
      throw InputError(path, "no grid named '" + grid_name + "' (" +
                                 (names.empty() ? "the file holds no grids" : "grids: " + names) + ")");
    }
    base = file.readGrid(grid_name);
    file.close();
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    // OpenVDB's own exceptions, and the allocations a corrupt file asks for.
    throw InputError(path, std::string("cannot read as an OpenVDB file: ") + e.what());
  }
  const openvdb::FloatGrid::Ptr grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
  if (!grid) throw InputError(path, where + " holds " + base->valueType() + " values, not float");
  return dense_grid(path, where, *grid);
}

}  // namespace spm
