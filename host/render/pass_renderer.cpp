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

// Pixels per gather launch: the whole image when its film fits the device's
// largest allocation, kMaxTile and the memory budget (--device-memory).
size_t gather_tile(const Device& device, const RenderSettings& s) {
  const size_t per_pixel = sizeof(cl_float4) + sizeof(cl_uint);
  size_t tile = std::min<size_t>({size_t(s.width) * s.height, device.info().max_alloc / sizeof(cl_float4), kMaxTile});
  if (s.memory_budget) tile = std::min(tile, std::max<size_t>(1, s.memory_budget / per_pixel));
  return tile;
}

}  // namespace

PassRenderer::PassRenderer(Device& device, const Scene& scene, const SceneTables& tables,
                           const RenderSettings& settings)
    : device_(device),
      scene_(scene),
      settings_(settings),
      gpu_(device, tables),
      tracer_(device, gpu_, stream_settings(scene, settings, 0)),
      gather_(device.kernel("spm_gather", "spm_gather")),
      tile_(gather_tile(device, settings)),
      film_(device.buffer(sizeof(cl_float4) * tile_, "the film", CL_MEM_WRITE_ONLY)),
      tests_(device.buffer(sizeof(cl_uint) * tile_, "the gather counters", CL_MEM_WRITE_ONLY)),
      errors_(device.buffer(sizeof(cl_uint), "the gather error word")),
      kernel_type_(code_of(scene.integrator.kernel, {"uniform", "epanechnikov"})),
      estimator_(code_of(scene.integrator.estimator, {"bre", "paper"})),
      direct_(code_of(scene.integrator.direct, {"nee", "photons"})) {}

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

  t = clock();
  const MapGrids grids(device_, maps, radius, direct_ == kDirectNee);
  out.grid_seconds = timer.lap();
  stage("grid", t);

  t = clock();
  out.rgb.resize(pixels * 3);
  const cl_uint no_error = 0;
  device_.queue().enqueueWriteBuffer(errors_, CL_FALSE, 0, sizeof no_error, &no_error);
  for (size_t first = 0; first < pixels; first += tile_) {
    const size_t count = std::min(tile_, pixels - first);
    set_args(gather_, gpu_, gpu_.camera(), film_, tests_, errors_, cl_uint(first), cl_uint(count), cl_uint(s.spp),
             cl_uint(s.max_depth), cl_uint(s.seed), cl_uint(pass), radius, kernel_type_, estimator_, direct_, grids);
    device_.launch("gather", gather_, count);
    const auto film = device_.download<cl_float4>(film_, count);
    for (size_t i = 0; i < count; ++i) {
      for (int c = 0; c < 3; ++c) out.rgb[3 * (first + i) + c] = film[i].s[c];
    }
    for (cl_uint n : device_.download<cl_uint>(tests_, count)) out.counters.sphere_tests += n;
  }
  if (device_.download<cl_uint>(errors_, 1)[0] & SPM_ERROR_NONFINITE) {
    throw RuntimeError("gather, pass " + std::to_string(pass) + ": a pixel's radiance is NaN or infinite");
  }
  out.gather_seconds = timer.lap();
  stage("gather", t);

  out.counters.live = maps.stats.live;
  out.counters.stream_counters = maps.stats.counters;
  out.counters.volume_records = maps.volume.size();
  out.counters.surface_records = maps.surface.size();
  out.counters.camera_samples = uint64_t(pixels) * s.spp;
  return out;
}

}  // namespace spm
