#include "spm/gather.h"

#include <chrono>

namespace spm {

namespace {

template <class Record>
std::vector<glm::vec3> positions(const std::vector<Record>& records) {
  std::vector<glm::vec3> out;
  out.reserve(records.size());
  for (const auto& r : records) out.emplace_back(r.position[0], r.position[1], r.position[2]);
  return out;
}

// With next-event estimation the gather skips records of streams that had no
// event before (METHOD.md 5): leaving them out of the grid saves the tests.
std::vector<SpmSurfaceRecord> used_surface(const std::vector<SpmSurfaceRecord>& records, bool skip_direct) {
  if (!skip_direct) return records;
  std::vector<SpmSurfaceRecord> out;
  for (const auto& r : records) {
    if (r.flags & SPM_RECORD_HAD_EVENT) out.push_back(r);
  }
  return out;
}

}  // namespace

MapGrids::MapGrids(Device& device, const PhotonMaps& maps, float radius, bool skip_direct)
    : MapGrids(device, maps.volume, used_surface(maps.surface, skip_direct), radius) {}

std::vector<cl_float4> item_positions(const SphereGrid& grid, const std::vector<glm::vec3>& centres) {
  std::vector<cl_float4> out(grid.items.size());
  for (size_t k = 0; k < grid.items.size(); ++k) {
    const glm::vec3& c = centres[grid.items[k]];
    out[k] = {{c.x, c.y, c.z, 0.0f}};
  }
  return out;
}

MapGrids::MapGrids(Device& device, const std::vector<SpmVolumeRecord>& volume,
                   const std::vector<SpmSurfaceRecord>& surface, float radius) {
  const auto start = std::chrono::steady_clock::now();
  const std::vector<glm::vec3> volume_centres = positions(volume), surface_centres = positions(surface);
  volume_grid_ = build_sphere_grid(volume_centres, radius);
  surface_grid_ = build_sphere_grid(surface_centres, radius);
  const auto volume_pos = item_positions(volume_grid_, volume_centres);
  const auto surface_pos = item_positions(surface_grid_, surface_centres);
  build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  volume_info_ = device.upload(std::vector<SpmGridInfo>{volume_grid_.info});
  volume_start_ = device.upload(volume_grid_.cell_start);
  volume_items_ = device.upload(volume_grid_.items);
  volume_pos_ = device.upload(volume_pos);
  volume_ = device.upload(volume);
  surface_info_ = device.upload(std::vector<SpmGridInfo>{surface_grid_.info});
  surface_start_ = device.upload(surface_grid_.cell_start);
  surface_items_ = device.upload(surface_grid_.items);
  surface_pos_ = device.upload(surface_pos);
  surface_ = device.upload(surface);
}

cl_uint MapGrids::bind(cl::Kernel& k, cl_uint i) const {
  for (const cl::Buffer* b : {&volume_info_, &volume_start_, &volume_items_, &volume_pos_, &volume_, &surface_info_,
                              &surface_start_, &surface_items_, &surface_pos_, &surface_}) {
    k.setArg(i++, *b);
  }
  return i;
}

}  // namespace spm
