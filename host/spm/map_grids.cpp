#include "spm/map_grids.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <future>

namespace spm {

namespace {

// The positions of records[first, last).
std::vector<glm::vec3> positions(const std::vector<SpmVolumeRecord>& records, size_t first, size_t last) {
  std::vector<glm::vec3> out;
  out.reserve(last - first);
  for (size_t i = first; i < last; ++i) {
    out.emplace_back(records[i].position[0], records[i].position[1], records[i].position[2]);
  }
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

// The sphere grid of radius r over records[first, last) and its items'
// positions; the items index `records`.
void sphere_grid_of(const std::vector<SpmVolumeRecord>& records, size_t first, size_t last, float r,
                    RecordGrid& grid, std::vector<cl_float4>& pos) {
  grid = build_sphere_grid(positions(records, first, last), r);
  for (uint32_t& item : grid.items) item += uint32_t(first);
  pos = volume_item_positions(grid, records);
}

}  // namespace

RecordGrid volume_grid(const std::vector<SpmVolumeRecord>& records, float radius) {
  return build_sphere_grid(positions(records, 0, records.size()), radius);
}

RecordGrid surface_grid(const SpmSurfaceRecord* records, const std::vector<uint32_t>& used, float radius) {
  std::vector<glm::vec3> centres;
  centres.reserve(used.size());
  for (uint32_t i : used) centres.emplace_back(records[i].position[0], records[i].position[1], records[i].position[2]);
  return build_point_grid(centres, kSurfaceCell * radius);
}

RecordGrid beam_grid(const std::vector<SpmBeam>& beams, float radius) {
  std::vector<glm::vec3> starts, ends;
  starts.reserve(beams.size());
  ends.reserve(beams.size());
  for (const SpmBeam& b : beams) {
    const glm::vec3 o(b.origin[0], b.origin[1], b.origin[2]), d(b.direction[0], b.direction[1], b.direction[2]);
    starts.push_back(o);
    ends.push_back(o + b.length * d);
  }
  return build_capsule_grid(starts, ends, radius, kBeamCell * radius);
}

std::vector<cl_float4> volume_item_positions(const RecordGrid& grid, const std::vector<SpmVolumeRecord>& records) {
  return per_item(grid, records, [](const SpmVolumeRecord& r) {
    return cl_float4{{r.position[0], r.position[1], r.position[2], float(r.depth)}};
  });
}

SurfaceItems surface_items(const RecordGrid& grid, const SpmSurfaceRecord* records, const std::vector<uint32_t>& used) {
  // One pass over the items for both arrays: each reads its record once.
  SurfaceItems out;
  out.pos.resize(grid.items.size());
  out.flux.resize(grid.items.size());
  for (size_t k = 0; k < grid.items.size(); ++k) {
    const SpmSurfaceRecord& r = records[used[grid.items[k]]];
    out.pos[k] = cl_float4{{r.position[0], r.position[1], r.position[2], pack_normal(r.normal)}};
    out.flux[k] = cl_float4{{r.flux[0], r.flux[1], r.flux[2], float(r.depth_photon >> 16)}};
  }
  return out;
}

bool QueryBounds::contains(const float* p) const {
  for (int k = 0; k < 3; ++k) {
    if (!(p[k] >= lo[k] && p[k] <= hi[k])) return false;
  }
  return true;
}

QueryBounds volume_core(const QueryBounds& reach, size_t records, float radius) {
  QueryBounds core = reach;
  const float edge = std::cbrt(float(records)) * 2.0f * radius;
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(reach.lo[k]) || !std::isfinite(reach.hi[k])) continue;
    const float centre = 0.5f * (reach.lo[k] + reach.hi[k]);
    const float half = std::max(0.5f * (reach.hi[k] - reach.lo[k]), 0.5f * edge);
    core.lo[k] = std::min(reach.lo[k], centre - half);
    core.hi[k] = std::max(reach.hi[k], centre + half);
  }
  return core;
}

