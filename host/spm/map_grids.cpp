#include "spm/map_grids.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <future>
#include <stdexcept>

#include "util/errors.h"

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

// An index as the bits of a float, for an item's w (as_uint in the kernels).
float index_bits(uint32_t i) {
  float f;
  std::memcpy(&f, &i, sizeof f);
  return f;
}

using Radii = MapGridData::Radii;

// The largest of a row's radii: the one its grid is built for, since a
// grid of radius R serves any radius up to R; 0 when nothing reads it.
float build_radius(const Radii& radii) { return *std::max_element(radii.begin(), radii.end()); }

// Writes the items of `grid` to pos (and, for disks, flux): a
// sphere grid's over `volume` or a capsule grid's over beams, its record's
// position and index; a disk grid's over surface[used[i]], its position
// with the packed normal in w (kernels/lib/estimate.h, unpack_normal) and
// its flux with its depth in w, so that the surface estimate never reads
// the records themselves. One pass for both arrays: each reads its record
// once.
void fill_items(const RecordGrid& grid, cl_uint kind, const std::vector<SpmVolumeRecord>& volume,
                const SpmSurfaceRecord* surface, const std::vector<uint32_t>* used, std::vector<cl_float4>& pos,
                std::vector<cl_float4>& flux) {
  pos.resize(grid.items.size());
  if (kind == SPM_GRID_DISKS) flux.resize(grid.items.size());
  for (size_t k = 0; k < grid.items.size(); ++k) {
    const uint32_t i = grid.items[k];
    if (kind == SPM_GRID_SPHERES) {
      const SpmVolumeRecord& r = volume[i];
      pos[k] = cl_float4{{r.position[0], r.position[1], r.position[2], index_bits(i)}};
    } else if (kind == SPM_GRID_CAPSULES) {
      pos[k] = cl_float4{{0.0f, 0.0f, 0.0f, index_bits(i)}};
    } else {
      const SpmSurfaceRecord& r = surface[(*used)[i]];
      pos[k] = cl_float4{{r.position[0], r.position[1], r.position[2], pack_normal(r.normal)}};
      flux[k] = cl_float4{{r.flux[0], r.flux[1], r.flux[2], float(r.depth_photon >> 16)}};
    }
  }
}

// The readers of each role (SPM_READ_*). Without a final gather there
// are no gather rays, and the camera reads the whole surface map at its
// vertex; with one, the caustic records there and at a gather ray's end
// near its start (SPM_GATHER_NEAR, where the path goes on), and the whole
// map at its other ends. The gather rays read the volume records with
// the radius where it is below the volume radius, through the
// gather_volume grid over the core's records (`own`), else as the camera
// does (docs/METHOD.md 17).
bool own_gather_grid(const PassRadii& p) { return p.final_gather && p.radius < p.volume_radius; }
// Whether the caustic volume records have a grid of their own.
bool split_caustic(const PassRadii& p) { return p.caustic_volume_radius < p.volume_radius; }

Radii surface_radii(const PassRadii& p) {
  return {0.0f, 0.0f, p.final_gather ? 0.0f : p.radius, p.final_gather ? p.radius : 0.0f, 0.0f};
}
Radii caustic_radii(const PassRadii& p) {
  const float r = p.final_gather ? p.radius : 0.0f;
  return {0.0f, 0.0f, r, 0.0f, r};
}
Radii volume_radii(const PassRadii& p) {
  if (p.beams) return {};
  return {p.volume_radius, p.final_gather && !own_gather_grid(p) ? p.volume_radius : 0.0f, 0.0f, 0.0f, 0.0f};
}
Radii gather_volume_radii(const PassRadii& p) {
  if (p.beams || !own_gather_grid(p)) return {};
  return {0.0f, p.radius, 0.0f, 0.0f, 0.0f};
}
Radii outer_radii(const PassRadii& p) {
  if (p.beams) return {};
  return {p.volume_radius, p.final_gather ? std::min(p.radius, p.volume_radius) : 0.0f, 0.0f, 0.0f, 0.0f};
}
Radii volume_caustic_radii(const PassRadii& p) {
  if (p.beams || !split_caustic(p)) return {};
  const float r = std::min(p.caustic_volume_radius, p.volume_radius);
  return {r, p.final_gather && !own_gather_grid(p) ? r : 0.0f, 0.0f, 0.0f, 0.0f};
}
Radii beam_radii(const PassRadii& p) {
  if (!p.beams) return {};
  return {p.beam_radius, p.final_gather ? p.beam_radius : 0.0f, 0.0f, 0.0f, 0.0f};
}

}  // namespace

