#include "spm/gather.h"

#include <cmath>
#include <cstring>

namespace spm {

namespace {

template <class Record>
std::vector<glm::vec3> positions(const std::vector<Record>& records) {
  std::vector<glm::vec3> out;
  out.reserve(records.size());
  for (const auto& r : records) out.emplace_back(r.position[0], r.position[1], r.position[2]);
  return out;
}

// Three 10-bit components 512 + round(511 n) (kernels/lib/estimate.h).
float pack_normal(const float* n) {
  uint32_t bits = 0;
  for (int k = 0; k < 3; ++k) {
    const float q = 512.0f + std::round(511.0f * std::fmax(-1.0f, std::fmin(1.0f, n[k])));
    bits |= static_cast<uint32_t>(q) << (10 * k);
  }
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

}  // namespace

std::vector<cl_float4> volume_item_positions(const SphereGrid& grid, const std::vector<SpmVolumeRecord>& records) {
  std::vector<cl_float4> out(grid.items.size());
  for (size_t k = 0; k < out.size(); ++k) {
    const auto& r = records[grid.items[k]];
    out[k] = {{r.position[0], r.position[1], r.position[2], 0.0f}};
  }
  return out;
}

std::vector<cl_float4> surface_item_positions(const SphereGrid& grid, const std::vector<SpmSurfaceRecord>& records) {
  std::vector<cl_float4> out(grid.items.size());
  for (size_t k = 0; k < out.size(); ++k) {
    const auto& r = records[grid.items[k]];
    out[k] = {{r.position[0], r.position[1], r.position[2], pack_normal(r.normal)}};
  }
  return out;
}

std::vector<cl_float4> surface_item_flux(const SphereGrid& grid, const std::vector<SpmSurfaceRecord>& records) {
  std::vector<cl_float4> out(grid.items.size());
  for (size_t k = 0; k < out.size(); ++k) {
    const auto& r = records[grid.items[k]];
    out[k] = {{r.flux[0], r.flux[1], r.flux[2], 0.0f}};
  }
  return out;
}

std::vector<SpmSurfaceRecord> used_surface_records(const std::vector<SpmSurfaceRecord>& records, bool skip_direct) {
  if (!skip_direct) return records;
  std::vector<SpmSurfaceRecord> out;
  for (const auto& r : records) {
    if (r.flags & SPM_RECORD_HAD_EVENT) out.push_back(r);
  }
  return out;
}

MapGrids::MapGrids(Device& device, const PhotonMaps& maps, float radius, bool skip_direct) {
  const std::vector<SpmSurfaceRecord> surface = used_surface_records(maps.surface, skip_direct);
  const SphereGrid volume_grid = build_sphere_grid(positions(maps.volume), radius);
  const SphereGrid surface_grid = build_sphere_grid(positions(surface), radius);
  const auto volume_pos = volume_item_positions(volume_grid, maps.volume);
  const auto surface_pos = surface_item_positions(surface_grid, surface);
  const auto surface_flux = surface_item_flux(surface_grid, surface);
  volume_info_ = device.upload(std::vector<SpmGridInfo>{volume_grid.info});
  volume_start_ = device.upload(volume_grid.cell_start);
  volume_pos_ = device.upload(volume_pos);
  volume_items_ = device.upload(volume_grid.items);
  volume_ = device.upload(maps.volume);
  surface_info_ = device.upload(std::vector<SpmGridInfo>{surface_grid.info});
  surface_start_ = device.upload(surface_grid.cell_start);
  surface_pos_ = device.upload(surface_pos);
  surface_flux_ = device.upload(surface_flux);
}

cl_uint MapGrids::bind(cl::Kernel& k, cl_uint i) const {
  for (const cl::Buffer* b : {&volume_info_, &volume_start_, &volume_pos_, &volume_items_, &volume_, &surface_info_,
                              &surface_start_, &surface_pos_, &surface_flux_}) {
    k.setArg(i++, *b);
  }
  return i;
}

}  // namespace spm
