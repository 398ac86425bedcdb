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

// value(record) for the record each grid item lists, in item order.
template <class Record, class Value>
std::vector<cl_float4> per_item(const RecordGrid& grid, const std::vector<Record>& records, Value value) {
  std::vector<cl_float4> out(grid.items.size());
  for (size_t k = 0; k < out.size(); ++k) out[k] = value(records[grid.items[k]]);
  return out;
}

}  // namespace

RecordGrid volume_grid(const std::vector<SpmVolumeRecord>& records, float radius) {
  return build_sphere_grid(positions(records), radius);
}

RecordGrid surface_grid(const std::vector<SpmSurfaceRecord>& records, float radius) {
  return build_point_grid(positions(records), kSurfaceCell * radius);
}

std::vector<cl_float4> volume_item_positions(const RecordGrid& grid, const std::vector<SpmVolumeRecord>& records) {
  return per_item(grid, records, [](const SpmVolumeRecord& r) {
    return cl_float4{{r.position[0], r.position[1], r.position[2], 0.0f}};
  });
}

std::vector<cl_float4> surface_item_positions(const RecordGrid& grid, const std::vector<SpmSurfaceRecord>& records) {
  return per_item(grid, records, [](const SpmSurfaceRecord& r) {
    return cl_float4{{r.position[0], r.position[1], r.position[2], pack_normal(r.normal)}};
  });
}

std::vector<cl_float4> surface_item_flux(const RecordGrid& grid, const std::vector<SpmSurfaceRecord>& records) {
  return per_item(grid, records,
                  [](const SpmSurfaceRecord& r) { return cl_float4{{r.flux[0], r.flux[1], r.flux[2], 0.0f}}; });
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
  const RecordGrid volume = volume_grid(maps.volume, radius);
  const RecordGrid surface_points = surface_grid(surface, radius);
  const auto volume_pos = volume_item_positions(volume, maps.volume);
  const auto surface_pos = surface_item_positions(surface_points, surface);
  const auto surface_flux = surface_item_flux(surface_points, surface);
  volume_info_ = device.upload(std::vector<SpmGridInfo>{volume.info});
  volume_start_ = device.upload(volume.cell_start);
  volume_pos_ = device.upload(volume_pos);
  volume_items_ = device.upload(volume.items);
  volume_ = device.upload(maps.volume);
  surface_info_ = device.upload(std::vector<SpmGridInfo>{surface_points.info});
  surface_start_ = device.upload(surface_points.cell_start);
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
