// The maps as the gather kernel reads them: each map with its sphere grid
// (host/spm/sphere_grid.h), uploaded as built and bound after the gather's own
// arguments in the order of kernels/spm_gather.cl.
#pragma once

#include "device/device.h"
#include "spm/sphere_grid.h"
#include "spm/streams.h"

namespace spm {

class MapGrids {
 public:
  // Builds both grids for search radius `radius`; the build time goes to
  // `build_seconds`.
  MapGrids(Device& device, const PhotonMaps& maps, float radius);

  cl_uint bind(cl::Kernel& kernel, cl_uint index) const;
  double build_seconds() const { return build_seconds_; }
  const SphereGrid& volume_grid() const { return volume_grid_; }
  const SphereGrid& surface_grid() const { return surface_grid_; }

 private:
  SphereGrid volume_grid_, surface_grid_;
  cl::Buffer volume_info_, volume_start_, volume_items_, volume_;
  cl::Buffer surface_info_, surface_start_, surface_items_, surface_;
  double build_seconds_ = 0.0;
};

}  // namespace spm