std::vector<uint32_t> used_surface_records(const SpmSurfaceRecord* records, size_t count, bool skip_direct,
                                           const QueryBounds& reach) {
  std::vector<uint32_t> out;
  out.reserve(count);
  for (size_t i = 0; i < count; ++i) {
    const SpmSurfaceRecord& r = records[i];
    if ((!skip_direct || (r.flags & SPM_RECORD_HAD_EVENT)) && reach.contains(r.position)) {
      out.push_back(static_cast<uint32_t>(i));
    }
  }
  return out;
}

template <class T>
size_t vector_bytes(const std::vector<T>& v) {
  return sizeof(T) * std::max<size_t>(1, v.size());  // Device::upload gives an empty table one element
}

size_t MapGridData::bytes() const {
  return 2 * sizeof(SpmGridInfo) + vector_bytes(volume.cell_start) + vector_bytes(volume_pos) +
         vector_bytes(volume.items) + vector_bytes(volume_records) + sizeof(SpmGridInfo) +
         vector_bytes(gather.cell_start) + vector_bytes(gather_pos) + vector_bytes(gather.items) + sizeof(SpmGridInfo) +
         vector_bytes(volume_caustic.cell_start) + vector_bytes(volume_caustic_pos) +
         vector_bytes(volume_caustic.items) + sizeof(SpmGridInfo) +
         vector_bytes(outer.cell_start) + vector_bytes(outer_pos) + vector_bytes(outer.items) +
         vector_bytes(outer_records) + vector_bytes(surface.cell_start) +
         vector_bytes(surface_pos) + vector_bytes(surface_flux) + sizeof(SpmGridInfo) + vector_bytes(beam.cell_start) +
         vector_bytes(beam.items) + vector_bytes(beams) + sizeof(SpmGridInfo) + vector_bytes(caustic.cell_start) +
         vector_bytes(caustic_pos) + vector_bytes(caustic_flux);
}

MapGridData map_grid_data(MapParts maps, float radius, float volume_radius, float caustic_volume_radius,
                          float beam_radius, bool skip_direct, bool final_gather, const QueryBounds& reach,
                          const WallImages* walls) {
  MapGridData d;
  std::vector<SpmVolumeRecord>& volume = maps.volume;
  std::vector<SpmBeam>& beams = maps.beams;
  if (skip_direct && !final_gather) {
    // Single scattering comes from next-event estimation (spm_gather.cl,
    // inscatter_nee): a volume record or beam at path vertex 1 has no
    // earlier event. A final gather keeps them: its rays read single
    // scattering from them (final_gather), and the camera's segments skip
    // them by depth (min_rec_depth 2).
    volume.erase(std::remove_if(volume.begin(), volume.end(), [](const SpmVolumeRecord& r) { return r.depth <= 1; }),
                 volume.end());
    beams.erase(std::remove_if(beams.begin(), beams.end(), [](const SpmBeam& b) { return b.depth <= 1; }),
                beams.end());
  }
  if (walls) walls->add(volume, volume_radius);
  const std::vector<uint32_t> surface = used_surface_records(maps.surface, maps.surface_count, skip_direct, reach);
  std::vector<uint32_t> caustic;
  if (final_gather) {
    for (uint32_t i : surface) {
      if (maps.surface[i].flags & SPM_RECORD_CAUSTIC) caustic.push_back(i);
    }
  }
  std::vector<SpmVolumeRecord> outer;
  const QueryBounds core = volume_core(reach, volume.size(), volume_radius);
  const auto far = std::stable_partition(volume.begin(), volume.end(),
                                         [&](const SpmVolumeRecord& r) { return core.contains(r.position); });
  outer.assign(far, volume.end());
  volume.erase(far, volume.end());
  // The caustic records last, so that the volume grid's items index the
  // records before them as they are and the caustic grid's need an offset.
  size_t focused = volume.size();
  if (caustic_volume_radius < volume_radius) {
    focused = size_t(std::stable_partition(volume.begin(), volume.end(),
                                           [](const SpmVolumeRecord& r) { return !(r.flags & SPM_RECORD_CAUSTIC); }) -
                     volume.begin());
  }
  // The volume grid on a thread of its own, the others here: they only read
  // the records, and the device waits for all of them (caustic_area's pass:
  // 15 ms for the volume grid and its items against 25 ms for the rest).
  std::future<void> volume_part = std::async(std::launch::async, [&] {
    sphere_grid_of(volume, 0, focused, volume_radius, d.volume, d.volume_pos);
  });
  sphere_grid_of(volume, focused, volume.size(), std::min(caustic_volume_radius, volume_radius), d.volume_caustic,
                 d.volume_caustic_pos);
  if (final_gather && radius < volume_radius) {
    d.gather = volume_grid(volume, radius);
    d.gather_pos = volume_item_positions(d.gather, volume);
  } else {
    d.gather = volume_grid({}, volume_radius);
  }
  d.outer = volume_grid(outer, volume_radius);
  d.surface = surface_grid(maps.surface, surface, radius);
  d.caustic = surface_grid(maps.surface, caustic, radius);
  d.beam = beam_grid(beams, beam_radius);
  d.outer_pos = volume_item_positions(d.outer, outer);
  SurfaceItems items = surface_items(d.surface, maps.surface, surface);
  d.surface_pos = std::move(items.pos);
  d.surface_flux = std::move(items.flux);
  items = surface_items(d.caustic, maps.surface, caustic);
  d.caustic_pos = std::move(items.pos);
  d.caustic_flux = std::move(items.flux);
  volume_part.get();
  d.volume_records = std::move(volume);
  d.outer_records = std::move(outer);
  d.beams = std::move(beams);
  return d;
}