const std::vector<GridRole>& grid_roles() {
  // The disk grids first (MapGridData::add). A reader sums the volume
  // grids it reads in this order.
  static const std::vector<GridRole> roles = {
      {"surface", SPM_GRID_DISKS, GridRecords::Surface, surface_radii},
      {"caustic", SPM_GRID_DISKS, GridRecords::SurfaceCaustic, caustic_radii},
      {"volume", SPM_GRID_SPHERES, GridRecords::Volume, volume_radii},
      {"gather_volume", SPM_GRID_SPHERES, GridRecords::VolumeCore, gather_volume_radii},
      {"outer", SPM_GRID_SPHERES, GridRecords::VolumeOuter, outer_radii},
      {"volume_caustic", SPM_GRID_SPHERES, GridRecords::VolumeCaustic, volume_caustic_radii},
      {"beams", SPM_GRID_CAPSULES, GridRecords::Beams, beam_radii},
  };
  return roles;
}

RecordGrid volume_grid(const std::vector<SpmVolumeRecord>& records, size_t first, size_t last, float radius) {
  RecordGrid grid = build_sphere_grid(positions(records, first, last), radius);
  for (uint32_t& item : grid.items) item += uint32_t(first);
  return grid;
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

size_t MapGridData::bytes() const {
  // Device::upload gives an empty buffer one element.
  size_t n = 0;
#define SPM_MAP_BYTES(type, name) n += sizeof(type) * std::max<size_t>(1, name.size());
  SPM_MAP_BUFFERS(SPM_MAP_BYTES)
#undef SPM_MAP_BYTES
  return n;
}

void MapGridData::add_row(RecordGrid grid, cl_uint kind, const Radii& radii, std::vector<cl_float4> pos,
                          std::vector<cl_float4> flux) {
  const size_t first_item = grid_pos.size();
  if (kind == SPM_GRID_DISKS && first_item != surface_flux.size()) {
    throw std::logic_error("a disk grid after another kind: surface_flux would not run parallel to grid_pos");
  }
  if (first_item + pos.size() > UINT32_MAX || grid_cells.size() + grid.cell_start.size() > UINT32_MAX) {
    throw RuntimeError("the photon maps' grids list more items than 32-bit indices hold");
  }
  SpmMapGrid g{};
  g.info = grid.info;
  g.first_cell = cl_uint(grid_cells.size());
  g.first_item = cl_uint(first_item);
  g.kind = kind;
  std::copy(radii.begin(), radii.end(), g.radius);
  grids.append({g});
  grid_cells.append(std::move(grid.cell_start));
  grid_pos.append(std::move(pos));
  if (kind == SPM_GRID_DISKS) surface_flux.append(std::move(flux));
}

void MapGridData::add_spheres(const RecordGrid& grid, const std::vector<SpmVolumeRecord>& records,
                              const Radii& radii) {
  std::vector<cl_float4> pos, flux;
  fill_items(grid, SPM_GRID_SPHERES, records, nullptr, nullptr, pos, flux);
  add_row(grid, SPM_GRID_SPHERES, radii, std::move(pos), {});
}

void MapGridData::add_capsules(const RecordGrid& grid, const Radii& radii) {
  std::vector<cl_float4> pos, flux;
  fill_items(grid, SPM_GRID_CAPSULES, {}, nullptr, nullptr, pos, flux);
  add_row(grid, SPM_GRID_CAPSULES, radii, std::move(pos), {});
}

void MapGridData::add_disks(const RecordGrid& grid, const SpmSurfaceRecord* records,
                            const std::vector<uint32_t>& used, const Radii& radii) {
  std::vector<cl_float4> pos, flux;
  fill_items(grid, SPM_GRID_DISKS, {}, records, &used, pos, flux);
  add_row(grid, SPM_GRID_DISKS, radii, std::move(pos), std::move(flux));
}

MapGridData map_grid_data(MapParts maps, const PassRadii& radii, bool skip_direct, const QueryBounds& reach,
                          const WallImages* walls) {
  std::vector<SpmVolumeRecord>& volume = maps.volume;
  std::vector<SpmBeam>& beams = maps.beams;
  if (skip_direct && !radii.final_gather) {
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
  if (walls) walls->add(volume, radii.volume_radius);
  // The volume records in one array: the core's (those without and then
  // those with SPM_RECORD_CAUSTIC, when they have a grid of their own),
  // then the outer ones.
  const QueryBounds core = volume_core(reach, volume.size(), radii.volume_radius);
  const size_t core_end = size_t(std::stable_partition(volume.begin(), volume.end(),
                                                       [&](const SpmVolumeRecord& r) {
                                                         return core.contains(r.position);
                                                       }) -
                                 volume.begin());
  size_t focused = core_end;
  if (split_caustic(radii)) {
    focused = size_t(std::stable_partition(volume.begin(), volume.begin() + core_end,
                                           [](const SpmVolumeRecord& r) { return !(r.flags & SPM_RECORD_CAUSTIC); }) -
                     volume.begin());
  }
  const std::vector<uint32_t> surface = used_surface_records(maps.surface, maps.surface_count, skip_direct, reach);
  std::vector<uint32_t> caustic;  // read with a final gather only (caustic_radii)
  if (radii.final_gather) {
    for (uint32_t i : surface) {
      if (maps.surface[i].flags & SPM_RECORD_CAUSTIC) caustic.push_back(i);
    }
  }
  // Each role's grid and its items on a thread of their own: they only
  // read the records, and the device waits for all of them.
  const std::vector<GridRole>& roles = grid_roles();
  struct Row {
    RecordGrid grid;
    std::vector<cl_float4> pos, flux;
  };
  std::vector<std::future<Row>> rows;
  for (const GridRole& role : roles) {
    rows.push_back(std::async(std::launch::async, [&, role]() -> Row {
      const float r = build_radius(role.radii(radii));
      Row row;
      if (!(r > 0.0f)) {
        row.grid = build_point_grid({}, 1.0f);  // one empty cell: nothing reads it
        return row;
      }
      const std::vector<uint32_t>& used = role.records == GridRecords::Surface ? surface : caustic;
      switch (role.records) {
        case GridRecords::Surface:
        case GridRecords::SurfaceCaustic: row.grid = surface_grid(maps.surface, used, r); break;
        case GridRecords::Volume: row.grid = volume_grid(volume, 0, focused, r); break;
        case GridRecords::VolumeCore: row.grid = volume_grid(volume, 0, core_end, r); break;
        case GridRecords::VolumeOuter: row.grid = volume_grid(volume, core_end, volume.size(), r); break;
        case GridRecords::VolumeCaustic: row.grid = volume_grid(volume, focused, core_end, r); break;
        case GridRecords::Beams: row.grid = beam_grid(beams, r); break;
      }
      fill_items(row.grid, role.kind, volume, maps.surface, &used, row.pos, row.flux);
      return row;
    }));
  }
  MapGridData d;
  for (size_t i = 0; i < roles.size(); ++i) {
    Row row = rows[i].get();
    d.add_row(std::move(row.grid), roles[i].kind, roles[i].radii(radii), std::move(row.pos), std::move(row.flux));
  }
  d.volume_records.append(std::move(volume));
  d.beams.append(std::move(beams));
  return d;
}

MapGrids::MapGrids(Device& device, const MapGridData& d) {
#define SPM_MAP_UPLOAD(type, name) name = device.upload(#name, d.name);
  SPM_MAP_BUFFERS(SPM_MAP_UPLOAD)
#undef SPM_MAP_UPLOAD
}

cl_uint MapGrids::bind(cl::Kernel& k, cl_uint i) const {
#define SPM_MAP_BIND(type, name) bind_arg(k, i++, #name, name);
  SPM_MAP_BUFFERS(SPM_MAP_BIND)
#undef SPM_MAP_BIND
  return i;
}

}  // namespace spm
