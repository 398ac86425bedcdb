#include "render/pass_renderer.h"

#include <algorithm>
#include <initializer_list>

#include "spm/gather.h"
#include "spm/maps_io.h"
#include "util/errors.h"
#include "util/timer.h"

namespace spm {

namespace {

// Codes of SPM_KERNEL_*, SPM_ESTIMATOR_* (kernels/lib/estimate.h) and
// SPM_DIRECT_* (kernels/spm_gather.cl): the position in `names`. The loader
// and the command line accept only these names.
cl_uint code_of(const std::string& value, std::initializer_list<const char*> names) {
  cl_uint i = 0;
  for (const char* n : names) {
    if (value == n) return i;
    ++i;
  }
  throw InputError("", "unknown value '" + value + "'");
}

constexpr cl_uint kDirectNee = 0;

// Pixels per gather launch at most: bounds the film buffer and a launch's length.
constexpr size_t kMaxTile = size_t(1) << 22;

// The device memory budget, shared out by sizes alone (never by what the
// driver has freed so far, which varies from run to run), so that the same
// render always makes the same batches, tiles and map parts: the scene's
// tables first, then half of the rest for a stream batch (at most 1 GiB),
// a quarter of what remains for the film, and the rest for the maps' grids.
size_t after_scene(const Device& device, const GpuScene& gpu) {
  const size_t budget = device.memory_budget();
  return budget > gpu.bytes() ? budget - gpu.bytes() : 0;
}

StreamSettings batch_settings(const Device& device, const GpuScene& gpu, const Scene& scene,
                              const RenderSettings& s) {
  StreamSettings out = stream_settings(scene, s, 0);
  out.memory_budget = std::max<size_t>(1, std::min<size_t>(after_scene(device, gpu) / 2, size_t(1) << 30));
  return out;
}

constexpr size_t kBytesPerPixel = sizeof(cl_float4) + sizeof(cl_uint);  // film and sphere-test count

// Pixels per gather launch: the whole image when its film fits the device's
// largest allocation, kMaxTile and its share of the budget.
size_t gather_tile(const Device& device, const RenderSettings& s, size_t share) {
  const size_t tile =
      std::min<size_t>({size_t(s.width) * s.height, device.info().max_alloc / sizeof(cl_float4), kMaxTile});
  return std::min(tile, std::max<size_t>(1, share / kBytesPerPixel));
}

// The maps' records in `parts` contiguous ranges of each map, the k-th.
template <class Record>
std::vector<Record> part_of(const std::vector<Record>& records, size_t k, size_t parts) {
  return std::vector<Record>(records.begin() + records.size() * k / parts,
                             records.begin() + records.size() * (k + 1) / parts);
}

}  // namespace

PassRenderer::PassRenderer(Device& device, const Scene& scene, const SceneTables& tables,
                           const RenderSettings& settings)
    : device_(device),
      scene_(scene),
      settings_(settings),
      gpu_(device, tables),
      tracer_(device, gpu_, batch_settings(device, gpu_, scene, settings)),
      gather_(device.kernel("spm_gather", "spm_gather")),
      tile_(gather_tile(device, settings, (after_scene(device, gpu_) - std::min(after_scene(device, gpu_),
                                                                                 tracer_.bytes())) / 4)),
      film_(device.buffer(sizeof(cl_float4) * tile_, "the film", CL_MEM_WRITE_ONLY)),
      tests_(device.buffer(sizeof(cl_uint) * tile_, "the gather counters", CL_MEM_WRITE_ONLY)),
      errors_(device.buffer(sizeof(cl_uint), "the gather error word")),
      kernel_type_(code_of(scene.integrator.kernel, {"uniform", "epanechnikov"})),
      estimator_(code_of(scene.integrator.estimator, {"bre", "paper"})),
      direct_(code_of(scene.integrator.direct, {"nee", "photons"})) {
  const size_t used = tracer_.bytes() + tile_ * kBytesPerPixel + sizeof(cl_uint);
  maps_budget_ = after_scene(device, gpu_) > used ? after_scene(device, gpu_) - used : 0;
}

PassOutput PassRenderer::render(int pass, Profiler* profiler, int track) {
  const IntegratorSettings& in = scene_.integrator;
  const RenderSettings& s = settings_;
  const size_t pixels = size_t(s.width) * s.height;
  PassOutput out;
  const auto stage = [&](const char* name, double start) {
    if (profiler) profiler->stage(name, start, profiler->now(), track);
  };
  const auto clock = [&] { return profiler ? profiler->now() : 0.0; };
  Timer timer;

  // Progressive radius (METHOD.md 6), the stream width shrinking with it.
  const float radius = pass_radius(in.radius, in.alpha, pass);
  double t = clock();
  const PhotonMaps maps = tracer_.trace(static_cast<uint32_t>(pass), in.width * radius / in.radius);
  out.propagate_seconds = timer.lap();
  stage("propagate", t);
  if (pass == 0 && !s.dump_maps.empty()) write_maps_ply(s.dump_maps, maps);
  timer.lap();

  // The estimates are sums over records, so maps whose grids do not fit the
  // device memory left are gathered in parts, each part's grids built,
  // uploaded and gathered along the same camera paths (same random
  // numbers), the parts' films summed; emission and next-event estimation
  // come with the first part only.
  out.rgb.assign(pixels * 3, 0.0f);
  const cl_uint no_error = 0;
  device_.queue().enqueueWriteBuffer(errors_, CL_FALSE, 0, sizeof no_error, &no_error);
  const bool skip_direct = direct_ == kDirectNee;
  const cl_uint max_depth = in.max_depth < 0 ? SPM_NONE : cl_uint(in.max_depth);
  const size_t records = maps.volume.size() + maps.surface.size();
  size_t parts = 1;
  for (size_t k = 0; k < parts;) {
    t = clock();
    MapGridData data = map_grid_data(part_of(maps.volume, k, parts), part_of(maps.surface, k, parts), radius,
                                     skip_direct);
    const size_t free = maps_budget_;
    if (data.bytes() > free) {
      if (parts == 1 && free > 0) {
        // The whole maps' size says about how many parts they need; a part
        // that still does not fit halves them all again below.
        parts = std::max<size_t>(2, size_t(1.25 * double(data.bytes()) / double(free)) + 1);
        continue;
      }
      if (parts >= std::max<size_t>(1, records)) {
        throw RuntimeError("gather, pass " + std::to_string(pass) + ": the photon maps' grids need " +
                           std::to_string(data.bytes()) + " bytes even in " + std::to_string(parts) +
                           " parts; " + std::to_string(maps_budget_) +
                           " bytes of the device memory budget are left for them (--device-memory)");
      }
      parts *= 2;  // start again with smaller parts
      k = 0;
      out.rgb.assign(pixels * 3, 0.0f);
      out.counters.sphere_tests = 0;
      continue;
    }
    const MapGrids grids(device_, data);
    data = MapGridData{};
    out.grid_seconds += timer.lap();
    stage("grid", t);
    t = clock();
    for (size_t first = 0; first < pixels; first += tile_) {
      const size_t count = std::min(tile_, pixels - first);
      set_args(gather_, gpu_, gpu_.camera(), film_, tests_, errors_, cl_uint(first), cl_uint(count), cl_uint(s.spp),
               max_depth, cl_uint(k == 0), cl_uint(s.seed), cl_uint(pass), radius, kernel_type_, estimator_, direct_,
               grids);
      device_.launch("gather", gather_, count);
      const auto film = device_.download<cl_float4>(film_, count);
      for (size_t i = 0; i < count; ++i) {
        for (int c = 0; c < 3; ++c) out.rgb[3 * (first + i) + c] += film[i].s[c];
      }
      for (cl_uint n : device_.download<cl_uint>(tests_, count)) out.counters.sphere_tests += n;
    }
    out.gather_seconds += timer.lap();
    stage("gather", t);
    ++k;
  }
  out.counters.map_parts = parts;
  if (device_.download<cl_uint>(errors_, 1)[0] & SPM_ERROR_NONFINITE) {
    throw RuntimeError("gather, pass " + std::to_string(pass) + ": a pixel's radiance is NaN or infinite");
  }

  out.counters.live = maps.stats.live;
  out.counters.stream_counters = maps.stats.counters;
  out.counters.volume_records = maps.volume.size();
  out.counters.surface_records = maps.surface.size();
  out.counters.camera_samples = uint64_t(pixels) * s.spp;
  return out;
}

}  // namespace spm
