// The maps as the gather kernel reads them: each map with its sphere grid
// (host/spm/sphere_grid.h), uploaded as built and bound after the gather's own
// arguments in the order of kernels/spm_gather.cl.
#pragma once

#include "device/device.h"
#include "spm/sphere_grid.h"
#include "spm/streams.h"

#include <vector>

namespace spm {

// The records' positions in the grid's item order (kernels/lib/grid.h).
std::vector<cl_float4> item_positions(const SphereGrid& grid, const std::vector<glm::vec3>& centres);

class MapGrids {
 public:
  // Builds both grids for search radius `radius`; `skip_direct` leaves out the
  // surface records the gather would skip (next-event estimation's light).
  MapGrids(Device& device, const PhotonMaps& maps, float radius, bool skip_direct);

  cl_uint bind(cl::Kernel& kernel, cl_uint index) const;
  double build_seconds() const { return build_seconds_; }
  const SphereGrid& volume_grid() const { return volume_grid_; }
  const SphereGrid& surface_grid() const { return surface_grid_; }

 private:
  MapGrids(Device& device, const std::vector<SpmVolumeRecord>& volume, const std::vector<SpmSurfaceRecord>& surface,
           float radius);

  SphereGrid volume_grid_, surface_grid_;
  cl::Buffer volume_info_, volume_start_, volume_items_, volume_pos_, volume_;
  cl::Buffer surface_info_, surface_start_, surface_items_, surface_pos_, surface_;
  double build_seconds_ = 0.0;
};

}  // namespace spm