MapGrids::MapGrids(Device& device, const MapGridData& d)
    : volume_info(device.upload("volume_info", std::vector<SpmGridInfo>{d.volume.info})),
      volume_start(device.upload("volume_start", d.volume.cell_start)),
      volume_pos(device.upload("volume_pos", d.volume_pos)),
      volume_items(device.upload("volume_items", d.volume.items)),
      volume(device.upload("volume", d.volume_records)),
      gather_info(device.upload("gather_info", std::vector<SpmGridInfo>{d.gather.info})),
      gather_start(device.upload("gather_start", d.gather.cell_start)),
      gather_pos(device.upload("gather_pos", d.gather_pos)),
      gather_items(device.upload("gather_items", d.gather.items)),
      volume_caustic_info(device.upload("volume_caustic_info", std::vector<SpmGridInfo>{d.volume_caustic.info})),
      volume_caustic_start(device.upload("volume_caustic_start", d.volume_caustic.cell_start)),
      volume_caustic_pos(device.upload("volume_caustic_pos", d.volume_caustic_pos)),
      volume_caustic_items(device.upload("volume_caustic_items", d.volume_caustic.items)),
      outer_info(device.upload("outer_info", std::vector<SpmGridInfo>{d.outer.info})),
      outer_start(device.upload("outer_start", d.outer.cell_start)),
      outer_pos(device.upload("outer_pos", d.outer_pos)),
      outer_items(device.upload("outer_items", d.outer.items)),
      outer(device.upload("outer", d.outer_records)),
      surface_info(device.upload("surface_info", std::vector<SpmGridInfo>{d.surface.info})),
      surface_start(device.upload("surface_start", d.surface.cell_start)),
      surface_pos(device.upload("surface_pos", d.surface_pos)),
      surface_flux(device.upload("surface_flux", d.surface_flux)),
      beam_info(device.upload("beam_info", std::vector<SpmGridInfo>{d.beam.info})),
      beam_start(device.upload("beam_start", d.beam.cell_start)),
      beam_items(device.upload("beam_items", d.beam.items)),
      beams(device.upload("beams", d.beams)),
      caustic_info(device.upload("caustic_info", std::vector<SpmGridInfo>{d.caustic.info})),
      caustic_start(device.upload("caustic_start", d.caustic.cell_start)),
      caustic_pos(device.upload("caustic_pos", d.caustic_pos)),
      caustic_flux(device.upload("caustic_flux", d.caustic_flux)) {}

cl_uint MapGrids::bind(cl::Kernel& k, cl_uint i) const {
#define SPM_MAP_BIND(type, name) bind_arg(k, i++, #name, name);
  SPM_MAP_BUFFERS(SPM_MAP_BIND)
#undef SPM_MAP_BIND
  return i;
}

}  // namespace spm
