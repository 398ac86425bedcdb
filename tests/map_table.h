// Grid tables for the estimate test kernels (kernels/spm_estimate.cl): a
// table of one row, built and laid out as map_grid_data lays out each of
// its rows (host/spm/map_grids.h), uploaded and bound with its row count.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "spm/map_grids.h"
#include "test_support.h"

namespace spm::test {

inline constexpr double kPi = 3.14159265358979323846;

inline glm::dvec3 v3(const float* p) { return {p[0], p[1], p[2]}; }

inline double kernel_2d(int kernel, double d2, double r2) {
  return kernel == 1 ? 2.0 / (kPi * r2) * (1.0 - d2 / r2) : 1.0 / (kPi * r2);
}

inline double phase_hg(double cos_theta, double g) {
  const double denom = 1 + g * g - 2 * g * cos_theta;
  return (1 - g * g) / (4 * kPi * denom * std::sqrt(denom));
}

// METHOD.md 5 written out directly: every record, no grid.
// Records deeper than max_depth are left out (METHOD.md 10), and those
// shallower than min_depth.
inline glm::dvec3 beam_reference(const std::vector<SpmVolumeRecord>& records, const SpmMedium& m, int medium,
                                 glm::dvec3 o, glm::dvec3 d, double t0, double t1, double r, int kernel, int estimator,
                                 uint32_t min_depth, uint32_t max_depth) {
  glm::dvec3 sum(0.0);
  for (const auto& rec : records) {
    if (rec.medium != medium || rec.depth > max_depth || rec.depth < min_depth) continue;
    const glm::dvec3 x = v3(rec.position);
    const double t = glm::dot(x - o, d);
    if (t < t0 || t > t1) continue;
    const double d2 = glm::dot(x - (o + t * d), x - (o + t * d));
    if (d2 >= r * r) continue;
    if (estimator == 1) {
      sum += v3(rec.flux);
      continue;
    }
    const double g = m.phase == SPM_PHASE_HG ? m.g : 0.0;
    for (int c = 0; c < 3; ++c) {
      sum[c] += kernel_2d(kernel, d2, r * r) * std::exp(-m.sigma_t[c] * (t - t0)) *
                phase_hg(-glm::dot(v3(rec.direction), d), g) * rec.flux[c] * m.albedo[c];
    }
  }
  return estimator == 1 ? sum / (kPi * r * r * (t1 - t0)) : sum;
}

// Radii with one reader reading at `radius`.
inline MapGridData::Radii read_by(cl_uint reader, float radius) {
  MapGridData::Radii r{};
  r[reader] = radius;
  return r;
}

// The sphere grid `grid` over `records` (its item indices), read by `reader`.
inline MapGridData sphere_table(const RecordGrid& grid, const std::vector<SpmVolumeRecord>& records, float radius,
                                cl_uint reader = SPM_READ_CAMERA) {
  MapGridData d;
  d.volume_records.append(records);
  d.add_spheres(grid, records, read_by(reader, radius));
  return d;
}

inline MapGridData sphere_table(const std::vector<SpmVolumeRecord>& records, float radius,
                                cl_uint reader = SPM_READ_CAMERA) {
  return sphere_table(volume_grid(records, 0, records.size(), radius), records, radius, reader);
}

// The point grid `grid` over records[used[i]], read by `reader`.
inline MapGridData disk_table(const std::vector<SpmSurfaceRecord>& records, const std::vector<uint32_t>& used,
                              const RecordGrid& grid, float radius, cl_uint reader = SPM_READ_VERTEX) {
  MapGridData d;
  d.add_disks(grid, records.data(), used, read_by(reader, radius));
  return d;
}

inline MapGridData capsule_table(const std::vector<SpmBeam>& beams, float radius, cl_uint reader = SPM_READ_CAMERA) {
  MapGridData d;
  d.beams.append(beams);
  d.add_capsules(beam_grid(beams, radius), read_by(reader, radius));
  return d;
}

// A table on the device, bound as the test kernels take it: `rows`, then
// the map buffers (SPM_MAP_PARAMS).
struct TableBuffers {
  MapGrids grids;
  cl_uint rows;

  TableBuffers(Device& dev, const MapGridData& d) : grids(dev, d), rows(cl_uint(d.grids.size())) {}

  cl_uint bind(cl::Kernel& kernel, cl_uint index) const {
    bind_arg(kernel, index, "rows", rows);
    return grids.bind(kernel, index + 1);
  }
};

// What spm_volume_test sets apart from the table and the rays.
struct VolumeTestSettings {
  int kernel = 0, estimator = 0;
  uint32_t min_depth = 0, max_depth = SPM_NONE;
  std::vector<SpmPatch> walls = std::vector<SpmPatch>(1);  // the patches images name (SPM_RECORD_IMAGE)
  cl_uint reader = SPM_READ_CAMERA;
};

// spm_volume_test over n rays (origin and t0, direction and t1) through the
// grids of `table` the reader reads, in medium 0 of `media`: one estimate
// per ray.
inline std::vector<cl_float4> volume_test(const MapGridData& table, const cl::Buffer& media, const cl::Buffer& origins,
                                        const cl::Buffer& directions, int n, const VolumeTestSettings& t) {
  auto& dev = device();
  const DeviceBuffer out = dev.buffer(sizeof(cl_float4) * n, "estimates", CL_MEM_WRITE_ONLY);
  cl::Kernel k = dev.kernel("spm_estimate", "spm_volume_test");
  const cl::Buffer patches = dev.upload("patches", t.walls);
  const TableBuffers buffers(dev, table);  // alive until the launch has run
  set_args(k, buffers, arg("media", media), arg("patches", patches),
                arg("origins", origins), arg("directions", directions), arg("out", out),
                arg("count", cl_uint(n)), arg("medium", cl_int(0)), arg("reader", t.reader),
                arg("density_kernel", cl_uint(t.kernel)), arg("estimator", cl_uint(t.estimator)),
                arg("min_rec_depth", cl_uint(t.min_depth)), arg("max_rec_depth", cl_uint(t.max_depth)));
  dev.launch(k, n);
  return dev.download<cl_float4>(out, n);
}

// The record indices row `row` of `d` lists, one per item, in item order.
inline std::vector<uint32_t> listed(const MapGridData& d, size_t row) {
  const SpmMapGrid& g = d.grids[row];
  const size_t cells = size_t(g.info.dims[0]) * g.info.dims[1] * g.info.dims[2];
  std::vector<uint32_t> out;
  for (uint32_t k = d.grid_cells[g.first_cell]; k < d.grid_cells[g.first_cell + cells]; ++k) {
    uint32_t index;
    std::memcpy(&index, &d.grid_pos[g.first_item + k].s[3], sizeof index);
    out.push_back(index);
  }
  return out;
}

// The row of the grid table that role `name` has (map_grids.cpp).
inline size_t role_row(const std::string& name) {
  const std::vector<GridRole>& roles = grid_roles();
  for (size_t i = 0; i < roles.size(); ++i) {
    if (name == roles[i].name) return i;
  }
  ADD_FAILURE() << "no grid role " << name;
  return 0;
}

// The distinct values of `v`, sorted: the records a sphere grid lists in
// one cell or several.
inline std::vector<uint32_t> distinct(std::vector<uint32_t> v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

}  // namespace spm::test
