// The maps as the gather kernel reads them: each map with its grid
// (host/spm/record_grid.h) and per-item arrays in cell order, uploaded and
// bound as the list in kernels/spm_maps.h says.
#pragma once

#include <cmath>
#include <vector>

#include "device/device.h"
#include "spm/record_grid.h"
#include "spm/propagate.h"
#include "spm/wall_images.h"
#include "spm_maps.h"

namespace spm {

// Edge of the surface map's point grid cells, in gather radii. A query
// examines about (2 + kSurfaceCell)^2 r^2 of surface for the pi r^2 it uses
// and reads the bounds of up to (2 / kSurfaceCell + 1)^2 rows of cells.
inline constexpr float kSurfaceCell = 1.0f;

// Edge of the stream beams' capsule grid cells, in beam radii: a ray
// examines the beams of the cells it crosses, which lie within about
// r + (1/2 + sqrt(3)/2) kBeamCell r of it, and a beam of length L is listed
// in about pi (1 + sqrt(3)/2 kBeamCell)^2 L / (kBeamCell^3 r) cells.
inline constexpr float kBeamCell = 1.5f;

// The gather's grids: the volume map's sphere grid and the surface map's
// point grid (host/spm/record_grid.h).
RecordGrid volume_grid(const std::vector<SpmVolumeRecord>& records, float radius);
// The surface grid lists records[used[i]] as item i.
RecordGrid surface_grid(const SpmSurfaceRecord* records, const std::vector<uint32_t>& used, float radius);
RecordGrid beam_grid(const std::vector<SpmBeam>& beams, float radius);

// Grid items of the volume map: the listed record's position, its depth in w
// (kernels/lib/estimate.h leaves out records deeper than max_depth allows).
std::vector<cl_float4> volume_item_positions(const RecordGrid& grid, const std::vector<SpmVolumeRecord>& records);

// Grid items of the surface map (a grid from surface_grid over `used`):
// position with the packed normal in w (kernels/lib/estimate.h,
// unpack_normal), and the record's flux with its depth in w, so that the
// surface estimate never reads the records themselves.
struct SurfaceItems {
  std::vector<cl_float4> pos, flux;
};
SurfaceItems surface_items(const RecordGrid& grid, const SpmSurfaceRecord* records, const std::vector<uint32_t>& used);

// The part of space the gather's queries can reach: the scene's bounds
// grown by the radius. A photon that lands on a tangent plane outside it
// (a grazing stream's footprint runs far, METHOD.md 1) is within r of no
// surface point, so no estimate could count it.
struct QueryBounds {
  glm::vec3 lo{-INFINITY}, hi{INFINITY};
  bool contains(const float* p) const;
};

// The volume records that go to the fine grid (map_grid_data): those in
// `reach` grown about its centre to an edge of cbrt(records) cells of 2r
// where that is wider, so that the fine grid has about as many cells as
// records while it holds the records near the scene as well as in it.
QueryBounds volume_core(const QueryBounds& reach, size_t records, float radius);

// The indices of the surface records among records[0, count) that the
// gather uses: with next-event estimation (`skip_direct`), not those of
// streams that had no event before (METHOD.md 5); and only those inside
// `reach`, so that the grid stays as tight as the scene. Indices, not
// copies: a pass of Fig. 3 (b) has a million records of 64 bytes.
std::vector<uint32_t> used_surface_records(const SpmSurfaceRecord* records, size_t count, bool skip_direct,
                                           const QueryBounds& reach = {});

// The gather's grids of some map records, built on the host: the volume
// map's sphere grid, the surface map's point grid and the stream beams'
// capsule grid with their per-item arrays, as MapGrids uploads them.
struct MapGridData {
  RecordGrid volume, gather, volume_caustic, outer, surface, beam, caustic;
  std::vector<cl_float4> volume_pos, gather_pos, volume_caustic_pos, outer_pos, surface_pos, surface_flux, caustic_pos,
      caustic_flux;
  std::vector<SpmVolumeRecord> volume_records, outer_records;
  std::vector<SpmBeam> beams;
  size_t bytes() const;  // device memory of the upload
};

// The records a pass's gather reads, and its radii.
struct MapParts {
  std::vector<SpmVolumeRecord> volume;  // empty when the gather reads beams
  const SpmSurfaceRecord* surface = nullptr;  // [surface, surface + surface_count), not owned
  size_t surface_count = 0;
  std::vector<SpmBeam> beams;           // empty unless the gather reads beams
};

// `surface` as the gather uses it (used_surface_records); with next-event
// estimation (`skip_direct`) the surface records of streams without an
// earlier event are left out, the final gather's rays included (they
// estimate that light by next-event estimation too, spm_gather.cl
// final_gather), and so are the volume records and beams of depth 1 unless
// there is a final gather (`final_gather`), whose rays read single
// scattering from them. With a final gather the caustic grid holds the
// surface records flagged SPM_RECORD_CAUSTIC, read at the camera's vertex.
// Volume records outside volume_core(reach) go to a grid of their own (`outer`): in a
// fog that fills all space they spread hundreds of radii beyond the scene,
// and one grid over all of them, capped in cells, would have cells far
// wider than 2r where the queries are (README "Why more streams cost the
// fog box so much"). Each record is in one of the two grids, and the
// gather sums both. The volume grids are over spheres of `volume_radius`,
// the surface grids over disks of `radius`. With a final gather and a
// volume radius above `radius`, the gather rays read the volume records
// with `radius`, through a grid of their own over the records in the core
// (`gather`; empty otherwise): one of `volume_radius` would make them walk
// cells of 2 volume_radius, and their estimate is averaged over the
// hemisphere, so the smaller radius costs them little variance (README
// "A wider volume kernel by default"). With a `caustic_volume_radius`
// below the volume radius, the records in the core flagged
// SPM_RECORD_CAUSTIC, light that glass or a mirror focused, are listed in
// a sphere grid of that radius (`volume_caustic`, its items indices into
// the core's records, which end with them) instead of the volume grid:
// the light the rest carries, scattered after a diffuse event, is smooth
// enough for a kernel twice as wide, while a focused cone is not (README
// "A kernel for focused light"). The gather rays' grid lists them all. With `walls`, the volume records
// near them get their mirror images (WallImages::add).
MapGridData map_grid_data(MapParts maps, float radius, float volume_radius, float caustic_volume_radius,
                          float beam_radius, bool skip_direct, bool final_gather = false,
                          const QueryBounds& reach = {}, const WallImages* walls = nullptr);

// The map buffers on the device, one per entry of SPM_MAP_BUFFERS, bound
// under their names after the gather's own arguments.
class MapGrids {
 public:
  MapGrids(Device& device, const MapGridData& data);

  cl_uint bind(cl::Kernel& kernel, cl_uint index) const;

 private:
#define SPM_MAP_BUFFER(type, name) DeviceBuffer name;
  SPM_MAP_BUFFERS(SPM_MAP_BUFFER)
#undef SPM_MAP_BUFFER
};

}  // namespace spm
