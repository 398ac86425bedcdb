#include "render/render.h"

#include <chrono>
#include <cmath>
#include <exception>
#include <mutex>
#include <thread>

#include "render/defaults.h"
#include "render/pass_renderer.h"
#include "scene/integrator_options.h"
#include "scene/settings.h"
#include "scene/gpu_scene.h"
#include "util/errors.h"
#include "util/timer.h"

namespace spm {

RenderSettings resolve_settings(const Scene& scene, RenderSettings s) {
  if (s.width == 0) s.width = scene.camera.width;
  if (s.height == 0) s.height = scene.camera.height;
  if (s.width < 1 || s.height < 1 || s.width > 16384 || s.height > 16384) {
    throw InputError("--res", "resolution " + std::to_string(s.width) + "x" + std::to_string(s.height) +
                                  " is outside 1x1 .. 16384x16384");
  }
  const IntegratorSettings& in = scene.integrator;
  check_settings(in, scene.path);
  if (s.spp < 0 || s.spp > 1 << 20) throw InputError("--spp", "samples per pixel must be in 1 .. 1048576");
  if (s.passes < 0) throw InputError("--passes", "the number of passes must be at least 1");
  if (s.spp == 0) s.spp = in.spp;
  if (s.seed == 0) s.seed = uint32_t(in.seed);
  // A pass count on the command line wins over a time budget; the scene's
  // own yields to it (below).
  if (s.passes == 0 && in.source("passes") == SettingSource::CommandLine) s.passes = in.passes;
  if (s.spp == 0) {
    s.spp = samples_per_pass(scene, s.width, s.height);
    s.spp_derived = true;
  }
  // A render for a time budget (integrator `time`, no pass count) or a
  // target error keeps passes = 0: it renders passes until the budget is
  // spent or the estimated error is below the target, whichever comes
  // first. Without a pass count or a budget, the sampler's sample_count is
  // the render's total samples per pixel (SCENES.md), spread over passes of
  // at most spp each.
  if (s.passes == 0 && !(in.time > 0.0f) && !(in.target_error > 0.0f)) {
    if (in.passes > 0) {
      s.passes = in.passes;
    } else {
      const int total = scene.camera.spp;
      s.spp = std::min(s.spp, total);
      s.passes = (total + s.spp - 1) / s.spp;
      s.spp = (total + s.passes - 1) / s.passes;
    }
  }
  return s;
}

StreamSettings stream_settings(const Scene& scene, const RenderSettings& s, int pass) {
  const IntegratorSettings& in = scene.integrator;
  const auto limit = [](int v) { return v < 0 ? SPM_NONE : static_cast<uint32_t>(v); };
  StreamSettings out;
  out.streams = static_cast<uint32_t>(derived_streams(in));
  out.associated = static_cast<uint32_t>(derived_associated(in));
  out.stream_width = in.stream_width;
  out.max_bounces = limit(in.max_bounces);
  out.max_depth = limit(in.max_depth);
  out.rr_depth = static_cast<uint32_t>(in.rr_depth);
  out.march_step = in.march_step;
  out.beams = kEstimatorOption.code(in.estimator) == SPM_ESTIMATOR_BEAMS;
  out.beam_streams = static_cast<uint32_t>(derived_beam_streams(in));
  out.seed = s.seed;
  out.pass = static_cast<uint32_t>(pass);
  return out;
}

float pass_radius(float r0, float alpha, int pass) {
  // r_{k+1}^2 = r_k^2 (k + alpha) / (k + 1) for passes k = 1, 2, ... (Knaus &
  // Zwicker 2011); `pass` counts from 0.
  double r2 = double(r0) * r0;
  for (int k = 1; k <= pass; ++k) r2 *= (k + double(alpha)) / (k + 1);
  return static_cast<float>(std::sqrt(r2));
}

float pass_beam_radius(float r0, float alpha, int pass) {
  // A 1D kernel's variance grows as 1/r, not 1/r^2, so the progressive rule
  // shrinks r itself by (k + alpha) / (k + 1) (progressive photon beams,
  // Jarosz et al. 2011, 4.3): the square of the 2D schedule, relative to r0.
  const float s = pass_radius(1.0f, alpha, pass);
  return r0 * s * s;
}

Image render(const Scene& scene, const RenderSettings& settings, Device& device, RenderStats* stats,
             const Progress& progress) {
  return render(scene, settings, std::vector<Device*>{&device}, stats, progress, nullptr);
}

OrderedSum::OrderedSum(size_t values, bool estimate) : sum_(values, 0.0) {
  if (estimate) model_.emplace(values);
}

void OrderedSum::add(int pass, PassImage image) {
  waiting_.emplace(pass, std::move(image));
  for (auto it = waiting_.find(summed_); it != waiting_.end(); it = waiting_.find(summed_)) {
    const PassImage& p = it->second;
    for (size_t i = 0; i < sum_.size(); ++i) sum_[i] += p.rgb[i];
    if (model_) model_->add(it->first, p.rgb, p.radius, p.probe);
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

int balanced_spp(double photon_seconds, double gather_seconds, int spp, double budget) {
  const double per_sample = gather_seconds / std::max(1, spp);
  if (!(per_sample > 0.0) || !(photon_seconds > 0.0)) return spp;
  double want = kGatherShare / (1.0 - kGatherShare) * photon_seconds / per_sample;
  // The pass must still fit its share of the budget.
  want = std::min(want, (kPassShareOfBudget * budget - photon_seconds) / per_sample);
  return static_cast<int>(std::clamp(std::lround(want), 1L, long(kMaxPassSpp)));
}

double first_pass_estimate(const Scene& scene, double pilot_seconds) {
  return kPassPerPilot * pilot_seconds * (1.0 + derived_associated(scene.integrator) / kPilotAssociated);
}

Scene sized_for_budget(const Scene& scene, RenderSettings& s, double pilot_seconds) {
  Scene out = scene;
  const double budget = scene.integrator.time;
  const double predicted = first_pass_estimate(scene, pilot_seconds);
  if (!(budget > 0.0) || s.passes > 0 || !(predicted > kPassShareOfBudget * budget)) return out;
  const double f = kPassShareOfBudget * budget / predicted;
  IntegratorSettings& in = out.integrator;
  const int streams = std::max(1, static_cast<int>(derived_streams(in) * f));
  // Fewer streams spread their records thinner: a derived radius grows as
  // the surface records' spacing does, with the inverse square root.
  const float grow = std::sqrt(float(derived_streams(in)) / float(streams));
  if (in.source("radius") == SettingSource::Derived) in.radius *= grow;
  if (in.source("width") == SettingSource::Derived) in.stream_width *= grow;
  in.streams = streams;
  in.sources["streams"] = SettingSource::Derived;
  s.spp = std::max(1, static_cast<int>(std::lround(s.spp * f)));
  return out;
}

RenderStats render_passes(const Scene& scene_in, const RenderSettings& settings, const std::vector<Device*>& devices,
                          PassSlice slice, const PassSink& sink, Profiler* profiler) {
  RenderSettings s = resolve_settings(scene_in, settings);
  const bool timed = s.passes == 0;
  // A render to a target error alone has no time budget.
  const double budget = scene_in.integrator.time > 0.0f ? double(scene_in.integrator.time) : INFINITY;
  for (Device* d : devices) d->set_memory_budget(s.memory_budget);
  const SceneTables tables = flatten_scene(scene_in, s.width, s.height);
  // Device 0's renderer first: the scale pilot is a pass of its own streams
  // (defaults.h). A timed render always runs it, whose propagation time
  // sizes its passes; a render with a radius needs no other.
  std::vector<std::unique_ptr<PassRenderer>> renderers(devices.size());
  renderers[0] = std::make_unique<PassRenderer>(*devices[0], scene_in, tables, s);
  ScalePilot pilot;
  if (scene_in.integrator.radius <= 0.0f || timed) {
    const double start = profiler ? profiler->now() : 0.0;
    pilot = renderers[0]->pilot();
    // The pilot is a host stage of its own; its launches stay out of the
    // passes' kernel figures.
    devices[0]->take_launches();
    if (profiler) profiler->stage("pilot", start, profiler->now(), 1);
  }
  Scene scene = sized_for_budget(derive_scale(scene_in, pilot), s, pilot.seconds);
  fill_derived(scene, s);
  if (s.announce) s.announce(scene, pilot.seconds);
  renderers[0]->set_scene(scene);

  std::mutex mutex;
  std::atomic<int> next{0};
  // A balanced render's passes differ in samples, so pass x spp would not
  // tile the pixels' scrambled sequence (stratify2): each pass claims the
  // next run of sample indices instead, one sequence per process, whose
  // ranks read sequences of their own.
  // One run per replicate (render/error_model.h).
  std::atomic<uint32_t> samples_claimed[kReplicates] = {};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  RenderStats st;
  st.devices.resize(devices.size());
  st.pilot_seconds = pilot.seconds;
  const auto stopping = [&] {
    return failed.load() || (s.stop && s.stop->load()) || (s.target_met && s.target_met->load());
  };

  const auto work = [&](size_t d) {
    try {
      Device& device = *devices[d];
      st.devices[d].name = device.info().name;
      if (profiler) profiler->add_device(int(d), device.info().name);
      if (!renderers[d]) renderers[d] = std::make_unique<PassRenderer>(device, scene, tables, s);
      PassRenderer& renderer = *renderers[d];
      // The budget counts from here: scene upload and kernel builds are
      // reported apart (RenderStats::build_seconds).
      Timer clock;
      // A pass starts only when its predicted length, the longest pass so
      // far (at first the pilot's estimate; with balanced samples, from its
      // parts, below), still fits the budget; device 0 renders one pass in
      // any case.
      double elapsed = 0.0, longest = std::min(first_pass_estimate(scene, pilot.seconds), kPassShareOfBudget * budget);
      // A timed render with derived samples per pass balances them from the
      // stage times of its passes so far (balanced_spp); their count then
      // depends on timing, as the number of passes already does.
      const bool balance = timed && s.spp_derived;
      int spp = balance ? std::min(s.spp, kFirstBalancedSpp) : s.spp;
      if (balance) renderer.set_spp(spp);
      double photon_seconds = 0.0, gather_seconds = 0.0, samples = 0.0;
      // With balancing, a pass's length is predicted from its parts: the
      // longest non-gather part and the slowest gather per sample so far,
      // times its samples; the longest pass of another sample count would
      // misjudge it.
      double longest_rest = 0.0, longest_per_sample = 0.0;
      for (int done = 0;; ++done) {
        if (stopping()) break;
        if (timed && (d > 0 || done > 0) && elapsed + longest > budget) break;
        // This process's k-th pass is slice.offset + k slice.stride.
        const int k = next++;
        const int pass = slice.offset + k * slice.stride;
        if (!timed && pass >= s.passes) break;
        if (balance) {
          renderer.set_first_sample(samples_claimed[pass % kReplicates].fetch_add(uint32_t(spp)),
                                    1u + uint32_t(slice.offset));
        }
        Timer busy;
        PassOutput out = renderer.render(pass, profiler, int(d) + 1);
        if (profiler) {
          profiler->add_launches(int(d), device.take_launches());
          profiler->add_pass(int(d), pass, out.counters);
        } else {
          device.take_launches();
        }
        const double took = busy.lap();
        elapsed += clock.lap();
        longest = std::max(longest, took);
        renderer.balance_probe(out, took);
        if (balance) {
          // From the means over this device's passes so far, steadier than
          // one pass. The first pass also pays for its kernels' first
          // launches (PoCL compiles the gather for its work-group size then:
          // cornell_fog at 64x64 with a cold cache waited 1.06 s before a
          // gather of 0.09 s), which would starve later passes of samples, so the
          // means and the longest parts start again from the second pass.
          if (done == 1) photon_seconds = gather_seconds = samples = longest_rest = longest_per_sample = 0.0;
          photon_seconds += out.propagate_seconds + out.grid_seconds;
          gather_seconds += out.gather_seconds;
          samples += spp;
          const int next_spp =
              balanced_spp(photon_seconds / std::max(1, done), gather_seconds * spp / samples, spp, budget);
          longest_rest = std::max(longest_rest, took - out.gather_seconds);
          longest_per_sample = std::max(longest_per_sample, out.gather_seconds / spp);
          longest = longest_rest + longest_per_sample * next_spp;
          spp = next_spp;
          renderer.set_spp(spp);
        }
        std::lock_guard<std::mutex> lock(mutex);
        st.devices[d].passes += 1;
        st.devices[d].busy_seconds += took;
        st.seconds = std::max(st.seconds, elapsed);
        st.propagate_seconds += out.propagate_seconds;
        st.grid_seconds += out.grid_seconds;
        st.gather_seconds += out.gather_seconds;
        st.probe_seconds += out.probe_seconds;
        st.camera_samples += out.counters.camera_samples;
        st.sphere_tests += out.counters.sphere_tests;
        ++st.passes;
        sink(pass, PassImage{std::move(out.rgb), std::move(out.probe), out.radius});
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
  OrderedSum sum(size_t(s.width) * s.height * 3, estimates_error(s));
  // A target error stops the render once the passes summed so far reach it.
  std::atomic<bool> target_met{false};
  RenderSettings run = settings;
  run.target_met = &target_met;
  const RenderStats st = render_passes(
      scene, run, devices, PassSlice{}, [&](int pass, PassImage&& image) {
        const int before = sum.summed();
        sum.add(pass, std::move(image));
        if (sum.summed() == before) return;
        const ErrorEstimate e = sum.estimate();
        if (profiler) profiler->add_estimate(e, profiler->now());
        const float target = scene.integrator.target_error;
        if (target > 0.0f && e.relmse >= 0.0 && e.relmse < target) target_met = true;
        if (progress) progress(sum.summed(), timed ? 0 : s.passes, e);
      },
      profiler);
  if (stats) {
    *stats = st;
    // With a time budget, only the passes before the first unfinished one count.
    stats->passes = sum.summed();
    stats->error = sum.estimate();
  }
  return sum.average(s.width, s.height);
}

}  // namespace spm
