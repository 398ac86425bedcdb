#include "render/render.h"

#include <chrono>
#include <cmath>

#include "scene/gpu_scene.h"
#include "spm/gather.h"
#include "spm/maps_io.h"
#include "spm/streams.h"
#include "util/errors.h"

namespace spm {

RenderSettings resolve_settings(const Scene& scene, RenderSettings s) {
  if (s.width == 0) s.width = scene.camera.width;
  if (s.height == 0) s.height = scene.camera.height;
  if (s.spp == 0) s.spp = scene.camera.spp;
  if (s.passes == 0) s.passes = scene.integrator.passes;
  if (s.max_depth == 0) s.max_depth = scene.integrator.max_depth;
  if (s.width < 1 || s.height < 1 || s.width > 16384 || s.height > 16384) {
    throw InputError("--res", "resolution " + std::to_string(s.width) + "x" + std::to_string(s.height) +
                                  " is outside 1x1 .. 16384x16384");
  }
  if (s.spp < 1 || s.spp > 1 << 20) throw InputError("--spp", "samples per pixel must be in 1 .. 1048576");
  if (s.passes < 1) throw InputError("--passes", "the number of passes must be at least 1");
  if (s.max_depth < 1 || s.max_depth > kMaxDepthLimit) {
    throw InputError(scene.integrator.where, "max_depth must be in 1 .. " + std::to_string(kMaxDepthLimit));
  }
  const IntegratorSettings& in = scene.integrator;
  const auto check = [&](bool ok, const std::string& what) {
    if (!ok) throw InputError(in.where.empty() ? scene.path : in.where, what);
  };
  check(in.streams >= 1, "streams must be at least 1 (--streams)");
  check(in.associated >= 1 && in.associated <= 65535, "associated must be in 1 .. 65535 (--associated)");
  check(in.width > 0.0f && std::isfinite(in.width), "the stream width must be positive (--width)");
  check(in.radius > 0.0f && std::isfinite(in.radius), "the search radius must be positive (--radius)");
  check(in.max_bounces >= 1, "max_bounces must be at least 1 (--bounces)");
  check(in.march_step >= 0.0f && std::isfinite(in.march_step), "march_step must not be negative (--march-step)");
  check(in.alpha > 0.0f && in.alpha < 1.0f, "alpha must be in (0, 1) (--alpha)");
  check(in.time >= 0.0f && std::isfinite(in.time), "the time budget must not be negative (--time)");
  return s;
}

StreamSettings stream_settings(const Scene& scene, const RenderSettings& s, int pass) {
  const IntegratorSettings& in = scene.integrator;
  StreamSettings out;
  out.streams = static_cast<uint32_t>(in.streams);
  out.associated = static_cast<uint32_t>(in.associated);
  out.width = in.width;
  out.max_bounces = static_cast<uint32_t>(in.max_bounces);
  out.march_step = in.march_step;
  out.seed = s.seed;
  out.pass = static_cast<uint32_t>(pass);
  out.memory_budget = s.memory_budget;
  return out;
}

float pass_radius(float r0, float alpha, int pass) {
  // r_{k+1}^2 = r_k^2 (k + alpha) / (k + 1) for passes k = 1, 2, ... (Knaus &
  // Zwicker 2011); `pass` counts from 0.
  double r2 = double(r0) * r0;
  for (int k = 1; k <= pass; ++k) r2 *= (k + double(alpha)) / (k + 1);
  return static_cast<float>(std::sqrt(r2));
}

namespace {

cl_uint code_of(const std::string& value, std::initializer_list<const char*> names) {
  cl_uint i = 0;
  for (const char* n : names) {
    if (value == n) return i;
    ++i;
  }
  throw InputError("", "unknown value '" + value + "'");
}

}  // namespace

Image render(const Scene& scene, const RenderSettings& settings, Device& device, RenderStats* stats,
             const Progress& progress) {
  const RenderSettings s = resolve_settings(scene, settings);
  const IntegratorSettings& in = scene.integrator;
  const SceneTables tables = flatten_scene(scene, s.width, s.height);
  GpuScene gpu(device, tables);
  const size_t pixels = static_cast<size_t>(s.width) * s.height;
  cl::Buffer film(device.context(), CL_MEM_WRITE_ONLY, sizeof(cl_float4) * pixels);
  cl::Buffer tests(device.context(), CL_MEM_WRITE_ONLY, sizeof(cl_uint) * pixels);
  cl::Kernel gather = device.kernel("spm_gather", "spm_gather");
  // The codes follow SPM_KERNEL_*, SPM_ESTIMATOR_* (kernels/lib/estimate.h)
  // and SPM_DIRECT_* (kernels/spm_gather.cl).
  const cl_uint kernel = code_of(in.kernel, {"uniform", "epanechnikov"});
  const cl_uint estimator = code_of(in.estimator, {"bre", "paper"});
  const cl_uint direct = code_of(in.direct, {"nee", "photons"});  // nee: 0

  // Passes are summed in pass order in double precision, so the image does not
  // depend on which device rendered which pass (METHOD.md 6).
  std::vector<double> sum(pixels * 3, 0.0);
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  const bool timed = in.time > 0.0f && settings.passes == 0;
  RenderStats st;
  int pass = 0;
  for (; timed ? (pass == 0 || elapsed() < in.time) : pass < s.passes; ++pass) {
    // Progressive radius (METHOD.md 6), the stream width shrinking with it.
    const float radius = pass_radius(in.radius, in.alpha, pass);
    StreamSettings ss = stream_settings(scene, s, pass);
    ss.width = in.width * radius / in.radius;
    auto t0 = std::chrono::steady_clock::now();
    const PhotonMaps maps = trace_streams(device, gpu, ss);
    auto t1 = std::chrono::steady_clock::now();
    st.propagate_seconds += std::chrono::duration<double>(t1 - t0).count();
    if (pass == 0 && !s.dump_maps.empty()) write_maps_ply(s.dump_maps, maps);
    const MapGrids grids(device, maps, radius, direct == 0);
    st.grid_seconds += grids.build_seconds();
    t0 = std::chrono::steady_clock::now();
    set_args(gather, gpu, gpu.camera(), film, tests, cl_uint(s.spp), cl_uint(s.max_depth), cl_uint(s.seed),
             cl_uint(pass), radius, kernel, estimator, direct, grids);
    device.launch("gather", gather, pixels);
    const auto pass_film = device.download<cl_float4>(film, pixels);
    for (cl_uint t : device.download<cl_uint>(tests, pixels)) st.sphere_tests += t;
    st.gather_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    st.camera_samples += pixels * s.spp;
    for (size_t i = 0; i < pixels; ++i) {
      for (int c = 0; c < 3; ++c) sum[3 * i + c] += pass_film[i].s[c];
    }
    if (progress) progress(pass + 1, timed ? 0 : s.passes);
  }
  Image image;
  image.width = s.width;
  image.height = s.height;
  image.rgb.resize(pixels * 3);
  for (size_t i = 0; i < sum.size(); ++i) image.rgb[i] = static_cast<float>(sum[i] / pass);
  if (stats) {
    st.passes = pass;
    st.seconds = elapsed();
    st.bvh_seconds = tables.bvh_seconds;
    st.build_seconds = device.build_seconds();
    *stats = st;
  }
  return image;
}

}  // namespace spm
