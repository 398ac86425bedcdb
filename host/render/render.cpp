#include "render/render.h"

#include <chrono>
#include <cmath>
#include <exception>
#include <mutex>
#include <thread>

#include "render/pass_renderer.h"
#include "scene/gpu_scene.h"
#include "util/errors.h"
#include "util/timer.h"

namespace spm {

RenderSettings resolve_settings(const Scene& scene, RenderSettings s) {
  if (s.width == 0) s.width = scene.camera.width;
  if (s.height == 0) s.height = scene.camera.height;
  if (s.spp == 0) s.spp = scene.camera.spp;
  // A render for a time budget (integrator `time`, no pass count) keeps
  // passes = 0: it renders passes until the budget is spent.
  if (s.passes == 0 && !(scene.integrator.time > 0.0f)) s.passes = scene.integrator.passes;
  if (s.max_depth == 0) s.max_depth = scene.integrator.max_depth;
  if (s.width < 1 || s.height < 1 || s.width > 16384 || s.height > 16384) {
    throw InputError("--res", "resolution " + std::to_string(s.width) + "x" + std::to_string(s.height) +
                                  " is outside 1x1 .. 16384x16384");
  }
  if (s.spp < 1 || s.spp > 1 << 20) throw InputError("--spp", "samples per pixel must be in 1 .. 1048576");
  if (s.passes < 0) throw InputError("--passes", "the number of passes must be at least 1");
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

Image render(const Scene& scene, const RenderSettings& settings, Device& device, RenderStats* stats,
             const Progress& progress) {
  return render(scene, settings, std::vector<Device*>{&device}, stats, progress, nullptr);
}

OrderedSum::OrderedSum(size_t values) : sum_(values, 0.0) {}

void OrderedSum::add(int pass, std::vector<float> rgb) {
  waiting_.emplace(pass, std::move(rgb));
  for (auto it = waiting_.find(summed_); it != waiting_.end(); it = waiting_.find(summed_)) {
    for (size_t i = 0; i < sum_.size(); ++i) sum_[i] += it->second[i];
    waiting_.erase(it);
    ++summed_;
  }
}

Image OrderedSum::average(int width, int height) const {
  if (summed_ == 0) throw RuntimeError("the render stopped before its first pass finished");
  Image image;
  image.width = width;
  image.height = height;
  image.rgb.resize(sum_.size());
  for (size_t i = 0; i < sum_.size(); ++i) image.rgb[i] = static_cast<float>(sum_[i] / summed_);
  return image;
}

RenderStats render_passes(const Scene& scene, const RenderSettings& settings, const std::vector<Device*>& devices,
                          PassSlice slice, const PassSink& sink, Profiler* profiler) {
  const RenderSettings s = resolve_settings(scene, settings);
  const IntegratorSettings& in = scene.integrator;
  const SceneTables tables = flatten_scene(scene, s.width, s.height);
  const bool timed = s.passes == 0;
  Timer clock;
  double elapsed = 0.0;  // guarded by `mutex`, like everything the workers share

  std::mutex mutex;
  std::atomic<int> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  RenderStats st;
  st.devices.resize(devices.size());
  const auto stopping = [&] { return failed.load() || (s.stop && s.stop->load()); };

  const auto work = [&](size_t d) {
    try {
      Device& device = *devices[d];
      st.devices[d].name = device.info().name;
      if (profiler) profiler->add_device(int(d), device.info().name);
      PassRenderer renderer(device, scene, tables, s);
      for (;;) {
        if (stopping()) break;
        // This process's k-th pass is slice.offset + k slice.stride.
        const int k = next++;
        const int pass = slice.offset + k * slice.stride;
        if (timed) {
          std::lock_guard<std::mutex> lock(mutex);
          elapsed += clock.lap();
          if (k > 0 && elapsed >= in.time) break;
        } else if (pass >= s.passes) {
          break;
        }
        Timer busy;
        PassOutput out = renderer.render(pass, profiler, int(d) + 1);
        if (profiler) {
          profiler->add_launches(int(d), device.take_launches());
          profiler->add_pass(int(d), pass, out.counters);
        } else {
          device.take_launches();
        }
        std::lock_guard<std::mutex> lock(mutex);
        st.devices[d].passes += 1;
        st.devices[d].busy_seconds += busy.lap();
        st.propagate_seconds += out.propagate_seconds;
        st.grid_seconds += out.grid_seconds;
        st.gather_seconds += out.gather_seconds;
        st.camera_samples += out.counters.camera_samples;
        st.sphere_tests += out.counters.sphere_tests;
        ++st.passes;
        sink(pass, std::move(out.rgb));
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex);
      if (!error) error = std::current_exception();
      failed = true;
    }
  };
  std::vector<std::thread> threads;
  for (size_t d = 1; d < devices.size(); ++d) threads.emplace_back(work, d);
  work(0);
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  st.interrupted = s.stop && s.stop->load();
  st.seconds = elapsed + clock.lap();
  st.bvh_seconds = tables.bvh_seconds;
  for (Device* d : devices) st.build_seconds += d->build_seconds();
  return st;
}

void add_build_values(Profiler& profiler, const RenderStats& stats, const std::vector<Device*>& devices) {
  profiler.add_value("bvh_build_s", stats.bvh_seconds);
  for (size_t d = 0; d < devices.size(); ++d) {
    for (const auto& [program, build] : devices[d]->program_builds()) {
      profiler.add_value(std::string(build.from_binary ? "program_binary_s." : "program_build_s.") +
                             std::to_string(d) + "." + program,
                         build.seconds);
    }
  }
}

Image render(const Scene& scene, const RenderSettings& settings, const std::vector<Device*>& devices,
             RenderStats* stats, const Progress& progress, Profiler* profiler) {
  const RenderSettings s = resolve_settings(scene, settings);
  const bool timed = s.passes == 0;
  OrderedSum sum(size_t(s.width) * s.height * 3);
  const RenderStats st = render_passes(
      scene, settings, devices, PassSlice{}, [&](int pass, std::vector<float>&& rgb) {
        sum.add(pass, std::move(rgb));
        if (progress) progress(sum.summed(), timed ? 0 : s.passes);
      },
      profiler);
  if (stats) {
    *stats = st;
    // With a time budget, only the passes before the first unfinished one count.
    stats->passes = sum.summed();
  }
  return sum.average(s.width, s.height);
}

}  // namespace spm
