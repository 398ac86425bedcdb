#include "render/render.h"

#include <chrono>
#include <cmath>

#include "scene/gpu_scene.h"
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

Image render(const Scene& scene, const RenderSettings& settings, Device& device, RenderStats* stats,
             const Progress& progress) {
  const RenderSettings s = resolve_settings(scene, settings);
  const SceneTables tables = flatten_scene(scene, s.width, s.height);
  GpuScene gpu(device, tables);
  const size_t pixels = static_cast<size_t>(s.width) * s.height;
  cl::Buffer film(device.context(), CL_MEM_WRITE_ONLY, sizeof(cl_float4) * pixels);
  cl::Kernel gather = device.kernel("spm_gather", "spm_gather");

  // Passes are summed in pass order in double precision, so the image does not
  // depend on which device rendered which pass (METHOD.md 6).
  std::vector<double> sum(pixels * 3, 0.0);
  const auto start = std::chrono::steady_clock::now();
  for (int pass = 0; pass < s.passes; ++pass) {
    const PhotonMaps maps = trace_streams(device, gpu, stream_settings(scene, s, pass));
    if (pass == 0 && !s.dump_maps.empty()) write_maps_ply(s.dump_maps, maps);
    set_args(gather, gpu, gpu.camera(), film, cl_uint(s.spp), cl_uint(s.max_depth), cl_uint(s.seed),
             cl_uint(pass));
    device.launch("gather", gather, pixels);
    const auto pass_film = device.download<cl_float4>(film, pixels);
    for (size_t i = 0; i < pixels; ++i) {
      for (int c = 0; c < 3; ++c) sum[3 * i + c] += pass_film[i].s[c];
    }
    if (progress) progress(pass + 1, s.passes);
  }
  Image image;
  image.width = s.width;
  image.height = s.height;
  image.rgb.resize(pixels * 3);
  for (size_t i = 0; i < sum.size(); ++i) image.rgb[i] = static_cast<float>(sum[i] / s.passes);
  if (stats) {
    stats->passes = s.passes;
    stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    stats->bvh_seconds = tables.bvh_seconds;
    stats->build_seconds = device.build_seconds();
  }
  return image;
}

}  // namespace spm
