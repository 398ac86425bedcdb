// The maps as the gather kernel reads them: each map with its grid
// (host/spm/record_grid.h) and per-item arrays in cell order, uploaded and
// bound as the list in kernels/spm_maps.h says.
#pragma once

#include <array>
#include <cmath>
#include <vector>

#include "device/device.h"
#include "render/tuning.h"
#include "spm/record_grid.h"
#include "spm/propagate.h"
#include "spm/wall_images.h"
#include "spm_maps.h"

namespace spm {

// The gather's grids: the volume map's sphere grid, the surface map's
// point grid and the stream beams' capsule grid (host/spm/record_grid.h).
RecordGrid volume_grid(const std::vector<SpmVolumeRecord>& records, size_t first, size_t last, float radius);
// The surface grid lists records[used[i]] as item i.
RecordGrid surface_grid(const SpmSurfaceRecord* records, const std::vector<uint32_t>& used, float radius);
RecordGrid beam_grid(const std::vector<SpmBeam>& beams, float radius);

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

// The gather's map buffers on the host, one per entry of SPM_MAP_BUFFERS
// (kernels/spm_maps.h): the grid table, the cells and items its rows
// share, and the records they list, each in parts that upload one after
// another (a row's cells and items are a part each).
struct MapGridData {
#define SPM_MAP_FIELD(type, name) Pieces<type> name;
  SPM_MAP_BUFFERS(SPM_MAP_FIELD)
#undef SPM_MAP_FIELD
  size_t bytes() const;  // device memory of the upload

  // Appends `grid` as the table's next row, read with `radii` (SPM_READ_*;
  // 0: not read). Its items list `records` (spheres: volume_records, which
  // the caller appends them to) or beams (capsules) by the grid's item
  // indices, or, for disks, the surface records records[used[i]] for item
  // i. Disk grids come before the others, so that surface_flux runs
  // parallel to grid_pos.
  using Radii = std::array<float, SPM_READERS>;
  void add_spheres(const RecordGrid& grid, const std::vector<SpmVolumeRecord>& records, const Radii& radii);
  void add_capsules(const RecordGrid& grid, const Radii& radii);
  void add_disks(const RecordGrid& grid, const SpmSurfaceRecord* records, const std::vector<uint32_t>& used,
                 const Radii& radii);

  // The table's next row: `grid` with its items' positions (and, for
  // disks, flux), as fill_items writes them, moved in.
  void add_row(RecordGrid grid, cl_uint kind, const Radii& radii, std::vector<cl_float4> pos,
               std::vector<cl_float4> flux);
};

// The records a pass's gather reads.
struct MapParts {
  std::vector<SpmVolumeRecord> volume;  // empty when the gather reads beams
  const SpmSurfaceRecord* surface = nullptr;  // [surface, surface + surface_count), not owned
  size_t surface_count = 0;
  std::vector<SpmBeam> beams;           // empty unless the gather reads beams
};

// What decides which reader reads which grid, and with what radius.
struct PassRadii {
  float radius = 0.0f;                 // the surface estimates' r
  float volume_radius = 0.0f;          // the camera's volume records' kernel radius
  float caustic_volume_radius = 0.0f;  // the camera's for caustic volume records
  float beam_radius = 0.0f;            // the stream beams' 1D kernel radius
  bool final_gather = false;
  bool beams = false;  // the volume estimate reads stream beams, not records
};

// Which of the pass's records a role's grid lists (map_grids.cpp).
enum class GridRecords { Surface, SurfaceCaustic, Volume, VolumeCore, VolumeOuter, VolumeCaustic, Beams };

// One role of the gather's grid table: what its grid lists, as which kind
// of grid, and the radius each reader reads it with in a pass.
struct GridRole {
  const char* name;
  cl_uint kind;  // SPM_GRID_*
  GridRecords records;
  MapGridData::Radii (*radii)(const PassRadii&);
};

// The roles, in the order of the grid table's rows (map_grids.cpp).
const std::vector<GridRole>& grid_roles();

// The gather's grids of some map records, built on the host, one row per
// role. With next-event estimation (`skip_direct`) the surface records of
// streams without an earlier event are left out (used_surface_records),
// the final gather's rays included (they estimate that light by next-event
// estimation too, spm_gather.cl final_gather), and so are the volume
// records and beams of depth 1 unless there is a final gather, whose rays
// read single scattering from them. Volume records outside
// volume_core(reach) go to a grid of their own (the `outer` role): in a
// fog that fills all space they spread hundreds of radii beyond the scene,
// and one grid over all of them, capped in cells, would have cells far
// wider than 2r where the queries are (docs/METHOD.md 17). Each record is
// in one of the two, and the camera's estimate sums both. With a caustic
// volume radius below the volume radius, the core's records flagged
// SPM_RECORD_CAUSTIC, light that glass or a mirror focused, get a sphere
// grid of that radius instead of the volume grid: the light the rest
// carries, scattered after a diffuse event, is smooth enough for a wider
// kernel, while a focused cone is not. With a final gather and a volume
// radius above the radius, the gather rays read the core's records with
// the radius through a grid of their own over all of them: one of the
// volume radius would make them walk cells of twice that, and their
// estimate is averaged over the hemisphere, so the smaller radius costs
// them little variance. With `walls`, the volume records near them get
// their mirror images (WallImages::add).
MapGridData map_grid_data(MapParts maps, const PassRadii& radii, bool skip_direct, const QueryBounds& reach = {},
                          const WallImages* walls = nullptr);

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
