#include "spm/gather.h"

namespace spm {

namespace {

template <class Record>
std::vector<glm::vec3> positions(const std::vector<Record>& records) {
  std::vector<glm::vec3> out;
  out.reserve(records.size());
  for (const auto& r : records) out.emplace_back(r.position[0], r.position[1], r.position[2]);
  return out;
}

}  // namespace

MapGrids::MapGrids(Device& device, const PhotonMaps& maps, float radius)
    : volume_grid_(build_sphere_grid(positions(maps.volume), radius)),
      surface_grid_(build_sphere_grid(positions(maps.surface), radius)),
      volume_info_(device.upload(std::vector<SpmGridInfo>{volume_grid_.info})),
      volume_start_(device.upload(volume_grid_.cell_start)),
      volume_items_(device.upload(volume_grid_.items)),
      volume_(device.upload(maps.volume)),
      surface_info_(device.upload(std::vector<SpmGridInfo>{surface_grid_.info})),
      surface_start_(device.upload(surface_grid_.cell_start)),
      surface_items_(device.upload(surface_grid_.items)),
      surface_(device.upload(maps.surface)),
      build_seconds_(volume_grid_.build_seconds + surface_grid_.build_seconds) {}

cl_uint MapGrids::bind(cl::Kernel& k, cl_uint i) const {
  for (const cl::Buffer* b : {&volume_info_, &volume_start_, &volume_items_, &volume_, &surface_info_,
                              &surface_start_, &surface_items_, &surface_}) {
    k.setArg(i++, *b);
  }
  return i;
}

}  // namespace spm
